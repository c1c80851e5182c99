"""What a new user gets wrong on the command line: each is a clear error naming what is wrong, with the
documented exit code (1 invalid input, 2 usage), no traceback and no wait."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import pytest
from click.testing import CliRunner

from swpm_usd.cli import main

TWO_TRIANGLES = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"

#: (encoding, parameter, what the error says): values out of the bounds the pipeline config's schema gives
#: them. Each was taken by the command line, the mesh read and (but for the sliding window) its collapse
#: sequence built before the encoder refused it, exit 1 as an invalid input. The words are a config's own
#: for the same value (test_a_bad_parameter_is_worded_alike_on_the_command_line_and_in_a_config)
OUT_OF_BOUNDS = [
    ("sliding-window", "mu=2", "mu: must be in [0, 1), got 2"),
    ("sliding-window", "mu=-0.1", "mu: must be in [0, 1), got -0.1"),
    ("sliding-window", "cache_size=2", "cache_size: must be in [3, 1024], got 2"),
    ("sliding-window", "inner_vertices=0", "inner_vertices: must be at least 1, got 0"),
    ("sliding-window", "order_passes=-3", "order_passes: must be in [0, 8], got -3"),
    ("sliding-window", "order_passes=x", "order_passes: 'x' is not of type 'integer', 'null'"),
    ("sliding-window", "target_slack=-1", "target_slack: must be at least 0, got -1"),
    # (json reads these; check_params does not check a None default's number finite: the encoder did)
    ("sliding-window", "target_slack=Infinity", "target_slack: inf is not a finite number"),
    ("sliding-window", "target_slack=NaN", "target_slack: nan is not a finite number"),
    ("sliding-window", "order_reach=99", "order_reach: must be in [1, 8], got 99"),
    ("sliding-window", "error_bound=0", "error_bound: must be greater than 0, got 0"),
    ("sliding-window", "builder=foo", "builder: 'foo' is not one of ['topology', 'forsyth']"),
    ("sliding-window", "cache_size=16.0", "cache_size: must be an integer, got 16.0"),
    # (one line in a config, as here: it was three, the type twice and the bound)
    ("sliding-window", "cache_size=2.5", "cache_size: must be an integer, got 2.5"),
    (
        "skip-strip",
        "degenerate_threshold=2",
        "degenerate_threshold: must be in [0, 1), got 2",
    ),
    ("skip-strip", "primitive=fan", "primitive: 'fan' is not one of ['strip', 'list']"),
    ("mixed", "level_threshold=-0.5", "level_threshold: must be in [0, 1), got -0.5"),
    ("mixed", "cache_size=0", "cache_size: must be in [1, 1024], got 0"),
]


@pytest.mark.parametrize("command", ["build", "encode"])
@pytest.mark.parametrize(("encoding", "param", "says"), OUT_OF_BOUNDS, ids=[c[1] for c in OUT_OF_BOUNDS])
def test_a_parameter_out_of_its_bounds_is_a_usage_error_before_the_mesh_is_read(
    tmp_path, command, encoding, param, says
):
    # the input does not exist: the parameter is refused before it is looked for (it was "file not found")
    missing = str(tmp_path / "missing.obj")
    args = [command, missing, "-e", encoding, "-p", param, "--json"]
    if command == "encode":
        args += ["-o", str(tmp_path / "out.swpm")]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2, (result.output, result.exception)
    assert f"Error: Invalid value for --param: {says}" in result.stderr
    out = json.loads(result.stdout)
    assert out["usage_error"] is True and says in out["error"] and out["input"] == missing
    assert not (tmp_path / "out.swpm").exists()


@pytest.mark.parametrize(
    ("encoding", "param"),
    [("sliding-window", "order_passes=null"), ("sliding-window", "mu=0"), ("skip-strip", "primitive=list")],
)
def test_a_parameter_within_its_bounds_is_taken(tmp_path, encoding, param):
    # (the input is missing: the command gets past its parameters to the file, exit 1)
    result = CliRunner().invoke(main, ["build", str(tmp_path / "missing.obj"), "-e", encoding, "-p", param])
    assert result.exit_code == 1 and "file not found" in result.stderr


@pytest.mark.parametrize(("encoding", "param", "says"), OUT_OF_BOUNDS, ids=[c[1] for c in OUT_OF_BOUNDS])
def test_a_bad_parameter_is_worded_alike_on_the_command_line_and_in_a_config(tmp_path, encoding, param, says):
    # `-p` was checked by a reader of the schema's bounds of its own ("mu must be in [0, 1), got 2"), a
    # config's params by JSON Schema ("2 is greater than or equal to the maximum of 1"): one value, two
    # wordings. Both are now schema.param_problem's, a bound missed in the interval's words (schema.worded)
    from swpm_usd.pipeline import ConfigError, load_config

    name, value = param.split("=", 1)
    written = {"Infinity": ".inf", "NaN": ".nan"}.get(value, value)
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: '*.obj'}]\noutput: {dir: out}\n"
        f"rules:\n  - {{name: r, encoding: {encoding}, params: {{{name}: {written}}}}}\n"
    )
    with pytest.raises(ConfigError) as err:
        load_config(cfg)
    worded = [p.split(f"$.rules[0].params.{name}: ", 1)[1] for p in err.value.problems]
    assert worded == [says.removeprefix(f"{name}: ")], err.value.problems
    result = CliRunner().invoke(main, ["build", str(tmp_path / "missing.obj"), "-e", encoding, "-p", param])
    assert result.exit_code == 2 and f"Invalid value for --param: {name}: {worded[0]}" in result.output


def _cli(*args: str, cwd) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.run(
        [sys.executable, "-m", "swpm_usd.cli", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,  # (each waited for ever, for a writer that never came)
    )


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="a FIFO needs a POSIX system")
@pytest.mark.parametrize(
    "command", [["validate"], ["inspect"], ["inspect", "--json"], ["validate", "--json"]]
)
def test_a_fifo_given_as_a_swpm_file_is_refused_at_once(tmp_path, command):
    os.mkfifo(tmp_path / "pipe.swpm")
    result = _cli(*command, "pipe.swpm", cwd=tmp_path)
    assert result.returncode == 1, result.stderr
    assert "Traceback" not in result.stderr
    text = result.stdout + result.stderr
    assert "pipe.swpm" in text and "not a regular file" in text
    if "--json" in command:
        problems = json.loads(result.stdout)["problems"]
        assert [p["code"] for p in problems] == ["SWPM_IO_ERROR"]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="a FIFO needs a POSIX system")
@pytest.mark.parametrize("as_json", [False, True])
def test_a_fifo_given_as_a_usd_stage_is_refused_at_once(tmp_path, as_json):
    # (it said "file not found"; with --json the report waited for the probe's alarm, 300 s by default)
    os.mkfifo(tmp_path / "pipe.usda")
    result = _cli("validate", "pipe.usda", *(["--json"] if as_json else []), cwd=tmp_path)
    assert result.returncode == 1, result.stderr
    assert result.stderr == "error: pipe.usda: not a regular file\n"
    if as_json:
        findings = json.loads(result.stdout)["findings"]
        assert [(f["code"], f["message"]) for f in findings] == [
            ("SWPM_USD_OPEN", "pipe.usda: it is not a regular file (a FIFO); it was not opened")
        ]


@pytest.mark.skipif(not hasattr(signal, "SIGALRM"), reason="a FIFO needs a POSIX system")
def test_a_fifo_is_refused_by_load_and_validate(tmp_path):
    from swpm_usd.format.errors import SwpmFormatError
    from swpm_usd.format.reader import load, validate

    fifo = tmp_path / "pipe.swpm"
    os.mkfifo(fifo)

    def waited(*_):
        raise AssertionError("the reader waited for a writer of the FIFO")

    previous = signal.signal(signal.SIGALRM, waited)
    signal.alarm(20)  # (the code before waited in open() for ever)
    try:
        rep = validate(fifo)
        assert not rep.valid and [p.code for p in rep.problems] == ["SWPM_IO_ERROR"]
        with pytest.raises(SwpmFormatError, match="not a regular file"):
            load(fifo)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def test_inspect_of_a_missing_file_names_it_in_one_plain_line(tmp_path):
    result = CliRunner().invoke(main, ["inspect", str(tmp_path / "nope.swpm")])
    assert result.exit_code == 1
    # it was Python's "error: [Errno 2] No such file or directory: '...'"
    assert result.stderr == f"error: {tmp_path / 'nope.swpm'}: cannot read file: No such file or directory\n"


def test_validate_of_a_missing_file_names_it_once(tmp_path):
    """It printed "nope.swpm: INVALID / SWPM_IO_ERROR: cannot read file: [Errno 2] No such file or directory:
    'nope.swpm'": the file twice. Once now, with the stable code, exit 1 (JSON alike)."""
    path = str(tmp_path / "nope.swpm")
    result = CliRunner().invoke(main, ["validate", path])
    assert result.exit_code == 1
    assert result.stdout.splitlines() == [
        f"{path}: INVALID",
        "  error   SWPM_IO_ERROR: cannot read file: No such file or directory",
    ]
    assert result.stdout.count("nope.swpm") == 1
    result = CliRunner().invoke(main, ["validate", "--json", path])
    out = json.loads(result.stdout)
    assert result.exit_code == 1 and out["path"] == path
    assert [(p["code"], p["message"]) for p in out["problems"]] == [
        ("SWPM_IO_ERROR", "cannot read file: No such file or directory")
    ]


