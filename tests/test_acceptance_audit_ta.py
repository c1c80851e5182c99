"""Defects found by a technical artist's acceptance audit of 0.9.0 (helper-196): each test failed before its fix.

The run's progress line cutting a failure's cause without saying so, and inspect's hint for a USD stage
(one the pipeline wrote, its SwpmMeshAPI prims encoded) leading with a rebuild.
"""

from __future__ import annotations

from click.testing import CliRunner

from swpm_usd.cli import main
from swpm_usd.pipeline.progress import _Progress


def _failed(error: str) -> dict:
    return {"id": "meshes/cow.obj", "status": "failed", "code": "INPUT_MALFORMED", "error": error, "seconds": 0.0}


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
