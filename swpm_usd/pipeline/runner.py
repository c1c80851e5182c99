"""``swpm-pipeline run``: plan every asset, skip what is up to date, run the rest on an executor, record.

This module is the orchestration: :func:`plan` decides what each asset needs, :func:`execute` runs the tasks,
:func:`run` holds the steps together and records. What they call lives beside it: :mod:`.manifest` (the file,
read and written fast), :mod:`.inputs` (which inputs are as recorded), :mod:`.rules` (an asset's rule, and
whether its build is still current), :mod:`.tasks` (what a worker gets), :mod:`.pool` (the worker processes
and their fork server), :mod:`.outputs` (the files in output.dir: checked, cleaned up, kept), :mod:`.lock`
(one run at a time in an output folder), :mod:`.scene` (scene.usda), :mod:`.progress` and :mod:`.interrupts`
(Ctrl-C), :mod:`.reasons` (why the plan builds an asset again: shown, never deciding), :mod:`.selection`
(which assets ``only`` picks), :mod:`.plan_item` (an asset's plan, the type those parts take).

The run manifest (``<output>/manifest.json``) is rewritten atomically as assets finish (at most once a second,
and at once when the run ends, fails or is stopped with Ctrl-C), so an interrupted run keeps every earlier
result (a kill loses at most the last second's) and a rerun only does what is left. An asset is up to date
when the digest of its input files, its resolved rule, parameters (defaults filled in, so writing one out
rebuilds nothing) and the tool version equal the manifest's (for ``encoding: auto`` also the budgets and
streaming policy it chose by), the budgets and streaming limits are as loose as those it passed
(:func:`.assets.checks_no_stricter`: loosening a budget rebuilds nothing, tightening one checks again), and
its outputs are those the config asks for and still as recorded (their size and stat, else their sha256:
:func:`.outputs._checked_output`). The digest of its inputs is the recorded one, without reading them, when
they are the recorded files with the size and stat recorded as they were hashed, taken a while after their
last change (:func:`.inputs._inputs_unchanged`), else they are hashed (and recorded anew); ``verify`` hashes
every input and output. A record the run does not write (a hand edit) is ignored, with a warning.

An asset whose rebuild fails keeps its previous build when that build's outputs are intact
(:func:`.outputs._keep_previous`): the manifest keeps its record (with ``last_failure``), the scene its layer,
and the run reports it failed. One run at a time writes in an output folder (:class:`.lock._OutputLock`). The
outputs of assets no longer in the config, and those a rebuild no longer writes (at the names ``output.names``
gave before, of a kind no longer asked for), are left and named, each with its asset and why
(:data:`.outputs.ORPHAN_REASONS`), and recorded under ``orphaned_outputs`` until a run with ``prune`` deletes
them (:func:`.outputs._orphaned_outputs`).

``only`` (``--only PATTERN``): the run plans every asset as ever (its warnings, name collisions and orphans
are the whole config's), then builds only the assets it selects (:func:`selected_ids`) that are not up to date
(with ``force``, each of those); the records of the others stay as they are, and the scene and report are
written from the whole manifest.

A run that builds and prunes nothing, whose failures each fail again as recorded (:func:`_same_failure`:
retried, their records kept), and whose manifest would hold what it holds, writes neither it nor scene.usda
nor report.html: those were written from these records (their ``run_outputs`` records marked
:data:`.manifest.CURRENT`) and are kept while they are as recorded (10,000 assets: a 47 MB manifest, 2.2 s to
write), the report while it names the config where it is now (:data:`.manifest.REPORT_CONFIG`: a project moved
whole has its report and manifest written); nor the lock file, which holds the pid of the last run that wrote
(:meth:`.lock._OutputLock.claim`).
"""

from __future__ import annotations