def test_python_validate_of_a_usd_stage_validates_the_stage(tmp_path):
    """``swpm_usd.validate(stage)`` read a USD stage as an SWPM file (SWPM_BAD_MAGIC); it dispatches by the
    suffix as ``swpm-pipeline validate`` does: the stage's findings, a missing stage one SWPM_USD_OPEN."""
    from pxr import Usd

    import swpm_usd
    from swpm_usd import usd
    from swpm_usd.format import Report

    mesh = tmp_path / "two.obj"
    mesh.write_text(TWO_TRIANGLES)
    path = usd.write(swpm_usd.build(str(mesh), encoding="vanilla"), tmp_path / "two.usda")
    rep = swpm_usd.validate(path)
    assert isinstance(rep, Report) and rep.valid and rep.problems == [] and rep.path == str(path)
    stage = Usd.Stage.Open(str(path))
    usd.find_encoded(stage)[0].GetAttribute("swpm:indexWidth").Set(4)  # the indices need 2
    stage.GetRootLayer().Save()
    rep = swpm_usd.validate(path)
    assert not rep.valid and rep.codes() == ["SWPM_USD_INDEX_WIDTH"]
    assert rep.problems[0].message.startswith("/Two/mesh: swpm:indexWidth is 4")
    assert "SWPM_USD_INDEX_WIDTH" in rep.format()
    missing = swpm_usd.validate(tmp_path / "nope.usdc")
    assert [(p.code, p.message) for p in missing.problems] == [("SWPM_USD_OPEN", "file not found")]


