"""One asset's work, run in a worker process (local pool or a Dask task): load, choose, build, check the
streaming order, write the outputs atomically. Never raises: a failure comes back as a record with its cause.

Beside it: :mod:`.auto` (``encoding: auto``'s choice and the figures a record keeps), :mod:`.input_changes`
(an input changed while it was read, or since the plan) and :mod:`.file_hash` (a file's sha256 with its
stat, an output's record), whose names this module still exports.
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import signal
import threading
import time
import traceback
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..codes import PROBLEM_KEYS, fields_of, problem_fields
from ..fileio import atomic_write_bytes, keep_aside, stage_bytes  # noqa: F401 - (runner, report import it)
from .auto import AUTO_CANDIDATES as AUTO_CANDIDATES  # (re-exported, as the names below)
from .auto import AUTO_ERROR_FRACTIONS as AUTO_ERROR_FRACTIONS
from .auto import AUTO_SELECT as AUTO_SELECT
from .auto import _misses_scores as _misses_scores
from .auto import choose_auto, summarize
from .auto import lod_change_cost as lod_change_cost
from .auto import misses_at_error as misses_at_error
from .build_version import build_version
from .file_hash import STAT_KEYS as STAT_KEYS  # (re-exported, as the names below)
from .file_hash import hash_with_stat as hash_with_stat
from .file_hash import output_record
from .file_hash import sha256_file as sha256_file
from .file_hash import stat_fields as stat_fields
from .file_hash import update_with_stat as update_with_stat
from .input_changes import (
    InputChangedError,
    _check_unchanged_by_the_read,
    _hashed_as_loaded,
    _moved_since_the_plan,
    _refuse_a_moved_listing,
    _stat_of,
)


def ignore_interrupts() -> None:
    """A pool worker's initializer: Ctrl-C (SIGINT, sent to the terminal's whole process group) is the main
    process's to handle, which stops the workers itself; a worker that took it would print a traceback."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def swpm_layout(data: bytes, legacy: bool) -> dict[str, Any]:
    """What the manifest records of a .swpm's integer layout beside its file record: whether it was written
    for a reader before 0.9.0 (``output.legacy_layout``) and the widths its header declares."""
    from ..format.layout import header_widths

    index_width, offset_width = header_widths(data)
    return {"legacy_layout": legacy, "index_width": index_width, "offset_width": offset_width}


