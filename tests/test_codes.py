"""Stable problem codes (swpm_usd/codes.py): every error the CLI and the pipeline report carries one.

A studio running thousands of assets groups its failures by ``code``: the JSON errors of ``build``,
``encode`` and ``run``, and a run's failure records, held their English message alone. The catalogue is
pinned (a rename fails here), documented in spec/errors.md (generated from it), and every code is produced
by a real input below.
"""

from __future__ import annotations

import fcntl
import json
import os
import re
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import ROOT

import swpm_usd
from swpm_usd.cli import main
from swpm_usd.codes import CODES, located
from swpm_usd.errors import BuildError, MeshLoadError, SwpmError
from swpm_usd.mesh import Mesh
from swpm_usd.pipeline import run

TWO_TRIANGLES = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"
#: the catalogue as released: a code is never renamed nor removed (new ones are added at the end)
PINNED = [
    "INPUT_NOT_FOUND",
    "INPUT_UNREADABLE",
    "INPUT_UNSUPPORTED",
    "INPUT_MALFORMED",
    "INPUT_INCOMPLETE",
    "INPUT_EMPTY",
    "INPUT_TOO_LARGE",
    "MESH_INVALID",
    "PARAMETER_INVALID",
    "BUILD_FAILED",
    "BUDGET_EXCEEDED",
    "TIME_LIMIT_EXCEEDED",
    "WORKER_LOST",
    "OUTPUT_UNWRITABLE",
    "OUTPUT_UNSUPPORTED",
    "OUTPUT_LOCKED",
    "CONFIG_INVALID",
    "USAGE_ERROR",
    "INTERRUPTED",
    "INTERNAL_ERROR",
    "INPUT_CHANGED",
    "EXTRA_MISSING",
]


def test_the_catalogue_is_pinned():
    assert list(CODES) == PINNED
    assert all(c.severity in ("error", "warning", "info") and c.meaning.endswith(".") for c in CODES.values())


def test_spec_errors_md_lists_the_catalogue():
    """The second table of spec/errors.md is the catalogue, code by code, with its severity."""
    text = (ROOT / "spec" / "errors.md").read_text()
    section = text[text.index("## Input, build, output and run problems") :]
    rows = re.findall(r"^\| `([A-Z_]+)` \| (\w+) \| (.+?) \|", section, re.M)
    assert [(code, severity) for code, severity, _ in rows] == [(c, CODES[c].severity) for c in PINNED]
    assert [meaning for _, _, meaning in rows] == [CODES[c].meaning for c in PINNED]


def _cli(args: list[str], exit_code: int = 1) -> dict:
    result = CliRunner().invoke(main, args)
    assert result.exit_code == exit_code, result.output
    return json.loads(result.stdout)


def _raised(fn: Callable[[], object], kind: type[BaseException] = SwpmError) -> BaseException:
    with pytest.raises(kind) as err:
        fn()
    return err.value


def _project(tmp: Path, config: str, files: dict[str, str]) -> Path:
    (tmp / "m").mkdir(exist_ok=True)
    for name, text in files.items():
        (tmp / "m" / name).write_text(text)
    cfg = tmp / "c.yaml"
    cfg.write_text("version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\n" + config)
    return cfg


def _fake_asset(task: dict) -> dict:
    """A worker's process_asset that dies or hangs as the task's id says (the pool's test double)."""
    if task["id"] == "killed":
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(120)
    return {}


def _pool_failures(monkeypatch) -> dict[str, dict]:
    import multiprocessing as mp

    from swpm_usd.pipeline import runner, worker

    monkeypatch.setattr(worker, "process_asset", _fake_asset)  # (inherited: fork)
    tasks = [{"id": i, "digest": i} for i in ("killed", "hangs")]
    return {r["id"]: r for r in runner._local_pool(tasks, 2, mp.get_context("fork"), 3.0)}


