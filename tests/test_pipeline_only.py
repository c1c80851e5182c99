"""``swpm-pipeline run --only PATTERN`` (``run(..., only=[...])``): the run plans the whole config and builds
the selected assets alone; the others' manifest records stay as they were, byte for byte."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner
from conftest import SHARED_MESHES

from swpm_usd.cli import main
from swpm_usd.pipeline import ConfigError, run
from swpm_usd.pipeline.selection import SelectionError, selected_ids

MESHES = ("hero_a", "hero_b", "rock", "tree")
PRIMS = ("stages/set.usda:/World/car", "stages/set.usda:/World/lamp")
ALL = [*(f"meshes/{m}.obj" for m in MESHES), *PRIMS]


def _config(extra: str = "") -> str:
    return (
        "version: 1\n"
        'assets:\n  - glob: "meshes/*.obj"\n  - stage: stages/set.usda\n'
        "output:\n  dir: out\n  report: false\n  usd: true\n  scene: true\n"
        f"defaults:\n  encoding: vanilla\n{extra}"
    )


def _stage(path: Path) -> None:
    """A stage of two Mesh prims (two triangles each): two assets, ``path:/World/car`` and ``.../lamp``."""
    from pxr import Usd, UsdGeom

    path.parent.mkdir(parents=True, exist_ok=True)
    st = Usd.Stage.CreateNew(str(path))
    for name in ("car", "lamp"):
        m = UsdGeom.Mesh.Define(st, f"/World/{name}")
        m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)])
        m.CreateFaceVertexCountsAttr([3, 3])
        m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
    st.GetRootLayer().Save()


def _project(root: Path, extra: str = "") -> Path:
    (root / "meshes").mkdir(parents=True)
    for name in MESHES:
        shutil.copy(SHARED_MESHES / "suzanne.obj", root / "meshes" / f"{name}.obj")
    _stage(root / "stages" / "set.usda")
    cfg = root / "pipeline.yaml"
    cfg.write_text(_config(extra))
    return cfg


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    """The project (four copies of suzanne, a stage of two prims), every asset built."""
    root = tmp_path_factory.mktemp("built")
    res = run(_project(root), echo=lambda m: None)
    assert (res.built, res.failed) == (6, 0), res.failures
    return root


@pytest.fixture
def project(built: Path, tmp_path: Path) -> Path:
    """A copy of the built project (its config at ``pipeline.yaml``)."""
    shutil.copytree(built, tmp_path / "p")
    return tmp_path / "p" / "pipeline.yaml"


def _records_text(cfg: Path) -> dict[str, str]:
    """Each asset record's text in manifest.json (``json.dumps(indent=1)``: a record at depth 2 ends at the
    first line that is two spaces and its closing brace)."""
    text = (cfg.parent / "out" / "manifest.json").read_text()
    found = {}
    for aid in json.loads(text)["assets"]:
        start = text.index(f"\n  {json.dumps(aid)}: {{")
        found[aid] = text[start : text.index("\n  }", start)]
    return found


def _outputs(cfg: Path, aid: str) -> dict[str, tuple[int, bytes]]:
    """An asset's output files: name -> (mtime_ns, bytes)."""
    rec = json.loads((cfg.parent / "out" / "manifest.json").read_text())["assets"][aid]
    files = [cfg.parent / "out" / o["path"] for o in rec["outputs"].values()]
    return {f.name: (f.stat().st_mtime_ns, f.read_bytes()) for f in files}


def _cli(cfg: Path, *args: str) -> tuple[int, str, str]:
    res = CliRunner().invoke(main, ["run", str(cfg), *args])
    return res.exit_code, res.stdout, res.stderr


