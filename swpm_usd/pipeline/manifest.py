"""The run manifest (``<output>/manifest.json``): its names, reading it back, and writing it fast and often.

:func:`_read_manifest` reads the file (one asset record per built or failed asset, the run's own outputs
under :data:`RUN_OUTPUTS`, shared ``inputs`` lists under :data:`INPUT_LISTS`) and says what in it is not a
manifest; :class:`_ManifestText` writes it as ``json.dumps(indent=1)`` would, each record serialised once
(a run rewrites the file as assets finish); :data:`CURRENT` marks the scene and report written from the
records as they stand. Separate from the runner: the file's format and its cost, not when a run writes it.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .assets import output_dir
from .config import Config, ConfigError, load_config
from .records import _what
from .worker import atomic_write_bytes

if TYPE_CHECKING:
    from .plan_item import PlanItem


MANIFEST = "manifest.json"


#: the manifest's list of outputs of assets removed from the config that a run left in place (no ``prune``)
ORPHANED = "orphaned_outputs"
#: the manifest's records of the run's own outputs (kind -> record): ``scene`` (scene.usda) and ``report``
#: (report.html), each with its ``output`` option's default, so that when the config stops asking for one
#: the file left (a scene referencing layers ``prune`` deletes, a report of an older run) is an orphan
RUN_OUTPUTS = "run_outputs"
_RUN_OUTPUT_DEFAULTS = {"scene": False, "report": True}
_RUN_OUTPUT_FILES = {"scene": "scene.usda", "report": "report.html"}
#: the report's :data:`RUN_OUTPUTS` record's config file as the report names it (an absolute path: the
#: manifest's ``config`` is relative to output.dir), so that a rerun of a project moved whole, which changes
#: no record, rewrites the report that names the old path (and the manifest, for its record) and no more
REPORT_CONFIG = "config"
#: a run output's record's mark that the file was written from the records of the manifest that holds it (the
#: run's last write of the manifest; a write during the run, or of a run stopped, leaves it out: the records
#: have changed since the file was written, or may have). A rerun that changes no record keeps such a file
#: while it is as recorded (:func:`.outputs._checked_output`), and writes neither it nor the manifest. True in
#: memory; in the file, the digest of the manifest's text before :data:`RUN_OUTPUTS` (its records as written,
#: :func:`_records_digest`), so that records edited by hand since leave the file not current
CURRENT = "current"
#: where a manifest written by :class:`_ManifestText` has its :data:`RUN_OUTPUTS` (after its records: no
#: line within them starts with one space)
_RUN_OUTPUTS_FIELD = f"\n {json.dumps(RUN_OUTPUTS)}: ".encode()


def _records_digest(text: bytes | memoryview) -> str:
    """The :data:`CURRENT` mark of a manifest whose text before :data:`_RUN_OUTPUTS_FIELD` is ``text``."""
    return hashlib.sha256(text).hexdigest()[:16]


def _asks_for(cfg: Config, kind: str) -> bool:
    """Does the config ask for the run output ``kind`` (a key of :data:`_RUN_OUTPUT_DEFAULTS`)?"""
    return bool(cfg.data["output"].get(kind, _RUN_OUTPUT_DEFAULTS[kind]))


def _recorded_output_paths(out_dir: Path, manifest: dict) -> list[Path]:
    """The files in ``out_dir`` that ``manifest`` records as the run's outputs (its assets', those left by
    removed assets, scene.usda and report.html), which no glob takes as assets (:func:`.assets.discover`);
    a hand-edited entry that is not a file name is left out."""
    records = manifest.get("assets") if isinstance(manifest.get("assets"), dict) else {}
    found = [
        o
        for rec in records.values()
        if isinstance(rec, dict) and isinstance(rec.get("outputs"), dict)
        for o in rec["outputs"].values()
    ]
    for key in (ORPHANED, RUN_OUTPUTS):
        value = manifest.get(key)
        found += value if isinstance(value, list) else list(value.values()) if isinstance(value, dict) else []
    names = {o.get("path") for o in found if isinstance(o, dict)}
    return [out_dir / n for n in names if isinstance(n, str) and n and "\0" not in n and "/" not in n]


#: the manifest's table of the ``inputs`` lists several records share (the prims of one stage: its layers),
#: each written once (key: :func:`_inputs_key`), and a record's reference to one in place of its ``inputs``
#: (10,000 prims of a stage of 50 layers: about 75 MB of manifest, each record listing the 50)
INPUT_LISTS = "input_lists"
INPUTS_REF = "inputs_ref"


def _inputs_key(entries: list) -> str:
    """The key of an ``inputs`` list in :data:`INPUT_LISTS`: its content's (one list, one key, in any run)."""
    return hashlib.sha256(json.dumps(entries, sort_keys=True).encode()).hexdigest()[:16]


