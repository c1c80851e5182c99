"""An output that is a link: ``encode -o`` and ``run`` write a temporary file and rename it into place, so
the link is replaced by the file and its target left as it was (as ``sed -i`` does)."""

from __future__ import annotations

from click.testing import CliRunner

import swpm_usd
from swpm_usd.cli import main
from swpm_usd.pipeline import run


def test_an_output_that_is_a_link_is_replaced_by_encode_as_by_run(tmp_path):
    """``encode -o link.swpm`` renames its file over the link (atomic), as ``run`` does with its outputs and
    ``sed -i`` with a file: the link's target is left as it was. ``encode --help`` says so."""
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    (tmp_path / "elsewhere").mkdir()
    target = tmp_path / "elsewhere" / "target.swpm"
    target.write_bytes(b"kept")
    target.chmod(0o640)
    link = tmp_path / "enc.swpm"
    link.symlink_to(target)
    result = CliRunner().invoke(main, ["encode", str(tmp_path / "meshes" / "a.obj"), "-o", str(link)])
    assert result.exit_code == 0, result.output
    assert not link.is_symlink() and link.read_bytes()[:4] != b"kept"
    assert target.read_bytes() == b"kept"
    assert (link.stat().st_mode & 0o777) == 0o640  # (the mode of the file the link led to, as a file's own)
    swpm_usd.validate(link)
    # run: the same for an asset's output that is a link before the build
    (tmp_path / "out").mkdir()
    out_link = tmp_path / "out" / "a.swpm"
    out_link.symlink_to(target)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text('version: 1\nassets: [{glob: "meshes/*.obj"}]\noutput: {dir: out, report: false}\n')
    run(cfg, echo=lambda m: None)
    assert not out_link.is_symlink() and target.read_bytes() == b"kept"
    help_text = " ".join(CliRunner().invoke(main, ["encode", "--help"]).output.split())
    assert "A link there is replaced by the file, its target left as it was" in help_text