def produce(code: str, tmp: Path, monkeypatch) -> dict:
    """Make ``code`` happen from a real input; return what reports it (a JSON error, a record, or the
    exception's fields)."""
    from swpm_usd.codes import problem_fields

    if code == "INPUT_NOT_FOUND":  # a mesh, and a pipeline config (item 4: "file not found", our words)
        out = _cli(["run", str(tmp / "missing.yaml"), "--json"], exit_code=2)
        assert out["problems"] == [f"{tmp / 'missing.yaml'}:1:1: $: file not found"]
        assert out["file"] == str(tmp / "missing.yaml")
        return _cli(["build", str(tmp / "missing.obj"), "--json"])
    if code == "INPUT_UNREADABLE":
        (tmp / "folder.obj").mkdir()
        from swpm_usd.io import load_mesh

        return problem_fields(_raised(lambda: load_mesh(tmp / "folder.obj")))
    if code == "INPUT_UNSUPPORTED":
        gltf = tmp / "a.gltf"
        gltf.write_text(json.dumps({"asset": {"version": "2.0"}, "extensionsRequired": ["EXT_unknown"]}))
        assert _cli(["build", str(gltf), "--json"])["code"] == code
        (tmp / "a.xyz").write_text("x")
        return _cli(["build", str(tmp / "a.xyz"), "--json"])
    if code == "INPUT_MALFORMED":
        (tmp / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 x 0\nf 1 2 3\n")
        out = _cli(["encode", str(tmp / "a.obj"), "-o", str(tmp / "a.swpm"), "--json"])
        assert (out["format"], out["line"], out["file"]) == ("obj", 4, str(tmp / "a.obj")), out
        assert out["error"].endswith("not a valid OBJ file: line 4: a 'v' row holds 'x', not a number")
        return out
    if code == "INPUT_INCOMPLETE":
        doc = {
            "asset": {"version": "2.0"},
            "buffers": [{"uri": "gone.bin", "byteLength": 36}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "nodes": [{"mesh": 0}],
            "scenes": [{"nodes": [0]}],
        }
        (tmp / "a.gltf").write_text(json.dumps(doc))
        out = _cli(["build", str(tmp / "a.gltf"), "--json"])
        assert "'gone.bin' is not found" in out["error"], out
        usda = tmp / "a.usda"
        usda.write_text('#usda 1.0\n(\n    subLayers = [@gone.usda@]\n)\ndef Mesh "m" {}\n')
        assert _cli(["build", str(usda), "--json"])["code"] == code
        return out
    if code == "INPUT_EMPTY":
        (tmp / "a.obj").write_text("")
        return _cli(["build", str(tmp / "a.obj"), "--json"])
    if code == "INPUT_TOO_LARGE":
        (tmp / "a.obj").write_text(TWO_TRIANGLES)
        return _cli(["build", str(tmp / "a.obj"), "--max-triangles", "1", "--json"])
    if code == "MESH_INVALID":  # a Mesh made directly, not through from_arrays or a loader
        points = np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], np.float32)
        err = _raised(lambda: swpm_usd.build(Mesh(points, np.array([[0, 1, 2]]), source="made"), "vanilla"))
        assert isinstance(err, BuildError)
        return problem_fields(err)
    if code == "PARAMETER_INVALID":  # a combination the encoder refuses, given to the API (the command line
        # and a config refuse it as a usage error before the build: tests/test_acceptance_audit.py)
        mesh = Mesh.from_arrays(*_two_triangles())
        err = _raised(lambda: swpm_usd.build(mesh, "sliding-window", builder="forsyth", order_passes=2))
        assert isinstance(err, BuildError)
        return problem_fields(err)
    if code == "BUILD_FAILED":  # buffers that do not agree with their LOD table
        from swpm_usd.encode.base import from_buffers

        pm = swpm_usd.build(Mesh.from_arrays(*_two_triangles()), "vanilla")
        counts = pm.vertex_counts[::-1].copy()  # (growing: LOD k draws a prefix that LOD 0 does not hold)
        args = (pm.points, pm.attributes, counts, pm.triangle_counts, pm.lod_errors, pm.buffers(), pm.params)
        return problem_fields(_raised(lambda: from_buffers(pm.encoding, *args)))
    if code == "BUDGET_EXCEEDED":
        cfg = _project(tmp, "budgets: {global_bytes: 1}\n", {"a.obj": TWO_TRIANGLES})
        return _cli(["run", str(cfg), "--json"])["failures"][0]
    if code in ("TIME_LIMIT_EXCEEDED", "WORKER_LOST"):
        return _pool_failures(monkeypatch)["hangs" if code == "TIME_LIMIT_EXCEEDED" else "killed"]
    if code == "OUTPUT_UNWRITABLE":
        if Path("/proc/self").is_dir():  # a run's output.dir whose parent cannot be made, even by root
            cfg = _project(tmp, "", {"a.obj": TWO_TRIANGLES})
            cfg.write_text(cfg.read_text().replace("{dir: out}", "{dir: /proc/nope/out}"))
            out = _cli(["run", str(cfg), "--json"], exit_code=2)
            assert out["code"] == code and "cannot create /proc/nope/out" in out["problems"][0], out
        # a run's asset whose output cannot be renamed into place (a folder holds its name)
        cfg = _project(tmp, "", {"b.obj": TWO_TRIANGLES})
        (tmp / "out" / "b.swpm").mkdir(parents=True)
        (tmp / "out" / "b.swpm" / "x").write_text("")
        failure = _cli(["run", str(cfg), "--json"])["failures"][0]
        assert failure["code"] == code and "Is a directory" in failure["error"], failure
        (tmp / "a.obj").write_text(TWO_TRIANGLES)
        out = _cli(["encode", str(tmp / "a.obj"), "-o", str(tmp / "a.obj" / "x.swpm"), "--json"])
        assert out["file"] == str(tmp / "a.obj" / "x.swpm")
        return out
    if code == "OUTPUT_UNSUPPORTED":  # an attribute the format has no element type for
        points, triangles = _two_triangles()
        mesh = Mesh.from_arrays(points, triangles, {"a": np.arange(4, dtype=np.int64)})
        pm = swpm_usd.build(mesh, "vanilla")
        return problem_fields(_raised(lambda: swpm_usd.save(pm, tmp / "a.swpm")))
    if code == "OUTPUT_LOCKED":
        cfg = _project(tmp, "", {"a.obj": TWO_TRIANGLES})
        (tmp / "out").mkdir()
        fd = os.open(tmp / "out" / ".swpm-pipeline.lock", os.O_RDWR | os.O_CREAT)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return _cli(["run", str(cfg), "--json"])
        finally:
            os.close(fd)
    if code == "CONFIG_INVALID":
        cfg = _project(tmp, "rules: 5\n", {})
        out = _cli(["run", str(cfg), "--json"], exit_code=2)
        assert out["error"] == "invalid configuration" and out["problems"]
        return out
    if code == "USAGE_ERROR":
        out = _cli(["build", "x.obj", "--rows", "0", "--json"], exit_code=2)
        assert out["usage_error"] is True
        return out
    if code == "INTERRUPTED":

        def interrupted(*args, **kwargs):
            raise KeyboardInterrupt

        monkeypatch.setattr(sys.modules["swpm_usd.build"], "build", interrupted)
        (tmp / "a.obj").write_text(TWO_TRIANGLES)
        out = _cli(["build", str(tmp / "a.obj"), "--json"], exit_code=130)
        assert out["error"] == "interrupted"
        return out
    if code == "INTERNAL_ERROR":  # a bug: an exception of no type of the package's, in a run's asset

        def broken(*args, **kwargs):
            raise RuntimeError("a bug")

        from swpm_usd.pipeline import worker

        monkeypatch.setattr(worker, "check_streaming", broken)  # (--jobs 1 builds in this process)
        cfg = _project(tmp, "", {"a.obj": TWO_TRIANGLES})
        failure = _cli(["run", str(cfg), "--json"])["failures"][0]
        record = json.loads((tmp / "out" / "manifest.json").read_text())["assets"]["m/a.obj"]
        assert record["code"] == code and "RuntimeError: a bug" in record["traceback"]
        return failure
    if code == "INPUT_CHANGED":  # its exporter still writing it while the worker reads it
        from swpm_usd import io

        cfg = _project(tmp, "", {"a.obj": TWO_TRIANGLES})
        real = io.load_mesh

        def written_as_read(path, **kw):
            mesh = real(path, **kw)
            with open(path, "a") as f:
                f.write("# more\n")
            return mesh

        monkeypatch.setattr(io, "load_mesh", written_as_read)
        return _cli(["run", str(cfg), "--json"])["failures"][0]
    if code == "EXTRA_MISSING":  # --executor dask without the dask extra (None in sys.modules: no import)
        cfg = _project(tmp, "", {"a.obj": TWO_TRIANGLES})
        monkeypatch.setitem(sys.modules, "dask.distributed", None)
        result = CliRunner().invoke(main, ["run", str(cfg), "--executor", "dask", "--json"])
        # a valid config: not CONFIG_INVALID (exit 2, "invalid configuration"), and said before the plan
        assert result.exit_code == 1 and not (tmp / "out").exists(), result.output
        assert "pip install 'swpm-usd[dask]'" in result.stderr, result.stderr
        out = json.loads(result.stdout)
        assert out["error"].startswith("--executor dask needs the dask extra, not installed ("), out
        return out
    raise AssertionError(f"no input produces {code}")


