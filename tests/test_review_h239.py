"""helper-239's review of the day's merges (helper-236's edge kernel, helper-238's first-hour fixes, the run's
"still working" line): each test here failed before its fix."""

from __future__ import annotations

import io
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from swpm_usd.cli import main
from swpm_usd.pipeline.config import ConfigError, load_config
from swpm_usd.pipeline.progress import _Progress

CONFIG = "version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out}\n"


@pytest.mark.parametrize(
    "name, text",
    [
        ("assets.usda", CONFIG),
        ("lods.obj", CONFIG),
        ("farm.gltf", '{"version": 1, "assets": [{"glob": "meshes/*.obj"}], "output": {"dir": "out"}}\n'),
        ("commented.ply", "# the farm's config\n\n---\n" + CONFIG),
    ],
)
def test_a_config_named_like_a_mesh_is_read_as_a_config(tmp_path, name, text):
    """The mesh-file check of ``run`` went by the suffix alone: a valid config named ``assets.usda`` was
    refused, "is a mesh file (.usda), not a pipeline config" (exit 2). Its first line of content decides."""
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    cfg = tmp_path / name
    cfg.write_text(text)
    assert [a["glob"] for a in load_config(cfg).data["assets"]] == ["meshes/*.obj"]
    result = CliRunner().invoke(main, ["run", str(cfg), "--dry-run"])
    assert result.exit_code == 0, result.output
    assert "1 to build" in result.stderr + result.stdout


@pytest.mark.parametrize(
    "name, data",
    [
        ("spot.obj", b"# exported\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
        ("cube.ply", b"ply\nformat ascii 1.0\nelement vertex 3\n"),
        ("stage.usda", b'#usda 1.0\n(\n    upAxis = "Y"\n)\ndef Mesh "m" {}\n'),
        ("scene.gltf", b'{"asset": {"version": "2.0"}, "meshes": []}'),
        ("model.usdc", b"PXR-USDC\x00\x00version: 1\n"),  # (binary: a NUL byte, whatever follows)
        ("empty.obj", b""),
    ],
)
def test_a_mesh_given_as_the_config_is_still_called_a_mesh(tmp_path, name, data):
    mesh = tmp_path / name
    mesh.write_bytes(data)
    with pytest.raises(ConfigError) as err:
        load_config(mesh)
    assert f"is a mesh file ({mesh.suffix}), not a pipeline config" in str(err.value)


class _Terminal(io.StringIO):
    """stderr on a terminal (what makes the run show a rich bar)."""

    def isatty(self) -> bool:
        return True


def test_the_bar_and_its_still_working_line_stay_off_stdout(monkeypatch):
    """``swpm-pipeline run cfg --json > report.json`` from a terminal: the bar (rich's own console, stdout)
    and the "still working" line printed through it went into the JSON, which no longer parsed."""
    out, err = io.StringIO(), _Terminal()
    monkeypatch.setattr(sys, "stdout", out)
    monkeypatch.setattr(sys, "stderr", err)
    progress = _Progress(1, still_working_s=0.01)
    timer = progress.timer
    assert timer is not None
    print("stdout's own line, as the bar runs")
    timer.join(timeout=60)  # (its line printed: the thread's end, however late a loaded machine runs it)
    assert not timer.is_alive()
    progress.advance({"id": "a.obj", "status": "built", "seconds": 0.1})
    progress.close()
    assert out.getvalue() == "stdout's own line, as the bar runs\n"
    said = err.getvalue()
    assert "[0/1] still working after 0 s" in said and "a.obj: built" in said


def test_no_still_working_line_once_an_asset_is_done(monkeypatch):
    """The timer's thread, woken as the first asset finished (or the run closed), printed "no asset
    finished yet" after that asset's line: its check and the cancelling are now one at a time."""
    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    progress = _Progress(2, still_working_s=3600)
    timer = progress.timer
    progress.advance({"id": "a.obj", "status": "built", "seconds": 0.1})
    timer.function(*timer.args)  # (the thread, past its wait before the cancel, calls it now)
    progress.close()
    timer.function(*timer.args)
    assert "still working" not in err.getvalue()


def test_an_unwritable_output_dir_without_statvfs_is_still_named(tmp_path, monkeypatch):
    """The read-only check called ``os.statvfs``, which Windows' os has not (nor ``ST_RDONLY``): an
    unwritable output.dir there was an AttributeError out of the run, not its "permission denied"."""
    import os

    (tmp_path / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    out = tmp_path / "out"
    out.mkdir()
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text("version: 1\nassets: [{glob: '*.obj'}]\noutput: {dir: out}\n")
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: Path(p) != out and real_access(p, mode, **kw))
    monkeypatch.delattr(os, "statvfs")
    monkeypatch.delattr(os, "ST_RDONLY")
    result = CliRunner().invoke(main, ["run", str(cfg)])
    assert result.exit_code == 2, result.output
    assert result.stderr.strip() == f"{cfg}:3:15: $.output.dir: cannot write in {out}: permission denied"


def test_save_with_its_arguments_swapped_says_so(tmp_path):
    """``save("spot.swpm", pm)`` was pathlib's "expected str, bytes or os.PathLike object, not
    VanillaProgressiveMesh"; the lead's check of ``pm`` would have called the path "a path: swpm_usd.build
    (path, ...) builds the mesh file there"."""
    import swpm_usd

    mesh = tmp_path / "a.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    pm = swpm_usd.build(mesh)
    out = tmp_path / "a.swpm"
    with pytest.raises(TypeError, match=r"save\(pm, path\): the progressive mesh first, then the path"):
        swpm_usd.save(str(out), pm)
    assert not out.exists()
    with pytest.raises(TypeError, match="a path: swpm_usd.build"):  # (a path alone: as before)
        swpm_usd.save(str(out), str(tmp_path / "b.swpm"))
    assert swpm_usd.save(pm, out) == out and swpm_usd.load(out).lod_count == pm.lod_count


def test_a_run_stopped_by_ctrl_c_says_nothing_of_still_working(tmp_path, monkeypatch, capsys):
    # the timer's line came after a Ctrl-C whose stop outlasted the time left to it (helper-239's find):
    # the timer is stopped before the run stops
    from functools import partial

    from swpm_usd.pipeline import run, runner

    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
        yield  # (a generator, as execute is)

    stop = runner._Run.stop
    # the timer's time ends during the stop: 1 s after the progress starts (the Ctrl-C comes at once, but a
    # loaded machine may pause the run a while: 0.2 s was within reach), the stop held till 0.5 s past it
    started, timers = [], []

    def progress(*args, **kwargs):
        made = partial(_Progress, still_working_s=1.0)(*args, **kwargs)
        started.append(time.monotonic())
        timers.append(made.timer)
        return made

    def slow_stop(self):
        interrupted_at.append(time.monotonic())
        time.sleep(max(0.0, started[0] + 1.5 - time.monotonic()))
        stop(self)

    interrupted_at: list[float] = []
    monkeypatch.setattr(runner, "execute", interrupted)
    monkeypatch.setattr(runner._Run, "stop", slow_stop)
    monkeypatch.setattr(runner, "_Progress", progress)
    with pytest.raises(KeyboardInterrupt):
        run(cfg, echo=lambda m: None)
    timers[0].join(timeout=60)  # (a line it was to print is printed by its thread's end)
    assert not timers[0].is_alive()
    assert "still working" not in capsys.readouterr().err
    assert interrupted_at[0] - started[0] < 1.0  # (the case tested: stopped before the time)
