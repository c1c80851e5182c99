"""The pipeline under what an asset farm meets: a full disk, a runner killed with SIGKILL, files it cannot
name, counts it cannot read."""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path

from click.testing import CliRunner

from swpm_usd.cli import main
from swpm_usd.pipeline import run


def _grid_obj(n: int, note: str = "") -> str:
    """An OBJ of an n x n grid of quads split in two triangles (2 n^2 triangles): small, fast to build."""
    lines = [f"v {x} {y} {(x * y) % 3 * 0.1}" for y in range(n + 1) for x in range(n + 1)]
    for y in range(n):
        for x in range(n):
            a = y * (n + 1) + x + 1
            lines += [f"f {a} {a + 1} {a + n + 2}", f"f {a} {a + n + 2} {a + n + 1}"]
    return "\n".join(lines) + f"\n# {note}\n"


def _project(tmp_path: Path, names=("a", "b"), extra: str = "") -> Path:
    (tmp_path / "meshes").mkdir()
    for name in names:
        (tmp_path / "meshes" / f"{name}.obj").write_text(_grid_obj(8, name))
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out, report: false}\n"
        f"defaults: {{encoding: vanilla}}\n{extra}"
    )
    return cfg


def _files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.name != ".swpm-pipeline.lock"}


def test_a_full_disk_mid_run_names_the_files_and_loses_nothing(tmp_path, monkeypatch):
    # a disk full as an asset is written and then as the manifest is: the error said "[Errno 28] No space
    # left on device" alone (a write's or fsync's OSError names no file), in the asset's failure and in the
    # run's one-line error. Now both name the file; the manifest and the outputs on disk stay as they were
    # (each written whole or not at all), no temporary file is left, and the next run resumes
    cfg = _project(tmp_path)
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    before = _files(out)
    (tmp_path / "meshes" / "b.obj").write_text(_grid_obj(9, "b edited"))  # b to rebuild

    real_fsync = os.fsync

    def full_for(prefix: str):
        def fsync(fd):  # (as a file server reports a full disk: at the flush that sync forces)
            if os.path.basename(os.readlink(f"/proc/self/fd/{fd}")).startswith(prefix):
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            return real_fsync(fd)

        return fsync

    with monkeypatch.context() as m:
        m.setattr(os, "fsync", full_for(".b.swpm."))  # the asset's output alone
        res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and res.failures["meshes/b.obj"]["kept_previous"], res.failures
    assert res.failures["meshes/b.obj"]["error"] == (
        f"OSError: [Errno {errno.ENOSPC}] No space left on device: '{out / 'b.swpm'}'"
    )
    kept = _files(out)
    assert {k: v for k, v in kept.items() if k != "manifest.json"} == {
        k: v for k, v in before.items() if k != "manifest.json"
    }  # (no temporary file, the previous build whole)
    (tmp_path / "meshes" / "b.obj").write_text(_grid_obj(10, "b edited again"))  # (a new failure to record)
    with monkeypatch.context() as m:
        m.setattr(os, "fsync", full_for(""))  # the manifest too
        r = CliRunner().invoke(main, ["run", str(cfg)])
    assert r.exit_code == 1 and not isinstance(r.exception, OSError), (r.exception, r.output)
    assert r.stderr == f"error: {out / 'manifest.json'}: No space left on device\n", r.stderr
    assert "Traceback" not in r.stderr
    assert _files(out) == kept  # (the manifest as it was, which the files on disk still are)
    res = run(cfg, echo=lambda m: None)  # space again: the run resumes
    assert (res.built, res.skipped, res.failed) == (1, 1, 0)
    manifest = json.loads((out / "manifest.json").read_text())
    assert {k: r["status"] for k, r in manifest["assets"].items()} == {
        "meshes/a.obj": "built",
        "meshes/b.obj": "built",
    }
    assert (out / "a.swpm").read_bytes() == before["a.swpm"] and (out / "b.swpm").read_bytes() != before[
        "b.swpm"
    ]