def test_inspect_shows_the_width_the_index_values_fit_beside_the_file_width():
    """An engine uploads the index lists; the file's idx may be wider (a writer before 0.9.0 widened it for
    its offsets and counts, or by choice). inspect keeps ``index_width``, adds ``index_values_width`` (a
    strips' restart index included, 0xFFFFFFFF as the u16 0xFFFF a u32 -> u16 copy makes of it while no
    vertex id is 0xFFFF: ``layout.draw_index_width``) and ``offset_width``, the tables' type (OFFSET32)."""
    from pathlib import Path

    vectors = Path(__file__).resolve().parents[1] / "spec" / "vectors" / "valid"
    cases = {
        "minimal-vanilla": (2, 2, 2),
        "vanilla-u32": (4, 2, 4),  # u32 by choice, every index fits u16
        "sliding-window-strips-u32": (4, 2, 4),  # the restart index 0xFFFFFFFF copies to u16 as 0xFFFF
        "skip-strip-strip-u32": (4, 2, 4),
        "sliding-window-strips-u32-restart-ffff": (4, 2, 4),  # an older file: uploads as u16, 0xFFFF restarts
        "skip-strip-strip": (2, 2, 2),
        "sliding-window-strips-offset32": (2, 2, 4),  # idx u16, the tables u32
        "mixed-offset32": (2, 2, 4),
    }
    for name, (file_w, values_w, off_w) in cases.items():
        path = str(vectors / f"{name}.swpm")
        r = CliRunner().invoke(main, ["inspect", "--json", path])
        out = json.loads(r.stdout)
        assert r.exit_code == 0, name
        assert (out["index_width"], out["index_values_width"], out["offset_width"]) == (
            file_w,
            values_w,
            off_w,
        )
        head = CliRunner().invoke(main, ["inspect", path]).stdout.splitlines()[0]
        fit = f" (index values fit u{8 * values_w})" if values_w != file_w else ""
        shown = f", index u{8 * file_w}{fit}, tables u{8 * off_w}"
        assert head.endswith(shown), (name, head)


