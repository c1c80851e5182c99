"""``output.names``: outputs named by the file's stem (the default) or by its path under its glob's fixed
folder (``path``), for a library whose files share a name (every glTF download is ``scene.gltf``)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from conftest import SHARED_MESHES

from swpm_usd.pipeline import ConfigError, load_config, run
from swpm_usd.pipeline.assets import PATH_NAME_SEPARATOR, _glob_root, path_name

CONFIG = """\
version: 1
assets:
  - glob: "library/**/*.obj"
output:
  dir: out
  usd: true
  scene: true
defaults: {encoding: vanilla}
"""


def _library(tmp_path: Path, config: str = CONFIG) -> Path:
    """Two ``scene.obj`` in different folders of ``library`` (suzanne and beetle) and the config."""
    for folder, mesh in (("props/chair", "suzanne.obj"), ("props/table", "beetle.obj")):
        (tmp_path / "library" / folder).mkdir(parents=True)
        shutil.copy(SHARED_MESHES / mesh, tmp_path / "library" / folder / "scene.obj")
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(config)
    return cfg


def _quiet(message: str) -> None:
    pass


def _scene_references(out: Path) -> dict[str, str]:
    """The scene's prims -> the layer each references."""
    from pxr import Sdf

    layer = Sdf.Layer.FindOrOpen(str(out / "scene.usda"))
    refs = {}
    for prim in layer.GetPrimAtPath("/Scene").nameChildren:
        (ref,) = prim.referenceList.prependedItems
        refs[prim.name] = ref.assetPath
    return refs


def test_two_files_of_one_stem_fail_under_stem_with_a_hint_to_name_by_path(tmp_path):
    cfg = _library(tmp_path)
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=_quiet)
    (problem,) = exc.value.problems
    assert "library/props/table/scene.obj and library/props/chair/scene.obj would both write scene.swpm" in (
        problem
    )
    assert "output.names: path" in problem and "props--chair--scene.swpm" in problem
    assert not (tmp_path / "out").exists()


def test_files_given_by_their_paths_are_named_by_their_stems_under_path(tmp_path):
    """A glob without a wildcard starts from its file's folder: two such files of one stem still collide
    under ``path``, and the error says to match them with one glob."""
    config = CONFIG.replace(
        '  - glob: "library/**/*.obj"',
        '  - glob: "library/props/chair/scene.obj"\n  - glob: "library/props/table/scene.obj"',
    )
    cfg = _library(tmp_path, config.replace("  scene: true", "  scene: true\n  names: path"))
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=_quiet)
    (problem,) = exc.value.problems
    assert "would both write scene.swpm; each is given by its path" in problem and "one glob" in problem
    # under stem the hint would not help (the path names are the stems): none
    cfg.write_text(config)
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=_quiet)
    assert exc.value.problems[0].endswith("would both write scene.swpm")


def test_names_by_path_build_both_and_the_manifest_and_scene_name_them(tmp_path):
    cfg = _library(tmp_path, CONFIG.replace("  scene: true", "  scene: true\n  names: path"))
    res = run(cfg, echo=_quiet)
    assert res.built == 2 and res.failed == 0
    out = tmp_path / "out"
    expected = {"props--chair--scene", "props--table--scene"}
    assert {p.name for p in out.iterdir() if p.suffix in (".swpm", ".usdc")} == {
        f"{s}{x}" for s in expected for x in (".swpm", ".usdc")
    }
    manifest = json.loads((out / "manifest.json").read_text())
    chair = manifest["assets"]["library/props/chair/scene.obj"]["outputs"]
    assert (chair["swpm"]["path"], chair["usd"]["path"]) == (
        "props--chair--scene.swpm",
        "props--chair--scene.usdc",
    )
    # the scene references each layer by its name (its prims: USD identifiers made of the names, hashed)
    refs = _scene_references(out)
    assert sorted(refs.values()) == ["./props--chair--scene.usdc", "./props--table--scene.usdc"]
    names = {ref: name for name, ref in refs.items()}
    assert re.fullmatch(r"props__chair__scene_[0-9a-f]{8}", names["./props--chair--scene.usdc"]), names
    again = run(cfg, echo=_quiet)
    assert again.built == 0 and again.skipped == 2


