"""Why the plan builds an asset again: each reason a stable code and a detail naming the thing.

:func:`.runner.plan` decides whether an asset is up to date (its record's digest, checks, memory, triangles
and outputs against today's config); :func:`build_reasons` says, for an asset it did not find up to date,
every part of that decision that failed, in the order of :data:`REASONS`, without taking the decision again
(the plan keeps it: a test pins that an asset is to build exactly when it has reasons). The digest is a hash
(:func:`.assets.treatment_digest`): which of its parts moved is found by reproducing the record's digest from
what the record and the manifest hold (its input digest, its encoding and parameters, the manifest's tool
version, its checks and instance count); a record whose digest is not reproduced so (an older version's, an
edited one) says ``digest-changed`` rather than guess.
"""

from __future__ import annotations

import itertools
import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import first_few
from .assets import _MAXIMA, _MINIMA, canonical_treatment, checks_no_stricter, checks_of, treatment_digest
from .auto import AUTO_SELECT
from .build_version import build_version
from .config import Config
from .file_hash import STAT_KEYS
from .inputs import recorded_path
from .rules import (
    OUTPUT_SUFFIXES,
    _max_triangles,
    _output_names_current,
    _rule_name,
    _swpm_layout_current,
    _total_fits,
    _wanted_outputs,
    _wants_outputs,
    _within_triangle_budget,
)
from .worker import TRIANGLES_READ

if TYPE_CHECKING:
    from .plan_item import PlanItem

#: every reason's code, in the order an asset's reasons are listed (a stable, lower-case contract: scripts
#: and ``--json``'s ``because`` use them)
REASONS = (
    "forced",  # --force
    "new",  # no record the run can use (none, or one not a record the run writes: ignored)
    "failed",  # the last build failed (its code), or the last rebuild of a kept build
    "inputs-changed",  # the digest of its input files is not the recorded one (which files)
    "treatment-changed",  # its encoding or parameters (a default written out is no change)
    "instances-changed",  # encoding auto, which chooses by the instance count
    "checks-changed",  # encoding auto, which chooses by the budgets and streaming policy
    "version-changed",  # the build version (the part that changed: sliding-window 0.9.2 -> 0.9.3)
    "digest-changed",  # the record's digest, not reproduced from what it holds (an older record)
    "rule-pending",  # its rule is left to the worker, by a triangle count the record does not hold
    "checks-stricter",  # a budget or streaming limit stricter than those it passed
    "over-total-bytes",  # global + instances x instance bytes over budgets.total_bytes
    "over-triangle-budget",  # its input's triangles over limits.max_triangles
    "outputs-unwanted",  # the config asks for no output (swpm: false, usd: false), the build wrote some
    "output-wanted",  # a kind of output the config asks for that the build did not write (usd: true added)
    "layout-changed",  # output.legacy_layout flipped since the .swpm was written
    "names-changed",  # output.names (or the glob that names by path) gives its outputs other names now
    "output-missing",  # a recorded output deleted
    "output-changed",  # a recorded output not as recorded (edited, replaced)
    "layer-units",  # a USD layer whose units the record lacks and the layer does not tell
)


def reason(code: str, detail: str = "") -> dict[str, str]:
    """One reason, as ``--json`` gives it: ``{"code": ..., "detail": ...}`` (``code``: of :data:`REASONS`)."""
    assert code in REASONS, code  # (a programming error: the codes are a contract)
    return {"code": code, "detail": detail}


def shown(reasons: list[dict[str, str]]) -> str:
    """Reasons as a plan line shows them: ``inputs changed (a.obj); treatment changed (mu 0.1 -> 0.3)``."""
    return "; ".join(
        r["code"].replace("-", " ") + (f" ({r['detail']})" if r["detail"] else "") for r in reasons
    )


def counted(reasons: list[list[dict[str, str]]]) -> dict[str, int]:
    """How many of several assets have each reason (code -> count, in the order of :data:`REASONS`)."""
    counts = dict.fromkeys(REASONS, 0)
    for found in reasons:
        for code in {r["code"] for r in found}:
            counts[code] += 1
    return {code: n for code, n in counts.items() if n}