def _two_triangles() -> tuple[np.ndarray, np.ndarray]:
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], np.float32)
    return points, np.array([[0, 1, 2], [1, 3, 2]])


@pytest.mark.parametrize("code", PINNED)
def test_every_code_is_produced_by_an_input(code, tmp_path, monkeypatch):
    reported = produce(code, tmp_path, monkeypatch)
    assert reported["code"] == code, reported
    assert reported["severity"] == CODES[code].severity


def test_a_run_records_the_code_of_each_failure_in_its_manifest_and_report(tmp_path):
    cfg = _project(
        tmp_path,
        "",
        {"a.obj": TWO_TRIANGLES, "empty.obj": "", "bad.obj": "v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n"},
    )
    out = _cli(["run", str(cfg), "--json"])
    failures = {f["id"]: f for f in out["failures"]}
    assert failures["m/empty.obj"]["code"] == "INPUT_EMPTY"
    assert failures["m/bad.obj"] == {
        "id": "m/bad.obj",
        "error": failures["m/bad.obj"]["error"],  # (its text as before)
        "kept_previous": False,
        "code": "INPUT_MALFORMED",
        "severity": "error",
        "format": "obj",
        "line": 2,
    }
    assets = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]
    assert assets["m/bad.obj"]["code"] == "INPUT_MALFORMED" and assets["m/bad.obj"]["line"] == 2
    assert "code" not in assets["m/a.obj"]  # (a built asset's record is as it was)
    report = (tmp_path / "out" / "report.html").read_text()
    assert "<code>INPUT_EMPTY</code>" in report and "<code>INPUT_MALFORMED</code>" in report