def test_flipping_names_rebuilds_under_the_new_names_and_prune_removes_the_old(tmp_path):
    # one folder of distinct stems: builds under both settings
    cfg = _library(tmp_path, CONFIG.replace("library/**/*.obj", "library/props/chair/*.obj"))
    shutil.copy(SHARED_MESHES / "suzanne.obj", tmp_path / "library" / "props" / "chair" / "cushion.obj")
    first = run(cfg, echo=_quiet)
    out = tmp_path / "out"
    assert first.built == 2 and (out / "scene.swpm").is_file() and (out / "cushion.usdc").is_file()
    # the glob's fixed folder is library/props/chair: the names are the stems again, nothing rebuilt
    cfg.write_text(cfg.read_text().replace("  scene: true", "  scene: true\n  names: path"))
    assert run(cfg, echo=_quiet).built == 0
    # from library/: the folders are in the names, each asset built again under them
    cfg.write_text(cfg.read_text().replace("library/props/chair/*.obj", "library/**/chair/*.obj"))
    # a dry run names the files the rebuilds leave at the old names, as the run does (it named none)
    lines: list[str] = []
    plan = run(cfg, dry_run=True, prune=True, echo=lines.append)
    assert sorted(plan.pruned) == ["cushion.swpm", "cushion.usdc", "scene.swpm", "scene.usdc"]
    # (named as what they are: the asset's, at its names before the flip, not a removed asset's)
    assert (
        "scene.swpm: output of library/props/chair/scene.obj at its name before output.names: stem -> path; "
        "--prune deletes it"
    ) in lines
    assert not any("no longer in the config" in line for line in lines)
    assert sorted(run(cfg, dry_run=True, echo=_quiet).unlisted) == sorted(plan.pruned)
    flipped = run(cfg, echo=_quiet)
    assert flipped.built == 2
    assert sorted(flipped.unlisted) == ["cushion.swpm", "cushion.usdc", "scene.swpm", "scene.usdc"]
    moved = {"code": "names-changed", "detail": "output.names: stem -> path"}
    assert sorted((o["path"], o["asset"], o["because"] == moved) for o in flipped.orphans) == [
        ("cushion.swpm", "library/props/chair/cushion.obj", True),
        ("cushion.usdc", "library/props/chair/cushion.obj", True),
        ("scene.swpm", "library/props/chair/scene.obj", True),
        ("scene.usdc", "library/props/chair/scene.obj", True),
    ]
    # a later run still says so (the manifest keeps why), in its last line and --json
    recorded = json.loads((out / "manifest.json").read_text())["orphaned_outputs"]
    assert {(o["path"], o["asset"], o["because"]["code"]) for o in recorded} == {
        (o["path"], o["asset"], "names-changed") for o in flipped.orphans
    }
    from click.testing import CliRunner

    from swpm_usd.cli import main

    r = CliRunner().invoke(main, ["run", str(cfg)])
    assert r.exit_code == 0 and "no longer in the config" not in r.output, r.output
    assert (
        "4 outputs at their assets' names before output.names: stem -> path left in output.dir "
        "(--prune deletes them)"
    ) in r.output
    r = CliRunner().invoke(main, ["run", str(cfg), "--json"])
    orphans = json.loads(r.stdout)["orphans"]
    assert sorted(o["path"] for o in orphans) == sorted(flipped.unlisted)
    assert all(o["because"] == moved and o["asset"].startswith("library/") for o in orphans)
    assert sorted(_scene_references(out).values()) == [
        "./props--chair--cushion.usdc",
        "./props--chair--scene.usdc",
    ]
    assert run(cfg, echo=_quiet).built == 0
    pruned = run(cfg, prune=True, echo=_quiet)
    assert pruned.built == 0
    assert sorted(pruned.pruned) == ["cushion.swpm", "cushion.usdc", "scene.swpm", "scene.usdc"]
    assert all(o["because"] == moved for o in pruned.orphans)
    assert sorted(p.name for p in out.iterdir() if p.suffix in (".swpm", ".usdc")) == [
        "props--chair--cushion.swpm",
        "props--chair--cushion.usdc",
        "props--chair--scene.swpm",
        "props--chair--scene.usdc",
    ]
    # and back to stems: built again under them, the path names orphaned
    cfg.write_text(cfg.read_text().replace("\n  names: path", ""))
    back = run(cfg, echo=_quiet)
    assert back.built == 2 and (out / "scene.swpm").is_file()
    assert sorted(back.unlisted) == [
        "props--chair--cushion.swpm",
        "props--chair--cushion.usdc",
        "props--chair--scene.swpm",
        "props--chair--scene.usdc",
    ]
    assert {o["because"]["detail"] for o in back.orphans} == {"output.names: path -> stem"}


