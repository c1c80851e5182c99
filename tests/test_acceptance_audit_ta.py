"""Defects found by a technical artist's acceptance audit of 0.9.0 (helper-196); each test failed before
its fix.

The run's progress line cutting a failure's cause without saying so, inspect's hint for a USD stage (one the
pipeline wrote, its SwpmMeshAPI prims encoded) leading with a rebuild, and a loader's warning printed with
the package's source file and code line.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

import swpm_usd
from swpm_usd.cli import main
from swpm_usd.pipeline.progress import _Progress


def _failed(error: str) -> dict:
    return {
        "id": "meshes/cow.obj",
        "status": "failed",
        "code": "INPUT_MALFORMED",
        "error": error,
        "seconds": 0.0,
    }


def test_a_progress_line_says_where_it_cut_a_long_cause(capsys):
    # a cause over 100 characters was cut there, mid-sentence: "refers to vertex 99999, the file" read as
    # a whole (wrong) cause; it now ends "..." (the summary after the run prints it whole)
    error = (
        "MeshLoadError: not a valid OBJ file: line 8725: face corner '99999' refers to vertex 99999, "
        "the file has 2903"
    )
    assert len(error) > 100
    progress = _Progress(2)
    progress.advance(_failed(error))
    progress.advance(_failed("MeshLoadError: no triangles: the file is empty (0 bytes)"))
    lines = capsys.readouterr().err.splitlines()
    long_line = next(ln for ln in lines if ln.startswith("[1/2]"))
    cause = long_line.split("FAILED [INPUT_MALFORMED] (", 1)[1].rsplit(") (", 1)[0]
    assert cause.endswith("...") and len(cause) == 100 and error.startswith(cause[:-3])
    short_line = next(ln for ln in lines if ln.startswith("[2/2]"))
    assert "(MeshLoadError: no triangles: the file is empty (0 bytes)) (" in short_line  # not cut: no "..."


def test_inspect_of_a_runs_usd_layer_points_to_validate_and_load_first(tmp_path):
    # a run's asset layer (bob.usdc, SwpmMeshAPI on its Mesh) given to inspect was "a mesh file (.usdc)",
    # with "encode bob.usdc -o bob.swpm writes one" first: a rebuild of its LOD 0, where swpm_usd.load and
    # swpm_usd.save turn the encoded prim into the .swpm file as it is
    from swpm_usd import usd

    mesh = tmp_path / "g.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.2\nf 1 2 3\nf 2 4 3\n")
    stage = tmp_path / "g.usdc"
    usd.write(swpm_usd.build(str(mesh), encoding="vanilla"), stage)
    result = CliRunner().invoke(main, ["inspect", str(stage)])
    assert result.exit_code == 1
    hint = result.stderr.strip().splitlines()[-1]
    assert hint.startswith(f"hint: {stage} is a USD stage (.usdc), not an SWPM file: swpm-pipeline validate")
    assert hint.index("swpm_usd.load") < hint.index("swpm-pipeline encode")
    assert "a stage of plain meshes: swpm-pipeline encode" in hint
    # and what the hint says to run does what it says
    assert CliRunner().invoke(main, ["validate", str(stage)]).exit_code == 0
    swpm_usd.save(swpm_usd.load(stage), tmp_path / "g.swpm")
    assert CliRunner().invoke(main, ["inspect", str(tmp_path / "g.swpm")]).exit_code == 0


_TWO_OBJECTS = (  # an OBJ of two objects, normals on the first alone: the loader drops them with a warning
    "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n"
    "o b\nv 2 0 0\nv 3 0 0\nv 2 1 0\nv 3 1 0\nf 4 5 6\nf 5 7 6\n"
)


def _command(*args: str, cwd) -> subprocess.CompletedProcess:
    # (a process of its own: pytest records warnings itself, so the command's format shows only outside it)
    env = {**os.environ, "PYTHONPATH": str(Path(swpm_usd.__file__).parents[1])}
    return subprocess.run(
        [sys.executable, "-m", "swpm_usd.cli", *args], cwd=cwd, env=env, capture_output=True, text=True
    )


@pytest.mark.parametrize("jobs", [None, "2"])
def test_a_loaders_warning_is_one_line_naming_the_file(tmp_path, jobs):
    # Python's format printed our source file and line ("/.../swpm_usd/build.py:77: UserWarning: ...") and
    # our code line after it ("  mesh = load_mesh(mesh_or_path)"); build and a run's workers (--jobs 2) now
    # print "warning: <message>", the message naming the file, as the run's own warnings are printed
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "two.obj").write_text(_TWO_OBJECTS)
    if jobs is None:
        result = _command("build", "meshes/two.obj", "--rows", "1", cwd=tmp_path)
    else:
        config = "version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out, report: false}\n"
        (tmp_path / "p.yaml").write_text(config + "defaults: {encoding: vanilla}\n")
        result = _command("run", "p.yaml", "--jobs", jobs, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    lines = [ln for ln in result.stderr.splitlines() if "normal values" in ln]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("warning: ") and "two.obj: its faces refer to normal values" in lines[0]
    assert "UserWarning" not in result.stderr and "swpm_usd" not in result.stderr, result.stderr


def test_a_program_keeps_pythons_format_for_the_packages_warnings(tmp_path):
    # the one-line format is the command's: a program importing the package is not changed
    import warnings

    mesh = tmp_path / "two.obj"
    mesh.write_text(_TWO_OBJECTS)
    before = warnings.formatwarning
    with pytest.warns(UserWarning, match="normal values"):
        swpm_usd.build(str(mesh), encoding="vanilla")
    assert warnings.formatwarning is before


def test_a_slow_build_says_it_is_still_building(capsys):
    # a first build on a cold numba cache printed nothing for 83 s (cow, sliding window), then "built in
    # 81.48 s": the timer prints one line once the block has run its time, and nothing after the block ends
    from swpm_usd.slow_notice import MESSAGE, notice_if_slow

    with notice_if_slow(0.0) as timer:
        timer.join()  # (the block outlasts the delay: the line is printed)
    assert capsys.readouterr().err == MESSAGE + "\n"
    with notice_if_slow(3600.0) as timer:
        pass
    timer.join()  # (cancelled as the block ended: it ends without printing)
    assert capsys.readouterr().err == ""
    assert "compiles numba's kernels" in MESSAGE


@pytest.mark.parametrize("command", ["build", "encode"])
def test_build_and_encode_run_their_build_under_the_notice(tmp_path, monkeypatch, command):
    import contextlib

    import swpm_usd.slow_notice as slow_notice

    entered = []

    @contextlib.contextmanager
    def recorded(*args, **kwargs):
        entered.append(command)
        yield None

    monkeypatch.setattr(slow_notice, "notice_if_slow", recorded)
    mesh = tmp_path / "two.obj"
    mesh.write_text(_TWO_OBJECTS)
    args = [command, str(mesh)] + (["-o", str(tmp_path / "two.swpm")] if command == "encode" else [])
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert entered == [command]


def test_encode_to_a_usd_name_says_where_a_usd_layer_comes_from(tmp_path):
    mesh = tmp_path / "two.obj"
    mesh.write_text(_TWO_OBJECTS)
    result = CliRunner().invoke(main, ["encode", str(mesh), "-o", str(tmp_path / "two.usdc")])
    assert result.exit_code == 2
    assert "the output must be a .swpm file (a USD layer: swpm_usd.usd.write" in result.stderr


@pytest.mark.parametrize(
    ("param", "hint"),
    [
        ("cluster=True", "write cluster=true"),  # (the README's own spelling, cluster=True, in its prose)
        ("mu=.2", "write mu=0.2"),
        ("order_passes=None", "write order_passes=null"),
        ("mu=abc", "true, false, null, a number (0.2) or text"),
    ],
)
def test_a_param_python_spells_says_how_json_spells_it(tmp_path, param, hint):
    # "-p cluster=True" was "cluster: 'True' is not of type 'boolean'", no word of -p reading JSON
    result = CliRunner().invoke(
        main, ["build", str(tmp_path / "none.obj"), "-e", "sliding-window", "-p", param]
    )
    assert result.exit_code == 2
    assert f"(-p reads its value as JSON: {hint})" in result.stderr, result.stderr


def test_a_param_json_spells_builds_unchanged(tmp_path):
    mesh = tmp_path / "two.obj"
    mesh.write_text(_TWO_OBJECTS)
    result = CliRunner().invoke(main, ["build", str(mesh), "-e", "sliding-window", "-p", "cluster=true"])
    assert result.exit_code == 0 and "reads its value as JSON" not in result.stderr


def test_loading_a_stage_of_several_encoded_prims_names_the_call_that_picks_one(tmp_path):
    # swpm_usd.load of a shot referencing an asset twice said "pass prim= to pick one"; load takes no prim=
    # (TypeError): the message names swpm_usd.usd.read_file, which does
    from pxr import Usd

    from swpm_usd import usd
    from swpm_usd.usd.reader import UsdReadError

    mesh = tmp_path / "two.obj"
    mesh.write_text(_TWO_OBJECTS)
    usd.write(swpm_usd.build(str(mesh), encoding="vanilla"), tmp_path / "asset.usdc")
    shot = Usd.Stage.CreateNew(str(tmp_path / "shot.usda"))
    for i in range(2):
        shot.DefinePrim(f"/World/copy_{i}", "Xform").GetReferences().AddReference("./asset.usdc")
    shot.GetRootLayer().Save()
    path = str(tmp_path / "shot.usda")
    with pytest.raises(UsdReadError, match=r"swpm_usd\.usd\.read_file\(.*, prim=\.\.\.\) reads one") as err:
        swpm_usd.load(path)
    assert "/World/copy_0" in str(err.value)
    assert usd.read_file(path, prim="/World/copy_1").lod_count > 0  # (what the message says works)


def test_a_run_with_nothing_finished_for_a_while_says_it_is_still_working(capsys):
    # a fresh install's first run printed "[0/2] building 2 assets ..." and then nothing for 135 s while
    # numba compiled (helper-238, session 56): it now says once that it is still working
    import time

    progress = _Progress(2, still_working_s=0.05)
    timer = progress.timer
    assert timer is not None
    # (the timer's thread ended, its line printed: a fixed sleep lost the race to a thread not yet run on a
    # loaded machine, two xdist workers beside the CI's other jobs)
    timer.join(timeout=60)
    assert not timer.is_alive()
    progress.advance(_failed("MeshLoadError: no triangles: the file is empty (0 bytes)"))
    progress.close()
    lines = capsys.readouterr().err.splitlines()
    still = [ln for ln in lines if "still working" in ln]
    assert len(still) == 1 and still[0].startswith("[0/2] still working after 0 s, no asset finished")
    assert lines.index(still[0]) < next(i for i, ln in enumerate(lines) if ln.startswith("[1/2]"))
    # an asset done first: no such line, even once the time has passed. (5 s: an advance 0.2 s after the
    # start on a loaded machine was late, and the line it then printed was right; the cancelled timer's
    # thread ends at once, one not cancelled prints at 5 s and then ends: joined, either is seen)
    progress = _Progress(2, still_working_s=5.0)
    timer = progress.timer
    assert timer is not None
    start = time.monotonic()
    progress.advance(_failed("MeshLoadError: no triangles: the file is empty (0 bytes)"))
    advanced = time.monotonic() - start
    timer.join(timeout=60)
    assert not timer.is_alive()
    progress.close()
    assert "still working" not in capsys.readouterr().err
    assert advanced < 5.0, advanced  # (the case tested: the asset done before the time)