def test_a_failure_recorded_without_a_code_gets_one_and_nothing_built_is_rebuilt(tmp_path):
    """A manifest of an earlier version holds failures without ``code``: the rerun retries them (as every
    rerun does) and records the code; the built assets stay up to date (their digests hold no error text),
    and the next rerun finds each failure as recorded and writes nothing."""
    cfg = _project(tmp_path, "", {"a.obj": TWO_TRIANGLES, "empty.obj": ""})
    time.sleep(2.1)  # (an input written within 2 s of its hash is hashed again next run: "racily clean")
    run(cfg, echo=lambda m: None)
    manifest = tmp_path / "out" / "manifest.json"
    data = json.loads(manifest.read_text())
    for key in ("code", "severity", "format"):
        del data["assets"]["m/empty.obj"][key]  # (as 0.7.3 wrote it)
    manifest.write_text(json.dumps(data, indent=1))
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped, res.failed) == (0, 1, 1)
    assert json.loads(manifest.read_text())["assets"]["m/empty.obj"]["code"] == "INPUT_EMPTY"
    written = manifest.stat().st_mtime_ns
    time.sleep(0.01)
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped, res.failed) == (0, 1, 1) and manifest.stat().st_mtime_ns == written


def test_a_kept_previous_build_records_the_code_of_its_last_failure(tmp_path):
    cfg = _project(tmp_path, "", {"a.obj": TWO_TRIANGLES})
    run(cfg, echo=lambda m: None)
    (tmp_path / "m" / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    out = _cli(["run", str(cfg), "--json"])
    assert out["failures"][0]["kept_previous"] is True and out["failures"][0]["code"] == "INPUT_MALFORMED"
    record = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]["m/a.obj"]
    assert record["status"] == "built" and record["last_failure"]["code"] == "INPUT_MALFORMED"
    assert record["last_failure"]["line"] == 4


