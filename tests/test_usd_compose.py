"""USD composition as a pipeline TD uses it: LOD layers, override layers over animated meshes, crowds of
instances, pipeline outputs of USD inputs, and errors located in the layer that broke the buffers."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import swpm_usd
from swpm_usd import usd

MESHES = Path(__file__).resolve().parents[2] / "shared" / "meshes"
if not MESHES.exists():
    MESHES = Path("/work/shared/meshes")


@pytest.fixture(scope="module")
def spot_pm():
    return swpm_usd.build(swpm_usd.load_mesh(MESHES / "spot.obj"), "vanilla")


def _fresh(code: str) -> str:
    """Run ``code`` in a fresh interpreter (no layer of this process's registry in memory); its stdout."""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout


# -- UsdLod layer ------------------------------------------------------------------------------------------
def test_usdlod_items_each_draw_their_own_lod(spot_pm, tmp_path):
    """Each LOD item draws its discrete LOD, in a fresh process and when the LOD layer is referenced many
    times (opinions under an instanceable prim are ignored: the selection must reach the prototype)."""
    asset = usd.write(spot_pm, tmp_path / "spot.usda", lods=4)
    layer = usd.write_usdlod(asset, tmp_path / "spot_lod.usda")
    expected = [3 * spot_pm.triangle_count_at(int(k)) for k in usd.select_lods(spot_pm, 4)]
    code = f"""
from pxr import Usd, UsdGeom
from swpm_usd import usd
def counts(stage, root):
    meshes = [UsdGeom.Mesh(stage.GetPrimAtPath(f"{{root}}/lod/LOD{{i}}/mesh")) for i in range(4)]
    return [len(m.GetFaceVertexIndicesAttr().Get()) for m in meshes]
stage = Usd.Stage.Open({str(layer)!r})
print(counts(stage, "/SpotLOD"))
scene = Usd.Stage.CreateInMemory()
for j in range(3):
    scene.DefinePrim(f"/W/a{{j}}").GetReferences().AddReference({str(layer)!r})
print(counts(scene, "/W/a0"), counts(scene, "/W/a2"), len(scene.GetPrototypes()))
print(sorted(str(p.GetPath()) for p in usd.find_encoded(stage)))
"""
    lines = _fresh(code).splitlines()
    assert lines[0] == str(expected)
    assert lines[1] == f"{expected} {expected} 4"  # three references share the four LOD prototypes
    assert lines[2] == str([f"/SpotLOD/lod/LOD{i}/mesh" for i in range(4)])
    assert usd.validate_stage(layer) == []
