"""``swpm-pipeline run``: plan every asset, skip what is up to date, run the rest on an executor, record.

This module is the orchestration: :func:`plan` decides what each asset needs, :func:`execute` runs the tasks,
:func:`run` holds the steps together and records. What they call lives beside it: :mod:`.manifest` (the file,
read and written fast), :mod:`.inputs` (which inputs are as recorded), :mod:`.rules` (an asset's rule, and
whether its build is still current), :mod:`.tasks` (what a worker gets), :mod:`.pool` (the worker processes
and their fork server), :mod:`.outputs` (the files in output.dir: checked, cleaned up, kept), :mod:`.lock`
(one run at a time in an output folder), :mod:`.scene` (scene.usda), :mod:`.progress` and :mod:`.interrupts`
(Ctrl-C), :mod:`.reasons` (why the plan builds an asset again: shown, never deciding), :mod:`.selection`
(which assets ``only`` picks), :mod:`.plan_item` (an asset's plan, the type those parts take),
:mod:`.up_to_date` (whether an asset's build is current), :mod:`.plan_shown` (a dry run's lines),
:mod:`.run_records` (the records a run keeps and compares), :mod:`.run_result` (what :func:`run` returns) and
:mod:`.gc_pause`.

Read in order: :func:`plan` (with :class:`_PlanInputs`, each asset's input digest, and
:func:`_triangle_count`), :func:`execute`, then :func:`run`, whose steps are the methods of :class:`_Run`
in the order :meth:`_Run.steps` calls them. The names tests patch here (``plan``, ``execute``,
``process_asset``, ``hash_inputs``, ``_count_triangles``, ``_write_manifest``, ...) are looked up in this
module when called: the code that calls them stays here.

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

A run that builds and prunes nothing, whose failures each fail again as recorded
(:func:`.run_records._same_failure`: retried, their records kept), and whose manifest would hold what it
holds, writes neither it nor scene.usda nor report.html: those were written from these records (their
``run_outputs`` records marked :data:`.manifest.CURRENT`) and are kept while they are as recorded (10,000
assets: a 47 MB manifest, 2.2 s to write), the report while it names the config where it is now
(:data:`.manifest.REPORT_CONFIG`: a project moved whole has its report and manifest written); nor the lock
file, which holds the pid of the last run that wrote (:meth:`.lock._OutputLock.claim`).
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Generator, Iterable
from pathlib import Path
from typing import Any

from .. import __version__
from ..errors import MissingExtraError
from .assets import (
    Asset,
    discover,
    hash_inputs,
    match_rule,
    output_dir,
)
from .config import Config, ConfigError, load_config
from .gc_pause import _gc_paused
from .inputs import INPUTS_LISTED as INPUTS_LISTED  # (re-exported)
from .inputs import LISTING as LISTING  # (re-exported)
from .inputs import (
    _input_size,
    _inputs_unchanged,
    _listed_inputs,
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
from .plan_shown import _assets, _plan_shown
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
from .reasons import build_reasons, reason
from .records import record_problem, recorded_inputs
from .rules import (
    _max_triangles,
    _names_moved,
    _routes_by_triangles,
    _rule_name,
    _rules_pending,
    _same_rule_from,
    _treatment_digest,
    _unreached_rules,
)
from .run_records import _failed_before, _orphan_named, _records_kept, _same_failure, _warnings_named
from .run_result import RunResult as RunResult  # (re-exported: swpm_usd.pipeline's)
from .scene import SCENE_METERS_PER_UNIT as SCENE_METERS_PER_UNIT  # (re-exported)
from .scene import SCENE_UP_AXIS as SCENE_UP_AXIS  # (re-exported)
from .scene import UNITS_OP as UNITS_OP  # (re-exported)
from .scene import UP_AXIS_OP as UP_AXIS_OP  # (re-exported)
from .scene import UTF8_PRIM_NAMES, _scene_stems, _utf8_named, _write_scene
from .selection import SelectionConflictError, _selection_clashes, selected_ids
from .selection import SelectionError as SelectionError  # (re-exported: swpm_usd.pipeline's)
from .tasks import _failed_loading, _task
from .up_to_date import _decide
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
    found = _PlanInputs(cfg, known, verify)
    aliases: list[str] = []  # (warnings: a matched link to another matched file, one asset)
    assets, inputs, problems = discover(
        cfg, _recorded_output_paths(out_dir, manifest), found.listed, found.settled, aliases
    )
    problems.extend(_unusable_out_dir(cfg, out_dir))
    problems.extend(_overwritten_inputs(cfg, out_dir, assets, inputs))
    if only and not problems:
        selected_ids((a.id for a in assets), only)  # (raises for a pattern that matches no asset)
    items = []
    record_warnings = []
    needs_rule_on_triangles = _routes_by_triangles(cfg)
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
        digest, input_stats = found.digest(a.id, inputs[a.id], prev, previous)
        # (the item's fields that say where its inputs came from, whatever its plan)
        listed = {
            "inputs": inputs[a.id],
            "previous": previous,
            "input_stats": input_stats,
            "inputs_listed": a.id in found.settled,
        }
        tri = prev.get("triangles_in") if prev.get("input_digest") == digest else None
        how = "exact" if tri is not None or needs_rule_on_triangles else "not needed"
        if tri is None and needs_rule_on_triangles:
            pending: PlanItem | None = None
            if not count_triangles:
                pending = PlanItem(
                    a, digest, None, why="rule chosen by the worker", rule_pending=True, **listed
                )
            else:
                count = _triangle_count(cfg, a, early_counts)
                if isinstance(count, str):
                    # routed as the run routes it: by the worker, once the file loads (it was routed as if
                    # it held 0 triangles, a rule the run never gave it). Its build fails unless it loads then
                    pending = PlanItem(
                        a,
                        digest,
                        None,
                        why=f"rule chosen by the worker: the file did not load to count its triangles "
                        f"({count})",
                        rule_pending=True,
                        **listed,
                        triangles_how="unknown",
                    )
                else:
                    tri, how = count
            if pending is not None:
                pending.because = build_reasons(cfg, pending, version_then, out_dir, ignored)
                items.append(pending)
                continue
        item = PlanItem(a, digest, tri, **listed, triangles_how=how)
        item.rule, item.treatment, item.why = match_rule(cfg, a, tri if tri is not None else 0)
        item.digest = _treatment_digest(cfg, item)
        _decide(cfg, item, prev, out_dir, verify, version_then, ignored)
        items.append(item)
    warnings = [] if _rules_pending(items, dry_run=early_counts) else _unreached_rules(cfg, items)
    return items, problems, aliases + record_warnings + warnings


class _PlanInputs:
    """Each asset's input digest and the stat of its inputs, for :func:`plan`: its record's when the files
    are as recorded (listed from the record, or stat'ed), else hashed; with the caches that make a stage's
    prims check and hash its layers once a plan, not once a prim."""

    def __init__(self, cfg: Config, known: dict[str, dict], verify: bool) -> None:
        self.cfg, self.known, self.verify = cfg, known, verify
        self.reused: set[str] = set()  # the assets whose inputs are their record's (as recorded: not read)
        self.settled: set[str] = set()  # the assets whose inputs their record may keep for reuse
        # input paths -> (digest, entries) hashed by this plan: the prims of one stage share its layers
        self.hashed: dict[tuple[Path, ...], tuple[str, list[dict]]] = {}
        # the prims of one stage share its list of layers (discover's) and their records one list of entries
        # (read_manifest's): each pair checked once a run (its files stat'ed once), not once a prim (1,000
        # prims of a 51-layer stage: 51,000 stats and path comparisons, a third of a no-change rerun). Keyed
        # by the lists' ids, each entry holding its lists so no id is reused while the plan runs
        self.checked_inputs: dict[tuple[int, int], tuple[list, list, bool]] = {}
        # id(a record's inputs) -> recorded_inputs
        self.valid_inputs: dict[int, tuple[Any, list[dict] | None]] = {}

    def listed(self, aid: str, path: Path) -> list[Path] | None:
        """:func:`.assets.discover`'s ``listed``: the asset's inputs as its record lists them, while they
        are as recorded (never with ``verify``)."""
        found = None if self.verify else _listed_inputs(path, self.known.get(aid), self.cfg.base)
        if found is not None:
            self.reused.add(aid)
        return found

    def recorded_of(self, rec: dict) -> list[dict] | None:
        """The record's input entries if they are valid (:func:`.records.recorded_inputs`), once a list."""
        listed = rec.get("inputs")
        hit = self.valid_inputs.get(id(listed))
        if hit is None or hit[0] is not listed:
            hit = self.valid_inputs[id(listed)] = (listed, recorded_inputs(rec))
        return hit[1]

    def unchanged(self, paths: list[Path], entries: list[dict] | None) -> bool:
        """Are the files ``paths`` those ``entries`` record, with their stat (once a pair of lists)?"""
        if entries is None:
            return False
        hit = self.checked_inputs.get((id(paths), id(entries)))
        if hit is None or hit[0] is not paths or hit[1] is not entries:
            hit = (paths, entries, _inputs_unchanged(paths, entries, self.cfg.base))
            self.checked_inputs[(id(paths), id(entries))] = hit
        return hit[2]

    def digest(self, aid: str, paths: list[Path], prev: dict, previous: dict | None) -> tuple[str, Any]:
        """(the input digest, the input entries) of asset ``aid`` built from ``paths``; ``prev`` its record
        ({} for none), ``previous`` the record or None."""
        # (a failed asset's record need not have its input digest: record_problem checks its type alone)
        recorded = None if "input_digest" not in prev else self.recorded_of(prev)
        # (inputs listed from the record: as recorded)
        reuse = not self.verify and aid in self.reused and previous is not None
        trusted = not reuse and self.unchanged(paths, recorded)
        if reuse or (trusted and not self.verify):
            return prev["input_digest"], recorded
        key = tuple(paths)
        if key not in self.hashed:
            try:
                found_digest, entries = hash_inputs(paths)
                self.hashed[key] = (found_digest, _recorded_paths(self.cfg.base, entries))
            except OSError as exc:
                # gone since it was listed, or unreadable: the asset is built and fails there with
                # its loader's error naming the file, while the others run. The digest matches no
                # record and no stat is recorded, so the next run hashes it again
                unread = [{"path": recorded_path(self.cfg.base, p)} for p in paths]
                self.hashed[key] = (f"unreadable: {exc}", unread)
        digest, input_stats = self.hashed[key]
        if trusted and digest == prev["input_digest"] and _same_stat(input_stats, recorded):
            # (verify: the bytes a run would have trusted unread are the recorded ones, their stat as
            # recorded: the record stands as it is, not rewritten for a new hashed_ns)
            input_stats = recorded
        return digest, input_stats


def _triangle_count(cfg: Config, a: Asset, early_counts: bool) -> tuple[int, str] | str:
    """(the triangles of asset ``a``, how they are known: :data:`.plan_item.TRIANGLE_COUNTS`) for a rule on
    triangles, or the error its file did not load with, named (the worker then routes it, and reports it as
    this asset's failure; the error not kept, nor the file's bytes its frames hold). ``early_counts`` (a
    dry run): the count the file tells before its geometry is read, where that routes it as its loaded count
    would."""
    early, data = None, b""
    if early_counts:  # (an OBJ's bytes kept: loaded from them below, not read twice)
        from ..io import early_triangle_count_and_data

        early, data = early_triangle_count_and_data(a.path, prim_path=a.prim)
    if early is not None and not early[1] and not _same_rule_from(cfg, a, early[0]):
        early = None  # (a lower bound under a rule's max: the count it routes by is loaded)
    if early is not None:
        return early[0], "declared before cleaning" if early[1] else "lower bound"
    try:
        return _count_triangles(a, _max_triangles(cfg), data), "exact"
    except Exception as exc:  # noqa: BLE001 - the worker reports it as this asset's failure
        return f"{type(exc).__name__}: {exc}"


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
        yield from _on_dask(tasks, jobs, scheduler)
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
        _start_forkserver(ctx, tasks)
    yield from _local_pool(tasks, max(1, jobs), ctx, limit_s)


def _on_dask(tasks: list[dict], jobs: int, scheduler: str | None) -> Generator[dict, None, None]:
    """:func:`execute` on Dask: the scheduler at ``scheduler``, else a local cluster of up to ``jobs``
    worker processes (closed at the end)."""
    require_dask()
    from dask.distributed import Client, LocalCluster, as_completed

    # (a local cluster's nannies set their workers' variables in this process, OMP_NUM_THREADS=1,
    # MALLOC_TRIM_THRESHOLD_, PYTHONHASHSEED...: left so, every process the caller started later had them)
    environ = dict(os.environ)
    started: dict[str, str] | None = None  # (os.environ once the cluster is up)
    # (closed in reverse, each whatever the one before raised: the client, the cluster, then the environment)
    with contextlib.ExitStack() as stack:
        stack.callback(lambda: _restore_environ(environ, dict(os.environ) if started is None else started))
        if scheduler:
            client = Client(scheduler)
        else:
            workers = max(1, min(jobs, len(tasks)))  # (no worker with nothing to do)
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True)
            stack.callback(cluster.close)  # (a client that fails to start: its workers were left running)
            client = Client(cluster)
        stack.callback(client.close)
        started = dict(os.environ)
        futures = client.map(process_asset, tasks, pure=False)
        for fut in as_completed(futures):
            yield fut.result()