def test_encode_refuses_an_output_below_a_file_before_it_builds(tmp_path):
    (tmp_path / "a.obj").write_text("not a folder")
    out = tmp_path / "a.obj" / "x.swpm"
    # the input is missing: the output is refused first (it was built, then "cannot write ...: File exists")
    result = CliRunner().invoke(main, ["encode", str(tmp_path / "missing.obj"), "-o", str(out), "--json"])
    assert result.exit_code == 1, result.output
    says = f"cannot write {out}: {tmp_path / 'a.obj'} is not a folder"
    assert result.stderr == f"error: {says}\n"
    assert json.loads(result.stdout) == {
        "input": str(tmp_path / "missing.obj"),
        "output": str(out),
        "error": says,
        "code": "OUTPUT_UNWRITABLE",
        "severity": "error",
        "file": str(out),
    }


@pytest.mark.parametrize("below", ["link", "link/deeper"])
def test_encode_refuses_an_output_under_a_dangling_link_before_it_builds(tmp_path, below):
    # a folder of the output that is a link to nothing: the build ran (minutes on a large mesh), then the
    # folder's making failed on the link, "cannot write ...: File exists"
    (tmp_path / "a.obj").write_text(TWO_TRIANGLES)
    (tmp_path / "link").symlink_to(tmp_path / "gone" / "folder")
    out = tmp_path / below / "x.swpm"
    built: list[str] = []
    module = sys.modules["swpm_usd.build"]  # (swpm_usd.build is the function the package exports)
    real = module.build
    with pytest.MonkeyPatch.context() as m:
        m.setattr(module, "build", lambda *a, **k: built.append("built") or real(*a, **k))
        result = CliRunner().invoke(main, ["encode", str(tmp_path / "a.obj"), "-o", str(out), "--json"])
    assert result.exit_code == 1, result.output
    says = f"cannot write {out}: {tmp_path / 'link'} is a dangling link (to {tmp_path / 'gone' / 'folder'})"
    assert result.stderr == f"error: {says}\n" and json.loads(result.stdout)["error"] == says
    assert built == [] and not (tmp_path / "gone").exists()


def test_encode_refuses_an_output_in_a_folder_it_cannot_write_before_it_builds(tmp_path, monkeypatch):
    # (a read-only folder: os.access as an unprivileged user finds it; the tests may run as root, where a
    # chmod does not stop a write, so the permission check is given its answer)
    real_access = os.access

    def access(path, mode):
        return False if str(path) == str(tmp_path) else real_access(path, mode)

    monkeypatch.setattr(os, "access", access)
    out = tmp_path / "new" / "x.swpm"
    result = CliRunner().invoke(main, ["encode", str(tmp_path / "missing.obj"), "-o", str(out)])
    assert result.exit_code == 1, result.output
    assert result.stderr == f"error: cannot write {out}: the folder {tmp_path} is not writable\n"
    assert not (tmp_path / "new").exists()


def test_encode_makes_a_missing_output_folder(tmp_path):
    from conftest import ROOT

    out = tmp_path / "new" / "deeper" / "spot.swpm"
    result = CliRunner().invoke(main, ["encode", str(ROOT / "samples" / "spot.obj"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    from swpm_usd.format.reader import validate

    assert validate(out).valid


def test_a_folder_given_to_the_reader_is_named_and_not_left_open(tmp_path):
    # (the FIFO check opened it as a descriptor: the error named the descriptor, "Is a directory: 3", and
    # the descriptor stayed open; as open(path) it said "[Errno 21] Is a directory: '<path>'")
    from swpm_usd.format.errors import SwpmFormatError
    from swpm_usd.format.reader import load, validate

    fds = os.listdir("/proc/self/fd") if os.path.isdir("/proc/self/fd") else None
    rep = validate(tmp_path)
    # (named once, by the report: the message repeated it, "[Errno 21] Is a directory: '<path>'")
    assert rep.path == str(tmp_path)
    assert [p.message for p in rep.problems] == ["cannot read file: Is a directory"]
    with pytest.raises(SwpmFormatError, match="Is a directory"):
        load(tmp_path)
    if fds is not None:
        assert len(os.listdir("/proc/self/fd")) == len(fds)


def test_a_bound_missed_anywhere_in_a_config_is_worded_by_its_interval(tmp_path):
    # (schema.worded: jsonschema's "-1 is less than the minimum of 0" named one end; a config's other bounds
    # are worded as its params' and -p's are)
    from swpm_usd.pipeline import ConfigError, load_config

    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: '*.obj'}]\noutput: {dir: out}\n"
        "rules:\n  - {name: r, match: {triangles: {min: -1}}, encoding: sliding-window}\n"
    )
    with pytest.raises(ConfigError) as err:
        load_config(cfg)
    assert [p.split(": ", 1)[1] for p in err.value.problems] == [
        "$.rules[0].match.triangles.min: must be at least 0, got -1"
    ], err.value.problems