def counted_shown(counts: dict[str, int]) -> str:
    """Counts of reasons as the end-of-run line shows them: ``new 2, inputs changed 10``."""
    return ", ".join(f"{code.replace('-', ' ')} {n}" for code, n in counts.items())


def _value(value: Any) -> str:
    """A parameter's or limit's value as a reason names it (JSON: ``true``, ``0.1``, ``"forsyth"``)."""
    return json.dumps(value, sort_keys=True, default=str)


def _failure(rec: dict) -> str:
    """A failed build's code and the first line of its error, cut short."""
    error = rec.get("error")
    line = error.strip().splitlines()[0] if isinstance(error, str) and error.strip() else ""
    line = line if len(line) <= 100 else line[:97] + "..."
    code = rec.get("code")
    return " ".join(p for p in (f"[{code}]" if isinstance(code, str) else "", line) if p)


def _changed_inputs(base: Path, recorded: Any, today: list[dict]) -> str:
    """Which input files moved from the record's ``inputs`` to today's entries: those added or gone, and
    those whose size or stat is not the recorded one (a file touched alone, its bytes the same, among them);
    "" when the record cannot tell (no entries, or every file as recorded: bytes changed under the same
    stat, which ``--verify`` finds)."""

    def key(path: str) -> str:
        return recorded_path(base, Path(path)) if os.path.isabs(path) else path

    if not isinstance(recorded, list) or not all(
        isinstance(e, dict) and isinstance(e.get("path"), str) for e in recorded
    ):
        return ""
    then = {key(e["path"]): e for e in recorded}
    now = {key(e["path"]): e for e in today if isinstance(e.get("path"), str)}
    fields = ("size", *STAT_KEYS)
    names = [f"{p} added" for p in now if p not in then]
    names += [f"{p} gone" for p in then if p not in now]
    names += [
        p for p in now if p in then and any(now[p].get(k) != then[p].get(k) for k in fields)
    ]  # (a file unread today, unreadable: no stat, so not as recorded)
    return first_few(names)


def _treatment_change(then: dict, now: dict) -> str:
    """What moved between two canonical treatments: ``encoding vanilla -> skip-strip``, or each parameter
    that changed (``mu 0.1 -> 0.3``)."""
    if then.get("encoding") != now.get("encoding"):
        return f"encoding {then.get('encoding')} -> {now.get('encoding')}"
    a, b = then.get("params") or {}, now.get("params") or {}
    changes = [
        f"{k} {_value(a[k]) if k in a else '(none)'} -> {_value(b[k]) if k in b else '(none)'}"
        for k in sorted(set(a) | set(b))
        if a.get(k, KeyError) != b.get(k, KeyError)
    ]
    return ", ".join(changes)


def _limits_changed(now: dict, then: dict | None, stricter: bool) -> str:
    """The limits of :func:`.assets.checks_of` that differ between ``then`` (a record's) and ``now``; only
    those stricter now (as :func:`.assets.checks_no_stricter` judges them) when ``stricter``."""
    if then is None:
        return "the record holds no checks"
    found = []
    for section in ("budgets", "streaming"):
        a, b = now.get(section) or {}, then.get(section) or {}
        for key in sorted(set(a) | set(b)):
            name, maximum, minimum = f"{section}.{key}", (section, key) in _MAXIMA, (section, key) in _MINIMA
            if a.get(key, KeyError) == b.get(key, KeyError):
                continue
            if stricter and key not in a and (maximum or minimum):
                continue  # (dropped: looser)
            if stricter and key in a and key in b and maximum and a[key] >= b[key]:
                continue
            if stricter and key in a and key in b and minimum and a[key] <= b[key]:
                continue
            was = _value(b[key]) if key in b else "(none)"
            found.append(f"{name} {was} -> {_value(a[key]) if key in a else '(none)'}")
    return ", ".join(found)


