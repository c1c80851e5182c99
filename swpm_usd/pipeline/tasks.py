"""The task a worker builds an asset from: a plain, picklable dict made from the asset's plan item.

:func:`_task` holds what :func:`.worker.process_asset` needs and nothing it would have to look up again:
the asset's files and the stat each was planned with (:func:`_planned_stats`: the worker fails an asset
whose input changed since), its treatment and digest, the config's checks, and whether its input failed to
load last time (:func:`_failed_loading`: no encoding warmed for it). Separate from the runner: the contract
between the run and its workers, which a Dask worker on another machine receives as it is.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .assets import output_names
from .config import Config
from .file_hash import STAT_KEYS
from .inputs import _is_recorded_path
from .rules import _max_triangles, _routes_by_triangles

if TYPE_CHECKING:
    from .plan_item import PlanItem


def _task(cfg: Config, item: PlanItem) -> dict[str, Any]:
    from ..usd.probe import cleared

    out = cfg.data["output"]
    return {
        "id": item.asset.id,
        "path": str(item.asset.path),
        "prim": item.asset.prim,
        "instances": item.asset.instances,
        "stem": item.asset.output_stem,
        # (recorded with the outputs: what named them, for a later run's account of files left at old names)
        "output_names": output_names(cfg),
        "digest": item.digest,
        "encoding": item.treatment.get("encoding"),
        "params": item.treatment.get("params", {}),
        "why": item.why,
        "streaming": cfg.data.get("streaming", {}),
        "budgets": cfg.data.get("budgets", {}),
        "max_triangles": _max_triangles(cfg),
        "out_dir": str(cfg.base / out["dir"]),
        "write_swpm": bool(out.get("swpm", True)),
        "write_usd": bool(out.get("usd", False)),
        # the .swpm in the layout a reader before 0.9.0 accepts (no OFFSET32: encode_bytes' legacy)
        "legacy_layout": bool(out.get("legacy_layout", False)),
        "input_digest": item.input_digest,
        # the files the asset is read from (its own first, then a glTF's buffers, a stage's layers): the
        # worker fails it when one changes while it reads them
        "inputs": [str(p) for p in item.inputs] or [str(item.asset.path)],
        # the stat of each input as the plan hashed it (or trusted it unread): the worker fails the asset when
        # the file it loads is another (its digest would be of bytes it was not built from)
        "input_stats": _planned_stats(cfg, item),
        # the count its rule was chosen by, when a rule matches on triangles: an input changed since the plan
        # is built from the bytes loaded when they hold as many (else its rule may be another's)
        "rule_triangles": item.triangles if not item.rule_pending and _routes_by_triangles(cfg) else None,
        # a pending rule: the worker runs match_rule on the config (plain data, picklable)
        "config_data": cfg.data if item.rule_pending else None,
        "config_path": str(cfg.path),
        "tags": item.asset.tags,
        # a crate file the planning probed clean (it opened the stage): the worker does not probe it again
        "probed": cleared(item.asset.path),
        # its input failed to load last time, and is the same file: no encoding or USD to warm for it
        "failed_loading": _failed_loading(item),
    }


def _planned_stats(cfg: Config, item: PlanItem) -> dict[str, list[int] | None]:
    """Each input's size and :data:`.file_hash.STAT_KEYS` as the plan hashed (or trusted) it, by path; None
    for an input it has none for (hashed while it changed, unreadable: its digest is of no bytes the worker
    loads); none when the entries are not the inputs'."""
    entries, paths = item.input_stats, item.inputs or [item.asset.path]
    if len(entries) != len(paths) or not all(
        _is_recorded_path(e["path"], p, cfg.base) for p, e in zip(paths, entries, strict=True)
    ):
        return {}
    return {
        str(p): [e["size"], *(e[k] for k in STAT_KEYS)]
        if "size" in e and all(k in e for k in STAT_KEYS)
        else None
        for p, e in zip(paths, entries, strict=True)
    }


def _failed_loading(item: PlanItem) -> bool:
    """Did ``item``'s asset fail last run before its mesh was loaded (a broken file: no ``triangles_in``),
    with the input digest it has now? Its retry most likely fails the same way, before any build."""
    prev = item.previous
    return (
        isinstance(prev, dict)
        and prev.get("status") == "failed"
        and "triangles_in" not in prev
        and prev.get("input_digest") == item.input_digest
    )