def _restore_environ(before: dict[str, str], after: dict[str, str]) -> None:
    """Undo what took ``os.environ`` from ``before`` to ``after`` (a cluster's start): each variable it set,
    changed or removed is given its value in ``before`` back, unless it has changed again since (the
    caller's other threads' variables, set while the run went on, are theirs: they were all undone)."""
    for name in {*before, *after}:
        if before.get(name) == after.get(name) or os.environ.get(name) != after.get(name):
            continue
        if name in before:
            os.environ[name] = before[name]
        else:
            del os.environ[name]


def _start_forkserver(ctx: Any, tasks: list[dict]) -> None:
    """Have the fork server running, warmed for the encodings of ``tasks`` and with the modules they need
    preloaded: the one an earlier run of this process started while it has them (:data:`_SERVER_GIVEN`),
    else a new one with both runs' sets."""
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
        return _Run(
            cfg,
            out_dir,
            lock,
            t_start,
            jobs=jobs,
            executor=executor,
            scheduler=scheduler,
            dry_run=dry_run,
            explain=explain,
            force=force,
            prune=prune,
            echo=echo,
            verify=verify,
            only=[only] if isinstance(only, str) else list(only or ()),  # (one pattern, not its characters)
        ).steps()
    finally:
        lock.release()


class _Run:
    """One run of :func:`run` once its config is loaded and output.dir's lock made: :meth:`steps` calls the
    steps in order, each a method below, reading and setting the run's state on ``self``.

    Before the build: ``manifest`` (the manifest read; from :meth:`prepare`, the one being written, of
    ``records``), ``previous`` (the manifest read), ``items`` (the whole config's plan), ``picked`` (those
    ``only`` selects), ``warnings``, ``orphans`` (the outputs of removed assets, with ``orphan_names`` and
    ``orphan_records`` naming them and those a rebuild leaves), ``because`` (each picked asset's reasons to
    be built). During it: ``records`` (the manifest's), ``run_outputs`` (scene.usda's and report.html's
    records), ``unchanged`` (no record changed yet: nothing to write), ``built_ids``, ``failures``."""

    def __init__(
        self,
        cfg: Config,
        out_dir: Path,
        lock: _OutputLock,
        t_start: float,
        *,
        jobs: int,
        executor: str,
        scheduler: str | None,
        dry_run: bool,
        explain: bool,
        force: bool,
        prune: bool,
        echo,
        verify: bool,
        only: list[str],
    ) -> None:
        self.cfg, self.out_dir, self.lock, self.t_start, self.echo = cfg, out_dir, lock, t_start, echo
        self.jobs, self.executor, self.scheduler = jobs, executor, scheduler
        self.dry_run, self.explain, self.force, self.prune = dry_run, explain, force, prune
        self.verify, self.only = verify, only
        self.manifest_path = out_dir / MANIFEST
        self.planned: list[dict] = []  # (a dry run's or --explain's plan lines, as RunResult.plan holds them)
        self.warnings: list[str] = []
        self.unchanged = True  # (until a record changes: changed())
        self.failed = 0
        self.built_ids: list[str] = []
        self.failures: dict[str, dict] = {}
        self.asset_warnings: list[str] = []
        self.results: Generator[dict, None, None] | None = None  # (execute's, once started)
        self.text = _ManifestText()

    def steps(self) -> RunResult:
        """The run: read, plan, select, warn, find the orphans; a dry run shows the plan and ends; a run
        that builds prepares the folder and the records, builds, records and writes its files."""
        if not self.dry_run and self.out_dir.is_dir():
            self.lock.acquire()  # before the manifest is read: it is this run's from here on
        self.read_manifest()
        self.make_plan()
        self.select()
        self.warn()
        self.find_orphans()
        # each asset's reasons to be built (--force: every asset's first), none for one up to date
        forced = self.force
        self.because = {
            it.asset.id: ([reason("forced", "--force")] if forced else []) + it.because for it in self.picked
        }
        if self.dry_run or self.explain:
            self.show_plan()
            if self.dry_run:
                return self.dry_run_result()
        self.prepare()
        self.build()
        self.warn_unreached()
        self.write_outputs()
        return self.result()

    def read_manifest(self) -> None:
        """Read the manifest (with the collector paused), noting the records whose input lists it cannot
        resolve, the lists of an older version, and why it is no manifest; then put back the outputs a
        stopped worker had set aside (the folder is this run's: before the plan checks the outputs)."""
        self.unresolved: dict[str, str] = {}  # asset id -> why its record's inputs_ref names no list
        self.older: list[str] = []  # the records of an older manifest's lists, which a rewrite writes compact
        self.unreadable: list[str] = []  # why the file at the manifest's path is no manifest (cut, not JSON)
        with _gc_paused():
            self.manifest = self.previous = _read_manifest(
                self.manifest_path, self.unresolved, self.older, self.unreadable
            )
        if not self.dry_run and self.out_dir.is_dir():  # (the run's from here on: before the plan checks)
            _restore_kept_aside(self.out_dir, self.manifest["assets"])

    def make_plan(self) -> None:
        """:func:`plan` every asset (with the collector paused, unless it loads meshes to count their
        triangles: a loader's garbage may be cyclic); its errors raised as a :class:`.config.ConfigError`."""
        dask_unlimited = self.executor == "dask" and "seconds" in self.cfg.data.get("limits", {})
        with contextlib.nullcontext() if self.dry_run or self.explain else _gc_paused():
            self.items, errors, self.warnings = plan(
                self.cfg,
                self.manifest,
                count_triangles=self.dry_run or self.explain,
                verify=self.verify,
                early_counts=self.dry_run,
                only=None if dask_unlimited else self.only,  # (a config error: raised first, as every other)
            )
        if dask_unlimited:
            errors = [
                *errors,
                "limits.seconds needs the local executor (--executor dask cannot stop an asset)",
            ]
        if errors:
            raise ConfigError(errors)

    def select(self) -> None:
        """The assets ``only`` picks (every one without it): ``picked``; a selection that clashes with the
        others' outputs raises :class:`.selection.SelectionConflictError`."""
        # (the patterns were checked once the plan discovered the ids, before it hashed an input: each
        # matches some; before any build or write; None: every asset)
        # (``items`` stay the whole config's: orphans, the outputs kept, the rules reached, the records kept)
        items = self.items
        self.chosen = selected_ids((it.asset.id for it in items), self.only) if self.only else None
        self.picked = items if self.chosen is None else [it for it in items if it.asset.id in self.chosen]
        self.not_selected = len(items) - len(self.picked)
        if self.chosen is not None and (
            clashes := _selection_clashes(self.cfg, items, self.picked, self.force)
        ):
            raise SelectionConflictError(clashes)

    def warn(self) -> None:
        """The run's warnings, echoed: a manifest it cannot read, records naming no list of their inputs,
        the plan's, and a manifest another config's run wrote."""
        cfg, where = self.cfg, _rel(self.cfg, self.manifest_path)
        # (no record to go by: every asset built again, and the outputs it recorded no longer known)
        lost = [
            f"{where}: {why}; the run takes it for no manifest: every asset is built "
            "again, and the outputs it recorded are no longer known (not pruned)"
            for why in self.unreadable
        ]
        self.warnings = (
            lost
            + self.warnings
            + [  # (a hand edit: the inputs of a current asset's record hashed, not trusted)
                f"{where}: the record of {it.asset.id} names no list of its inputs "
                f"({self.unresolved[it.asset.id]}); they are hashed"
                for it in self.items
                if it.asset.id in self.unresolved and it.previous is not None
            ]
        )
        if shared := _shared_with(cfg, self.manifest, self.items):
            self.warnings.append(
                f"{where} was written by a run of another config ({shared[0]}): "
                f"{shared[1]} of its assets {'is' if shared[1] == 1 else 'are'} not in "
                f"{cfg.shown or cfg.path} and taken as removed (outputs "
                f"{'deleted' if self.prune else 'left unlisted'}, rebuilt by that config's next run); "
                "give each config its own output.dir"
            )
        for w in self.warnings:
            self.echo(f"warning: {w}")

    def find_orphans(self) -> None:
        """The outputs of assets no longer in the config (before any build: a removed asset's output path
        may be a current asset's, which is never deleted), named."""
        self.orphans = _orphaned_outputs(self.cfg, self.out_dir, self.manifest, self.items, self.verify)
        self.orphan_names = [o["path"] for _, o in self.orphans]
        # (each named: its asset and why it is left, in the order of orphan_names)
        self.orphan_records = [_orphan_named(o) for _, o in self.orphans]

    def show_plan(self) -> None:
        """A dry run's or ``--explain``'s plan lines, and how many assets ``only`` left out."""
        self.planned = _plan_shown(self.cfg, self.picked, self.force, self.because, self.echo)
        if self.chosen is not None:
            self.echo(
                f"{_assets(self.not_selected)} not selected by --only (of {len(self.items)}): not listed, "
                "not built"
            )

    def dry_run_result(self) -> RunResult:
        """A dry run's result: what it would skip and build, and the outputs it would leave or prune (with
        those a rebuild leaves, at names output.names moved or of a kind no longer asked for: the run names
        them, and prune deletes them, once it is rebuilt; the plan said less than the run did)."""
        skipped = 0 if self.force else sum(i.up_to_date for i in self.picked)  # (force: each "to build")
        rebuilt = [it for it in self.picked if self.force or not it.up_to_date]
        left = _left_by_rebuilds(self.cfg, self.out_dir, self.items, rebuilt)
        self.orphan_names.extend(o["path"] for o in left)
        self.orphan_records.extend(_orphan_named(o) for o in left)
        for o in self.orphan_records:
            self.echo(orphan_line(o) + ("; --prune deletes it" * self.prune))
        to_build = {aid: found for aid, found in self.because.items() if found}
        return RunResult(
            {}, 0, skipped, 0, self.warnings, 0.0, self.manifest_path, self.planned, **self.orphan_lists(),
            because=to_build, not_selected=self.not_selected, orphans=self.orphan_records,
        )  # fmt: skip

    def orphan_lists(self) -> dict[str, list[str]]:
        """:class:`RunResult`'s ``pruned`` (with ``prune``) or ``unlisted``: the orphans' names."""
        return {"pruned" if self.prune else "unlisted": self.orphan_names}

    def prepare(self) -> None:
        """The folder made and locked, a killed run's temporary files deleted, the orphans pruned (with
        ``prune``); the records the run keeps, and the manifest it writes of them, with the scene's and
        report's records while those files are still there. ``unchanged`` stays True while the run would
        write what the manifest holds."""
        cfg, out_dir, lock = self.cfg, self.out_dir, self.lock
        _make_out_dir(cfg, out_dir)
        lock.acquire(folder_checked=True)  # (a folder this run created)
        _remove_temporary(out_dir)  # left by a killed run
        self.todo = [it for it in self.picked if self.force or not it.up_to_date]
        if self.prune and self.orphans:
            lock.claim()
            for path, _ in self.orphans:
                path.unlink(missing_ok=True)
        records = self.records = _records_kept(cfg, self.manifest, self.items, self.picked, self.force)
        read_outputs = self.manifest.get(RUN_OUTPUTS)
        # (the files still there until the run writes them anew: a stopped run records them)
        self.run_outputs = {
            kind: o
            for kind, o in (read_outputs if isinstance(read_outputs, dict) else {}).items()
            if kind in _RUN_OUTPUT_DEFAULTS and _asks_for(cfg, kind)
        }
        manifest = {"tool_version": __version__, "config": _config_ref(cfg, out_dir), "assets": records}
        if self.orphans and not self.prune:  # so a later run with prune still finds them
            orphaned = {ORPHANED: [o for _, o in self.orphans]}
        else:
            orphaned = {}
        # no record changed, nothing pruned (the manifest but its run outputs as read): the scene and report
        # the last run wrote from these records, still as it recorded them, are kept while each asset to
        # build fails again as its record says it failed (:func:`_same_failure`: retried, as the README
        # promises, and nothing to write: 500 assets, 10 broken, a rerun rewrote the manifest, report and
        # scene each time)
        settled = (
            not self.older
            and not (self.prune and self.orphans)
            and {**manifest, **orphaned} == {k: v for k, v in self.previous.items() if k != RUN_OUTPUTS}
        )
        if self.run_outputs:
            manifest[RUN_OUTPUTS] = self.run_outputs
        manifest.update(orphaned)
        self.manifest = manifest
        # (an asset that did not fail before, built or failing: the records change)
        if not settled or not all(_failed_before(records.get(it.asset.id)) for it in self.todo):
            self.changed()

    def changed(self) -> None:
        """A record changes: the run writes here, and its scene and report are no longer those of the
        manifest's records (:data:`.manifest.CURRENT`)."""
        if not self.unchanged:
            return
        self.unchanged = False
        # (the run writes here: its pid in the lock file, for the message of a run it stops)
        self.lock.claim()
        self.run_outputs = {
            kind: {k: v for k, v in o.items() if k != CURRENT} if isinstance(o, dict) else o
            for kind, o in self.run_outputs.items()
        }
        if self.run_outputs:
            self.manifest[RUN_OUTPUTS] = self.run_outputs

    def stop(self) -> None:
        """An error or Ctrl-C: the workers stopped, their temporary files deleted, every finished asset
        recorded (a second Ctrl-C does not cut this short: a pool's workers are stopped with it ignored)."""
        if self.results is not None:
            self.results.close()  # first: it restores the Ctrl-C handler it set (--jobs 1)
        with _interrupts_ignored():
            self.lock.claim()
            _restore_kept_aside(self.out_dir, self.records)  # (a worker stopped while it renamed outputs)
            _remove_temporary(self.out_dir)
            _write_manifest(self.manifest_path, self.manifest, self.text)

    def build(self) -> None:
        """Build ``todo`` on the executor, largest inputs first, recording each asset as it finishes
        (:meth:`record`) and rewriting the manifest as it goes (at most once :data:`_MANIFEST_EVERY_S`, or
        less often while a rewrite takes more than 1/:data:`_MANIFEST_BACKOFF` of it); stopped cleanly
        (:meth:`stop`) by an error or Ctrl-C."""
        cfg = self.cfg
        # (a rerun whose only work is broken inputs retried builds nothing: no word of numba's compile)
        progress = _Progress(len(self.todo), compiles=not all(_failed_loading(it) for it in self.todo))
        self.by_id = {it.asset.id: it for it in self.todo}
        self.kept_files: set[tuple] | None = None  # (_files_kept, once an asset drops an output)
        last_write, write_s = float("-inf"), 0.0
        try:
            # largest inputs first, so no worker is left with a big asset at the end (LPT scheduling)
            ordered = sorted(self.todo, key=lambda it: -_input_size(it.asset.path))
            limit_s = cfg.data.get("limits", {}).get("seconds")
            tasks = [_task(cfg, it) for it in ordered]
            self.results = execute(tasks, self.jobs, self.executor, self.scheduler, limit_s)
            for rec in self.results:
                it = self.by_id[rec["id"]]
                rec = self.record(rec, it)
                now = time.perf_counter()
                # (unchanged: each asset so far failed again as recorded, nothing to write)
                if not self.unchanged and now - last_write >= max(
                    _MANIFEST_EVERY_S, _MANIFEST_BACKOFF * write_s
                ):
                    _write_manifest(self.manifest_path, self.manifest, self.text)
                    last_write = time.perf_counter()
                    write_s = last_write - now
                progress.advance(rec, str(it.asset.path))
        except BaseException:
            progress.stop_timer()  # (first: a Ctrl-C stop that took past 30 s printed "still working")
            self.stop()
            raise
        finally:
            progress.close()

    def record(self, rec: dict, it: PlanItem) -> dict:
        """A worker's record ``rec`` of asset ``it`` into the manifest: completed (its inputs, rule,
        warnings, outputs' stat); a build replaces the asset's record and names the outputs it no longer
        writes, a failure keeps the previous build where it is intact. The record as the progress shows it
        (a failure's with ``kept_previous``)."""
        cfg, out_dir, records = self.cfg, self.out_dir, self.records
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
            self.asset_warnings.extend(rec["warnings"])
        for o in rec.get("outputs", {}).values():
            _complete_output_record(out_dir / o["path"], o)
        if rec["status"] == "built":
            self.built_ids.append(rec["id"])
            self.name_dropped_outputs(rec, it)
            records[rec["id"]] = rec
        else:
            self.failed += 1
            before = records.get(rec["id"])
            kept = _keep_previous(out_dir, before, rec, self.verify)
            after = rec if kept is None else kept
            if _same_failure(before, after):
                after = before  # (its record as it was: the seconds it took aside, nothing changed)
            else:
                self.changed()
            records[rec["id"]] = after
            rec = self.failures[rec["id"]] = {**rec, "kept_previous": kept is not None}
        if rec["status"] == "built":
            self.changed()
        return rec

    def name_dropped_outputs(self, rec: dict, it: PlanItem) -> None:
        """The outputs asset ``it``'s build ``rec`` no longer writes (a kind the config no longer asks for,
        or one output.names moved): each old file named as the asset's, left behind, and pruned as a removed
        asset's output is (never a file another current asset keeps)."""
        before = self.records.get(rec["id"])
        moved = _names_moved(self.cfg, it.asset, before)
        for path, o in _dropped_outputs(self.out_dir, before, rec, self.verify, it.asset.id, moved):
            if self.kept_files is None:
                self.kept_files = _files_kept(self.cfg, self.out_dir, self.items)
            if _file_key(path) in self.kept_files:
                continue
            if self.prune:
                path.unlink(missing_ok=True)
            else:
                self.manifest.setdefault(ORPHANED, []).append(o)
            self.orphan_names.append(o["path"])
            self.orphan_records.append(_orphan_named(o))

    def warn_unreached(self) -> None:
        """The rules no asset reached, warned of now that the rules are known; unless an asset not selected
        has its rule still pending (a rule only it would take was named as matching no asset): a run that
        builds that asset warns then. The loaders' warnings join the run's."""
        items = self.items
        if _rules_pending(items) and not _rules_pending(
            [it for it in items if it.asset.id not in self.by_id]
        ):
            unreached = _unreached_rules(self.cfg, items)
            for w in unreached:
                self.echo(f"warning: {w}")
            self.warnings = self.warnings + unreached
        self.warnings = self.warnings + self.asset_warnings

    def write_outputs(self) -> None:
        """scene.usda and report.html (those the config asks for), each kept while it was written from
        these records and is as written, then the manifest unless it would hold what it holds; stopped
        cleanly (:meth:`stop`) by an error. A scene whose layer of its name, open here, did not reload is
        written and recorded, its error raised once the manifest is."""
        cfg, out_dir, manifest, run_outputs = self.cfg, self.out_dir, self.manifest, self.run_outputs
        stale: Exception | None = (
            None  # (scene.usda written, but the layer of its name open here not reloaded)
        )
        try:
            manifest[RUN_OUTPUTS] = (
                run_outputs  # (each recorded as written: a write that fails stops the run)
            )
            for kind in ("scene", "report"):
                if not _asks_for(cfg, kind):
                    continue
                path = out_dir / _RUN_OUTPUT_FILES[kind]
                # (the report's: the config as it names it, absolute, so a moved tree's is rewritten)
                shown: dict[str, Any] = {}
                if kind == "report":
                    from .report import config_shown

                    shown = {REPORT_CONFIG: config_shown(path, manifest["config"])}
                elif _utf8_named(
                    _scene_stems(self.records)
                ):  # (a scene of such names mangled: written again)
                    shown = {UTF8_PRIM_NAMES: True}
                if (
                    self.unchanged
                    and isinstance(kept := run_outputs.get(kind), dict)
                    and kept.get(CURRENT) is True
                    and all(
                        kept.get(k) == v for k, v in shown.items()
                    )  # (a record without it: rewritten once)
                ):
                    checked = _checked_output(path, kept, self.verify)
                    if checked is not None:  # (written from these records, and as written)
                        run_outputs[kind] = checked
                        continue
                run_outputs.pop(kind, None)  # (being rewritten: no longer the file recorded)
                self.lock.claim()
                if kind == "scene":
                    stale = self.write_scene()
                else:
                    from .report import write_report

                    because = {aid: self.because[aid] for aid in self.built_ids}
                    write_report(path, manifest, because=because)
                run_outputs[kind] = {**output_record(path), **shown, CURRENT: True}
            if not run_outputs:
                del manifest[RUN_OUTPUTS]
            if not self.unchanged or manifest != self.previous:
                self.lock.claim()
                _write_manifest(self.manifest_path, manifest, self.text)
        except BaseException as exc:
            self.stop()
            if stale is not None:  # (the scene's reload failed first: said too, not lost behind this error)
                exc.add_note(f"before it: {type(stale).__name__}: {stale}")
            raise
        if stale is not None:
            raise stale

    def write_scene(self) -> Exception | None:
        """scene.usda written from the records; the error of a layer of its name open here that did not
        reload, returned, not raised."""
        from ..usd.writer import LayerReloadError

        try:
            _write_scene(self.out_dir, self.records)
        except LayerReloadError as exc:
            # the file is written, whole, from these records: it is recorded, the report and the manifest
            # written, and the error raised once they are (raised here, the manifest left the scene on disk
            # unrecorded, and the report of this run unwritten). Without its traceback, whose frames hold
            # the layer written at .scene.tmp.usda: kept alive, usd-core refused to create that layer again,
            # the next scene written in this process failing
            return exc.with_traceback(None)
        return None

    def result(self) -> RunResult:
        """The run's result: its records, counts, warnings, failures, orphans and why each asset it tried
        was built."""
        seconds = time.perf_counter() - self.t_start
        tried = {it.asset.id: self.because[it.asset.id] for it in self.todo}
        return RunResult(
            self.records, len(self.built_ids), len(self.picked) - len(self.todo), self.failed, self.warnings,
            seconds, self.manifest_path, self.planned, self.failures, **self.orphan_lists(),
            built_ids=self.built_ids, because=tried, not_selected=self.not_selected,
            orphans=self.orphan_records,
        )  # fmt: skip