#: canonical treatments (:func:`_canonical`) by their encoding and parameters: a plan's assets to build share
#: a few, canonicalised once, not twice an asset (1,000 copies of suzanne to build, :func:`build_reasons` per
#: asset: a parameter changed 99 -> 76 us, the version changed 92 -> 60 us; medians of 9 alternating rounds)
_CANONICAL: dict[tuple, dict] = {}
_CANONICAL_MOST = 1024


def _canonical(treatment: dict) -> dict:
    """:func:`.assets.canonical_treatment` of ``treatment`` (its encoding and parameters alone), the same
    object for the same values (do not change it): one of scalar parameters is looked up by their values
    and types (``1``, ``1.0`` and ``true`` are equal, but not one parameter)."""
    params = treatment.get("params") or {}
    try:
        key = (
            treatment.get("encoding"),
            tuple(sorted((k, type(v).__name__, v) for k, v in params.items())),
        )
        hit = _CANONICAL.get(key)
    except TypeError:  # (a parameter's value a list or an object: not a key)
        return canonical_treatment({"encoding": treatment.get("encoding"), "params": params})
    if hit is None:
        if len(_CANONICAL) >= _CANONICAL_MOST:
            _CANONICAL.clear()
        hit = _CANONICAL[key] = canonical_treatment({"encoding": treatment.get("encoding"), "params": params})
    return hit


def _once(values: list) -> list:
    """``values`` without repeats (the first of each kept)."""
    return [x for i, x in enumerate(values) if x not in values[:i]]


def _recorded_treatments(prev: dict) -> list[dict]:
    """The treatments (canonical) a record may have been built with, from what it holds: ``encoding: auto``
    with each ``select`` when auto chose its encoding (the record holds the one chosen); else its encoding
    with its parameters as the build resolved them (``pm.params``) less those no config can set (a strip's
    restart index) and, for each one whose default is None (the build's own choice), that value written
    out or left to the build. Candidates only: the record's digest tells which one, if any, it was."""
    from ..encodings import ENCODING_PARAMS

    if "auto_candidates" in prev or "; auto: " in str(prev.get("why", "")):
        return [_canonical({"encoding": "auto", "params": {"select": s}}) for s in AUTO_SELECT]
    enc, params = prev.get("encoding"), prev.get("params")
    defaults = ENCODING_PARAMS.get(enc) if isinstance(enc, str) else None
    if defaults is None or not isinstance(params, dict):
        return []
    given = {k: v for k, v in params.items() if k in defaults}
    chosen = [k for k, v in given.items() if defaults[k] is None and v is not None][:3]
    found = []
    for left in itertools.product((False, True), repeat=len(chosen)):
        kept = {k: v for k, v in given.items() if not (k in chosen and left[chosen.index(k)])}
        found.append(_canonical({"encoding": enc, "params": kept}))
    return _once(found)


def _build_version_parts(version: str) -> dict[str, str] | None:
    """A build version's parts (:func:`.build_version.build_version`: part -> release), None for a tool's
    version (a record's from before build versions)."""
    try:
        parts = dict(item.rsplit(" ", 1) for item in version.split(", "))
    except ValueError:
        return None
    return parts if "base" in parts else None


def _version_change(then: str, now: str) -> str:
    """``version-changed``'s detail: the parts of the build version that changed (``sliding-window 0.9.2 ->
    0.9.3``), or the record's tool version and today's build version when the record is older than build
    versions."""
    old, new = _build_version_parts(then), _build_version_parts(now)
    if old is None or new is None:
        return f"{then} -> {now}"
    changed = sorted(p for p in old.keys() | new.keys() if old.get(p) != new.get(p))
    return ", ".join(f"{p} {old.get(p, 'none')} -> {new.get(p, 'none')}" for p in changed)