@pytest.mark.parametrize("below", ["loop", "loop/deeper"])
def test_encode_calls_an_output_folder_in_a_link_loop_a_loop(tmp_path, below):
    # a folder of the output that is a link leading round in a loop was "a dangling link": a user looked for
    # a folder that was missing, when none was
    (tmp_path / "a.obj").write_text(TWO_TRIANGLES)
    (tmp_path / "loop").symlink_to(tmp_path / "round")
    (tmp_path / "round").symlink_to(tmp_path / "loop")
    out = tmp_path / below / "x.swpm"
    result = CliRunner().invoke(main, ["encode", str(tmp_path / "a.obj"), "-o", str(out), "--json"])
    assert result.exit_code == 1, result.output
    says = f"cannot write {out}: {tmp_path / 'loop'} is a link loop (to {tmp_path / 'round'})"
    assert result.stderr == f"error: {says}\n" and json.loads(result.stdout)["error"] == says


@pytest.mark.parametrize("command", ["build", "encode", "validate"])
@pytest.mark.parametrize("where", ["itself", "folder"])
def test_an_input_in_a_link_loop_is_called_a_link_loop(tmp_path, command, where):
    # was "file not found": the file was never missing, a link leads round (a.obj -> b.obj -> a.obj)
    suffix = ".usda" if command == "validate" else ".obj"
    if where == "itself":
        (tmp_path / f"a{suffix}").symlink_to(f"b{suffix}")
        (tmp_path / f"b{suffix}").symlink_to(f"a{suffix}")
        given = tmp_path / f"a{suffix}"
        says = f"{given}: a link loop (to b{suffix}): following it comes back round, to no file"
    else:
        (tmp_path / "d").symlink_to("e")
        (tmp_path / "e").symlink_to("d")
        given = tmp_path / "d" / f"a{suffix}"
        loop = f"{tmp_path / 'd'} is a link loop (to e)"
        says = f"{given}: its folder {loop}: following it comes back round, to no file"
    args = [command, str(given)] + (["-o", str(tmp_path / "x.swpm")] if command == "encode" else [])
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1 and result.stderr == f"error: {says}\n", result.output


def test_an_input_at_the_end_of_a_chain_of_too_many_links_is_no_link_loop(tmp_path):
    # ELOOP is also the system's word for a chain of more links than it follows (40 on Linux) that ends at a
    # file: it was called "a link loop ... comes back round, to no file" (the file is there); and a long
    # loop (2000 links) is still a loop, found at once
    (tmp_path / "real.obj").write_text(TWO_TRIANGLES)
    prev = "real.obj"
    for i in range(60):
        (tmp_path / f"l{i}.obj").symlink_to(prev)
        prev = f"l{i}.obj"
    result = CliRunner().invoke(main, ["build", str(tmp_path / prev)])  # (Linux follows 40)
    says = "too many links to follow on the way to it (a chain longer than the system follows)"
    assert result.exit_code == 1 and result.stderr == f"error: {tmp_path / prev}: {says}\n", result.output
    for i in range(2000):
        (tmp_path / f"r{i}.obj").symlink_to(f"r{(i + 1) % 2000}.obj")
    result = CliRunner().invoke(main, ["build", str(tmp_path / "r0.obj")])
    says = "a link loop (to r1.obj): following it comes back round, to no file"
    assert result.exit_code == 1 and result.stderr == f"error: {tmp_path / 'r0.obj'}: {says}\n", result.output