def test_patterns_match_ids_with_star_crossing_slashes_and_a_plain_id_matching_itself():
    ids = ["meshes/hero_a.obj", "meshes/hero/b.obj", "meshes/Hero_c.obj", "x/a[1].obj", "s.usda:/World/car"]
    assert selected_ids(ids, ["meshes/hero_*"]) == {"meshes/hero_a.obj"}
    assert selected_ids(ids, ["meshes/hero*"]) == {"meshes/hero_a.obj", "meshes/hero/b.obj"}  # (case: kept)
    assert selected_ids(ids, ["meshes/*.obj"]) == set(ids[:3])
    assert selected_ids(ids, ["x/a[1].obj"]) == {"x/a[1].obj"}  # (as written, not a character class)
    assert selected_ids(ids, ["s.usda:*"]) == {"s.usda:/World/car"}
    assert selected_ids(ids, ["*car", "meshes/Hero_?.obj"]) == {"s.usda:/World/car", "meshes/Hero_c.obj"}
    with pytest.raises(SelectionError) as err:
        selected_ids(ids, ["meshes/hero_a.obj", "nope*", "also/nope"])
    assert err.value.patterns == ["nope*", "also/nope"]
    assert "'nope*', 'also/nope' match no asset" in str(err.value)
    assert "meshes/hero_a.obj, meshes/hero/b.obj" in str(err.value)


def test_a_pattern_that_misses_by_a_folder_a_suffix_or_an_output_name_gets_the_one_that_matches():
    """A TD writes the path under the glob's folder, a file without its suffix or the output's name (what
    ``out/`` and the scene show): the error names the id pattern that matches, and how many it takes."""
    ids = [f"lib/set{s}/{n}.obj" for s in ("01", "02") for n in ("rock", "tree")] + ["lib/s.usda:/World/car"]
    cases = {
        "set01/*": ("lib/set01/*", "2 assets"),
        "lib/set02/rock": ("lib/set02/rock.obj", "1 asset"),
        "set02--tree": ("lib/set02/tree.obj", "1 asset"),
        "rock": ("*/rock.*", "2 assets"),  # (under two folders: no common head to write)
    }
    for pattern, (hint, count) in cases.items():
        with pytest.raises(SelectionError) as err:
            selected_ids(ids, [pattern])
        assert f"'{pattern}' matches no asset (did you mean '{hint}'? {count}); " in str(err.value)
        assert selected_ids(ids, [hint])  # (the hint does match)
    with pytest.raises(SelectionError) as err:
        selected_ids(ids, ["nothing/near*"])
    assert "did you mean" not in str(err.value) and err.value.hints == {}


def test_a_bracket_pattern_is_a_character_class():
    assert selected_ids(["a1.obj", "a2.obj", "ab.obj"], ["a[0-9].obj"]) == {"a1.obj", "a2.obj"}


def test_only_builds_the_selected_assets_and_keeps_the_others_records_byte_for_byte(project):
    for name in ("hero_a", "rock"):  # (both out of date; rock is not selected)
        with open(project.parent / "meshes" / f"{name}.obj", "a") as f:
            f.write("# edited\n")
    before = _records_text(project)
    rock_out = _outputs(project, "meshes/rock.obj")
    code, out, err = _cli(project, "--only", "meshes/hero_*")
    assert code == 0, err
    assert "1 built (inputs changed 1), 1 up to date, 0 failed, 4 not selected in " in out
    after = _records_text(project)
    assert after["meshes/hero_a.obj"] != before["meshes/hero_a.obj"]
    for aid in ("meshes/rock.obj", "meshes/tree.obj", *PRIMS):
        assert after[aid] == before[aid], aid  # (rock out of date, left as it was; the others unchecked)
    assert _outputs(project, "meshes/rock.obj") == rock_out
    # the scene is the whole manifest's: every asset keeps its prim
    scene = (project.parent / "out" / "scene.usda").read_text()
    for stem in ("hero_a", "hero_b", "rock", "tree", "set__World_car", "set__World_lamp"):
        assert f"./{stem}.usdc" in scene, stem
    # a run of the whole config then builds what is left
    res = run(project, echo=lambda m: None)
    assert res.built_ids == ["meshes/rock.obj"] and res.not_selected == 0


