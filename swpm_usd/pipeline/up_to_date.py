"""Whether a planned asset's build is current (:func:`_decide`): its record's digest and checks, the budgets
it passed, the outputs the config asks for, each still as recorded; when it is not, why it is built again.

Separate from the runner: the decision of :func:`.runner.plan` for one asset once its rule, treatment and
digest are known; :func:`.runner.plan` finds those (hashing the inputs, counting the triangles).
"""

from __future__ import annotations

from pathlib import Path

from .assets import checks_no_stricter, checks_of
from .config import Config
from .outputs import _checked_output
from .plan_item import PlanItem
from .reasons import build_reasons
from .rules import (
    _output_names_current,
    _swpm_layout_current,
    _total_fits,
    _wanted_outputs,
    _wants_outputs,
    _within_triangle_budget,
)
from .scene import _layer_with_units


def _decide(
    cfg: Config,
    item: PlanItem,
    prev: dict,
    out_dir: Path,
    verify: bool,
    version_then: str | None,
    ignored: str | None,
) -> None:
    """Set ``item.up_to_date`` from its manifest record ``prev`` ({} for none), ``item.checked_outputs``
    where checking its outputs changed their records, and ``item.because`` (its reasons to be built) when
    it is not up to date. ``version_then``: the manifest's tool version; ``ignored``: why its record was
    ignored (:func:`.records.record_problem`), else None."""
    outs = prev.get("outputs", {})
    item.up_to_date = (
        prev.get("status") == "built"
        and prev.get("digest") == item.digest
        # (auto's checks are in its digest; another encoding passes limits as loose as it passed before)
        and (
            item.treatment.get("encoding") == "auto"
            or checks_no_stricter(checks_of(cfg.data), prev.get("checks"))
        )
        and _total_fits(cfg, prev, item)
        and _within_triangle_budget(cfg, prev)
        and bool(outs) == _wants_outputs(cfg)
        # (an output the config asks for that the build did not write: `usd: true` added since)
        and _wanted_outputs(cfg) <= set(outs)
        # (a .swpm of the other layout: `legacy_layout` flipped since)
        and _swpm_layout_current(cfg, outs)
        # (outputs at the other names: `output.names` flipped since)
        and _output_names_current(cfg, item, outs)
    )
    checked = None  # (the outputs, once the rest is current: their reasons, should they not be)
    units_ok = True
    if item.up_to_date:
        checked = {kind: _checked_output(out_dir / o["path"], o, verify) for kind, o in outs.items()}
        # (an output of a kind the config no longer asks for, deleted or changed since: no longer the
        # run's, it leaves the record; the build is still current; `usd: false`, then the layers deleted)
        wanted = _wanted_outputs(cfg)
        item.up_to_date = all(o is not None for kind, o in checked.items() if kind in wanted)
        if item.up_to_date and any(checked[kind] is not o for kind, o in outs.items()):
            item.checked_outputs = {kind: o for kind, o in checked.items() if o is not None}
        layer = checked.get("usd")
        if item.up_to_date and layer is not None:
            with_units = _layer_with_units(out_dir, layer)
            item.up_to_date = units_ok = with_units is not None  # (else rebuilt, its units recorded)
            if with_units is not None and with_units is not layer:
                kept = item.checked_outputs if item.checked_outputs is not None else dict(outs)
                item.checked_outputs = {**kept, "usd": with_units}
    if not item.up_to_date:  # (the decision is taken: its reasons, for the plan lines and the report)
        item.because = build_reasons(cfg, item, version_then, out_dir, ignored, checked, units_ok)
