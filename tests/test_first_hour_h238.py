"""A new user's first hour, from a fresh install (helper-238): the README's example does not flood the
terminal, its first command's sentence names every file the run writes, and the first slips on the command
line (a parameter of another encoding, a misspelt name, a mesh given to ``run``) say what was meant."""

from __future__ import annotations

import contextlib
import io
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import ROOT

from swpm_usd.cli import main
from swpm_usd.pipeline import run
from swpm_usd.pipeline.config import ConfigError, load_config

README = (ROOT / "README.md").read_text()


def test_the_readme_python_example_prints_a_screenful(tmp_path, monkeypatch):
    """It printed the whole layer, ``ExportToString()``: 0.9 MB of spot's arrays on the terminal, the
    schema's attributes lost in it."""
    code = re.findall(r"```python\n(.*?)```", README, re.S)[0]
    shutil.copytree(ROOT / "samples", tmp_path / "samples", ignore=shutil.ignore_patterns("out"))
    monkeypatch.chdir(tmp_path)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {})  # noqa: S102 - the README's own example
    printed = out.getvalue()
    assert len(printed) < 8000 and max(len(line) for line in printed.splitlines()) <= 100, len(printed)
    # what it is there to show: the asset's prim, the Mesh with the schema and its attributes
    shown = ('def Xform "Spot"', 'prepend apiSchemas = ["SwpmMeshAPI"]', "swpm:encoding", "swpm:lodErrors")
    for says in shown:
        assert says in printed, says


def test_the_readme_names_every_file_the_sample_run_writes(tmp_path):
    """The first command's sentence listed a .swpm and a USD layer per mesh, manifest.json and report.html;
    the sample config writes scene.usda too."""
    shutil.copytree(ROOT / "samples", tmp_path / "samples", ignore=shutil.ignore_patterns("out"))
    res = run(tmp_path / "samples" / "pipeline.yaml", echo=lambda m: None)
    assert res.built == 2
    written = {p.name for p in (tmp_path / "samples" / "out").iterdir() if not p.name.startswith(".")}
    stems = {p.stem for p in (tmp_path / "samples").glob("*.obj")}
    kinds = {f".{name.split('.', 1)[1]}" if name.split(".", 1)[0] in stems else name for name in written}
    assert kinds == {".swpm", ".usdc", "scene.usda", "manifest.json", "report.html"}, written
    sentence = README[README.index("Install and run the main job") : README.index("```sh")]
    for kind in kinds:
        assert f"`{kind}`" in sentence, kind


@pytest.mark.parametrize(
    "args, says",
    [
        # the default encoding is vanilla: -p mu=0.2 said vanilla takes boundary_weight and seam_weight
        (["-p", "mu=0.2"], "mu not a parameter of vanilla (mu: sliding-window takes it); it takes"),
        (["-e", "mixed", "-p", "primitive=list"], "(primitive: sliding-window and skip-strip take it)"),
        (
            ["-e", "sliding-window", "-p", "muu=0.2"],
            "muu not a parameter of sliding-window (muu: did you mean 'mu'?)",
        ),
        (
            ["-e", "skip-strip", "-p", "mu=0.1", "-p", "restrat=true"],
            "(mu: sliding-window takes it; restrat: did you mean 'restart'?)",
        ),
        # a slip on another encoding's name: the name meant and who takes it (it said nothing of MU)
        (["-p", "MU=0.2"], "(MU: did you mean 'mu'? sliding-window takes it)"),
        (
            ["-e", "skip-strip", "-p", "optimise_connectivity=true"],
            "(optimise_connectivity: did you mean 'optimize_connectivity'? sliding-window takes it)",
        ),
        (["-e", "slidingwindow"], "vanilla (did you mean 'sliding-window'?)"),
        (["-e", "Vanilla"], "(did you mean 'vanilla'?)"),
    ],
)
@pytest.mark.parametrize("command", ["build", "encode"])
def test_a_slip_on_the_command_line_says_what_was_meant(tmp_path, command, args, says):
    mesh = tmp_path / "a.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    argv = [command, str(mesh), *args, *(["-o", str(tmp_path / "a.swpm")] if command == "encode" else [])]
    result = CliRunner().invoke(main, argv)
    assert result.exit_code == 2 and says in result.output, result.output
    result = CliRunner().invoke(main, [*argv, "--json"])
    assert result.exit_code == 2 and says in json.loads(result.stdout)["error"]
    assert not (tmp_path / "a.swpm").exists()