def test_force_only_rebuilds_the_selected_alone(project):
    before = _records_text(project)
    code, out, err = _cli(project, "--force", "--only", "meshes/rock.obj", "--only", "meshes/tree*", "--json")
    assert code == 0, err
    summary = json.loads(out)
    assert summary["built_assets"] == ["meshes/rock.obj", "meshes/tree.obj"]
    assert (summary["built"], summary["skipped"], summary["not_selected"]) == (2, 0, 4)
    assert summary["built_because"] == {"forced": 2}
    after = _records_text(project)
    assert {aid for aid in ALL if after[aid] != before[aid]} == {"meshes/rock.obj", "meshes/tree.obj"}


def test_a_prim_of_a_stage_is_selected_by_its_id(project):
    res = run(project, force=True, only=["stages/set.usda:/World/lamp"], echo=lambda m: None)
    assert res.built_ids == ["stages/set.usda:/World/lamp"]
    assert (res.skipped, res.not_selected) == (0, 5)
    lines: list[str] = []
    res = run(project, dry_run=True, only=["stages/set.usda:*"], echo=lines.append)
    assert [p["id"] for p in res.plan] == list(PRIMS)
    assert [x.split(": ")[0] for x in lines] == [*PRIMS, "4 assets not selected by --only (of 6)"]


def test_a_pattern_that_matches_nothing_is_a_usage_error_before_anything_is_written(tmp_path, project):
    fresh = _project(tmp_path / "fresh")
    code, out, err = _cli(fresh, "--only", "meshes/hreo_*")
    assert code == 2
    assert "'meshes/hreo_*' matches no asset" in err and "meshes/hero_a.obj, meshes/hero_b.obj" in err
    assert "(6 assets)" in err  # (the first five shown, and how many there are)
    assert not (fresh.parent / "out").exists()
    # a built project: nothing built or written, one of two patterns unmatched is named alone
    out_dir = project.parent / "out"
    files = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in out_dir.iterdir()}
    code, out, err = _cli(project, "--force", "--only", "meshes/rock.obj", "--only", "nope", "--json")
    assert code == 2
    error = json.loads(out)
    assert error["usage_error"] is True and error["code"] == "USAGE_ERROR"
    assert error["input"] == str(project)  # (the config, as run's other --json errors name it)
    assert "'nope' matches no asset" in error["error"] and "rock.obj'" not in error["error"]
    assert {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in out_dir.iterdir()} == files
    with pytest.raises(SelectionError):
        run(project, dry_run=True, only=["nope"], echo=lambda m: None)


@pytest.mark.parametrize("dry_run", [False, True])
def test_a_pattern_that_matches_nothing_is_refused_before_any_input_is_hashed_or_loaded(
    tmp_path, monkeypatch, dry_run
):
    """The patterns are checked once the asset ids are known, before the plan hashes an input or loads one
    to count its triangles (they were checked after the whole plan: minutes on thousands of assets), with
    the same error; a config with problems is still a config error first."""
    import swpm_usd.pipeline.runner as runner

    cfg = _project(
        tmp_path / "p", extra="rules:\n  - {name: big, match: {triangles: {min: 1}}, encoding: vanilla}\n"
    )
    touched: list[str] = []

    def hashed(paths):
        touched.append("hashed")
        raise AssertionError("an input hashed before the patterns were checked")

    def counted(*args, **kwargs):
        touched.append("counted")
        raise AssertionError("an input loaded before the patterns were checked")

    monkeypatch.setattr(runner, "hash_inputs", hashed)
    monkeypatch.setattr(runner, "_count_triangles", counted)
    with pytest.raises(SelectionError) as exc:
        run(cfg, dry_run=dry_run, only=["hero_*"], echo=lambda m: None)
    assert touched == []
    # the error the whole plan's ids gave: its message, the first ids, the count and the did-you-mean
    with pytest.raises(SelectionError) as planned:
        selected_ids(ALL, ["hero_*"])
    assert str(exc.value) == str(planned.value) and "did you mean 'meshes/hero_*'? 2 assets" in str(exc.value)
    assert not (tmp_path / "p" / "out").exists()
    # the config's own problems first, as before (the plan then goes on: its inputs hashed)
    monkeypatch.undo()
    cfg.write_text(cfg.read_text().replace("meshes/*.obj", "nothing/*.obj"))
    with pytest.raises(ConfigError, match="the glob matches no file"):
        run(cfg, dry_run=dry_run, only=["hero_*"], echo=lambda m: None)


