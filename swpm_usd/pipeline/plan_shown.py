"""The plan as a dry run and ``--explain`` show it (:func:`_plan_shown`): a line an asset, and each asset's
plan as :attr:`.run_result.RunResult.plan` holds it.

Separate from the runner: display only; the plan itself is :func:`.runner.plan`'s.
"""

from __future__ import annotations

import json

from .plan_item import PlanItem, _triangles_shown
from .reasons import shown as reasons_shown


def _plan_shown(picked: list[PlanItem], force: bool, because: dict[str, list], echo) -> list[dict]:
    """A dry run's or ``--explain``'s plan of the assets ``picked``: a line echoed for each (its encoding,
    parameters, state, triangles, instances, why and ``because``, its reasons to be built), and each as
    :attr:`.run_result.RunResult.plan` holds it."""
    planned = []
    for it in picked:
        state = "up to date" if it.up_to_date and not force else "to build"
        encoding, params = it.treatment.get("encoding"), it.treatment.get("params", {})  # (none: pending)
        reasons = because[it.asset.id]
        echo(
            f"{it.asset.id}: {encoding or '?'} "
            f"{json.dumps(params, sort_keys=True)} "
            f"[{state}] {_triangles_shown(it)} instances={it.asset.instances}; {it.why}"
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
                "why": it.why,
                "because": reasons,
            }
        )
    return planned


def _assets(n: int) -> str:
    return f"{n} asset" + "s" * (n != 1)