import contextlib
import gc
import json
import os
import time
from collections.abc import Generator, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import __version__
from ..errors import MissingExtraError
from .assets import (
    Asset,
    checks_no_stricter,
    checks_of,
    discover,
    hash_inputs,
    match_rule,
    output_dir,
)
from .config import Config, ConfigError, load_config
from .inputs import INPUTS_LISTED as INPUTS_LISTED  # (re-exported)
from .inputs import LISTING as LISTING  # (re-exported)
from .inputs import (
    _input_size,
    _inputs_unchanged,
    _listed_inputs,
    _listing_mark,
    _recorded_paths,
    _same_stat,
    _with_inputs,
    recorded_path,
)
from .interrupts import _interrupts_ignored, _interrupts_noted
from .lock import LOCK as LOCK  # (re-exported)
from .lock import _OutputLock
from .manifest import (
    _RUN_OUTPUT_DEFAULTS,
    _RUN_OUTPUT_FILES,
    CURRENT,
    MANIFEST,
    ORPHANED,
    REPORT_CONFIG,
    RUN_OUTPUTS,
    _asks_for,
    _config_ref,
    _ManifestText,
    _read_manifest,
    _recorded_output_paths,
    _shared_with,
    _write_manifest,
)
from .manifest import INPUT_LISTS as INPUT_LISTS  # (re-exported)
from .manifest import INPUTS_REF as INPUTS_REF  # (re-exported)
from .outputs import (
    ORPHAN_ASSET,
    ORPHAN_BECAUSE,
    _checked_output,
    _clean_after_worker,
    _complete_output_record,
    _dropped_outputs,
    _file_key,
    _files_kept,
    _keep_previous,
    _left_by_rebuilds,
    _make_out_dir,
    _orphaned_outputs,
    _overwritten_inputs,
    _rel,
    _remove_temporary,
    _restore_kept_aside,
    _unusable_out_dir,
    orphan_line,
)
from .outputs import planned_outputs as planned_outputs  # (re-exported)
from .plan_item import TRIANGLE_COUNTS as TRIANGLE_COUNTS  # (re-exported)
from .plan_item import PlanItem as PlanItem  # (re-exported)
from .plan_item import _triangles_shown
from .pool import (
    _TRIMESH_PRELOAD,
    _environ,
    _forkserver_pid,
    _forkserver_preload,
    _forkserver_ready,
    _local_pool,
    _server_import_path,
    _stop_forkserver,
    _warm_encodings,
)
from .progress import _Progress
from .reasons import build_reasons, counted, reason
from .reasons import shown as reasons_shown
from .records import record_problem, recorded_inputs
from .rules import (
    _current_why,
    _max_triangles,
    _names_moved,
    _output_names_current,
    _routes_by_triangles,
    _rule_name,
    _rules_pending,
    _same_rule_from,
    _swpm_layout_current,
    _total_fits,
    _treatment_digest,
    _unreached_rules,
    _wanted_outputs,
    _wants_outputs,
    _within_triangle_budget,
)
from .scene import SCENE_METERS_PER_UNIT as SCENE_METERS_PER_UNIT  # (re-exported)
from .scene import SCENE_UP_AXIS as SCENE_UP_AXIS  # (re-exported)
from .scene import UNITS_OP as UNITS_OP  # (re-exported)
from .scene import UP_AXIS_OP as UP_AXIS_OP  # (re-exported)
from .scene import UTF8_PRIM_NAMES, _layer_with_units, _scene_stems, _utf8_named, _write_scene
from .selection import SelectionConflictError, _selection_clashes, selected_ids
from .selection import SelectionError as SelectionError  # (re-exported: swpm_usd.pipeline's)
from .tasks import _task
from .worker import (
    RUNNER_PID_ENV,
    WARM_ENCODINGS_ENV,
    output_record,
    process_asset,
)

#: the manifest is rewritten at most this often during a run, or less often while one rewrite takes more
#: than 1/_MANIFEST_BACKOFF of it: rewriting it after every asset, each time serialising every record, made
#: a run of 1,500 small assets spend about 380 of its 461 s writing JSON (a 6 MB manifest, 1,500 times; 82 s
#: then). With a fifth, the share of a run spent rewriting grew with the asset count up to a sixth (10,000
#: small assets, a 47 MB manifest at 0.3-0.5 s a write, --jobs 2: 162 writes, 27 s of 218, a core the two
#: workers then shared): a twentieth keeps it under 5 %; a run killed outright (Ctrl-C and errors write it
#: at once) has at most 20 rewrite times of finished assets to build again
_MANIFEST_EVERY_S = 1.0
_MANIFEST_BACKOFF = 20


@dataclass
class RunResult:
    records: dict[str, dict]
    built: int
    skipped: int
    failed: int
    warnings: list[str]
    seconds: float
    manifest_path: Path
    plan: list[dict] = field(default_factory=list)  # --dry-run / --explain: each asset's plan
    #: this run's failures: asset id -> the failed attempt's record (``error``, ``traceback``, ...), with
    #: ``kept_previous`` True when the asset's previous build was kept (see :func:`.outputs._keep_previous`)
    failures: dict[str, dict] = field(default_factory=dict)
    #: the outputs of assets no longer in the config: deleted (``prune``), or left in output.dir and named
    #: here, as output.dir-relative paths (a dry run names what ``prune`` would delete)
    pruned: list[str] = field(default_factory=list)
    unlisted: list[str] = field(default_factory=list)
    #: the ids of the assets this run built (``built`` counts them), in the order they finished
    built_ids: list[str] = field(default_factory=list)
    #: why each asset this run built or tried (a dry run: would build) was to be built: asset id -> its
    #: reasons (:func:`.reasons.build_reasons`, ``forced`` first with ``--force``)
    because: dict[str, list[dict[str, str]]] = field(default_factory=dict)
    #: the assets of the config that ``only`` left out (not built, not counted in ``skipped``, not planned)
    not_selected: int = 0
    #: each output of ``pruned`` or ``unlisted`` (in their order), named: ``{"path", "asset", "because":
    #: {"code", "detail"}}`` (:data:`.outputs.ORPHAN_REASONS`: its asset removed, or rebuilt under other
    #: names, ...; ``asset`` None for scene.usda or report.html)
    orphans: list[dict] = field(default_factory=list)

    def orphans_counted(self) -> list[tuple[int, str, str]]:
        """How many of :attr:`orphans` have each reason and detail: (count, code, detail), in the order
        first found (:func:`.outputs.orphan_phrase` says each)."""
        counts: dict[tuple[str, str], int] = {}
        for o in self.orphans:
            key = (o["because"]["code"], o["because"]["detail"])
            counts[key] = counts.get(key, 0) + 1
        return [(n, code, detail) for (code, detail), n in counts.items()]

    @property
    def built_because(self) -> dict[str, int]:
        """How many of the assets built had each reason (code -> count, in the order of
        :data:`.reasons.REASONS`; an asset with two reasons counts in both)."""
        return counted([self.because.get(aid, []) for aid in self.built_ids])


