"""The manifest records a run keeps, replaces and compares (:func:`_records_kept`, :func:`_same_failure`),
and the orphans and loader warnings as its result names them.

Separate from the runner: each is a pure function of the records, the plan and the config, where the
runner decides when to call them.
"""

from __future__ import annotations

from .assets import Asset
from .config import Config
from .inputs import _listing_mark, _with_inputs
from .outputs import ORPHAN_ASSET, ORPHAN_BECAUSE
from .plan_item import PlanItem
from .rules import _current_why, _rule_name


def _records_kept(
    cfg: Config, manifest: dict, items: list[PlanItem], picked: list[PlanItem], force: bool
) -> dict[str, dict]:
    """The manifest records a run that builds keeps before it builds: those of the config's assets it can
    use (not a hand-edited one: see :func:`.runner.plan`), an up-to-date picked asset's brought up to date
    itself (its ``last_failure`` dropped, its outputs' stat, rule, why, digest, instances and inputs as the
    plan found them); the records of the assets to build are replaced as each finishes."""
    # (the records of current assets the run can use: a hand-edited one is ignored, see plan)
    usable = {it.asset.id for it in items if it.previous is not None}
    records = {k: v for k, v in manifest.get("assets", {}).items() if k in usable}
    for it in picked:  # (an asset not selected keeps its record as it is, up to date or not)
        kept = records.get(it.asset.id)
        if not it.up_to_date or force or kept is None:
            continue
        if "last_failure" in kept:  # up to date again (an input or a config put back): another's failure
            kept = records[it.asset.id] = {k: v for k, v in kept.items() if k != "last_failure"}
        if it.checked_outputs is not None:  # hashed, and their stat recorded anew
            kept = records[it.asset.id] = {**kept, "outputs": it.checked_outputs}
        rule, why = _rule_name(cfg, it), _current_why(kept.get("why"), it)
        if kept.get("rule") != rule or kept.get("why") != why:
            # another rule (renamed, reordered, added) now gives the asset the same treatment: the build is
            # current, and its record names the rule that chose it today (the report shows it)
            kept = records[it.asset.id] = {**kept, "rule": rule, "why": why}
        if kept.get("digest") != it.digest:  # (of a version whose digest held the count: as it is now)
            kept = records[it.asset.id] = {**kept, "digest": it.digest}
        if "instances" in kept and kept["instances"] != it.asset.instances:
            # (another instance count, the same build: an encoding other than auto; the report shows it)
            kept = records[it.asset.id] = {**kept, "instances": it.asset.instances}
        if it.input_stats is not kept.get("inputs") or _listing_mark(kept) != it.inputs_listed:
            # hashed (to the recorded digest): their stat anew; or listed by reading the file (the record
            # of an older version): marked as a list the next run may take
            records[it.asset.id] = _with_inputs(kept, it)
    return records


def _orphan_named(o: dict) -> dict:
    """An orphan's record as a :class:`.run_result.RunResult` names it: its path, asset and why it is left."""
    return {k: o[k] for k in ("path", ORPHAN_ASSET, ORPHAN_BECAUSE)}


def _warnings_named(warnings: list[str], asset: Asset) -> list[str]:
    """``warnings`` with the asset's input file named by its path relative to the config (its id's), where
    they name it by the absolute path its worker loaded."""
    return [w.replace(str(asset.path), asset.file_id) for w in warnings]


def _failed_before(record: dict | None) -> bool:
    """Did the asset of manifest record ``record`` fail in the run that wrote it (a failed record, or a
    build kept with its ``last_failure``)? Only such an asset can fail again with its record unchanged."""
    return isinstance(record, dict) and (record.get("status") == "failed" or "last_failure" in record)


def _same_failure(before: dict | None, after: dict) -> bool:
    """Is ``after``, the record of an asset that failed again, ``before`` (its manifest record) but for the
    seconds the attempt took: the same error, traceback, digests and inputs, the same previous build
    kept? Then the record stays as it was and the run writes nothing for it."""

    def timeless(rec: dict) -> dict:
        out = {k: v for k, v in rec.items() if k != "seconds"}
        if isinstance(out.get("last_failure"), dict):
            out["last_failure"] = {k: v for k, v in out["last_failure"].items() if k != "seconds"}
        return out

    return before is not None and _failed_before(before) and timeless(before) == timeless(after)
