"""helper-249's review of h245-h247's merges: each test fails before its fix."""

from __future__ import annotations

from pathlib import Path

from swpm_usd.pipeline import run

TWO_TRIANGLES_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"


def _quiet(message: str) -> None:
    pass


def test_a_long_output_name_is_no_error_where_the_run_writes_no_outputs(tmp_path: Path):
    # output.swpm and output.usd off (a run for its manifest's figures alone): nothing is named after the
    # asset, and a long name built (2 built, exit 0) before LONGEST_STEM's check made it a config error
    from swpm_usd.pipeline.assets import LONGEST_STEM

    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / f"{'é' * (LONGEST_STEM // 2 + 1)}.obj").write_text(TWO_TRIANGLES_OBJ)
    (tmp_path / "lib" / "ok.obj").write_text(TWO_TRIANGLES_OBJ)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        'version: 1\nassets:\n  - glob: "lib/*.obj"\n'
        "output: {dir: out, swpm: false, usd: false, scene: false, report: false}\n"
        "defaults: {encoding: vanilla}\n"
    )
    assert run(cfg, echo=_quiet).built == 2
