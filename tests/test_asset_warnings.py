"""A loader's warning about an asset is kept: in its manifest record, the run's warnings (``--json``) and the
report, not only on the worker's stderr (helper-196's audit: "attributes ['color'] are missing on some of its
2 meshes; dropped" was printed and lost). :func:`swpm_usd.pipeline.worker.process_asset`."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from swpm_usd.pipeline import run
from swpm_usd.pipeline.records import record_problem
from swpm_usd.pipeline.worker import MAX_RECORD_WARNINGS, _warning_lines

SHARED_MESHES = Path(__file__).resolve().parents[2] / "shared" / "meshes"


def _two_meshes_one_coloured(path: Path) -> None:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    for i, name in enumerate(("a", "b")):
        mesh = UsdGeom.Mesh.Define(stage, f"/World/{name}")
        x = 3.0 * i
        pts = [(x, 0, 0), (x + 1, 0, 0), (x + 1, 1, 0), (x, 1, 0), (x + 0.5, 0.5, 0.5)]
        mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in pts]))
        mesh.CreateFaceVertexCountsAttr([3, 3, 3, 3])
        mesh.CreateFaceVertexIndicesAttr([0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4])
        if i == 0:  # (one mesh coloured: the colour is dropped, with a warning)
            pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
                "displayColor", Sdf.ValueTypeNames.Color3fArray, "vertex"
            )
            pv.Set(Vt.Vec3fArray([Gf.Vec3f(1, 0, 0)] * 5))
    stage.GetRootLayer().Save()


CONFIG = """\
version: 1
assets:
  - glob: "meshes/*"
output:
  dir: out
  report: true
defaults:
  encoding: vanilla
"""


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_loaders_warning_is_kept_in_the_record_the_run_and_the_report(tmp_path, jobs):
    (tmp_path / "meshes").mkdir()
    _two_meshes_one_coloured(tmp_path / "meshes" / "pair.usda")
    shutil.copy(SHARED_MESHES / "suzanne.obj", tmp_path / "meshes" / "suzanne.obj")
    (tmp_path / "pipeline.yaml").write_text(CONFIG)
    res = run(tmp_path / "pipeline.yaml", jobs=jobs, echo=lambda m: None)
    assert res.built == 2 and res.failed == 0
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    pair, suzanne = manifest["assets"]["meshes/pair.usda"], manifest["assets"]["meshes/suzanne.obj"]
    assert len(pair["warnings"]) == 1 and "missing on some of its 2 meshes" in pair["warnings"][0]
    # (the message names the file as the config does, not by the absolute path the worker loaded)
    assert pair["warnings"][0].startswith("meshes/pair.usda: attributes ['color']"), pair["warnings"]
    assert str(tmp_path) not in pair["warnings"][0]
    assert "warnings" not in suzanne
    assert record_problem(pair) is None
    assert pair["warnings"][0] in res.warnings
    report = (tmp_path / "out" / "report.html").read_text()
    assert "missing on some of its 2 meshes" in report
    # a rerun builds nothing and keeps the record (and its warning) as it was
    again = run(tmp_path / "pipeline.yaml", jobs=jobs, echo=lambda m: None)
    assert again.built == 0
    kept = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]["meshes/pair.usda"]
    assert kept["warnings"] == pair["warnings"]


def test_a_record_keeps_distinct_user_warnings_and_counts_the_rest():
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for i in range(MAX_RECORD_WARNINGS + 5):
            warnings.warn(f"prim {i}: not drawn", UserWarning, stacklevel=1)
        warnings.warn("prim 0: not drawn", UserWarning, stacklevel=1)  # (a repeat)
        warnings.warn("old API", DeprecationWarning, stacklevel=1)  # (a library's: not the asset's)
    lines = _warning_lines(caught)
    assert len(lines) == MAX_RECORD_WARNINGS
    assert lines[0] == "prim 0: not drawn" and lines[-2] == f"prim {MAX_RECORD_WARNINGS - 2}: not drawn"
    assert lines[-1] == "... and 6 more warnings"
    assert all("old API" not in line for line in lines)


def test_a_record_with_warnings_of_another_type_is_not_a_record_the_run_writes():
    assert "warnings" in record_problem({"status": "failed", "warnings": "one"})
    assert "warnings" in record_problem({"status": "failed", "warnings": [1]})
    assert record_problem({"status": "failed", "warnings": ["a"]}) is None