def _count_triangles(asset: Asset, max_triangles: int | None = None, data: bytes = b"") -> int:
    """The triangles of ``asset``'s mesh, loaded; ``data``, when not empty, its OBJ file's bytes as
    :func:`.io.early_triangle_count_and_data` read them (not read again)."""
    from ..io import load_mesh

    mesh = load_mesh(asset.path, prim_path=asset.prim, max_triangles=max_triangles, data=data)
    return mesh.triangle_count


def plan(
    cfg: Config,
    manifest: dict,
    count_triangles: bool = True,
    verify: bool = False,
    early_counts: bool = False,
    only: list[str] | None = None,
) -> tuple[list[PlanItem], list[str], list[str]]:
    """Resolve each asset's rule and parameters; (items, errors, warnings).

    ``only`` (``run --only``'s patterns): checked against the asset ids as soon as :func:`.assets.discover`
    has found them, before any input is hashed or its mesh loaded (:func:`.selection.selected_ids` raises
    :class:`.selection.SelectionError` for one that matches none: every asset was hashed and planned first,
    400 copies of a 2.4 MB OBJ under a rule on triangles, a dry run: 15.3 s, now 0.40 s), unless the config
    has problems (its :class:`.config.ConfigError` comes first, as it did). Every asset is still planned.

    Rules on triangle counts need the count of every new or changed asset. ``count_triangles=False``
    leaves those items ``rule_pending`` (their rule, treatment and digest empty, never up to date): the
    worker that builds the asset loads it anyway and chooses the rule then, so the main process does not
    load every new asset a second time, one after another (1,000 small assets: 10 of 46 s).
    ``early_counts`` (a dry run, which builds nothing from the plan): the count a file tells before its
    geometry is read (:func:`.io.early_triangle_count`; ``triangles_how`` says which) where it tells one,
    else it is loaded.

    An asset's input digest is its record's when its input files are as recorded
    (:func:`.inputs._inputs_unchanged`), else they are hashed (:func:`.assets.hash_inputs`, the item's
    ``input_stats`` then those of the files hashed, which the run records); its recorded outputs are intact
    when their size and stat are as recorded, or else their sha256 (:func:`.outputs._checked_output`).
    ``verify`` hashes every input and output. A manifest record that is not one the run writes
    (:func:`.records.record_problem`: hand-edited) is ignored, as if the asset had none, and named in a
    warning."""
    out_dir = output_dir(cfg)
    known = manifest.get("assets", {})
    reused: set[str] = set()  # the assets whose inputs are their record's (as recorded: not read)

    def listed(aid: str, path: Path) -> list[Path] | None:
        found = None if verify else _listed_inputs(path, known.get(aid), cfg.base)
        if found is not None:
            reused.add(aid)
        return found

    settled: set[str] = set()  # the assets whose inputs their record may keep for reuse
    aliases: list[str] = []  # (warnings: a matched link to another matched file, one asset)
    assets, inputs, problems = discover(
        cfg, _recorded_output_paths(out_dir, manifest), listed, settled, aliases
    )
    problems.extend(_unusable_out_dir(cfg, out_dir))
    problems.extend(_overwritten_inputs(cfg, out_dir, assets, inputs))
    if only and not problems:
        selected_ids((a.id for a in assets), only)  # (raises for a pattern that matches no asset)
    items = []
    record_warnings = []
    needs_rule_on_triangles = _routes_by_triangles(cfg)
    # input paths -> (digest, entries) hashed by this plan: the prims of one stage share its layers
    hashed: dict[tuple[Path, ...], tuple[str, list[dict]]] = {}
    # the prims of one stage share its list of layers (discover's) and their records one list of entries
    # (read_manifest's): each pair checked once a run (its files stat'ed once), not once a prim (1,000 prims
    # of a 51-layer stage: 51,000 stats and path comparisons, a third of a no-change rerun). Keyed by the
    # lists' ids, each entry holding its lists so no id is reused while the plan runs
    checked_inputs: dict[tuple[int, int], tuple[list, list, bool]] = {}
    valid_inputs: dict[int, tuple[Any, list[dict] | None]] = {}  # id(a record's inputs) -> recorded_inputs

    def recorded_of(rec: dict) -> list[dict] | None:
        listed = rec.get("inputs")
        hit = valid_inputs.get(id(listed))
        if hit is None or hit[0] is not listed:
            hit = valid_inputs[id(listed)] = (listed, recorded_inputs(rec))
        return hit[1]

    def unchanged(paths: list[Path], entries: list[dict] | None) -> bool:
        if entries is None:
            return False
        hit = checked_inputs.get((id(paths), id(entries)))
        if hit is None or hit[0] is not paths or hit[1] is not entries:
            hit = (paths, entries, _inputs_unchanged(paths, entries, cfg.base))
            checked_inputs[(id(paths), id(entries))] = hit
        return hit[2]

    version_then = manifest.get("tool_version")
    for a in assets:
        previous = known.get(a.id)
        ignored = None  # (why its record is ignored)
        if a.id in known and (problem := record_problem(previous)) is not None:
            ignored = problem
            record_warnings.append(
                f"{_rel(cfg, out_dir / MANIFEST)}: the record of {a.id} is not one this tool writes "
                f"({problem}); it is ignored and the asset built again"
            )
            previous = None
        prev = previous or {}
        # (a failed asset's record need not have its input digest: record_problem checks its type alone)
        recorded = None if "input_digest" not in prev else recorded_of(prev)
        # (inputs listed from the record: as recorded)
        reuse = not verify and a.id in reused and previous is not None
        trusted = not reuse and unchanged(inputs[a.id], recorded)
        if reuse or (trusted and not verify):
            digest, input_stats = prev["input_digest"], recorded
        else:
            key = tuple(inputs[a.id])
            if key not in hashed:
                try:
                    found_digest, entries = hash_inputs(inputs[a.id])
                    hashed[key] = (found_digest, _recorded_paths(cfg.base, entries))
                except OSError as exc:
                    # gone since it was listed, or unreadable: the asset is built and fails there with
                    # its loader's error naming the file, while the others run. The digest matches no
                    # record and no stat is recorded, so the next run hashes it again
                    unread = [{"path": recorded_path(cfg.base, p)} for p in inputs[a.id]]
                    hashed[key] = (f"unreadable: {exc}", unread)
            digest, input_stats = hashed[key]
            if trusted and digest == prev["input_digest"] and _same_stat(input_stats, recorded):
                # (verify: the bytes a run would have trusted unread are the recorded ones, their stat as
                # recorded: the record stands as it is, not rewritten for a new hashed_ns)
                input_stats = recorded
        tri = prev.get("triangles_in") if prev.get("input_digest") == digest else None
        how = "exact" if tri is not None or needs_rule_on_triangles else "not needed"
        if tri is None and needs_rule_on_triangles:
            if not count_triangles:
                items.append(
                    PlanItem(
                        a,
                        digest,
                        None,
                        why="rule chosen by the worker",
                        rule_pending=True,
                        inputs=inputs[a.id],
                        previous=previous,
                        input_stats=input_stats,
                        inputs_listed=a.id in settled,
                    )
                )
                items[-1].because = build_reasons(cfg, items[-1], version_then, out_dir, ignored)
                continue
            early, data = None, b""
            if early_counts:  # (an OBJ's bytes kept: loaded from them below, not read twice)
                from ..io import early_triangle_count_and_data

                early, data = early_triangle_count_and_data(a.path, prim_path=a.prim)
            if early is not None and not early[1] and not _same_rule_from(cfg, a, early[0]):
                early = None  # (a lower bound under a rule's max: the count it routes by is loaded)
            if early is not None:
                data = b""  # (not loaded: released before the next asset's file is read)
                tri, how = early[0], "declared before cleaning" if early[1] else "lower bound"
            else:
                try:
                    tri = _count_triangles(a, _max_triangles(cfg), data)
                except Exception as exc:  # noqa: BLE001 - the worker reports it as this asset's failure
                    # routed as the run routes it: by the worker, once the file loads (it was routed as if
                    # it held 0 triangles, a rule the run never gave it). Its build fails unless it loads then
                    items.append(
                        PlanItem(
                            a,
                            digest,
                            None,
                            why=f"rule chosen by the worker: the file did not load to count its triangles "
                            f"({type(exc).__name__}: {exc})",
                            rule_pending=True,
                            inputs=inputs[a.id],
                            previous=previous,
                            input_stats=input_stats,
                            inputs_listed=a.id in settled,
                            triangles_how="unknown",
                        )
                    )
                    items[-1].because = build_reasons(cfg, items[-1], version_then, out_dir, ignored)
                    continue
                finally:
                    data = b""  # (released before the next asset's file is read)
        item = PlanItem(
            a,
            digest,
            tri,
            inputs=inputs[a.id],
            previous=previous,
            input_stats=input_stats,
            inputs_listed=a.id in settled,
            triangles_how=how,
        )
        item.rule, item.treatment, item.why = match_rule(cfg, a, tri if tri is not None else 0)
        item.digest = _treatment_digest(cfg, item)
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
        items.append(item)
    warnings = [] if _rules_pending(items, dry_run=early_counts) else _unreached_rules(cfg, items)
    return items, problems, aliases + record_warnings + warnings