@pytest.mark.parametrize(
    "args",
    [
        ["build", ""],
        ["encode", "", "-o", "x.swpm"],
        ["encode", "a.obj", "-o", ""],
        ["inspect", ""],
        ["validate", ""],
        ["run", ""],
    ],
)
def test_an_empty_path_is_a_usage_error_said_alike(tmp_path, monkeypatch, args):
    # "" (an unset shell variable, "$MESH") was the current folder, each command saying it its own way:
    # build ".: unsupported file type", inspect ": cannot read file" (exit 1), run ".:1:1: $: cannot read the
    # file ([Errno 21] Is a directory: '.')"
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a.obj").write_text(TWO_TRIANGLES)
    result = CliRunner().invoke(main, [*args, "--json"])
    assert result.exit_code == 2, result.output
    assert "the path is empty (an unset shell variable?)" in result.stderr
    out = json.loads(result.stdout)
    assert out["usage_error"] is True and "the path is empty" in out["error"]


def test_run_refuses_a_scheduler_without_the_dask_executor(tmp_path):
    # --scheduler ADDR without --executor dask was ignored: every asset built here, none on the cluster
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    result = CliRunner().invoke(main, ["run", str(cfg), "--scheduler", "tcp://10.0.0.1:8786", "--json"])
    assert result.exit_code == 2, result.output
    assert "needs --executor dask" in result.stderr and json.loads(result.stdout)["usage_error"] is True
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", ["inspect", "validate"])
def test_a_mesh_given_as_an_swpm_file_gets_a_hint(tmp_path, command):
    # `validate spot.obj` (or inspect) said "magic is 7620302e33343837, expected ..." and no more: a user
    # who meant to check a mesh is told what to run. The report (and its JSON) are as before
    mesh = tmp_path / "a.obj"
    mesh.write_text(TWO_TRIANGLES)
    result = CliRunner().invoke(main, [command, str(mesh), "--json"])
    assert result.exit_code == 1
    assert json.loads(result.stdout)["problems"][0]["code"] == "SWPM_HEADER_BAD_MAGIC"
    assert result.stderr == (
        f"hint: {mesh} is a mesh file (.obj), not an SWPM file: swpm-pipeline encode {mesh} -o a.swpm "
        f"writes one, swpm-pipeline build {mesh} shows its LODs\n"
    )
    (tmp_path / "b.swpm").write_text(TWO_TRIANGLES)  # (an .swpm that is not one: no hint)
    result = CliRunner().invoke(main, [command, str(tmp_path / "b.swpm")])
    assert result.exit_code == 1 and "hint" not in result.stderr


@pytest.mark.parametrize("command", ["inspect", "validate"])
@pytest.mark.parametrize("kind", [".usdc", ".usda"])
def test_a_stage_under_an_swpm_name_gets_a_hint(tmp_path, command, kind):
    # a .usdc renamed .swpm got only "magic is 5058522d55534443": the user is told what it is and how to
    # check or read it
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(tmp_path / f"s{kind}"))
    UsdGeom.Mesh.Define(stage, "/M")
    stage.GetRootLayer().Save()
    fake = tmp_path / "s.swpm"
    (tmp_path / f"s{kind}").rename(fake)
    result = CliRunner().invoke(main, [command, str(fake)])
    assert result.exit_code == 1
    assert result.stderr == (
        f"hint: {fake} is a USD stage ({kind[1:]}), not an SWPM file: under a {kind} name (as s{kind}) "
        "swpm-pipeline validate checks its SwpmMeshAPI prims and swpm_usd.load reads it\n"
    )


@pytest.mark.parametrize(
    "params, says",
    [
        (["mu=0.5", "mu=0.1"], "Invalid value for --param: mu given twice ('0.5', then '0.1'); give it once"),
        (["=5"], "--param expects NAME=VALUE, got '=5'"),
    ],
)
def test_a_parameter_given_twice_or_without_a_name_is_a_usage_error(tmp_path, params, says):
    # `-p mu=0.5 -p mu=0.1` built with the last, silently; `-p =5` said " not a parameter of vanilla"
    args = ["build", str(tmp_path / "missing.obj"), "-e", "sliding-window"]
    for p in params:
        args += ["-p", p]
    result = CliRunner().invoke(main, [*args, "--json"])
    assert result.exit_code == 2 and says in result.stderr, result.output
    assert json.loads(result.stdout)["error"] == says
