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
import signal
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from pxr import Usd, UsdGeom, Vt

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
        assert finding["message"].startswith(f"{path}: usd-core crashed") and "SIGSEGV" in finding["message"]
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


def test_write_overrides_and_write_usdlod_refuse_a_usdc_that_crashes_usd_core(tmp_path):
    # each opens a stage it is given (the source of the overrides, the asset the LOD layer references)
    bad = _crashing(tmp_path / "bad.usdc")
    code = (
        "import sys\nfrom swpm_usd import usd\nfrom swpm_usd.errors import SwpmError\n"
        "for write in (lambda: usd.write_overrides(sys.argv[1], sys.argv[2]),\n"
        "              lambda: usd.write_usdlod(sys.argv[1], sys.argv[3])):\n"
        "    try:\n        write()\n    except SwpmError as e:\n        print(type(e).__name__, e)\n"
    )
    args = [str(bad), str(tmp_path / "over.usda"), str(tmp_path / "lod.usda")]
    done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, (done.returncode, done.stderr)
    lines = done.stdout.splitlines()
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
    asked: list[str] = []
    real = probe._probe_all
    monkeypatch.setattr(
        probe, "_probe_all", lambda files, jobs: asked.extend(p for p, _ in files) or real(files, jobs)
    )
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


def test_each_file_is_probed_in_a_fresh_process_and_a_crash_leaves_the_server(tmp_path):
    # whether usd-core's read past the corrupt data crashes depends on the process's memory: a probe server
    # that opened files itself, having served many, got an error instead of the crash. Each probe is a fresh
    # fork of a server that opens none
    for i in range(3):
        assert probe.check(_seed(tmp_path / f"good{i}.usdc")) is None
    server = probe._server
    bad = _crashing(tmp_path / "bad.usdc")
    found = probe.check(bad)
    assert found is not None and found.kind == "crash" and f"died by {signal.SIGSEGV.name}" in found.message
    assert probe._server is server and server.poll() is None
    assert probe.check(_seed(tmp_path / "good.usdc")) is None


def test_a_token_that_is_not_utf8_is_a_value_usd_core_cannot_read(tmp_path):
    # found by the sweep over byte flips of a vanilla asset layer: a flip in its compressed tokens gives
    # swpm:bufferNames a token that is not UTF-8, and `validate` printed a traceback (UnicodeDecodeError, as
    # Python reads the token) where the loader had not read that value. The probe reads every value: it is
    # SWPM_USD_READ, and the loader's MeshLoadError
    import swpm_usd
    from swpm_usd import usd

    obj = tmp_path / "seed.obj"
    spot = load_mesh(SAMPLES / "spot.obj")
    trimesh.Trimesh(spot.points, spot.triangles, process=False).submesh([np.arange(200)], append=True).export(
        obj
    )
    layer = usd.write(swpm_usd.build(obj, encoding="vanilla"), tmp_path / "seed_vanilla.usdc")
    data = bytearray(layer.read_bytes())
    data[6990] ^= 0xFF
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


def test_a_small_files_probe_does_not_pay_usd_cores_start_each_time(tmp_path):
    # each probe is a fresh fork of the server: one that had not built usd-core's schema registry (its first
    # stage does, ~25 ms) paid it in every fork, ~35-40 ms a small file, a pipeline's planning of thousands of
    # .usdc assets that much each, serially (a build of 60 small .usdc assets, --jobs 1, took twice main's
    # time). The fastest of a few probes (the least disturbed by other processes) is well below that
    import time

    seed = _seed(tmp_path / "seed.usdc")
    assert probe.check(seed) is None  # (the server started)
    times: list[float] = []
    for i in range(20):  # (until one is fast: on a machine busy with other processes, the most are slower)
        copy = tmp_path / f"c{i}.usdc"
        copy.write_bytes(seed.read_bytes())
        start = time.perf_counter()
        assert probe.check(copy) is None
        times.append(time.perf_counter() - start)
        if times[-1] < 0.02:
            break
    assert min(times) < 0.02, times


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
    asked: list[str] = []
    real = probe._probe_all
    monkeypatch.setattr(
        probe, "_probe_all", lambda files, jobs: asked.extend(p for p, _ in files) or real(files, jobs)
    )
    monkeypatch.setattr(probe, "_answers", {})  # (a worker: another process, nothing probed)
    rec = worker._process_asset(task)
    assert rec["status"] == "built" and asked == [], (rec, asked)
    monkeypatch.setattr(probe, "_answers", {})
    os.utime(seed, ns=(1, 1))  # (changed since the planning: its answer is not this file's)
    rec = worker._process_asset(task)
    assert rec["status"] == "built" and asked == [str(seed)], (rec, asked)
