"""An asset's treatment: the rule that matches it, its parameters written out, its digest, and the checks it
passed.

:func:`match_rule` gives an asset its rule (the first whose ``match`` conditions, :func:`rule_checks`, it
meets; else ``defaults``); :func:`treatment_digest` is what decides whether its build is current (its inputs,
prim, :func:`canonical_treatment`, its build version (:mod:`.build_version`); for ``auto`` the budgets it
chose by, :func:`checks_of`); :func:`checks_no_stricter` whether a build that passed some budgets passes
today's.
Separate from :mod:`.assets`' discovery (which files and prims are assets), which re-exports these names.
"""

from __future__ import annotations

import fnmatch
import hashlib
import json
from typing import TYPE_CHECKING, Any

from .config import Config

if TYPE_CHECKING:
    from .assets import Asset


def _in_range(value: float, rng: dict | None) -> bool:
    if not rng:
        return True
    return rng.get("min", float("-inf")) <= value <= rng.get("max", float("inf"))


def canonical_treatment(treatment: dict[str, Any]) -> dict[str, Any]:
    """``treatment`` with every parameter of its encoding, defaults filled in (``auto``: ``select``), and
    whole numbers given for a real-valued parameter as floats: two configs that build the same thing
    (``mu: 0.1`` written out or left to the default, ``mu: 1`` or ``mu: 1.0``) give one treatment."""
    from ..encodings import ENCODING_PARAMS
    from .auto import AUTO_SELECT
    from .schema import real_valued

    encoding = treatment.get("encoding")
    defaults = ENCODING_PARAMS.get(encoding) or {"select": AUTO_SELECT[0]}
    params = dict(defaults)
    for name, value in (treatment.get("params") or {}).items():
        if (
            name in defaults
            and real_valued(name, defaults[name])
            and isinstance(value, int)
            and not isinstance(value, bool)
        ):
            try:
                value = float(value)
            except OverflowError:  # out of any build's range: the build reports it, located
                pass
        params[name] = value
    return {**treatment, "params": params}


def checks_of(data: dict[str, Any]) -> dict[str, Any]:
    """The parts of a config (its data) that decide whether a built asset passes: ``budgets`` (which ``auto``
    also chooses by) and ``streaming``."""
    return {"budgets": data.get("budgets") or {}, "streaming": data.get("streaming") or {}}


#: the limits of :func:`checks_of` that a larger value loosens, and the one a smaller value loosens
_MAXIMA = {
    ("budgets", "total_bytes"),
    ("budgets", "global_bytes"),
    ("budgets", "instance_bytes"),
    ("streaming", "coarsest_lod_bytes"),
    ("streaming", "max_lods"),
}
_MINIMA = {("streaming", "min_coarsest_triangles")}


def checks_no_stricter(now: dict[str, Any], then: dict[str, Any] | None) -> bool:
    """Does an asset that passed the checks ``then`` pass ``now`` without being built again: every limit of
    ``now`` as loose as ``then``'s or looser (a limit dropped is looser, one added is not), every other
    setting (the streaming order) the same? ``then`` None (a record without its checks): no."""
    if then is None:
        return False
    for section in ("budgets", "streaming"):
        a, b = now.get(section) or {}, then.get(section) or {}
        for key in set(a) | set(b):
            if key not in a and ((section, key) in _MAXIMA or (section, key) in _MINIMA):
                continue  # dropped
            if (section, key) in _MAXIMA:
                if key not in b or a[key] < b[key]:
                    return False
            elif (section, key) in _MINIMA:
                if key not in b or a[key] > b[key]:
                    return False
            elif a.get(key) != b.get(key):
                return False
    return True


def treatment_digest(
    input_digest: str,
    asset: Asset,
    treatment: dict[str, Any],
    version: str,
    checks: dict[str, Any] | None = None,
    *,
    instances: int | None = None,
) -> str:
    """What decides whether an asset's outputs are current: its inputs, prim, encoding and parameters
    (:func:`canonical_treatment`: a default written out changes nothing), for ``encoding: auto`` its
    instances and the budgets and streaming policy it chose by (:func:`checks_of`; other encodings keep
    their checks in their record, and :func:`checks_no_stricter` decides), and its build version
    (:func:`.build_version.build_version`).

    Another encoding builds the same outputs for any instance count (a rule on ``instances`` that picks
    another treatment changes the digest by that treatment): its digest takes the count as 1, the default,
    so an asset of the default count keeps the digest it had when every count was in it, and a source's
    ``instances`` changed rebuilds only its ``auto`` assets (the runner checks ``budgets.total_bytes``
    against the recorded memory and the new count: :func:`.runner.plan`). ``instances`` given is the count
    the digest takes instead (a record's, built when every count was in the digest: :func:`.runner.plan`)."""
    if instances is None:
        instances = asset.instances if treatment.get("encoding") == "auto" else 1
    payload = json.dumps(
        [input_digest, asset.prim, instances, canonical_treatment(treatment), checks or {}, version],
        sort_keys=True,
    )
    return hashlib.sha256(payload.encode()).hexdigest()


def rule_checks(rule: dict[str, Any], asset: Asset, triangles: int) -> list[tuple[str, bool]]:
    """Each of ``rule``'s match conditions, named, and whether ``asset`` (of ``triangles``) meets it: the
    rule matches the asset when it meets them all (a rule without ``match`` matches every asset)."""
    m = rule.get("match") or {}
    checks = []
    if "path" in m:
        checks.append(("path", fnmatch.fnmatch(asset.file_id, m["path"])))  # (a stage asset: its stage's)
    if "prim" in m:
        checks.append(("prim", asset.prim is not None and fnmatch.fnmatch(asset.prim, m["prim"])))
    if "triangles" in m:
        checks.append((f"triangles={triangles}", _in_range(triangles, m["triangles"])))
    if "instances" in m:
        checks.append((f"instances={asset.instances}", _in_range(asset.instances, m["instances"])))
    if "tag" in m:
        checks.append(("tag", all(asset.tags.get(k) == v for k, v in m["tag"].items())))
    return checks


def match_rule(cfg: Config, asset: Asset, triangles: int) -> tuple[int | None, dict[str, Any], str]:
    """(rule index or None for defaults, {'encoding', 'params'}, why) for an asset."""
    for i, rule in enumerate(cfg.data.get("rules", [])):
        checks = rule_checks(rule, asset, triangles)
        if all(ok for _, ok in checks):
            why = f"rule {rule['name']!r} matched" + (
                f" ({', '.join(name for name, _ in checks)})" if checks else " (no match conditions)"
            )
            return i, {"encoding": rule["encoding"], "params": dict(rule.get("params", {}))}, why
    d = cfg.data.get("defaults", {})
    return (
        None,
        {"encoding": d.get("encoding", "sliding-window"), "params": dict(d.get("params", {}))},
        ("no rule matched: defaults"),
    )