def test_an_unmisspelt_unknown_parameter_gets_no_guess(tmp_path):
    mesh = tmp_path / "a.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    result = CliRunner().invoke(main, ["build", str(mesh), "-p", "zz=1"])
    assert result.exit_code == 2
    assert "zz not a parameter of vanilla; it takes boundary_weight, seam_weight" in result.output


def test_a_config_names_the_encoding_that_takes_a_parameter(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: '*.obj'}]\noutput: {dir: out}\n"
        "defaults: {encoding: vanilla, params: {mu: 0.2, seam_weight: 1}}\n"
        "rules:\n  - {name: a, encoding: mixed, params: {primitive: list, nope: 1}}\n"
    )
    (tmp_path / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(ConfigError) as err:
        load_config(cfg)
    assert [p.split(": ", 1)[1] for p in err.value.problems] == [
        "$.defaults.params.mu: unknown key (not a parameter of vanilla; sliding-window takes it)",
        "$.rules[0].params.primitive: unknown key (not a parameter of mixed; sliding-window and skip-strip "
        "take it)",
        "$.rules[0].params.nope: unknown key (not a parameter of mixed)",
    ]


@pytest.mark.parametrize("name", ["spot.obj", "scene.gltf", "model.glb", "stage.usda"])
def test_run_given_a_mesh_says_it_is_a_mesh_and_what_to_run(tmp_path, name):
    """``swpm-pipeline run spot.obj`` said "the configuration must be a mapping (version, assets, output), not
    a scalar"; a .glb "cannot read the file ('utf-8' codec can't decode ...)"; a .gltf listed its JSON's keys
    as unknown ones of a config."""
    contents = {
        "spot.obj": (ROOT / "samples" / "spot.obj").read_bytes(),
        "scene.gltf": json.dumps({"asset": {"version": "2.0"}, "meshes": []}).encode(),
        "model.glb": b"glTF\x02\x00\x00\x00\x0c\x00\x00\x00\xff\xfe",
        "stage.usda": b'#usda 1.0\ndef Mesh "m" {}\n',
    }
    mesh = tmp_path / name
    mesh.write_bytes(contents[name])
    result = CliRunner().invoke(main, ["run", str(mesh)])
    assert result.exit_code == 2
    stem = name.split(".")[0]
    assert result.stderr.strip() == (
        f"{mesh}:1:1: $: {mesh} is a mesh file (.{name.split('.')[1]}), not a pipeline config: swpm-pipeline "
        f"build {mesh} shows its LODs, swpm-pipeline encode {mesh} -o {stem}.swpm writes one; a config is a "
        "YAML file whose assets name the meshes (samples/pipeline.yaml is one)"
    )
    result = CliRunner().invoke(main, ["run", str(mesh), "--json"])
    out = json.loads(result.stdout)
    assert result.exit_code == 2 and out["code"] == "CONFIG_INVALID"
    assert "is a mesh file" in out["problems"][0]
    # a mesh name that is no file is still "file not found", and a config is read as before
    result = CliRunner().invoke(main, ["run", str(tmp_path / "nope.obj")])
    assert result.exit_code == 2 and result.stderr.strip().endswith("$: file not found")


@pytest.mark.parametrize("read_only", [True, False])
def test_an_output_dir_on_a_read_only_mount_is_named_so(tmp_path, monkeypatch, read_only):
    """A read-only mount (a farm's input share given as output.dir) said "permission denied", even to root,
    whom no permission stops; its flag says why."""
    import os
    import types

    (tmp_path / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "out").mkdir()
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text("version: 1\nassets: [{glob: '*.obj'}]\noutput: {dir: out}\n")
    out = tmp_path / "out"
    real_access, real_statvfs = os.access, os.statvfs
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: Path(p) != out and real_access(p, mode, **kw))

    def statvfs(p):
        if Path(p) == out:
            return types.SimpleNamespace(f_flag=os.ST_RDONLY if read_only else 0)
        return real_statvfs(p)

    monkeypatch.setattr(os, "statvfs", statvfs)
    result = CliRunner().invoke(main, ["run", str(cfg)])
    why = "it is on a read-only file system" if read_only else "permission denied"
    assert result.exit_code == 2
    assert result.stderr.strip() == f"{cfg}:3:15: $.output.dir: cannot write in {out}: {why}"
    assert not list(out.glob("*.swpm"))  # (nothing built; the lock file root could still make aside)