def check_streaming(pm, policy: dict) -> list[str]:
    """The config's streaming policy on top of the format's own invariants (checked by validate)."""
    problems = []
    last = pm.lod_count - 1
    if "max_lods" in policy and pm.lod_count > policy["max_lods"]:
        problems.append(f"{pm.lod_count} LODs exceed streaming.max_lods={policy['max_lods']}")
    if "min_coarsest_triangles" in policy and pm.triangle_count_at(last) < policy["min_coarsest_triangles"]:
        problems.append(
            f"coarsest LOD has {pm.triangle_count_at(last)} triangles < "
            f"streaming.min_coarsest_triangles={policy['min_coarsest_triangles']}"
        )
    if "coarsest_lod_bytes" in policy:
        from ..format.layout import draw_index_width

        stride = pm.vertex_bytes() // max(1, pm.vertex_count)
        kind, stream = pm.draw_stream(last)
        # (the width global_bytes counts: an engine's, not the file's idx, which an older writer's offsets
        # widened)
        isz = draw_index_width(pm.vertex_count, pm.restart_index if kind == "strip" else None)
        need = pm.vertex_count_at(last) * stride + stream.shape[0] * isz
        if need > policy["coarsest_lod_bytes"]:
            problems.append(
                f"coarsest LOD needs {need} bytes > "
                f"streaming.coarsest_lod_bytes={policy['coarsest_lod_bytes']}"
            )
    # vertex prefix property and monotone tables, independent of the file format
    vc = pm.vertex_counts
    if np.any(np.diff(vc) > 0) or np.any(np.diff(pm.triangle_counts) > 0):
        problems.append("LOD table is not ordered finest to coarsest")
    for k in {0, last // 2, last}:
        t = pm.triangles_at(k)
        if t.size and int(t.max()) >= pm.vertex_count_at(k):
            problems.append(f"LOD {k} uses a vertex outside its prefix [0, {pm.vertex_count_at(k)})")
    return problems


#: the suffix of a USD layer exported beside its target before it is renamed into place (the runner
#: deletes files named ``.*.tmp.usdc`` a killed run left)
USD_TEMPORARY_SUFFIX = ".tmp.usdc"


def layer_units(source: str | None) -> dict[str, Any]:
    """The ``up_axis`` and ``meters_per_unit`` of the asset layer of a mesh loaded from ``source``: a USD
    file's (:func:`.usd.writer.stage_metadata`), :func:`.usd.write`'s defaults (Y, 1) for what a USD file
    does not say and for any other file. Recorded with the layer (its manifest record), so the scene
    corrects the asset to its own units without opening the layer (:func:`.scene._write_scene`)."""
    from ..usd.writer import stage_metadata

    meta = stage_metadata(source) if source is not None else {}
    return {"up_axis": meta.get("up_axis", "Y"), "meters_per_unit": float(meta.get("meters_per_unit", 1.0))}


#: the keys of :func:`layer_units`, which a USD layer's manifest record holds (one of 0.7.2 before they were
#: recorded has neither: :func:`recorded_layer_units`)
LAYER_UNIT_KEYS = ("up_axis", "meters_per_unit")


def recorded_layer_units(path: Path) -> dict[str, Any] | None:
    """The :func:`layer_units` an asset layer at ``path`` was written with (:func:`_stage_usd` authors both),
    read from its metadata alone (none of its prims); None when it does not read or authors other units.
    For a layer whose record predates the units' (the scene would reference it uncorrected)."""
    from pxr import Sdf, Tf

    try:
        layer = Sdf.Layer.OpenAsAnonymous(os.fspath(path), metadataOnly=True)
    except Tf.ErrorException:
        return None
    info = layer.pseudoRoot if layer is not None else None
    if info is None or not all(info.HasInfo(k) for k in ("upAxis", "metersPerUnit")):
        return None
    up, scale = str(info.GetInfo("upAxis")), info.GetInfo("metersPerUnit")
    if up not in ("Y", "Z") or not isinstance(scale, float) or not math.isfinite(scale) or scale <= 0:
        return None
    return {"up_axis": up, "meters_per_unit": scale}


def _stage_usd(
    pm, target: Path, source: str | None = None, units: dict[str, Any] | None = None
) -> tuple[Path, Path]:
    """Export ``pm``'s USD layer (named after ``target``) to a temporary file beside ``target``, synced to
    disk; (temporary file, target), for :func:`_place_usd`. A mesh of a USD ``source`` keeps its stage's
    upAxis and metersPerUnit (the loader keeps its coordinates): a Z-up stage in centimetres written as Y-up
    metres stood 100 times too large, on its side. ``units``: :func:`layer_units` of ``source`` when the
    caller has them."""
    import os

    from ..fileio import set_mode_for, set_plain_mode, temporary_beside
    from ..usd import write as usd_write
    from ..usd.writer import UsdWriteError

    target.parent.mkdir(parents=True, exist_ok=True)
    fd, name = temporary_beside(target, f".{target.stem}.", USD_TEMPORARY_SUFFIX)
    tmp = Path(name)
    try:
        try:
            set_plain_mode(fd)  # (mkstemp's 0o600 would stay: usd-core keeps the file's mode)
        finally:
            os.close(fd)
        meta = layer_units(source) if units is None else units
        usd_write(pm, tmp, name=target.stem.split(".")[0] or None, identifier="./" + target.name, **meta)
        # the replaced layer's mode once written (a read-only one's, given first, refused usd-core the write)
        set_mode_for(tmp, target)
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError) and exc.filename is None and exc.errno is not None:
            raise OSError(exc.errno, exc.strerror, os.fspath(target)) from exc  # (fsync's names no file)
        if type(exc) is UsdWriteError and str(tmp) in str(exc):  # (named as the file it was to replace, as
            raise UsdWriteError(str(exc).replace(str(tmp), str(target))) from exc  # a .swpm's is)
        raise
    return tmp, target


