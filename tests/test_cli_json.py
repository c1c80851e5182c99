"""``--json`` on the command line: a usage error (click's UsageError or BadParameter, from the parser or the
command's own checks) prints a JSON object on stdout as the command's other errors do, and still exits 2
with click's usage text on stderr (stdout was empty: a script reading it got no JSON)."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from swpm_usd.cli import main
from swpm_usd.usd.cli import validate_usd

#: (arguments, what the message says, the fields naming the input the error object carries)
CASES = [
    (
        ["build", "x.obj", "--encoding", "nope", "--json"],
        "Invalid value for --encoding: 'nope'",
        {"input": "x.obj"},
    ),
    (["build", "x.obj", "-p", "zz=1", "--json"], "zz not a parameter of vanilla", {"input": "x.obj"}),
    # the input given is named though the error is another option's (the README: "with `input`, and
    # `output` for `encode`, when given"; it was left out when click had not parsed it yet)
    (["build", "--json", "x.obj", "--rows", "0"], "Invalid value for '--rows'", {"input": "x.obj"}),
    (["build", "x.obj", "--rows", "0", "--json"], "Invalid value for '--rows'", {"input": "x.obj"}),
    (["build", "/", "--json"], "Invalid value for 'INPUT'", {"input": "/"}),
    (
        ["encode", "x.obj", "-o", "/", "--json"],
        "Invalid value for '-o' / '--output'",
        {"input": "x.obj", "output": "/"},
    ),
    (["encode", "x.obj", "--json"], "Missing option '-o' / '--output'", {"input": "x.obj"}),
    (
        ["encode", "x.obj", "-o", "y.txt", "--json"],
        "the output must be a .swpm file",
        {"input": "x.obj", "output": "y.txt"},
    ),
    # run's input is its config, named as its other --json errors name it (it had no `input`)
    (["run", "c.yaml", "--jobs", "0", "--json"], "Invalid value for '--jobs' / '-j'", {"input": "c.yaml"}),
    (["run", "--jobs", "0", "--json", "c.yaml"], "Invalid value for '--jobs' / '-j'", {"input": "c.yaml"}),
    (["run", "--json"], "Missing argument 'CONFIG'", {}),
    (["inspect", "x.swpm", "--rows", "0", "--json"], "Invalid value for '--rows'", {}),
    (["validate", "a.swpm", "b.swpm", "--json"], "Got unexpected extra argument (b.swpm)", {}),
    (["validate", "a.swpm", "--jsn", "--json"], "No such option '--jsn'", {}),
    # validate --ranges: an item that is not OFF:LEN is named, before the file is read
    (["validate", "a.swpm", "--ranges", "0:64,64-128", "--json"], "'64-128' is not OFF:LEN", {}),
    (["validate", "a.swpm", "--ranges", "", "--json"], "'' is not OFF:LEN", {}),
    (["validate", "a.swpm", "--ranges", "0:6\u00b2", "--json"], "'0:6\u00b2' is not OFF:LEN", {}),
    (
        ["validate", "a.swpm", "--lod", "1", "--prefix", "9", "--json"],
        "give one of --prefix, --ranges, --lod",
        {},
    ),
    (
        ["validate", "a.usda", "--ranges", "0:64", "--json"],
        "reads an SWPM file's bytes, not a USD stage's",
        {},
    ),
    (["conformance", "/nonexistent/vectors", "--json"], "/nonexistent/vectors: no such folder", {}),
]


@pytest.mark.parametrize(("args", "says", "fields"), CASES, ids=[" ".join(c[0]) for c in CASES])
def test_a_usage_error_with_json_prints_a_json_error_and_exits_2(args, says, fields):
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2, (result.output, result.exception)
    out = json.loads(result.stdout)
    assert says in out["error"] and out["usage_error"] is True
    assert (out["code"], out["severity"]) == ("USAGE_ERROR", "error")  # (swpm_usd/codes.py)
    assert {k: v for k, v in out.items() if k not in ("error", "usage_error", "code", "severity")} == fields
    assert "Usage:" in result.stderr and f"Error: {out['error']}" in result.stderr
    # without --json: stdout stays empty, the same text on stderr
    plain = [a for a in args if a != "--json"]
    result = CliRunner().invoke(main, plain)
    assert result.exit_code == 2 and result.stdout == "" and f"Error: {out['error']}" in result.stderr


def test_json_after_a_double_dash_is_an_argument_not_the_option():
    result = CliRunner().invoke(main, ["build", "--rows", "0", "--", "--json"])
    assert result.exit_code == 2 and result.stdout == ""


def test_validate_usd_alone_prints_its_usage_error_as_json():
    result = CliRunner().invoke(validate_usd, ["--json"])
    assert result.exit_code == 2
    assert json.loads(result.stdout) == {
        "error": "Missing argument 'STAGE'.",
        "usage_error": True,
        "code": "USAGE_ERROR",
        "severity": "error",
    }


@pytest.mark.parametrize(
    "args",
    [
        ["encode", "x.obj", "-o", "--json", "--bogus"],
        ["encode", "x.obj", "--output", "--json", "--bogus"],
        ["build", "x.obj", "-p", "--json", "--rows", "0"],
        ["build", "x.obj", "--param", "--json", "--bogus"],
        ["run", "c.yaml", "-j", "--json"],
    ],
    ids=lambda a: " ".join(a),
)
def test_json_given_as_an_options_value_is_not_the_option(args):
    # `-o --json` is the output named "--json" (click takes it as -o's value), not the flag: the usage error
    # is click's text alone, as without --json (stdout was a JSON object the command was not asked for)
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2 and result.stdout == "", result.stdout
    assert "Error: " in result.stderr
    # the same options with --json given as the flag too print the JSON error
    result = CliRunner().invoke(main, [*args, "--json"])
    assert result.exit_code == 2 and json.loads(result.stdout)["usage_error"] is True


@pytest.mark.parametrize("command", ["build", "encode"])
def test_max_triangles_refuses_an_input_over_it(tmp_path, command):
    """``--max-triangles N``: an input over it exits 1, the error naming the file, its count and the budget;
    at its count it builds."""
    mesh = tmp_path / "quads.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\nf 1 2 3 4\nf 2 5 6 3\n")
    out = ["-o", str(tmp_path / "q.swpm")] if command == "encode" else []
    result = CliRunner().invoke(main, [command, str(mesh), *out, "--max-triangles", "3", "--json"])
    assert result.exit_code == 1, (result.output, result.exception)
    error = json.loads(result.stdout)["error"]
    assert str(mesh) in error and "4 triangles" in error and "max_triangles=3" in error
    result = CliRunner().invoke(main, [command, str(mesh), *out, "--max-triangles", "4", "--json"])
    assert result.exit_code == 0, (result.output, result.exception)
    result = CliRunner().invoke(main, [command, str(mesh), *out, "--max-triangles", "-1"])
    assert result.exit_code == 2


def test_every_json_error_of_run_names_its_config_as_input(tmp_path, monkeypatch):
    """``run --json``: a usage error, an invalid config, output.dir unusable and Ctrl-C each carry
    ``input``, the config as given (a usage error had none; a script collecting errors of many runs could
    not tell whose it was)."""
    import swpm_usd.pipeline

    cfg = tmp_path / "c.yaml"
    (tmp_path / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    cfg.write_text("version: 1\nassets: [{glob: '*.obj'}]\noutput: {dir: out}\n")
    given = str(cfg)
    usage = CliRunner().invoke(main, ["run", given, "--only", "nope", "--json"])
    assert usage.exit_code == 2 and json.loads(usage.stdout)["input"] == given
    (tmp_path / "bad.yaml").write_text("version: 1\nassets: 3\n")
    bad = str(tmp_path / "bad.yaml")
    invalid = CliRunner().invoke(main, ["run", bad, "--json"])
    assert invalid.exit_code == 2 and json.loads(invalid.stdout)["input"] == bad
    (tmp_path / "out").write_text("a file where output.dir goes")
    unusable = CliRunner().invoke(main, ["run", given, "--json"])
    assert unusable.exit_code == 2 and json.loads(unusable.stdout)["input"] == given

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(swpm_usd.pipeline, "run", interrupted)
    stopped = CliRunner().invoke(main, ["run", given, "--json"])
    assert stopped.exit_code == 130 and json.loads(stopped.stdout)["input"] == given

    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device", "out/report.html")

    monkeypatch.setattr(swpm_usd.pipeline, "run", full_disk)
    unwritten = CliRunner().invoke(main, ["run", given, "--json"])
    error = json.loads(unwritten.stdout)
    assert unwritten.exit_code == 1 and (error["input"], error["file"]) == (given, "out/report.html")