def test_a_stage_s_prims_are_named_after_the_stage_under_path(tmp_path):
    """A stage is given as a path: its fixed folder is its own, so its prims' names are the stage's stem and
    ``__<prim>`` under either setting."""
    from pxr import Usd, UsdGeom

    (tmp_path / "shots" / "a").mkdir(parents=True)
    st = Usd.Stage.CreateNew(str(tmp_path / "shots" / "a" / "shot.usda"))
    for name in ("rock", "tree"):
        m = UsdGeom.Mesh.Define(st, f"/World/{name}")
        m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)])
        m.CreateFaceVertexCountsAttr([3, 3])
        m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
    st.GetRootLayer().Save()
    config = CONFIG.replace('glob: "library/**/*.obj"', "stage: shots/a/shot.usda").replace(
        "  scene: true", "  scene: true\n  names: path"
    )
    cfg = _library(tmp_path, config)
    res = run(cfg, echo=_quiet)
    assert res.built == 2
    assert sorted(r["outputs"]["swpm"]["path"] for r in res.records.values()) == [
        "shot__World_rock.swpm",
        "shot__World_tree.swpm",
    ]
    assert sorted(_scene_references(tmp_path / "out").values()) == [
        "./shot__World_rock.usdc",
        "./shot__World_tree.usdc",
    ]


@pytest.mark.parametrize("names", ["path", "stem"])
def test_two_stages_of_one_name_in_two_folders_are_one_problem_naming_both_entries(tmp_path, names):
    """Two ``stage:`` entries whose files are both ``scene.usda`` (in two folders) with prims at the same
    paths would write the same outputs under either setting (a stage is named by its stem): the config is
    refused before anything is written, said once for the pair of entries (it was said once a prim, at the
    later entry alone, without what to do), both entries located."""
    from pxr import Usd, UsdGeom

    for shot in ("a", "b"):
        (tmp_path / "shots" / shot).mkdir(parents=True)
        st = Usd.Stage.CreateNew(str(tmp_path / "shots" / shot / "scene.usda"))
        for name in ("rock", "tree", "bush") if shot == "a" else ("rock", "tree", "car"):
            m = UsdGeom.Mesh.Define(st, f"/World/{name}")
            m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)])
            m.CreateFaceVertexCountsAttr([3, 3])
            m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
        st.GetRootLayer().Save()
    del st, m  # (its layer open here would be the one a run reads, not the file edited below)
    config = CONFIG.replace(
        '  - glob: "library/**/*.obj"', "  - stage: shots/a/scene.usda\n  - stage: shots/b/scene.usda"
    ).replace("  scene: true", f"  scene: true\n  names: {names}")
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(config)
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=_quiet)
    (problem,) = exc.value.problems
    assert problem.startswith(
        f"{cfg}:4:5: $.assets[1]: stage shots/b/scene.usda and stage shots/a/scene.usda "
        f"($.assets[0], {cfg}:3:5) would both write scene__World_rock.swpm and 1 more output name "
        "(2 prim paths in both)"
    ), problem
    assert "rename one stage file" in problem
    assert not (tmp_path / "out").exists()
    # prims at other paths: the two stages build side by side
    (tmp_path / "shots" / "b" / "scene.usda").write_text(
        (tmp_path / "shots" / "b" / "scene.usda").read_text().replace("World", "Shot")
    )
    assert run(cfg, echo=_quiet).built == 6