def require_dask() -> None:
    """Raise :class:`..errors.MissingExtraError` unless dask's distributed scheduler imports (the ``dask``
    extra): it was a ``ConfigError`` (``CONFIG_INVALID``, exit 2), raised once every input was hashed and
    planned, of a config that was valid."""
    try:
        import dask.distributed  # noqa: F401 - (imported to see that it is installed)
    except ImportError as exc:
        raise MissingExtraError("--executor dask", "dask", exc) from None


def execute(
    tasks: list[dict], jobs: int, executor: str, scheduler: str | None, limit_s: float | None = None
) -> Generator[dict, None, None]:
    """Run tasks, yielding each record as it finishes (order of completion).

    ``limit_s`` (``limits.seconds``): an asset still building after that many seconds has its worker stopped
    and fails; the other assets go on. With it, ``--jobs 1`` builds in a worker process too (a build in this
    process cannot be stopped)."""
    if not tasks:
        return
    if executor == "dask":
        if limit_s is not None:
            raise ValueError("limit_s needs the local executor (a Dask task cannot be stopped)")
        require_dask()
        from dask.distributed import Client, LocalCluster, as_completed

        cluster = None
        if scheduler:
            client = Client(scheduler)
        else:
            workers = max(1, min(jobs, len(tasks)))  # (no worker with nothing to do)
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True)
            client = Client(cluster)
        try:
            futures = client.map(process_asset, tasks, pure=False)
            for fut in as_completed(futures):
                yield fut.result()
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
        return
    if jobs <= 1 and limit_s is None:
        with _interrupts_noted() as noted:
            for t in tasks:
                rec = process_asset(t)
                # compiled code turns a Ctrl-C into another error (numba: SystemError), an import it cut short
                # into errors after it, a library may swallow it: an asset done across a Ctrl-C is not
                # recorded (its outputs are whole files, which the next run checks and builds again)
                if noted:
                    raise KeyboardInterrupt
                yield rec
        return
    import multiprocessing as mp

    # workers fork from a server that has imported the package once (fast start, no inherited threads)
    ctx = mp.get_context("forkserver" if "forkserver" in mp.get_all_start_methods() else "spawn")
    if ctx.get_start_method() == "forkserver":
        warm, preload = _warm_encodings(tasks), _forkserver_preload(tasks)
        given = _SERVER_GIVEN.get(_forkserver_pid())
        # (trimesh alone missing is no reason to start it again: each worker imports it, ~0.6 s in parallel,
        # where a new server's warm-up costs seconds first)
        needed = {m for m in preload if m not in _TRIMESH_PRELOAD}
        if given is not None and not (set(warm) <= set(given[0]) and needed <= set(given[1])):
            # the server of an earlier run in this process warmed or preloaded less than this run uses (it
            # kept them: a first run retrying broken inputs alone left every later run's workers cold): a
            # new one, with both runs' (the pool's workers fork from it, never from the one it replaces)
            warm = [*given[0], *(e for e in warm if e not in given[0])]
            preload = [*given[1], *(m for m in preload if m not in given[1])]
            with _interrupts_ignored():
                _stop_forkserver()
        ctx.set_forkserver_preload(preload)  # loaded once, inherited
        # started with Ctrl-C ignored, which the server (warming up) and every worker it forks inherit: a
        # Ctrl-C is the main process's alone (each worker ignores it itself too: spawn)
        with (
            _interrupts_ignored(),
            _environ(WARM_ENCODINGS_ENV, ",".join(warm)),
            _environ(RUNNER_PID_ENV, str(os.getpid())),  # (a server reparented at its start ends: ._warm)
            # (the runner's import path, not the current folder's modules: _server_import_path)
            _environ("PYTHONSAFEPATH", "1"),
            _environ("PYTHONPATH", _server_import_path()),
        ):
            from multiprocessing import forkserver

            forkserver.ensure_running()
        if (pid := _forkserver_pid()) is not None and pid not in _SERVER_GIVEN:
            _SERVER_GIVEN.clear()  # (one server at a time)
            _SERVER_GIVEN[pid] = (warm, preload)
        _forkserver_ready(ctx)
    yield from _local_pool(tasks, max(1, jobs), ctx, limit_s)