def _digest_reasons(cfg: Config, item: PlanItem, prev: dict, version_then: Any) -> list[dict]:
    """The reasons the record's digest is not today's: its input digest, and the other parts of the digest
    that reproduce it (:func:`.assets.treatment_digest` of the record's input digest with the treatment,
    version, checks and instance count tried from today's and the record's), else ``digest-changed``."""
    found = []
    then_inputs = prev.get("input_digest")
    if then_inputs != item.input_digest:
        detail = _changed_inputs(cfg.base, prev.get("inputs"), item.input_stats)
        found.append(reason("inputs-changed", detail))
    if not isinstance(then_inputs, str) or not isinstance(prev.get("digest"), str):
        return [*found, reason("digest-changed", "the record holds no digest to compare")]
    asset = item.asset
    now = _canonical(item.treatment)
    # the treatments tried (canonical, each once): the record's first (what it was most likely built with),
    # then today's
    treatments = [t for t in _recorded_treatments(prev) if t != now] + [now]
    today_checks = checks_of(cfg.data)
    match = None
    for treatment in treatments:
        auto = treatment.get("encoding") == "auto"
        checks = _once([today_checks, prev.get("checks")] if auto else [None])
        counts = _once([asset.instances, prev.get("instances")] if auto else [1, prev.get("instances")])
        # the treatment's build version today, the record's, and (a record of a tool before build versions,
        # whose digest held the tool's version) the manifest's tool version
        versions = _once([build_version(treatment), prev.get("build_version"), version_then])
        for v, c, n in itertools.product(versions, checks, counts):
            if type(n) is not int or (auto and not isinstance(c, dict)) or not isinstance(v, str):
                continue
            today = (now, build_version(now), today_checks if auto else None, asset.instances if auto else 1)
            if then_inputs == item.input_digest and (treatment, v, c, n) == today:
                continue  # (today's digest, which is not the record's)
            if treatment_digest(then_inputs, asset, treatment, v, c, instances=n) == prev["digest"]:
                match = (treatment, v, c, n)
                break
        if match is not None:
            break
    if match is None:
        if prev.get("status") != "built" and "encoding" not in prev:
            why = "a build that failed before it chose an encoding: its record holds none to compare"
        else:
            why = "the record's digest is not reproduced from what it holds: an older version's, or edited"
        return [*found, reason("digest-changed", why)]
    then, v, c, n = match
    parts = []
    if then != now:
        detail = _treatment_change(then, now)
        rule_then, rule_now = prev.get("rule"), _rule_name(cfg, item)
        if rule_then != rule_now:
            named = ("defaults" if r is None else repr(r) for r in (rule_then, rule_now))
            detail += f", rule {' -> '.join(named)}"  # (one more change of the list, not of the last one)
        parts.append(reason("treatment-changed", detail))
    if now.get("encoding") == "auto" and then.get("encoding") == "auto":
        if n != asset.instances:
            parts.append(reason("instances-changed", f"{n} -> {asset.instances}"))
        if c != today_checks:
            parts.append(reason("checks-changed", _limits_changed(today_checks, c, stricter=False)))
    if v != build_version(then):
        parts.append(reason("version-changed", _version_change(v, build_version(then))))
    if not found and not parts:  # (reproduced, yet every part today's: not expected, said as it is)
        parts.append(reason("digest-changed", "the record's digest is not today's"))
    return found + parts