def test_dry_run_lists_the_selected_and_counts_the_others(project):
    (project.parent / "meshes" / "new.obj").write_bytes((SHARED_MESHES / "suzanne.obj").read_bytes())
    code, out, err = _cli(project, "--dry-run", "--only", "meshes/new.obj", "--only", "meshes/hero_b.obj")
    assert code == 0, err
    lines = out.splitlines()
    assert [x.split(": ")[0] for x in lines] == [
        "meshes/hero_b.obj",
        "meshes/new.obj",
        "5 assets not selected by --only (of 7)",
        "1 to build (new 1), 1 up to date, 5 not selected; dry run",
    ]
    assert "[up to date]" in lines[0] and "[to build]" in lines[1] and "because: new" in lines[1]
    assert lines[-1] == "1 to build (new 1), 1 up to date, 5 not selected; dry run: nothing written"
    assert not (project.parent / "out" / "new.swpm").exists()
    code, out, err = _cli(project, "--dry-run", "--only", "meshes/*", "--json")
    summary = json.loads(out)
    assert [p["id"] for p in summary["plan"]] == ["meshes/hero_a.obj", "meshes/hero_b.obj", "meshes/new.obj",
                                                  "meshes/rock.obj", "meshes/tree.obj"]  # fmt: skip
    assert (summary["skipped"], summary["not_selected"]) == (4, 2)
    assert "2 assets not selected by --only (of 7)" in err  # (--json: the plan's lines on stderr)
    # --explain lists the same, then builds the selected
    lines = []
    res = run(project, explain=True, only=["meshes/new.obj"], echo=lines.append)
    assert lines[-1] == "6 assets not selected by --only (of 7): not listed, not built"
    assert res.built_ids == ["meshes/new.obj"] and [p["id"] for p in res.plan] == ["meshes/new.obj"]


def test_without_only_every_asset_is_selected(project):
    (project.parent / "meshes" / "new.obj").write_bytes((SHARED_MESHES / "suzanne.obj").read_bytes())
    code, out, err = _cli(project, "--json")
    assert code == 0, err
    summary = json.loads(out)
    assert summary["built_assets"] == ["meshes/new.obj"]
    assert (summary["skipped"], summary["not_selected"]) == (6, 0)
    code, out, err = _cli(project)
    assert code == 0 and "not selected" not in out and "0 built, 7 up to date, 0 failed in " in out


def test_the_api_takes_a_list_or_one_pattern(project):
    res = run(project, force=True, only=["meshes/hero_a.obj", "*lamp"], echo=lambda m: None)
    assert sorted(res.built_ids) == ["meshes/hero_a.obj", "stages/set.usda:/World/lamp"]
    assert (res.built, res.skipped, res.not_selected) == (2, 0, 4)
    res = run(project, force=True, only="meshes/tree.obj", echo=lambda m: None)  # (not its characters)
    assert res.built_ids == ["meshes/tree.obj"] and res.not_selected == 5
    res = run(project, force=True, only=[], echo=lambda m: None)  # (empty: every asset)
    assert res.built == 6 and res.not_selected == 0


def test_prune_keeps_its_meaning_whatever_only_selects(project):
    (project.parent / "meshes" / "tree.obj").unlink()  # (its outputs are now orphans)
    tree_out = project.parent / "out" / "tree.swpm"
    assert tree_out.exists()
    res = run(project, only=["meshes/rock.obj"], echo=lambda m: None)
    assert res.unlisted == ["tree.swpm", "tree.usdc"] and tree_out.exists()
    res = run(project, only=["meshes/rock.obj"], prune=True, echo=lambda m: None)
    assert res.pruned == ["tree.swpm", "tree.usdc"] and not tree_out.exists()
    assert res.built == 0 and res.not_selected == 4


