"""helper-239's review of the day's merges (helper-236's edge kernel, helper-238's first-hour fixes, the run's
"still working" line): each test here failed before its fix."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from swpm_usd.cli import main
from swpm_usd.pipeline.config import ConfigError, load_config

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
