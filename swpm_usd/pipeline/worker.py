"""One asset's work, run in a worker process (local pool or a Dask task): load, choose, build, check the
streaming order, write the outputs atomically. Never raises: a failure comes back as a record with its cause.
"""

from __future__ import annotations

import contextlib
import hashlib
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
from ..errors import SwpmError
from ..fileio import atomic_write_bytes, keep_aside, stage_bytes  # noqa: F401 - (runner, report import it)

AUTO_CANDIDATES = ("vanilla", "skip-strip", "mixed", "sliding-window")
#: ``encoding: auto``'s ``select`` parameter: what the candidates within the budgets are ranked by.
#: ``acmr``: the ACMR at half the triangles (issue 7's rule, the default). ``misses-at-error``: the
#: vertex-cache misses each draws at equal error, as a renderer picking LODs by error (``lod_for_error``)
#: would draw them: an encoding whose LODs carry more error draws more triangles for the same screen-space
#: error
AUTO_SELECT = ("acmr", "misses-at-error")
#: ``misses-at-error``: the triangle fractions whose errors are the references (see :func:`misses_at_error`)
AUTO_ERROR_FRACTIONS = (0.5, 0.25, 0.1)


def ignore_interrupts() -> None:
    """A pool worker's initializer: Ctrl-C (SIGINT, sent to the terminal's whole process group) is the main
    process's to handle, which stops the workers itself; a worker that took it would print a traceback."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


#: the fields of ``os.stat`` an output's manifest record keeps beside its ``size`` and ``sha256``: a later run
#: that finds the file with the same size and all of these trusts it unchanged without reading it
#: (:func:`.outputs._checked_output`). ``ctime_ns`` moves on any change to the file's data or metadata and
#: cannot be set back (``os.utime`` sets the mtime, not the ctime); ``ino`` and ``dev`` change when another
#: file is renamed over it (a copy written into it, ``cp`` or ``cp -p``, keeps its inode: its ctime moves)
STAT_KEYS = ("mtime_ns", "ctime_ns", "ino", "dev")


def stat_fields(st: os.stat_result) -> dict[str, int]:
    """The :data:`STAT_KEYS` of a stat result."""
    return {"mtime_ns": st.st_mtime_ns, "ctime_ns": st.st_ctime_ns, "ino": st.st_ino, "dev": st.st_dev}


def hash_with_stat(path: Path) -> tuple[str, os.stat_result | None]:
    """The sha256 of ``path`` and its stat, taken through the descriptor it is read from, before the read;
    the stat is None when the file changed while it was read (its size, mtime or ctime moved), so it
    describes the bytes hashed (a file renamed over ``path`` meanwhile is another inode, which the stat of
    the one read does not match)."""
    h = hashlib.sha256()
    st = update_with_stat(h, path)
    return h.hexdigest(), st


def update_with_stat(h: Any, path: Path) -> os.stat_result | None:
    """Feed ``path``'s bytes to the hash object ``h``; its stat as :func:`hash_with_stat` takes it (None
    when the file changed while it was read), for a digest of several files (an asset's inputs)."""
    with open(path, "rb") as f:
        before = os.fstat(f.fileno())
        while chunk := f.read(1 << 20):
            h.update(chunk)
        after = os.fstat(f.fileno())
    same = (before.st_size, before.st_mtime_ns, before.st_ctime_ns) == (
        after.st_size,
        after.st_mtime_ns,
        after.st_ctime_ns,
    )
    return before if same else None


def sha256_file(path: Path) -> str:
    """The sha256 of ``path`` (:func:`hash_with_stat`'s)."""
    return hash_with_stat(path)[0]


def output_record(path: Path) -> dict[str, Any]:
    """A new output's manifest record: its name (``path`` is in output.dir), sha256, size, and the
    :data:`STAT_KEYS` of the bytes hashed (none when the file changed while it was read)."""
    sha, st = hash_with_stat(path)
    rec: dict[str, Any] = {"path": path.name, "sha256": sha}
    if st is not None:
        rec.update(size=st.st_size, **stat_fields(st))
    return rec


def swpm_layout(data: bytes, legacy: bool) -> dict[str, Any]:
    """What the manifest records of a .swpm's integer layout beside its file record: whether it was written
    for a reader before 0.9.0 (``output.legacy_layout``) and the widths its header declares."""
    from ..format.layout import header_widths

    index_width, offset_width = header_widths(data)
    return {"legacy_layout": legacy, "index_width": index_width, "offset_width": offset_width}


def lod_change_cost(pm) -> float:
    """Mean index writes per record when an instance changes LOD (0 for a table look-up)."""
    b = pm.buffers()
    if "collapse_change_count" in b and b["collapse_change_count"].size:
        return float(np.mean(b["collapse_change_count"]))
    return 0.0


def summarize(pm, cache_size: int = 16) -> dict[str, Any]:
    """Figures the manifest and the report show: lambda, ACMR and error per LOD sample, memory."""
    from ..encode.base import stored_index_count
    from ..metrics import acmr

    t0 = max(1, pm.triangle_count_at(0))
    dataset = stored_index_count(pm.buffers())
    curve = []
    for f in np.linspace(1.0, 0.0, 21):
        k = pm.lod_for_triangles(int(round(f * t0)))
        if curve and curve[-1]["lod"] == k:
            continue
        kind, stream = pm.draw_stream(k)
        curve.append(
            {
                "lod": int(k),
                "triangles": pm.triangle_count_at(k),
                "vertices": pm.vertex_count_at(k),
                "error": pm.error_at(k),
                "acmr": acmr(stream, cache_size=cache_size, kind=kind, restart_index=pm.restart_index),
            }
        )
    half = curve[min(range(len(curve)), key=lambda i: abs(curve[i]["triangles"] - t0 / 2))]
    return {
        "lod_count": pm.lod_count,
        "triangles": int(t0),
        "vertices": pm.vertex_count,
        "lambda": dataset / (3 * t0),
        "acmr": half["acmr"],
        "error_at_half": half["error"],
        "global_bytes": int(pm.global_bytes),
        "instance_bytes": int(pm.instance_bytes),
        "lod_change_cost": lod_change_cost(pm),
        "curve": curve,
    }


def misses_at_error(pms: dict[str, Any], fractions=AUTO_ERROR_FRACTIONS, cache_size: int = 16) -> dict:
    """Per encoding, the FIFO misses its draw stream costs at equal error, at each of ``fractions``.

    For each fraction ``f``, the reference error is the smallest that any of ``pms`` (built from one mesh)
    stores for its LOD at ``f`` of LOD 0's triangles (``error_at(lod_for_triangles(...))``), among those whose
    LODs get down to that count (one that stops simplifying above it would offer its coarsest LOD's error);
    a fraction none of them reaches is skipped. Each encoding then draws its coarsest LOD within that error
    (``lod_for_error``), as a renderer selecting by error would, and its misses (cache of ``cache_size``,
    degenerate triangles and strip joins included) are counted. Returns
    ``{encoding: {"misses": [...], "triangles": [...], "reference_errors": [...]}}``, one entry per fraction
    used."""
    from ..metrics import cache_misses

    t0 = max(1, min(pm.triangle_count_at(0) for pm in pms.values()))
    refs = []
    for f in fractions:
        target = int(round(f * t0))
        errs = []
        for pm in pms.values():
            k = pm.lod_for_triangles(target)
            if pm.triangle_count_at(k) <= target:
                errs.append(pm.error_at(k))
        if errs:
            refs.append(min(errs))
    out = {}
    for enc, pm in pms.items():
        misses, tris = [], []
        for e in refs:
            k = pm.lod_for_error(e)
            kind, stream = pm.draw_stream(k)
            misses.append(int(cache_misses(stream, cache_size, kind, pm.restart_index)[0]))
            tris.append(pm.triangle_count_at(k))
        out[enc] = {"misses": misses, "triangles": tris, "reference_errors": [float(e) for e in refs]}
    return out


def _misses_scores(per_encoding: dict) -> dict[str, float]:
    """Per encoding, the geometric mean over the reference errors of its misses over the fewest any encoding
    draws there (1.0: the fewest at every one), so each error weighs alike."""
    encs = list(per_encoding)
    m = np.array([per_encoding[e]["misses"] for e in encs], dtype=np.float64).reshape(len(encs), -1)
    if m.shape[1] == 0:
        return dict.fromkeys(encs, 1.0)
    ratio = np.maximum(m, 1.0) / np.maximum(m.min(axis=0), 1.0)
    return {e: float(np.exp(np.log(ratio[i]).mean())) for i, e in enumerate(encs)}


def choose_auto(
    mesh,
    instances: int,
    budgets: dict,
    storable: frozenset[str] | None = None,
    select: str = "acmr",
) -> tuple[Any, str, dict]:
    """Build every candidate, measure, and pick (Forsyth's table with measured numbers).

    Within the memory budgets (global + instances x instance bytes), the lowest ACMR at half the triangles
    wins (``select="acmr"``), or the fewest vertex-cache misses at equal error (``select="misses-at-error"``:
    :func:`misses_at_error`, each encoding's misses over the fewest at every reference error, geometric
    mean); values within 5 % are a tie, broken by total memory, then by LOD-change cost.
    If nothing fits the budgets, the smallest total memory wins and the reason says so.
    """
    if select not in AUTO_SELECT:
        raise ValueError(f"auto: select must be one of {', '.join(AUTO_SELECT)}, got {select!r}")
    from ..build import build
    from ..encode import BUILDERS

    measured = {}
    built = {}
    for enc in AUTO_CANDIDATES:
        if enc not in BUILDERS or (storable is not None and enc not in storable):
            continue
        pm = build(mesh, enc)
        s = summarize(pm)
        s["total_bytes"] = s["global_bytes"] + instances * s["instance_bytes"]
        measured[enc] = {k: v for k, v in s.items() if k != "curve"}
        built[enc] = pm

    def fits(m: dict) -> bool:
        return (
            m["total_bytes"] <= budgets.get("total_bytes", float("inf"))
            and m["global_bytes"] <= budgets.get("global_bytes", float("inf"))
            and m["instance_bytes"] <= budgets.get("instance_bytes", float("inf"))
        )

    if select == "misses-at-error" and built:
        # the reference errors come from every candidate, within the budgets or not: they only pick the
        # error levels at which the candidates are compared
        per_encoding = misses_at_error(built)
        scores = _misses_scores(per_encoding)
        for enc, m in per_encoding.items():
            measured[enc]["misses_at_error"] = m["misses"]
            measured[enc]["misses_at_error_score"] = scores[enc]
            measured[enc]["triangles_at_error"] = m["triangles"]
            measured[enc]["reference_errors"] = m["reference_errors"]
    key = "acmr" if select == "acmr" else "misses_at_error_score"
    ok = [e for e in measured if fits(measured[e])]
    if ok:
        best = min(measured[e][key] for e in ok)
        tied = [e for e in ok if measured[e][key] <= 1.05 * best]
        pick = min(tied, key=lambda e: (measured[e]["total_bytes"], measured[e]["lod_change_cost"]))
        if select == "acmr":
            what = f"ACMR {measured[pick]['acmr']:.3f} (best within budget {best:.3f})"
        else:
            what = (
                f"{measured[pick]['misses_at_error_score']:.2f}x the fewest cache misses at equal error "
                f"(best within budget {best:.2f}x; geometric mean over the errors stored at "
                f"{', '.join(f'{f:g}' for f in AUTO_ERROR_FRACTIONS)} of the triangles)"
            )
        why = (
            f"auto: {pick} has {what} and "
            f"{measured[pick]['total_bytes']} bytes for {instances} instance(s); candidates within budget: "
            f"{', '.join(sorted(ok))}"
        )
    else:
        pick = min(measured, key=lambda e: measured[e]["total_bytes"])
        why = (
            f"auto: no encoding fits the budgets; {pick} needs the least memory "
            f"({measured[pick]['total_bytes']} bytes for {instances} instance(s))"
        )
    return built[pick], why, measured


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
        usd_write(pm, tmp, name=target.stem.split(".")[0] or None, **meta)
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


class InputChangedError(SwpmError, RuntimeError):
    """The input file changed while the worker read it (an exporter still writing it, a sync replacing it):
    the mesh read may be part of one version and part of another, so it is not built (the asset's previous
    build is kept), and the next run, finding the file's stat moved, hashes and builds it again. ``path``:
    the file, for a JSON error's ``file`` and ``format`` (``encode``'s; a run's record names its asset)."""

    code = "INPUT_CHANGED"

    def __init__(self, message: str, path: str | None = None) -> None:
        from ..codes import format_of

        super().__init__(message)
        self.file, self.format = path, format_of(path)


def _stat_of(path: str) -> os.stat_result | None:
    try:
        return os.stat(path)
    except OSError:  # (gone: the loader says so, naming the file)
        return None


def _check_unchanged_by_the_read(path: str, before: os.stat_result | None) -> None:
    """Raise :class:`InputChangedError` when the file at ``path`` is not the one stat ``before`` saw as the
    read began (its size, mtime, ctime or inode moved). A change before the read began is not one: that file
    is read whole, and the next run hashes it (the record keeps the stat taken as the plan hashed it)."""
    after = _stat_of(path)
    if before is None or after is None:
        return
    if (before.st_size, *stat_fields(before).values()) != (after.st_size, *stat_fields(after).values()):
        moved = (
            f"size {before.st_size} -> {after.st_size} bytes"
            if before.st_size != after.st_size
            else "same size, modified or replaced"
        )
        raise InputChangedError(
            f"{path}: changed while it was read ({moved}): not built from it; the next run builds it again"
        )


def _moved_since_the_plan(task: dict[str, Any], before: dict[str, os.stat_result | None]) -> list[str]:
    """The inputs whose stat ``before`` the load is not the one the plan hashed (or trusted) them at (the
    task's ``input_stats``: each input's size and :data:`STAT_KEYS`; None for one it has no stat for, hashed
    while it changed or unreadable, which is one): the task's input digest is not of the bytes the worker
    loads. A file gone is not one (the loader says so, naming it), nor one ``input_stats`` does not name."""
    planned = task.get("input_stats") or {}
    return [
        path
        for path, st in before.items()
        if st is not None and path in planned and planned[path] != [st.st_size, *stat_fields(st).values()]
    ]


def _refuse_a_moved_listing(moved: list[str]) -> None:
    """Raise :class:`InputChangedError` for an input moved since the plan whose bytes list the asset's other
    inputs (a glTF's buffers, a USD file's layers: :data:`.assets.LISTED_SUFFIXES`): the files the loader
    reads may be others than the plan's, which the record would list as the asset's, unread by the next run
    (it takes a built record's list while the files it names are unchanged)."""
    from .assets import LISTED_SUFFIXES

    for path in moved:
        if Path(path).suffix.lower() in LISTED_SUFFIXES:
            raise InputChangedError(
                f"{path}: changed since the run hashed it (an exporter still writing it?): not built from "
                "it (the files it names may be others); the next run builds it again"
            )


def _hashed_as_loaded(
    inputs: list[str], before: dict[str, os.stat_result | None]
) -> tuple[str, list[dict[str, Any]]]:
    """The digest of ``inputs`` and their entries (:func:`.assets.hash_inputs`), hashed once the load has
    read them, each the file stat ``before`` saw as the load began (so the bytes loaded): else
    :class:`InputChangedError`."""
    from .assets import hash_inputs

    digest, entries = hash_inputs([Path(p) for p in inputs])
    for path, entry in zip(inputs, entries, strict=True):
        st = before.get(path)
        seen = None if st is None else {"size": st.st_size, **stat_fields(st)}
        if seen is None or {k: entry.get(k) for k in seen} != seen:
            raise InputChangedError(
                f"{path}: changed while it was read (hashed once loaded, it was another): not built from it; "
                "the next run builds it again"
            )
    return digest, entries


def _treatment_digest_of(task: dict[str, Any], input_digest: str) -> str:
    """The task's digest (:func:`.assets.treatment_digest`: the runner's, of its planned rule) with
    ``input_digest`` for the plan's."""
    from .. import __version__
    from .assets import Asset, checks_of, treatment_digest

    asset = Asset(task["id"], Path(task["path"]), task["prim"], task["instances"], task["tags"])
    treatment = {"encoding": task["encoding"], "params": task["params"]}
    checks = checks_of(task) if task["encoding"] == "auto" else None
    if treatment_digest(task["input_digest"], asset, treatment, __version__, checks) != task["digest"]:
        raise RuntimeError(f"{task['path']}: the plan's digest is not reproduced from its task")  # (a bug)
    return treatment_digest(input_digest, asset, treatment, __version__, checks)


def _process_asset(task: dict[str, Any]) -> dict[str, Any]:
    start = time.perf_counter()
    rec: dict[str, Any] = {"id": task["id"], "digest": task["digest"], "status": "failed"}
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
            from .. import __version__
            from .assets import Asset, checks_of, match_rule, treatment_digest
            from .config import Config

            asset = Asset(task["id"], Path(task["path"]), task["prim"], task["instances"], task["tags"])
            rule, treatment, reason = match_rule(
                Config(Path(task["config_path"]), task["config_data"]), asset, mesh.triangle_count
            )
            encoding, params = treatment["encoding"], treatment["params"]
            rec["rule_index"] = rule
            checks = checks_of(task["config_data"]) if treatment["encoding"] == "auto" else None
            rec["digest"] = treatment_digest(input_digest, asset, treatment, __version__, checks)
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
