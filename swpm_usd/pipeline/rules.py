"""The plan's questions about rules: which rule an asset's triangle count routes it by, which rules no asset
reaches, and whether the build its record holds still meets today's config.

A build is current when its digest is the treatment's (:func:`_treatment_digest`), its recorded memory
still fits ``budgets.total_bytes`` at today's instance count (:func:`_total_fits`), its triangles
``limits.max_triangles`` (:func:`_within_triangle_budget`), and its outputs are those the config asks for
(:func:`_wanted_outputs`), at the names ``output.names`` gives them (:func:`_output_names_current`).
Separate from the runner: each answer is a small pure function of the config and a record, which
:func:`.runner.plan` and the run's records use.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .assets import OUTPUT_NAMES, Asset, checks_of, match_rule, output_names, rule_checks, treatment_digest
from .build_version import build_version
from .config import Config
from .worker import TRIANGLES_READ

if TYPE_CHECKING:
    from .plan_item import PlanItem


def _total_fits(cfg: Config, record: dict, item: PlanItem) -> bool:
    """Does the build ``record`` holds still meet ``budgets.total_bytes`` with ``item``'s instance count
    (global bytes + instances x instance bytes, as the worker checks it)? The count is not in the digest of
    an encoding other than ``auto`` (:func:`.assets.treatment_digest`), so more instances than it passed
    with check it again, from the memory the record holds (a record without it: built again)."""
    limit = (cfg.data.get("budgets") or {}).get("total_bytes")
    if (
        limit is None
        or item.treatment.get("encoding") == "auto"
        or record.get("instances") == item.asset.instances
    ):
        return True
    summary = record.get("summary") or {}
    if not all(isinstance(summary.get(k), (int, float)) for k in ("global_bytes", "instance_bytes")):
        return False
    return summary["global_bytes"] + item.asset.instances * summary["instance_bytes"] <= limit


def _treatment_digest(cfg: Config, item: PlanItem) -> str:
    checks = checks_of(cfg.data) if item.treatment.get("encoding") == "auto" else None
    return treatment_digest(
        item.input_digest, item.asset, item.treatment, build_version(item.treatment), checks
    )


def _same_rule_from(cfg: Config, asset: Asset, lowest: int) -> bool:
    """Does ``asset`` match the same rule (or the defaults) at every triangle count from ``lowest`` up? A
    lower bound (an OBJ's face lines: a quad is two triangles) routes the asset by its count only then: under
    a rule's ``max`` it named that rule where the mesh, loaded, had more triangles and matched another."""
    counts = {lowest}
    for rule in cfg.data.get("rules", []):
        rng = (rule.get("match") or {}).get("triangles") or {}
        if "min" in rng and rng["min"] > lowest:
            counts.add(math.ceil(rng["min"]))
        if "max" in rng and rng["max"] >= lowest:
            counts.add(math.floor(rng["max"]) + 1)
    return len({match_rule(cfg, asset, n)[0] for n in counts}) == 1


def _max_triangles(cfg: Config) -> int | None:
    """``limits.max_triangles``, or None."""
    limits = cfg.data.get("limits")
    return limits.get("max_triangles") if isinstance(limits, dict) else None


def _within_triangle_budget(cfg: Config, record: dict) -> bool:
    """Whether the asset a record built holds no more triangles than ``limits.max_triangles`` (a budget set
    or lowered since: an asset over it is loaded again, and fails), counted as the budget counts them, before
    cleaning (:data:`.worker.TRIANGLES_READ`; the cleaned ``triangles_in`` left a file over it by duplicate
    or degenerate triangles alone current). A record without that count (of a version before it) is built
    again, and then has it."""
    budget, tri = _max_triangles(cfg), record.get(TRIANGLES_READ)
    return budget is None or (type(tri) is int and tri <= budget)


def _rules_pending(items: list[PlanItem], dry_run: bool = False) -> bool:
    """Are rules left to the workers, so the rules no asset reaches are known only once they have built? A
    dry run's plan leaves out the files that did not load to be counted (a run's worker fails them before any
    rule, if they load no better then); a run (``--explain`` counts as it plans) waits for its workers: such a
    file may load whole by then (an exporter was still writing it) and take a rule."""
    return any(i.rule_pending and not (dry_run and i.triangles_how == "unknown") for i in items)


def _unreached_rules(cfg: Config, items: list[PlanItem]) -> list[str]:
    """A warning for each rule no asset took: one shadowed by earlier rules (every asset it matches is
    taken first by one of them, named) or one that matches no asset at all."""
    reached = {i.rule for i in items}
    rules = cfg.data.get("rules", [])
    warnings = []
    path_hints: dict[str, str] = {}  # (a pattern's hint, once: each looks at every asset's id)
    for idx, rule in enumerate(rules):
        if idx in reached:
            continue
        # (an asset whose rule is unknown, one that failed before the worker matched it, is left out)
        takers = sorted(
            {
                it.rule
                for it in items
                if it.rule is not None and all(ok for _, ok in rule_checks(rule, it.asset, it.triangles or 0))
            }
        )
        if takers:
            by = ("rules " if len(takers) > 1 else "rule ") + " and ".join(
                repr(rules[i]["name"]) for i in takers
            )
            warnings.append(
                f"{cfg.where(('rules', idx))}: rule {rule['name']!r} is shadowed by {by}: every asset it "
                "matches is taken by an earlier rule"
            )
        else:
            hint = _path_hint(rule, items, path_hints) or _tag_hint(rule)
            warnings.append(f"{cfg.where(('rules', idx))}: rule {rule['name']!r} matches no asset{hint}")
    return warnings


def _tag_hint(rule: dict[str, Any]) -> str:
    """Where a rule with a ``match.tag`` matches no asset: where tags are read (a studio tags the Xform that
    places an asset in its set, which no rule sees)."""
    if not (rule.get("match") or {}).get("tag"):
        return ""
    return (
        " (a tag is read on a stage asset's Mesh prim, its own customData: not an ancestor's, and a glob's "
        "files carry none; match.prim globs on prim paths)"
    )


def _path_hint(rule: dict[str, Any], items: list[PlanItem], known: dict[str, str] | None = None) -> str:
    """Where a rule's ``match.path`` matches no asset's path at all: how paths are written and, as ``--only``
    says, the pattern near it that matches some (``props/*`` written from the glob's folder for
    ``assets/props/*``: the warning named the rule alone, and the studio looked at its other conditions).
    ``known``: the hints of patterns already looked at (a pattern -> its hint), kept there."""
    from .selection import _selection_hint

    pattern = (rule.get("match") or {}).get("path")
    if not isinstance(pattern, str):
        return ""
    if known is not None:
        if pattern not in known:
            known[pattern] = _path_hint(rule, items)
        return known[pattern]
    ids = list(dict.fromkeys(it.asset.file_id for it in items))
    if not ids or any(fnmatch.fnmatch(i, pattern) for i in ids):
        return ""
    near = _selection_hint(pattern, ids)
    guess = f": did you mean {near[0]!r}? {near[1]} asset{'s' * (near[1] != 1)}" if near else ""
    how = "relative to the config as --dry-run shows it"
    return f" (its path {pattern!r} matches no asset's path, {how}{guess})"


def _wants_outputs(cfg: Config) -> bool:
    out = cfg.data["output"]
    return bool(out.get("swpm", True) or out.get("usd", False))


def _wanted_outputs(cfg: Config) -> set[str]:
    """The kinds of output (a record's ``outputs`` keys) the config asks each asset for."""
    out = cfg.data["output"]
    return {
        kind for kind, wanted in (("swpm", out.get("swpm", True)), ("usd", out.get("usd", False))) if wanted
    }


def _swpm_layout_current(cfg: Config, outputs: dict) -> bool:
    """Is an asset's recorded .swpm, when the config asks for one, of the layout ``output.legacy_layout``
    asks for? Else it is written again (built again: the run keeps no build to re-encode). A record
    without ``legacy_layout`` (written before the key was) is of the default layout."""
    recorded = outputs.get("swpm")
    if "swpm" not in _wanted_outputs(cfg) or not isinstance(recorded, dict):
        return True
    return recorded.get("legacy_layout", False) is bool(cfg.data["output"].get("legacy_layout", False))


#: the suffix of each kind of output (a record's ``outputs`` key) after the asset's output stem
OUTPUT_SUFFIXES = {"swpm": ".swpm", "usd": ".usdc"}


def _output_names_current(cfg: Config, item: PlanItem, outputs: dict) -> bool:
    """Are an asset's recorded outputs, of the kinds the config asks for, at the names it gives them today
    (``<output stem>.swpm``, ``.usdc``: ``output.names`` flipped since moves them)? Else the asset is built
    again under its new names, not its files renamed: a USD layer's root prim is named after its file, so a
    renamed layer is not what a build writes; the files at the old names are then the build's dropped
    outputs (:func:`.outputs._dropped_outputs`), listed as orphans and deleted by ``prune``."""
    stem = item.asset.output_stem
    for kind in _wanted_outputs(cfg) & set(outputs):
        recorded = outputs[kind]
        if not isinstance(recorded, dict) or recorded.get("path") != f"{stem}{OUTPUT_SUFFIXES[kind]}":
            return False
    return True


def _names_moved(cfg: Config, asset: Asset, previous: dict | None) -> str:
    """What gives ``asset`` other output names than its record (``previous``) lists: ``output.names: stem ->
    path`` (or ``path -> stem``), or, under ``path`` both times, its glob (whose fixed folder starts the
    names); "" when its names did not move (none recorded, or as today). The setting the record's build ran
    under (its ``output_names``) tells the flip from the glob; a record of an earlier version has none, and
    then old names that are the stems are taken for a flip (under ``path`` a glob's fixed folder can also give
    the stems)."""
    outputs = previous.get("outputs") if isinstance(previous, dict) else None
    old = {
        Path(o["path"]).stem
        for o in (outputs.values() if isinstance(outputs, dict) else [])
        if isinstance(o, dict) and isinstance(o.get("path"), str)
    }
    if not old or old == {asset.output_stem}:
        return ""
    now = output_names(cfg)
    then = previous.get("output_names")
    if then in OUTPUT_NAMES and then != now:
        return f"output.names: {then} -> {now}"
    if then == now == "path":
        return "its glob (output.names: path)"
    by_stem = dataclasses.replace(asset, path_name=None).output_stem
    if now == "path":
        return "output.names: stem -> path" if by_stem in old else "its glob (output.names: path)"
    return "output.names: path -> stem"


def _routes_by_triangles(cfg: Config) -> bool:
    """Does a rule match on triangle counts (so an asset's rule depends on its count)?"""
    return any("triangles" in (r.get("match") or {}) for r in cfg.data.get("rules", []))


def _current_why(recorded: Any, item: PlanItem) -> str:
    """The ``why`` of an up-to-date asset's record today: the rule that chooses its treatment now
    (``item.why``), and for ``encoding: auto`` the choice its build recorded after it (``; auto: ...``,
    :func:`.auto.choose_auto`'s, which the build alone measures: this treatment's, as the digest is)."""
    if item.treatment.get("encoding") == "auto" and isinstance(recorded, str):
        cut = recorded.rfind("; auto: ")  # (the last: the choice holds none, a rule's name might)
        if cut >= 0:
            return item.why + recorded[cut:]
    return item.why


def _rule_name(cfg: Config, item: PlanItem) -> str | None:
    """The name of the rule that chose ``item``'s treatment (None: the defaults)."""
    return None if item.rule is None else cfg.data["rules"][item.rule]["name"]
