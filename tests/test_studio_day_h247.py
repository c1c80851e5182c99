"""What a studio's first day with the pipeline tripped on (helper-247's walk-through): each test failed before
its fix."""

from __future__ import annotations

import unicodedata
from pathlib import Path

import pytest

from swpm_usd.pipeline import ConfigError, run
from swpm_usd.pipeline.selection import selected_ids

TWO_TRIANGLES_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"
TWO_TRIANGLES_OFF = "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\n"


def _quiet(message: str) -> None:
    pass


@pytest.mark.parametrize("names", ["stem", "path"])
def test_one_folder_s_files_of_one_name_but_their_suffix_are_told_what_to_do(tmp_path: Path, names: str):
    # a source and its export side by side (cow.obj, cow.off): one output name under either output.names,
    # and the error ended at "would both write ...swpm", saying nothing of what to do
    (tmp_path / "lib" / "cow").mkdir(parents=True)
    (tmp_path / "lib" / "cow" / "cow.obj").write_text(TWO_TRIANGLES_OBJ)
    (tmp_path / "lib" / "cow" / "cow.off").write_text(TWO_TRIANGLES_OFF)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        f'version: 1\nassets:\n  - glob: "lib/**/*"\noutput: {{dir: out, names: {names}}}\n'
        "defaults: {encoding: vanilla}\n"
    )
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=_quiet, dry_run=True)
    (problem,) = exc.value.problems
    assert "lib/cow/cow.o" in problem and "would both write" in problem
    assert "named without the file's suffix" in problem and "rename one" in problem
    assert "output.names: path names outputs" not in problem  # (that would not help: it names them alike)
    # renamed as it says, both build
    (tmp_path / "lib" / "cow" / "cow.off").rename(tmp_path / "lib" / "cow" / "cow_off.off")
    assert run(cfg, echo=_quiet).built == 2


def test_two_folders_files_of_one_name_keep_their_hint(tmp_path: Path):
    # (the new words are for one folder's pair alone: another folder's keeps output.names: path's hint)
    for folder in ("a", "b"):
        (tmp_path / "lib" / folder).mkdir(parents=True)
        (tmp_path / "lib" / folder / "rock.obj").write_text(TWO_TRIANGLES_OBJ)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text('version: 1\nassets:\n  - glob: "lib/**/*.obj"\noutput: {dir: out}\n')
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=_quiet, dry_run=True)
    (problem,) = exc.value.problems
    assert "output.names: path names outputs" in problem and "suffix" not in problem


@pytest.mark.parametrize("on_disk", ["NFC", "NFD"])
def test_only_matches_a_pattern_in_another_unicode_normalization(tmp_path: Path, on_disk: str):
    # `--only 'props/café.obj'` pasted from a macOS Finder or terminal (e and a combining accent) matched no
    # asset named with one code point, and the usage error showed the same-looking text as unmatched
    name = unicodedata.normalize(on_disk, "café.obj")
    (tmp_path / "props").mkdir()
    (tmp_path / "props" / name).write_text(TWO_TRIANGLES_OBJ)
    (tmp_path / "props" / "rock.obj").write_text(TWO_TRIANGLES_OBJ)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text('version: 1\nassets:\n  - glob: "props/*.obj"\noutput: {dir: out}\n')
    for form in ("NFC", "NFD"):
        typed = unicodedata.normalize(form, "props/café.obj")
        res = run(cfg, echo=_quiet, only=[typed], force=True)
        assert res.built == 1 and res.not_selected == 1, form
        assert selected_ids([f"props/{name}", "props/rock.obj"], [typed]) == {f"props/{name}"}
        glob = unicodedata.normalize(form, "props/café*")
        assert selected_ids([f"props/{name}"], [glob]) == {f"props/{name}"}
    # (still case-sensitive: ids are the config's paths)
    assert selected_ids(["props/Rock.obj", "props/rock.obj"], ["props/rock.obj"]) == {"props/rock.obj"}


