"""The plan as a dry run and ``--explain`` show it (:func:`_plan_shown`): a line an asset, and each asset's
plan as :attr:`.run_result.RunResult.plan` holds it.

Separate from the runner: display only; the plan itself is :func:`.runner.plan`'s.
"""

from __future__ import annotations

import json
from typing import Any

from .config import Config
from .plan_item import PlanItem, _triangles_shown
from .reasons import shown as reasons_shown
from .treatment import rule_checks

#: a pending item's ``why`` (:func:`.runner.plan`), before what kept its triangles from being counted
_PENDING_WHY = "rule chosen by the worker"


def _plan_shown(
    cfg: Config, picked: list[PlanItem], force: bool, because: dict[str, list], echo
) -> list[dict]:
    """A dry run's or ``--explain``'s plan of the assets ``picked``: a line echoed for each (its encoding,
    parameters, state, triangles, instances, why and ``because``, its reasons to be built), and each as
    :attr:`.run_result.RunResult.plan` holds it. An asset whose rule is left to the worker (its triangles
    not counted) shows the rule its path decides, if one does (:func:`_rule_decided_without_triangles`)."""
    planned = []
    for it in picked:
        state = "up to date" if it.up_to_date and not force else "to build"
        encoding, params = it.treatment.get("encoding"), it.treatment.get("params", {})  # (none: pending)
        why = it.why
        decided = _rule_decided_without_triangles(cfg, it) if it.rule_pending else None
        if decided is not None:  # (it showed `? {}`, "rule chosen by the worker", for a rule on its path)
            treatment, matched = decided
            encoding, params = treatment["encoding"], treatment["params"]
            why = matched + it.why.removeprefix(_PENDING_WHY)
        reasons = because[it.asset.id]
        echo(
            f"{it.asset.id}: {encoding or '?'} "
            f"{json.dumps(params, sort_keys=True)} "
            f"[{state}] {_triangles_shown(it)} instances={it.asset.instances}; {why}"
            + (f"; because: {reasons_shown(reasons)}" if reasons else "")
        )
        planned.append(
            {
                "id": it.asset.id,
                "encoding": encoding,
                "params": params,
                "state": state,
                "triangles": it.triangles,
                "triangles_count": it.triangles_how,
                "instances": it.asset.instances,
                "why": why,
                "because": reasons,
            }
        )
    return planned


def _rule_decided_without_triangles(cfg: Config, it: PlanItem) -> tuple[dict[str, Any], str] | None:
    """(treatment, why) of the rule that takes ``it`` whatever its triangle count, as :func:`.match_rule`
    would: the first rule whose other conditions (path, prim, instances, tags: known before the file loads)
    it meets, if that rule has no condition on triangles, or the defaults when every rule fails on another
    condition; None when a rule on triangles decides (the worker's, once it has counted them)."""
    for rule in cfg.data.get("rules", []):
        checks = rule_checks(rule, it.asset, 0)
        known = [name for name, ok in checks if not name.startswith("triangles=")]
        if not all(ok for name, ok in checks if name in known):
            continue
        if len(known) < len(checks):
            return None
        matched = f"rule {rule['name']!r} matched" + (
            f" ({', '.join(known)})" if known else " (no match conditions)"
        )
        matched += " before any rule on triangles"
        return {"encoding": rule["encoding"], "params": dict(rule.get("params", {}))}, matched
    d = cfg.data.get("defaults", {})
    treatment = {"encoding": d.get("encoding", "sliding-window"), "params": dict(d.get("params", {}))}
    return treatment, "no rule matched, whatever the triangles: defaults"


def _assets(n: int) -> str:
    return f"{n} asset" + "s" * (n != 1)