def _place_usd(tmp: Path, target: Path) -> Path:
    """Rename a layer :func:`_stage_usd` exported over ``target``; a layer of that name open in this
    process is reloaded (it would keep its old content)."""
    import os

    from ..usd.writer import reload_if_open

    os.replace(tmp, target)
    reload_if_open(target)
    return target


def _place_outputs(staged: dict[str, tuple[Path, Path]]) -> dict[str, dict[str, Any]]:
    """Rename each staged output (kind -> (temporary file, target), in order) over its target, all or none;
    each one's manifest record (:func:`output_record`).

    Each target's previous file is kept aside (:func:`.fileio.keep_aside`: a hard link) until every output
    is in place and recorded. When a rename or a record fails, the outputs already renamed are undone (their
    previous files put back, one without a previous file deleted) and the error raised: the asset's previous
    build is left as it was, and no new file the manifest would not list (a failure after the .swpm's rename
    left the new .swpm, listed nowhere, beside the previous .usdc)."""
    # (kind, temporary file, target, its previous file kept aside), listed before the rename: an error or a
    # Ctrl-C raised as it returns (a signal is handled then), or an error of the layer's reload, undoes it too
    placed: list[tuple[str, Path, Path, Path | None]] = []
    aside: list[Path] = []
    try:
        for kind, (tmp, target) in staged.items():
            previous = keep_aside(target)
            if previous is not None:
                aside.append(previous)
            placed.append((kind, tmp, target, previous))
            if kind == "usd":
                _place_usd(tmp, target)
            else:
                os.replace(tmp, target)
        return {kind: output_record(target) for kind, (_, target) in staged.items()}
    except BaseException as exc:
        from ..usd.writer import LayerReloadError, reload_if_open

        for kind, tmp, target, previous in reversed(placed):
            if os.path.lexists(tmp):
                continue  # not renamed: the target is still its previous file
            try:
                if previous is None:
                    target.unlink(missing_ok=True)
                else:
                    os.replace(previous, target)
            except OSError:  # the new file goes at least (the runner then finds the previous build broken)
                target.unlink(missing_ok=True)
            if kind == "usd":
                # (a reload that fails again leaves the open layer as it was, the previous file's: the other
                # outputs are still undone; raised here, it left the new .swpm beside the previous .usdc)
                with contextlib.suppress(LayerReloadError):
                    reload_if_open(target)
        if isinstance(exc, LayerReloadError):  # (not "written": undone, the asset's previous build kept)
            why = f" ({exc.reason})" if exc.reason else ""
            raise LayerReloadError(
                exc.path,
                exc.reason,
                f"{exc.path}: the layer of that name open in this process could not be reloaded{why}: the "
                "asset's new outputs were taken back, its previous build is as it was",
            ) from exc
        raise
    finally:
        for path in aside:
            path.unlink(missing_ok=True)


def process_asset(task: dict[str, Any]) -> dict[str, Any]:
    """Do one asset. ``task`` is plain data (picklable for process pools and Dask).

    The build runs on one core, ``--jobs 1`` included (no sliding-window finishing thread:
    :func:`.slidingwindow.inline_finishing`): ``--jobs`` is the pipeline's parallelism, and a build thread
    beside every worker would compete with the other workers (20 assets, ``--jobs 2``: 19.5 s with a build
    thread beside each worker, 16.8 s without)."""
    from ..encode import slidingwindow

    # (a loader's warning, "cow.usda: attributes ['uv'] are missing on some of its 2 meshes; dropped", went
    # to the worker's stderr alone: the record keeps it, for the manifest, the report and --json)
    # (the filters stay the process's: a warning an "error" filter makes an exception still fails the asset)
    with warnings.catch_warnings(record=True) as caught:
        with slidingwindow.inline_finishing():
            rec = _process_asset(task)
    for w in caught:  # shown as they were before they were kept
        warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    kept = _warning_lines(caught)
    if kept:
        rec["warnings"] = kept
    return rec