@pytest.mark.parametrize(
    "kwargs, says",
    [
        ({"mu": 0.2}, "mu do not belong to encoding 'vanilla' (mu: sliding-window takes it); it accepts"),
        (
            {"encoding": "sliding-window", "params": {"mu": 0.2}},  # (a config's params, given whole)
            "(params: give each parameter as a keyword, build(path, encoding, **params))",
        ),
        ({"encoding": "slidingwindow"}, "vanilla'] (did you mean 'sliding-window'?)"),
        (
            {"encoding": "mixed", "muu": 1},  # (a slip on another encoding's name: that one named)
            "muu do not belong to encoding 'mixed' (muu: did you mean 'mu'? sliding-window takes it); it",
        ),
        ({"encoding": "mixed", "zz": 1}, "parameter(s) zz do not belong to encoding 'mixed'; it accepts"),
    ],
)
def test_a_slip_in_python_says_what_was_meant(tmp_path, kwargs, says):
    import swpm_usd
    from swpm_usd.errors import SwpmError

    mesh = tmp_path / "a.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(SwpmError) as err:
        swpm_usd.build(mesh, **kwargs)
    assert err.value.code == "PARAMETER_INVALID" and says in str(err.value), str(err.value)


@pytest.mark.parametrize("name", ["meshes", "dir.obj"])
def test_a_folder_given_as_a_mesh_is_called_a_folder(tmp_path, name):
    """``swpm_usd.build("meshes")`` said "unsupported file type '(no suffix)'"."""
    import swpm_usd
    from swpm_usd.io import MeshLoadError

    (tmp_path / name).mkdir()
    with pytest.raises(MeshLoadError) as err:
        swpm_usd.build(tmp_path / name)
    assert err.value.code == "INPUT_UNREADABLE"
    assert str(err.value) == (
        f"{tmp_path / name}: not a regular file: a folder; a pipeline config builds the meshes in one "
        "(assets: [{glob: 'meshes/*.obj'}], as samples/pipeline.yaml)"
    )


@pytest.mark.parametrize(
    "assets, says",
    [
        (
            "  - glob: *.obj\n",
            "3:12: $: invalid YAML: expected alphabetic or numeric character, but found '.'",
        ),
        (
            "  - glob: **/*.obj\n",
            "3:12: $: invalid YAML: expected alphabetic or numeric character, but found '*'",
        ),
        ("  - glob: *obj\n", "3:11: $: invalid YAML: found undefined alias 'obj'"),
    ],
)
def test_an_unquoted_glob_is_told_to_be_quoted(tmp_path, assets, says):
    """``glob: *.obj`` unquoted is a YAML alias: the config said only "expected alphabetic or numeric
    character, but found '.'"."""
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(f"version: 1\nassets:\n{assets}output: {{dir: out}}\n")
    with pytest.raises(ConfigError) as err:
        load_config(cfg)
    assert err.value.problems == [
        f'{cfg}:{says}; a value starting with * is a YAML alias: quote it, as glob: "*.obj"'
    ]


def test_a_tab_in_a_config_is_told_as_a_tab(tmp_path):
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text("version: 1\nassets:\n  - glob: '*.obj'\noutput:\n  dir: out\n\tswpm: true\n")
    with pytest.raises(ConfigError) as err:
        load_config(cfg)
    assert err.value.problems == [
        f"{cfg}:6:1: $: invalid YAML: found character '\\t' that cannot start any token; YAML indents with "
        "spaces, not tabs"
    ]