@pytest.mark.parametrize(
    ("path", "problem", "where"),
    [
        ("a.obj", "not a valid OBJ file: line 12: a 'v' row holds 2 values, not 3", (12, None)),
        ("a.ply", "not a valid PLY file: line 3: 'element vertex x' is not 'element NAME COUNT'", (3, None)),
        ("a.gltf", "not a glTF file (not JSON: Expecting value: line 5 column 3 (char 40))", (5, None)),
        (
            "a.glb",
            "not a valid GLB file: its JSON chunk is not JSON: Expecting ',' at byte offset 57 (line 2 of "
            "the chunk)",
            (None, 57),
        ),
        ("a.obj", "byte 0xff at byte offset 9 (line 2) is not UTF-8 text", (2, 9)),
        ("a.glb", "its JSON chunk: byte 0xff at byte offset 29 (line 1) is not UTF-8 text", (None, 29)),
        ("a.usda", "USD could not open it: syntax error at line 3", (None, None)),
        ("a.obj", "no triangles: the file holds no triangle geometry", (None, None)),
        # what a message quotes (a name, a path, the file's content) is not where: the loader's own words are
        (
            "a.gltf",
            "not a valid glTF file: buffer 0: its file 'line 7.bin' is not found beside the .gltf",
            (None, None),
        ),
        ("a.gltf", 'buffer 0: its file "it\'s byte offset 3.bin" is not found', (None, None)),
        ("a.obj", "not a valid OBJ file: line 4: 'line 9' starts with 'f', not a face", (4, None)),
        (
            "a.usda",
            "first: Could not load sublayer @/x/byte offset 3.usda@ of layer @/x/a.usda@",
            (None, None),
        ),
        ("a.obj", "a link loop (to /tmp/line 5/a.obj): following it comes back round", (None, None)),
        # usd-core's words, which may echo a path as given: "byte offset 3.usda:4:1: parse error"
        ("byte offset 3.usda", "USD could not open it: byte offset 3.usda:4:1: parse error", (None, None)),
    ],
)
def test_where_a_loader_says_the_problem_is(path, problem, where):
    """A loader's message names a line of a text file or a byte offset; a .glb's lines are its JSON chunk's
    and a USD error's are usd-core's, not given as the file's."""
    assert located(problem, path) == where
    err = MeshLoadError(path, problem)
    assert (err.line, err.offset) == where and str(err) == f"{path}: {problem}"