#: the most warnings a record keeps (a loader warning in a loop over thousands of prims says the rest's count)
MAX_RECORD_WARNINGS = 20


def _warning_lines(caught: list[warnings.WarningMessage]) -> list[str]:
    """The messages of the user warnings among ``caught`` (the loaders' and encoders', which name the file and
    what happened; a library's deprecation notice is not the asset's), distinct, in order, at most
    :data:`MAX_RECORD_WARNINGS` and a line counting the rest."""
    lines = list(dict.fromkeys(str(w.message) for w in caught if issubclass(w.category, UserWarning)))
    if len(lines) > MAX_RECORD_WARNINGS:
        rest = len(lines) - MAX_RECORD_WARNINGS + 1
        lines = [*lines[: MAX_RECORD_WARNINGS - 1], f"... and {rest} more warnings"]
    return lines


#: a record's count of the triangles its input file holds before cleaning (:func:`..io.triangles_read`), the
#: count ``limits.max_triangles`` is on; ``triangles_in`` is the cleaned mesh's, which the rules match
TRIANGLES_READ = "triangles_read"

READY = "ready"
"""What a worker process (:func:`serve`) sends first, with the time it was ready."""
#: the environment variable naming the encodings the fork server warms (:mod:`._warm`), comma separated
#: ("" for none; unset: every one), set by :func:`.runner.execute` for the encodings its tasks use: the server
#: inherits the environment of the process that starts it. Warming all four for a rerun whose only tasks
#: were a few broken assets (retried, failing before any build) cost the run the encoders' kernels
WARM_ENCODINGS_ENV = "SWPM_USD_WARM_ENCODINGS"
#: the environment variable naming the process that starts the fork server (its pid, set by
#: :func:`.runner.execute`): a server whose parent is another process by the time it watches its runner
#: (:mod:`._warm`: the runner killed while the server imported the package, the server reparented) ends
RUNNER_PID_ENV = "SWPM_USD_RUNNER_PID"


def _end_with_the_runner(conn: Any) -> None:
    """End this worker process once the runner's end of ``conn`` closes, mid-task too (a thread waiting for
    the hang-up, Linux's ``POLLRDHUP``, which data waiting to be read does not raise). A runner killed with
    SIGKILL (a farm's job killed, the out-of-memory killer) left its workers building: each renamed its
    outputs into place after the run had ended, unlisted in the manifest, while a rerun planned or built the
    same assets. (The kernel's parent-death signal cannot do it: a worker's parent is the fork server, which
    every worker keeps alive.) The runner closes its end only once it no longer wants the worker; what a
    worker ended mid-task leaves, the next run cleans as a killed worker's. Elsewhere a worker ends at its
    next task, finding the pipe closed."""
    hangup = getattr(select, "POLLRDHUP", None)
    if hangup is None:
        return
    fd = conn.fileno()

    def watch() -> None:
        poller = select.poll()
        poller.register(fd, hangup)
        while True:
            for _, event in poller.poll():
                if event & (hangup | select.POLLHUP | select.POLLERR | select.POLLNVAL):
                    os._exit(1)

    threading.Thread(target=watch, name="swpm-pipeline-runner-watch", daemon=True).start()


def serve(conn: Any) -> None:
    """A local pool's worker process (:func:`.runner.execute`): build each task received on ``conn`` and send
    back its record, until ``None`` or the pipe closes. One task at a time, so the runner knows which asset a
    worker that dies (an out-of-memory kill, a crash in native code) or overruns ``limits.seconds`` was
    building. It first sends :data:`READY` and when (``time.monotonic``): the limit times the asset's build
    from then, not the process's start-up (a fork from the server, under load a second or more of a 2 s
    limit: an asset that builds in 1 s was stopped)."""
    ignore_interrupts()
    _end_with_the_runner(conn)
    from ..warnlines import package_warnings_as_lines

    package_warnings_as_lines()  # (a loader's warning: one line naming the file, as the command prints it)
    try:
        conn.send((READY, time.monotonic()))
    except OSError:
        return
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        conn.send(process_asset(task))