def test_a_rule_only_unselected_assets_reach_is_not_said_to_match_none(tmp_path):
    # rules on triangles: new assets' rules are the workers' to choose; those not selected never choose
    extra = "rules:\n  - name: big\n    match: {triangles: {min: 500}}\n    encoding: skip-strip\n"
    cfg = _project(tmp_path / "p", extra)
    warned: list[str] = []
    res = run(cfg, only=["stages/*"], echo=warned.append)
    assert res.built_ids and sorted(res.built_ids) == list(PRIMS)
    assert not [w for w in warned if "matches no asset" in w], warned
    res = run(cfg, echo=warned.append)  # (the whole config: big is reached)
    assert res.built == 4 and not [w for w in warned if "big" in w], warned


def test_a_manifest_read_and_written_again_is_the_same_text(built):
    # (a stage's prims name their shared inputs list by inputs_ref: read back, the list was appended after
    # the record's other keys, and every rewrite moved it, so a record left as it was changed its text)
    from swpm_usd.pipeline.manifest import _ManifestText, _read_manifest

    path = built / "out" / "manifest.json"
    assert '"inputs_ref"' in path.read_text()
    assert _ManifestText().dumps(_read_manifest(path)) == path.read_text().removesuffix("\n")


def test_a_selected_asset_renamed_onto_an_unselected_ones_recorded_output_is_refused(tmp_path):
    """Under ``output.names: path`` ``meshes/a/b.obj`` is named ``a--b``, the name ``meshes/x/a--b.obj``
    had under ``stem``: built alone, it replaced that asset's build, which its record and the scene still
    gave it (both prims of the scene drew suzanne). Refused before anything is written; built together, or
    the other first, it is fine."""
    for folder, name, mesh in (("a", "b", "suzanne.obj"), ("x", "a--b", "beetle.obj")):
        (tmp_path / "meshes" / folder).mkdir(parents=True)
        shutil.copy(SHARED_MESHES / mesh, tmp_path / "meshes" / folder / f"{name}.obj")
    cfg = tmp_path / "pipeline.yaml"
    text = (
        'version: 1\nassets:\n  - glob: "meshes/**/*.obj"\n'
        "output:\n  dir: out\n  report: false\n  usd: true\n  scene: true\ndefaults: {encoding: vanilla}\n"
    )
    cfg.write_text(text)
    assert not run(cfg, echo=lambda m: None).failed
    out = tmp_path / "out"
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    cfg.write_text(text.replace("  scene: true\n", "  scene: true\n  names: path\n"))
    r = CliRunner().invoke(main, ["run", str(cfg), "--only", "meshes/a/*"])
    assert r.exit_code == 2, r.output
    assert (
        "meshes/a/b.obj would write a--b.swpm and a--b.usdc, the recorded outputs of meshes/x/a--b.obj, "
        "which is not selected" in r.output
    )
    assert "--only 'meshes/x/a--b.obj'" in r.output
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # nothing written
    with pytest.raises(SelectionError):  # (the API too, dry run included)
        run(cfg, only=["meshes/a/*"], dry_run=True, echo=lambda m: None)
    # the other selected first: its build moves to x--a--b, and then the first builds alone
    assert run(cfg, only=["meshes/x/*"], echo=lambda m: None).built == 1
    assert run(cfg, only=["meshes/a/*"], echo=lambda m: None).built == 1
    records = json.loads((out / "manifest.json").read_text())["assets"]
    assert records["meshes/a/b.obj"]["outputs"]["swpm"]["path"] == "a--b.swpm"
    assert records["meshes/x/a--b.obj"]["outputs"]["swpm"]["path"] == "x--a--b.swpm"
    sha = {k: r["outputs"]["swpm"]["sha256"] for k, r in records.items()}
    assert sha["meshes/a/b.obj"] != sha["meshes/x/a--b.obj"]