def test_a_bad_value_is_a_located_config_error(tmp_path):
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(CONFIG.replace("  scene: true", "  scene: true\n  names: folders"))
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    (problem,) = exc.value.problems
    assert problem.startswith(f"{cfg}:8:10: $.output.names: ") and "'stem'" in problem and "'path'" in problem


def test_path_names_under_the_glob_s_fixed_folder():
    assert _glob_root("library/**/*.gltf") == ("library",)
    assert _glob_root("a/b?/c.obj") == ("a",)
    assert _glob_root("*.obj") == ()
    assert _glob_root("props/chair/scene.gltf") == ("props", "chair")  # (a path: its file's folder)
    root = Path("/p/library")
    assert path_name(root / "props/chair/scene.gltf", root) == "props--chair--scene"
    assert path_name(root / "rock.v2.obj", root) == "rock.v2"  # (the last suffix alone, as a stem)
    assert path_name(Path("/elsewhere/rock.obj"), root) == "rock"
    assert PATH_NAME_SEPARATOR != "__" and "." not in PATH_NAME_SEPARATOR


def test_two_stages_of_one_name_locate_the_first_entry_in_a_config_whose_path_holds_a_colon(tmp_path):
    """The pair's problem locates the first entry by the config's ``FILE:LINE:COL``, whole where the config's
    path holds ``": "`` (a folder ``my: shots``; it was cut at the first ``": "``, naming ``.../my``)."""
    from pxr import Usd, UsdGeom

    root = tmp_path / "my: shots"
    for shot in ("a", "b"):
        (root / shot).mkdir(parents=True)
        st = Usd.Stage.CreateNew(str(root / shot / "scene.usda"))
        m = UsdGeom.Mesh.Define(st, "/World/rock")
        m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
        m.CreateFaceVertexCountsAttr([3])
        m.CreateFaceVertexIndicesAttr([0, 1, 2])
        st.GetRootLayer().Save()
    del st, m
    cfg = root / "pipeline.yaml"
    entries = "  - stage: a/scene.usda\n  - stage: b/scene.usda\n"
    cfg.write_text(f"version: 1\nassets:\n{entries}output: {{dir: out}}\n")
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=_quiet)
    (problem,) = exc.value.problems
    assert problem.startswith(
        f"{cfg}:4:5: $.assets[1]: stage b/scene.usda and stage a/scene.usda ($.assets[0], {cfg}:3:5) "
        "would both write scene__World_rock.swpm (1 prim path in both)"
    ), problem


def test_names_moved_by_the_glob_alone_are_said_to_be_the_globs(tmp_path):
    """Built under ``names: path`` with a glob whose fixed folder gives the stems, then the glob widened: the
    files left at the old names are the glob's doing (the record says which setting named them), not a flip
    of ``output.names`` (the old names being the stems, that was the guess); a record of an earlier version,
    without ``output_names``, keeps the guess."""
    config = CONFIG.replace("library/**/*.obj", "library/props/chair/*.obj")
    cfg = _library(tmp_path, config.replace("  scene: true", "  scene: true\n  names: path"))
    assert run(cfg, echo=_quiet).built == 1
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    (record,) = manifest["assets"].values()
    assert record["output_names"] == "path" and record["outputs"]["swpm"]["path"] == "scene.swpm"
    cfg.write_text(cfg.read_text().replace("library/props/chair/*.obj", "library/**/chair/*.obj"))
    lines: list[str] = []
    run(cfg, dry_run=True, echo=lines.append)
    assert (
        "scene.swpm: output of library/props/chair/scene.obj at its name before its glob (output.names: path)"
        in ("\n".join(lines))
    ), lines
    # the same record as an earlier version wrote it: the stems taken for a flip
    del record["output_names"]
    (tmp_path / "out" / "manifest.json").write_text(json.dumps(manifest))
    lines.clear()
    run(cfg, dry_run=True, echo=lines.append)
    assert "at its name before output.names: stem -> path" in "\n".join(lines), lines