def test_coarsest_lod_bytes_counts_the_lod_s_own_bytes_not_the_file_prefix(tmp_path: Path):
    # the sample's comment read "the coarsest LOD must be drawable from this many bytes" (a download's
    # prefix); the check counts the LOD's vertices and indices: spot's skip-strip file (the sample's rule)
    # passes 65,536 with 828 bytes while its coarsest LOD draws from the first 271,024 of the file (README,
    # Command line)
    from conftest import SHARED_MESHES

    import swpm_usd
    from swpm_usd.format import SwpmFormatError, encode_bytes, open_prefix
    from swpm_usd.pipeline.worker import check_streaming

    pm = swpm_usd.build(SHARED_MESHES / "spot.obj", encoding="skip-strip", primitive="strip", restart=True)
    assert check_streaming(pm, {"coarsest_lod_bytes": 65536}) == []
    assert check_streaming(pm, {"coarsest_lod_bytes": 827}) == [
        "coarsest LOD needs 828 bytes > streaming.coarsest_lod_bytes=827"
    ]
    data = encode_bytes(pm)

    def draws(n: int) -> bool:
        try:
            return open_prefix(data[:n]).finest_drawable is not None
        except SwpmFormatError:
            return False

    # (the run's file, 64 bytes of asset digest longer, from 271,024: measured for the README)
    assert not draws(65536) and not draws(len(data) * 3 // 4) and draws(len(data))


def test_a_rule_whose_path_matches_no_asset_path_is_told_the_near_pattern(tmp_path: Path):
    # `match: {path: "props/*"}` written from the glob's folder (the ids are "assets/props/..."): the warning
    # said "rule 'props' matches no asset" alone, and the assets took the defaults
    (tmp_path / "assets" / "props").mkdir(parents=True)
    for name in ("chair", "lamp"):
        (tmp_path / "assets" / "props" / f"{name}.obj").write_text(TWO_TRIANGLES_OBJ)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        'version: 1\nassets:\n  - glob: "assets/**/*.obj"\noutput: {dir: out}\n'
        "defaults: {encoding: vanilla}\nrules:\n"
        '  - {name: props, match: {path: "props/*"}, encoding: mixed}\n'
        '  - {name: huge-props, match: {path: "assets/props/*", triangles: {min: 1000}}, encoding: mixed}\n'
    )
    res = run(cfg, echo=_quiet, dry_run=True)
    props, huge = res.warnings
    assert props.endswith(
        "rule 'props' matches no asset (its path 'props/*' matches no asset's path, relative to the config "
        "as --dry-run shows it: did you mean 'assets/props/*'? 2 assets)"
    ), props
    # (a path that matches, the rule missing by another condition: no word on the path)
    assert huge.endswith("rule 'huge-props' matches no asset"), huge


def test_a_rerun_retrying_broken_inputs_alone_says_nothing_of_numba_s_compile(tmp_path: Path, capsys):
    # every rerun of a library with one broken file printed "[0/1] building 1 asset; on a new machine numba
    # compiles its kernels first (a minute or more, once)" for a retry that fails before any build
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES_OBJ)
    (tmp_path / "m" / "empty.obj").write_text("")
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text('version: 1\nassets:\n  - glob: "m/*.obj"\noutput: {dir: out}\n')

    def first_line() -> str:
        capsys.readouterr()
        run(cfg, echo=_quiet)
        return capsys.readouterr().err.splitlines()[0]

    note = "; on a new machine numba compiles its kernels first (a minute or more, once)"
    assert first_line() == f"[0/2] building 2 assets{note}"  # (new: both may build)
    assert first_line() == "[0/1] building 1 asset"  # (the broken file retried alone)
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES_OBJ + "f 1 3 4\n")
    assert first_line() == f"[0/2] building 2 assets{note}"  # (a mesh to build beside it)