#: the fork server this process started (its pid) -> (the encodings it warmed, the modules it preloaded): a
#: server outlives the run that started it, and serves the later runs of the process (:func:`execute`)
_SERVER_GIVEN: dict[int, tuple[list[str], list[str]]] = {}


def run(
    config_path: str | Path,
    *,
    jobs: int = 1,
    executor: str = "local",
    scheduler: str | None = None,
    dry_run: bool = False,
    explain: bool = False,
    force: bool = False,
    prune: bool = False,
    echo=print,
    verify: bool = False,
    only: Iterable[str] | None = None,
) -> RunResult:
    """Run the pipeline described by ``config_path``; see the module docstring.

    ``only``: patterns (:func:`selected_ids`) choosing the assets built (and listed by ``dry_run`` and
    ``explain``); None or empty: every asset. Every asset is planned as without it; the records of the
    others stay as they are; ``RunResult.not_selected`` counts them. A pattern that matches no asset raises
    :class:`SelectionError` before the run builds or writes anything.

    ``prune``: delete the recorded outputs of assets the config no longer has (those still as the manifest
    recorded them and not outputs of this run's assets); without it they stay and the result names them.

    ``verify``: hash every input file and recorded output (sha256) to decide whether it changed, where a run
    otherwise trusts one whose size, mtime, ctime, inode and device are as recorded
    (:func:`.inputs._inputs_unchanged`, :func:`.outputs._checked_output`): a file whose bytes changed with
    none of those (a disk's silent corruption, a write within the timestamp granularity of the run's own) is
    found and its asset rebuilt.

    A run that writes (not ``dry_run``) holds output.dir's lock from before it reads the manifest (or, for
    an output.dir it creates, from then) to its end; another run there raises :class:`OutputLockedError`."""
    t_start = time.perf_counter()
    cfg = load_config(config_path)
    if executor == "dask" and not dry_run:  # (before the plan hashes the inputs: minutes on a large tree)
        require_dask()
    out_dir = output_dir(cfg)
    lock = _OutputLock(out_dir, echo)
    try:
        return _run(
            cfg,
            out_dir,
            lock,
            t_start,
            jobs,
            executor,
            scheduler,
            dry_run,
            explain,
            force,
            prune,
            echo,
            verify,
            [only] if isinstance(only, str) else list(only or ()),  # (one pattern, not its characters)
        )
    finally:
        lock.release()