def test_validate_of_a_stage_says_valid_or_invalid_as_of_an_swpm_file(tmp_path):
    """``validate spot.usdc`` ended "spot.usdc: 0 error(s), 0 warning(s)" where ``validate spot.swpm`` says
    "spot.swpm: valid": the verdict first, alike."""
    import swpm_usd
    from swpm_usd import usd

    pm = swpm_usd.build(ROOT / "samples" / "spot.obj", encoding="vanilla")
    stage = tmp_path / "spot.usdc"
    usd.write(pm, stage)
    result = CliRunner().invoke(main, ["validate", str(stage)])
    assert (
        result.exit_code == 0
        and result.output.splitlines()[-1] == f"{stage}: valid, 0 error(s), 0 warning(s)"
    )
    bad = tmp_path / "bad.usda"
    bad.write_text(
        '#usda 1.0\ndef Mesh "m" (prepend apiSchemas = ["SwpmMeshAPI"]) {\n'
        '    uniform token swpm:encoding = "nope"\n}\n'
    )
    result = CliRunner().invoke(main, ["validate", str(bad), "--no-builtin"])
    last = result.output.splitlines()[-1]
    assert result.exit_code == 1 and last.startswith(f"{bad}: INVALID, ") and "0 error(s)" not in last


def test_the_readme_names_the_benchmarks_that_need_meshoptimizer():
    """After the README's first command (``pip install .``, no dev extra) ``benchmarks/run.py`` and five
    others stop at ``No module named 'meshoptimizer'``: the Benchmarks section names them and the extra."""
    section = README[README.index("## Benchmarks") : README.index("```sh", README.index("## Benchmarks"))]
    needing = sorted(
        p.name
        for p in (ROOT / "benchmarks").glob("*.py")
        if re.search(r"^\s*import meshoptimizer", p.read_text(), re.M)
    )
    assert needing, "no benchmark imports meshoptimizer: the README's sentence is stale"
    for name in needing:
        assert f"`{name}`" in section, name
    assert "pip install -e '.[dev]'" in section


def test_the_readme_command_line_section_names_every_option():
    """``build --rows``, ``inspect --rows`` and ``validate --no-builtin`` were in ``--help`` alone."""
    import click

    section = README[README.index("## Command line") : README.index("## Layout")]
    ctx = click.Context(main)
    missing = []
    for name in main.list_commands(ctx):
        for param in main.get_command(ctx, name).params:
            if isinstance(param, click.Option) and "--help" not in param.opts:
                if not any(re.search(rf"`[^`]*{re.escape(opt)}\b[^`]*`", section) for opt in param.opts):
                    missing.append(f"{name} {'/'.join(param.opts)}")
    assert not missing, missing


def test_load_of_a_mesh_file_says_what_reads_it(tmp_path):
    """``swpm_usd.load("spot.obj")`` said only "SWPM_HEADER_BAD_MAGIC: magic is 7620302e33343837, ..."."""
    import swpm_usd
    from swpm_usd.format import SwpmFormatError

    with pytest.raises(SwpmFormatError) as err:
        swpm_usd.load(ROOT / "samples" / "spot.obj")
    assert err.value.code == "INPUT_MALFORMED" and err.value.report.errors[0].code == "SWPM_HEADER_BAD_MAGIC"
    assert str(err.value).endswith(
        "; it is a mesh file (.obj), not an SWPM file: swpm_usd.build reads it (swpm_usd.save writes one)"
    )
    other = tmp_path / "notes.txt"  # (no mesh name: no hint)
    other.write_text("x" * 100)
    with pytest.raises(SwpmFormatError) as err:
        swpm_usd.load(other)
    assert "mesh file" not in str(err.value)


def test_build_help_gives_a_param_example_that_builds(tmp_path):
    """``build --help`` gave ``-p mu=0.2`` as -p's example: under the default vanilla, a usage error."""
    text = " ".join(CliRunner().invoke(main, ["build", "--help"], terminal_width=80).output.split())
    example = re.search(r"when it can be: ((?:-[ep] \S+ ?)+)", text)
    assert example, text
    mesh = tmp_path / "a.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    result = CliRunner().invoke(main, ["build", str(mesh), *example.group(1).split()])
    assert result.exit_code == 0, result.output


def test_save_of_what_is_not_a_progressive_mesh_says_what_it_got(tmp_path):
    # swpm_usd.save(1, path) was "AttributeError: 'int' object has no attribute 'encoding'" from the writer
    import swpm_usd

    mesh = swpm_usd.Mesh(np.zeros((3, 3)), np.array([[0, 1, 2]]))
    for pm, said in ((1, "not int"), ("spot.obj", "a path: swpm_usd.build"), (mesh, "before its build")):
        with pytest.raises(TypeError, match=said):
            swpm_usd.save(pm, tmp_path / "a.swpm")
    assert not list(tmp_path.iterdir())
