"""The pipeline under what an asset farm meets: a full disk, a runner killed with SIGKILL, files it cannot
name, counts it cannot read."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from click.testing import CliRunner

from swpm_usd.cli import main
from swpm_usd.pipeline import run
from swpm_usd.pipeline.worker import USD_TEMPORARY_SUFFIX


def _grid_obj(n: int, note: str = "") -> str:
    """An OBJ of an n x n grid of quads split in two triangles (2 n^2 triangles): small, fast to build."""
    lines = [f"v {x} {y} {(x * y) % 3 * 0.1}" for y in range(n + 1) for x in range(n + 1)]
    for y in range(n):
        for x in range(n):
            a = y * (n + 1) + x + 1
            lines += [f"f {a} {a + 1} {a + n + 2}", f"f {a} {a + n + 2} {a + n + 1}"]
    return "\n".join(lines) + f"\n# {note}\n"


def _project(tmp_path: Path, names=("a", "b"), extra: str = "") -> Path:
    (tmp_path / "meshes").mkdir()
    for name in names:
        (tmp_path / "meshes" / f"{name}.obj").write_text(_grid_obj(8, name))
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out, report: false}\n"
        f"defaults: {{encoding: vanilla}}\n{extra}"
    )
    return cfg


def _files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.name != ".swpm-pipeline.lock"}


def test_a_full_disk_mid_run_names_the_files_and_loses_nothing(tmp_path, monkeypatch):
    # a disk full as an asset is written and then as the manifest is: the error said "[Errno 28] No space
    # left on device" alone (a write's or fsync's OSError names no file), in the asset's failure and in the
    # run's one-line error. Now both name the file; the manifest and the outputs on disk stay as they were
    # (each written whole or not at all), no temporary file is left, and the next run resumes
    cfg = _project(tmp_path)
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    before = _files(out)
    (tmp_path / "meshes" / "b.obj").write_text(_grid_obj(9, "b edited"))  # b to rebuild

    real_fsync = os.fsync

    def full_for(prefix: str):
        def fsync(fd):  # (as a file server reports a full disk: at the flush that sync forces)
            if os.path.basename(os.readlink(f"/proc/self/fd/{fd}")).startswith(prefix):
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            return real_fsync(fd)

        return fsync

    with monkeypatch.context() as m:
        m.setattr(os, "fsync", full_for(".b.swpm."))  # the asset's output alone
        res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and res.failures["meshes/b.obj"]["kept_previous"], res.failures
    assert res.failures["meshes/b.obj"]["error"] == (
        f"OSError: [Errno {errno.ENOSPC}] No space left on device: '{out / 'b.swpm'}'"
    )
    kept = _files(out)
    assert {k: v for k, v in kept.items() if k != "manifest.json"} == {
        k: v for k, v in before.items() if k != "manifest.json"
    }  # (no temporary file, the previous build whole)
    (tmp_path / "meshes" / "b.obj").write_text(_grid_obj(10, "b edited again"))  # (a new failure to record)
    with monkeypatch.context() as m:
        m.setattr(os, "fsync", full_for(""))  # the manifest too
        r = CliRunner().invoke(main, ["run", str(cfg)])
    assert r.exit_code == 1 and not isinstance(r.exception, OSError), (r.exception, r.output)
    # (after the run's start line, one line: its own files' error, naming the manifest)
    start, *rest = r.stderr.splitlines(keepends=True)
    assert start.startswith("[0/1] building 1 asset") and rest, r.stderr
    assert rest == [f"error: {out / 'manifest.json'}: No space left on device\n"], r.stderr
    assert "Traceback" not in r.stderr
    assert _files(out) == kept  # (the manifest as it was, which the files on disk still are)
    res = run(cfg, echo=lambda m: None)  # space again: the run resumes
    assert (res.built, res.skipped, res.failed) == (1, 1, 0)
    manifest = json.loads((out / "manifest.json").read_text())
    assert {k: r["status"] for k, r in manifest["assets"].items()} == {
        "meshes/a.obj": "built",
        "meshes/b.obj": "built",
    }
    assert (out / "a.swpm").read_bytes() == before["a.swpm"] and (out / "b.swpm").read_bytes() != before[
        "b.swpm"
    ]


#: on the path of a run's processes (the fork server and its workers import it as they start): a worker
#: holds each asset, before building it, until the test lets it go on
_HOLD = """\
import os, time
if os.environ.get("SWPM_TEST_HOLD"):
    from swpm_usd.pipeline import worker

    real, hold = worker._process_asset, os.environ["SWPM_TEST_HOLD"]

    def held(task):
        open(os.path.join(hold, f"worker-{os.getpid()}"), "w").close()
        while not os.path.exists(os.path.join(hold, "release")):
            time.sleep(0.02)
        return real(task)

    worker._process_asset = held
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # (a zombie, ended but not reaped, is no worker)
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _held_runner(tmp_path, cfg, hook: str, hold_env: str) -> subprocess.Popen:
    """``run cfg --jobs 2`` in a process whose ``sitecustomize`` is ``hook``, told the folder ``tmp_path /
    "hold"`` (made here) in ``hold_env``: the hook marks its process there and holds until ``release``."""
    hold = tmp_path / "hold"
    hold.mkdir()
    (tmp_path / "hook").mkdir()
    (tmp_path / "hook" / "sitecustomize.py").write_text(hook)
    path = os.pathsep.join([str(tmp_path / "hook"), *filter(None, [os.environ.get("PYTHONPATH")])])
    return subprocess.Popen(
        [sys.executable, "-m", "swpm_usd.cli", "run", str(cfg), "--jobs", "2"],
        env={**os.environ, "PYTHONPATH": path, hold_env: str(hold)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def test_workers_end_with_a_runner_killed_by_sigkill(tmp_path):
    # a runner killed with SIGKILL (a farm's job killed, the out-of-memory killer) left its pool's workers
    # building: each renamed its outputs into place after the run had ended, unlisted in the manifest, while
    # a rerun planned or built the same assets. They end with it now, and the rerun builds everything whole
    cfg = _project(tmp_path, ("a", "b", "c"))
    out, hold = tmp_path / "out", tmp_path / "hold"
    runner = _held_runner(tmp_path, cfg, _HOLD, "SWPM_TEST_HOLD")
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 600  # (the workers' start: the encoders compiled on a cold cache)
        while len(workers) < 2 and time.monotonic() < deadline and runner.poll() is None:
            workers = [int(p.name.split("-")[1]) for p in hold.glob("worker-*")]
            time.sleep(0.05)
        assert len(workers) == 2, "the run's workers did not start"
        runner.send_signal(signal.SIGKILL)
        runner.wait()
        deadline = time.monotonic() + 60
        while any(_alive(p) for p in workers) and time.monotonic() < deadline:
            time.sleep(0.05)
        alive = [p for p in workers if _alive(p)]
    finally:
        (hold / "release").touch()
    assert not alive, "workers still building after their runner was killed"
    time.sleep(0.5)
    assert not list(out.glob("*.swpm"))  # (none written after the run ended)
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.failed) == (3, 0)
    assert sorted(p.name for p in out.iterdir()) == [
        ".swpm-pipeline.lock", "a.swpm", "b.swpm", "c.swpm", "manifest.json",
    ]  # fmt: skip


#: on the path of a run's processes: the fork server, warming up, holds in its first build (its pid named in
#: SWPM_TEST_WARM) until the test lets it go on, as it does compiling the kernels on a cold cache
_HOLD_WARM_UP = """\
import os, sys, time
if os.environ.get("SWPM_TEST_WARM") and "forkserver" in " ".join(sys.orig_argv):
    import swpm_usd.build

    module = sys.modules["swpm_usd.build"]  # (the package's `build` is the function)
    real, hold = module.build, os.environ["SWPM_TEST_WARM"]

    def held(*args, **kwargs):
        open(os.path.join(hold, f"server-{os.getpid()}"), "w").close()
        while not os.path.exists(os.path.join(hold, "release")):
            time.sleep(0.02)
        return real(*args, **kwargs)

    module.build = held
"""


def test_the_fork_server_ends_with_a_runner_killed_during_its_warm_up(tmp_path):
    # the fork server reads its pipe from the runner only once its preloads are imported: a runner killed
    # with SIGKILL while the server warmed up (minutes compiling the kernels on a cold cache) left it
    # compiling on a busy farm node until the end. It ends with the runner now
    cfg = _project(tmp_path, ("a", "b"))
    hold = tmp_path / "hold"
    runner = _held_runner(tmp_path, cfg, _HOLD_WARM_UP, "SWPM_TEST_WARM")
    server: list[int] = []
    try:
        deadline = time.monotonic() + 600  # (the server's start: importing the encoders under load)
        while not server and time.monotonic() < deadline and runner.poll() is None:
            server = [int(p.name.split("-")[1]) for p in hold.glob("server-*")]
            time.sleep(0.05)
        assert server, "the fork server did not start warming up"
        runner.send_signal(signal.SIGKILL)
        runner.wait()
        deadline = time.monotonic() + 60
        while _alive(server[0]) and time.monotonic() < deadline:
            time.sleep(0.05)
        alive = _alive(server[0])
    finally:
        (hold / "release").touch()
        if runner.poll() is None:  # (the server never started warming up: the runner not left behind)
            runner.kill()
            runner.wait()
    assert not alive, "the fork server still warming up after its runner was killed"


def test_a_fork_server_whose_runner_is_gone_before_it_watches_it_ends(monkeypatch):
    # the server watches its parent from its first preload, after importing the package (~0.4 s): a runner
    # SIGKILLed before then left the server reparented, its watch on its new parent (init), never ending, and
    # its warm-up (minutes on a cold cache) run to the end. The runner names itself: another parent ends it
    import pytest

    from swpm_usd.pipeline.worker import RUNNER_PID_ENV, WARM_ENCODINGS_ENV

    monkeypatch.setenv(WARM_ENCODINGS_ENV, "")  # (its import builds nothing)
    from swpm_usd.pipeline import _warm

    def exit_(code: int) -> None:
        raise SystemExit(code)

    def no_pidfd(pid: int) -> int:  # (no watch thread, nor fork hook, in the test's process)
        raise OSError(errno.ENOSYS, "no pidfd")

    monkeypatch.setattr(_warm, "_in_the_fork_server", lambda *a, **k: True)
    monkeypatch.setattr(os, "_exit", exit_)
    monkeypatch.setattr(os, "pidfd_open", no_pidfd, raising=False)
    monkeypatch.setenv(RUNNER_PID_ENV, str(os.getppid()))  # (its runner still its parent: goes on)
    _warm.end_with_the_runner()
    monkeypatch.setenv(RUNNER_PID_ENV, str(os.getppid() + 1))  # (reparented: another parent)
    with pytest.raises(SystemExit):
        _warm.end_with_the_runner()


_FORK_WATCHED = """
import json, os, sys, threading
from swpm_usd.pipeline import _warm
from swpm_usd.pipeline.worker import RUNNER_PID_ENV

os.environ[RUNNER_PID_ENV] = str(os.getppid())
at_fork = []  # (registered first, so run after the watch's own hook: before-hooks run last registered first)
os.register_at_fork(before=lambda: at_fork.append(sorted(t.name for t in threading.enumerate())))
server = {"__name__": "multiprocessing.forkserver"}  # (the watch is the fork server's preload alone)
exec("from swpm_usd.pipeline import _warm\\ndef main():\\n    _warm.end_with_the_runner()", server)


def open_fds():  # (those open once the listing's own is closed)
    def is_open(fd):
        try:
            return os.fstat(int(fd)) is not None
        except OSError:
            return False

    return {fd for fd in os.listdir("/proc/self/fd") if is_open(fd)}


fds = open_fds()
server["main"]()
ours = sorted(open_fds() - fds)  # (the watch's)
watched = sorted(t.name for t in threading.enumerate())
r, w = os.pipe()
pid = os.fork()  # (not from the server loop: an import's fork during the warm-up, another Python's loop)
if pid == 0:
    os.write(w, json.dumps(sorted(set(ours) & open_fds())).encode())
    os._exit(0)
os.waitpid(pid, 0)
os.close(w)
after = sorted(t.name for t in threading.enumerate())
print(json.dumps([watched, at_fork, after, json.loads(os.read(r, 4096)), len(ours)]))
"""


def test_the_fork_servers_watch_is_stopped_before_any_fork_and_watches_again_after(tmp_path):
    # the watch was stopped before the server loop's fork alone, which it told by the frame of
    # multiprocessing.forkserver.main calling os.fork (CPython 3.11's layout): another fork (an import's
    # during the warm-up, a Python whose loop forks elsewhere) forked the process with the thread running.
    # Every fork stops it now (os.register_at_fork), and the server watches its runner again once forked
    from swpm_usd.pipeline.worker import WARM_ENCODINGS_ENV

    env = {**os.environ, WARM_ENCODINGS_ENV: ""}  # (its import builds nothing)
    done = subprocess.run(
        [sys.executable, "-c", _FORK_WATCHED], env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    watched, at_fork, after, kept, opened = json.loads(done.stdout)
    watch = "swpm-forkserver-runner-watch"
    assert watch in watched, watched
    assert at_fork == [["MainThread"]], at_fork  # (the child starts with no other thread)
    assert watch in after, after  # (the server still ends with its runner)
    # (nor with the watch's descriptors: the runner's pidfd, its wake-up pipe)
    assert opened == 3 and kept == [], (opened, kept)


_WORKER_FORKS = """
import json, os, threading, time
from swpm_usd.pipeline.worker import RUNNER_PID_ENV

os.environ[RUNNER_PID_ENV] = str(os.getppid())
server = {"__name__": "multiprocessing.forkserver"}  # (the watch is the fork server's preload alone)
exec("from swpm_usd.pipeline import _warm\\ndef main():\\n    _warm.end_with_the_runner()", server)
server["main"]()
r, w = os.pipe()
pid = os.fork()  # (the server forks a worker)
if pid == 0:
    os.close(r)
    a, b = os.pipe()  # (the worker's own files: the numbers of the watch's descriptors, closed, reused)
    c, d = os.pipe()
    child = os.fork()  # (the worker forks in turn: a library's os.fork)
    if child == 0:
        os._exit(0 if os.write(b, b"") == 0 and os.write(d, b"") == 0 else 3)  # (its pipes still open)
    _, status = os.waitpid(child, 0)
    threads = sorted(t.name for t in threading.enumerate())
    os.write(b, b"x")  # (data on the worker's own pipes: no watch of its server's runner ends it)
    os.write(d, b"x")
    time.sleep(0.3)
    os.write(w, json.dumps([threads, os.waitstatus_to_exitcode(status)]).encode())
    os._exit(0)
os.close(w)
_, status = os.waitpid(pid, 0)
print(json.dumps([os.waitstatus_to_exitcode(status), json.loads(os.read(r, 4096) or b"null")]))
"""


def test_a_worker_that_forks_does_not_watch_its_fork_servers_runner(tmp_path):
    # the at-fork hooks that stop and restart the fork server's watch stayed registered in its workers: a
    # worker that forked in turn started a watch there, on the descriptors it had closed, whose numbers its
    # own files held by then (data on one of them ended the worker, exit 1), and its child closed them again
    from swpm_usd.pipeline.worker import WARM_ENCODINGS_ENV

    env = {**os.environ, WARM_ENCODINGS_ENV: ""}  # (its import builds nothing)
    done = subprocess.run(
        [sys.executable, "-c", _WORKER_FORKS], env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    worker_exit, seen = json.loads(done.stdout)
    assert worker_exit == 0 and seen is not None, (worker_exit, seen)
    threads, grandchild_exit = seen
    assert threads == ["MainThread"], threads  # (no watch started in the worker)
    assert grandchild_exit == 0  # (its child found the worker's pipes open)


def test_a_dry_run_routes_a_file_that_does_not_load_as_the_run_does(tmp_path):
    # a file whose triangle count did not read was planned as if it held 0 triangles: the dry run named the
    # rule of small meshes, which the run never gave it (the run leaves the rule to the worker, which fails
    # to load it). The plan says the count is unknown and leaves the rule to the worker, as the run does
    cfg = _project(tmp_path, ("a",))
    (tmp_path / "meshes" / "broken.ply").write_bytes(
        b"ply\nformat ascii 1.0\nelement vertex 3\nend_header\n1 2\n"
    )
    cfg.write_text(
        cfg.read_text().replace("*.obj", "*")
        + "rules:\n  - {name: tiny, match: {triangles: {max: 100}}, encoding: skip-strip}\n"
    )
    lines: list[str] = []
    res = run(cfg, dry_run=True, echo=lines.append)
    plan = {p["id"]: p for p in res.plan}
    assert plan["meshes/a.obj"]["encoding"] == "vanilla"  # (128 triangles)
    broken = plan["meshes/broken.ply"]
    assert (broken["encoding"], broken["triangles"], broken["triangles_count"]) == (None, None, "unknown")
    assert broken["why"].startswith(
        "rule chosen by the worker: the file did not load to count its triangles ("
    )
    shown = next(ln for ln in lines if ln.startswith("meshes/broken.ply: "))
    assert shown.startswith("meshes/broken.ply: ? {} [to build] triangles=? (unknown: the file did not load)")
    warned = [ln for ln in lines if ln.startswith("warning")]
    assert len(warned) == 1 and warned[0].endswith("rule 'tiny' matches no asset"), warned
    res = run(cfg, echo=lambda m: None)  # the run: the file fails, before any rule
    assert (res.built, res.failed) == (1, 1)
    assert res.warnings == [warned[0].removeprefix("warning: ")]
    assert res.records["meshes/broken.ply"]["rule"] is None, res.records["meshes/broken.ply"]


def test_an_input_that_changes_while_it_is_read_fails_its_asset_alone(tmp_path, monkeypatch):
    # an exporter still writing a file as the worker read it: the mesh read could be part of two versions,
    # and it was built and replaced the asset's previous build. The asset fails, saying so, its previous
    # build kept; the others are built, and the next run builds it from the file as it now is
    import swpm_usd.io as io

    cfg = _project(tmp_path)
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    previous = (out / "b.swpm").read_bytes()
    b = tmp_path / "meshes" / "b.obj"
    b.write_text(_grid_obj(9, "b being written"))
    real = io.load_mesh

    def written_as_read(path, **kw):
        if Path(path).name == "b.obj":
            mesh = real(path, **kw)
            with open(b, "a") as f:  # (the rest of the file, written as the loader ends)
                f.write("# more\n")
            return mesh
        return real(path, **kw)

    (tmp_path / "meshes" / "a.obj").write_text(_grid_obj(9, "a edited"))
    with monkeypatch.context() as m:
        m.setattr(io, "load_mesh", written_as_read)
        res = run(cfg, echo=lambda m: None)
    assert (res.built, res.failed) == (1, 1), res.failures
    failure = res.failures["meshes/b.obj"]
    assert failure["error"].startswith(f"InputChangedError: {b}: changed while it was read (size "), failure
    assert failure["kept_previous"] and (out / "b.swpm").read_bytes() == previous
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped, res.failed) == (1, 1, 0)


def test_a_usd_layer_that_cannot_be_written_is_named_as_its_output(tmp_path, monkeypatch):
    # the layer is exported to a temporary file beside it: a full disk there was named by that file alone
    # (".b.k2j4x9qa.tmp.usdc"), or by none (the sync's error); it is named as the output, as a .swpm is
    import swpm_usd.usd as usd
    from swpm_usd.usd.writer import UsdWriteError

    cfg = _project(tmp_path)
    cfg.write_text(cfg.read_text().replace("report: false", "report: false, usd: true"))
    out = tmp_path / "out"
    real_fsync = os.fsync

    def fsync(fd):
        if os.path.basename(os.readlink(f"/proc/self/fd/{fd}")).startswith(".b."):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_fsync(fd)

    with monkeypatch.context() as m:
        m.setattr(os, "fsync", fsync)
        res = run(cfg, echo=lambda m: None)
    assert (res.built, res.failed) == (1, 1)
    assert (
        res.failures["meshes/b.obj"]["error"]
        == f"OSError: [Errno 28] No space left on device: '{out / 'b.usdc'}'"
    )
    real_write = usd.write

    def write(pm, path, **kw):
        if Path(path).name.startswith(".b."):
            raise UsdWriteError(
                f"{path}: could not write: Error occurred writing file: No space left on device"
            )
        return real_write(pm, path, **kw)

    with monkeypatch.context() as m:
        m.setattr(usd, "write", write)
        res = run(cfg, echo=lambda m: None)
    assert res.failures["meshes/b.obj"]["error"] == (
        f"UsdWriteError: {out / 'b.usdc'}: could not write: Error occurred writing file: "
        "No space left on device"
    )
    assert [p.name for p in out.glob(".*")] == [".swpm-pipeline.lock"]  # (no temporary left)
    assert run(cfg, echo=lambda m: None).built == 1


def test_a_gltf_buffer_that_changes_while_it_is_read_fails_its_asset_alone(tmp_path, monkeypatch):
    # a .gltf's triangles are in the .bin beside it, an input of the asset as the plan lists it: a .bin still
    # being written as the worker read it was not checked (the .gltf alone was), and the mesh read from it
    # was built and replaced the previous build
    import trimesh

    import swpm_usd.io as io

    (tmp_path / "m").mkdir()
    grid = _grid_obj(8)
    points = [[float(c) for c in line.split()[1:]] for line in grid.splitlines() if line.startswith("v ")]
    faces = [[int(c) - 1 for c in line.split()[1:]] for line in grid.splitlines() if line.startswith("f ")]
    files = trimesh.Scene(trimesh.Trimesh(points, faces, process=False)).export(file_type="gltf")
    for name, data in files.items():
        (tmp_path / "m" / name).write_bytes(data)
    buffer = sorted(tmp_path / "m" / name for name in files if name.endswith(".bin"))[0]
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.gltf'}]\noutput: {dir: out, report: false}\n"
        "defaults: {encoding: vanilla}\n"
    )
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    (swpm,) = out.glob("*.swpm")
    previous = swpm.read_bytes()
    buffer.write_bytes(buffer.read_bytes() + b"\0" * 8)  # (past its byteLength: the mesh read is the same)
    real = io.load_mesh

    def written_as_read(path, **kw):
        mesh = real(path, **kw)
        with open(buffer, "ab") as f:  # (its exporter still writing it as the loader ends)
            f.write(b"\0" * 8)
        return mesh

    with monkeypatch.context() as m:
        m.setattr(io, "load_mesh", written_as_read)
        res = run(cfg, echo=lambda m: None)
    assert (res.built, res.failed) == (0, 1), res.failures
    (failure,) = res.failures.values()
    said = f"InputChangedError: {buffer}: changed while it was read (size "
    assert failure["error"].startswith(said), failure
    assert failure["kept_previous"] and swpm.read_bytes() == previous
    assert run(cfg, echo=lambda m: None).built == 1


def test_an_input_changed_at_its_size_is_said_to_be_modified_not_resized(tmp_path):
    # an input rewritten at its size (an exporter rewriting it in place) said "size 88 -> 88 bytes"
    from swpm_usd.pipeline.worker import InputChangedError, _check_unchanged_by_the_read

    f = tmp_path / "a.obj"
    f.write_text("v 0 0 0\n")
    before = os.stat(f)
    os.utime(f, ns=(before.st_atime_ns, before.st_mtime_ns + 5_000_000_000))
    try:
        _check_unchanged_by_the_read(str(f), before)
    except InputChangedError as exc:
        assert str(exc) == (
            f"{f}: changed while it was read (same size, modified or replaced): not built from it; the next "
            "run builds it again"
        )
    else:
        raise AssertionError("not raised")
    _check_unchanged_by_the_read(str(f), os.stat(f))  # (unchanged: nothing raised)


def test_explain_warns_of_an_unreached_rule_once_the_worker_routed_a_file_that_did_not_count(
    tmp_path, monkeypatch
):
    # --explain counts each asset's triangles as it plans (a dry run does), then builds: a file that did not
    # load to be counted (an exporter still writing it as the plan read it) is routed by the worker, which
    # loads it whole. Its rule was left out of the unreached rules warned of before the run, and they were
    # not looked at again after it: "rule 'tiny' matches no asset" for a rule the asset then took
    from swpm_usd.pipeline import runner

    cfg = _project(tmp_path, ("a",))
    cfg.write_text(
        cfg.read_text() + "rules:\n  - {name: tiny, match: {triangles: {max: 1000}}, encoding: skip-strip}\n"
    )
    real = runner._count_triangles

    def not_yet_whole(asset, *a, **kw):
        if asset.path.name == "a.obj":
            raise ValueError(f"{asset.path}: cut short (still being written)")
        return real(asset, *a, **kw)

    monkeypatch.setattr(runner, "_count_triangles", not_yet_whole)
    lines: list[str] = []
    res = run(cfg, explain=True, echo=lines.append)
    assert res.built == 1 and res.records["meshes/a.obj"]["rule"] == "tiny", res.records
    assert res.warnings == [] and not [ln for ln in lines if ln.startswith("warning")], lines


def test_an_output_whose_temporary_file_cannot_be_created_is_named_as_the_output(tmp_path, monkeypatch):
    # each output is written to a temporary file beside it, then renamed: a disk quota met (or a folder
    # refusing files) as that file was created named it (".b.swpm.k2j4x9qa.tmp", a file that is not there)
    # where the output's name was meant, for the .swpm and the USD layer alike
    cfg = _project(tmp_path)
    cfg.write_text(cfg.read_text().replace("report: false", "report: false, usd: true"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    (tmp_path / "meshes" / "b.obj").write_text(_grid_obj(9, "b edited"))
    for refused, named in ((".b.swpm.", "b.swpm"), (USD_TEMPORARY_SUFFIX, "b.usdc")):
        with monkeypatch.context() as m:
            m.setattr(os, "open", _over_quota(os.open, refused))
            res = run(cfg, echo=lambda m: None)
        assert (res.built, res.failed) == (0, 1), res.failures
        error = res.failures["meshes/b.obj"]["error"]
        assert error == f"OSError: [Errno {errno.EDQUOT}] {os.strerror(errno.EDQUOT)}: '{out / named}'", error
        assert not [p.name for p in out.iterdir() if ".tmp" in p.name]


def _over_quota(real_open, refused: str):
    """``os.open`` refusing to create a file whose name starts or ends with ``refused``: a disk quota met."""

    def refuse(path, flags, *a, **kw):
        name = os.path.basename(os.fspath(path))
        if (name.startswith(refused) or name.endswith(refused)) and flags & os.O_CREAT:
            raise OSError(errno.EDQUOT, os.strerror(errno.EDQUOT), os.fspath(path))
        return real_open(path, flags, *a, **kw)

    return refuse