@contextlib.contextmanager
def _gc_paused() -> Iterator[None]:
    """The cyclic garbage collector paused (then as it was): a rerun of 10,000 assets reads a 47 MB manifest
    and plans, allocating millions of objects (none garbage in a cycle) that its full collections traversed
    again and again: 0.4 of a 2.4 s rerun."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _run(
    cfg: Config,
    out_dir: Path,
    lock: _OutputLock,
    t_start: float,
    jobs: int,
    executor: str,
    scheduler: str | None,
    dry_run: bool,
    explain: bool,
    force: bool,
    prune: bool,
    echo,
    verify: bool = False,
    only: list[str] | None = None,
) -> RunResult:
    if not dry_run and out_dir.is_dir():
        lock.acquire()  # before the manifest is read: it is this run's from here on
    manifest_path = out_dir / MANIFEST
    unresolved: dict[str, str] = {}  # asset id -> why its record's inputs_ref names no list
    older: list[str] = []  # the records of an older manifest's lists, which a rewrite writes compact
    unreadable: list[str] = []  # why the file at the manifest's path is no manifest (cut, not JSON)
    with _gc_paused():
        manifest = previous = _read_manifest(manifest_path, unresolved, older, unreadable)
    if not dry_run and out_dir.is_dir():  # (the run's from here on: before the plan checks the outputs)
        _restore_kept_aside(out_dir, manifest["assets"])
    # (not while it loads meshes to count their triangles: a loader's garbage may be cyclic)
    dask_unlimited = executor == "dask" and "seconds" in cfg.data.get("limits", {})
    with contextlib.nullcontext() if dry_run or explain else _gc_paused():
        items, errors, warnings = plan(
            cfg,
            manifest,
            count_triangles=dry_run or explain,
            verify=verify,
            early_counts=dry_run,
            only=None if dask_unlimited else only,  # (a config error: raised first, as every other)
        )
    if dask_unlimited:
        errors = [*errors, "limits.seconds needs the local executor (--executor dask cannot stop an asset)"]
    if errors:
        raise ConfigError(errors)
    # (the patterns were checked once the plan discovered the ids, before it hashed an input: each matches
    # some; before any build or write; None: every asset)
    # (``items`` stay the whole config's: orphans, the outputs kept, the rules reached, the records kept)
    chosen = selected_ids((it.asset.id for it in items), only) if only else None
    picked = items if chosen is None else [it for it in items if it.asset.id in chosen]
    not_selected = len(items) - len(picked)
    if chosen is not None and (clashes := _selection_clashes(cfg, items, picked, force)):
        raise SelectionConflictError(clashes)
    # (no record to go by: every asset built again, and the outputs it recorded no longer known)
    lost = [
        f"{_rel(cfg, manifest_path)}: {why}; the run takes it for no manifest: every asset is built "
        "again, and the outputs it recorded are no longer known (not pruned)"
        for why in unreadable
    ]
    warnings = (
        lost
        + warnings
        + [  # (a hand edit: the inputs of a current asset's record hashed, not trusted)
            f"{_rel(cfg, manifest_path)}: the record of {it.asset.id} names no list of its inputs "
            f"({unresolved[it.asset.id]}); they are hashed"
            for it in items
            if it.asset.id in unresolved and it.previous is not None
        ]
    )
    if shared := _shared_with(cfg, manifest, items):
        warnings.append(
            f"{_rel(cfg, manifest_path)} was written by a run of another config ({shared[0]}): "
            f"{shared[1]} of its assets {'is' if shared[1] == 1 else 'are'} not in {cfg.shown or cfg.path} "
            f"and taken as removed (outputs {'deleted' if prune else 'left unlisted'}, rebuilt by that "
            "config's next run); give each config its own output.dir"
        )
    for w in warnings:
        echo(f"warning: {w}")
    # (before any build: a removed asset's output path may be a current asset's, which is never deleted)
    orphans = _orphaned_outputs(cfg, out_dir, manifest, items, verify)
    orphan_names = [o["path"] for _, o in orphans]
    orphan_lists = {"pruned" if prune else "unlisted": orphan_names}  # RunResult's fields
    # (each named: its asset and why it is left, in the order of orphan_names)
    orphan_records = [_orphan_named(o) for _, o in orphans]
    planned = []
    # each asset's reasons to be built (--force: every asset's first), none for one up to date
    because = {it.asset.id: ([reason("forced", "--force")] if force else []) + it.because for it in picked}
    if dry_run or explain:
        planned = _plan_shown(picked, force, because, echo)
        if chosen is not None:
            echo(f"{_assets(not_selected)} not selected by --only (of {len(items)}): not listed, not built")
        if dry_run:
            skipped = 0 if force else sum(i.up_to_date for i in picked)  # (force: each "to build")
            # (and a rebuild's old outputs, at names output.names moved or of a kind no longer asked for: the
            # run names them, and prune deletes them, once it is rebuilt; the plan said less than the run did)
            left = _left_by_rebuilds(cfg, out_dir, items, [it for it in picked if force or not it.up_to_date])
            orphan_names.extend(o["path"] for o in left)
            orphan_records.extend(_orphan_named(o) for o in left)
            for o in orphan_records:
                echo(orphan_line(o) + ("; --prune deletes it" * prune))
            to_build = {aid: found for aid, found in because.items() if found}
            return RunResult(
                {}, 0, skipped, 0, warnings, 0.0, manifest_path, planned, **orphan_lists, because=to_build,
                not_selected=not_selected, orphans=orphan_records,
            )  # fmt: skip
    _make_out_dir(cfg, out_dir)
    lock.acquire(folder_checked=True)  # (a folder this run created)
    _remove_temporary(out_dir)  # left by a killed run
    todo = [it for it in picked if force or not it.up_to_date]
    if prune and orphans:
        lock.claim()
        for path, _ in orphans:
            path.unlink(missing_ok=True)
    records = _records_kept(cfg, manifest, items, picked, force)
    run_outputs = {  # (the files still there until the run writes them anew: a stopped run records them)
        kind: o
        for kind, o in (
            manifest.get(RUN_OUTPUTS) if isinstance(manifest.get(RUN_OUTPUTS), dict) else {}
        ).items()
        if kind in _RUN_OUTPUT_DEFAULTS and _asks_for(cfg, kind)
    }
    manifest = {"tool_version": __version__, "config": _config_ref(cfg, out_dir), "assets": records}
    if orphans and not prune:  # so a later run with prune still finds them
        orphaned = {ORPHANED: [o for _, o in orphans]}
    else:
        orphaned = {}
    # no record changed, nothing pruned (the manifest but its run outputs as read): the scene and report
    # the last run wrote from these records, still as it recorded them, are kept while each asset to build
    # fails again as its record says it failed (:func:`_same_failure`: retried, as the README promises, and
    # nothing to write: 500 assets, 10 broken, a rerun rewrote the manifest, report and scene each time)
    settled = (
        not older
        and not (prune and orphans)
        and {**manifest, **orphaned} == {k: v for k, v in previous.items() if k != RUN_OUTPUTS}
    )
    unchanged = True  # (until a record changes: changed())
    if run_outputs:
        manifest[RUN_OUTPUTS] = run_outputs
    manifest.update(orphaned)

    def changed() -> None:
        """A record changes: the run writes here, and its scene and report are no longer those of the
        manifest's records (:data:`.manifest.CURRENT`)."""
        nonlocal unchanged, run_outputs
        if not unchanged:
            return
        unchanged = False
        lock.claim()  # (the run writes here: its pid in the lock file, for the message of a run it stops)
        run_outputs = {
            kind: {k: v for k, v in o.items() if k != CURRENT} if isinstance(o, dict) else o
            for kind, o in run_outputs.items()
        }
        if run_outputs:
            manifest[RUN_OUTPUTS] = run_outputs

    # (an asset that did not fail before, built or failing: the records change)
    if not settled or not all(_failed_before(records.get(it.asset.id)) for it in todo):
        changed()
    failed = 0
    built_ids: list[str] = []
    kept_files: set[tuple] | None = None  # (_files_kept, once an asset drops an output)
    failures: dict[str, dict] = {}
    progress = _Progress(len(todo))
    by_id = {it.asset.id: it for it in todo}
    last_write, write_s = float("-inf"), 0.0
    text = _ManifestText()
    results: Generator[dict, None, None] | None = None
    asset_warnings: list[str] = []

    def stop() -> None:
        """An error or Ctrl-C: the workers stopped, their temporary files deleted, every finished asset
        recorded (a second Ctrl-C does not cut this short: a pool's workers are stopped with it ignored)."""
        if results is not None:
            results.close()  # first: it restores the Ctrl-C handler it set (--jobs 1)
        with _interrupts_ignored():
            lock.claim()
            _restore_kept_aside(out_dir, records)  # (a worker stopped while it renamed outputs)
            _remove_temporary(out_dir)
            _write_manifest(manifest_path, manifest, text)

    try:
        # largest inputs first, so no worker is left with a big asset at the end (LPT scheduling)
        ordered = sorted(todo, key=lambda it: -_input_size(it.asset.path))
        limit_s = cfg.data.get("limits", {}).get("seconds")
        results = execute([_task(cfg, it) for it in ordered], jobs, executor, scheduler, limit_s)
        for rec in results:
            it = by_id[rec["id"]]
            if rec.pop("worker_lost", False):  # stopped or died mid-asset: what it left behind goes
                _clean_after_worker(out_dir, records, it.asset.output_stem)
            if it.rule_pending:
                it.rule = rec.pop("rule_index", None)
                it.triangles = rec.get("triangles_in")  # (known now: a shadowed rule is found by them)
            # (the stat of each input as it was hashed to this digest, never a later one: an input changed
            # since the plan, the worker hashed once it had loaded it, and its digest and stat are those)
            if "input_digest" in rec:
                it.input_digest = rec.pop("input_digest")
                it.input_stats = _recorded_paths(cfg.base, rec.pop("inputs"))
                it.digest = rec["digest"]
            rec = _with_inputs(rec, it)
            rec["rule"] = _rule_name(cfg, it)
            # (a loader's warnings, printed by the worker as it built, kept by the record and in --json's;
            # the input named as the config names it, not by the absolute path the worker loaded, so a
            # project moved keeps its records)
            if rec.get("warnings"):
                rec["warnings"] = _warnings_named(rec["warnings"], it.asset)
                asset_warnings.extend(rec["warnings"])
            for o in rec.get("outputs", {}).values():
                _complete_output_record(out_dir / o["path"], o)
            if rec["status"] == "built":
                built_ids.append(rec["id"])
                # (a kind of output the config no longer asks for, or one output.names moved: its old file
                # is named as the asset's, left behind, and pruned as a removed asset's output is)
                before = records.get(rec["id"])
                moved = _names_moved(cfg, it.asset, before)
                for path, o in _dropped_outputs(out_dir, before, rec, verify, it.asset.id, moved):
                    if kept_files is None:
                        kept_files = _files_kept(cfg, out_dir, items)
                    if _file_key(path) in kept_files:
                        continue
                    if prune:
                        path.unlink(missing_ok=True)
                    else:
                        manifest.setdefault(ORPHANED, []).append(o)
                    orphan_names.append(o["path"])
                    orphan_records.append(_orphan_named(o))
                records[rec["id"]] = rec
            else:
                failed += 1
                before = records.get(rec["id"])
                kept = _keep_previous(out_dir, before, rec, verify)
                after = rec if kept is None else kept
                if _same_failure(before, after):
                    after = before  # (its record as it was: the seconds it took aside, nothing changed)
                else:
                    changed()
                records[rec["id"]] = after
                rec = failures[rec["id"]] = {**rec, "kept_previous": kept is not None}
            if rec["status"] == "built":
                changed()
            now = time.perf_counter()
            # (unchanged: each asset so far failed again as recorded, nothing to write)
            if not unchanged and now - last_write >= max(_MANIFEST_EVERY_S, _MANIFEST_BACKOFF * write_s):
                _write_manifest(manifest_path, manifest, text)
                last_write = time.perf_counter()
                write_s = last_write - now
            progress.advance(rec, str(it.asset.path))
    except BaseException:
        stop()
        raise
    finally:
        progress.close()
    # the rules are known now; unless an asset not selected has its rule still pending (a rule only it would
    # take was named as matching no asset): a run that builds that asset warns then
    if _rules_pending(items) and not _rules_pending([it for it in items if it.asset.id not in by_id]):
        unreached = _unreached_rules(cfg, items)
        for w in unreached:
            echo(f"warning: {w}")
        warnings = warnings + unreached
    warnings = warnings + asset_warnings
    stale: Exception | None = None  # (scene.usda written, but the layer of its name open here not reloaded)
    try:
        manifest[RUN_OUTPUTS] = run_outputs  # (each recorded as written: a write that fails stops the run)
        for kind in ("scene", "report"):
            if not _asks_for(cfg, kind):
                continue
            path = out_dir / _RUN_OUTPUT_FILES[kind]
            # (the report's: the config as it names it, absolute, so a moved tree's is rewritten)
            shown: dict[str, Any] = {}
            if kind == "report":
                from .report import config_shown

                shown = {REPORT_CONFIG: config_shown(path, manifest["config"])}
            elif _utf8_named(_scene_stems(records)):  # (a scene of such names mangled: written again)
                shown = {UTF8_PRIM_NAMES: True}
            if (
                unchanged
                and isinstance(kept := run_outputs.get(kind), dict)
                and kept.get(CURRENT) is True
                and all(kept.get(k) == v for k, v in shown.items())  # (a record without it: rewritten once)
            ):
                checked = _checked_output(path, kept, verify)
                if checked is not None:  # (written from these records, and as written)
                    run_outputs[kind] = checked
                    continue
            run_outputs.pop(kind, None)  # (being rewritten: no longer the file recorded)
            lock.claim()
            if kind == "scene":
                from ..usd.writer import LayerReloadError

                try:
                    _write_scene(out_dir, records)
                except LayerReloadError as exc:
                    # the file is written, whole, from these records: it is recorded, the report and the
                    # manifest written, and the error raised once they are (raised here, the manifest
                    # left the scene on disk unrecorded, and the report of this run unwritten). Without its
                    # traceback, whose frames hold the layer written at .scene.tmp.usda: kept alive, usd-core
                    # refused to create that layer again, the next scene written in this process failing
                    stale = exc.with_traceback(None)
            else:
                from .report import write_report

                write_report(path, manifest, because={aid: because[aid] for aid in built_ids})
            run_outputs[kind] = {**output_record(path), **shown, CURRENT: True}
        if not run_outputs:
            del manifest[RUN_OUTPUTS]
        if not unchanged or manifest != previous:
            lock.claim()
            _write_manifest(manifest_path, manifest, text)
    except BaseException as exc:
        stop()
        if stale is not None:  # (the scene's reload failed first: said too, not lost behind this error)
            exc.add_note(f"before it: {type(stale).__name__}: {stale}")
        raise
    if stale is not None:
        raise stale
    seconds = time.perf_counter() - t_start
    tried = {it.asset.id: because[it.asset.id] for it in todo}
    return RunResult(
        records, len(built_ids), len(picked) - len(todo), failed, warnings, seconds, manifest_path, planned,
        failures, **orphan_lists, built_ids=built_ids, because=tried, not_selected=not_selected,
        orphans=orphan_records,
    )  # fmt: skip