def build_reasons(
    cfg: Config,
    item: PlanItem,
    version_then: Any,
    out_dir: Path,
    ignored: str | None = None,
    checked: dict[str, dict | None] | None = None,
    units_ok: bool = True,
) -> list[dict[str, str]]:
    """Why :func:`.runner.plan` builds ``item`` again (it found it not up to date), every reason that
    applies in the order of :data:`REASONS` (``forced`` aside: the runner adds it). ``version_then``: the
    manifest's ``tool_version`` (a record's digest before build versions held it); ``ignored``: why the
    asset's record was ignored (not one the run writes); ``checked``: its outputs as the plan checked them
    (:func:`.outputs._checked_output`, None for one not as recorded), when the plan got that far, else a
    wanted output is only looked for (missing or not); ``units_ok`` False: its USD layer's units are not
    known (:func:`.scene._layer_with_units`)."""
    prev = item.previous
    if prev is None:
        return [reason("new", f"its record is ignored: {ignored}" if ignored else "no record")]
    found = []
    built = prev.get("status") == "built"
    if not built:
        found.append(reason("failed", _failure(prev)))
    elif isinstance(prev.get("last_failure"), dict):
        found.append(reason("failed", _failure(prev["last_failure"]) + "; its previous build kept"))
    if item.rule_pending:
        if prev.get("input_digest") != item.input_digest:
            detail = _changed_inputs(cfg.base, prev.get("inputs"), item.input_stats)
            found.append(reason("inputs-changed", detail))
        elif built:
            found.append(reason("rule-pending", "the record holds no triangle count the rules route by"))
        return found
    if prev.get("digest") != item.digest:
        found += _digest_reasons(cfg, item, prev, version_then)
    if not built:
        return found
    now_checks, then_checks = checks_of(cfg.data), prev.get("checks")
    if item.treatment.get("encoding") != "auto" and not checks_no_stricter(now_checks, then_checks):
        found.append(reason("checks-stricter", _limits_changed(now_checks, then_checks, stricter=True)))
    if not _total_fits(cfg, prev, item):
        limit = cfg.data["budgets"]["total_bytes"]
        s = prev.get("summary") or {}
        g, i = s.get("global_bytes"), s.get("instance_bytes")
        if isinstance(g, (int, float)) and isinstance(i, (int, float)):
            n = item.asset.instances
            detail = f"{g} + {n} x {i} = {g + n * i} > budgets.total_bytes {limit}"
        else:
            detail = "the record holds no memory to check budgets.total_bytes by"
        found.append(reason("over-total-bytes", detail))
    if not _within_triangle_budget(cfg, prev):
        tri = prev.get(TRIANGLES_READ)
        budget = _max_triangles(cfg)
        detail = f"{tri} > limits.max_triangles {budget}" if type(tri) is int else "the record holds no count"
        found.append(reason("over-triangle-budget", detail))
    outs = prev.get("outputs") or {}
    wanted = _wanted_outputs(cfg)
    if outs and not _wants_outputs(cfg):
        found.append(reason("outputs-unwanted", ", ".join(sorted(outs))))
    missing_kinds = sorted(wanted - set(outs))
    if missing_kinds:
        found.append(reason("output-wanted", ", ".join(missing_kinds)))
    if not _swpm_layout_current(cfg, outs):
        then = outs["swpm"].get("legacy_layout", False)
        now = bool(cfg.data["output"].get("legacy_layout", False))
        found.append(reason("layout-changed", f"legacy_layout {_value(then)} -> {_value(now)}"))
    if not _output_names_current(cfg, item, outs):
        stem = item.asset.output_stem
        moved = [
            f"{outs[kind].get('path')} -> {stem}{OUTPUT_SUFFIXES[kind]}"
            for kind in sorted(wanted & set(outs))
            if isinstance(outs[kind], dict) and outs[kind].get("path") != f"{stem}{OUTPUT_SUFFIXES[kind]}"
        ]
        found.append(reason("names-changed", ", ".join(moved)))
    gone, edited = [], []
    for kind in sorted(wanted & set(outs)):
        path = out_dir / outs[kind]["path"]
        if checked is not None and checked.get(kind) is not None:
            continue
        exists = os.path.lexists(path)
        if not exists:
            gone.append(recorded_path(cfg.base, path))
        elif checked is not None:  # (not hashed when the build is to go for another reason)
            edited.append(recorded_path(cfg.base, path))
    if gone:
        found.append(reason("output-missing", ", ".join(gone)))
    if edited:
        found.append(reason("output-changed", ", ".join(edited)))
    if not units_ok:
        found.append(reason("layer-units", recorded_path(cfg.base, out_dir / outs["usd"]["path"])))
    return found