def test_a_tag_is_read_on_the_mesh_prim_not_its_ancestors_as_the_readme_says(tmp_path: Path):
    # a studio tags the Xform that places an asset in its set; the rule's tag is read on the Mesh prim alone
    # (README, Command line): the prim glob is what matches such an asset
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(tmp_path / "set.usda"))
    for name in ("hero", "extra"):
        xf = UsdGeom.Xform.Define(stage, f"/World/{name}")
        mesh = UsdGeom.Mesh.Define(stage, f"/World/{name}/Geo")
        mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)])
        mesh.CreateFaceVertexCountsAttr([3, 3])
        mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
    xf.GetPrim().SetCustomDataByKey("tier", "hero")  # (on /World/extra's Xform)
    stage.GetPrimAtPath("/World/hero/Geo").SetCustomDataByKey("tier", "hero")
    stage.GetRootLayer().Save()
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets:\n  - stage: set.usda\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
        "rules:\n  - {name: tagged, match: {tag: {tier: hero}}, encoding: mixed}\n"
        '  - {name: by-prim, match: {prim: "/World/extra/*"}, encoding: skip-strip}\n'
    )
    plan = {p["id"]: p for p in run(cfg, echo=_quiet, dry_run=True).plan}
    assert plan["set.usda:/World/hero/Geo"]["encoding"] == "mixed"
    assert plan["set.usda:/World/extra/Geo"]["encoding"] == "skip-strip"
    # a tag on the Xforms alone: the rule matches nothing, and its warning says where tags are read (it
    # named the rule alone)
    stage.GetPrimAtPath("/World/hero/Geo").ClearCustomDataByKey("tier")
    stage.GetPrimAtPath("/World/hero").SetCustomDataByKey("tier", "hero")
    stage.GetRootLayer().Save()
    (warning,) = run(cfg, echo=_quiet, dry_run=True).warnings
    assert warning.endswith(
        "rule 'tagged' matches no asset (a tag is read on a stage asset's Mesh prim, its own customData: not "
        "an ancestor's, and a glob's files carry none; match.prim globs on prim paths)"
    ), warning


@pytest.mark.parametrize("names", ["path", "stem"])
def test_an_output_name_too_long_to_write_is_a_config_error_before_any_build(tmp_path: Path, names: str):
    # a library nine folders deep under output.names: path: the dry run passed, the run built the mesh and
    # failed its asset at the rename (OUTPUT_UNWRITABLE, "[Errno 36] File name too long")
    from swpm_usd.pipeline.assets import LONGEST_STEM

    deep = tmp_path / "lib"
    for i in range(9):
        deep = deep / f"very_long_folder_name_for_department_{i}"
    deep.mkdir(parents=True)
    long_stem = "s" * (LONGEST_STEM + 1) if names == "stem" else "suzanne"
    (deep / f"{long_stem}.obj").write_text(TWO_TRIANGLES_OBJ)
    (tmp_path / "lib" / "ok.obj").write_text(TWO_TRIANGLES_OBJ)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        f'version: 1\nassets:\n  - glob: "lib/**/*.obj"\noutput: {{dir: out, names: {names}, usd: true}}\n'
        "defaults: {encoding: vanilla}\n"
    )
    for dry_run in (True, False):
        with pytest.raises(ConfigError) as exc:
            run(cfg, echo=_quiet, dry_run=dry_run)
        (problem,) = exc.value.problems
        assert f"past the {LONGEST_STEM} a name may have here" in problem, problem
        assert ("start the glob from a deeper folder" if names == "path" else "rename the file") in problem
    assert not (tmp_path / "out").exists()  # (nothing built or written)
    # the longest name that fits builds, and builds again over its previous build (kept aside meanwhile)
    (deep / f"{long_stem}.obj").unlink()
    fits = tmp_path / "lib" / f"{'f' * LONGEST_STEM}.obj"
    fits.write_text(TWO_TRIANGLES_OBJ)
    cfg.write_text(cfg.read_text().replace(f"names: {names}", "names: stem"))
    assert run(cfg, echo=_quiet).built == 2
    assert run(cfg, echo=_quiet, force=True).built == 2