def test_a_name_or_path_in_a_message_is_not_taken_for_where_the_problem_is(tmp_path):
    """A missing .gltf buffer named "line 7.bin", a USD sublayer named "byte offset 3.usda", a mesh that is a
    link in a loop through a folder named "line 5": none of these names a place in the file."""
    gltf = {
        "asset": {"version": "2.0"},
        "buffers": [{"uri": "line 7.bin", "byteLength": 36}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": 3,
                "type": "VEC3",
                "max": [1, 1, 0],
                "min": [0] * 3,
            }
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    (tmp_path / "a.gltf").write_text(json.dumps(gltf))
    (tmp_path / "b.usda").write_text(
        '#usda 1.0\n(\n    subLayers = [@./byte offset 3.usda@]\n)\ndef Mesh "m" {\n'
        "    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n    int[] faceVertexCounts = [3]\n"
        "    int[] faceVertexIndices = [0, 1, 2]\n}\n"
    )
    (tmp_path / "line 5").mkdir()
    (tmp_path / "c.obj").symlink_to(tmp_path / "line 5" / "d.obj")
    (tmp_path / "line 5" / "d.obj").symlink_to(tmp_path / "c.obj")
    for name, code in (
        ("a.gltf", "INPUT_INCOMPLETE"),
        ("b.usda", "INPUT_INCOMPLETE"),
        ("c.obj", "INPUT_NOT_FOUND"),
    ):
        out = _cli(["build", str(tmp_path / name), "--json"])
        assert out["code"] == code and "line" not in out and "offset" not in out, out


def test_a_glb_whose_json_does_not_parse_reports_its_byte_offset(tmp_path):
    chunk = b'{"asset": ]}    '
    glb = b"glTF" + (2).to_bytes(4, "little") + (20 + len(chunk)).to_bytes(4, "little")
    glb += len(chunk).to_bytes(4, "little") + b"JSON" + chunk
    (tmp_path / "a.glb").write_bytes(glb)
    out = _cli(["build", str(tmp_path / "a.glb"), "--json"])
    assert (out["code"], out["format"], out["offset"]) == ("INPUT_MALFORMED", "glb", 30), out
    assert "line" not in out


def test_the_exceptions_keep_their_classes_and_messages():
    err = MeshLoadError("a.obj", "file not found", code="INPUT_NOT_FOUND")
    assert str(err) == "a.obj: file not found" and err.problem == "file not found" and err.path == "a.obj"
    assert err.code == "INPUT_NOT_FOUND" and err.severity == "error"
    assert MeshLoadError("a.obj", "x").code == "INPUT_MALFORMED"
    assert BuildError("mu must be in [0, 1), got 2").code == "PARAMETER_INVALID"
    assert str(BuildError("m", code="BUILD_FAILED")) == "m" and BuildError("m").args == ("m",)


def test_run_of_a_missing_config_says_file_not_found(tmp_path):
    result = CliRunner().invoke(main, ["run", str(tmp_path / "missing.yaml")])
    assert result.exit_code == 2
    assert result.stderr == f"{tmp_path / 'missing.yaml'}:1:1: $: file not found\n"  # (not "[Errno 2] ...")
    # a link in a loop is named so, as a mesh's is ("[Errno 40] Too many levels of symbolic links")
    (tmp_path / "a.yaml").symlink_to(tmp_path / "b.yaml")
    (tmp_path / "b.yaml").symlink_to(tmp_path / "a.yaml")
    out = _cli(["run", str(tmp_path / "a.yaml"), "--json"], exit_code=2)
    assert out["code"] == "INPUT_NOT_FOUND", out
    assert out["problems"] == [
        f"{tmp_path / 'a.yaml'}:1:1: $: a link loop (to {tmp_path / 'b.yaml'}): following it comes back "
        "round, to no file"
    ]


def test_a_config_that_is_not_utf8_is_invalid_not_unreadable(tmp_path):
    """Its bytes were read: a config whose text is not UTF-8 is invalid (exit 2, as before), as a mesh's
    would be malformed; INPUT_UNREADABLE is a file that cannot be read (a folder, no permission)."""
    (tmp_path / "c.yaml").write_bytes(b"version: 1\nassets: [{glob: '\xff.obj'}]\n")
    out = _cli(["run", str(tmp_path / "c.yaml"), "--json"], exit_code=2)
    assert out["code"] == "CONFIG_INVALID" and "cannot read the file" in out["problems"][0], out


def test_a_dry_run_with_prune_lists_what_it_would_delete_not_as_pruned(tmp_path):
    cfg = _project(tmp_path, "", {"a.obj": TWO_TRIANGLES, "b.obj": TWO_TRIANGLES})
    run(cfg, echo=lambda m: None)
    (tmp_path / "m" / "b.obj").unlink()
    out = _cli(["run", str(cfg), "--dry-run", "--prune", "--json"], exit_code=0)
    assert out["pruned"] == [] and out["would_prune"] == ["b.swpm"] and out["unlisted"] == ["b.swpm"]
    assert (tmp_path / "out" / "b.swpm").is_file()  # (a dry run deletes nothing)
    out = _cli(["run", str(cfg), "--dry-run", "--json"], exit_code=0)
    assert out["pruned"] == [] and out["would_prune"] == [] and out["unlisted"] == ["b.swpm"]
    out = _cli(["run", str(cfg), "--prune", "--json"], exit_code=0)
    assert out["pruned"] == ["b.swpm"] and "would_prune" not in out
    assert not (tmp_path / "out" / "b.swpm").exists()


def test_another_librarys_exception_is_an_internal_error_without_its_attributes():
    from swpm_usd.codes import problem_fields

    err = SyntaxError("x", ("f.py", 3, 7, "text"))  # (its offset and line are a Python file's)
    assert problem_fields(err) == {"code": "INTERNAL_ERROR", "severity": "error"}
    assert problem_fields(KeyboardInterrupt()) == {"code": "INTERRUPTED", "severity": "error"}


@pytest.mark.parametrize(
    ("raised", "code"), [(PermissionError, "INPUT_UNREADABLE"), (FileNotFoundError, "INPUT_NOT_FOUND")]
)
def test_encode_labels_an_oserror_reading_its_input_as_the_inputs(raised, code, tmp_path, monkeypatch):
    """encode labelled any OSError OUTPUT_UNWRITABLE: one reading the input (its digest read after the build,
    the file gone or unreadable since) named the output, which was never the problem, and wrote nothing. The
    digest's read is now the load's (an OBJ read once): refused or gone as it is read, it is the input's."""
    import builtins

    src, out = tmp_path / "a.obj", tmp_path / "out" / "a.swpm"
    src.write_text(TWO_TRIANGLES)
    real = builtins.open

    def refusing_open(file, *args, **kwargs):  # (the file there as the command starts, not as it is read)
        if isinstance(file, (str, os.PathLike)) and Path(file) == src:
            raise raised(13 if raised is PermissionError else 2, "refused", str(file))
        return real(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", refusing_open)
    err = _cli(["encode", str(src), "-o", str(out), "--json"])
    monkeypatch.setattr(builtins, "open", real)
    assert (err["code"], err["file"], err["output"]) == (code, str(src), str(out)), err
    assert str(src) in err["error"] and not out.exists()
    # in the loader's words for its code: a file gone is "file not found" (it said "cannot read the file (No
    # such file or directory)" here, "file not found" from the loader)
    assert ("file not found" in err["error"]) == (code == "INPUT_NOT_FOUND"), err
    # the output's own OSError is still the output's
    (tmp_path / "file").write_text("")
    err = _cli(["encode", str(src), "-o", str(tmp_path / "file" / "a.swpm"), "--json"])
    assert (err["code"], err["file"]) == ("OUTPUT_UNWRITABLE", str(tmp_path / "file" / "a.swpm")), err