def _read_manifest(
    path: Path,
    unresolved: dict[str, str] | None = None,
    older: list[str] | None = None,
    unreadable: list[str] | None = None,
) -> dict:
    """The manifest at ``path``, ``{"assets": {}}`` for none (or not one); each record's :data:`INPUTS_REF`
    replaced by the list it names (one list object for all the records that share it), and records of
    older manifests that list the same inputs (a stage's prims) given one list object too. A reference to
    no list (a hand edit: none of that key, or :data:`INPUT_LISTS` not an object) leaves the record without
    ``inputs`` (hashed, as a malformed list is), and is described in ``unresolved`` (asset id -> why).
    ``older`` gets the ids of the records of an older manifest given one list object (which a rewrite
    writes once, in :data:`INPUT_LISTS`). A run output's :data:`CURRENT` mark is True when it is the digest
    of the text before :data:`RUN_OUTPUTS` (the records as the run wrote them), else left out. A file
    there that is not a manifest (cut, not JSON, edited into another shape) is described in ``unreadable``.
    """
    try:
        raw = path.read_bytes()
        data = json.loads(raw)
    except FileNotFoundError:
        return {"assets": {}}
    except (OSError, ValueError) as exc:
        if unreadable is not None:
            unreadable.append(f"it does not read ({type(exc).__name__}: {exc})")
        return {"assets": {}}
    if not isinstance(data, dict) or not isinstance(data.get("assets"), dict):
        if unreadable is not None:
            unreadable.append(
                f"it is {_what(data)}, not an object"
                if not isinstance(data, dict)
                else f"its assets is {_what(data.get('assets'))}, not an object"
            )
        return {"assets": {}}
    runs = data.get(RUN_OUTPUTS)
    marked = (
        [o for o in runs.values() if isinstance(o, dict) and CURRENT in o] if isinstance(runs, dict) else []
    )
    if marked:
        end = raw.find(_RUN_OUTPUTS_FIELD)
        digest = _records_digest(memoryview(raw)[:end]) if end >= 0 else None
        for o in marked:
            if o[CURRENT] == digest:
                o[CURRENT] = True
            else:
                del o[CURRENT]
    found = data.pop(INPUT_LISTS, None)
    tables = found if isinstance(found, dict) else {}
    seen: dict[str, list] = {}
    for aid, rec in data["assets"].items():
        if not isinstance(rec, dict):
            continue
        if INPUTS_REF in rec:
            ref = rec[INPUTS_REF]
            entries = tables.get(ref) if isinstance(ref, str) else None
            if isinstance(entries, list):  # (else none: the inputs are hashed, as for a malformed list)
                # in the reference's place, which the writer keeps: a record rewritten unchanged (one a run
                # --only leaves) is the same text (appended, the list moved after the record's other keys)
                data["assets"][aid] = {
                    ("inputs" if k == INPUTS_REF else k): (entries if k == INPUTS_REF else v)
                    for k, v in rec.items()
                    if k != "inputs"
                }
                continue
            del rec[INPUTS_REF]
            if unresolved is not None:
                if not isinstance(ref, str):
                    why = f"its {INPUTS_REF} is {_what(ref)}, not a string"
                elif found is None:
                    why = f"{INPUTS_REF} {ref!r}, and the manifest has no {INPUT_LISTS}"
                elif not isinstance(found, dict):
                    why = f"{INPUTS_REF} {ref!r}; its {INPUT_LISTS} is {_what(found)}, not an object"
                elif ref not in tables:
                    why = f"{INPUTS_REF} {ref!r}, which the manifest's {INPUT_LISTS} does not hold"
                else:
                    why = f"{INPUTS_REF} {ref!r}, which is {_what(entries)} in {INPUT_LISTS}, not a list"
                unresolved[aid] = why
        elif isinstance(rec.get("inputs"), list) and len(rec["inputs"]) > 1:
            own = rec["inputs"]
            rec["inputs"] = seen.setdefault(json.dumps(own, sort_keys=True), own)
            if older is not None and rec["inputs"] is not own:
                older.append(aid)
    return data


