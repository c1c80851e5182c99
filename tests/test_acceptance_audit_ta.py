"""Defects found by a technical artist's acceptance audit of 0.9.0 (helper-196); each test failed before
its fix.

The run's progress line cutting a failure's cause without saying so, and inspect's hint for a USD stage
(one the pipeline wrote, its SwpmMeshAPI prims encoded) leading with a rebuild.
"""

from __future__ import annotations

from click.testing import CliRunner

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
    import swpm_usd
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
