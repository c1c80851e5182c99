"""Defects found by a user's acceptance audit (helper-181): each test failed before its fix.

inspect's lambda against the run's, an SWPM file given where a mesh is expected, the hint for a mesh (or a
USD stage) given to inspect, and conformance given a folder that does not exist.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

import swpm_usd
from swpm_usd.cli import main
from swpm_usd.errors import MeshLoadError
from swpm_usd.io import load_mesh
from swpm_usd.pipeline.worker import summarize


def _grid_obj(n: int) -> str:
    """An OBJ of an n x n grid of quads split in two triangles, its heights varied: builds in a moment."""
    lines = [f"v {x} {y} {(x * y) % 3 * 0.1}" for y in range(n + 1) for x in range(n + 1)]
    for y in range(n):
        for x in range(n):
            a = y * (n + 1) + x + 1
            lines += [f"f {a} {a + 1} {a + n + 2}", f"f {a} {a + n + 2} {a + n + 1}"]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("encoding", ["vanilla", "skip-strip", "mixed", "sliding-window"])
def test_inspect_reports_the_lambda_the_run_reports(tmp_path, encoding):
    # inspect divided INDX alone by LOD 0's indices, the run's manifest and report every stored index list:
    # spot's skip-strip file read lambda 2.61 in inspect, 5.23 in its run's report.html
    mesh = tmp_path / "g.obj"
    mesh.write_text(_grid_obj(8))
    pm = swpm_usd.build(str(mesh), encoding=encoding)
    swpm_usd.save(pm, tmp_path / "g.swpm")
    result = CliRunner().invoke(main, ["inspect", str(tmp_path / "g.swpm"), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["lambda"] == pytest.approx(summarize(pm)["lambda"])
    # (index_count stays what INDX holds)
    indx = {"vanilla": "indices", "skip-strip": "level_indices", "mixed": "level_static_indices"}
    assert report["index_count"] == pm.buffers()[indx.get(encoding, "index_pool")].shape[0]


@pytest.mark.parametrize("suffix", [".obj", ".usdc", ".ply"])
def test_an_swpm_file_under_a_mesh_name_is_called_an_swpm_file(tmp_path, suffix):
    # a .swpm renamed .obj was "no triangles: the file holds no triangle geometry" (INPUT_EMPTY), as .usdc
    # "USD could not open it": the file is named for what it is and what reads it
    mesh = tmp_path / "g.obj"
    mesh.write_text(_grid_obj(3))
    swpm_usd.save(swpm_usd.build(str(mesh), encoding="vanilla"), tmp_path / "g.swpm")
    renamed = tmp_path / f"r{suffix}"
    renamed.write_bytes((tmp_path / "g.swpm").read_bytes())
    with pytest.raises(MeshLoadError, match="it is an SWPM file") as err:
        load_mesh(renamed)
    assert err.value.code == "INPUT_MALFORMED" and err.value.offset == 0
    result = CliRunner().invoke(main, ["encode", str(renamed), "-o", str(tmp_path / "o.swpm"), "--json"])
    assert result.exit_code == 1
    out = json.loads(result.stdout)
    assert out["code"] == "INPUT_MALFORMED" and "swpm-pipeline inspect" in out["error"]
    assert not (tmp_path / "o.swpm").exists()


def test_an_swpm_file_given_to_encode_says_what_reads_it(tmp_path):
    path = tmp_path / "a.swpm"
    path.write_bytes(b"\0" * 64)
    with pytest.raises(MeshLoadError, match=r"unsupported file type '\.swpm'.*swpm-pipeline inspect") as err:
        load_mesh(path)
    assert err.value.code == "INPUT_UNSUPPORTED"


def test_a_short_mesh_file_given_to_inspect_gets_the_hint(tmp_path):
    # the hint came on a bad magic only: a mesh file shorter than the magic (header truncated) got none
    mesh = tmp_path / "t.obj"
    mesh.write_text("v 0\n")
    result = CliRunner().invoke(main, ["inspect", str(mesh)])
    assert result.exit_code == 1
    assert "SWPM_HEADER_TRUNCATED" in result.stdout
    assert result.stderr.startswith(f"hint: {mesh} is a mesh file (.obj), not an SWPM file")


def test_a_usd_stage_given_to_inspect_is_pointed_to_validate(tmp_path):
    # inspect reads .swpm files only; for a stage it suggested encode alone, not validate, which checks it
    from swpm_usd import usd

    mesh = tmp_path / "g.obj"
    mesh.write_text(_grid_obj(3))
    usd.write(swpm_usd.build(str(mesh), encoding="vanilla"), tmp_path / "g.usda")
    stage = tmp_path / "g.usda"
    result = CliRunner().invoke(main, ["inspect", str(stage)])
    assert result.exit_code == 1
    assert f"swpm-pipeline validate {stage} checks a stage's SwpmMeshAPI prims" in result.stderr
    assert CliRunner().invoke(main, ["validate", str(stage)]).exit_code == 0


def test_conformance_of_a_missing_folder_says_it_is_missing(tmp_path):
    # it said "nowhere has no manifest.json", as of a folder that exists without one
    missing = tmp_path / "nowhere"
    result = CliRunner().invoke(main, ["conformance", str(missing)])
    assert result.exit_code == 2
    assert f"{missing}: no such folder" in result.stderr
    (tmp_path / "empty").mkdir()
    result = CliRunner().invoke(main, ["conformance", str(tmp_path / "empty")])
    assert result.exit_code == 2 and "has no manifest.json" in result.stderr


@pytest.mark.parametrize("width, found", [(2, False), (3, True), (4, True)])
def test_a_wrong_index_width_on_a_stage_is_found(tmp_path, width, found):
    # swpm:indexWidth 3 (or 4 where 2 is derived) passed validate: a runtime uploads the indices at it
    from pxr import Usd

    from swpm_usd import usd
    from swpm_usd.usd.validate import CODES, validate_stage

    mesh = tmp_path / "g.obj"
    mesh.write_text(_grid_obj(3))
    path = usd.write(
        swpm_usd.build(str(mesh), encoding="sliding-window", primitive="strip"), tmp_path / "g.usda"
    )
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetPrimAtPath(stage.GetDefaultPrim().GetPath().AppendChild("mesh"))
    assert prim.GetAttribute("swpm:indexWidth").Get() == 2
    prim.GetAttribute("swpm:indexWidth").Set(width)
    stage.GetRootLayer().Save()
    codes = [f.code for f in validate_stage(path, builtin=False)]
    assert ("SWPM_USD_INDEX_WIDTH" in codes) is found and "SWPM_USD_INDEX_WIDTH" in CODES
    assert codes == (["SWPM_USD_INDEX_WIDTH"] if found else [])


def test_the_report_names_an_asset_no_rule_matched_as_built_by_the_defaults(tmp_path):
    # report.html's rule column read "None" (Python's) for an asset built by the config's defaults
    from swpm_usd.pipeline import run

    (tmp_path / "m").mkdir()
    for name in ("a", "b"):
        (tmp_path / "m" / f"{name}.obj").write_text(_grid_obj(3 if name == "a" else 4))
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out, usd: false, scene: false}\n"
        "defaults: {encoding: vanilla}\n"
        "rules: [{name: big, match: {triangles: {min: 30}}, encoding: vanilla}]\n"
    )
    res = run(cfg, echo=lambda m: None)
    assert not res.failures
    html = (tmp_path / "out" / "report.html").read_text()
    assert "<td>m/a.obj</td><td>(defaults)</td>" in html and "<td>m/b.obj</td><td>big</td>" in html
    assert "<td>None</td>" not in html


COMBINATIONS = [
    (["builder=forsyth", "order_passes=1"], "order_passes > 0 needs builder='topology' without cluster"),
    (["cluster=true", "order_passes=2"], "order_passes > 0 needs builder='topology' without cluster"),
    (["cluster=true", "builder=forsyth"], "cluster=True needs builder='topology'"),
    # (Forsyth's builder ignored the bound and recorded it in the file's params all the same)
    (["builder=forsyth", "error_bound=4"], "error_bound needs builder='topology'"),
    # (Forsyth's builder ignored these too, silently: target_slack recorded, the bytes the default's)
    (["builder=forsyth", "target_slack=0.5"], "target_slack needs builder='topology'"),
    (["builder=forsyth", "mu=0.2"], "mu needs builder='topology'"),
    (["builder=forsyth", "inner_vertices=3"], "inner_vertices needs builder='topology'"),
    (["builder=forsyth", "absorb_middle=false"], "absorb_middle needs builder='topology'"),
    (["builder=forsyth", "absorb_rounds=0"], "absorb_rounds needs builder='topology'"),
    (["builder=forsyth", "order_reach=3"], "order_reach needs builder='topology'"),
    # (and the other parameters a build ignored, silently, where another one turns their use off)
    (["tolerance=0.5"], "tolerance needs builder='forsyth'"),
    (["swap_max_deviation=0.001"], "swap_max_deviation needs optimize_connectivity=True"),
    (["absorb_middle=false", "absorb_rounds=0"], "absorb_rounds needs absorb_middle=True"),
    (
        ["cluster=true", "order_reach=3"],
        "order_reach needs order_passes > 0 (builder='topology' without cluster)",
    ),
    (
        ["order_passes=0", "order_reach=1"],
        "order_reach needs order_passes > 0 (builder='topology' without cluster)",
    ),
    (["strip_window=8"], "strip_window needs primitive='strip'"),  # (the sliding window's default: list)
]


@pytest.mark.parametrize("params, says", COMBINATIONS)
def test_a_parameter_combination_the_builder_refuses_is_a_usage_error(tmp_path, params, says):
    # each value valid alone: the command line read the mesh and failed at the build (exit 1), a config
    # passed --dry-run and failed every asset; both now stop before any mesh is read, in the builder's words
    args = ["build", str(tmp_path / "missing.obj"), "-e", "sliding-window"]
    for p in params:
        args += ["-p", p]
    result = CliRunner().invoke(main, [*args, "--json"])
    assert result.exit_code == 2, result.output
    assert json.loads(result.stdout)["error"] == f"Invalid value for --param: {says}"
    values = ", ".join(p.replace("=", ": ") for p in params)
    for section in (
        f"defaults: {{encoding: sliding-window, params: {{{values}}}}}\n",
        f"rules: [{{name: r, encoding: sliding-window, params: {{{values}}}}}]\n",
    ):
        cfg = tmp_path / "pipeline.yaml"
        cfg.write_text(f"version: 1\nassets: [{{glob: 'm/*.obj'}}]\noutput: {{dir: out}}\n{section}")
        result = CliRunner().invoke(main, ["run", str(cfg), "--dry-run"])
        assert result.exit_code == 2, result.output
        assert f"params: {says}" in result.stderr
    with pytest.raises(swpm_usd.BuildError, match=says.replace("(", r"\(").replace(")", r"\)")):
        swpm_usd.build(str(_write(tmp_path / "g.obj")), encoding="sliding-window", **_values(params))


@pytest.mark.parametrize(
    "params, says",
    [
        (["primitive=list", "restart=false"], "restart needs primitive='strip'"),
        (["primitive=list", "strip_window=8"], "strip_window needs primitive='strip'"),
    ],
)
def test_a_strip_parameter_with_primitive_list_is_a_usage_error(tmp_path, params, says):
    # skip-strip with primitive=list builds no strip: restart and strip_window were ignored, silently, and
    # recorded in the file's params
    args = ["build", str(tmp_path / "missing.obj"), "-e", "skip-strip"]
    for p in params:
        args += ["-p", p]
    result = CliRunner().invoke(main, [*args, "--json"])
    assert result.exit_code == 2, result.output
    assert json.loads(result.stdout)["error"] == f"Invalid value for --param: {says}"
    cfg = tmp_path / "pipeline.yaml"
    values = ", ".join(p.replace("=", ": ") for p in params)
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\n"
        f"defaults: {{encoding: skip-strip, params: {{{values}}}}}\n"
    )
    result = CliRunner().invoke(main, ["run", str(cfg), "--dry-run"])
    assert result.exit_code == 2, result.output
    assert f"params: {says}" in result.stderr
    kwargs = {k: json.loads(v) if v != "list" else v for k, v in (p.split("=") for p in params)}
    with pytest.raises(swpm_usd.BuildError, match=says):
        swpm_usd.build(str(_write(tmp_path / "g.obj")), encoding="skip-strip", **kwargs)
    for taken in (["primitive=list", "restart=true", "strip_window=4"], ["restart=false", "strip_window=8"]):
        args = ["build", str(tmp_path / "g.obj"), "-e", "skip-strip", "--rows", "2"]
        for p in taken:
            args += ["-p", p]
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 0, result.output


def test_a_combination_the_builder_takes_is_taken(tmp_path):
    mesh = _write(tmp_path / "g.obj")
    for params in (
        ["cluster=true", "order_passes=0"],
        ["builder=forsyth", "order_passes=0"],
        ["mu=0.2"],
        ["builder=forsyth", "error_bound=null"],
        ["builder=forsyth", "target_slack=null", "mu=0.1", "order_reach=2"],  # (each its default)
        ["builder=forsyth", "tolerance=0.5", "cache_size=12", "primitive=strip"],  # (what it uses)
        ["tolerance=0.1", "swap_max_deviation=0.0005", "order_passes=0", "order_reach=2"],  # (defaults)
        ["optimize_connectivity=true", "swap_max_deviation=0.001", "absorb_rounds=0", "order_reach=3"],
        ["primitive=strip", "strip_window=8"],
        ["cluster=true", "error_bound=4"],
    ):
        args = ["build", str(mesh), "-e", "sliding-window", "--rows", "2"]
        for p in params:
            args += ["-p", p]
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 0, result.output


def _write(path):
    path.write_text(_grid_obj(4))
    return path


def _values(params: list[str]) -> dict:
    return {k: json.loads(v) if v not in ("forsyth",) else v for k, v in (p.split("=") for p in params)}


def test_save_refuses_a_mesh_file_name(tmp_path):
    # swpm_usd.save(pm, "spot.obj") wrote the SWPM bytes over the source mesh; encode -o refuses such a name
    from swpm_usd.format.errors import SwpmEncodeError

    mesh = _write(tmp_path / "g.obj")
    before = mesh.read_bytes()
    pm = swpm_usd.build(str(mesh), encoding="vanilla")
    for name in ("g.obj", "g.USDA", "h.glb"):
        with pytest.raises(SwpmEncodeError, match="a mesh file's name") as err:
            swpm_usd.save(pm, tmp_path / name)
        assert err.value.code == "OUTPUT_UNSUPPORTED"
    assert mesh.read_bytes() == before and not (tmp_path / "g.USDA").exists()
    assert swpm_usd.load(swpm_usd.save(pm, tmp_path / "g.swpm")).lod_count == pm.lod_count
    swpm_usd.save(pm, tmp_path / "g.bin")  # (any other name is the caller's)


def test_loading_a_missing_swpm_file_is_input_not_found(tmp_path):
    # it was INPUT_MALFORMED, as a corrupt file: the codes a missing or unreadable mesh gets
    from swpm_usd.format.errors import SwpmFormatError

    with pytest.raises(SwpmFormatError, match="SWPM_IO_ERROR") as err:
        swpm_usd.load(tmp_path / "missing.swpm")
    assert err.value.code == "INPUT_NOT_FOUND"
    with pytest.raises(SwpmFormatError) as err:
        swpm_usd.load(tmp_path)
    assert err.value.code == "INPUT_UNREADABLE"
    (tmp_path / "cut.swpm").write_bytes(b"SWPM")
    with pytest.raises(SwpmFormatError) as err:
        swpm_usd.load(tmp_path / "cut.swpm")
    assert err.value.code == "INPUT_MALFORMED"


def test_reading_a_prim_the_stage_lacks_says_so(tmp_path):
    # usd.read(stage.GetPrimAtPath("/Typo")) told the user to keep the stage in a variable, which they did
    from pxr import Usd

    from swpm_usd import usd
    from swpm_usd.usd.reader import UsdReadError

    usd.write(swpm_usd.build(str(_write(tmp_path / "g.obj")), encoding="vanilla"), tmp_path / "g.usda")
    stage = Usd.Stage.Open(str(tmp_path / "g.usda"))
    with pytest.raises(UsdReadError, match="a null prim, no prim at the path asked") as err:
        usd.read(stage.GetPrimAtPath("/Typo"))
    assert "keep the Usd.Stage" not in str(err.value)
    with pytest.raises(
        UsdReadError, match=r"invalid prim /G: not a prim of an open stage \(keep the Usd.Stage"
    ):
        usd.read(Usd.Stage.Open(str(tmp_path / "g.usda")).GetDefaultPrim())
    assert usd.read(stage.GetDefaultPrim()).lod_count > 1


def test_encode_and_build_help_say_what_each_parameter_does():
    # they listed names and defaults (mu=0.1 cluster=false ...) and no word of what any does
    from swpm_usd.encodings import ENCODING_PARAMS, PARAM_HELP

    assert {k for d in ENCODING_PARAMS.values() for k in d} <= set(PARAM_HELP)
    for command in ("encode", "build"):
        text = CliRunner().invoke(main, [command, "--help"], terminal_width=80).output
        section = text[text.index("What each parameter does:") :]
        for name, says in PARAM_HELP.items():
            assert any(line.split() == [name, *says.split()] for line in section.splitlines()), name
    assert "What each parameter does" not in CliRunner().invoke(main, ["--help"]).output


def test_an_unknown_parameter_in_a_config_names_its_encoding(tmp_path):
    # "(not a parameter of this rule's encoding)" of the defaults too, and of auto, which takes select alone
    from swpm_usd.pipeline.config import ConfigError, load_config

    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: '*.obj'}]\noutput: {dir: out}\n"
        "defaults: {encoding: vanilla, params: {mu: 0.2}}\n"
        "rules:\n"
        "  - {name: a, encoding: skip-strip, params: {cluster: true}}\n"
        "  - {name: b, encoding: auto, params: {mu: 0.2}}\n"
    )
    (tmp_path / "a.obj").write_text(_grid_obj(2))
    with pytest.raises(ConfigError) as err:
        load_config(cfg)
    assert [p.split(": ", 1)[1] for p in err.value.problems] == [
        "$.defaults.params.mu: unknown key (not a parameter of vanilla; sliding-window takes it)",
        "$.rules[0].params.cluster: unknown key (not a parameter of skip-strip; sliding-window takes it)",
        "$.rules[1].params.mu: unknown key (not a parameter of auto, which takes select alone)",
    ]


@pytest.mark.parametrize(
    "section, says",
    [
        (
            "{encoding: sliding-window, params: {tolerance: '0.2'}}",
            "tolerance: '0.2' is not of type 'number'",
        ),
        (
            "{encoding: sliding-window, params: {builder: forsyth, mu: 'x'}}",
            "mu: 'x' is not of type 'number'",
        ),
        (
            "{encoding: sliding-window, params: {builder: forsyth, absorb_rounds: true}}",
            "absorb_rounds: True is not of type",
        ),
        (
            "{encoding: skip-strip, params: {primitive: list, strip_window: '8'}}",
            "strip_window: '8' is not of type 'integer'",
        ),
    ],
)
def test_a_parameter_of_the_wrong_type_is_named_once_not_as_a_combination_too(tmp_path, section, says):
    # combination_problem counted a value of the wrong type as set: a config said 'tolerance needs
    # builder='forsyth'' (or 'mu needs builder='topology'', ...) beside the value's own type error
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(f"version: 1\nassets: [{{glob: 'm/*.obj'}}]\noutput: {{dir: out}}\ndefaults: {section}\n")
    result = CliRunner().invoke(main, ["run", str(cfg), "--dry-run"])
    assert result.exit_code == 2, result.output
    assert says in result.stderr
    assert "needs" not in result.stderr, result.stderr


@pytest.mark.parametrize(
    "encoding, params, says",
    [
        (
            "sliding-window",
            {"builder": "forsyth", "absorb_middle": False},
            "absorb_middle needs builder='topology'",
        ),
        (
            "sliding-window",
            {"absorb_middle": False, "absorb_rounds": 0},
            "absorb_rounds needs absorb_middle=True",
        ),
        (
            "sliding-window",
            {"optimize_connectivity": False, "swap_max_deviation": 0.001},
            "swap_max_deviation needs optimize_connectivity=True",
        ),
        ("skip-strip", {"primitive": "list", "restart": False}, "restart needs primitive='strip'"),
    ],
)
def test_a_combination_of_numpy_bools_is_refused_as_of_python_bools(tmp_path, encoding, params, says):
    # swpm_usd.build takes numpy's bool for a bool parameter (check_params); the combination rules compared
    # 'is False' (absorb_rounds, swap_max_deviation), and a numpy bool read as a value of the wrong type
    # (numpy 2 names it 'bool'), so np.False_ was let through, ignored, and recorded in the file's params
    from swpm_usd.encodings import combination_problem

    numpy_params = {k: np.bool_(v) if isinstance(v, bool) else v for k, v in params.items()}
    assert combination_problem(encoding, params) == says
    assert combination_problem(encoding, numpy_params) == says
    with pytest.raises(swpm_usd.BuildError, match=says.replace("(", r"\(").replace(")", r"\)")):
        swpm_usd.build(str(_write(tmp_path / "g.obj")), encoding=encoding, **numpy_params)
    taken = {k: np.bool_(True) if k == "absorb_middle" else v for k, v in numpy_params.items()}
    if encoding == "sliding-window" and "builder" not in params:
        assert combination_problem(encoding, {**taken, "optimize_connectivity": np.bool_(True)}) is None
