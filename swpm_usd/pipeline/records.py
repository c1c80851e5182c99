"""The shape of a run manifest's asset record, checked before a run relies on one.

A record is written by the run (:func:`.worker.process_asset`, completed by the runner), but the manifest is a
JSON file a person can edit. A record of a current asset that is not what the run writes (not an object, a
key missing, a value of another type) would raise in the planning, the scene or the report; the runner treats
it as absent instead (the asset is built again) and names it in a warning (:func:`record_problem`). Its
``inputs`` (each input file's size and stat as hashed) only spare a rerun reading them: malformed, they are
not trusted and the inputs hashed, the record kept (:func:`recorded_inputs`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from .assets import _MAXIMA, _MINIMA, OUTPUT_NAMES
from .file_hash import STAT_KEYS


def _what(value: Any) -> str:
    """A JSON value's kind, as a message names it."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def _number(value: Any) -> bool:
    return type(value) is int or type(value) is float  # (a JSON value: a boolean is not a number)


def _count(value: Any) -> bool:
    return type(value) is int and value >= 0


def _file_name(value: Any) -> bool:
    """A file name in output.dir: no folder, no NUL byte, not ``.`` or ``..``."""
    return isinstance(value, str) and value not in ("", ".", "..") and not any(c in value for c in "/\\\0")


#: key -> (check, what it must be); a record's keys the run, the scene or the report read
_RECORD: dict[str, tuple[Callable[[Any], bool], str]] = {
    "status": (lambda v: isinstance(v, str), "a string"),
    "digest": (lambda v: isinstance(v, str), "a string"),
    "build_version": (lambda v: isinstance(v, str), "a string"),
    "input_digest": (lambda v: isinstance(v, str), "a string"),
    "encoding": (lambda v: isinstance(v, str), "a string"),
    "error": (lambda v: isinstance(v, str), "a string"),
    "code": (lambda v: isinstance(v, str), "a string"),
    "why": (lambda v: isinstance(v, str), "a string"),
    "triangles_in": (_count, "a whole number"),
    "triangles_read": (_count, "a whole number"),
    "instances": (_count, "a whole number"),
    "seconds": (_number, "a number"),
    "outputs": (lambda v: isinstance(v, dict), "an object"),
    "checks": (lambda v: isinstance(v, dict), "an object"),
    "summary": (lambda v: isinstance(v, dict), "an object"),
    "last_failure": (lambda v: isinstance(v, dict), "an object"),
    "auto_candidates": (lambda v: isinstance(v, dict), "an object"),
    "warnings": (lambda v: isinstance(v, list) and all(isinstance(w, str) for w in v), "a list of strings"),
    "output_names": (lambda v: v in OUTPUT_NAMES, '"stem" or "path"'),
}
#: the keys of a built asset's record (a failed one has its status alone for sure)
_BUILT = ("status", "digest", "input_digest", "encoding", "outputs", "summary")
_OUTPUT: dict[str, tuple[Callable[[Any], bool], str]] = {
    "path": (_file_name, "a file name in output.dir"),
    "sha256": (lambda v: isinstance(v, str), "a string"),
    "size": (_count, "a whole number"),
}
#: the units of a USD layer's record (:func:`.worker.layer_units`; a record of an earlier version has none)
_UNITS: dict[str, tuple[Callable[[Any], bool], str]] = {
    "up_axis": (lambda v: v in ("Y", "Z"), '"Y" or "Z"'),
    "meters_per_unit": (lambda v: _number(v) and math.isfinite(v) and v > 0, "a number above 0"),
}
#: the layout of a .swpm's record (:func:`.worker.swpm_layout`; a record of an earlier version has none)
_LAYOUT: dict[str, tuple[Callable[[Any], bool], str]] = {
    "legacy_layout": (lambda v: isinstance(v, bool), "a boolean"),
    "index_width": (lambda v: type(v) is int and v in (2, 4), "2 or 4"),
    "offset_width": (lambda v: type(v) is int and v in (2, 4), "2 or 4"),
}
#: the figures of a record's summary that the report shows (``curve``: one object of these per point)
_SUMMARY_FIGURES = ("lambda", "acmr", "global_bytes", "instance_bytes")
_CURVE_FIGURES = ("lod", "triangles", "error", "acmr")
_CANDIDATE_FIGURES = ("acmr", "misses_at_error_score", "lod_change_cost")
#: the numeric limits of a record's ``checks``, by section (see :func:`.assets.checks_no_stricter`)
_LIMITS = {
    section: tuple(sorted(key for s, key in (*_MAXIMA, *_MINIMA) if s == section))
    for section in ("budgets", "streaming")
}


