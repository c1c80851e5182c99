"""What a new user meets in a first hour with the README and the command line: a run that says what it is
doing before numba's first compile, a screen-space LOD pick for every encoding, a command list that is not
cut off, a conformance run outside a checkout that says where vectors are, and Ctrl-C in a numba kernel."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import shared_mesh

import swpm_usd
from swpm_usd.cli import main
from swpm_usd.pipeline import run


@pytest.mark.parametrize("encoding", ["vanilla", "sliding-window"])
def test_lod_for_screen_error_is_the_coarsest_lod_within_the_pixels(encoding):
    pm = swpm_usd.build(shared_mesh("suzanne.obj"), encoding=encoding)
    errs = pm.lod_errors.astype(np.float64)
    distance, fov_y, height = 12.0, math.radians(60.0), 1080
    pixels_per_unit = height / (2.0 * distance * math.tan(0.5 * fov_y))
    # an error halfway between two distinct LOD errors: the LOD is the last one at or below it
    i = int(np.searchsorted(errs, errs[-1] / 4))
    j = int(np.searchsorted(errs, errs[i], side="right"))
    target = 0.5 * (errs[i] + errs[j])
    expected = int(np.searchsorted(errs, target, side="right")) - 1
    k = pm.lod_for_screen_error(target * pixels_per_unit, distance, fov_y, height)
    assert k == expected == pm.lod_for_error(target) and 0 < k < pm.lod_count - 1
    # farther away, the same pixels allow a coarser LOD; a fraction of a pixel up close, no error
    assert pm.lod_for_screen_error(target * pixels_per_unit, 10 * distance, fov_y, height) > k
    assert pm.lod_for_screen_error(1e-9, distance, fov_y, height) == pm.lod_for_error(1e-9 / pixels_per_unit)
    assert pm.lod_errors[pm.lod_for_screen_error(1e-9, distance, fov_y, height)] <= 1e-9
    if encoding == "sliding-window":  # the window record the sliding window's own helper gives
        rec = pm.record_for_screen_error(target * pixels_per_unit, distance, fov_y, height)
        assert np.array_equal(rec, pm.window_records[k])


def test_the_command_list_shows_each_command_whole():
    """click cut each summary at 45 characters (``build  Build INPUT (.obj .ply .stl .off .glb .gltf
    .usd*) and...``), and ``inspect --help`` showed the docstring's reST quotes."""
    result = CliRunner().invoke(main, ["--help"])
    assert result.exit_code == 0
    commands = result.output.split("Commands:")[1].split("Encodings")[0]
    assert "..." not in commands, commands
    for name in ("build", "conformance", "encode", "inspect", "run", "validate"):
        assert f"  {name} " in commands
    result = CliRunner().invoke(main, ["inspect", "--help"])
    assert result.exit_code == 0 and "``" not in result.output, result.output


def test_a_run_says_it_is_building_before_its_first_asset(tmp_path, capsys):
    """A first run on a new machine printed nothing for minutes (numba compiling in the fork server) before
    its first progress line: users took it for a hang."""
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text('version: 1\nassets: [{glob: "meshes/*.obj"}]\noutput: {dir: out, report: false}\n')
    capsys.readouterr()
    res = run(cfg, echo=lambda m: None)
    assert res.built == 1
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("[0/1] building 1 asset; on a new machine numba compiles"), lines
    assert any(line.startswith("[1/1] meshes/a.obj: built") for line in lines), lines
    # nothing to build: no such line
    run(cfg, echo=lambda m: None)
    assert "building" not in capsys.readouterr().err


def test_conformance_without_vectors_says_where_they_are(tmp_path, monkeypatch):
    """Installed from a wheel, run outside the repository: it said ``spec/vectors has no manifest.json``."""
    import swpm_usd.format.cli as format_cli

    monkeypatch.setattr(format_cli, "_REPO_VECTORS", tmp_path / "none")
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["conformance"])
    assert result.exit_code == 2 and "no spec/vectors here" in result.stderr, result.output
    assert "python -m swpm_usd.format.vectors VECTOR_DIR" in result.stderr
    # the command it names writes vectors the command then passes
    from swpm_usd.format.vectors import write_all

    write_all(str(tmp_path / "v"))
    assert CliRunner().invoke(main, ["conformance", str(tmp_path / "v")]).exit_code == 0


@pytest.mark.parametrize("command", ["build", "encode"])
def test_ctrl_c_in_a_compiled_kernel_exits_130_with_one_line(tmp_path, monkeypatch, request, command):
    """Ctrl-C while a build ran in a numba kernel printed numba's ``SystemError: CPUDispatcher(<function
    absorb_middle ...>) returned a result with an exception set`` traceback and exited 1 (found with
    ``swpm-pipeline build nefertiti.obj -e sliding-window`` and Ctrl-C after 12 s)."""
    import signal
    import sys

    # (the CLI leaves SIGINT ignored as it exits: pytest's own handler is back after, whatever the outcome)
    original = signal.getsignal(signal.SIGINT)
    request.addfinalizer(lambda: signal.signal(signal.SIGINT, original))
    build_module = sys.modules["swpm_usd.build"]  # (swpm_usd.build is also the function)

    def interrupted_in_a_kernel(*args, **kwargs):
        try:
            signal.raise_signal(signal.SIGINT)  # the handler raises KeyboardInterrupt, as in compiled code
        except KeyboardInterrupt:
            pass  # which numba's dispatcher turns into this:
        raise SystemError("CPUDispatcher(<function absorb_middle>) returned a result with an exception set")

    monkeypatch.setattr(build_module, "build", interrupted_in_a_kernel)
    obj = tmp_path / "a.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    args = [command, str(obj)] + (["-o", str(tmp_path / "a.swpm")] if command == "encode" else [])
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 130 and result.stderr == "swpm-pipeline: interrupted\n", result.output
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN  # (the exiting process ignores another)
    # a SystemError of its own, with no Ctrl-C, is no interruption
    monkeypatch.setattr(build_module, "build", lambda *a, **k: (_ for _ in ()).throw(SystemError("own")))
    signal.signal(signal.SIGINT, signal.default_int_handler)
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1 and isinstance(result.exception, SystemError)