def _plan_shown(picked: list[PlanItem], force: bool, because: dict[str, list], echo) -> list[dict]:
    """A dry run's or ``--explain``'s plan of the assets ``picked``: a line echoed for each (its encoding,
    parameters, state, triangles, instances, why and ``because``, its reasons to be built), and each as
    :attr:`RunResult.plan` holds it."""
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


def _records_kept(
    cfg: Config, manifest: dict, items: list[PlanItem], picked: list[PlanItem], force: bool
) -> dict[str, dict]:
    """The manifest records a run that builds keeps before it builds: those of the config's assets it can
    use (not a hand-edited one: see :func:`plan`), an up-to-date picked asset's brought up to date itself
    (its ``last_failure`` dropped, its outputs' stat, rule, why, digest, instances and inputs as the plan
    found them); the records of the assets to build are replaced as each finishes."""
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
    """An orphan's record as a :class:`RunResult` names it: its path, asset and why it is left."""
    return {k: o[k] for k in ("path", ORPHAN_ASSET, ORPHAN_BECAUSE)}


def _warnings_named(warnings: list[str], asset: Asset) -> list[str]:
    """``warnings`` with the asset's input file named by its path relative to the config (its id's), where
    they name it by the absolute path its worker loaded."""
    return [w.replace(str(asset.path), asset.file_id) for w in warnings]


def _assets(n: int) -> str:
    return f"{n} asset" + "s" * (n != 1)


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