def _fields(obj: dict, spec: dict, where: str, required: tuple[str, ...] = ()) -> str | None:
    """The first of ``required`` that ``obj`` lacks, or of its keys in ``spec`` whose value fails its check,
    as a message (``where``: the path of ``obj`` in the record, "" for the record itself)."""
    for key in required:
        if key not in obj:
            return f"{where or 'the record'} has no {key!r}"
    for key, (ok, expected) in spec.items():
        if key in obj and not ok(obj[key]):
            value = obj[key]
            shown = repr(value) if isinstance(value, str) else _what(value)  # (a file name, an up axis)
            return f"{where}{'.' * bool(where)}{key} is {shown}, not {expected}"
    return None


def _figures(obj: dict, keys: tuple[str, ...], where: str, required: bool = False) -> str | None:
    """:func:`_fields` for figures (numbers), the usual case (all of them numbers) without a message made."""
    for key in keys:
        value = obj.get(key)
        if type(value) is not int and type(value) is not float and (required or key in obj):
            if key not in obj:
                return f"{where} has no {key!r}"
            return f"{where}.{key} is {_what(value)}, not a number"
    return None


#: the keys of an input's entry in a record's ``inputs`` beside its ``path`` (:func:`.assets.hash_inputs`)
INPUT_STAT_KEYS = ("size", *STAT_KEYS, "hashed_ns")


def recorded_inputs(rec: dict) -> list[dict[str, Any]] | None:
    """A record's ``inputs`` (each input file's path, and its size and stat as it was hashed) when the run
    could have written them, else None: a list of objects, each with a string ``path`` and whole numbers
    for those of :data:`INPUT_STAT_KEYS` it has (an entry with its path alone, a file that changed while it
    was read, is one). Unlike the keys :func:`record_problem` checks, a malformed ``inputs`` (a hand edit)
    does not make the record one the run ignores: the stats only spare reading the inputs, so the run
    hashes them instead (as it does an output whose stat fields are not as recorded) and records them
    anew."""
    entries = rec.get("inputs")
    if not isinstance(entries, list):
        return None
    for entry in entries:
        if not isinstance(entry, dict) or not isinstance(entry.get("path"), str):
            return None
        if any(k in entry and type(entry[k]) is not int for k in INPUT_STAT_KEYS):
            return None
    return entries


def record_problem(rec: Any) -> str | None:
    """What makes ``rec``, a manifest's record of an asset, other than a record the run writes, or None: its
    type, a key a built asset's record has that it lacks, or a value of another type (among those the
    runner, the scene and the report read), as a message names it (``outputs.swpm.size is a string, not a
    whole number``)."""
    if not isinstance(rec, dict):
        return f"the record is {_what(rec)}, not an object"
    problem = _fields(rec, _RECORD, "", _BUILT if rec.get("status") == "built" else ("status",))
    if problem:
        return problem
    for kind, out in rec.get("outputs", {}).items():
        if not isinstance(out, dict):
            return f"outputs.{kind} is {_what(out)}, not an object"
        problem = _fields(out, _OUTPUT, f"outputs.{kind}", tuple(_OUTPUT))
        if problem:
            return problem
        if kind == "usd":
            problem = _fields(out, _UNITS, f"outputs.{kind}")
            if problem:
                return problem
        if kind == "swpm":
            problem = _fields(out, _LAYOUT, f"outputs.{kind}")
            if problem:
                return problem
    checks = rec.get("checks", {})
    for section in ("budgets", "streaming"):
        limits = checks.get(section)
        if limits is None:
            continue
        if not isinstance(limits, dict):
            return f"checks.{section} is {_what(limits)}, not an object"
        problem = _figures(limits, _LIMITS[section], f"checks.{section}")
        if problem:
            return problem
    if "summary" in rec:
        summary = rec["summary"]
        problem = _figures(summary, _SUMMARY_FIGURES, "summary", required=rec["status"] == "built")
        if problem:
            return problem
        curve = summary.get("curve", [])
        if not isinstance(curve, list):
            return f"summary.curve is {_what(curve)}, not a list"
        for i, point in enumerate(curve):  # (the longest part: a loop of its own, a message only when due)
            if type(point) is not dict:
                return f"summary.curve[{i}] is {_what(point)}, not an object"
            for key in _CURVE_FIGURES:
                value = point.get(key)
                if type(value) is not int and type(value) is not float:
                    return _figures(point, _CURVE_FIGURES, f"summary.curve[{i}]", required=True)
    failure = rec.get("last_failure", {})
    if "error" in failure and not isinstance(failure["error"], str):
        return f"last_failure.error is {_what(failure['error'])}, not a string"
    for enc, candidate in rec.get("auto_candidates", {}).items():
        if not isinstance(candidate, dict):
            return f"auto_candidates.{enc} is {_what(candidate)}, not an object"
        problem = _figures(candidate, _CANDIDATE_FIGURES, f"auto_candidates.{enc}")
        if problem:
            return problem
    return None