#: what a record's ``summary.curve`` is serialised as before its rows replace it (:func:`_record_text`): a
#: JSON string whose quotes no string value's text can hold unescaped
_CURVE_MARK = json.dumps("\0summary.curve\0")


def _indented(value: Any, depth: int) -> str:
    """``json.dumps(value, indent=1)`` nested ``depth`` spaces in, as a value inside the manifest."""
    return json.dumps(value, indent=1, default=float).replace("\n", "\n" + " " * depth)


def _record_text(rec: Any, depth: int) -> str:
    """``json.dumps(rec, indent=1)`` indented to ``depth``, but for its ``summary.curve``: a line a point
    (``{"lod":0,"triangles":5804,...}``), the same JSON value, which every reader reads as before. Written a
    key a line, the curve (21 points of 5 figures) was two thirds of a record: 2,000 records of suzanne
    (vanilla, usd) took 9.39 MB, 4,695 bytes each, and 7.46 MB now, 3,729 bytes each (0.99 s to serialise
    then, 0.83 s now)."""
    summary = rec.get("summary") if isinstance(rec, dict) else None
    curve = summary.get("curve") if isinstance(summary, dict) else None
    if not isinstance(curve, list) or not curve:
        return _indented(rec, depth)
    text = _indented({**rec, "summary": {**summary, "curve": json.loads(_CURVE_MARK)}}, depth)
    pad = "\n" + " " * (depth + 3)
    rows = ",".join(pad + json.dumps(point, default=float, separators=(",", ":")) for point in curve)
    return text.replace(f'"curve": {_CURVE_MARK}', f'"curve": [{rows}\n{" " * (depth + 2)}]', 1)


