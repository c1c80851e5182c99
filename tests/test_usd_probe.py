"""Corrupt crate (.usdc) files that crash usd-core: validate, the loader, ``build`` and the pipeline report
them as typed errors naming the file, and never crash (``swpm_usd.usd.probe``).

The crashing file is found by a sweep over byte flips of a small valid file (every offset, in a scratch
folder): flipping byte 88 of :func:`_seed` (the first bytes of its data after the crate's 88-byte header)
makes ``Usd.Stage.Open`` plus a read of its values die by SIGSEGV in usd-core 26.11. Each test runs the
command in a child process: before the probe, the command itself died.
"""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from pxr import Sdf, Usd, UsdGeom, Vt

from swpm_usd.errors import MeshLoadError
from swpm_usd.io import load_mesh
from swpm_usd.usd import probe

SAMPLES = Path(__file__).resolve().parents[1] / "samples"
TWO_TRIANGLES = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"
#: a child's open and read of a USD file with usd-core alone (no probe): its exit code
_RAW_READ = """
import sys
from pxr import Usd
stage = Usd.Stage.Open(sys.argv[1])
for prim in stage.Traverse():
    for attr in prim.GetAttributes():
        attr.Get()
"""


#: the signals usd-core dies by on the crashing file: which one depends on the memory the corrupt read hits
_CRASHES = ("SIGSEGV", "SIGABRT", "SIGBUS")


def _seed(path: Path) -> Path:
    """A valid .usdc: 200 triangles of spot in one Mesh ``/m`` (tests/test_fuzz_io.py's seed)."""
    spot = load_mesh(SAMPLES / "spot.obj")
    sub = trimesh.Trimesh(spot.points, spot.triangles, process=False).submesh([np.arange(200)], append=True)
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/m")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(sub.vertices, np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(sub.faces), 3, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(sub.faces, np.int32).reshape(-1)))
    stage.GetRootLayer().Save()
    del stage
    return path


_CRASHING: list[bytes] = []


def _crashing(path: Path) -> Path:
    """:func:`_seed` (written beside ``path`` as ``seed-<name>``) with byte 88 flipped, at ``path``: usd-core
    crashes on it (asserted once a session: a test of a file it survives would prove nothing)."""
    seed = _seed(path.with_name("seed-" + path.name))
    data = bytearray(seed.read_bytes())
    data[88] ^= 0xFF
    path.write_bytes(bytes(data))
    if bytes(data) not in _CRASHING:
        raw = subprocess.run([sys.executable, "-c", _RAW_READ, str(path)], capture_output=True, timeout=120)
        assert raw.returncode < 0, f"usd-core survives {path} (exit {raw.returncode}): find another case"
        _CRASHING.append(bytes(data))
    return path


def _cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "swpm_usd.cli", *args], capture_output=True, text=True, timeout=600, cwd=cwd
    )


def _files_probed(monkeypatch) -> list[str]:
    """The files the probe server is asked to probe, each batch's appended as it is asked (the real probe
    still runs)."""
    asked: list[str] = []
    real = probe._probe_all
    monkeypatch.setattr(
        probe, "_probe_all", lambda files, jobs: asked.extend(p for p, _ in files) or real(files, jobs)
    )
    return asked