def _treatment_digest_of(task: dict[str, Any], input_digest: str) -> str:
    """The task's digest (:func:`.assets.treatment_digest`: the runner's, of its planned rule) with
    ``input_digest`` for the plan's."""
    from .assets import Asset, checks_of, treatment_digest

    asset = Asset(task["id"], Path(task["path"]), task["prim"], task["instances"], task["tags"])
    treatment = {"encoding": task["encoding"], "params": task["params"]}
    checks = checks_of(task) if task["encoding"] == "auto" else None
    version = build_version(treatment)
    if treatment_digest(task["input_digest"], asset, treatment, version, checks) != task["digest"]:
        raise RuntimeError(f"{task['path']}: the plan's digest is not reproduced from its task")  # (a bug)
    return treatment_digest(input_digest, asset, treatment, version, checks)


def _process_asset(task: dict[str, Any]) -> dict[str, Any]:
    start = time.perf_counter()
    rec: dict[str, Any] = {"id": task["id"], "digest": task["digest"], "status": "failed"}
    if task["encoding"] is not None:  # (the digest's build version; a pending rule's: once it is matched)
        rec["build_version"] = build_version({"encoding": task["encoding"]})
    writing = False  # (an OSError once the outputs are written is theirs: OUTPUT_UNWRITABLE)
    try:
        from .. import build as build_pm
        from ..io import load_mesh, triangles_read
        from ..usd.probe import trust

        trust(task.get("probed", ()))  # (probed clean as the run planned: not again in this process)
        # the file and those the loader reads beside it (a glTF's buffers, a stage's layers: the plan's list)
        before = {path: _stat_of(path) for path in task.get("inputs") or [task["path"]]}
        # (an input changed since the plan hashed it: built from the bytes loaded, and those hashed once
        # loaded, their digest and stat recorded, so the record and the .swpm's source digest are of them)
        moved = _moved_since_the_plan(task, before)
        _refuse_a_moved_listing(moved)
        mesh = load_mesh(task["path"], prim_path=task["prim"], max_triangles=task.get("max_triangles"))
        for path, stat in before.items():
            _check_unchanged_by_the_read(path, stat)
        input_digest = task["input_digest"]
        if moved:
            input_digest, rec["inputs"] = _hashed_as_loaded(list(before), before)
            rec["input_digest"] = input_digest
            routed_by = task.get("rule_triangles")
            if routed_by is not None and mesh.triangle_count != routed_by:
                raise InputChangedError(
                    f"{moved[0]}: changed since the run hashed it: {mesh.triangle_count} triangles, its rule "
                    f"chosen for {routed_by}: not built; the next run builds it again"
                )
            if task.get("config_data") is None:
                rec["digest"] = _treatment_digest_of(task, input_digest)
        rec["triangles_in"] = mesh.triangle_count
        # (the count limits.max_triangles is on: a budget set or lowered since is checked against it)
        rec[TRIANGLES_READ] = triangles_read(mesh)
        encoding, params = task["encoding"], task["params"]
        reason = task["why"]
        if task.get("config_data") is not None:  # the planner left the rule to the triangle count
            from .assets import Asset, checks_of, match_rule, treatment_digest
            from .config import Config

            asset = Asset(task["id"], Path(task["path"]), task["prim"], task["instances"], task["tags"])
            rule, treatment, reason = match_rule(
                Config(Path(task["config_path"]), task["config_data"]), asset, mesh.triangle_count
            )
            encoding, params = treatment["encoding"], treatment["params"]
            rec["rule_index"] = rule
            checks = checks_of(task["config_data"]) if treatment["encoding"] == "auto" else None
            rec["build_version"] = build_version(treatment)
            rec["digest"] = treatment_digest(input_digest, asset, treatment, rec["build_version"], checks)
        candidates = None
        if encoding == "auto":
            storable = None
            if task["write_swpm"]:  # only encodings the .swpm format has a layout for
                from ..format.layout import ENCODING_FEATURES

                storable = frozenset(ENCODING_FEATURES)
            pm, why, candidates = choose_auto(mesh, task["instances"], task["budgets"], storable, **params)
            reason = f"{reason}; {why}"
        else:
            pm = build_pm(mesh, encoding, **params)
        rec.update(encoding=pm.encoding, params=pm.params, why=reason, instances=task["instances"])
        if candidates:
            rec["auto_candidates"] = candidates
        problems = check_streaming(pm, task["streaming"])
        total = pm.global_bytes + task["instances"] * pm.instance_bytes
        for key, value in (
            ("global_bytes", pm.global_bytes),
            ("instance_bytes", pm.instance_bytes),
            ("total_bytes", total),
        ):
            if key in task["budgets"] and value > task["budgets"][key]:
                problems.append(f"{key} {value} exceeds budgets.{key}={task['budgets'][key]}")
        rec["summary"] = summarize(pm, int(pm.params.get("cache_size", 16)))
        if problems:
            rec["error"] = "streaming/budget check failed: " + "; ".join(problems)
            rec.update(fields_of("BUDGET_EXCEEDED"))
            return rec
        out_dir = Path(task["out_dir"])
        # every output is made (staged beside its target) before any replaces its old file, and they are
        # renamed into place all or none (:func:`_place_outputs`): a failure leaves the asset's previous
        # outputs as they were
        staged: dict[str, tuple[Path, Path]] = {}
        units = layer_units(task["path"]) if task["write_usd"] else None
        writing = True
        try:
            if task["write_usd"]:
                staged["usd"] = _stage_usd(pm, out_dir / f"{task['stem']}.usdc", task["path"], units)
            if task["write_swpm"]:
                from .. import format as swpm_format

                target = out_dir / f"{task['stem']}.swpm"
                # validate the bytes before they replace anything: a bad build never overwrites a good file
                # ("asset:" + the record's digest, of its input files, treatment and version: spec/format.md
                # 3.1; "sha256:" is encode's, of one file's bytes alone)
                legacy = bool(task.get("legacy_layout", False))
                data = swpm_format.encode_bytes(pm, source_digest="asset:" + rec["digest"], legacy=legacy)
                report = swpm_format.validate_bytes(data, path=str(target))
                if not report.valid:
                    problems = "; ".join(f"{p.code}: {p.message}" for p in report.errors[:5])
                    rec["error"] = "encoded file failed validation: " + problems
                    rec.update(fields_of("BUILD_FAILED"))
                    return rec
                staged["swpm"] = (stage_bytes(target, data), target)
            outputs = _place_outputs({k: staged[k] for k in ("swpm", "usd") if k in staged})
        finally:
            for tmp, _ in staged.values():
                tmp.unlink(missing_ok=True)
        if units is not None:  # (the scene corrects the asset to its units from them: scene._write_scene)
            outputs["usd"].update(units)
        if "swpm" in outputs:  # (the runner rebuilds a .swpm whose layout is not the config's: runner.plan)
            outputs["swpm"].update(swpm_layout(data, legacy))
        rec["outputs"] = outputs
        rec["output_names"] = task.get("output_names", "stem")
        from .assets import checks_of

        rec["checks"] = checks_of(task)  # passed (the task carries the config's budgets and streaming)
        rec["status"] = "built"
    except Exception as exc:  # noqa: BLE001 - one asset's failure must not stop the others
        rec["error"] = f"{type(exc).__name__}: {exc}"
        fields = (
            fields_of("OUTPUT_UNWRITABLE") if writing and isinstance(exc, OSError) else problem_fields(exc)
        )
        rec.update({k: fields[k] for k in PROBLEM_KEYS if k in fields})
        rec["traceback"] = traceback.format_exc(limit=6)
    finally:
        rec["seconds"] = time.perf_counter() - start
    return rec