class _ManifestText:
    """``json.dumps(manifest, indent=1)``, but a record's ``summary.curve`` one point a line (the same JSON
    value), with every asset record serialised once: a record does not
    change once recorded, so a rewrite joins cached texts (a 6 MB manifest: 0.6 s serialised in full).

    An ``inputs`` list that several records hold (the same list object: the prims of one stage, hashed
    once) is written once, in the :data:`INPUT_LISTS` table after ``assets``, and each of those records
    names it by its :data:`INPUTS_REF` instead; :func:`_read_manifest` puts it back."""

    def __init__(self) -> None:
        #: asset id -> (record, its inputs' key or None, its row: key and text at depth 2)
        self._records: dict[str, tuple[dict, str | None, str]] = {}
        self._keys: dict[int, tuple[list, str, str]] = {}  # id(list) -> (list, key, text at depth 2)

    def _shared(self, entries: list) -> tuple[str, str]:
        hit = self._keys.get(id(entries))
        if hit is None or hit[0] is not entries:
            hit = self._keys[id(entries)] = (entries, _inputs_key(entries), _indented(entries, 2))
        return hit[1], hit[2]

    def dumps(self, manifest: dict) -> str:
        fields = []
        for key, value in manifest.items():
            if key == "assets" and isinstance(value, dict) and value:
                holders: dict[int, int] = {}  # id(inputs list) -> how many records hold it
                for rec in value.values():
                    inputs = rec.get("inputs") if isinstance(rec, dict) else None
                    if isinstance(inputs, list) and inputs:
                        holders[id(inputs)] = holders.get(id(inputs), 0) + 1
                tables: dict[str, str] = {}
                rows = []
                for aid, rec in value.items():
                    inputs = rec.get("inputs") if isinstance(rec, dict) else None
                    ref = None
                    if isinstance(inputs, list) and holders.get(id(inputs), 0) > 1:
                        ref, text = self._shared(inputs)
                        tables[ref] = text
                    hit = self._records.get(aid)
                    if hit is None or hit[0] is not rec or hit[1] != ref:
                        shown = rec
                        if ref is not None:
                            shown = {(INPUTS_REF if k == "inputs" else k): v for k, v in rec.items()}
                            shown[INPUTS_REF] = ref
                        # (the row with its key: joined as it is, not copied into a new string each write)
                        hit = (rec, ref, f"  {json.dumps(aid)}: {_record_text(shown, 2)}")
                        self._records[aid] = hit
                    rows.append(hit[2])
                fields.append(' "assets": {\n' + ",\n".join(rows) + "\n }")
                if tables:
                    table_rows = [f"  {json.dumps(k)}: {text}" for k, text in sorted(tables.items())]
                    fields.append(f" {json.dumps(INPUT_LISTS)}: {{\n" + ",\n".join(table_rows) + "\n }")
            elif (
                key == RUN_OUTPUTS
                and isinstance(value, dict)
                and any(isinstance(o, dict) and o.get(CURRENT) is True for o in value.values())
            ):  # (the mark: the digest of the text before, see CURRENT)
                digest = _records_digest(("{\n" + ",\n".join(fields) + ",").encode())
                marked = {
                    kind: {**o, CURRENT: digest} if isinstance(o, dict) and o.get(CURRENT) is True else o
                    for kind, o in value.items()
                }
                fields.append(f" {json.dumps(key)}: {_indented(marked, 1)}")
            else:
                fields.append(f" {json.dumps(key)}: {_indented(value, 1)}")
        return "{\n" + ",\n".join(fields) + "\n}"


def _write_manifest(path: Path, manifest: dict, text: _ManifestText | None = None) -> None:
    body = (text or _ManifestText()).dumps(manifest)
    atomic_write_bytes(path, (body + "\n").encode())


def _config_ref(cfg: Config, out_dir: Path) -> str:
    """The manifest's ``config``: the config file's path relative to output.dir (``../pipeline.yaml``), so a
    project folder moved or renamed whole names it as before; absolute where no relative path leads there
    (another drive)."""
    try:
        return Path(os.path.relpath(cfg.path, out_dir.resolve())).as_posix()
    except ValueError:
        return str(cfg.path)


def _shared_with(cfg: Config, manifest: dict, items: list[PlanItem]) -> tuple[str, int] | None:
    """(the other config, how many of its assets this one has not) when ``manifest`` was written by a run
    of another config file, still there (not this one moved or renamed) and writing in this output.dir (not
    the original of a copied project), whose assets this one lacks: two configs sharing an output.dir take
    each other's assets as removed, and each run rebuilds the other's."""
    other = manifest.get("config")
    if (
        not isinstance(other, str)
        or "\0" in other
        or other in (str(cfg.path), _config_ref(cfg, output_dir(cfg)))
    ):
        return None  # (this config's: a rerun reads no more)
    from .report import config_named

    other = config_named(output_dir(cfg), other)  # (relative to output.dir, or an older version's absolute)
    if other is None or not isinstance(manifest.get("assets"), dict):
        return None
    current = {it.asset.id for it in items}
    dropped = sum(aid not in current for aid in manifest["assets"])
    try:
        if not dropped or not os.path.isfile(other) or os.path.samefile(other, cfg.path):
            return None
    except OSError:
        return None
    try:  # (a copy of the project, its manifest naming the original config: that one writes elsewhere)
        if not os.path.samefile(output_dir(load_config(other)), output_dir(cfg)):
            return None
    except ConfigError:  # (one this version cannot read: it wrote here, as far as the manifest tells)
        pass
    except (OSError, ValueError):  # (its output.dir missing: not this one)
        return None
    return other, dropped