def test_a_process_that_probed_a_file_exits_without_a_resource_warning(tmp_path):
    # the probe server a load starts used to be left running at exit, its pipes open: Python warned of
    # "subprocess ... is still running" and of two unclosed files at the exit of a process that loaded a crate
    seed = _seed(tmp_path / "seed.usdc")
    code = "import sys\nfrom swpm_usd.io import load_mesh\nprint(load_mesh(sys.argv[1]).triangle_count)\n"
    done = subprocess.run(
        [sys.executable, "-W", "always::ResourceWarning", "-c", code, str(seed)],
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert done.returncode == 0 and done.stdout == "200\n", done.stderr
    assert "ResourceWarning" not in done.stderr, done.stderr


def test_a_forked_process_whose_server_cannot_start_leaves_its_parents_server_running(tmp_path, monkeypatch):
    # a process forked after its parent started a probe server has the parent's server as its own `_server`;
    # when its own could not start (OSError), or on Ctrl-C before it had one, it killed the parent's
    seed = _seed(tmp_path / "seed.usdc")
    parents = subprocess.Popen(
        [sys.executable, "-c", "import sys; sys.stdin.read()"], stdin=subprocess.PIPE, stdout=subprocess.PIPE
    )
    try:
        monkeypatch.setattr(probe, "_server", parents)
        monkeypatch.setattr(probe, "_server_pid", os.getpid() + 1)  # (as in a process forked from it)

        def no_process(*args, **kwargs):
            raise OSError("no process can be started")

        monkeypatch.setattr(probe.subprocess, "Popen", no_process)
        problem, _ = probe._probe_all([(str(seed), seed.stat().st_size)], 1)[str(seed)]
        assert problem is not None and problem.kind == "probe", problem
        assert "no process can be started" in problem.message, problem
        assert parents.poll() is None, "the parent's server was killed"
    finally:
        parents.kill()
        parents.wait()
        for pipe in (parents.stdin, parents.stdout):
            pipe.close()


def test_validate_reports_a_usdc_that_crashes_usd_core_as_a_coded_error(tmp_path):
    # `swpm-pipeline validate bad.usdc` died by SIGSEGV (no output, exit -11)
    bad = _crashing(tmp_path / "bad.usdc")
    binary_usd = tmp_path / "bad.usd"  # (a .usd written binary is a crate file too)
    binary_usd.write_bytes(bad.read_bytes())
    for path in (bad, binary_usd):
        done = _cli("validate", str(path), "--json")
        assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
        rep = json.loads(done.stdout)
        assert rep["errors"] == 1 and len(rep["findings"]) == 1
        finding = rep["findings"][0]
        assert finding["code"] == "SWPM_USD_CRASH" and finding["severity"] == "error"
        assert finding["message"].startswith(f"{path}: usd-core crashed") and any(
            s in finding["message"] for s in _CRASHES
        )
    done = _cli("validate", str(bad))
    assert done.returncode == 1 and "SWPM_USD_CRASH" in done.stdout and "Traceback" not in done.stderr
    # the seed it was made from validates clean through the same probe (our validator: it has no
    # defaultPrim or upAxis, which usd-core's own validators report)
    done = _cli("validate", str(tmp_path / "seed-bad.usdc"), "--json", "--no-builtin")
    assert done.returncode == 0 and json.loads(done.stdout)["errors"] == 0, done.stdout + done.stderr


def test_the_loader_and_build_fail_a_usdc_that_crashes_usd_core_with_a_mesh_load_error(tmp_path):
    bad = _crashing(tmp_path / "bad.usdc")
    code = (
        "import sys\nfrom swpm_usd.errors import MeshLoadError\nfrom swpm_usd.io import load_mesh\n"
        "try:\n    load_mesh(sys.argv[1])\nexcept MeshLoadError as e:\n    print(repr((e.path, str(e))))\n"
    )
    done = subprocess.run([sys.executable, "-c", code, str(bad)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, (done.returncode, done.stderr)
    path, message = eval(done.stdout)  # noqa: S307 - our own repr of two strings
    assert path == str(bad) and message.startswith(f"{bad}: usd-core crashed opening or reading it")
    done = _cli("build", str(bad), "--json")
    assert done.returncode == 1 and json.loads(done.stdout)["error"] == message, done.stdout + done.stderr


def test_load_and_read_file_fail_a_usdc_that_crashes_usd_core_with_a_usd_read_error(tmp_path):
    # swpm_usd.load / usd.read_file opened the stage in the calling process, unprobed: the process died by
    # SIGSEGV (exit -11) where validate and the loader name the file
    bad = _crashing(tmp_path / "bad.usdc")
    code = (
        "import sys\nimport swpm_usd\nfrom swpm_usd import usd\n"
        "from swpm_usd.usd.reader import UsdReadError\n"
        "for read in (swpm_usd.load, usd.read_file):\n"
        "    try:\n        read(sys.argv[1])\n    except UsdReadError as e:\n        print(e)\n"
    )
    done = subprocess.run([sys.executable, "-c", code, str(bad)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, (done.returncode, done.stderr)
    lines = done.stdout.splitlines()
    assert len(lines) == 2 and lines[0] == lines[1], lines
    assert lines[0].startswith(f"{bad}: usd-core crashed opening or reading it"), lines


def _write_overrides_and_usdlod(source: Path, tmp_path: Path) -> list[str]:
    """The errors ``write_overrides`` and ``write_usdlod`` of ``source`` raise (a line each: type, message),
    run in a child process (on a crashing file, one that survives)."""
    code = (
        "import sys\nfrom swpm_usd import usd\nfrom swpm_usd.errors import SwpmError\n"
        "for write in (lambda: usd.write_overrides(sys.argv[1], sys.argv[2]),\n"
        "              lambda: usd.write_usdlod(sys.argv[1], sys.argv[3])):\n"
        "    try:\n        write()\n    except SwpmError as e:\n        print(type(e).__name__, e)\n"
    )
    args = [str(source), str(tmp_path / "over.usda"), str(tmp_path / "lod.usda")]
    done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, (done.returncode, done.stderr)
    return done.stdout.splitlines()


def test_write_overrides_and_write_usdlod_refuse_a_usdc_that_crashes_usd_core(tmp_path):
    # each opens a stage it is given (the source of the overrides, the asset the LOD layer references)
    bad = _crashing(tmp_path / "bad.usdc")
    lines = _write_overrides_and_usdlod(bad, tmp_path)
    assert len(lines) == 2 and all("usd-core crashed opening or reading it" in line for line in lines), lines
    assert lines[0].startswith(f"UsdOverrideError {bad}: ") and lines[1].startswith(f"UsdWriteError {bad}: ")
    assert not (tmp_path / "over.usda").exists() and not (tmp_path / "lod.usda").exists()


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_pipeline_fails_a_usdc_that_crashes_usd_core_alone(tmp_path, jobs):
    # the run opens a USD asset's stage as it plans (the layers it uses are its inputs) and, --jobs 1, builds
    # in its own process: the whole run died by SIGSEGV, the good asset beside the bad one unbuilt
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    _crashing(tmp_path / "bad.usdc").rename(tmp_path / "m" / "bad.usdc")
    (tmp_path / "c.yaml").write_text(
        "version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    done = _cli("run", str(tmp_path / "c.yaml"), "--jobs", jobs, "--json")
    assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
    summary = json.loads(done.stdout)
    assert summary["built_assets"] == ["m/a.obj"] and summary["failed"] == 1
    (failure,) = summary["failures"]
    assert failure["id"] == "m/bad.usdc" and "usd-core crashed opening or reading it" in failure["error"]
    assert "bad.usdc" in failure["error"] and (tmp_path / "out" / "a.swpm").is_file()


def test_a_stage_asset_that_crashes_usd_core_is_a_config_error_naming_it(tmp_path):
    # a `stage:` source is opened as the run plans: the run died by SIGSEGV; it is the error of a stage
    # that does not open (exit 2, located)
    _crashing(tmp_path / "scene.usdc")
    (tmp_path / "c.yaml").write_text("version: 1\nassets: [{stage: scene.usdc}]\noutput: {dir: out}\n")
    done = _cli("run", str(tmp_path / "c.yaml"))
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    assert "cannot open stage scene.usdc: usd-core crashed opening or reading it" in done.stderr


def test_a_crate_file_is_probed_once_per_process_and_a_text_one_never(tmp_path, monkeypatch):
    seed = _seed(tmp_path / "a.usdc")
    text = tmp_path / "a.usda"
    Usd.Stage.Open(str(seed)).Export(str(text))
    asked = _files_probed(monkeypatch)
    assert load_mesh(seed).triangle_count == 200 and load_mesh(seed).triangle_count == 200
    assert load_mesh(text).triangle_count == 200
    assert asked == [str(seed)]
    seed.write_bytes(seed.read_bytes())  # (another inode or mtime: the file may have changed)
    os.utime(seed, ns=(1, 1))
    assert probe.check(seed) is None and asked == [str(seed)] * 2


def test_a_probe_reports_a_giant_allocation_as_an_open_error_within_its_memory_limit(tmp_path):
    # a section's count (FIELDSETS, read as the layer opens) set to 2**40 entries asks usd-core for
    # terabytes: in the probe, under its address-space limit, a std::bad_alloc usd-core reports
    data = bytearray(_seed(tmp_path / "seed.usdc").read_bytes())
    (toc,) = struct.unpack_from("<q", data, 16)
    (count,) = struct.unpack_from("<Q", data, toc)
    sections = {}
    for i in range(count):
        name, start, _ = struct.unpack_from("<16sqq", data, toc + 8 + 32 * i)
        sections[name.rstrip(b"\0")] = start
    struct.pack_into("<Q", data, sections[b"FIELDSETS"], 1 << 40)
    bad = tmp_path / "giant.usdc"
    bad.write_bytes(bytes(data))
    found = probe.check(bad)
    assert found is not None and found.kind == "open", found
    assert (
        found.message.startswith(f"{bad}: usd-core cannot open it as a USD layer")
        and "bad_alloc" in found.message
    )
    assert probe._server is not None and probe._server.poll() is None  # (the probe server lives on)
    assert probe.check(_seed(tmp_path / "good.usdc")) is None


def test_each_file_is_probed_in_a_fresh_process_and_a_crash_leaves_the_server(tmp_path, monkeypatch):
    # whether usd-core's read past the corrupt data crashes depends on the process's memory: a probe server
    # that opened files itself, having served many, got an error instead of the crash. Each probe is a fresh
    # fork of a server that opens none. (Deterministic: a probe program that records its pid, and kills
    # itself by SIGSEGV on bad.usdc where usd-core might or might not crash; the real file is the next test)
    pids = tmp_path / "pids"
    _patched_program(
        monkeypatch,
        "def probe(path):\n",
        "def probe(path):\n"
        f"    with open({str(pids)!r}, 'a') as f:\n"
        "        f.write(f'{os.getpid()}\\n')\n"
        "    if path.endswith('bad.usdc'):\n"
        "        os.kill(os.getpid(), signal.SIGSEGV)\n",
    )
    try:
        for i in range(3):
            assert probe.check(_seed(tmp_path / f"good{i}.usdc")) is None
        server = probe._server
        assert server is not None
        bad = _seed(tmp_path / "bad.usdc")
        found = probe.check(bad)
        assert found is not None and found.kind == "crash" and "died by SIGSEGV" in found.message, found
        assert found.message.startswith(f"{bad}: "), found
        assert probe._server is server and server.poll() is None  # (the server outlives its probe's crash)
        assert probe.check(_seed(tmp_path / "good.usdc")) is None
        assert probe._server is server
        forked = [int(line) for line in pids.read_text().split()]
        # (five probes, five processes, none of them the server)
        assert len(forked) == 5 and len(set(forked)) == 5 and server.pid not in forked, forked
    finally:
        probe._stop(probe._server)  # (the next test's server runs the real program)


def test_a_file_usd_core_crashes_on_is_answered_and_leaves_the_server(tmp_path):
    # the real corrupt file: usd-core mostly dies on it (SIGSEGV, SIGABRT: the memory the corrupt read hits
    # decides), though under load a probe once got an error instead. Either way an answer that keeps the
    # file out of this process, the server alive for the next file
    assert probe.check(_seed(tmp_path / "good0.usdc")) is None
    server = probe._server
    bad = _crashing(tmp_path / "bad.usdc")
    found = probe.check(bad)
    assert found is not None and found.message.startswith(f"{bad}: "), found
    if found.kind == "crash":
        assert any(f"died by {s}" in found.message for s in _CRASHES), found
    else:
        assert found.kind in ("open", "read"), found
    assert probe._server is server and server.poll() is None
    assert probe.check(_seed(tmp_path / "good.usdc")) is None


def _vanilla_layer_bytes(tmp_path: Path) -> bytearray:
    """The bytes of a vanilla asset layer of 200 of spot's triangles: the seed of the token-flip sweep."""
    import swpm_usd
    from swpm_usd import usd

    obj = tmp_path / "seed.obj"
    spot = load_mesh(SAMPLES / "spot.obj")
    trimesh.Trimesh(spot.points, spot.triangles, process=False).submesh([np.arange(200)], append=True).export(
        obj
    )
    layer = usd.write(swpm_usd.build(obj, encoding="vanilla"), tmp_path / "seed_vanilla.usdc")
    return bytearray(layer.read_bytes())


def test_a_token_that_is_not_utf8_is_a_value_usd_core_cannot_read(tmp_path):
    # found by the sweep over byte flips of a vanilla asset layer: a flip in its compressed tokens gives
    # swpm:bufferNames a token that is not UTF-8, and `validate` printed a traceback (UnicodeDecodeError, as
    # Python reads the token) where the loader had not read that value. The probe reads every value: it is
    # SWPM_USD_READ, and the loader's MeshLoadError
    from swpm_usd import usd

    data = _vanilla_layer_bytes(tmp_path)
    # (a byte of the compressed TOKENS section whose flip garbles bufferNames' token alone: 6990 until the
    # root prim gained assetInfo in 0.9.2, which moved the section; found again by a sweep over its bytes)
    data[7104] ^= 0xFF
    bad = tmp_path / "bad.usdc"
    bad.write_bytes(bytes(data))
    stage = Usd.Stage.Open(str(bad))  # (the value as Python reads it: the defect's precondition)
    with pytest.raises(UnicodeDecodeError):
        list(usd.find_encoded(stage)[0].GetAttribute("swpm:bufferNames").Get())
    del stage
    done = _cli("validate", str(bad), "--json")
    assert done.returncode == 1, (done.stdout, done.stderr)
    (finding,) = json.loads(done.stdout)["findings"]
    assert finding["code"] == "SWPM_USD_READ" and finding["message"].startswith(
        f"{bad}: usd-core cannot read it"
    )
    assert "not UTF-8" in finding["message"] and "Traceback" not in done.stderr


def test_a_metadata_token_that_is_not_utf8_is_a_value_usd_core_cannot_read(tmp_path):
    # the same sweep's other flips: one garbles a token of the prim's apiSchemas list op (metadata, whose
    # items the probe's GetAllMetadata left unread): `validate` printed a traceback (UnicodeDecodeError in
    # is_encoded) where it is SWPM_USD_READ, as a value's

    data = _vanilla_layer_bytes(tmp_path)
    data[6702] ^= 0xFF  # (found by the sweep over the TOKENS section's bytes)
    bad = tmp_path / "bad.usdc"
    bad.write_bytes(bytes(data))
    stage = Usd.Stage.Open(str(bad))  # (the defect's precondition: the list op's items as Python reads them)
    with pytest.raises(UnicodeDecodeError):
        for prim in stage.Traverse():
            ops = prim.GetMetadata("apiSchemas")
            if ops:
                ops.GetAddedOrExplicitItems()
    del stage
    done = _cli("validate", str(bad), "--json")
    assert done.returncode == 1 and "Traceback" not in done.stderr, (done.stdout, done.stderr)
    codes = [f["code"] for f in json.loads(done.stdout)["findings"]]
    assert "SWPM_USD_READ" in codes, codes


def test_a_small_files_probe_does_not_pay_usd_cores_start_each_time(tmp_path, monkeypatch):
    # each probe is a fresh fork of the server: one that had not built usd-core's schema registry (its first
    # stage does, ~25 ms) paid it in every fork, ~35-40 ms a small file, a pipeline's planning of thousands of
    # .usdc assets that much each, serially (a build of 60 small .usdc assets, --jobs 1, took twice main's
    # time; the speed itself is benchmarks/' to measure). Asserted by structure, not by a wall time: the
    # server is started once and warms usd-core (its schema registry) once, before its first probe, and
    # every probe is a process forked from it (inheriting that), a fresh one per file
    log = tmp_path / "log"
    program = probe._PROBE
    for kind, line in (("warm", "def warm():\n"), ("probe", "def probe(path):\n")):
        assert line in program
        record = f"open({str(log)!r}, 'a').write(f'{kind} {{os.getpid()}} {{os.getppid()}}\\n')"
        program = program.replace(line, f"{line}    {record}\n")
    monkeypatch.setattr(probe, "_PROBE", program)
    probe._stop(probe._server)  # (a fresh server runs it)
    try:
        seed = _seed(tmp_path / "seed.usdc")
        copies = [seed]
        for i in range(4):
            copies.append(tmp_path / f"c{i}.usdc")
            copies[-1].write_bytes(seed.read_bytes())
        for copy in copies[:3]:
            assert probe.check(copy) is None
        assert probe.check_many(copies[3:]) == [None, None]
        server = probe._server
        assert server is not None and server.poll() is None
        lines = [line.split() for line in log.read_text().splitlines()]
        assert lines[0] == ["warm", str(server.pid), str(os.getpid())], lines  # (started once, by us)
        probes = [(int(pid), int(parent)) for kind, pid, parent in lines[1:] if kind == "probe"]
        assert len(lines) == 1 + len(copies) and len(probes) == len(copies), lines  # (warmed once)
        assert all(parent == server.pid for _, parent in probes), (server.pid, probes)  # (forked by it)
        assert len({pid for pid, _ in probes} | {server.pid}) == len(copies) + 1, probes  # (fresh each)
    finally:
        probe._stop(probe._server)  # (the next test's server runs the real program)


def test_a_probe_interrupted_while_waiting_does_not_give_its_answer_to_the_next_file(tmp_path, monkeypatch):
    # Ctrl-C (KeyboardInterrupt) while this process waited for a probe's answer left the answer in the
    # server's output: the next file's check read it, the crash of the file interrupted given as another's
    # (or a clean answer as a crashing file's: then opened in this process)
    bad = _crashing(tmp_path / "bad.usdc")
    good = _seed(tmp_path / "good.usdc")
    real_select = probe.select.select
    interrupted: list[bool] = []

    def select_interrupted_once(*args):
        if not interrupted:
            interrupted.append(True)
            raise KeyboardInterrupt
        return real_select(*args)

    monkeypatch.setattr(probe.select, "select", select_interrupted_once)
    with pytest.raises(KeyboardInterrupt):
        probe.check(bad)
    assert probe.check(good) is None
    found = probe.check(bad)
    assert found is not None and found.kind == "crash", found


def test_a_pipeline_worker_does_not_probe_again_a_usdc_the_run_probed_as_it_planned(tmp_path, monkeypatch):
    # the planning probes a new .usdc asset (it opens its stage for the layers it uses); each worker is
    # another process, and probed it again: a build of many small .usdc assets, --jobs 2, paid two probes
    # an asset. The task carries the planning's answer (the file's key); a file changed since is probed
    from swpm_usd.pipeline import runner, worker
    from swpm_usd.pipeline.assets import Asset
    from swpm_usd.pipeline.config import load_config

    (tmp_path / "m").mkdir()
    seed = _seed(tmp_path / "m" / "a.usdc")
    cfg_path = tmp_path / "c.yaml"
    cfg_path.write_text(
        "version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    cfg = load_config(cfg_path)
    assert probe.check(seed) is None  # (as the run planned)
    item = runner.PlanItem(
        Asset("m/a.usdc", seed, None, 1, {}, 0), "0" * 64, None, treatment={"encoding": "vanilla"}, digest="d"
    )
    task = runner._task(cfg, item)
    asked = _files_probed(monkeypatch)
    monkeypatch.setattr(probe, "_answers", {})  # (a worker: another process, nothing probed)
    rec = worker._process_asset(task)
    assert rec["status"] == "built" and asked == [], (rec, asked)
    monkeypatch.setattr(probe, "_answers", {})
    os.utime(seed, ns=(1, 1))  # (changed since the planning: its answer is not this file's)
    rec = worker._process_asset(task)
    assert rec["status"] == "built" and asked == [str(seed)], (rec, asked)


def _text_root(path: Path, arc: str, target: Path) -> Path:
    """A .usda at ``path`` whose stage opens ``target`` by ``arc``: a sublayer, a reference or a payload
    (of /m, the seed's mesh, as the default prim ``/a``)."""
    rel = os.path.relpath(target, path.parent)
    if arc == "sublayer":
        path.write_text(f"#usda 1.0\n(\n    subLayers = [@./{rel}@]\n)\n")
    else:
        arcs = {"reference": "references", "payload": "payload"}
        path.write_text(
            f'#usda 1.0\n(\n    defaultPrim = "a"\n)\ndef "a" ({arcs[arc]} = @./{rel}@</m>) {{}}\n'
        )
    return path


def _giant(path: Path) -> Path:
    """:func:`_seed` (written beside ``path`` as ``seed-<name>``) with the fourth byte of its STRINGS section
    flipped, at ``path`` (found by a sweep over the sections' first bytes, the file referenced from a .usda):
    usd-core asks for a giant allocation reading it; a read in a child without a memory limit ran past 20 s
    (not repeated here: it may take the machine's memory), under the probe's limit it is std::bad_alloc."""
    data = bytearray(_seed(path.with_name("seed-" + path.name)).read_bytes())
    (toc,) = struct.unpack_from("<q", data, 16)
    (count,) = struct.unpack_from("<Q", data, toc)
    for i in range(count):
        name, start, _ = struct.unpack_from("<16sqq", data, toc + 8 + 32 * i)
        if name.rstrip(b"\0") == b"STRINGS":
            data[start + 3] ^= 0xFF
    path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize("arc", ["sublayer", "reference", "payload"])
def test_a_usda_that_opens_a_corrupt_usdc_is_probed(tmp_path, arc):
    # the probe was keyed on the root's suffix: a .usda naming a corrupt .usdc was opened in the process,
    # which died by SIGSEGV (a sublayer of the crashing file: validate, the loader, build), or, a reference
    # or payload of the other (a giant count), read in the process with no limit (SWPM_USD_READ there, after
    # the allocation; in the probe, a composition error usd-core reports as it skips the layer). Its
    # composed stage is probed, and a crate layer that exists but does not open there is an error
    (tmp_path / "assets").mkdir()
    if arc == "sublayer":
        bad = _crashing(tmp_path / "assets" / "bad.usdc")
        code, start = "SWPM_USD_CRASH", "usd-core crashed opening or reading it"
    else:
        bad = _giant(tmp_path / "assets" / "bad.usdc")
        code, start = "SWPM_USD_OPEN", f"usd-core cannot open a crate layer its stage uses, {bad}: "
    root = _text_root(tmp_path / "root.usda", arc, bad)
    if arc == "sublayer":
        raw = subprocess.run([sys.executable, "-c", _RAW_READ, str(root)], capture_output=True, timeout=120)
        assert raw.returncode < 0, raw.returncode  # (usd-core alone dies on the .usda)
    done = _cli("validate", str(root), "--json")
    assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
    (finding,) = json.loads(done.stdout)["findings"]
    assert finding["code"] == code and finding["message"].startswith(f"{root}: {start}"), finding
    assert "bad_alloc" in finding["message"] or arc == "sublayer"
    done = _cli("build", str(root), "--json")
    assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
    assert json.loads(done.stdout)["error"] == finding["message"]
    # the good seed through the same arc builds (the probe reads the composed stage clean)
    good = _text_root(tmp_path / "good.usda", arc, tmp_path / "assets" / "seed-bad.usdc")
    assert probe.needs_probe(good) and probe.check(good) is None
    assert load_mesh(good).triangle_count == 200


def test_write_overrides_write_usdlod_and_a_pipeline_refuse_a_usda_over_a_corrupt_usdc(tmp_path):
    bad = _crashing(tmp_path / "bad.usdc")
    root = _text_root(tmp_path / "root.usda", "sublayer", bad)
    lines = _write_overrides_and_usdlod(root, tmp_path)
    assert len(lines) == 2 and all("usd-core crashed opening or reading it" in line for line in lines), lines
    assert lines[0].startswith(f"UsdOverrideError {root}: ") and lines[1].startswith(
        f"UsdWriteError {root}: "
    )
    assert not (tmp_path / "over.usda").exists() and not (tmp_path / "lod.usda").exists()
    # a pipeline: a glob's .usda asset over a corrupt layer fails alone; a stage: source is a config error
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    _text_root(tmp_path / "m" / "b.usda", "payload", _giant(tmp_path / "giant.usdc"))
    _text_root(tmp_path / "m" / "c.usda", "sublayer", bad)
    (tmp_path / "c.yaml").write_text(
        "version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    done = _cli("run", str(tmp_path / "c.yaml"), "--json")
    assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
    summary = json.loads(done.stdout)
    assert summary["built_assets"] == ["m/a.obj"] and summary["failed"] == 2, summary
    failures = {f["id"]: f["error"] for f in summary["failures"]}
    assert "usd-core cannot open a crate layer its stage uses" in failures["m/b.usda"], failures
    assert "usd-core crashed opening or reading it" in failures["m/c.usda"], failures
    (tmp_path / "s.yaml").write_text("version: 1\nassets: [{stage: root.usda}]\noutput: {dir: out2}\n")
    done = _cli("run", str(tmp_path / "s.yaml"))
    assert done.returncode == 2 and "cannot open stage root.usda: usd-core crashed" in done.stderr, (
        done.stderr
    )


def test_a_text_root_naming_no_crate_file_is_not_probed(tmp_path, monkeypatch):
    seed = _seed(tmp_path / "seed.usdc")
    text = tmp_path / "seed.usda"
    Usd.Stage.Open(str(seed)).Export(str(text))
    root = _text_root(tmp_path / "root.usda", "reference", text)
    (tmp_path / "tex.usda").write_text('#usda 1.0\ndef "t" {\n    asset file = @./seed.png@\n}\n')
    asked = _files_probed(monkeypatch)
    for path in (root, text, tmp_path / "tex.usda"):
        assert not probe.needs_probe(path) and probe.check(path) is None
    assert load_mesh(root).triangle_count == 200 and asked == []
    # a layer it names becomes a crate file: probed (the answer depended on that layer)
    text.unlink()
    _text_root(text, "sublayer", seed)
    assert probe.check(root) is None and asked == [str(root)]


def test_a_cached_answer_holds_only_while_the_layers_the_probe_opened_are_unchanged(tmp_path, monkeypatch):
    # the answer was kept by the root file's key alone: a sublayer replaced by a corrupt one since was
    # taken as probed clean, and opened in this process (which died)
    seed = _seed(tmp_path / "sub.usdc")
    stage = Usd.Stage.CreateNew(str(tmp_path / "root.usdc"))
    stage.GetRootLayer().subLayerPaths.append("./sub.usdc")
    stage.GetRootLayer().Save()
    del stage
    root = tmp_path / "root.usdc"
    asked = _files_probed(monkeypatch)
    assert probe.check(root) is None and probe.check(root) is None and asked == [str(root)]
    (key,) = probe.cleared(root)
    assert [d[0] for d in key[4]] == [str(seed.resolve())]  # (the layer the probe opened, with its stamp)
    crashing = _crashing(tmp_path / "c.usdc").read_bytes()
    seed.write_bytes(crashing)
    os.utime(seed, ns=(2, 2))  # (a stamp of its own: rewrites within one clock tick keep the mtime)
    found = probe.check(root)
    assert found is not None and found.kind == "crash" and asked == [str(root)] * 2, found
    assert probe.cleared(root) == []
    # a worker trusts the planning's key only while the sublayer is as the planning probed it
    seed.write_bytes((tmp_path / "seed-c.usdc").read_bytes())
    os.utime(seed, ns=(3, 3))
    assert probe.check(root) is None and len(asked) == 3
    handed = probe.cleared(root)
    monkeypatch.setattr(probe, "_answers", {})
    probe.trust(json.loads(json.dumps(handed)))  # (as a task carries it: plain data)
    assert probe.check(root) is None and len(asked) == 3
    monkeypatch.setattr(probe, "_answers", {})
    probe.trust(handed)
    os.utime(seed, ns=(1, 1))
    assert probe.check(root) is None and len(asked) == 4


@pytest.mark.parametrize("root_kind", ["usdc", "usda"])
def test_a_cached_answer_is_probed_again_when_a_layer_missing_at_its_probe_appears(
    tmp_path, monkeypatch, root_kind
):
    # the answer was keyed on the layers the probe opened: a crate layer's sublayer that was missing then
    # (skipped by usd-core) and written since as a corrupt file kept the clean answer, and the stage was
    # opened in this process (which died). A .usdc root, or a .usda over a .usdc (whose sublayers the text
    # walk does not read): the missing file the stage's composition errors name is a file it depends on
    asked = _files_probed(monkeypatch)
    stage = Usd.Stage.CreateNew(str(tmp_path / "mid.usdc"))
    stage.GetRootLayer().subLayerPaths.append("./later.usdc")
    stage.GetRootLayer().Save()
    del stage
    root = (
        tmp_path / "mid.usdc"
        if root_kind == "usdc"
        else _text_root(tmp_path / "root.usda", "sublayer", tmp_path / "mid.usdc")
    )
    assert probe.check(root) is None and probe.check(root) is None and asked == [str(root)]
    _crashing(tmp_path / "later.usdc")
    found = probe.check(root)
    assert found is not None and found.kind == "crash" and asked == [str(root)] * 2, found


def test_a_stage_reached_through_a_linked_folder_is_not_failed_for_a_crate_layer_it_opened(
    tmp_path, monkeypatch
):
    # a composition error naming a crate layer that opened (a reference to a prim it does not have) was taken
    # for "a crate layer that did not open" when the folder was reached through a link (the layer's path as
    # usd-core gives it against the error's path resolved): SWPM_USD_OPEN, a crate layer "that does not open"
    from swpm_usd.usd.validate import validate_stage

    (tmp_path / "real").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "real")
    _seed(tmp_path / "real" / "good.usdc")
    (tmp_path / "real" / "root.usda").write_text(
        '#usda 1.0\n(\n    defaultPrim = "a"\n)\n'
        'def "a" (references = @./good.usdc@</m>) {}\ndef "b" (references = @./good.usdc@</nope>) {}\n'
    )
    for folder in ("real", "link"):
        root = tmp_path / folder / "root.usda"
        monkeypatch.setattr(probe, "_answers", {})  # (one file: the real folder's answer is the link's)
        stage = Usd.Stage.Open(str(root))  # (the error the probe sees: the layer opened)
        assert any("Unresolved reference prim path" in str(e) for e in stage.GetCompositionErrors())
        del stage
        assert probe.check(root) is None, folder
        codes = {f.code for f in validate_stage(root)}
        assert codes and not codes & {"SWPM_USD_OPEN", "SWPM_USD_CRASH"}, (folder, codes)
        # (the loader's own refusal of an incomplete stage, as for the real folder: not the probe's)
        with pytest.raises(MeshLoadError, match="1 composition error, the stage is incomplete"):
            load_mesh(root)


def test_the_text_walk_counts_the_layers_it_reads_not_the_files_they_name(tmp_path, monkeypatch):
    # its bound on the text layers read below a root counted every file named (textures too): a .usda with
    # a material library's textures and one text sublayer was probed (its whole stage read in a probe) as
    # a layer stack too large to walk
    monkeypatch.setattr(probe, "_TEXT_LAYERS_READ", 3)
    textures = "".join(f"    asset t{i} = @./tex/t{i}.png@\n" for i in range(10))
    (tmp_path / "sub.usda").write_text("#usda 1.0\n")
    (tmp_path / "root.usda").write_text(
        f'#usda 1.0\n(\n    subLayers = [@./sub.usda@]\n)\ndef "a" {{\n{textures}}}\n'
    )
    crate, named = probe._named_files(str(tmp_path / "root.usda"))
    assert not crate and len(named) == 12 and not probe.needs_probe(tmp_path / "root.usda"), named
    # a stack of more text layers than the bound is probed, not walked to its end
    for i in range(4):
        _text_root(tmp_path / f"chain{i}.usda", "sublayer", tmp_path / f"chain{i + 1}.usda")
    (tmp_path / "chain4.usda").write_text("#usda 1.0\n")
    assert probe.needs_probe(tmp_path / "chain0.usda")
    assert not probe.needs_probe(tmp_path / "chain2.usda")  # (three layers: within it)


def test_a_probe_ended_by_usd_cores_fatal_error_says_what_usd_core_said_and_leaves_no_crash_report(
    tmp_path, monkeypatch
):
    # usd-core's fatal error handler (SIGABRT: how the corrupt test file ends a probe since the probe opens
    # its layers one by one) wrote a crash report, st_python3.11.<pid>, to /var/tmp for each file probed,
    # never removed (249 of them after a day of tests), and what it said was lost. The server's TMPDIR is a
    # folder of its own: the report's first line is read into the answer and the file removed
    _patched_program(
        monkeypatch,
        "def probe(path):\n",
        "def probe(path):\n"
        "    if path.endswith('bad.usdc'):\n"
        "        Tf.Fatal('swpm test: a corrupt section')\n",
    )
    try:
        bad = _seed(tmp_path / "bad.usdc")
        found = probe.check(bad)
        assert found is not None and found.kind == "crash" and "died by SIGABRT" in found.message, found
        assert "usd-core said: FATAL ERROR: Python Fatal Error: swpm test: a corrupt section" in found.message
        server = probe._server
        assert server is not None and server.poll() is None
        folder = probe._crash_dir()
        assert folder != "/var/tmp" and os.listdir(folder) == []  # (read, then removed)
        assert probe.check(_seed(tmp_path / "good.usdc")) is None
    finally:
        probe._stop(probe._server)


def _patched_program(monkeypatch, old: str, new: str) -> None:
    """The probe server's program with ``old`` replaced by ``new``, in a fresh server."""
    assert old in probe._PROBE
    monkeypatch.setattr(probe, "_PROBE", probe._PROBE.replace(old, new))
    probe._stop(probe._server)


def _crash_of_the_open_is_keyed_on(
    monkeypatch, root: Path, crashing: str, keyed: list[Path], touched: Path
) -> None:
    """The probe server's open of ``root`` crashes where the path opened ends with ``crashing`` (as usd-core
    would on a file it cannot read: after the layers named); the crash is keyed on each of ``keyed``, kept
    while they are unchanged, and probed again once ``touched`` changes."""
    asked = _files_probed(monkeypatch)
    _patched_program(
        monkeypatch,
        "        stage = Usd.Stage.Open(path)\n",
        f"        if path.endswith({crashing!r}):\n"
        "            os.kill(os.getpid(), signal.SIGSEGV)\n"
        "        stage = Usd.Stage.Open(path)\n",
    )
    try:
        found = probe.check(root)
        assert found is not None and found.kind == "crash", found
        names = [n for n, _ in probe._answers[probe._key(str(root))][1]]
        for path in keyed:
            assert str(path.resolve()) in names, names
        assert probe.check(root) == found and len(asked) == 1  # (kept while its layers are unchanged)
        os.utime(touched, ns=(5, 5))
        assert probe.check(root) == found and len(asked) == 2  # (probed again)
    finally:
        probe._stop(probe._server)  # (the next test's server runs the real program)


def test_a_probe_that_fails_itself_is_probed_again_then_a_located_error(tmp_path, monkeypatch):
    # an exception in the probe outside its guarded reads was "no answer", and the file was then opened in
    # this process, unprobed: it is tried once more in a fresh server, then an error naming the file
    from swpm_usd.usd.validate import CODES, validate_stage

    good = _seed(tmp_path / "good.usdc")
    marker = tmp_path / "fail-once"
    _patched_program(
        monkeypatch,
        "    used = attempt(stage.GetUsedLayers) or []\n",
        "    used = attempt(stage.GetUsedLayers) or []\n"
        f"    if os.path.exists({str(marker)!r}):\n"
        f"        os.remove({str(marker)!r})\n"
        "        raise RuntimeError('a bug of the probe')\n",
    )
    try:
        marker.touch()
        assert probe.check(good) is None and not marker.exists()  # (failed once: probed again, clean)
        _patched_program(
            monkeypatch,
            "    used = attempt(stage.GetUsedLayers) or []\n",
            "    raise RuntimeError('a bug of the probe')\n",
        )
        other = _seed(tmp_path / "other.usdc")
        found = probe.check(other)
        assert found is not None and found.kind == "probe", found
        assert found.message.startswith(f"{other}: the process probing it failed (RuntimeError: a bug")
        assert found.message.endswith("it was not opened in this process")
        monkeypatch.setattr(probe, "_answers", {})
        (finding,) = validate_stage(other)
        assert finding.code == "SWPM_USD_PROBE" and finding.code in CODES and finding.message == found.message
        with pytest.raises(MeshLoadError, match="the process probing it failed"):
            load_mesh(other)
    finally:
        probe._stop(probe._server)  # (the next test's server runs the real program)


def _children(pid: int) -> list[int]:
    out = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(entry))
    return out


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_probe_server_ends_with_the_process_that_asks(tmp_path):
    # a worker killed while a probe ran left its probe server (and the probe) alive until the probe's alarm,
    # up to 300 s. The worker's probes hang (a sleep where usd-core would work: as on a slow file; a FIFO,
    # which hung usd-core's open, is now answered without a probe)
    import time

    seed = _seed(tmp_path / "slow.usdc")
    code = (
        "import sys\nfrom swpm_usd.usd import probe\n"
        "probe._PROBE = probe._PROBE.replace('def probe(path):\\n', "
        "'def probe(path):\\n    import time\\n    time.sleep(600)\\n')\n"
        "probe.check(sys.argv[1])\n"
    )
    env = {**os.environ, "SWPM_USD_PROBE_SECONDS": "300"}
    worker = subprocess.Popen([sys.executable, "-c", code, str(seed)], env=env)
    try:
        deadline = time.monotonic() + 120
        servers: list[int] = []
        probes: list[int] = []
        while time.monotonic() < deadline and not probes:
            servers = _children(worker.pid)
            probes = [p for s in servers for p in _children(s)]
            time.sleep(0.1)
        assert servers and probes, "no probe started"
        time.sleep(0.5)
        assert worker.poll() is None and all(map(_alive, servers + probes))
    finally:
        worker.kill()
        worker.wait()
    # (they end within a second, polled every 0.25 s; the bound only tells that from the probe's 300 s alarm,
    # with room for a loaded machine)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and any(map(_alive, servers + probes)):
        time.sleep(0.1)
    assert not any(map(_alive, servers + probes)), [p for p in servers + probes if _alive(p)]


def test_check_many_probes_several_at_once_with_the_answers_of_one_at_a_time(tmp_path, monkeypatch):
    good = [_seed(tmp_path / f"g{i}.usdc") for i in range(4)]
    bad = _crashing(tmp_path / "bad.usdc")
    (tmp_path / "empty.usdc").write_bytes(b"")
    text = _text_root(tmp_path / "t.usda", "sublayer", bad)
    paths = [good[0], bad, good[1], tmp_path / "empty.usdc", good[2], text, good[3], good[0], tmp_path / "nx"]
    one_by_one = []
    for p in paths:
        one_by_one.append(probe.check(p))
    monkeypatch.setattr(probe, "_answers", {})
    in_flight: list[int] = []
    real_serve = probe._serve
    monkeypatch.setattr(
        probe, "_serve", lambda queue, *a: in_flight.append(len(queue)) or real_serve(queue, *a)
    )
    # several at once: each probe marks its start, then waits (up to 60 s, in vain when one runs alone) for
    # another probe's mark and logs the marks it saw. The first probe sees a second one started as it runs
    marks = tmp_path / "marks"
    marks.mkdir()
    _patched_program(
        monkeypatch,
        "def probe(path):\n",
        "def probe(path):\n"
        "    import time\n"
        f"    open(os.path.join({str(marks)!r}, str(os.getpid())), 'w').close()\n"
        "    for _ in range(1200):\n"
        f"        if len(os.listdir({str(marks)!r})) >= 2:\n"
        "            break\n"
        "        time.sleep(0.05)\n"
        f"    seen = len(os.listdir({str(marks)!r}))\n"
        f"    open({str(tmp_path / 'seen')!r}, 'a').write(str(seen) + '\\n')\n",
    )
    try:
        assert probe.check_many(paths, jobs=3) == one_by_one
    finally:
        probe._stop(probe._server)  # (the next test's server runs the real program)
    assert in_flight == [7]  # (the distinct files probed, in one pass of up to 3 at once)
    seen = [int(n) for n in (tmp_path / "seen").read_text().split()]
    assert len(seen) == 7 and seen[0] >= 2, seen
    assert [f.kind if f else None for f in one_by_one] == [
        None,
        "crash",
        None,
        "open",
        None,
        "crash",
        None,
        None,
        None,
    ]


def test_a_probe_server_that_ends_before_its_queue_does_is_no_traceback(tmp_path, monkeypatch):
    # the server gone with files not yet asked of it (more files than probes at once): those were in no
    # answer, and check_many raised KeyError (validate's and the planning's traceback). They are asked of
    # the fresh server, their own try unspent; a server that ends at every request fails each file alone
    files = [_seed(tmp_path / f"g{i}.usdc") for i in range(3)]
    _patched_program(monkeypatch, "def start(line):\n", "def start(line):\n    os._exit(3)\n")
    try:
        found = probe.check_many(files, jobs=1)
    finally:
        probe._stop(probe._server)  # (the next test's server runs the real program)
    assert [f.kind if f else None for f in found] == ["probe"] * 3, found
    for path, problem in zip(files, found, strict=True):
        assert problem.message.startswith(
            f"{path}: the process probing it failed (it ended without an answer)"
        )


def test_a_dask_run_fails_a_corrupt_usdc_and_a_usda_over_it_alone(tmp_path):
    # --executor dask had never met a crashing input: its workers (a local cluster's processes) probe as the
    # local pool's do. The one skip allowed: dask is an optional extra
    pytest.importorskip("dask.distributed")
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    bad = _crashing(tmp_path / "bad.usdc")  # (its seed beside it, not an asset)
    (tmp_path / "m" / "bad.usdc").write_bytes(bad.read_bytes())
    _text_root(tmp_path / "m" / "c.usda", "sublayer", bad)
    (tmp_path / "c.yaml").write_text(
        "version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    done = _cli("run", str(tmp_path / "c.yaml"), "--executor", "dask", "--jobs", "2", "--json")
    assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
    summary = json.loads(done.stdout)
    assert summary["built_assets"] == ["m/a.obj"] and summary["failed"] == 2, summary
    failures = {f["id"]: f["error"] for f in summary["failures"]}
    assert set(failures) == {"m/bad.usdc", "m/c.usda"}
    assert all("usd-core crashed opening or reading it" in e for e in failures.values()), failures
    assert (tmp_path / "out" / "a.swpm").is_file()


def test_the_planner_probes_its_new_usd_assets_in_one_batch(tmp_path, monkeypatch):
    # the planning probed each new .usdc asset as it came to it, one after another (2,000 assets: 20 s); it
    # now hands them to check_many together (several at once), and the inputs it finds are as before
    from swpm_usd.pipeline.assets import discover
    from swpm_usd.pipeline.config import load_config

    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    seeds = [_seed(tmp_path / "m" / f"s{i}.usdc") for i in range(3)]
    root = _text_root(tmp_path / "m" / "t.usda", "sublayer", seeds[0])
    _crashing(tmp_path / "bad.usdc").rename(tmp_path / "m" / "bad.usdc")
    (tmp_path / "c.yaml").write_text("version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\n")
    batches: list[list[str]] = []
    real = probe.check_many
    monkeypatch.setattr(
        probe,
        "check_many",
        lambda paths, jobs=None, **kw: batches.append([str(p) for p in paths]) or real(paths, jobs, **kw),
    )
    assets, inputs, problems = discover(load_config(tmp_path / "c.yaml"))
    assert problems == [] and [a.id for a in assets] == [
        "m/a.obj",
        "m/bad.usdc",
        *[f"m/s{i}.usdc" for i in range(3)],
        "m/t.usda",
    ]
    assert batches[0] == [
        str(tmp_path / "m" / n) for n in ("bad.usdc", "s0.usdc", "s1.usdc", "s2.usdc", "t.usda")
    ]
    assert inputs["m/t.usda"] == [root, seeds[0]] and inputs["m/s1.usdc"] == [seeds[1]]
    assert inputs["m/bad.usdc"] == [tmp_path / "m" / "bad.usdc"] and list(inputs) == [a.id for a in assets]


def test_the_planner_parses_a_new_text_root_once_and_holds_one_at_a_time(tmp_path, monkeypatch):
    # the planner's batch check parsed each new .usda asset (does it name a crate file?) and let it go; its
    # open a moment later parsed it again (discover of one 3.8 MB .usda: 3.28 s, now 1.76 s, medians). A
    # text root naming no crate file is now opened while the check holds it: found parsed, and only its own
    from swpm_usd.pipeline.assets import discover
    from swpm_usd.pipeline.config import load_config

    (tmp_path / "m").mkdir()
    seed = _seed(tmp_path / "seed.usdc")
    plain = []
    for name in ("p.usda", "q.usda"):
        Usd.Stage.Open(str(seed)).Export(str(tmp_path / "m" / name))
        plain.append(tmp_path / "m" / name)
    over = _text_root(tmp_path / "m" / "t.usda", "sublayer", seed)
    (tmp_path / "c.yaml").write_text("version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\n")
    seen: dict[str, list[bool]] = {}
    real = Usd.Stage.Open

    def open_(path, *args, **kwargs):
        if Path(str(path)).suffix == ".usda":
            seen[Path(str(path)).name] = [Sdf.Layer.Find(str(p)) is not None for p in (*plain, over)]
        return real(path, *args, **kwargs)

    monkeypatch.setattr(Usd.Stage, "Open", open_)
    assets, inputs, problems = discover(load_config(tmp_path / "c.yaml"))
    assert problems == [] and [a.id for a in assets] == ["m/p.usda", "m/q.usda", "m/t.usda"]
    # (each plain root parsed by the check when it is opened, and no other; the root over a crate file,
    # probed in the batch, is not opened here: the probe listed its layers)
    assert seen == {"p.usda": [True, False, False], "q.usda": [False, True, False]}
    assert inputs["m/p.usda"] == [plain[0]] and inputs["m/t.usda"] == [over, seed]


def test_the_planner_opens_no_stage_a_probe_opened(tmp_path, monkeypatch):
    # a crate asset, or a text root over a crate layer, was parsed by the probe, then opened again by the
    # planner for the files of its layers (and a third time by the worker's build): the probe lists them now
    from swpm_usd.pipeline.assets import discover
    from swpm_usd.pipeline.config import load_config

    (tmp_path / "m").mkdir()
    seed = _seed(tmp_path / "seed.usdc")
    crate = _seed(tmp_path / "m" / "c.usdc")
    over = _text_root(tmp_path / "m" / "t.usda", "reference", seed)
    (tmp_path / "c.yaml").write_text("version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\n")
    opened: list[str] = []
    real = Usd.Stage.Open
    monkeypatch.setattr(
        Usd.Stage, "Open", lambda path, *a, **k: opened.append(str(path)) or real(path, *a, **k)
    )
    assets, inputs, problems = discover(load_config(tmp_path / "c.yaml"))
    assert problems == [] and [a.id for a in assets] == ["m/c.usdc", "m/t.usda"]
    assert opened == [] and inputs == {"m/c.usdc": [crate], "m/t.usda": [over, seed]}, (opened, inputs)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
@pytest.mark.parametrize(
    "case", ["fifo.usd", "fifo.usda", "fifo.usdc", "sublayer-fifo.usda", "sublayer-fifo.usdc", "folder.usda"]
)
def test_a_layer_that_is_not_a_regular_file_is_an_open_error_at_once(tmp_path, case):
    # a FIFO given as a layer (the root, a layer a text root names, or one a crate root names, which only the
    # probe reads) was probed, and its open waited for a writer until the probe's alarm: 300 s before a
    # timeout. It is reported at once, by os.stat, as the open error it is, naming the file; never opened
    import time

    odd = tmp_path / (
        "slow.usd" if case == "fifo.usd" else "slow.usdc" if case == "fifo.usdc" else "slow.usda"
    )
    if case == "folder.usda":
        odd.mkdir()
    else:
        os.mkfifo(odd)
    target = odd
    if case == "sublayer-fifo.usda":
        target = tmp_path / "root.usda"
        target.write_text(f"#usda 1.0\n(\n    subLayers = [@./{odd.name}@]\n)\n")
    elif case == "sublayer-fifo.usdc":
        target = _seed(tmp_path / "root.usdc")
        layer = Sdf.Layer.FindOrOpen(str(target))  # (a layer, not a stage: which would open the sublayer)
        layer.subLayerPaths.append(f"./{odd.name}")
        layer.Save()
        del layer
    what = "a folder" if case == "folder.usda" else "a FIFO"
    if target == odd:
        message = f"{target}: it is not a regular file ({what}); it was not opened"
    else:
        message = (
            f"{target}: a layer its stage opens, {odd}, is not a regular file ({what}); it was not opened"
        )
    code = (
        "import sys\nfrom swpm_usd.usd import probe\nfrom swpm_usd.usd.validate import validate_stage\n"
        "print(repr(probe.check(sys.argv[1])))\n"
        "print(repr([(f.code, f.message) for f in validate_stage(sys.argv[1])]))\n"
    )
    env = {**os.environ, "SWPM_USD_PROBE_SECONDS": "300"}
    start = time.monotonic()
    done = subprocess.run(
        [sys.executable, "-c", code, str(target)], env=env, capture_output=True, text=True, timeout=240
    )
    took = time.monotonic() - start
    assert done.returncode == 0, done.stderr
    found, findings = done.stdout.splitlines()
    assert found == repr(probe.Problem("open", message)), found
    assert eval(findings) == [("SWPM_USD_OPEN", message)], findings  # noqa: S307 - our own repr
    assert took < 120, took  # (not the alarm's 300 s: on a loaded machine, two starts of Python and usd-core)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_a_fifo_an_attribute_names_is_no_layer_and_one_a_reference_names_is(tmp_path):
    # a FIFO (or a folder) a texture's asset path names is resolved, never opened: no open error, no wait. (A
    # texture path with a layer's suffix, @./pipe.usd@, stays an open error: usd-core's own validators open
    # it as a layer, UsdUtils.ComputeAllDependencies, and wait on a FIFO for ever.) A FIFO a reference names
    # is an open error at once
    os.mkfifo(tmp_path / "pipe.png")
    os.mkfifo(tmp_path / "pipe.usd")
    (tmp_path / "dir.png").mkdir()
    seed = _seed(tmp_path / "seed.usdc")
    textured = tmp_path / "textured.usda"
    textured.write_text(
        f'#usda 1.0\ndef "a" (\n    references = @./{seed.name}@</m>\n)\n{{\n'
        "    asset inputs:file = @./pipe.png@\n    asset[] inputs:files = [@./dir.png@]\n}\n"
    )
    referencing = tmp_path / "referencing.usda"
    referencing.write_text('#usda 1.0\ndef "a" (\n    references = @./pipe.usd@\n)\n{\n}\n')
    code = (
        "import sys\nfrom swpm_usd.usd import probe\nfrom swpm_usd.usd.validate import validate_stage\n"
        "for path in sys.argv[1:]:\n"
        "    print(repr((probe.check(path), [(f.code, f.message) for f in validate_stage(path)])))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(textured), str(referencing)],
        env={**os.environ, "SWPM_USD_PROBE_SECONDS": "300"},
        capture_output=True,
        text=True,
        timeout=240,  # (a FIFO opened waits for a writer: the probe's alarm is 300 s)
    )
    assert done.returncode == 0, done.stderr
    (found, findings), (odd, odd_findings) = (
        eval(line, {"Problem": probe.Problem}) for line in done.stdout.splitlines()
    )  # noqa: S307
    assert found is None and not [f for f in findings if f[0] == "SWPM_USD_OPEN"], (found, findings)
    message = (
        f"{referencing}: a layer its stage opens, {tmp_path / 'pipe.usd'}, is not a regular file (a FIFO); "
        "it was not opened"
    )
    assert odd == ("open", message) and odd_findings == [("SWPM_USD_OPEN", message)], (odd, odd_findings)


def test_a_probe_that_hangs_is_a_timeout_at_its_alarm(tmp_path, monkeypatch):
    # the alarm stays the backstop for what os.stat cannot tell before the open (a layer usd-core hangs on)
    monkeypatch.setenv("SWPM_USD_PROBE_SECONDS", "1")
    _patched_program(
        monkeypatch, "def probe(path):\n", "def probe(path):\n    import time\n    time.sleep(60)\n"
    )
    try:
        seed = _seed(tmp_path / "slow.usdc")
        found = probe.check(seed)
    finally:
        probe._stop(probe._server)  # (the next test's server runs the real program)
    assert found is not None and found.kind == "timeout" and found.message.startswith(f"{seed}: "), found


def test_check_many_probes_one_file_given_in_two_spellings_once_and_stats_each_file_once(
    tmp_path, monkeypatch
):
    # check_many deduplicated by the path string: a file and a link to it (or `d/../file`) were two probes of
    # one file; and it stat'ed each file twice (its key, then whether it is a regular file)
    asked = _files_probed(monkeypatch)
    bad = _crashing(tmp_path / "bad.usdc")
    (tmp_path / "link.usdc").symlink_to(bad)
    (tmp_path / "d").mkdir()
    spellings = [bad, tmp_path / "link.usdc", tmp_path / "d" / ".." / "bad.usdc"]
    found = probe.check_many(spellings)
    assert asked == [str(bad)], asked
    for path, problem in zip(spellings, found, strict=True):  # (each message names the file as asked)
        assert problem is not None and problem.kind == "crash", problem
        assert problem.message.startswith(f"{path}: usd-core crashed"), (path, problem.message)
    # (and later, one at a time: the kept answer, named as asked)
    assert probe.check(spellings[1]).message.startswith(f"{spellings[1]}: usd-core crashed")
    assert asked == [str(bad)]
    text = tmp_path / "t.usd"  # (a text .usd: the spelling that was stat'ed three times)
    text.write_text('#usda 1.0\ndef "a" {}\n')
    stats: list[str] = []
    real_stat = os.stat
    monkeypatch.setattr(os, "stat", lambda p, *a, **k: stats.append(os.fspath(p)) or real_stat(p, *a, **k))
    assert probe.check_many([text, tmp_path / "t.usda"]) == [None, None]
    assert stats.count(str(text)) == 1, stats


def test_a_crashed_probes_answer_is_keyed_on_the_layers_it_reached(tmp_path, monkeypatch):
    # a crash names no layers: its answer was keyed on the layers of an earlier answer for the file, or on
    # none. A crate root over a crashing sublayer kept its crash after the sublayer was mended (never probed
    # again). Each probe names each layer before it opens it: a crash is keyed on those
    asked = _files_probed(monkeypatch)
    sub = _crashing(tmp_path / "sub.usdc")
    layer = Sdf.Layer.CreateNew(str(tmp_path / "root.usdc"))
    layer.subLayerPaths.append("./sub.usdc")
    layer.Save()
    del layer
    root = tmp_path / "root.usdc"
    found = probe.check(root)
    assert found is not None and found.kind == "crash" and asked == [str(root)], found
    key = probe._key(str(root))
    assert [n for n, _ in probe._answers[key][1]] == [str(sub.resolve())]  # (the layer it was opening)
    assert probe.check(root) == found and len(asked) == 1  # (kept while the layers are as they were)
    sub.write_bytes((tmp_path / "seed-sub.usdc").read_bytes())  # (mended)
    os.utime(sub, ns=(5, 5))
    assert probe.check(root) is None and len(asked) == 2


def test_checked_holds_the_text_layers_it_parsed_for_the_callers_open(tmp_path):
    # a .usda root was parsed twice: here, to know whether it names a crate file, then by the caller's open
    # (+26 % on a 3.8 MB .usda). In a `checked` block, the layers the check parsed stay in usd-core's layer
    # registry, where the block's open finds them; they are let go as it ends
    seed = _seed(tmp_path / "seed.usdc")
    text = tmp_path / "sub.usda"
    Usd.Stage.Open(str(seed)).Export(str(text))
    root = _text_root(tmp_path / "root.usda", "sublayer", text)
    for path in (root, text):
        assert Sdf.Layer.Find(str(path)) is None
    with probe.checked(root) as problem:
        assert problem is None
        held = [Sdf.Layer.Find(str(path)) for path in (root, text)]
        assert all(held), held  # (parsed by the check, not yet opened by us)
        stage = Usd.Stage.Open(str(root))
        assert stage.GetRootLayer() == held[0] and held[1] in stage.GetLayerStack()
    del stage, held
    assert Sdf.Layer.Find(str(root)) is None and Sdf.Layer.Find(str(text)) is None
    # (answered from the kept answer: nothing parsed, nothing held; a plain check holds nothing)
    with probe.checked(root) as problem:
        assert problem is None and Sdf.Layer.Find(str(root)) is None
    os.utime(root, ns=(7, 7))
    assert probe.check(root) is None and Sdf.Layer.Find(str(root)) is None


def _variant_root(path: Path, selected: str) -> Path:
    """A crate root (``path``) whose default prim ``/a`` has variant set ``lod``: "hi" references the seed's
    mesh in ``good.usdc``, "broken" that of ``bad.usdc`` (both beside it), ``selected`` selected."""
    text = path.with_suffix(".usda")
    text.write_text(
        '#usda 1.0\n(\n    defaultPrim = "a"\n)\n'
        f'def "a" (\n    variants = {{ string lod = "{selected}" }}\n    prepend variantSets = "lod"\n)\n{{\n'
        '    variantSet "lod" = {\n'
        '        "hi" ( references = @./good.usdc@</m> ) { }\n'
        '        "broken" ( references = @./bad.usdc@</m> ) { }\n'
        "    }\n}\n"
    )
    layer = Sdf.Layer.FindOrOpen(str(text))  # (a layer, not a stage: which would open bad.usdc)
    assert layer.Export(str(path))
    del layer
    text.unlink()
    return path


def test_a_layer_only_a_variant_not_selected_names_is_not_opened_by_the_probe(tmp_path, monkeypatch):
    # the probe opened every layer its layers name before the stage (GetCompositionAssetDependencies: the
    # references of every variant): a corrupt file in a variant not selected, which the stage never opens
    # (nor the caller's open, nor the loader), made the stage a crash. Such a layer is named to the server
    # (a crash of the stage's open in it, when its variant is selected, is keyed on it), not opened
    bad = _crashing(tmp_path / "bad.usdc")
    _seed(tmp_path / "good.usdc")
    root = _variant_root(tmp_path / "root.usdc", "hi")
    assert probe.check(root) is None
    stage = Usd.Stage.Open(str(root))  # (what the caller then does: the stage never opens bad.usdc)
    assert str(bad) not in [layer.realPath for layer in stage.GetUsedLayers()]
    del stage
    # (the variant selected: a probe that crashes in the stage's open, as usd-core would on a file it
    # cannot read, is keyed on the variant's layer, named before the open)
    selected = _variant_root(tmp_path / "selected.usdc", "broken")
    _crash_of_the_open_is_keyed_on(monkeypatch, selected, "selected.usdc", [bad], bad)


def _broken_variant_root(mid: str) -> str:
    """A root layer whose selected variant, "broken", references ``mid`` (the other, "hi", good.usdc)."""
    return (
        '#usda 1.0\n(\n    defaultPrim = "a"\n)\n'
        'def "a" (\n    variants = { string lod = "broken" }\n    prepend variantSets = "lod"\n)\n{\n'
        '    variantSet "lod" = {\n'
        '        "hi" ( references = @./good.usdc@</m> ) { }\n'
        f'        "broken" ( references = @./{mid}@</m> ) {{ }}\n'
        "    }\n}\n"
    )


def test_a_crash_in_a_layer_a_selected_variants_layer_names_is_keyed_on_that_layer(tmp_path, monkeypatch):
    # the probe named a variant's own layer (mid.usda) before the stage's open, not the layers it names in
    # turn: a crash of the open in bad.usdc, which only mid.usda names, was keyed on mid.usda alone, and
    # kept after bad.usdc changed (mended: never probed again). A text layer only a variant names is read
    # (the text parser fails cleanly) and the layers it names are named too; a crate one is named, not opened
    bad = _seed(tmp_path / "bad.usdc")
    (tmp_path / "mid.usda").write_text('#usda 1.0\ndef "m" (\n    references = @./bad.usdc@</m>\n)\n{\n}\n')
    _seed(tmp_path / "good.usdc")
    text = tmp_path / "root.usda"
    text.write_text(_broken_variant_root("mid.usda"))
    root = tmp_path / "root.usdc"
    layer = Sdf.Layer.FindOrOpen(str(text))  # (a layer, not a stage)
    assert layer.Export(str(root))
    del layer
    text.unlink()
    # (the stage's open crashes, as usd-core would on bad.usdc were it corrupt: after the layers named)
    _crash_of_the_open_is_keyed_on(monkeypatch, root, "root.usdc", [bad, tmp_path / "mid.usda"], bad)


def test_a_crash_in_a_layer_a_selected_variants_crate_layer_names_is_keyed_on_that_layer(
    tmp_path, monkeypatch
):
    # as for a text layer only a variant names (the test above), but the variant's layer a crate file: it was
    # named, not opened, so the layers it names were not known before the stage's open; a crash of the open
    # in bad.usdc, which only mid.usdc names, was keyed on mid.usdc alone and kept after bad.usdc changed.
    # mid.usdc is read in a process of its own (a crash there is not the stage's) and what it names named
    bad = _seed(tmp_path / "bad.usdc")
    mid_text = tmp_path / "mid.usda"
    mid_text.write_text('#usda 1.0\ndef "m" (\n    references = @./bad.usdc@</m>\n)\n{\n}\n')
    mid = tmp_path / "mid.usdc"
    layer = Sdf.Layer.FindOrOpen(str(mid_text))
    assert layer.Export(str(mid))
    del layer
    mid_text.unlink()
    _seed(tmp_path / "good.usdc")
    text = tmp_path / "root.usda"
    text.write_text(_broken_variant_root("mid.usdc"))
    _crash_of_the_open_is_keyed_on(monkeypatch, text, "root.usda", [bad, mid], bad)


def test_the_planner_uses_no_stale_layer_list_once_a_sublayer_names_no_crate(tmp_path):
    # a probe's list of the layers a stage uses was kept for the root's key alone: once a sublayer changed to
    # name no crate file (no probe: the root checked here, in text), the old list was still taken, so the
    # asset's inputs named the crate it no longer uses and not the layer it does (a change there went unseen)
    from swpm_usd.pipeline.assets import _usd_layer_files

    seed = _seed(tmp_path / "seed.usdc")
    other = tmp_path / "other.usda"
    other.write_text('#usda 1.0\ndef "m" {\n}\n')
    sub = tmp_path / "sub.usda"
    sub.write_text(f'#usda 1.0\ndef "m" (\n    references = @{seed}@</m>\n)\n{{\n}}\n')
    root = tmp_path / "root.usda"
    root.write_text("#usda 1.0\n(\n    subLayers = [@./sub.usda@]\n)\n")
    files, ok = _usd_layer_files(root)
    assert ok and sorted(files) == sorted([sub, seed]), files
    sub.write_text(f'#usda 1.0\ndef "m" (\n    references = @{other}@</m>\n)\n{{\n}}\n')
    os.utime(sub, ns=(7, 7))
    assert probe.used_layers(root) is None  # (its answer's layers changed: no list)
    files, ok = _usd_layer_files(root)
    assert ok and sorted(files) == sorted([sub, other]), files


def test_a_crate_layer_only_an_unselected_variant_names_that_hangs_is_no_timeout_of_the_stage(
    tmp_path, monkeypatch
):
    # the process the probe forks to read a crate layer only a variant names (crate_names) had no time limit
    # of its own: the probe waited for it, and one that hung (usd-core on a corrupt file, in a variant not
    # selected) took the probe's whole time, a timeout of a stage that opens cleanly. It has half the probe's
    # time left, then is killed; the stage's open has the rest
    monkeypatch.setenv("SWPM_USD_PROBE_SECONDS", "6")
    _seed(tmp_path / "good.usdc")
    _seed(tmp_path / "mid.usdc")
    root = tmp_path / "root.usda"
    root.write_text(
        '#usda 1.0\n(\n    defaultPrim = "a"\n)\n'
        'def "a" (\n    variants = { string lod = "hi" }\n    prepend variantSets = "lod"\n)\n{\n'
        '    variantSet "lod" = {\n'
        '        "hi" ( references = @./good.usdc@</m> ) { }\n'
        '        "broken" ( references = @./mid.usdc@</m> ) { }\n'
        "    }\n}\n"
    )
    _patched_program(  # (the forked reader hangs, as usd-core might on a corrupt crate file)
        monkeypatch,
        "        found = []\n        try:\n",
        "        found = []\n        import time\n        time.sleep(600)\n        try:\n",
    )
    try:
        found = probe.check(root)
    finally:
        probe._stop(probe._server)  # (the next test's server runs the real program)
    assert found is None, found  # (not a timeout: the stage opens good.usdc alone)
