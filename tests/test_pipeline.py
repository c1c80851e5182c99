"""The declarative pipeline: config errors, rules, incremental runs, failures, interruption, executors."""

from __future__ import annotations

import contextlib
import html
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import SHARED_MESHES

import swpm_usd
from swpm_usd.cli import main
from swpm_usd.encode import BUILDERS
from swpm_usd.pipeline import ConfigError, load_config, run
from swpm_usd.pipeline.schema import PACKAGED_SCHEMA, SCHEMA_PATH, schema_text


def sha256_of(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


#: how long a subprocess may take to build its first asset: the numba kernels are compiled on a cold cache
#: (minutes on a loaded 2-core machine); it only costs time when a test fails
FIRST_ASSET_S = 900


def _project(tmp_path: Path, meshes=("cow.obj", "spot.obj"), config: str = "") -> Path:
    (tmp_path / "meshes").mkdir()
    for m in meshes:
        shutil.copy(SHARED_MESHES / m, tmp_path / "meshes" / m)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(config)
    return cfg


MINIMAL = """\
version: 1
assets:
  - glob: "meshes/*.obj"
output:
  dir: out
rules:
  - name: small
    match: {triangles: {max: 15000}}
    encoding: skip-strip
  - name: default
    encoding: sliding-window
"""


def test_schema_file_matches_the_encoders():
    assert SCHEMA_PATH.read_text() == schema_text(), "regenerate: python -m swpm_usd.pipeline.schema"
    assert PACKAGED_SCHEMA.read_text() == schema_text()


def test_every_parameter_in_the_schema_says_what_it_does_and_its_default():
    # an editor completing a pipeline.yaml from the schema shows these (encode --help's lines)
    from swpm_usd.encodings import ENCODING_PARAMS, PARAM_HELP

    schema = json.loads(schema_text())
    for section in (schema["properties"]["defaults"], schema["properties"]["rules"]["items"]):
        by_encoding = {
            b["if"]["properties"]["encoding"]["const"]: b["then"]["properties"]["params"]["properties"]
            for b in section["allOf"]
            if "const" in b.get("if", {}).get("properties", {}).get("encoding", {})
        }
        assert set(by_encoding) - {"auto"} == set(ENCODING_PARAMS)  # (auto takes select alone)
        for enc, params in ENCODING_PARAMS.items():
            assert set(by_encoding[enc]) == set(params), enc
            for name, default in params.items():
                prop = by_encoding[enc][name]
                assert prop["description"] == PARAM_HELP[name] and prop["description"], (enc, name)
                assert prop["default"] == default, (enc, name)


def test_encoding_params_are_the_builders_defaults():
    from swpm_usd.encode import BUILDERS
    from swpm_usd.encodings import ENCODING_PARAMS

    assert list(ENCODING_PARAMS) == list(BUILDERS)
    for name, (_, defaults) in BUILDERS.items():
        assert defaults == ENCODING_PARAMS[name], name


#: a fresh interpreter runs the command line (``argv``) in-process and prints which heavy modules it imported
_IMPORTS_OF = """\
import sys
from swpm_usd.cli import main
try:
    main(sys.argv[1:], prog_name="swpm-pipeline")
except SystemExit as exc:
    code = exc.code
print({"exit": code, "numba": "numba" in sys.modules, "encode": "swpm_usd.encode" in sys.modules})
"""


def test_help_and_a_rerun_with_nothing_to_build_import_no_encoder(tmp_path):
    # numba and the encoders cost a command about 0.4 s: a run with nothing to build (and --help) needs none
    cfg = _project(tmp_path, ("suzanne.obj",), MINIMAL)
    assert run(cfg, echo=lambda m: None).built == 1
    for argv, code in ((["--help"], 0), (["run", "--help"], 0), (["run", str(cfg)], 0)):
        proc = subprocess.run(
            [sys.executable, "-c", _IMPORTS_OF, *argv], capture_output=True, text=True, timeout=FIRST_ASSET_S
        )
        last = proc.stdout.strip().splitlines()[-1]
        assert last == str({"exit": code, "numba": False, "encode": False}), (argv, proc.stdout, proc.stderr)
    # and a run that builds imports them (the same command, once the mesh changed)
    mesh = tmp_path / "meshes" / "suzanne.obj"
    mesh.write_text(mesh.read_text() + "\n# changed\n")
    proc = subprocess.run(
        [sys.executable, "-c", _IMPORTS_OF, "run", "--jobs", "1", str(cfg)],
        capture_output=True,
        text=True,
        timeout=FIRST_ASSET_S,
    )
    assert "1 built" in proc.stdout, proc.stdout + proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == str({"exit": 0, "numba": True, "encode": True})


def test_minimal_config_runs_and_writes_manifest_and_files(tmp_path):
    cfg = _project(tmp_path, ("cow.obj", "spot.obj", "stanford-bunny.obj"), MINIMAL)
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 0 and res.built == 3
    out = tmp_path / "out"
    manifest = json.loads((out / "manifest.json").read_text())
    assets = manifest["assets"]
    assert set(assets) == {"meshes/cow.obj", "meshes/spot.obj", "meshes/stanford-bunny.obj"}
    assert (
        assets["meshes/cow.obj"]["encoding"] == "skip-strip" and assets["meshes/cow.obj"]["rule"] == "small"
    )
    assert assets["meshes/stanford-bunny.obj"]["encoding"] == "sliding-window"
    for stem in ("cow", "spot", "stanford-bunny"):
        path = out / f"{stem}.swpm"
        assert swpm_usd.validate(path).valid
        rec = assets[f"meshes/{stem}.obj"]
        assert rec["outputs"]["swpm"]["path"] == f"{stem}.swpm"
        for key in ("lambda", "acmr", "global_bytes", "instance_bytes"):
            assert key in rec["summary"]
    assert (out / "report.html").read_text().count("<svg") >= 6


def test_config_errors_are_all_reported_with_positions(tmp_path):
    cfg = _project(
        tmp_path,
        config="""\
version: 1
assets:
  - glob: "meshes/*.obj"
output:
  dir: out
  colour: red
rules:
  - name: small
    encoding: vanilla
    params: {mu: 0.2}
  - name: bad
    encoding: squiggle
""",
    )
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    problems = exc.value.problems
    assert any(p.startswith(f"{cfg}:6:3: $.output.colour:") for p in problems)
    assert any(p.startswith(f"{cfg}:10:14: $.rules[0].params.mu:") for p in problems)
    assert any(p.startswith(f"{cfg}:12:15: $.rules[1].encoding:") for p in problems)
    result = CliRunner().invoke(main, ["run", str(cfg)])
    assert result.exit_code == 2
    assert "$.output.colour" in result.output and "$.rules[1].encoding" in result.output
    for jobs in ("0", "-3"):  # was taken as one job
        result = CliRunner().invoke(main, ["run", str(cfg), "--jobs", jobs])
        assert result.exit_code == 2 and "--jobs" in result.output


def test_params_out_of_build_bounds_fail_at_their_config_line(tmp_path):
    cfg = _project(
        tmp_path,
        config=MINIMAL
        + "    params: {cache_size: 100000}\n  - name: weights\n    encoding: vanilla\n"
        + "    params: {seam_weight: -1.0}\n",
    )
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    problems = exc.value.problems
    assert problems == [
        f"{cfg}:12:26: $.rules[1].params.cache_size: must be in [3, 1024], got 100000",
        f"{cfg}:15:27: $.rules[2].params.seam_weight: must be in [0, 1000000], got -1.0",
    ]


def test_semantic_errors_and_unreachable_rule_warning(tmp_path):
    cfg = _project(
        tmp_path,
        config="""\
version: 1
assets:
  - glob: "meshes/*.obj"
  - glob: "nothing/*.obj"
output: {dir: out}
rules:
  - name: everything
    encoding: vanilla
  - name: never
    encoding: skip-strip
""",
    )
    result = CliRunner().invoke(main, ["run", str(cfg)])
    assert result.exit_code == 2
    assert "pipeline.yaml:4:11: $.assets[1].glob: the glob matches no file" in result.output
    cfg.write_text(cfg.read_text().replace('  - glob: "nothing/*.obj"\n', ""))
    messages = []
    res = run(cfg, dry_run=True, echo=messages.append)
    assert res.built == 0 and not (tmp_path / "out").exists()
    assert any("rule 'never' is shadowed by rule 'everything'" in m for m in messages)
    assert any(m.startswith("meshes/cow.obj: vanilla") and "rule 'everything' matched" in m for m in messages)


def test_incremental_rerun_and_changes(tmp_path):
    cfg = _project(tmp_path, config=MINIMAL.replace("sliding-window", "vanilla"))
    assert run(cfg, echo=lambda m: None).built == 2
    again = run(cfg, echo=lambda m: None)
    assert again.built == 0 and again.skipped == 2
    # a changed input is rebuilt, the other is not
    spot = tmp_path / "meshes" / "spot.obj"
    spot.write_text(spot.read_text() + "\n# touched\n")
    third = run(cfg, echo=lambda m: None)
    assert third.built == 1 and third.records["meshes/spot.obj"]["status"] == "built"
    # changed parameters rebuild what they apply to
    cfg.write_text(
        cfg.read_text().replace("encoding: skip-strip", "encoding: skip-strip\n    params: {primitive: list}")
    )
    fourth = run(cfg, echo=lambda m: None)
    assert fourth.built == 2
    # a default written out (as a whole number, for a real-valued parameter) builds the same thing: nothing
    # is rebuilt; another value is
    cfg.write_text(cfg.read_text().replace("{primitive: list}", "{primitive: list, boundary_weight: 8}"))
    assert run(cfg, echo=lambda m: None).built == 0
    cfg.write_text(cfg.read_text().replace("boundary_weight: 8}", "boundary_weight: 8.5}"))
    assert run(cfg, echo=lambda m: None).built == 2
    # a deleted output is rebuilt
    (tmp_path / "out" / "cow.swpm").unlink()
    assert run(cfg, echo=lambda m: None).built == 1


def test_legacy_layout_writes_no_offset32_and_flipping_it_rewrites(tmp_path):
    """``output.legacy_layout``: each .swpm as a reader before 0.9.0 accepts it (never OFFSET32; cow's pool
    passes 65,535 indices, so INDEX32), recorded per output; a rerun skips, flipping the key rewrites."""
    from swpm_usd.format import layout as L

    def features(path: Path) -> int:
        return int.from_bytes(path.read_bytes()[20:24], "little")

    config = MINIMAL.replace("dir: out", "dir: out\n  usd: true\n  legacy_layout: true")
    cfg = _project(tmp_path, meshes=("cow.obj",), config=config.replace("max: 15000", "max: 10"))
    swpm, usdc = tmp_path / "out" / "cow.swpm", tmp_path / "out" / "cow.usdc"
    first = run(cfg, echo=lambda m: None)
    assert first.built == 1
    assert features(swpm) & L.FEATURE_INDEX32 and not features(swpm) & L.FEATURE_OFFSET32
    assert swpm_usd.format.validate(swpm).valid
    out = first.records["meshes/cow.obj"]["outputs"]["swpm"]
    assert (out["legacy_layout"], out["index_width"], out["offset_width"]) == (True, 4, 4)
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["assets"]["meshes/cow.obj"]["outputs"]["swpm"]["legacy_layout"] is True
    legacy_bytes, usd_bytes = swpm.read_bytes(), usdc.read_bytes()
    again = run(cfg, echo=lambda m: None)
    assert again.built == 0 and again.skipped == 1 and swpm.read_bytes() == legacy_bytes
    # flipped (the key removed: its default, false): the .swpm is written again, with OFFSET32
    cfg.write_text(cfg.read_text().replace("\n  legacy_layout: true", ""))
    flipped = run(cfg, echo=lambda m: None)
    assert flipped.built == 1
    assert features(swpm) & L.FEATURE_OFFSET32 and not features(swpm) & L.FEATURE_INDEX32
    out = flipped.records["meshes/cow.obj"]["outputs"]["swpm"]
    assert (out["legacy_layout"], out["index_width"], out["offset_width"]) == (False, 2, 4)
    assert usdc.read_bytes() == usd_bytes  # (the USD layer is the same either way)
    assert run(cfg, echo=lambda m: None).built == 0
    # and back: the legacy file again, byte for byte
    cfg.write_text(cfg.read_text().replace("dir: out", "dir: out\n  legacy_layout: true"))
    assert run(cfg, echo=lambda m: None).built == 1 and swpm.read_bytes() == legacy_bytes
    # a hand-edited record whose layout is not a boolean is not the run's: rebuilt, with a warning
    manifest_path = tmp_path / "out" / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    manifest["assets"]["meshes/cow.obj"]["outputs"]["swpm"]["legacy_layout"] = "yes"
    manifest_path.write_text(json.dumps(manifest))
    messages = []
    assert run(cfg, echo=messages.append).built == 1
    assert any("outputs.swpm.legacy_layout is 'yes', not a boolean" in m for m in messages), messages


def test_legacy_layout_in_the_schema_says_usd_is_unaffected(tmp_path):
    schema = json.loads(schema_text())
    key = schema["properties"]["output"]["properties"]["legacy_layout"]
    assert key["type"] == "boolean" and key["default"] is False
    assert "USD outputs are unaffected" in key["description"]
    cfg_text = "version: 1\nassets:\n  - glob: '*.obj'\noutput:\n  dir: out\n  legacy_layout: 1\n"
    (tmp_path / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "pipeline.yaml").write_text(cfg_text)
    with pytest.raises(ConfigError, match="legacy_layout"):
        load_config(tmp_path / "pipeline.yaml")


def test_outputs_of_removed_assets_are_named_and_pruned_only_on_request(tmp_path):
    cfg = _project(tmp_path, config=MINIMAL.replace("sliding-window", "vanilla"))
    cfg.write_text(cfg.read_text().replace("dir: out", "dir: out\n  usd: true"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    # spot leaves the config (its input moves out of the glob): its outputs stay, named, and recorded
    (tmp_path / "meshes" / "spot.obj").rename(tmp_path / "spot.obj")
    first = run(cfg, echo=lambda m: None)
    assert sorted(first.unlisted) == ["spot.swpm", "spot.usdc"] and first.pruned == []
    assert (out / "spot.swpm").is_file() and (out / "spot.usdc").is_file()
    manifest = json.loads((out / "manifest.json").read_text())
    assert "meshes/spot.obj" not in manifest["assets"]
    assert sorted(o["path"] for o in manifest["orphaned_outputs"]) == ["spot.swpm", "spot.usdc"]
    # a later run still knows them; a file changed since is no longer the run's
    with open(out / "spot.usdc", "ab") as f:
        f.write(b"edited")
    second = run(cfg, echo=lambda m: None)
    assert second.unlisted == ["spot.swpm"]
    r = CliRunner().invoke(main, ["run", str(cfg)])
    assert r.exit_code == 0
    left = "1 output of an asset no longer in the config left in output.dir (--prune deletes it)"
    assert left in r.output
    r = CliRunner().invoke(main, ["run", str(cfg), "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["unlisted"] == ["spot.swpm"], r.output
    # (each named: its asset, and why it is left)
    assert json.loads(r.stdout)["orphans"] == [
        {"path": "spot.swpm", "asset": "meshes/spot.obj", "because": {"code": "asset-removed", "detail": ""}}
    ]
    # a dry run names what --prune would delete and deletes nothing
    lines: list[str] = []
    dry = run(cfg, dry_run=True, prune=True, echo=lines.append)
    assert dry.pruned == ["spot.swpm"] and (out / "spot.swpm").is_file()
    named = "spot.swpm: output of an asset no longer in the config (meshes/spot.obj); --prune deletes it"
    assert named in lines
    # an entry an older version recorded (without its asset and why) is said to be an earlier run's
    path = out / "manifest.json"
    manifest = json.loads(path.read_text())
    manifest["orphaned_outputs"] = [
        {k: v for k, v in o.items() if k not in ("asset", "because")} for o in manifest["orphaned_outputs"]
    ]
    path.write_text(json.dumps(manifest))
    older = run(cfg, dry_run=True, echo=lines.append)
    assert [(o["asset"], o["because"]["code"]) for o in older.orphans] == [(None, "earlier-run")]
    assert "spot.swpm: output an earlier run left (its reason not recorded)" in lines
    # --prune deletes the recorded, unchanged ones before building; the current assets' outputs stay
    pruned = run(cfg, prune=True, echo=lambda m: None)
    assert pruned.pruned == ["spot.swpm"] and not (out / "spot.swpm").exists()
    assert (out / "spot.usdc").is_file() and (out / "cow.swpm").is_file() and (out / "cow.usdc").is_file()
    assert "orphaned_outputs" not in json.loads((out / "manifest.json").read_text())
    assert run(cfg, echo=lambda m: None).unlisted == []
    # an asset back under its old name is built again, and its old files never count as orphans
    (tmp_path / "spot.obj").rename(tmp_path / "meshes" / "spot.obj")
    back = run(cfg, prune=True, echo=lambda m: None)
    assert back.built == 1 and back.pruned == [] and (out / "spot.swpm").is_file()


def test_a_removed_assets_output_that_a_current_asset_writes_is_never_pruned(tmp_path):
    cfg = _project(tmp_path, meshes=("cow.obj",), config=MINIMAL.replace("sliding-window", "vanilla"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    # the manifest says another, removed asset wrote out/cow.swpm too (a renamed asset, an edited manifest)
    manifest = json.loads((out / "manifest.json").read_text())
    rec = dict(manifest["assets"]["meshes/cow.obj"])
    manifest["assets"]["meshes/old-cow.obj"] = rec
    (out / "manifest.json").write_text(json.dumps(manifest))
    res = run(cfg, prune=True, echo=lambda m: None)
    assert res.pruned == [] and (out / "cow.swpm").is_file()


def test_a_removed_assets_output_that_a_current_asset_reads_is_never_pruned(tmp_path):
    # spot.obj's USD layer becomes a stage input once spot.obj leaves the config: --prune keeps it
    cfg = _project(tmp_path, config=MINIMAL.replace("sliding-window", "vanilla"))
    cfg.write_text(cfg.read_text().replace("dir: out", "dir: out\n  usd: true"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    sha = sha256_of(out / "spot.usdc")
    cfg.write_text(cfg.read_text().replace('"meshes/*.obj"', '"meshes/cow.obj"\n  - stage: out/spot.usdc'))
    res = run(cfg, prune=True, echo=lambda m: None)
    assert res.pruned == ["spot.swpm"] and not (out / "spot.swpm").exists()
    assert (out / "spot.usdc").is_file() and sha256_of(out / "spot.usdc") == sha


def test_odd_recorded_paths_of_removed_assets_are_ignored(tmp_path):
    cfg = _project(tmp_path, meshes=("cow.obj",), config=MINIMAL.replace("sliding-window", "vanilla"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["assets"]["meshes/gone.obj"] = {"outputs": {"swpm": {"path": "a\u0000b.swpm", "size": 1}}}
    manifest["orphaned_outputs"] = [{"path": "c\u0000d.swpm"}, None, {"path": 3}]
    (out / "manifest.json").write_text(json.dumps(manifest))
    assert run(cfg, prune=True, echo=lambda m: None).pruned == []
    assert run(cfg, dry_run=True, echo=lambda m: None).unlisted == []


def test_one_bad_asset_does_not_stop_the_others(tmp_path):
    cfg = _project(tmp_path, config=MINIMAL.replace("sliding-window", "vanilla"))
    (tmp_path / "meshes" / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    result = CliRunner().invoke(main, ["run", str(cfg), "--json"])
    assert result.exit_code == 1
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["assets"]["meshes/broken.obj"]["status"] == "failed"
    assert "broken.obj" in manifest["assets"]["meshes/broken.obj"]["error"]
    assert manifest["assets"]["meshes/cow.obj"]["status"] == "built"
    assert swpm_usd.validate(tmp_path / "out" / "spot.swpm").valid


def test_streaming_policy_and_budgets_fail_the_asset(tmp_path):
    cfg = _project(
        tmp_path,
        ("cow.obj",),
        """\
version: 1
assets: [{glob: "meshes/*.obj"}]
output: {dir: out}
defaults: {encoding: vanilla}
streaming: {coarsest_lod_bytes: 10}
""",
    )
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1
    assert "coarsest_lod_bytes" in res.records["meshes/cow.obj"]["error"]
    assert not (tmp_path / "out" / "cow.swpm").exists()


def _auto_project(tmp_path: Path, rule: str = "{name: auto, encoding: auto}") -> Path:
    """Cow, 500 instances, one ``auto`` rule."""
    config = f"""\
version: 1
assets: [{{glob: "meshes/*.obj", instances: 500}}]
output: {{dir: out}}
rules: [{rule}]
"""
    return _project(tmp_path, ("cow.obj",), config)


def test_auto_encoding_records_choice_and_reason(tmp_path):
    cfg = _auto_project(tmp_path)
    res = run(cfg, echo=lambda m: None)
    rec = res.records["meshes/cow.obj"]
    assert rec["status"] == "built", rec.get("error")
    cands = rec["auto_candidates"]
    assert set(cands) >= {"vanilla", "skip-strip"}
    totals = {e: c["global_bytes"] + 500 * c["instance_bytes"] for e, c in cands.items()}
    assert all(totals[e] == cands[e]["total_bytes"] for e in cands)
    assert "auto:" in rec["why"] and rec["encoding"] in rec["why"]


def test_misses_at_error_draws_each_encodings_coarsest_lod_within_the_reference_error():
    from swpm_usd.pipeline.worker import AUTO_ERROR_FRACTIONS, _misses_scores, misses_at_error

    mesh = swpm_usd.load_mesh(SHARED_MESHES / "cow.obj")
    pms = {e: swpm_usd.build(mesh, encoding=e) for e in ("vanilla", "skip-strip", "sliding-window")}
    got = misses_at_error(pms)
    T = mesh.triangle_count
    refs = got["vanilla"]["reference_errors"]
    assert len(refs) == len(AUTO_ERROR_FRACTIONS)
    for i, f in enumerate(AUTO_ERROR_FRACTIONS):
        # the reference is the smallest error any encoding stores at f of the triangles
        errs = [pm.error_at(pm.lod_for_triangles(int(round(f * T)))) for pm in pms.values()]
        assert refs[i] == pytest.approx(min(errs))
    for enc, pm in pms.items():
        for e, t in zip(refs, got[enc]["triangles"], strict=True):
            # the coarsest LOD within the error: coarser LODs exceed it
            k = int(np.flatnonzero([pm.triangle_count_at(j) == t for j in range(pm.lod_count)])[-1])
            assert pm.error_at(k) <= e and (k == pm.lod_count - 1 or pm.error_at(k + 1) > e)
    # vanilla and skip-strip share the collapse order, so they draw the same triangle counts; vanilla's bin
    # order draws them colder (README: 3.5x meshoptimizer's misses against 1.15x)
    assert got["vanilla"]["triangles"] == got["skip-strip"]["triangles"]
    skip, van = got["skip-strip"]["misses"], got["vanilla"]["misses"]
    assert all(s < 0.5 * v for s, v in zip(skip, van, strict=True))
    # the sliding window's levels carry more error along them: at equal error it draws more triangles
    assert sum(got["sliding-window"]["triangles"]) > 1.2 * sum(got["skip-strip"]["triangles"])
    scores = _misses_scores(got)
    assert min(scores.values()) >= 1.0 and scores["skip-strip"] < scores["sliding-window"] < scores["vanilla"]


def test_misses_at_error_ignores_a_candidate_that_stops_simplifying_above_a_fraction():
    from swpm_usd.pipeline.worker import misses_at_error

    pm = swpm_usd.build(SHARED_MESHES / "cow.obj", encoding="vanilla")

    class OneLod:  # stops at LOD 0: its error there, 0, must not become the reference
        lod_count = 1
        restart_index = None

        def triangle_count_at(self, k):
            return pm.triangle_count_at(0)

        def lod_for_triangles(self, target):
            return 0

        def error_at(self, k):
            return 0.0

        def lod_for_error(self, e):
            return 0

        def draw_stream(self, k):
            return pm.draw_stream(0)

    got = misses_at_error({"vanilla": pm, "stub": OneLod()})
    alone = misses_at_error({"vanilla": pm})
    assert got["vanilla"] == alone["vanilla"] and min(alone["vanilla"]["reference_errors"]) > 0
    assert got["stub"]["triangles"] == [pm.triangle_count_at(0)] * 3
    # with no candidate getting down to a fraction, that fraction is skipped
    assert misses_at_error({"stub": OneLod()})["stub"]["misses"] == []


def test_auto_can_rank_by_misses_at_equal_error(tmp_path):
    cfg = _auto_project(tmp_path, "{name: auto, encoding: auto, params: {select: misses-at-error}}")
    res = run(cfg, echo=lambda m: None)
    rec = res.records["meshes/cow.obj"]
    assert rec["status"] == "built", rec.get("error")
    cands = rec["auto_candidates"]
    scores = {e: c["misses_at_error_score"] for e, c in cands.items()}
    assert len(scores) >= 3 and min(scores.values()) >= 1.0
    assert all(len(c["misses_at_error"]) == 3 and min(c["misses_at_error"]) > 0 for c in cands.values())
    # no budgets: the fewest misses at equal error wins, ties within 5 % going to the smaller memory
    assert scores[rec["encoding"]] <= 1.05 * min(scores.values())
    assert "cache misses at equal error" in rec["why"]
    # the report shows every candidate as measured, the chosen one in bold
    report = (tmp_path / "out" / "report.html").read_text()
    assert "Encodings compared by <code>auto</code>" in report and "misses at equal error" in report
    assert f"<b>{rec['encoding']}</b>" in report
    for enc, c in cands.items():
        assert f"<td>{c['misses_at_error_score']:.2f}</td><td>{c['global_bytes']}</td>" in report, enc
    # the selector is part of the treatment: changing it rebuilds
    cfg.write_text(cfg.read_text().replace("misses-at-error", "acmr"))
    res2 = run(cfg, echo=lambda m: None)
    rec2 = res2.records["meshes/cow.obj"]
    assert res2.built == 1 and "misses_at_error" not in rec2["auto_candidates"][rec2["encoding"]]
    assert "ACMR" in rec2["why"]


def test_auto_takes_select_alone(tmp_path):
    cfg = _project(
        tmp_path,
        config="""\
version: 1
assets:
  - glob: "meshes/*.obj"
output:
  dir: out
rules:
  - name: a
    encoding: auto
    params: {select: fastest}
  - name: b
    encoding: auto
    params: {mu: 0.2}
""",
    )
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    problems = exc.value.problems
    assert problems == [
        f"{cfg}:9:22: $.rules[0].params.select: 'fastest' is not one of ['acmr', 'misses-at-error']",
        f"{cfg}:12:14: $.rules[1].params.mu: unknown key (not a parameter of auto, which takes select alone)",
    ]


def test_usd_stage_assets_count_instances(tmp_path):
    from pxr import Usd, UsdGeom

    asset = tmp_path / "spot_asset.usda"
    mesh = swpm_usd.load_mesh(SHARED_MESHES / "spot.obj")
    st = Usd.Stage.CreateNew(str(asset))
    root = UsdGeom.Xform.Define(st, "/Spot")
    st.SetDefaultPrim(root.GetPrim())
    m = UsdGeom.Mesh.Define(st, "/Spot/Body")
    m.CreatePointsAttr(mesh.points)
    m.CreateFaceVertexCountsAttr([3] * mesh.triangle_count)
    m.CreateFaceVertexIndicesAttr(mesh.triangles.reshape(-1))
    st.GetRootLayer().Save()
    scene = tmp_path / "scene.usda"
    st = Usd.Stage.CreateNew(str(scene))
    for i in range(3):
        p = st.DefinePrim(f"/World/spot_{i}", "Xform")
        p.GetReferences().AddReference("./spot_asset.usda")
        p.SetInstanceable(True)
    st.GetRootLayer().Save()
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        """\
version: 1
assets: [{stage: scene.usda}]
output: {dir: out}
rules:
  - {name: crowd, match: {instances: {min: 2}}, encoding: vanilla}
  - {name: single, encoding: skip-strip}
"""
    )
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 0 and res.built == 1
    (rec,) = res.records.values()
    assert rec["instances"] == 3 and rec["rule"] == "crowd"


def test_usd_stage_meshes_a_renderer_does_not_draw_are_not_assets(tmp_path):
    """Since the loader leaves out Mesh prims a renderer does not draw, each invisible, guide or proxy Mesh
    prim of a stage asset (a viewport stand-in beside its render mesh) was an asset that failed ('no
    triangles: ... not rendered'), where it had been built before."""
    from pxr import Usd, UsdGeom

    scene = tmp_path / "scene.usda"
    st = Usd.Stage.CreateNew(str(scene))
    UsdGeom.Xform.Define(st, "/World/off")
    for name in ("render", "proxy", "guide", "hidden", "off/child"):
        m = UsdGeom.Mesh.Define(st, f"/World/{name}")
        m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)])
        m.CreateFaceVertexCountsAttr([3, 3])
        m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
        if name in ("render", "proxy", "guide"):
            m.CreatePurposeAttr(name)
    UsdGeom.Imageable(st.GetPrimAtPath("/World/hidden")).MakeInvisible()
    UsdGeom.Imageable(st.GetPrimAtPath("/World/off")).MakeInvisible()
    st.GetRootLayer().Save()
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{stage: scene.usda}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 0 and res.built == 1
    assert list(res.records) == ["scene.usda:/World/render"]


def test_usd_stage_mesh_of_only_holes_is_not_an_asset(tmp_path):
    """A Mesh prim whose holeIndices list every face renders nothing, as an invisible one: it was an asset
    of the stage that failed every run ('no triangles: ... have no faces (or only holes)'); a USD file that
    holds only such a mesh is an asset that fails, saying every face is a hole."""
    from pxr import Usd, UsdGeom

    scene = tmp_path / "scene.usda"
    st = Usd.Stage.CreateNew(str(scene))
    for name in ("solid", "holes"):
        m = UsdGeom.Mesh.Define(st, f"/World/{name}")
        m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)])
        m.CreateFaceVertexCountsAttr([3, 3])
        m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
    UsdGeom.Mesh(st.GetPrimAtPath("/World/holes")).CreateHoleIndicesAttr([0, 1])
    st.GetRootLayer().Save()
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{stage: scene.usda}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 0 and res.built == 1
    assert list(res.records) == ["scene.usda:/World/solid"]
    st.RemovePrim("/World/solid")
    st.GetRootLayer().Export(str(tmp_path / "alone.usda"))
    cfg.write_text(
        "version: 1\nassets: [{glob: alone.usda}]\noutput: {dir: out2}\ndefaults: {encoding: vanilla}\n"
    )
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and res.built == 0
    (rec,) = res.records.values()
    assert "every face is a hole" in json.dumps(rec)


def test_interrupted_run_keeps_earlier_outputs_and_rerun_finishes(tmp_path):
    cfg = _project(tmp_path, ("cow.obj", "spot.obj", "bob.obj", "fandisk.obj", "teapot.obj"), "")
    cfg.write_text(
        "version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: skip-strip}\n"
    )
    manifest = tmp_path / "out" / "manifest.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "swpm_usd.cli", "run", str(cfg)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.time() + FIRST_ASSET_S
    done_before = 0
    while time.time() < deadline and proc.poll() is None:
        if manifest.exists():
            done_before = len(json.loads(manifest.read_text())["assets"])
            if done_before >= 1:
                break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert done_before >= 1
    recorded = json.loads(manifest.read_text())["assets"]
    for rec in recorded.values():
        assert swpm_usd.validate(tmp_path / "out" / rec["outputs"]["swpm"]["path"]).valid
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 0
    assert res.built + res.skipped == 5 and res.skipped >= len(recorded)
    assert not list((tmp_path / "out").glob(".*.tmp"))


def _group_members(pgid: int) -> list[int]:
    """The processes of the group ``pgid`` that have not exited. A zombie has: where nothing reaps orphans
    (a container whose PID 1 is not an init), the fork server the run left stays one."""
    proc = Path("/proc")
    if not (proc / "self" / "stat").is_file():
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return []
        return [pgid]
    members = []
    for d in proc.iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:  # gone meanwhile
                continue
            state, _ppid, group = stat[stat.rindex(")") + 2 :].split()[:3]
            if int(group) == pgid and state not in "ZX":
                members.append(int(d.name))
    return members


def _group_gone(pgid: int, seconds: float) -> bool:
    """Has every process of the group ``pgid`` exited (within ``seconds``)?"""
    deadline = time.time() + seconds
    while time.time() < deadline:
        if not _group_members(pgid):
            return True
        time.sleep(0.05)
    return False


def _holding_driver(folder: Path) -> Path:
    """``folder``/driver.py: the CLI, whose second build in a process touches $HOLDING, then builds again and
    again until $RELEASED exists, or for $HOLD_SECONDS at most (a test that failed or was killed before it
    released the run leaves no process building for ever: the run then ends, and the test fails)."""
    driver = folder / "driver.py"
    driver.write_text(
        "import os, pathlib, sys, time\n"
        "import swpm_usd\n"
        "real, builds = swpm_usd.build, []\n"
        "def build(*args, **kwargs):  # (the worker builds through the package's build)\n"
        "    builds.append(1)\n"
        "    if len(builds) == 2:\n"
        "        pathlib.Path(os.environ['HOLDING']).touch()\n"
        "        give_up = time.monotonic() + float(os.environ['HOLD_SECONDS'])\n"
        "        while not os.path.exists(os.environ['RELEASED']) and time.monotonic() < give_up:\n"
        "            real(*args, **kwargs)\n"
        "    return real(*args, **kwargs)\n"
        "swpm_usd.build = build\n"
        "if __name__ == '__main__':  # (not in the workers, which import this)\n"
        "    from swpm_usd.cli import main\n"
        "    main(sys.argv[1:])\n"
    )
    return driver


def test_the_ctrl_c_tests_driver_holds_a_build_for_its_time_at_most(tmp_path, monkeypatch):
    # the driver held the second build until the test released it, with no end: a test that failed before
    # (or was killed) left a process group rebuilding a mesh for ever
    import importlib.util
    import threading

    calls = []

    def fake_build(*args, **kwargs):
        calls.append(args)
        time.sleep(0.01)
        return len(calls)

    monkeypatch.setattr(swpm_usd, "build", fake_build)
    monkeypatch.setenv("HOLDING", str(tmp_path / "holding"))
    monkeypatch.setenv("RELEASED", str(tmp_path / "never-released"))
    monkeypatch.setenv("HOLD_SECONDS", "1")
    spec = importlib.util.spec_from_file_location("holding_driver", _holding_driver(tmp_path))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # (it replaces swpm_usd.build: monkeypatch puts the real one back)
    assert swpm_usd.build(1) == 1
    second = threading.Thread(target=swpm_usd.build, args=(2,), daemon=True)
    second.start()
    second.join(timeout=60)
    assert not second.is_alive(), "the driver held the build past its time"
    assert (tmp_path / "holding").exists() and len(calls) > 3  # it did hold it, building


@pytest.mark.parametrize("jobs", [2, 1])
def test_ctrl_c_during_a_run_stops_it_cleanly(tmp_path, jobs):
    # Ctrl-C sends SIGINT to the terminal's whole process group: the workers used to take it too and print
    # tracebacks, and kept writing outputs after the run had stopped; in one process (--jobs 1) numba turned
    # it into a SystemError, recorded as the asset's failure, and the run went on
    from swpm_usd.pipeline.outputs import _TEMPORARY

    cfg = _project(tmp_path, ("cow.obj", "spot.obj", "bob.obj", "fandisk.obj", "teapot.obj"), "")
    for i in range(4):
        shutil.copy(tmp_path / "meshes" / "spot.obj", tmp_path / "meshes" / f"spot{i}.obj")
    cfg.write_text(
        "version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out, usd: true, scene: true}\n"
        "defaults: {encoding: sliding-window}\n"
    )
    # the run must still be going when Ctrl-C comes: the second asset a process builds is built again and
    # again (real builds, so the Ctrl-C lands in one as before) until the test has pressed Ctrl-C. (The rest
    # of the run once the first asset was recorded took a second or so: with a cold numba cache under load
    # the run could end before the test's Ctrl-C)
    holding, released = tmp_path / "holding", tmp_path / "released"
    driver = _holding_driver(tmp_path)
    out = tmp_path / "out"
    manifest = out / "manifest.json"
    proc = subprocess.Popen(
        [sys.executable, str(driver), "run", str(cfg), "-j", str(jobs)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its own process group, as a terminal's foreground job
        # (the workers import the driver from PYTHONPATH)
        env={
            **os.environ,
            "HOLDING": str(holding),
            "RELEASED": str(released),
            "HOLD_SECONDS": str(FIRST_ASSET_S + 300),
            "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path]),
        },
    )
    try:
        deadline = time.time() + FIRST_ASSET_S
        while time.time() < deadline and proc.poll() is None:  # an asset recorded, another building
            if holding.exists() and manifest.exists() and json.loads(manifest.read_text())["assets"]:
                break
            time.sleep(0.05)
        assert proc.poll() is None, "the run ended before it could be interrupted"
        assert holding.exists(), "no second asset started"
        os.killpg(proc.pid, signal.SIGINT)
        time.sleep(0.1)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)  # a second Ctrl-C while it stops changes nothing
        released.touch()  # (with --jobs 1 the Ctrl-C stops the run once the asset it came in is built)
        stderr = proc.communicate(timeout=120)[1].decode()
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and "Error" not in stderr, stderr
    lines = [line for line in stderr.splitlines() if not line.startswith("[")]  # progress lines aside
    assert lines == [
        "swpm-pipeline run: interrupted; the assets finished are recorded in the manifest, and a rerun "
        "builds the rest"
    ], stderr
    assert _group_gone(proc.pid, 30), "a worker outlived the run"  # nothing writes into out/ any more
    assert not [p.name for pattern in _TEMPORARY for p in out.glob(pattern)]
    recorded = json.loads(manifest.read_text())["assets"]
    assert recorded and all(rec["status"] == "built" for rec in recorded.values())
    for rec in recorded.values():
        for o in rec["outputs"].values():
            assert sha256_of(out / o["path"]) == o["sha256"]
    for path in out.glob("*.swpm"):  # whole files only (an asset finished as the run stopped is not listed)
        assert swpm_usd.validate(path).valid, path
    res = run(cfg, jobs=2, echo=lambda m: None)
    assert res.failed == 0 and res.built + res.skipped == 9 and res.skipped >= len(recorded)


def test_ctrl_c_while_the_workers_warm_up_stops_the_run_at_once(tmp_path):
    # the fork server loads (with a cold numba cache: compiles, minutes) the kernels before it forks the
    # workers; a Ctrl-C then was deferred until the workers had started, so the run went on for minutes
    (tmp_path / "slow_warm.py").write_text(
        "import os, pathlib, time\npathlib.Path(os.environ['WARMING']).touch()\ntime.sleep(600)\n"
    )
    driver = tmp_path / "driver.py"
    driver.write_text(
        "import signal, sys\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "from multiprocessing import forkserver\n"
        "real = forkserver.set_forkserver_preload\n"
        "forkserver.set_forkserver_preload = lambda names: real(['slow_warm'])  # a warm-up of 10 minutes\n"
        "if __name__ == '__main__':  # (not in the processes the fork server starts, which import this)\n"
        "    from swpm_usd.cli import main\n"
        "    main(sys.argv[1:])\n"
    )
    cfg = _project(tmp_path, ("cow.obj", "spot.obj"), MINIMAL)
    warming = tmp_path / "warming"
    proc = subprocess.Popen(
        [sys.executable, str(driver), "run", str(cfg), "-j", "2"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        start_new_session=True,
        # (Python 3.11's fork server imports its preload modules from PYTHONPATH, not the caller's sys.path)
        env={
            **os.environ,
            "WARMING": str(warming),
            "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path]),
        },
    )
    try:
        deadline = time.time() + 120
        while time.time() < deadline and proc.poll() is None and not warming.exists():
            time.sleep(0.05)
        assert warming.exists() and proc.poll() is None, proc.stderr.read().decode()
        os.killpg(proc.pid, signal.SIGINT)
        stderr = proc.communicate(timeout=60)[1].decode()
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, stderr
    lines = stderr.splitlines()
    # the run's start line, and no asset done (the warm-up never ends): only the interruption after it
    assert lines[:1] and lines[0].startswith("[0/2] building 2 assets"), stderr
    assert lines[1:] == [
        "swpm-pipeline run: interrupted; the assets finished are recorded in the manifest, and a rerun "
        "builds the rest"
    ], stderr
    assert _group_gone(proc.pid, 30), "the fork server outlived the run"


def test_ctrl_c_in_any_command_exits_130_with_one_line(tmp_path, monkeypatch):
    build_module = sys.modules["swpm_usd.build"]  # (swpm_usd.build is also the function)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(build_module, "build", interrupted)
    obj = tmp_path / "a.obj"
    obj.write_text(TWO_TRIANGLES)
    for args in (["build", str(obj)], ["encode", str(obj), "-o", str(tmp_path / "a.swpm")]):
        r = CliRunner().invoke(main, args)
        assert r.exit_code == 130 and r.stderr == "swpm-pipeline: interrupted\n", (args, r.output)
        assert r.stdout == "" and not (tmp_path / "a.swpm").exists()
        # the exiting process ignores another Ctrl-C (the conftest fixture gives pytest its handler back)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        # --json: JSON on stdout, as for the command's other errors (and run --json's interruption)
        r = CliRunner().invoke(main, [*args, "--json"])
        assert r.exit_code == 130 and r.stderr == "swpm-pipeline: interrupted\n", (args, r.output)
        expected = {"input": str(obj), "error": "interrupted", "code": "INTERRUPTED", "severity": "error"}
        if args[0] == "encode":
            expected = {"output": str(tmp_path / "a.swpm"), **expected}
        assert json.loads(r.stdout) == expected


def test_ctrl_c_while_the_command_imports_the_package_exits_130_with_one_line(tmp_path):
    # a Ctrl-C in the first second of swpm-pipeline (numpy, numba, usd-core importing) printed the traceback
    # of the import it cut short: the console script imports the package before any code of the command runs
    import tomllib

    from conftest import ROOT

    entry = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]["swpm-pipeline"]
    module, func = entry.split(":")
    importing = tmp_path / "importing"
    script = tmp_path / "bin" / "swpm-pipeline"
    script.parent.mkdir()
    # the launcher pip writes for the entry point, after a hook that holds the package's import of numpy
    # until the test has pressed Ctrl-C (so it lands in the import, however fast the machine)
    script.write_text(
        "import os, sys, time\n"
        "class Hold:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'numpy':\n"
        "            open(os.environ['IMPORTING'], 'w').close()\n"
        "            time.sleep(120)\n"
        "sys.meta_path.insert(0, Hold())\n"
        "import re\n"
        f"from {module} import {func}\n"
        "if __name__ == '__main__':\n"
        "    sys.argv[0] = re.sub(r'(-script\\.pyw|\\.exe)?$', '', sys.argv[0])\n"
        f"    sys.exit({func}())\n"
    )
    package_root = str(Path(swpm_usd.__file__).resolve().parents[1])
    env = {
        **os.environ,
        "IMPORTING": str(importing),
        "PYTHONPATH": os.pathsep.join([package_root, *filter(None, [os.environ.get("PYTHONPATH")])]),
    }
    proc = subprocess.Popen(
        [sys.executable, str(script), "--version"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        start_new_session=True,
    )
    try:
        deadline = time.time() + 120
        while time.time() < deadline and proc.poll() is None and not importing.exists():
            time.sleep(0.02)
        assert importing.exists() and proc.poll() is None, proc.communicate()
        os.killpg(proc.pid, signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert (proc.returncode, stderr.decode(), stdout) == (130, "swpm-pipeline: interrupted\n", b"")


def test_the_command_gives_ctrl_c_back_to_python_when_it_starts(tmp_path):
    # (the import's handler exits at once: a run needs its KeyboardInterrupt to stop its workers and record)
    from swpm_usd import _startup

    obj = tmp_path / "a.obj"
    obj.write_text(TWO_TRIANGLES)
    signal.signal(signal.SIGINT, _startup._interrupted)
    assert CliRunner().invoke(main, ["build", str(obj)]).exit_code == 0
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert _startup.is_command(["/venv/bin/swpm-pipeline"], []) and not _startup.is_command(["pytest"], [])
    assert _startup.is_command(["-m"], ["python", "-X", "dev", "-m", "swpm_usd.cli", "run"])
    assert not _startup.is_command(["-c"], ["python", "-c", "import swpm_usd", "-m", "swpm_usd.cli"])


def test_the_command_s_spawned_processes_keep_python_s_ctrl_c(tmp_path):
    # a process the command starts with multiprocessing's spawn (Dask's LocalCluster workers, --executor
    # dask) is given the command's sys.argv and imports its console script, so the package's import set the
    # handler there too, never given back: on Ctrl-C each such worker wrote "swpm-pipeline: interrupted"
    # and exited at once
    from swpm_usd import _startup

    script = tmp_path / "bin" / "swpm-pipeline"
    script.parent.mkdir()
    script.write_text(
        "import multiprocessing, signal, sys\n"
        "from swpm_usd.cli import main\n"
        "def handler():\n"
        "    return signal.getsignal(signal.SIGINT).__name__\n"
        "if __name__ == '__main__':\n"
        "    from swpm_usd._startup import restore_interrupts\n"
        "    restore_interrupts()  # (as the command does when it starts)\n"
        "    with multiprocessing.get_context('spawn').Pool(1) as pool:\n"
        "        print(handler(), pool.apply(handler))\n"
    )
    package_root = str(Path(swpm_usd.__file__).resolve().parents[1])
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([package_root, *filter(None, [os.environ.get("PYTHONPATH")])]),
    }
    r = subprocess.run([sys.executable, str(script), "run"], capture_output=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr.decode()
    assert r.stdout.decode().split() == ["default_int_handler", "default_int_handler"]
    spawned = [
        "python",
        "-c",
        "from multiprocessing.spawn import spawn_main; spawn_main()",
        "--multiprocessing-fork",
    ]
    assert not _startup.is_command(["/venv/bin/swpm-pipeline", "run"], spawned)
    assert _startup.is_command(
        ["/venv/bin/swpm-pipeline", "run"], ["python", "/venv/bin/swpm-pipeline", "run"]
    )


@pytest.mark.parametrize("disposition", ["ignored", "own handler"])
def test_a_run_keeps_an_ignored_or_own_ctrl_c(tmp_path, monkeypatch, disposition):
    # a background job of a script starts with Ctrl-C ignored, a caller may handle it: --jobs 1 turned it
    # into a KeyboardInterrupt all the same
    from swpm_usd.pipeline import runner

    cfg = _project(tmp_path, ("cow.obj", "spot.obj"), MINIMAL)
    real = runner.process_asset

    def interrupted(task):
        os.kill(os.getpid(), signal.SIGINT)
        return real(task)

    monkeypatch.setattr(runner, "process_asset", interrupted)
    received = []
    signal.signal(
        signal.SIGINT, signal.SIG_IGN if disposition == "ignored" else lambda *a: received.append(1)
    )
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.failed) == (2, 0)
    assert received == ([] if disposition == "ignored" else [1, 1])


def test_a_second_ctrl_c_does_not_cut_the_first_ones_clean_up_short(tmp_path, monkeypatch):
    # a Ctrl-C pressed again while the first one's KeyboardInterrupt unwinds raised another in the middle of
    # whatever clean-up ran then (in the run's generator: restoring the Ctrl-C handler, stopping the workers)
    from swpm_usd.pipeline import runner

    cfg = _project(tmp_path, ("cow.obj",), MINIMAL)
    cleaned = []

    def interrupted_twice(task):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)  # (not reached: the handler raises at once)
        except KeyboardInterrupt:
            os.kill(os.getpid(), signal.SIGINT)  # pressed again
            sum(range(10_000))  # (the handler runs between bytecodes)
            cleaned.append(task["id"])
            raise

    monkeypatch.setattr(runner, "process_asset", interrupted_twice)
    handler = signal.getsignal(signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        run(cfg, echo=lambda m: None)
    assert cleaned == ["meshes/cow.obj"] and signal.getsignal(signal.SIGINT) is handler


#: Linux lists the holder of each flock in /proc/locks: a run refused names it (else the pid in the lock file)
_KERNEL_LISTS_LOCKS = Path("/proc/locks").is_file()


def _lock_held_elsewhere(path: Path, pid: int) -> int:
    """Hold ``path`` as another run does (an exclusive flock on its own open file, with its pid); the fd."""
    import fcntl

    fd = os.open(path, os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    os.ftruncate(fd, 0)
    os.write(fd, f"{pid}\n".encode())
    return fd


def _lock_is_free(path: Path) -> bool:
    import fcntl

    fd = os.open(path, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except BlockingIOError:
        return False
    finally:
        os.close(fd)


def test_one_run_at_a_time_in_an_output_folder(tmp_path, monkeypatch):
    from swpm_usd.errors import OutputLockedError
    from swpm_usd.pipeline import runner

    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("sliding-window", "vanilla"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    lock = out / runner.LOCK
    assert lock.is_file() and _lock_is_free(lock)  # released at the end of the run
    # another run is writing here: its temporary file must survive, the second run must touch nothing
    (out / ".cow.swpm.abc123.tmp").write_bytes(b"the other run's")
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.name != runner.LOCK}
    cfg.write_text(cfg.read_text().replace("encoding: skip-strip", "encoding: mixed"))  # work to do
    holder = os.getpid()  # (the process that holds the lock: the kernel lists it so, and so does the file)
    fd = _lock_held_elsewhere(lock, holder)
    try:
        t = time.perf_counter()
        r = CliRunner().invoke(main, ["run", str(cfg), "--json"])
        assert time.perf_counter() - t < 10  # at once, not after waiting for the lock
        assert r.exit_code == 1, r.output
        message = f"{out}: another swpm-pipeline run (pid {holder}) is writing in this output folder"
        assert json.loads(r.stdout)["error"].startswith(message) and r.stderr.startswith(f"error: {message}")
        with pytest.raises(OutputLockedError) as err:
            run(cfg, echo=lambda m: None)
        assert err.value.path == str(out) and err.value.pid == holder
        assert {p.name: p.read_bytes() for p in out.iterdir() if p.name != runner.LOCK} == before
        assert run(cfg, dry_run=True, echo=lambda m: None).built == 0  # a dry run writes nothing: no lock
    finally:
        os.close(fd)
    # the lock goes with the run however it ends: an error, Ctrl-C, in a worker or in the run's own loop;
    # so does the run's Ctrl-C handler
    handler = signal.getsignal(signal.SIGINT)
    for where, stop in (
        ("process_asset", RuntimeError("a bug")),
        ("process_asset", KeyboardInterrupt()),
        ("_keep_previous", KeyboardInterrupt()),  # (the asset fails, then the run is interrupted)
    ):

        def broken(*args, stop=stop):
            raise stop

        with monkeypatch.context() as m:
            m.setattr(runner, where, broken)
            if where != "process_asset":
                m.setattr(runner, "process_asset", lambda task: {"id": task["id"], "status": "failed"})
            with pytest.raises(type(stop)):
                run(cfg, echo=lambda m: None)
        assert _lock_is_free(lock) and signal.getsignal(signal.SIGINT) is handler, where
    res = run(cfg, echo=lambda m: None)
    assert res.built == 1 and _lock_is_free(lock)
    assert not (out / ".cow.swpm.abc123.tmp").exists()  # once the folder is its own, a run cleans up
    # a folder the run creates is locked too, before anything is written in it
    cfg.write_text(cfg.read_text().replace("dir: out", "dir: fresh"))
    seen = []
    real = runner._remove_temporary
    monkeypatch.setattr(
        runner, "_remove_temporary", lambda d: (seen.append(_lock_is_free(d / runner.LOCK)), real(d))
    )
    assert run(cfg, echo=lambda m: None).built == 1 and seen and not any(seen)


def test_output_lock_of_another_user_an_unwritable_folder_or_no_locks(tmp_path, monkeypatch):
    # a lock file left by another user's run (0o644) or a folder the run cannot write in ended the run with
    # a PermissionError traceback
    import errno

    from swpm_usd.errors import OutputLockedError
    from swpm_usd.pipeline import runner

    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("sliding-window", "vanilla"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    lock = out / runner.LOCK
    real_open, real_access = os.open, os.access

    def refused(path, flags, *args, **kwargs):
        if Path(path) == lock and flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", refused)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True)
    lock.write_text(dead.stdout.decode())  # the other user's run, ended
    seen = []

    def second_run(task):  # while the run holds the lock (opened read-only), another is refused
        with pytest.raises(OutputLockedError) as err:
            runner._OutputLock(out, print).acquire()
        seen.append(err.value.pid)  # (the file holds the ended run's pid: not shown, the holder's instead)
        return real_process_asset(task)

    real_process_asset = runner.process_asset
    monkeypatch.setattr(runner, "process_asset", second_run)
    r = CliRunner().invoke(main, ["run", str(cfg), "--force"])
    progress = [line for line in r.stderr.splitlines() if not line.startswith("[0/")]  # (its start aside)
    assert r.exit_code == 0 and len(progress) == 1, r.output  # (the summary alone)
    assert seen == [os.getpid() if _KERNEL_LISTS_LOCKS else None] and _lock_is_free(lock)
    monkeypatch.setattr(runner, "process_asset", real_process_asset)
    # a folder the run cannot write in (no lock file to open either): reported as such, exit 2
    lock.unlink()
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: Path(p) != out and real_access(p, mode, **kw))
    r = CliRunner().invoke(main, ["run", str(cfg), "--force"])
    assert r.exit_code == 2 and f"cannot write in {out}: permission denied" in r.stderr, r.output
    # a filesystem without locks (NFS without lockd): the run goes on, with a warning
    monkeypatch.setattr(os, "open", real_open)
    monkeypatch.setattr(os, "access", real_access)
    import fcntl

    def no_locks(fd, op):
        raise OSError(errno.ENOLCK, "No locks available")

    monkeypatch.setattr(fcntl, "flock", no_locks)
    r = CliRunner().invoke(main, ["run", str(cfg), "--force", "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["built"] == 1, r.output
    assert f"warning: {out}: cannot lock the output folder (No locks available)" in r.stderr


@contextlib.contextmanager
def _run_held_in(tmp_path: Path, cfg: Path, hook: str, setup: str = ""):
    """``swpm-pipeline run cfg`` in another process, held in ``runner.<hook>`` (the lock held) until
    ``release`` exists; yields (the process, release) once it is there, and ends it if the block did not."""
    started, release = tmp_path / "started", tmp_path / "release"
    driver = tmp_path / "first.py"
    driver.write_text(
        "import pathlib, sys, time\n"
        "from swpm_usd.pipeline import runner\n"
        f"real = runner.{hook}\n"
        "def held(*args, **kwargs):  # there until the test lets it go on\n"
        "    pathlib.Path(sys.argv[1]).touch()\n"
        "    while not pathlib.Path(sys.argv[2]).exists():\n"
        "        time.sleep(0.02)\n"
        "    return real(*args, **kwargs)\n"
        f"runner.{hook} = held\n"
        f"{setup}"
        "from swpm_usd.cli import main\n"
        "main(sys.argv[3:])\n"
    )
    first = subprocess.Popen(
        [sys.executable, str(driver), str(started), str(release), "run", str(cfg)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        deadline = time.time() + 120
        while time.time() < deadline and first.poll() is None and not started.exists():
            time.sleep(0.02)
        assert started.exists() and first.poll() is None, first.stderr.read().decode()
        yield first, release
    finally:
        release.touch()
        if first.poll() is None:
            first.kill()
            first.wait()
        first.stderr.close()  # (read only when an assertion fails: left open, a ResourceWarning later)


def test_a_second_concurrent_run_fails_fast(tmp_path):
    # two real processes: the second exits 1 naming the folder while the first goes on to finish. The first
    # holds its first asset until the second has ended (the second's start raced the first's last assets)
    cfg = _project(tmp_path, ("cow.obj", "spot.obj"), "")
    cfg.write_text(
        "version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out}\n"
        "defaults: {encoding: sliding-window}\n"
    )
    with _run_held_in(tmp_path, cfg, "process_asset") as (first, release):  # (mid-run, the lock held)
        second = subprocess.run(
            [sys.executable, "-m", "swpm_usd.cli", "run", str(cfg)],
            capture_output=True,
            text=True,
            timeout=300,
        )
        release.touch()
        assert first.wait(timeout=FIRST_ASSET_S) == 0, first.stderr.read().decode()
    assert second.returncode == 1, second.stderr
    assert f"{tmp_path / 'out'}: another swpm-pipeline run (pid {first.pid}) is writing" in second.stderr
    assert run(cfg, echo=lambda m: None).skipped == 2  # the first run's work is whole


def test_manifest_is_not_rewritten_after_every_asset(tmp_path, monkeypatch):
    # each rewrite serialises every record: once per asset made a run quadratic in its asset count
    # (1,500 small assets: 461 s, 380 of them writing JSON; 82 s with the rewrites spaced out)
    from swpm_usd.pipeline import runner

    (tmp_path / "meshes").mkdir()
    text = (SHARED_MESHES / "suzanne.obj").read_text()
    for i in range(40):
        (tmp_path / "meshes" / f"m{i:02d}.obj").write_text(f"{text}\n# copy {i}\n")
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out, report: false}\n"
        "defaults: {encoding: vanilla}\n"
    )
    writes, at = [], []
    real = runner._write_manifest
    monkeypatch.setattr(
        runner,
        "_write_manifest",
        lambda path, m, *a: (
            writes.append(len(m["assets"])),
            at.append(time.perf_counter()),
            real(path, m, *a),
        ),
    )
    t = time.perf_counter()
    res = run(cfg, echo=lambda m: None)
    seconds = time.perf_counter() - t
    assert res.built == 40 and res.failed == 0
    assert writes[0] == 1  # the first finished asset is on disk at once
    assert (
        writes[-1] == 40 and len(json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]) == 40
    )
    every = runner._MANIFEST_EVERY_S
    assert len(writes) <= seconds / every + 3, (writes, seconds)
    # the rewrites as assets finish (all but the run's last) are spaced out, however fast the assets come;
    # fewer than one an asset where the run is quick enough to tell (4.4 s measured at a load of 5.6; two
    # xdist workers on a loaded CI machine may take longer, when one an asset is what the spacing allows)
    gaps = [b - a for a, b in zip(at[:-2], at[1:-1], strict=True)]
    assert all(gap >= every for gap in gaps), (gaps, writes)
    assert len(writes) < 40 or seconds >= (40 - 3) * every, (writes, seconds)
    # the cached record texts make the same file json.dumps would (but for each summary.curve, a point a
    # line: the same JSON value), and the file a serialiser without a cache makes
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    text = runner._ManifestText()
    assert json.loads(text.dumps(manifest)) == manifest
    flat = {
        **manifest,
        "assets": {k: {**r, "summary": {**r["summary"], "curve": []}} for k, r in manifest["assets"].items()},
    }
    assert runner._ManifestText().dumps(flat) == json.dumps(flat, indent=1)
    manifest["assets"]["meshes/m07.obj"] = {"replaced": [1, {"a": None}]}
    again = text.dumps(manifest)  # a new record object is serialised again
    assert json.loads(again) == manifest and again == runner._ManifestText().dumps(manifest)


def test_rules_on_triangles_are_matched_by_the_worker_that_loads_the_asset(tmp_path, monkeypatch):
    # the planner used to load every new asset to count its triangles, one after another, before the
    # workers loaded it again (1,000 small assets: 10 of 46 s); now only --dry-run / --explain count
    from swpm_usd.pipeline import runner

    cfg = _project(tmp_path, ("suzanne.obj", "spot.obj"), MINIMAL.replace("15000", "2000"))
    counted = []
    real = runner._count_triangles
    monkeypatch.setattr(runner, "_count_triangles", lambda a: (counted.append(a.id), real(a))[1])
    res = run(cfg, echo=lambda m: None)
    assert counted == [] and res.built == 2 and res.failed == 0
    rules = {k: (r["rule"], r["encoding"], r["why"]) for k, r in res.records.items()}
    assert rules == {
        "meshes/suzanne.obj": ("small", "skip-strip", "rule 'small' matched (triangles=967)"),
        "meshes/spot.obj": ("default", "sliding-window", "rule 'default' matched (no match conditions)"),
    }
    again = run(cfg, echo=lambda m: None)  # the worker's digest is the planner's: nothing to do
    assert again.built == 0 and again.skipped == 2 and counted == []
    (tmp_path / "meshes" / "spot.obj").write_text((SHARED_MESHES / "suzanne.obj").read_text())
    changed = run(cfg, echo=lambda m: None)
    assert changed.built == 1 and changed.records["meshes/spot.obj"]["rule"] == "small"
    lines = []
    run(cfg, dry_run=True, echo=lines.append)
    assert any("meshes/spot.obj: skip-strip" in line and "[up to date]" in line for line in lines)


def test_scene_references_every_asset_layer_by_name(tmp_path):
    from pxr import Usd

    from swpm_usd import usd

    cfg = _project(
        tmp_path, ("cow.obj", "spot.obj"), MINIMAL.replace("dir: out", "{dir: out, usd: true, scene: true}")
    )
    res = run(cfg, echo=lambda m: None)
    assert res.built == 2 and res.failed == 0
    stage = Usd.Stage.Open(str(tmp_path / "out" / "scene.usda"))
    names = [p.GetName() for p in stage.GetPrimAtPath("/Scene").GetChildren()]
    assert names == ["cow", "spot"]  # the assets' names, not a0_0, a1_1, nor an index that shifts
    encoded = usd.find_encoded(stage)
    assert [usd.read(p).encoding for p in encoded] == ["skip-strip", "skip-strip"]


def test_scene_prim_names_depend_on_their_own_asset_alone():
    # the names ended in the asset's index among the built ones (cow_0, spot_1): one asset more or less
    # renamed the others, and a layer overriding /Scene/spot_1 lost it
    from pxr import Sdf

    from swpm_usd.pipeline.scene import _scene_prim_name

    stems = ["cow", "a-b", "a b", "1cow", "a_b", "sp\u00f6t"]
    names = [_scene_prim_name(s, set()) for s in stems]
    assert names[0] == "cow" and names[4] == "a_b"
    assert all(Sdf.Path.IsValidIdentifier(n) for n in names) and len(set(names)) == len(names)
    assert names[1].startswith("a_b_") and names[2].startswith("a_b_") and names[1] != names[2]
    used: set[str] = set()
    assert [_scene_prim_name(s, used) for s in reversed(stems)] == list(reversed(names))
    assert _scene_prim_name("a_b", {"a_b"}).startswith("a_b_")  # (taken: hashed, never a duplicate)


def test_a_non_ascii_name_usd_takes_is_the_scene_prim_as_it_is():
    # usd-core 0.26 takes UTF-8 identifiers (XID_Start, XID_Continue): café.usdc's prim was /Scene/caf___
    # and a hash (Tf.MakeValidIdentifier is ASCII's). What USD refuses is still made valid and hashed, each
    # refused character one `_`; an ASCII name is made as before
    from pxr import Sdf, Tf

    from swpm_usd.pipeline.scene import _scene_prim_name

    for stem in ("caf\u00e9", "\u65e5\u672c", "\u03a9mega", "cafe\u0301", "\u00e9t\u00e9_2"):
        assert _scene_prim_name(stem, set()) == stem
    assert re.fullmatch("caf\u00e9_1_[0-9a-f]{8}", _scene_prim_name("caf\u00e9-1", set()))
    assert re.fullmatch("_caf\u00e9_[0-9a-f]{8}", _scene_prim_name("1caf\u00e9", set()))
    assert re.fullmatch("x__[0-9a-f]{8}", _scene_prim_name("x\u00b2", set()))  # (² is no XID_Continue)
    for stem in ("cow", "a-b", "a b", "1cow", "a_b", "x.y", ""):  # (ASCII: Tf's identifier, as before)
        base = Tf.MakeValidIdentifier(stem)
        name = _scene_prim_name(stem, set())
        assert name == base if base == stem else name.startswith(f"{base}_")
    for stem in ("caf\u00e9-1", "1caf\u00e9", "x\u00b2", "\u00e9\u00e9", "a\u2014b"):
        assert Sdf.Path.IsValidIdentifier(_scene_prim_name(stem, set()))


def test_a_scene_written_with_mangled_non_ascii_names_is_written_again(tmp_path, monkeypatch):
    """A scene recorded by a run that mangled non-ASCII names is not current, though no record changed: the
    rerun writes it with the names USD takes, and records so (``utf8_prim_names``); a scene of ASCII names
    alone is recorded as before, without it."""
    from pxr import Sdf, Tf

    import swpm_usd.pipeline.scene as scene
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)  # (inputs just written: see the racily clean test)
    cfg = _vanilla_project(tmp_path, "caf\u00e9", "cow")
    cfg.write_text(cfg.read_text().replace("dir: out", "dir: out, usd: true, scene: true"))
    out = tmp_path / "out"

    def prims() -> set[str]:
        layer = Sdf.Layer.OpenAsAnonymous(str(out / "scene.usda"))
        return {c.name for c in layer.GetPrimAtPath("/Scene").nameChildren}

    def scene_record() -> dict:
        return json.loads((out / "manifest.json").read_text())["run_outputs"]["scene"]

    with monkeypatch.context() as m:  # (the names as the run made them before: Tf's, ASCII)
        m.setattr(scene, "_valid_identifier", Tf.MakeValidIdentifier)
        assert run(cfg, echo=lambda m: None).built == 2
    old = prims()
    assert "cow" in old and "caf\u00e9" not in old and scene.UTF8_PRIM_NAMES not in scene_record()
    manifest = (out / "manifest.json").read_bytes()
    again = run(cfg, echo=lambda m: None)
    assert (again.built, again.skipped) == (0, 2)
    assert prims() == {"cow", "caf\u00e9"} and scene_record()[scene.UTF8_PRIM_NAMES] is True
    assert (out / "manifest.json").read_bytes() != manifest
    # written so, it is current: the next rerun writes nothing
    written = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert run(cfg, echo=lambda m: None).skipped == 2
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == written
    # ASCII names alone: the record as before, without the key
    (tmp_path / "m" / "caf\u00e9.obj").unlink()
    run(cfg, prune=True, echo=lambda m: None)
    assert prims() == {"cow"} and scene.UTF8_PRIM_NAMES not in scene_record()


def test_scene_is_written_without_opening_the_asset_layers(tmp_path, capfd):
    # the scene was authored on a stage, which composed every reference as it was added: each asset layer
    # opened and read (5,000 assets: 20 s and 350 MB on every run, one with nothing to build included).
    # Written on the layer alone, a layer that cannot be read is not looked at, and the text is the same
    from pxr import Sdf, Usd

    from swpm_usd.pipeline.runner import _write_scene

    (tmp_path / "bad.usdc").write_bytes(b"not a layer")  # (a stage's reference to it warns on stderr)
    records = {
        "meshes/bad.obj": {"status": "built", "outputs": {"usd": {"path": "bad.usdc"}}},
        "meshes/a-b.obj": {"status": "built", "outputs": {"usd": {"path": "a-b.usdc"}}},  # (missing)
        "meshes/gone.obj": {"status": "failed", "error": "x"},
        "meshes/cow.obj": {"status": "built", "outputs": {"swpm": {"path": "cow.swpm"}}},  # (no layer)
    }
    capfd.readouterr()
    _write_scene(tmp_path, records)
    assert capfd.readouterr().err == ""  # (no "Could not open asset @bad.usdc@")
    layer = Sdf.Layer.OpenAsAnonymous(str(tmp_path / "scene.usda"))
    assert layer.defaultPrim == "Scene"
    assert (layer.pseudoRoot.GetInfo("upAxis"), layer.pseudoRoot.GetInfo("metersPerUnit")) == ("Y", 1.0)
    scene = layer.GetPrimAtPath("/Scene")
    assert (scene.specifier, scene.typeName) == (Sdf.SpecifierDef, "Xform")
    kids = {c.name: c for c in scene.nameChildren}
    assert set(kids) == {"bad", _scene_prim_name_of("a-b")}
    for name, path in (("bad", "./bad.usdc"), (_scene_prim_name_of("a-b"), "./a-b.usdc")):
        assert (kids[name].specifier, kids[name].typeName) == (Sdf.SpecifierDef, "Xform")
        assert list(kids[name].referenceList.prependedItems) == [Sdf.Reference(path)]
    assert not (tmp_path / ".scene.tmp.usda").exists()
    capfd.readouterr()
    stage = Usd.Stage.Open(str(tmp_path / "scene.usda"))  # (as a stage, the references are composed)
    assert stage.GetDefaultPrim().GetPath() == Sdf.Path("/Scene")


def _scene_prim_name_of(stem: str) -> str:
    from swpm_usd.pipeline.scene import _scene_prim_name

    return _scene_prim_name(stem, set())


def _listed_outputs(out: Path) -> tuple[set[str], set[str]]:
    """(every .swpm / .usdc file in ``out``, every output the manifest lists)."""
    files = {p.name for p in out.iterdir() if p.suffix in (".swpm", ".usdc")}
    assets = json.loads((out / "manifest.json").read_text())["assets"]
    return files, {o["path"] for rec in assets.values() for o in rec.get("outputs", {}).values()}


def test_a_pipeline_layer_s_asset_info_names_its_own_file_not_the_temporary_one(tmp_path):
    """The worker exports each layer to a temporary file and renames it: assetInfo's identifier, the layer
    itself, is the output's name (./cow.usdc), not the temporary file's, and resolves to the output."""
    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("dir: out", "{dir: out, usd: true, scene: true}"))
    from pxr import Usd

    assert run(cfg, echo=lambda m: None).built == 1
    layer = tmp_path / "out" / "cow.usdc"
    stage = Usd.Stage.Open(str(layer))
    model = Usd.ModelAPI(stage.GetDefaultPrim())
    assert model.GetAssetName() == "Cow" and model.GetAssetIdentifier().path == "./cow.usdc"
    assert Path(model.GetAssetIdentifier().resolvedPath) == layer.resolve()
    scene = Usd.Stage.Open(str(tmp_path / "out" / "scene.usda"))  # (composed: read through the reference)
    (child,) = scene.GetDefaultPrim().GetChildren()
    assert Path(Usd.ModelAPI(child).GetAssetIdentifier().resolvedPath) == layer.resolve()


def test_rebuilt_outputs_keep_the_mode_of_the_files_they_replace(tmp_path):
    """Each output is a temporary file renamed over the previous one: it took the umask's mode (0o644), so
    outputs made private (0o600) were readable by everyone after the next run."""
    import stat

    cfg = _project(
        tmp_path,
        ("cow.obj",),
        MINIMAL.replace("dir: out", "{dir: out, usd: true, scene: true, report: true}"),
    )
    out = tmp_path / "out"
    old = os.umask(0o022)
    try:
        assert run(cfg, echo=lambda m: None).built == 1
        names = ("cow.swpm", "cow.usdc", "scene.usda", "manifest.json", "report.html")
        for name in names:
            assert stat.S_IMODE((out / name).stat().st_mode) == 0o644, name
            os.chmod(out / name, 0o600)
        assert run(cfg, echo=lambda m: None, force=True).built == 1
    finally:
        os.umask(old)
    assert {name: oct(stat.S_IMODE((out / name).stat().st_mode)) for name in names} == dict.fromkeys(
        names, "0o600"
    )


def test_a_read_only_usd_layer_is_rebuilt_and_stays_read_only(tmp_path, monkeypatch):
    """The temporary USD layer took the mode of the layer it replaces before usd-core wrote it: a read-only
    previous layer (0o444) made it read-only too, and usd-core, not root, could not write it ("Insufficient
    permissions to write to destination file"). It is written with the plain mode and given 0o444 after."""
    import stat

    from swpm_usd import usd
    from swpm_usd.format import encode_bytes, load_bytes
    from swpm_usd.format.vectors import fan_vanilla
    from swpm_usd.pipeline import worker

    pm = load_bytes(encode_bytes(fan_vanilla()))  # type: ignore[arg-type]
    target = tmp_path / "a.usdc"
    worker._place_usd(*worker._stage_usd(pm, target))
    os.chmod(target, 0o444)
    modes = []
    write = usd.write

    def recording(pm, path, **kwargs):
        modes.append(stat.S_IMODE(Path(path).stat().st_mode))
        return write(pm, path, **kwargs)

    monkeypatch.setattr(usd, "write", recording)
    tmp, _ = worker._stage_usd(pm, target)
    assert modes and modes[0] & stat.S_IWUSR  # (writable while usd-core writes it)
    assert stat.S_IMODE(tmp.stat().st_mode) == 0o444
    worker._place_usd(tmp, target)
    assert stat.S_IMODE(target.stat().st_mode) == 0o444
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.usdc"]


def test_a_failed_rebuild_keeps_the_previous_build(tmp_path):
    from pxr import Usd

    cfg = _project(tmp_path, config=MINIMAL.replace("dir: out", "{dir: out, usd: true, scene: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    # (the USD layer, exported to a temporary file and renamed, has the mode of the other outputs)
    assert (out / "cow.usdc").stat().st_mode == (out / "cow.swpm").stat().st_mode
    before = json.loads((out / "manifest.json").read_text())["assets"]["meshes/cow.obj"]
    cow = tmp_path / "meshes" / "cow.obj"
    good = cow.read_bytes()
    cow.write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")  # the input is broken: its rebuild fails
    for _ in range(2):  # and fails again on the next run, which tries again
        r = CliRunner().invoke(main, ["run", str(cfg), "--json"])
        assert r.exit_code == 1, r.output
        summary = json.loads(r.stdout)
        assert (summary["built"], summary["skipped"], summary["failed"]) == (0, 1, 1)
        (failure,) = summary["failures"]
        assert failure["id"] == "meshes/cow.obj" and failure["kept_previous"] is True
        assert "cow.obj" in failure["error"]
        rec = json.loads((out / "manifest.json").read_text())["assets"]["meshes/cow.obj"]
        # the previous build's record, untouched, with the failure beside it
        assert {k: v for k, v in rec.items() if k != "last_failure"} == before
        assert "cow.obj" in rec["last_failure"]["error"] and rec["last_failure"]["digest"] != before["digest"]
        for o in rec["outputs"].values():
            assert sha256_of(out / o["path"]) == o["sha256"]
        stage = Usd.Stage.Open(str(out / "scene.usda"))
        assert [p.GetName() for p in stage.GetPrimAtPath("/Scene").GetChildren()] == ["cow", "spot"]
        report = (out / "report.html").read_text()
        assert (
            "rebuild failed; the previous build (below) is kept" in report
            and "keeping their previous" in report
        )
        files, listed = _listed_outputs(out)
        assert files == listed == {"cow.swpm", "cow.usdc", "spot.swpm", "spot.usdc"}
    r = CliRunner().invoke(main, ["run", str(cfg)])  # the text summary says so too (with the problem's code)
    assert r.exit_code == 1 and "FAILED [INPUT_MALFORMED] meshes/cow.obj: " in r.stderr
    assert "previous build is kept" in r.stderr
    # the input put back: the kept build is up to date again, and the failure goes
    cow.write_bytes(good)
    again = run(cfg, echo=lambda m: None)
    assert (again.built, again.skipped, again.failed, again.failures) == (0, 2, 0, {})
    rec = json.loads((out / "manifest.json").read_text())["assets"]["meshes/cow.obj"]
    # (but for its input's stat, recorded anew: the file put back was hashed, to the recorded digest)
    assert {**rec, "inputs": None} == {**before, "inputs": None} and _as_hashed(rec["inputs"][0], cow)
    # a previous build whose outputs are no longer all there is not kept: the failure replaces its record
    # and its remaining outputs go with it (none is left that the manifest does not list)
    (out / "cow.usdc").unlink()
    cow.write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and res.failures["meshes/cow.obj"]["kept_previous"] is False
    assert (
        res.records["meshes/cow.obj"]["status"] == "failed"
        and "last_failure" not in res.records["meshes/cow.obj"]
    )
    files, listed = _listed_outputs(out)
    assert files == listed == {"spot.swpm", "spot.usdc"}
    stage = Usd.Stage.Open(str(out / "scene.usda"))
    assert [p.GetName() for p in stage.GetPrimAtPath("/Scene").GetChildren()] == ["spot"]


def test_a_failed_usd_export_replaces_no_output(tmp_path, monkeypatch):
    # the outputs are all made before any replaces its old file: a USD layer that cannot be written leaves
    # the asset's .swpm as it was, and no temporary file
    from swpm_usd import usd

    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("dir: out", "{dir: out, usd: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    swpm = (out / "cow.swpm").read_bytes()

    def refuse(*args, **kwargs):
        raise OSError("disk full (test)")

    monkeypatch.setattr(usd, "write", refuse)
    cfg.write_text(cfg.read_text().replace("encoding: skip-strip", "encoding: vanilla"))  # another .swpm
    res = run(cfg, echo=lambda m: None)
    assert (out / "cow.swpm").read_bytes() == swpm
    names = sorted(p.name for p in out.iterdir())
    assert names == [".swpm-pipeline.lock", "cow.swpm", "cow.usdc", "manifest.json", "report.html"]
    assert res.failed == 1 and "disk full" in res.failures["meshes/cow.obj"]["error"]
    assert res.failures["meshes/cow.obj"]["kept_previous"]


def test_an_output_that_cannot_be_renamed_into_place_keeps_the_previous_build(tmp_path, monkeypatch):
    # the .swpm was renamed into place before the USD layer: when the layer's rename failed, the new .swpm
    # stayed, listed nowhere, and the previous build (its .swpm overwritten) could not be kept
    import errno

    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("dir: out", "{dir: out, usd: true, scene: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    before = {name: sha256_of(out / name) for name in ("cow.swpm", "cow.usdc")}
    real = os.replace

    def refuse_usdc(src, dst, *args, **kwargs):
        if os.fspath(dst).endswith(".usdc"):
            raise OSError(errno.EIO, "rename refused (test)")
        return real(src, dst, *args, **kwargs)

    monkeypatch.setattr(os, "replace", refuse_usdc)
    cfg.write_text(cfg.read_text().replace("encoding: skip-strip", "encoding: vanilla"))  # another .swpm
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and "rename refused" in res.failures["meshes/cow.obj"]["error"]
    assert res.failures["meshes/cow.obj"]["kept_previous"]
    assert {name: sha256_of(out / name) for name in before} == before
    files, listed = _listed_outputs(out)
    assert files == listed == {"cow.swpm", "cow.usdc"}
    names = sorted(p.name for p in out.iterdir())  # no temporary file left
    assert names == [
        ".swpm-pipeline.lock",
        "cow.swpm",
        "cow.usdc",
        "manifest.json",
        "report.html",
        "scene.usda",
    ]
    # an asset built for the first time: none of its outputs is left
    shutil.copy(SHARED_MESHES / "spot.obj", tmp_path / "meshes" / "spot.obj")
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 2 and not res.failures["meshes/spot.obj"]["kept_previous"]
    files, listed = _listed_outputs(out)
    assert files == listed == {"cow.swpm", "cow.usdc"}
    # and when the rename works again, both are built
    monkeypatch.undo()
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.failed) == (2, 0)
    files, listed = _listed_outputs(out)
    assert files == listed == {"cow.swpm", "cow.usdc", "spot.swpm", "spot.usdc"}


def test_a_worker_killed_while_it_renames_outputs_leaves_the_previous_build(tmp_path, monkeypatch):
    # a worker killed (a pool's worker stopped by Ctrl-C, a kill, the OOM killer) after renaming the asset's
    # new outputs into place, before they were recorded: each previous file was kept aside
    # (.<name>.XXXXXXXX.prev.tmp), and the next run deleted those as temporary files, so the previous build
    # was lost (the new files, which the manifest does not list, left in its place)
    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("dir: out", "{dir: out, usd: true, scene: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    before = {name: sha256_of(out / name) for name in ("cow.swpm", "cow.usdc")}
    original = cfg.read_text()
    cfg.write_text(original.replace("encoding: skip-strip", "encoding: vanilla"))  # another .swpm
    killed = subprocess.run(
        [
            sys.executable,
            "-c",
            "import os, signal, sys\n"
            "from swpm_usd.pipeline import run, worker\n"
            "worker.output_record = lambda path: os.kill(os.getpid(), signal.SIGKILL)\n"
            "run(sys.argv[1], echo=lambda m: None)\n",
            str(cfg),
        ],
        capture_output=True,
    )
    assert killed.returncode == -signal.SIGKILL, killed.stderr.decode()
    assert len(list(out.glob(".*.prev.tmp"))) == 2 and sha256_of(out / "cow.swpm") != before["cow.swpm"]
    # a rebuild that fails keeps the previous build, which is whole
    cfg.write_text(cfg.read_text() + "budgets: {global_bytes: 1}\n")
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and res.failures["meshes/cow.obj"]["kept_previous"], res.failures
    assert {name: sha256_of(out / name) for name in before} == before
    files, listed = _listed_outputs(out)
    assert files == listed == {"cow.swpm", "cow.usdc"}
    assert not list(out.glob(".*.tmp"))
    # the config put back: up to date
    cfg.write_text(original)
    assert run(cfg, echo=lambda m: None).skipped == 1
    assert {name: sha256_of(out / name) for name in before} == before
    # a pool's worker that Ctrl-C stopped there: the run puts the previous build back as it stops
    from swpm_usd.fileio import keep_aside, stage_bytes
    from swpm_usd.pipeline import runner

    def stopped_while_renaming(tasks, *args):
        for name in ("cow.swpm", "cow.usdc"):
            keep_aside(out / name)
            os.replace(stage_bytes(out / name, b"new"), out / name)
        raise KeyboardInterrupt
        yield

    monkeypatch.setattr(runner, "execute", stopped_while_renaming)
    cfg.write_text(original.replace("encoding: skip-strip", "encoding: vanilla"))
    with pytest.raises(KeyboardInterrupt):
        run(cfg, echo=lambda m: None)
    assert {name: sha256_of(out / name) for name in before} == before
    assert not list(out.glob(".*.tmp"))


def test_place_outputs_is_all_or_nothing(tmp_path, monkeypatch):
    # whichever step fails once the first output is renamed into place (the second's rename, recording the
    # outputs), the previous files are put back and a new one without a previous file is deleted
    from swpm_usd.pipeline import worker

    def staged_pair() -> dict:
        staged = {}
        for kind, name in (("swpm", "a.swpm"), ("usd", "b.usdc")):
            tmp = tmp_path / f".{name}.new.tmp"
            tmp.write_bytes(b"new " + name.encode())
            staged[kind] = (tmp, tmp_path / name)
        return staged

    (tmp_path / "a.swpm").write_bytes(b"old a.swpm")  # b.usdc has no previous file
    real = worker.output_record

    def fail_on_record(path):
        if path.name == "b.usdc":
            raise OSError("cannot read (test)")
        return real(path)

    monkeypatch.setattr(worker, "output_record", fail_on_record)
    with pytest.raises(OSError, match="cannot read"):
        worker._place_outputs(staged_pair())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.swpm"]
    assert (tmp_path / "a.swpm").read_bytes() == b"old a.swpm"
    monkeypatch.undo()
    records = worker._place_outputs(staged_pair())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.swpm", "b.usdc"]
    assert (tmp_path / "a.swpm").read_bytes() == b"new a.swpm"
    assert records["swpm"]["sha256"] == sha256_of(tmp_path / "a.swpm") and records["usd"]["path"] == "b.usdc"


@pytest.mark.parametrize("kind", ["swpm", "usd"])
def test_place_outputs_undoes_a_rename_cut_short_as_it_returns(tmp_path, monkeypatch, kind):
    # a Ctrl-C received during a rename is raised as it returns (--jobs 1: the worker is the main process),
    # and an error of the USD layer's reload after its rename: the rename was not yet listed as done, so it
    # was not undone, and the previous file, kept aside, was deleted with the new file left in its place
    from swpm_usd.pipeline import worker

    staged = {}
    for k, name in (("swpm", "a.swpm"), ("usd", "a.usdc")):
        (tmp_path / name).write_bytes(b"old " + name.encode())
        tmp = tmp_path / f".{name}.new.tmp"
        tmp.write_bytes(b"new " + name.encode())
        staged[k] = (tmp, tmp_path / name)
    real = os.replace

    def replace_then_interrupted(src, dst, *args, **kwargs):
        real(src, dst, *args, **kwargs)
        if Path(src) == staged[kind][0]:  # (once: not the rename that puts the previous file back)
            raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", replace_then_interrupted)
    with pytest.raises(KeyboardInterrupt):
        worker._place_outputs(staged)
    monkeypatch.undo()
    for tmp, _ in staged.values():  # (as its caller does)
        tmp.unlink(missing_ok=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.swpm", "a.usdc"]
    assert (tmp_path / "a.swpm").read_bytes() == b"old a.swpm"
    assert (tmp_path / "a.usdc").read_bytes() == b"old a.usdc"


def test_place_outputs_undoes_every_output_when_the_open_layer_does_not_reload(tmp_path, monkeypatch):
    # the .usdc's reload (a layer of its name open in this process) failing after its rename: the undo
    # reloaded it again, which raised again out of the undo and left the new .swpm beside the previous .usdc
    from pxr import Sdf

    from swpm_usd.pipeline import worker

    def layer_file(path: Path, note: str) -> None:
        layer = Sdf.Layer.CreateNew(str(path))
        layer.comment = note
        assert layer.Save()

    (tmp_path / "a.swpm").write_bytes(b"old a.swpm")
    layer_file(tmp_path / "a.usdc", "old")
    layer_file(tmp_path / ".a.new.usdc", "new")
    (tmp_path / ".a.swpm.new.tmp").write_bytes(b"new a.swpm")
    staged = {
        "swpm": (tmp_path / ".a.swpm.new.tmp", tmp_path / "a.swpm"),
        "usd": (tmp_path / ".a.new.usdc", tmp_path / "a.usdc"),
    }
    before = {name: sha256_of(tmp_path / name) for name in ("a.swpm", "a.usdc")}
    opened = Sdf.Layer.FindOrOpen(str(tmp_path / "a.usdc"))  # (open in this process)

    def failing_reload(self, force=False):
        Sdf.Layer.CreateNew("")  # (a real usd-core error: "cannot use empty identifier")

    monkeypatch.setattr(Sdf.Layer, "Reload", failing_reload)
    with pytest.raises(Exception) as exc:  # noqa: B017 - (its type checked below, after the files)
        worker._place_outputs(staged)
    monkeypatch.undo()
    assert {name: sha256_of(tmp_path / name) for name in before} == before  # both outputs undone
    assert opened.comment == "old"
    assert type(exc.value).__name__ == "LayerReloadError"  # (a SwpmError, no raw Tf.ErrorException)
    message = str(exc.value)
    assert message.startswith(f"{tmp_path / 'a.usdc'}: the layer of that name open in this process could not")
    assert "cannot use empty identifier" in message and "previous build is as it was" in message
    assert "written" not in message


def test_restoring_kept_aside_layers_goes_on_when_an_open_layer_does_not_reload(tmp_path, monkeypatch):
    # a run stopped while a worker renamed outputs puts the previous ones back (_restore_kept_aside) and
    # reloads a layer of that name open in this process: a reload that failed raised out of it (from the
    # run's stop(), before the temporary files were deleted and the manifest written), the other layers
    # kept aside left as they were
    from pxr import Sdf

    from swpm_usd.fileio import keep_aside, stage_bytes
    from swpm_usd.pipeline import runner

    cfg = _project(tmp_path, ("cow.obj", "spot.obj"), MINIMAL.replace("dir: out", "{dir: out, usd: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    records = json.loads((out / "manifest.json").read_text())["assets"]
    names = ("cow.usdc", "spot.usdc")
    before = {name: sha256_of(out / name) for name in names}
    opened = [Sdf.Layer.FindOrOpen(str(out / name)) for name in names]  # (open in this process)
    for name in names:  # (a worker stopped between the renames and their records)
        keep_aside(out / name)
        os.replace(stage_bytes(out / name, b"new"), out / name)

    def failing_reload(self, force=False):
        Sdf.Layer.CreateNew("")  # (a real usd-core error: "cannot use empty identifier")

    monkeypatch.setattr(Sdf.Layer, "Reload", failing_reload)
    runner._restore_kept_aside(out, records)
    monkeypatch.undo()
    assert {name: sha256_of(out / name) for name in names} == before
    assert not list(out.glob(".*.prev.tmp"))
    assert all(layer.rootPrims for layer in opened)  # (their previous content: not reloaded)


def test_keep_aside_links_or_copies_the_previous_file(tmp_path, monkeypatch):
    import errno

    from swpm_usd.fileio import keep_aside

    target = tmp_path / "a.swpm"
    assert keep_aside(target) is None  # nothing to keep
    target.write_bytes(b"previous")
    os.chmod(target, 0o640)
    aside = keep_aside(target)
    assert aside.name.startswith(".a.swpm.") and aside.name.endswith(".prev.tmp")
    assert aside.stat().st_ino == target.stat().st_ino  # a hard link: no data copied
    aside.unlink()

    def no_links(*args, **kwargs):
        raise OSError(errno.EPERM, "no hard links here (test)")

    monkeypatch.setattr(os, "link", no_links)
    aside = keep_aside(target)  # a copy, with the mode and mtime of the file
    assert aside.read_bytes() == b"previous" and aside.stat().st_ino != target.stat().st_ino
    assert aside.stat().st_mode == target.stat().st_mode
    assert aside.stat().st_mtime_ns == target.stat().st_mtime_ns
    target.unlink()
    assert keep_aside(target) is None and sorted(p.name for p in tmp_path.iterdir()) == [aside.name]


def _hand_edited(good: dict) -> dict[str, object]:
    """Malformed versions of the manifest record ``good`` (a built asset's, with a .swpm and a .usdc), each
    a record this tool never writes: what a hand edit of the manifest can leave."""
    import copy

    def edit(change) -> dict:
        rec = copy.deepcopy(good)
        change(rec)
        return rec

    return {
        "a list": [1, 2],
        "a string": "built",
        "null": None,
        "no status": edit(lambda r: r.pop("status")),
        "no outputs": edit(lambda r: r.pop("outputs")),
        "no digest": edit(lambda r: r.pop("digest")),
        "outputs a list": edit(lambda r: r.update(outputs=list(r["outputs"].values()))),
        "an output a string": edit(lambda r: r["outputs"].update(swpm="cow.swpm")),
        "an output without its path": edit(lambda r: r["outputs"]["usd"].pop("path")),
        "a size that is a string": edit(
            lambda r: r["outputs"]["swpm"].update(size=str(r["outputs"]["swpm"]["size"]))
        ),
        "a path outside output.dir": edit(lambda r: r["outputs"]["swpm"].update(path="../meshes/cow.obj")),
        "triangles_in a string": edit(lambda r: r.update(triangles_in=str(r["triangles_in"]))),
        "checks.budgets a string": edit(lambda r: r["checks"].update(budgets="none")),
        "a budget a string": edit(lambda r: r["checks"].update(budgets={"total_bytes": "1e9"})),
        "summary a list": edit(lambda r: r.update(summary=[])),
        "a curve point without its error": edit(lambda r: r["summary"]["curve"][0].pop("error")),
        "last_failure a string": edit(lambda r: r.update(last_failure="boom")),
        "seconds a string": edit(lambda r: r.update(seconds="0.5")),
        "build_version a number": edit(lambda r: r.update(build_version=0.92)),
        # (the scene corrects the asset's layer by its units: scene._author_units_correction)
        "an up axis X": edit(lambda r: r["outputs"]["usd"].update(up_axis="X")),
        "metersPerUnit 0": edit(lambda r: r["outputs"]["usd"].update(meters_per_unit=0)),
    }


def test_a_malformed_manifest_record_is_built_again_with_a_warning(tmp_path):
    # a hand-edited manifest: a record of a current asset that is not a dict, lacks a key or holds a value
    # of another type raised in plan, _keep_previous, the scene or the report; it is now ignored, named
    from swpm_usd.pipeline.runner import _keep_previous

    cfg = _project(tmp_path, config=MINIMAL.replace("dir: out", "{dir: out, usd: true, scene: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    manifest = json.loads((out / "manifest.json").read_text())
    good = manifest["assets"]["meshes/cow.obj"]
    assert run(cfg, echo=lambda m: None).skipped == 2
    for what, rec in _hand_edited(good).items():
        assert _keep_previous(out, rec, {"error": "x"}) is None, what  # never raises either
        manifest["assets"]["meshes/cow.obj"] = rec
        (out / "manifest.json").write_text(json.dumps(manifest))
        lines: list[str] = []
        dry = run(cfg, dry_run=True, echo=lines.append)
        assert dry.skipped == 1 and any(
            line.startswith("meshes/cow.obj: ") and "[to build]" in line for line in lines
        ), lines
        (warning,) = [w for w in dry.warnings if "meshes/cow.obj" in w]
        assert (
            warning.startswith("out/manifest.json: the record of meshes/cow.obj ")
            and "built again" in warning
        )
        lines.clear()
        res = run(cfg, echo=lines.append)
        assert (res.built, res.skipped, res.failed) == (1, 1, 0), (what, res.failures)
        assert res.warnings.count(warning) == 1 and f"warning: {warning}" in lines, (what, lines)
        files, listed = _listed_outputs(out)
        assert files == listed == {"cow.swpm", "cow.usdc", "spot.swpm", "spot.usdc"}, what
        assert run(cfg, echo=lambda m: None).skipped == 2, what  # its record is whole again
    # a rebuild that fails: the failure is recorded (no previous build to keep), the run goes on
    manifest["assets"]["meshes/cow.obj"] = _hand_edited(good)["an output a string"]
    (out / "manifest.json").write_text(json.dumps(manifest))
    (tmp_path / "meshes" / "cow.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    r = CliRunner().invoke(main, ["run", str(cfg)])
    assert r.exit_code == 1 and "Traceback" not in r.output, r.output
    assert "warning: out/manifest.json: the record of meshes/cow.obj " in r.stdout
    rec = json.loads((out / "manifest.json").read_text())["assets"]["meshes/cow.obj"]
    assert rec["status"] == "failed" and "outputs" not in rec


def test_an_output_turned_on_after_a_build_is_written(tmp_path):
    # `usd: true` added to a config whose assets were built: every asset was up to date, and no .usdc was
    # ever written (the record's outputs were only checked to be there, not to be those the config asks for)
    cfg = _project(tmp_path, ("cow.obj",), MINIMAL)
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    cfg.write_text(cfg.read_text().replace("dir: out", "{dir: out, usd: true}"))
    assert run(cfg, echo=lambda m: None).built == 1
    files, listed = _listed_outputs(out)
    assert files == listed == {"cow.swpm", "cow.usdc"}
    # turned off again: nothing to build (the layer stays, listed)
    cfg.write_text(cfg.read_text().replace("{dir: out, usd: true}", "dir: out"))
    assert run(cfg, echo=lambda m: None).skipped == 1
    files, listed = _listed_outputs(out)
    assert files == listed == {"cow.swpm", "cow.usdc"}


def test_an_output_turned_off_when_its_asset_is_rebuilt_is_named_and_pruned(tmp_path):
    # `swpm: false, usd: true` where the assets were built with their .swpm alone: the asset is rebuilt (the
    # layer it lacks), and its new record lists the layer alone, so its .swpm was left listed nowhere, neither
    # named as unlisted nor deleted by --prune, for good
    cfg = _project(tmp_path, ("cow.obj",), MINIMAL)
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    cfg.write_text(cfg.read_text().replace("dir: out", "{dir: out, swpm: false, usd: true}"))
    res = run(cfg, echo=lambda m: None)
    assert res.built == 1 and res.unlisted == ["cow.swpm"]
    unwanted = {"code": "kind-unwanted", "detail": "swpm: false"}
    assert res.orphans == [{"path": "cow.swpm", "asset": "meshes/cow.obj", "because": unwanted}]
    res = run(cfg, echo=lambda m: None)
    assert res.skipped == 1 and res.unlisted == ["cow.swpm"]
    assert res.orphans == [{"path": "cow.swpm", "asset": "meshes/cow.obj", "because": unwanted}]  # (kept)
    assert run(cfg, prune=True, echo=lambda m: None).pruned == ["cow.swpm"]
    files, listed = _listed_outputs(out)
    assert files == listed == {"cow.usdc"}


def test_parallel_jobs_and_dask_executor(tmp_path):
    import dask.distributed  # noqa: F401 - the dask extra is part of .[dev]

    cfg = _project(tmp_path, config=MINIMAL.replace("sliding-window", "vanilla"))
    res = run(cfg, jobs=2, echo=lambda m: None)
    assert res.built == 2 and res.failed == 0
    cfg2 = tmp_path / "pipeline2.yaml"
    cfg2.write_text(cfg.read_text().replace("dir: out", "dir: out_dask"))
    environ = dict(os.environ)
    res2 = run(cfg2, jobs=1, executor="dask", echo=lambda m: None)
    assert res2.built == 2 and res2.failed == 0
    # the local cluster's nanny set its workers' variables in this process (OMP_NUM_THREADS=1,
    # MALLOC_TRIM_THRESHOLD_, PYTHONHASHSEED, ...): every process the caller started later had them, and the
    # tests after this one in its xdist worker ran so
    changed = {k for k in {*environ, *os.environ} if environ.get(k) != os.environ.get(k)}
    assert not changed, sorted(changed)
    a = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]
    b = json.loads((tmp_path / "out_dask" / "manifest.json").read_text())["assets"]
    for key in a:
        assert a[key]["outputs"]["swpm"]["sha256"] == b[key]["outputs"]["swpm"]["sha256"]


def test_every_rule_encoding_is_buildable():
    schema = json.loads(schema_text())
    assert set(schema["properties"]["rules"]["items"]["properties"]["encoding"]["enum"]) == {
        *BUILDERS,
        "auto",
    }


@pytest.mark.parametrize(
    "preset", sorted((SCHEMA_PATH.parent / "presets").glob("*.yaml")), ids=lambda p: p.name
)
def test_presets_and_sample_config_are_valid(preset):
    load_config(preset)
    load_config(SCHEMA_PATH.parents[1] / "samples" / "pipeline.yaml")


def test_whole_numbers_for_an_optional_real_parameter_give_one_treatment():
    # target_slack defaults to None (the encoder's choice) and takes a real number: 1 and 1.0 build the same
    # pool, so they are one treatment; an integer parameter stays an integer
    from swpm_usd.pipeline.assets import canonical_treatment

    one = canonical_treatment(
        {"encoding": "sliding-window", "params": {"target_slack": 1, "order_passes": 2}}
    )
    other = canonical_treatment(
        {"encoding": "sliding-window", "params": {"target_slack": 1.0, "order_passes": 2}}
    )
    assert json.dumps(one, sort_keys=True) == json.dumps(other, sort_keys=True)
    assert one["params"]["target_slack"] == 1.0 and isinstance(one["params"]["target_slack"], float)
    assert isinstance(one["params"]["order_passes"], int)
    assert one["params"]["mu"] == BUILDERS["sliding-window"][1]["mu"]  # the defaults filled in
    from swpm_usd.io import load_mesh

    suzanne = load_mesh(SHARED_MESHES / "suzanne.obj")
    pools = [swpm_usd.build(suzanne, "sliding-window", target_slack=v).index_pool for v in (1, 1.0)]
    assert np.array_equal(*pools)


TWO_TRIANGLES = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"


#: a config building every ``m/*.obj`` beside it as vanilla, outputs in ``out``
VANILLA_M = "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"


def _vanilla_project(tmp_path: Path, *names: str) -> Path:
    """``tmp_path/m/<name>.obj`` (two triangles) for each of ``names`` (``a`` alone by default) and
    ``tmp_path/c.yaml`` (:data:`VANILLA_M`): the config's path."""
    (tmp_path / "m").mkdir()
    for name in names or ("a",):
        (tmp_path / "m" / f"{name}.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    cfg.write_text(VANILLA_M)
    return cfg


def _digest(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_the_run_never_overwrites_its_own_inputs(tmp_path):
    # a stage asset whose generated scene.usda would replace the stage itself (output.dir ".")
    from pxr import Usd, UsdGeom

    mesh_layer = tmp_path / "quad.usda"
    st = Usd.Stage.CreateNew(str(mesh_layer))
    st.SetDefaultPrim(UsdGeom.Xform.Define(st, "/Quad").GetPrim())
    m = UsdGeom.Mesh.Define(st, "/Quad/Geo")
    m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)])
    m.CreateFaceVertexCountsAttr([3, 3])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
    st.GetRootLayer().Save()
    scene = tmp_path / "scene.usda"
    st = Usd.Stage.CreateNew(str(scene))
    st.DefinePrim("/World/q", "Xform").GetReferences().AddReference("./quad.usda")
    st.GetRootLayer().Save()
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{stage: scene.usda}]\n"
        'output: {dir: ".", usd: true, scene: true}\ndefaults: {encoding: vanilla}\n'
    )
    before = _digest(scene)
    result = CliRunner().invoke(main, ["run", str(cfg)])
    assert result.exit_code == 2, result.output
    assert "c.yaml:3:" in result.output and "$.output.dir" in result.output
    assert "scene layer would overwrite scene.usda" in result.output
    assert _digest(scene) == before and not (tmp_path / "manifest.json").exists()
    # a glob whose files have the names of the outputs (*.usdc in the output dir), "" as "."
    (tmp_path / "beetle.usdc").write_bytes(b"")
    os.replace(mesh_layer, tmp_path / "beetle.usda")
    from pxr import Sdf

    Sdf.Layer.FindOrOpen(str(tmp_path / "beetle.usda")).Export(str(tmp_path / "beetle.usdc"))
    before = _digest(tmp_path / "beetle.usdc")
    for out_dir in ('"."', '""'):
        cfg.write_text(
            f"version: 1\nassets: [{{glob: '*.usdc'}}]\noutput: {{dir: {out_dir}, usd: true}}\n"
            "defaults: {encoding: vanilla}\n"
        )
        result = CliRunner().invoke(main, ["run", str(cfg), "--dry-run"])
        assert result.exit_code == 2, result.output
        assert "USD layer of beetle.usdc would overwrite beetle.usdc" in result.output
        assert _digest(tmp_path / "beetle.usdc") == before
    # the config itself, and a stale-temporary-file name the run deletes
    cfg2 = tmp_path / "report.html"
    cfg2.write_text("version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: .}\n")
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    with pytest.raises(ConfigError, match=r"the run report would overwrite report.html \(the configuration"):
        run(cfg2, echo=lambda m: None)
    # (of a mesh type: a glob's files of other types are not assets, so not inputs; output.dir "." holding
    # the config: a glob's files below another output.dir are never assets)
    (tmp_path / "m" / ".b.tmp.usda").write_text("#usda 1.0\n")
    cfg3 = tmp_path / "m" / "c.yaml"
    cfg3.write_text("version: 1\nassets: [{glob: '*.*'}]\noutput: {dir: .}\n")
    with pytest.raises(ConfigError, match="named like a temporary file"):
        run(cfg3, echo=lambda m: None)
    cfg3.unlink()
    # apart from the inputs, the same config runs
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    assert run(cfg, echo=lambda m: None).built == 1


@pytest.mark.parametrize(
    ("stage", "glob", "output", "message"),
    [
        ("Scene.usda", None, "usd: true, scene: true", "the scene layer would overwrite out/Scene.usda"),
        # (Café in NFD, the run's Café.usdc in NFC: one name to macOS)
        (
            "Cafe\u0301.usdc",
            "m/Caf\u00e9.obj",
            "usd: true",
            "of m/Caf\u00e9.obj would overwrite out/Cafe\u0301.usdc",
        ),
    ],
)
def test_an_output_named_as_an_input_but_for_case_or_normalization_is_refused(
    tmp_path, stage, glob, output, message
):
    # the inputs were compared with the outputs by their exact paths: on a case-insensitive filesystem
    # out/scene.usda, which the run writes, is out/Scene.usda, a stage of the config
    from pxr import Sdf

    (tmp_path / "out").mkdir()
    layer = tmp_path / "quad.usda"
    _quad_stage(layer)
    Sdf.Layer.FindOrOpen(str(layer)).Export(str(tmp_path / "out" / stage))
    before = _digest(tmp_path / "out" / stage)
    assets = f"[{{stage: 'out/{stage}'}}]"
    if glob is not None:
        (tmp_path / "m").mkdir()
        (tmp_path / glob).write_text(TWO_TRIANGLES)
        assets = f"[{{stage: 'out/{stage}'}}, {{glob: 'm/*.obj'}}]"
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        f"version: 1\nassets: {assets}\noutput: {{dir: out, {output}}}\ndefaults: {{encoding: vanilla}}\n"
    )
    with pytest.raises(ConfigError, match=message):
        run(cfg, echo=lambda m: None)
    assert _digest(tmp_path / "out" / stage) == before and not (tmp_path / "out" / "manifest.json").exists()


def test_tightened_budgets_or_streaming_and_changed_outputs_rebuild(tmp_path):
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    base = "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    cfg.write_text(base + "budgets: {global_bytes: 1000000}\n")
    assert run(cfg, echo=lambda m: None).built == 1
    assert run(cfg, echo=lambda m: None).skipped == 1
    # a budget the asset no longer meets is checked again, not skipped as up to date
    cfg.write_text(base + "budgets: {global_bytes: 1}\n")
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and "budgets.global_bytes=1" in res.failures["m/a.obj"]["error"]
    # its previous build is kept (see test_a_failed_rebuild_keeps_the_previous_build): with the budget it
    # passed back, it is up to date
    assert "budgets.global_bytes=1" in res.records["m/a.obj"]["last_failure"]["error"]
    cfg.write_text(base + "budgets: {global_bytes: 1000000}\n")
    res = run(cfg, echo=lambda m: None)
    assert (res.skipped, res.failed) == (1, 0) and "last_failure" not in res.records["m/a.obj"]
    # a looser or dropped limit lets through what passed before: nothing to build (a studio loosening a
    # budget over thousands of assets rebuilds none of them)
    for looser in ("budgets: {global_bytes: 2000000}\n", "", "budgets: {global_bytes: 1000000}\n"):
        cfg.write_text(base + looser)
        assert run(cfg, echo=lambda m: None).skipped == 1, looser
    # a limit added, or a streaming order given, builds again; a minimum dropped does not
    two = "budgets: {global_bytes: 1000000, instance_bytes: 1000000}\n"
    for text, built in (
        (two, 1),
        (two + "streaming: {order: coarse-to-fine}\n", 1),
        (two + "streaming: {order: coarse-to-fine, min_coarsest_triangles: 0}\n", 1),
        (two + "streaming: {order: coarse-to-fine}\n", 0),
    ):
        cfg.write_text(base + text)
        res = run(cfg, echo=lambda m: None)
        assert (res.built, res.skipped) == (built, 1 - built), text
    cfg.write_text(base + "budgets: {global_bytes: 1000000}\nstreaming: {coarsest_lod_bytes: 1}\n")
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and "coarsest_lod_bytes" in res.failures["m/a.obj"]["error"]
    # an output changed in place (same size) is rebuilt: its sha256 is compared, not only its size
    cfg.write_text(base)
    assert run(cfg, echo=lambda m: None).built == 1
    out = tmp_path / "out" / "a.swpm"
    data = bytearray(out.read_bytes())
    data[len(data) // 2] ^= 0xFF
    out.write_bytes(bytes(data))
    assert run(cfg, echo=lambda m: None).built == 1
    assert swpm_usd.validate(out).valid


def _output_reads(monkeypatch, out: Path) -> list[str]:
    """The names of the outputs (.swpm, .usdc) in ``out`` this process opens from now on, in order."""
    import builtins

    real = builtins.open
    opened: list[str] = []

    def spy(file, *args, **kwargs):
        if isinstance(file, (str, os.PathLike)):
            p = Path(file)
            if p.parent == out and p.suffix in (".swpm", ".usdc"):
                opened.append(p.name)
        return real(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", spy)
    return opened


STAT_KEYS = ("mtime_ns", "ctime_ns", "ino", "dev")


def _recorded_outputs(out: Path) -> dict[str, dict]:
    manifest = json.loads((out / "manifest.json").read_text())
    return {o["path"]: o for rec in manifest["assets"].values() for o in rec.get("outputs", {}).values()}


def test_a_rerun_reads_no_output_whose_size_and_stat_are_as_recorded(tmp_path, monkeypatch):
    # every rerun hashed (sha256) every output of every asset to find it intact: with thousands of assets,
    # most of a rerun's time; the manifest now records each output's stat, and a file found with the same
    # size, mtime, ctime, inode and device is not read
    cfg = _project(tmp_path, config=MINIMAL.replace("dir: out", "{dir: out, usd: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    recorded = _recorded_outputs(out)
    assert sorted(recorded) == ["cow.swpm", "cow.usdc", "spot.swpm", "spot.usdc"]
    for name, o in recorded.items():
        st = (out / name).stat()
        assert (o["size"], o["sha256"]) == (st.st_size, sha256_of(out / name))
        assert [o[k] for k in STAT_KEYS] == [st.st_mtime_ns, st.st_ctime_ns, st.st_ino, st.st_dev]
    reads = _output_reads(monkeypatch, out)
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == []
    # touched (mtime moved, bytes the same): hashed, up to date, its stat recorded anew; then trusted again
    cow = out / "cow.swpm"
    st = cow.stat()
    os.utime(cow, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == ["cow.swpm"]
    assert _recorded_outputs(out)["cow.swpm"]["mtime_ns"] == st.st_mtime_ns + 10**9
    reads.clear()
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == []
    # the same size, other bytes, a later mtime: hashed, rebuilt
    data = bytearray(cow.read_bytes())
    data[len(data) // 2] ^= 0xFF
    cow.write_bytes(bytes(data))
    assert run(cfg, echo=lambda m: None).built == 1 and swpm_usd.validate(cow).valid
    # the same size, other bytes, the recorded mtime set back (os.utime): the ctime moved, rebuilt
    st = cow.stat()
    data = bytearray(cow.read_bytes())
    data[len(data) // 2] ^= 0xFF
    cow.write_bytes(bytes(data))
    os.utime(cow, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert cow.stat().st_mtime_ns == st.st_mtime_ns
    assert run(cfg, echo=lambda m: None).built == 1 and swpm_usd.validate(cow).valid
    # another file of the same size and mtime renamed over it (another inode): rebuilt
    spot = out / "spot.usdc"
    st = spot.stat()
    other = out / "other.usdc"
    other.write_bytes(bytes(st.st_size))
    os.utime(other, ns=(st.st_atime_ns, st.st_mtime_ns))
    other.replace(spot)
    assert (
        run(cfg, echo=lambda m: None).built == 1
        and sha256_of(spot) == _recorded_outputs(out)["spot.usdc"]["sha256"]
    )
    reads.clear()
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == []


def test_outputs_of_an_older_manifest_are_hashed_once_then_trusted(tmp_path, monkeypatch):
    # a manifest written before outputs had their stat recorded: each output hashed as before, its stat
    # then recorded, and the next rerun reads none
    cfg = _project(tmp_path, config=MINIMAL.replace("dir: out", "{dir: out, usd: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    manifest = json.loads((out / "manifest.json").read_text())
    for rec in manifest["assets"].values():
        for o in rec["outputs"].values():
            for k in STAT_KEYS:
                del o[k]
    (out / "manifest.json").write_text(json.dumps(manifest))
    reads = _output_reads(monkeypatch, out)
    assert run(cfg, echo=lambda m: None).skipped == 2
    assert sorted(reads) == ["cow.swpm", "cow.usdc", "spot.swpm", "spot.usdc"]
    for name, o in _recorded_outputs(out).items():
        st = (out / name).stat()
        assert [o[k] for k in STAT_KEYS] == [st.st_mtime_ns, st.st_ctime_ns, st.st_ino, st.st_dev]
    reads.clear()
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == []
    # the outputs of a removed asset (orphaned_outputs, checked on every run until --prune) keep their stat
    (tmp_path / "meshes" / "spot.obj").unlink()
    res = run(cfg, echo=lambda m: None)
    assert sorted(res.unlisted) == ["spot.swpm", "spot.usdc"] and reads == []
    orphaned = json.loads((out / "manifest.json").read_text())["orphaned_outputs"]
    assert all(set(STAT_KEYS) <= set(o) for o in orphaned)
    assert sorted(run(cfg, echo=lambda m: None).unlisted) == ["spot.swpm", "spot.usdc"] and reads == []
    assert run(cfg, prune=True, echo=lambda m: None).pruned and not (out / "spot.swpm").exists()


def test_verify_hashes_every_output(tmp_path, monkeypatch):
    # what the stat cannot show (bytes changed with none of size, mtime, ctime, inode moving: a disk's silent
    # corruption), --verify finds: here the recorded sha256 is made wrong instead
    cfg = _project(tmp_path, config=MINIMAL.replace("dir: out", "{dir: out, usd: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["assets"]["meshes/cow.obj"]["outputs"]["usd"]["sha256"] = "0" * 64
    (out / "manifest.json").write_text(json.dumps(manifest))
    reads = _output_reads(monkeypatch, out)
    assert run(cfg, dry_run=True, echo=lambda m: None).skipped == 2 and reads == []
    assert run(cfg, dry_run=True, verify=True, echo=lambda m: None).skipped == 1
    assert sorted(reads) == ["cow.swpm", "cow.usdc", "spot.swpm", "spot.usdc"]
    r = CliRunner().invoke(main, ["run", str(cfg), "--verify", "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["built"] == 1, r.output
    assert _recorded_outputs(out)["cow.usdc"]["sha256"] == sha256_of(out / "cow.usdc")
    assert "--verify" in CliRunner().invoke(main, ["run", "--help"]).output


def _input_reads(monkeypatch, folder: Path) -> list[str]:
    """The names of the files in ``folder`` (the assets' inputs) this process opens from now on, in order."""
    import builtins

    real = builtins.open
    opened: list[str] = []

    def spy(file, *args, **kwargs):
        if isinstance(file, (str, os.PathLike)) and Path(file).parent == folder:
            opened.append(Path(file).name)
        return real(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", spy)
    return opened


INPUT_KEYS = ("size", *STAT_KEYS, "hashed_ns")


def _recorded_inputs(out: Path) -> dict[str, list[dict]]:
    """Asset id -> its record's ``inputs`` (or the list of the manifest's ``input_lists`` its ``inputs_ref``
    names: one several records share)."""
    manifest = json.loads((out / "manifest.json").read_text())
    tables = manifest.get("input_lists", {})
    return {
        aid: tables[rec["inputs_ref"]] if "inputs_ref" in rec else rec.get("inputs")
        for aid, rec in manifest["assets"].items()
    }


def _as_hashed(entry: dict, path: Path) -> bool:
    """Is ``entry`` (an input's in a record: its path relative to the config's folder, or absolute) ``path``
    with its current size and stat?"""
    st = path.stat()
    recorded = Path(entry["path"])
    same = (
        recorded == path if recorded.is_absolute() else path.parts[-len(recorded.parts) :] == recorded.parts
    )
    return same and [entry[k] for k in ("size", *STAT_KEYS)] == [
        st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino, st.st_dev,
    ]  # fmt: skip


def _same_size_edit(path: Path, after: bytes = b"\nv ") -> None:
    """Change the first digit after ``after`` in ``path`` (an OBJ's first vertex), in place, its size the
    same and its mtime set back (os.utime): only its ctime shows the edit."""
    st = path.stat()
    data = path.read_bytes()
    i = data.index(after) + len(after)
    while data[i : i + 1] not in b"0123456789":
        i += 1
    path.write_bytes(data[:i] + (b"7" if data[i : i + 1] != b"7" else b"8") + data[i + 1 :])
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert (path.stat().st_size, path.stat().st_mtime_ns) == (st.st_size, st.st_mtime_ns)


def test_a_rerun_reads_no_input_whose_size_and_stat_are_as_recorded(tmp_path, monkeypatch):
    # every rerun hashed every input file of every asset (1,000 assets of 10 MB: 10 GB read with nothing
    # changed); the manifest now records each input's size and stat as it was hashed, and a rerun that finds
    # them unchanged takes the recorded input digest without reading the file
    from swpm_usd.pipeline import inputs
    from swpm_usd.pipeline.assets import file_digest

    monkeypatch.setattr(inputs, "_RACY_NS", 0)  # (inputs just written: see the racily clean test)
    cfg = _project(tmp_path, config=MINIMAL)
    out, meshes = tmp_path / "out", tmp_path / "meshes"
    assert run(cfg, echo=lambda m: None).built == 2
    for aid, entries in _recorded_inputs(out).items():
        (entry,) = entries
        assert _as_hashed(entry, tmp_path / aid) and set(entry) == {"path", *INPUT_KEYS}, entry
    reads = _input_reads(monkeypatch, meshes)
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == []
    # a same-size edit with the mtime set back: the ctime moved, hashed, rebuilt
    spot, cow = meshes / "spot.obj", meshes / "cow.obj"
    _same_size_edit(spot)
    res = run(cfg, echo=lambda m: None)
    assert res.built == 1 and res.records["meshes/spot.obj"]["input_digest"] == file_digest([spot])
    assert _as_hashed(_recorded_inputs(out)["meshes/spot.obj"][0], spot)
    # a copy of the same bytes and mtime renamed over an input (another inode): hashed, the digest the same,
    # nothing rebuilt; its stat recorded anew, then trusted
    st = cow.stat()
    shutil.copyfile(cow, tmp_path / "cow-copy")
    os.utime(tmp_path / "cow-copy", ns=(st.st_atime_ns, st.st_mtime_ns))
    (tmp_path / "cow-copy").replace(cow)
    assert cow.stat().st_ino != st.st_ino
    reads.clear()
    assert not _as_hashed(_recorded_inputs(out)["meshes/cow.obj"][0], cow)
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped) == (0, 2) and reads == ["cow.obj"]
    assert _as_hashed(_recorded_inputs(out)["meshes/cow.obj"][0], cow)
    assert res.records["meshes/cow.obj"]["input_digest"] == file_digest([cow])
    reads.clear()
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == []


def test_an_input_gone_after_it_was_listed_fails_its_asset_alone(tmp_path, monkeypatch):
    # an input listed by the glob and gone (or unreadable) when the plan hashed it stopped the whole run
    # with a traceback (FileNotFoundError out of the plan, or out of the largest-first ordering); now that
    # asset fails with its loader's error naming the file, its previous build is kept, the others build
    from swpm_usd.pipeline import runner

    cfg = _project(tmp_path, config=MINIMAL)
    out, spot = tmp_path / "out", tmp_path / "meshes" / "spot.obj"
    assert run(cfg, echo=lambda m: None).built == 2
    listed = runner.discover

    def discover_then_lose_spot(config, *args):
        found = listed(config, *args)
        spot.rename(tmp_path / "spot.away")
        return found

    monkeypatch.setattr(runner, "discover", discover_then_lose_spot)
    res = run(cfg, force=True, echo=lambda m: None)
    assert (res.built, res.failed) == (1, 1)
    failure = res.failures["meshes/spot.obj"]
    assert "spot.obj" in failure["error"] and failure["kept_previous"]
    assert (out / "spot.swpm").exists()
    # back in place, the same bytes: the kept build is up to date (the record kept is the previous build's)
    monkeypatch.setattr(runner, "discover", listed)
    (tmp_path / "spot.away").rename(spot)
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped, res.failed) == (0, 2, 0)


def test_a_glob_takes_its_mesh_files_only(tmp_path):
    # `glob: "*.*"` (or "meshes/*" beside .mtl and texture files) took every file it matched as an asset: the
    # config itself, a texture and a README each failed as "unsupported file type"; a glob's assets are
    # its files of a mesh type, and a glob that matches files but no mesh says so
    cfg = _project(tmp_path, config=MINIMAL.replace('"meshes/*.obj"', '"**/*.*"'))
    (tmp_path / "meshes" / "albedo.png").write_bytes(b"\x89PNG")
    (tmp_path / "meshes" / "README.TXT").write_text("where the meshes are from")
    (tmp_path / "meshes" / "SPOT2.OBJ").write_bytes((tmp_path / "meshes" / "spot.obj").read_bytes())
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.failed) == (3, 0), res.failures
    assert set(res.records) == {"meshes/cow.obj", "meshes/spot.obj", "meshes/SPOT2.OBJ"}
    only_other = tmp_path / "other.yaml"
    pngs = MINIMAL.replace('"meshes/*.obj"', '"meshes/*.png"')
    only_other.write_text(pngs.replace("dir: out", "dir: out2"))
    result = CliRunner().invoke(main, ["run", str(only_other)])
    assert result.exit_code == 2, result.output
    assert "the glob matches no mesh file (1 file of another type: meshes/albedo.png)" in result.output


def _two_layer_stage(tmp_path: Path) -> tuple[Path, Path]:
    """stage/scene.usda referencing stage/spot_asset.usda (two Mesh prims, spot's), and a config of the
    stage: (the config, the referenced layer)."""
    from pxr import Usd, UsdGeom

    (tmp_path / "stage").mkdir()
    mesh = swpm_usd.load_mesh(SHARED_MESHES / "spot.obj")
    layer = tmp_path / "stage" / "spot_asset.usda"
    st = Usd.Stage.CreateNew(str(layer))
    st.SetDefaultPrim(UsdGeom.Xform.Define(st, "/Spot").GetPrim())
    for name in ("Body", "Copy"):
        m = UsdGeom.Mesh.Define(st, f"/Spot/{name}")
        m.CreatePointsAttr(mesh.points)
        m.CreateFaceVertexCountsAttr([3] * mesh.triangle_count)
        m.CreateFaceVertexIndicesAttr(mesh.triangles.reshape(-1))
    st.GetRootLayer().Save()
    scene = tmp_path / "stage" / "scene.usda"
    st = Usd.Stage.CreateNew(str(scene))
    st.DefinePrim("/World/spot", "Xform").GetReferences().AddReference("./spot_asset.usda")
    st.GetRootLayer().Save()
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text("version: 1\nassets: [{stage: stage/scene.usda}]\noutput: {dir: out}\n")
    return cfg, layer


def test_a_stage_s_prims_share_the_hash_of_its_layers_and_a_rerun_reads_none(tmp_path, monkeypatch):
    # a stage asset's inputs are the stage and every layer it uses: each listed with its stat, hashed once
    # for all the stage's prims, and read by no rerun until one of them changes
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg, layer = _two_layer_stage(tmp_path)
    reads = _input_reads(monkeypatch, tmp_path / "stage")
    assert run(cfg, echo=lambda m: None).built == 2
    assert sorted(reads) == ["scene.usda", "spot_asset.usda"]  # (USD reads them itself, not through open)
    recorded = _recorded_inputs(tmp_path / "out")
    assert len(recorded) == 2
    for entries in recorded.values():
        assert sorted(Path(e["path"]).name for e in entries) == ["scene.usda", "spot_asset.usda"]
        assert all(_as_hashed(e, tmp_path / e["path"]) for e in entries)
    reads.clear()
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == []
    _same_size_edit(layer, b"points = [(")  # (the first prim's first point)
    reads.clear()
    assert run(cfg, echo=lambda m: None).built == 2 and sorted(reads) == ["scene.usda", "spot_asset.usda"]
    reads.clear()
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == []


def test_a_stage_s_layers_are_its_inputs_in_one_order_whatever_order_usd_gives(tmp_path, monkeypatch):
    # Usd.Stage.GetUsedLayers returns a set of layer handles, in the order of their addresses, which differs
    # from one process to the next: the stage's inputs were listed, hashed and compared with the record in
    # that order, so a rerun (a new swpm-pipeline process) took the same layers for other inputs, hashed
    # them to another digest and rebuilt every prim of the stage
    from pxr import Usd

    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg, _ = _two_layer_stage(tmp_path)
    assert run(cfg, echo=lambda m: None).built == 2
    used = Usd.Stage.GetUsedLayers
    reads = _input_reads(monkeypatch, tmp_path / "stage")
    for reverse in (False, True):

        def by_name(stage, *args, reverse=reverse):
            return sorted(used(stage, *args), key=lambda layer: layer.identifier, reverse=reverse)

        monkeypatch.setattr(Usd.Stage, "GetUsedLayers", by_name)
        reads.clear()
        assert run(cfg, echo=lambda m: None).skipped == 2 and reads == [], reverse


def test_a_usdz_stage_s_input_is_its_package(tmp_path, monkeypatch):
    # the layers of a .usdz stage are in the package, `pkg.usdz[scene.usda]`: that was taken for an input
    # file, and the run stopped in the plan with a traceback (FileNotFoundError) hashing it
    from pxr import Sdf, UsdUtils

    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg, _ = _two_layer_stage(tmp_path)
    pkg = tmp_path / "pkg.usdz"
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(str(tmp_path / "stage" / "scene.usda")), str(pkg))
    cfg.write_text("version: 1\nassets: [{stage: pkg.usdz}]\noutput: {dir: out}\n")
    assert run(cfg, echo=lambda m: None).built == 2
    for entries in _recorded_inputs(tmp_path / "out").values():
        assert [e["path"] for e in entries] == ["pkg.usdz"] and _as_hashed(entries[0], pkg)
    assert run(cfg, echo=lambda m: None).skipped == 2


def test_a_gltf_s_buffer_files_are_its_inputs(tmp_path, monkeypatch):
    # a .gltf's vertices and triangles are in the buffer files its `buffers` name (model.gltf + *.bin), which
    # the loader reads beside it: they were no input of the asset, so a .bin edited (new vertices) left the
    # asset "up to date", its stale build kept
    import numpy as np
    import trimesh

    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    (tmp_path / "m").mkdir()
    spot = swpm_usd.load_mesh(SHARED_MESHES / "spot.obj")
    mesh = trimesh.Trimesh(spot.points, spot.triangles, process=False)
    files = trimesh.Scene(mesh).export(file_type="gltf")
    for name, data in files.items():
        (tmp_path / "m" / name).write_bytes(data)
    bins = sorted(tmp_path / "m" / name for name in files if name.endswith(".bin"))
    assert bins and (tmp_path / "m" / "model.gltf").is_file()
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text("version: 1\nassets: [{glob: m/*.gltf}]\noutput: {dir: out}\n")
    assert run(cfg, echo=lambda m: None).built == 1
    (entries,) = _recorded_inputs(tmp_path / "out").values()
    assert [(tmp_path / e["path"]) for e in entries] == [tmp_path / "m" / "model.gltf", *bins]
    assert run(cfg, echo=lambda m: None).skipped == 1
    # the buffers of the mesh scaled by 2 (the same names and sizes), the .gltf left as it is (its accessors'
    # min and max, which the loader does not check, no longer the data's)
    points = swpm_usd.load_mesh(tmp_path / "m" / "model.gltf").points
    scaled = trimesh.Scene(mesh.copy().apply_scale(2.0)).export(file_type="gltf")
    for b in bins:
        assert len(scaled[b.name]) == b.stat().st_size
        b.write_bytes(scaled[b.name])
    assert np.allclose(swpm_usd.load_mesh(tmp_path / "m" / "model.gltf").points, 2 * points)
    assert run(cfg, echo=lambda m: None).built == 1


def test_a_swpm_whose_rule_the_worker_chose_holds_its_asset_s_digest(tmp_path):
    # a rule on triangle counts leaves a new asset's rule to the worker, which computes its digest: the .swpm
    # held the plan's, empty ("source_digest":"")
    cfg = _project(tmp_path, meshes=("cow.obj",), config=MINIMAL)
    assert run(cfg, echo=lambda m: None).built == 1
    rec = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]["meshes/cow.obj"]
    assert len(rec["digest"]) == 64
    assert f'"source_digest":"asset:{rec["digest"]}"'.encode() in (tmp_path / "out" / "cow.swpm").read_bytes()


_NO_COUNT_RULE = "version: 1\nassets: [{glob: meshes/*.obj}]\noutput: {dir: out}\n"
# (auto, with instances and budgets: every part of the digest the worker computes again)
_AUTO_RULE = """\
version: 1
assets: [{glob: meshes/*.obj, instances: 500}]
output: {dir: out}
budgets: {total_bytes: 100000000}
rules: [{name: auto, encoding: auto}]
"""


@pytest.mark.parametrize(
    "config",
    [MINIMAL, _NO_COUNT_RULE, _AUTO_RULE],
    ids=["rule-by-the-worker", "rule-planned", "auto-with-instances-and-budgets"],
)
def test_an_input_changed_between_plan_and_build_is_built_and_recorded_as_loaded(
    tmp_path, monkeypatch, config
):
    # the worker loads the input after the plan hashed it: an input changed in between was built, its record
    # (and its .swpm's source digest) holding the digest and stat of the bytes the plan hashed, not those it
    # was built from. Stable across the worker's own load, it is built and hashed once loaded: the record
    # holds the digest and stat of the bytes loaded, the .swpm its digest, and the next run skips it
    from swpm_usd.pipeline import inputs, runner
    from swpm_usd.pipeline.assets import file_digest

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg = _project(tmp_path, meshes=("cow.obj",), config=config)
    cow = tmp_path / "meshes" / "cow.obj"
    planned = file_digest([cow])
    real = runner.process_asset

    def edited_first(task):
        _same_size_edit(cow)
        return real(task)

    monkeypatch.setattr(runner, "process_asset", edited_first)
    assert run(cfg, echo=lambda m: None).built == 1
    monkeypatch.setattr(runner, "process_asset", real)
    rec = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]["meshes/cow.obj"]
    assert rec["input_digest"] == file_digest([cow]) != planned
    assert _as_hashed(_recorded_inputs(tmp_path / "out")["meshes/cow.obj"][0], cow)
    assert f'"source_digest":"asset:{rec["digest"]}"'.encode() in (tmp_path / "out" / "cow.swpm").read_bytes()
    assert run(cfg, echo=lambda m: None).skipped == 1


def test_an_input_the_plan_hashed_while_it_changed_is_hashed_by_the_worker_once_loaded(tmp_path, monkeypatch):
    # the plan's hash saw it change (no stat recorded, a digest of no one version): built, its record held
    # that digest; the worker hashes the bytes it loaded, and the next run skips it
    from swpm_usd.pipeline import inputs, runner
    from swpm_usd.pipeline.assets import file_digest

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg = _project(tmp_path, meshes=("cow.obj",), config=_NO_COUNT_RULE)
    cow = tmp_path / "meshes" / "cow.obj"
    real = runner.hash_inputs

    def unsettled(paths):
        _, entries = real(paths)
        return "0" * 64, [{"path": e["path"]} for e in entries]

    monkeypatch.setattr(runner, "hash_inputs", unsettled)
    assert run(cfg, echo=lambda m: None).built == 1
    monkeypatch.setattr(runner, "hash_inputs", real)
    rec = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]["meshes/cow.obj"]
    assert rec["input_digest"] == file_digest([cow])
    assert _as_hashed(_recorded_inputs(tmp_path / "out")["meshes/cow.obj"][0], cow)
    assert run(cfg, echo=lambda m: None).skipped == 1


def test_an_input_changed_since_the_plan_and_again_once_loaded_is_refused(tmp_path, monkeypatch):
    # changed since the plan, it is hashed once loaded: another file by then (changed again after the load),
    # the digest would be of bytes it was not built from
    from swpm_usd.pipeline import assets, inputs, runner

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg = _project(tmp_path, meshes=("cow.obj",), config=_NO_COUNT_RULE)
    cow = tmp_path / "meshes" / "cow.obj"
    real, hash_inputs = runner.process_asset, assets.hash_inputs

    def edited_first(task):
        _same_size_edit(cow)
        return real(task)

    def edited_again(paths):  # (the worker's hash, once the load has read the file)
        _same_size_edit(cow)
        return hash_inputs(paths)

    monkeypatch.setattr(runner, "process_asset", edited_first)
    monkeypatch.setattr(assets, "hash_inputs", edited_again)
    res = run(cfg, echo=lambda m: None)
    (failure,) = res.failures.values()
    assert (res.built, failure["code"]) == (0, "INPUT_CHANGED"), failure
    assert f"{cow}: changed while it was read (hashed once loaded" in failure["error"], failure
    assert not (tmp_path / "out" / "cow.swpm").exists()


def test_an_input_changed_since_the_plan_with_another_triangle_count_than_its_rule_s_is_refused(
    tmp_path, monkeypatch
):
    # its rule chosen by the plan for the count the record held: built from bytes of another count, the
    # asset would be recorded with a rule that is not the one its triangles match
    from swpm_usd.pipeline import inputs, runner

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg = _project(tmp_path, meshes=("cow.obj",), config=MINIMAL)
    cow = tmp_path / "meshes" / "cow.obj"
    assert run(cfg, echo=lambda m: None).built == 1
    (
        tmp_path / "out" / "cow.swpm"
    ).unlink()  # (its input unchanged: the plan routes it by its record's count)
    real = runner.process_asset

    def one_face_less(task):
        assert task["rule_triangles"] is not None
        data = cow.read_bytes()
        face = data.rindex(b"\nf ") + 1  # (its last face line removed)
        end = data.find(b"\n", face)
        cow.write_bytes(data[:face] + (data[end + 1 :] if end >= 0 else b""))
        return real(task)

    monkeypatch.setattr(runner, "process_asset", one_face_less)
    res = run(cfg, echo=lambda m: None)
    (failure,) = res.failures.values()
    assert (res.built, failure["code"]) == (0, "INPUT_CHANGED"), failure
    assert "its rule chosen for" in failure["error"], failure
    monkeypatch.setattr(runner, "process_asset", real)
    assert run(cfg, echo=lambda m: None).built == 1
    assert run(cfg, echo=lambda m: None).skipped == 1


def test_a_file_naming_other_inputs_changed_since_the_plan_is_refused(tmp_path, monkeypatch):
    # a glTF names its buffers: changed since the plan, the loader may read others than the plan listed,
    # which the record would list unread by the next run. Its buffers changed alone are built and recorded
    import trimesh

    from swpm_usd.pipeline import inputs, runner
    from swpm_usd.pipeline.assets import file_digest

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    (tmp_path / "m").mkdir()
    spot = swpm_usd.load_mesh(SHARED_MESHES / "spot.obj")
    files = trimesh.Scene(trimesh.Trimesh(spot.points, spot.triangles, process=False)).export(
        file_type="gltf"
    )
    for name, data in files.items():
        (tmp_path / "m" / name).write_bytes(data)
    gltf = tmp_path / "m" / "model.gltf"
    bins = sorted(tmp_path / "m" / name for name in files if name.endswith(".bin"))
    buffer = bins[0]
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text("version: 1\nassets: [{glob: m/*.gltf}]\noutput: {dir: out}\n")
    real = runner.process_asset

    def touched(path):
        def edit(task):
            os.utime(path, ns=(path.stat().st_atime_ns, path.stat().st_mtime_ns + 1_000_000_000))
            return real(task)

        return edit

    monkeypatch.setattr(runner, "process_asset", touched(gltf))
    res = run(cfg, echo=lambda m: None)
    (failure,) = res.failures.values()
    assert (
        failure["code"] == "INPUT_CHANGED" and f"{gltf}: changed since the run hashed it" in failure["error"]
    )
    monkeypatch.setattr(runner, "process_asset", touched(buffer))
    assert run(cfg, echo=lambda m: None).built == 1
    monkeypatch.setattr(runner, "process_asset", real)
    (entries,) = _recorded_inputs(tmp_path / "out").values()
    assert len(entries) == 1 + len(bins) and all(map(_as_hashed, entries, [gltf, *bins]))
    rec = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]["m/model.gltf"]
    assert rec["input_digest"] == file_digest([gltf, *bins])
    assert run(cfg, echo=lambda m: None).skipped == 1


def test_verify_hashes_every_input(tmp_path, monkeypatch):
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg = _project(tmp_path, config=MINIMAL)
    assert run(cfg, echo=lambda m: None).built == 2
    reads = _input_reads(monkeypatch, tmp_path / "meshes")
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == []
    assert run(cfg, dry_run=True, verify=True, echo=lambda m: None).skipped == 2
    assert sorted(reads) == ["cow.obj", "spot.obj"]
    reads.clear()
    assert run(cfg, verify=True, echo=lambda m: None).skipped == 2
    assert sorted(reads) == ["cow.obj", "spot.obj"]
    help_text = " ".join(CliRunner().invoke(main, ["run", "--help"]).output.split())
    assert "--verify Hash every input file and recorded output" in help_text


def _files_as_written(out: Path) -> dict[str, tuple[int, int, int]]:
    """Each file of ``out`` (the lock's too: a run that writes nothing leaves it as it was) -> its inode,
    mtime and ctime."""
    return {
        p.name: (p.stat().st_ino, p.stat().st_mtime_ns, p.stat().st_ctime_ns) for p in sorted(out.iterdir())
    }


def test_verify_of_an_unchanged_tree_writes_nothing_and_rebuilds_what_it_finds_changed(tmp_path, monkeypatch):
    # --verify hashed every input, then recorded each input anew (its hashed_ns moved): the manifest changed,
    # so the manifest, scene.usda and report.html were all written again on every verify of an unchanged tree
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)  # (inputs trusted as soon as they were hashed)
    cfg = _project(tmp_path, config=MINIMAL.replace("dir: out", "{dir: out, usd: true, scene: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    written = _files_as_written(out)
    assert {"manifest.json", "scene.usda", "report.html", "cow.swpm", "spot.usdc"} <= set(written)
    for _ in range(2):
        res = run(cfg, verify=True, echo=lambda m: None)
        assert (res.built, res.skipped) == (0, 2)
        assert _files_as_written(out) == written
    # bytes changed with a stat that does not show it (the manifest given the files' stat after the change)
    swpm = out / "cow.swpm"
    st = swpm.stat()
    data = bytearray(swpm.read_bytes())
    data[len(data) // 2] ^= 0xFF
    swpm.write_bytes(bytes(data))
    os.utime(swpm, ns=(st.st_atime_ns, st.st_mtime_ns))
    spot = tmp_path / "meshes" / "spot.obj"
    _same_size_edit(spot)
    manifest = json.loads((out / "manifest.json").read_text())
    cow_out = manifest["assets"]["meshes/cow.obj"]["outputs"]["swpm"]
    cow_out.update(mtime_ns=swpm.stat().st_mtime_ns, ctime_ns=swpm.stat().st_ctime_ns)
    (spot_in,) = manifest["assets"]["meshes/spot.obj"]["inputs"]
    spot_in.update(ctime_ns=spot.stat().st_ctime_ns, hashed_ns=spot.stat().st_ctime_ns + 1)
    old_digest = manifest["assets"]["meshes/spot.obj"]["input_digest"]
    (out / "manifest.json").write_text(json.dumps(manifest))
    assert run(cfg, dry_run=True, echo=lambda m: None).skipped == 2  # (the stat trusted: not seen)
    res = run(cfg, verify=True, echo=lambda m: None)
    assert sorted(res.built_ids) == ["meshes/cow.obj", "meshes/spot.obj"]
    assert _recorded_outputs(out)["cow.swpm"]["sha256"] == sha256_of(swpm)
    assert res.records["meshes/spot.obj"]["input_digest"] != old_digest
    written = _files_as_written(out)
    assert run(cfg, verify=True, echo=lambda m: None).skipped == 2 and _files_as_written(out) == written


def test_a_moved_project_is_a_rerun_that_changes_nothing(tmp_path, monkeypatch):
    # records held each input's absolute path and the config's: a project folder renamed (its config,
    # inputs and output.dir with it) had every input hashed again and the manifest, scene and report
    # rewritten. They are relative to the config's folder (the config's to output.dir) now; an input given
    # by an absolute path elsewhere (a stage in a shared library) keeps its absolute path

    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)  # (inputs trusted as soon as they were hashed)
    library = tmp_path / "library"
    library.mkdir()
    quad = library / "quad.usda"
    _quad_stage(quad)
    project = tmp_path / "a"
    project.mkdir()
    cfg = _project(
        project,
        meshes=("cow.obj",),
        config=f"version: 1\nassets:\n  - glob: 'meshes/*.obj'\n  - stage: '{quad}'\n"
        "output: {dir: out, usd: true, scene: true}\ndefaults: {encoding: vanilla}\n",
    )
    assert run(cfg, echo=lambda m: None).built == 2
    manifest = json.loads((project / "out" / "manifest.json").read_text())
    assert manifest["config"] == "../pipeline.yaml"
    recorded = _recorded_inputs(project / "out")
    assert [e["path"] for e in recorded["meshes/cow.obj"]] == ["meshes/cow.obj"]
    assert [e["path"] for e in recorded[f"{quad}:/Quad"]] == [str(quad)]
    assert f"config\n{cfg}:" in (project / "out" / "report.html").read_text()
    written = _files_as_written(project / "out")
    moved = tmp_path / "b"
    os.rename(project, moved)
    reads = _input_reads(monkeypatch, moved / "meshes")
    res = run(moved / "pipeline.yaml", echo=lambda m: None)
    assert (res.built, res.skipped) == (0, 2) and reads == [] and not res.warnings
    # the report named the old path until a run wrote it for another reason: it is rewritten (with the
    # manifest, which records it, and the lock file given the pid of a run that writes), the rest as it was
    rewritten = {"report.html", "manifest.json", ".swpm-pipeline.lock"}
    now = _files_as_written(moved / "out")
    assert {k: v for k, v in now.items() if k not in rewritten} == {
        k: v for k, v in written.items() if k not in rewritten
    }
    assert f"config\n{moved / 'pipeline.yaml'}:" in (moved / "out" / "report.html").read_text()
    manifest = json.loads((moved / "out" / "manifest.json").read_text())
    assert manifest["run_outputs"]["report"]["config"] == str(moved / "pipeline.yaml")
    assert manifest["config"] == "../pipeline.yaml"
    assert all(o.get("current") for o in manifest["run_outputs"].values())  # (both still as written)
    written = now
    res = run(moved / "pipeline.yaml", echo=lambda m: None)  # (then a rerun writes nothing)
    assert (res.built, res.skipped) == (0, 2) and reads == [] and _files_as_written(moved / "out") == written
    # a copy (other inodes): its inputs and outputs hashed once, nothing rebuilt, the original left alone
    shutil.copytree(moved, project)
    res = run(project / "pipeline.yaml", echo=lambda m: None)
    assert (res.built, res.skipped) == (0, 2) and not res.warnings
    assert _files_as_written(moved / "out") == written


def test_the_report_names_the_config_when_output_dir_is_a_link(tmp_path):
    # the manifest's config is relative to output.dir's real folder; the report joined it to output.dir as
    # spelt, so a link to a folder elsewhere (out -> /data/out) named a config that is not there
    # (/home/home/p/pipeline.yaml for /home/p/pipeline.yaml)
    project, data = tmp_path / "home" / "p", tmp_path / "data" / "out"
    project.mkdir(parents=True)
    data.mkdir(parents=True)
    cfg = _project(project, meshes=("cow.obj",), config=MINIMAL)
    (project / "out").symlink_to(data)
    assert run(cfg, echo=lambda m: None).built == 1
    assert json.loads((data / "manifest.json").read_text())["config"] == "../../home/p/pipeline.yaml"
    report = (data / "report.html").read_text()
    assert f"config\n{cfg}:" in report


def test_a_no_change_rerun_compares_recorded_input_paths_as_text(tmp_path, monkeypatch):
    # a record's input paths are relative to the config's folder: each rerun turned every input of every
    # asset into that path (Path.relative_to, 14 us) to compare it, and a stage's prims each compare all
    # its layers: 1,000 prims of a 51-layer stage, a no-change rerun (best of 5) 1.06-1.10 s before the
    # paths were relative, 1.27-1.52 s with them, 1.13-1.17 s compared as text
    from swpm_usd.pipeline import inputs as input_checks
    from swpm_usd.pipeline import runner

    monkeypatch.setattr(input_checks, "_RACY_NS", 0)
    cfg, _ = _two_layer_stage(tmp_path)
    cfg.write_text(
        "version: 1\nassets: [{stage: stage/scene.usda}, {glob: 'm/*.obj'}]\noutput: {dir: out}\n"
        "defaults: {encoding: vanilla}\n"
    )
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    assert run(cfg, echo=lambda m: None).built == 3
    made = []
    real = runner.recorded_path
    for where in (runner, input_checks):  # (the plan's calls, and those of the input checks it calls)
        monkeypatch.setattr(where, "recorded_path", lambda base, path: made.append(path) or real(base, path))
    reads = _input_reads(monkeypatch, tmp_path / "stage")
    assert run(cfg, echo=lambda m: None).skipped == 3 and reads == [] and made == []
    # compared as they were: the same files up to date, another file's record not taken for them
    inputs = _recorded_inputs(tmp_path / "out")
    assert [e["path"] for e in inputs["m/a.obj"]] == ["m/a.obj"]
    entries = inputs["stage/scene.usda:/World/spot/Body"]
    paths = [tmp_path / e["path"] for e in entries]
    assert runner._inputs_unchanged(paths, entries, tmp_path)
    assert not runner._inputs_unchanged(paths[::-1], entries, tmp_path)
    assert not runner._inputs_unchanged(paths, entries, tmp_path / "stage")
    # the text compared is the path recorded_path makes (or the absolute one an older record holds)
    for base in (tmp_path, Path("/"), tmp_path / "m"):
        for path in (tmp_path / "m" / "a.obj", tmp_path / "m" / ".." / "a.obj", tmp_path / "mx" / "a.obj"):
            for text in ("m/a.obj", "a.obj", "../a.obj", "m/../a.obj", "m//a.obj", "./m/a.obj", str(path)):
                expected = text in (str(path), runner.recorded_path(base, path))
                assert input_checks._is_recorded_path(text, path, base) == expected, (text, path, base)


def test_a_record_s_curve_is_written_a_point_a_line(tmp_path, monkeypatch):
    # summary.curve, written a key a line (indent=1), was two thirds of each record: each point is one line
    # now, the same JSON value (every reader of the manifest reads what it read), the record a third smaller
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)  # (inputs trusted as soon as they were hashed)
    cfg = _project(tmp_path, meshes=("cow.obj",), config=MINIMAL)
    assert run(cfg, echo=lambda m: None).built == 1
    text = (tmp_path / "out" / "manifest.json").read_text()
    manifest = json.loads(text)
    rec = manifest["assets"]["meshes/cow.obj"]
    curve = rec["summary"]["curve"]
    assert len(curve) > 10
    assert all(set(c) == {"lod", "triangles", "vertices", "error", "acmr"} for c in curve)
    lines = [line.strip().removesuffix(",") for line in text.splitlines()]
    assert all(json.dumps(c, separators=(",", ":")) in lines for c in curve)
    row = text[text.index('  "meshes/cow.obj": ') : text.index("\n  }") + 4]
    assert json.loads("{" + row + "}") == {"meshes/cow.obj": rec}
    assert len(row) < 0.85 * len(json.dumps(rec, indent=1).replace("\n", "\n  "))
    # (the record's ratio moves with each key a record gains, 0.799 before the .swpm's layout was recorded:
    # the curve's own text is what its rows shrink: 2,197 characters, not 3,459)
    start = row.index('"curve": [')
    rows = row[start + len('"curve": ') : row.index("]", start) + 1]
    assert json.loads(rows) == curve
    assert len(rows) < 0.7 * len(json.dumps(curve, indent=1).replace("\n", "\n      "))
    # read back as written: the rerun is up to date and writes nothing
    written = _files_as_written(tmp_path / "out")
    assert run(cfg, echo=lambda m: None).skipped == 1 and _files_as_written(tmp_path / "out") == written


def test_inputs_of_an_older_manifest_are_hashed_once_then_trusted(tmp_path, monkeypatch):
    # a manifest written before inputs had their stat recorded: each input hashed as before (to the same
    # digest: nothing rebuilt), its stat then recorded, and the next rerun reads none
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg = _project(tmp_path, config=MINIMAL)
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    manifest = json.loads((out / "manifest.json").read_text())
    for rec in manifest["assets"].values():
        del rec["inputs"]
    (out / "manifest.json").write_text(json.dumps(manifest))
    reads = _input_reads(monkeypatch, tmp_path / "meshes")
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped) == (0, 2) and sorted(reads) == ["cow.obj", "spot.obj"]
    for aid, (entry,) in _recorded_inputs(out).items():
        assert _as_hashed(entry, tmp_path / aid)
    reads.clear()
    assert run(cfg, echo=lambda m: None).skipped == 2 and reads == []


def test_a_malformed_input_stat_is_hashed_not_trusted(tmp_path, monkeypatch):
    # a hand-edited `inputs` never raises, nor makes the record one the run ignores: the input is hashed
    # (the digest the same, nothing rebuilt) and its entry recorded anew
    from swpm_usd.pipeline import inputs
    from swpm_usd.pipeline.records import record_problem, recorded_inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg = _project(tmp_path, config=MINIMAL)
    out, cow = tmp_path / "out", tmp_path / "meshes" / "cow.obj"
    assert run(cfg, echo=lambda m: None).built == 2
    manifest = json.loads((out / "manifest.json").read_text())
    (good,) = manifest["assets"]["meshes/cow.obj"]["inputs"]
    malformed = {
        "a string": "cow.obj",
        "null": None,
        "an object": {"path": str(cow)},
        "an entry a string": [str(cow)],
        "no path": [{k: v for k, v in good.items() if k != "path"}],
        "a path a number": [{**good, "path": 3}],
        "a size a string": [{**good, "size": str(good["size"])}],
        "an mtime a float": [{**good, "mtime_ns": float(good["mtime_ns"])}],
        "an inode a boolean": [{**good, "ino": True}],
        "hashed_ns null": [{**good, "hashed_ns": None}],
    }
    # well formed, but not trusted: the path alone (changed while hashed), a key missing, another path, one
    # more input, none, another size
    untrusted = {
        "the path alone": [{"path": good["path"]}],
        "no ctime": [{k: v for k, v in good.items() if k != "ctime_ns"}],
        "another path": [{**good, "path": str(tmp_path / "meshes" / "spot.obj")}],
        "two inputs": [good, good],
        "no input": [],
        "another size": [{**good, "size": good["size"] + 1}],
    }
    reads = _input_reads(monkeypatch, tmp_path / "meshes")
    for what, value in {**malformed, **untrusted}.items():
        rec = manifest["assets"]["meshes/cow.obj"]
        rec["inputs"] = value
        assert record_problem(rec) is None and (recorded_inputs(rec) is None) == (what in malformed), what
        (out / "manifest.json").write_text(json.dumps(manifest))
        reads.clear()
        res = run(cfg, echo=lambda m: None)
        assert (res.built, res.skipped) == (0, 2) and reads == ["cow.obj"], what
        assert not [w for w in res.warnings if "manifest.json" in w], what
        assert _as_hashed(_recorded_inputs(out)["meshes/cow.obj"][0], cow), what
        reads.clear()
        assert run(cfg, echo=lambda m: None).skipped == 2 and reads == [], what
    # a failed asset's record without its input digest (only its status is required): built again
    manifest = json.loads((out / "manifest.json").read_text())
    rec = manifest["assets"]["meshes/cow.obj"]
    rec["status"] = "failed"
    del rec["input_digest"]
    assert record_problem(rec) is None and recorded_inputs(rec) is not None
    (out / "manifest.json").write_text(json.dumps(manifest))
    assert run(cfg, echo=lambda m: None).built == 1


def test_a_racily_clean_input_is_hashed_again(tmp_path, monkeypatch):
    # an input changed within the timestamp granularity of its hash can keep the recorded size and stat with
    # other bytes (as git's "racily clean" files): a record whose mtime or ctime is not older than the
    # moment of hashing by _RACY_NS is not trusted, and the input is hashed (its entry recorded anew)
    from swpm_usd.pipeline import inputs

    cfg = _project(tmp_path, meshes=("cow.obj",), config=MINIMAL)
    out, cow = tmp_path / "out", tmp_path / "meshes" / "cow.obj"
    assert run(cfg, echo=lambda m: None).built == 1
    manifest = json.loads((out / "manifest.json").read_text())
    rec = manifest["assets"]["meshes/cow.obj"]
    reads = _input_reads(monkeypatch, tmp_path / "meshes")

    def trusted(hashed_ns: int) -> bool:
        """Is cow.obj, recorded as it is now and hashed at ``hashed_ns``, trusted (not read) by a rerun?"""
        (entry,) = _recorded_inputs(out)["meshes/cow.obj"]
        assert _as_hashed(entry, cow)
        rec["inputs"] = [{**entry, "hashed_ns": hashed_ns}]
        (out / "manifest.json").write_text(json.dumps(manifest))
        reads.clear()
        assert run(cfg, echo=lambda m: None).skipped == 1
        (fresh,) = _recorded_inputs(out)["meshes/cow.obj"]
        assert _as_hashed(fresh, cow) and (fresh["hashed_ns"] == hashed_ns) == (reads == [])
        return reads == []

    st = cow.stat()
    changed = max(st.st_mtime_ns, st.st_ctime_ns)
    assert not trusted(changed + 10**9)  # hashed a second after its last change
    assert not trusted(changed + inputs._RACY_NS)
    assert trusted(changed + inputs._RACY_NS + 1)
    assert trusted(changed + 60 * 10**9)
    # the ctime counts as the mtime does (a chmod or a rename just before the hash, then an edit with the
    # mtime set back in the same tick): an mtime a minute older than the hash does not make it trusted
    os.utime(cow, ns=(st.st_atime_ns, st.st_mtime_ns - 60 * 10**9))
    assert run(cfg, echo=lambda m: None).skipped == 1  # (hashed: its stat moved; recorded anew)
    st = cow.stat()
    assert not trusted(st.st_ctime_ns + 10**9)
    assert trusted(st.st_ctime_ns + inputs._RACY_NS + 1)


def _config_problems(cfg, text: str, stderr_lists_them: bool = False) -> list[str]:
    """``text`` written to ``cfg``: a dry run exits 2 without a traceback, and the problems
    ``load_config`` raises (``stderr_lists_them``: the run printed exactly those lines on stderr), both
    given the config's name from its folder (so the problems name it alone, as given)."""
    import contextlib

    cfg.write_text(text)
    with contextlib.chdir(cfg.parent):
        result = CliRunner().invoke(main, ["run", cfg.name, "--dry-run"])
        assert result.exit_code == 2 and "Traceback" not in result.output, result.output
        with pytest.raises(ConfigError) as exc:
            load_config(cfg.name)
    if stderr_lists_them:
        assert result.stderr.splitlines() == exc.value.problems
    return exc.value.problems


def test_yaml_empty_values_floats_without_a_dot_and_duplicate_keys(tmp_path):
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\n"

    def problems(text: str) -> list[str]:
        return _config_problems(cfg, text)

    # an empty value (a bare `rules:` or `params:`) is null, reported at its line
    assert problems(head + "rules:\n") == ["c.yaml:4:7: $.rules: empty value (null); expected an array"]
    assert problems(head + "rules:\n  - {name: a, encoding: mixed, params: }\n") == [
        "c.yaml:5:39: $.rules[0].params: empty value (null); expected an object"
    ]
    # a key given twice is an error at its second occurrence, not silently replaced
    assert problems("version: 1\n" + head + "rules: []\nrules:\n  - {name: b, encoding: vanilla}\n") == [
        "c.yaml:2:1: $.version: duplicate key (first given on line 1)",
        "c.yaml:6:1: $.rules: duplicate key (first given on line 5)",
    ]
    assert problems(head + "defaults: {encoding: vanilla, encoding: mixed}\n")[0].startswith(
        "c.yaml:4:31: $.defaults.encoding: duplicate key"
    )
    # YAML 1.2 floats without a dot (YAML 1.1 reads them as strings)
    cfg.write_text(
        head + "defaults:\n  encoding: sliding-window\n"
        "  params: {optimize_connectivity: true, swap_max_deviation: 1e-3, mu: 2E-1}\n"
    )
    params = load_config(cfg).data["defaults"]["params"]
    assert params["swap_max_deviation"] == 0.001 and params["mu"] == 0.2
    # python tags stay refused, located
    assert problems(head.replace("'m/*.obj'", '!!python/name:os.system ""'))[0].startswith(
        "c.yaml:2:17: $: invalid"
    )


def test_an_unquoted_key_yaml_reads_as_no_string_is_named_with_the_quotes_it_needs(tmp_path):
    # a key is a string in JSON and in a prim's customData: `match: {tag: {on: x}}` was read as {True: "x"},
    # which passed the schema (a tag's keys are not checked) and silently never matched an asset
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\n"
    head += "rules:\n  - name: r\n    encoding: vanilla\n"
    hint = "quote it to keep it as written:"
    for key, read in (("on", "a boolean (true)"), ("1", "a number (1)"), ("1e5", "a number (100000.0)")):
        cfg.write_text(head + f"    match: {{tag: {{{key}: x}}}}\n")
        with pytest.raises(ConfigError) as exc:
            load_config(cfg)
        assert exc.value.problems == [
            f"{cfg}:7:19: $.rules[0].match.tag.{key}: key {key} is read by YAML as {read}, not a string; "
            f'{hint} "{key}"'
        ]
    # quoted, it is the key written; a date is read back as the text written, a key of the schema's as before
    cfg.write_text(head + "    match: {tag: {'on': x, 2024-01-01: y}}\n")
    assert load_config(cfg).data["rules"][0]["match"]["tag"] == {"on": "x", "2024-01-01": "y"}
    cfg.write_text(head + "    match: {tag: {k: x}}\n    params: {yes: 1}\n")
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    assert any("unknown key" in p for p in exc.value.problems), exc.value.problems


def test_an_unquoted_value_yaml_reads_as_no_string_is_named_with_the_quotes_it_needs(tmp_path):
    # `name: 1e5` or `name: yes` where the schema wants a string said "100000.0 is not of type 'string'" or
    # "True is not of type 'string'": neither what was written nor what to do
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\n"

    def problems(text: str) -> list[str]:
        return _config_problems(cfg, text, stderr_lists_them=True)

    hint = "quote it to keep it as written:"
    for value, read in (
        ("1e5", "a number (100000.0)"),
        ("yes", "a boolean (true)"),
        ("off", "a boolean (false)"),
        ("007", "a number (7)"),
        ("1:20", "a number (80)"),  # (YAML 1.1's base 60)
        ("2024-01-01", "a date"),
    ):
        assert problems(head + f"rules:\n  - name: {value}\n    encoding: vanilla\n") == [
            f"c.yaml:5:11: $.rules[0].name: {value} is read by YAML as {read}, not a string; "
            f'{hint} name: "{value}"'
        ]
    assert problems(head + "defaults: {encoding: skip-strip, params: {primitive: yes}}\n") == [
        "c.yaml:4:54: $.defaults.params.primitive: yes is read by YAML as a boolean (true), not a string; "
        f'{hint} primitive: "yes"'
    ]
    assert problems("version: 1\nassets: [{glob: 1e5}]\noutput: {dir: no}\n") == [
        "c.yaml:2:17: $.assets[0].glob: 1e5 is read by YAML as a number (100000.0), not a string; "
        f'{hint} glob: "1e5"',
        f'c.yaml:3:15: $.output.dir: no is read by YAML as a boolean (false), not a string; {hint} dir: "no"',
    ]
    # quoted, they are the strings written; where the schema takes a number or a boolean, nothing changes
    cfg.write_text(
        head.replace("{dir: out}", "{dir: out, usd: yes}") + "rules:\n  - {name: '1e5', encoding: vanilla}\n"
    )
    config = load_config(cfg)
    assert config.data["rules"][0]["name"] == "1e5" and config.data["output"]["usd"] is True
    # an empty value keeps its own message
    assert problems(head + "rules:\n  - name:\n    encoding: vanilla\n") == [
        "c.yaml:5:10: $.rules[0].name: empty value (null); expected a string"
    ]


def test_unusable_output_dir_and_globs_are_located_config_errors(tmp_path):
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"

    def problems(glob: str, out_dir: str, *options: str) -> str:
        cfg.write_text(f"version: 1\nassets: [{{glob: '{glob}'}}]\noutput: {{dir: '{out_dir}'}}\n")
        result = CliRunner().invoke(main, ["run", str(cfg), *options])
        assert result.exit_code == 2 and "Traceback" not in result.output, result.output
        return result.output

    assert "c.yaml:3:15: $.output.dir: " in problems("m/*.obj", "m/a.obj")
    assert "m/a.obj is a file, not a folder" in problems("m/*.obj", "m/a.obj", "--dry-run")
    assert "is under " in problems("m/*.obj", "m/a.obj/out")
    if Path("/proc/self").is_dir():  # a parent that cannot be created, even by root
        assert "c.yaml:3:15: $.output.dir: cannot create /proc/nope/out" in problems(
            "m/*.obj", "/proc/nope/out"
        )
    absolute = str(tmp_path / "m" / "*.obj")
    assert "c.yaml:2:17: $.assets[0].glob: a glob must be a non-empty pattern relative" in problems(
        absolute, "out", "--dry-run"
    )
    assert "$.assets[0].glob: a glob must be" in problems("", "out")


def test_a_file_matched_by_two_asset_entries_is_one_asset(tmp_path):
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    (tmp_path / "m" / "b.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}, {glob: 'm/a.*'}]\noutput: {dir: out}\n"
        "defaults: {encoding: vanilla}\n"
    )
    res = run(cfg, echo=lambda m: None)
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert res.built == 2 and sorted(manifest["assets"]) == ["m/a.obj", "m/b.obj"]
    # the same file with other settings is ambiguous: refused, at the second entry
    cfg.write_text(cfg.read_text().replace("{glob: 'm/a.*'}", "{glob: 'm/a.*', instances: 50}"))
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=lambda m: None)
    assert exc.value.problems == [
        f"{cfg}:2:29: $.assets[1]: m/a.obj is also matched by $.assets[0] with instances=1, here "
        "instances=50: one file is one asset; narrow one of the two so each file is matched once"
    ]


def test_json_output_on_failure_is_json(tmp_path):
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    (tmp_path / "m" / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    runner = CliRunner()  # click 8.2: result.stdout holds stdout alone
    r = runner.invoke(main, ["build", str(tmp_path / "m" / "broken.obj"), "--json"])
    assert r.exit_code == 1 and "broken.obj" in json.loads(r.stdout)["error"]
    r = runner.invoke(main, ["inspect", str(tmp_path / "nope.swpm"), "--json"])
    rep = json.loads(r.stdout)
    assert r.exit_code == 1 and not rep["valid"] and rep["problems"][0]["code"] == "SWPM_IO_ERROR"
    r = runner.invoke(main, ["run", str(tmp_path / "nope.yaml"), "--json"])
    assert r.exit_code == 2 and "nope.yaml:1:1: $: file not found" in json.loads(r.stdout)["problems"][0]
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    r = runner.invoke(main, ["run", str(cfg), "--json", "--dry-run"])
    plan = json.loads(r.stdout)["plan"]
    assert r.exit_code == 0 and [p["id"] for p in plan] == ["m/a.obj", "m/broken.obj"]
    assert plan[0]["encoding"] == "vanilla" and plan[0]["state"] == "to build"
    r = runner.invoke(main, ["run", str(cfg), "--json"])
    summary = json.loads(r.stdout)
    assert r.exit_code == 1 and summary["built"] == 1 and summary["failed"] == 1
    (failure,) = summary["failures"]
    assert failure["id"] == "m/broken.obj" and "broken.obj" in failure["error"]


def test_checks_no_stricter_compares_limits_by_their_direction():
    from swpm_usd.pipeline.assets import checks_no_stricter

    then = {
        "budgets": {"global_bytes": 100},
        "streaming": {"min_coarsest_triangles": 8, "order": "coarse-to-fine"},
    }
    same = {
        "budgets": {"global_bytes": 100},
        "streaming": {"min_coarsest_triangles": 8, "order": "coarse-to-fine"},
    }
    assert checks_no_stricter(same, then)
    assert checks_no_stricter({**same, "budgets": {"global_bytes": 101}}, then)  # a larger maximum
    assert not checks_no_stricter({**same, "budgets": {"global_bytes": 99}}, then)
    assert not checks_no_stricter({**same, "budgets": {"global_bytes": 100, "total_bytes": 10**9}}, then)
    looser_min = {**same, "streaming": {"min_coarsest_triangles": 4, "order": "coarse-to-fine"}}
    assert checks_no_stricter(looser_min, then)  # a smaller minimum
    assert not checks_no_stricter(
        looser_min | {"budgets": {}}, {**then, "budgets": {}} | {"streaming": {"min_coarsest_triangles": 2}}
    )
    assert checks_no_stricter(
        {"budgets": {}, "streaming": {"order": "coarse-to-fine"}}, then
    )  # limits dropped
    assert not checks_no_stricter({"budgets": {"global_bytes": 100}, "streaming": {}}, then)  # order dropped
    assert not checks_no_stricter(same, None)  # a record without its checks


def test_params_the_encoders_refuse_are_config_errors_at_their_line(tmp_path):
    # builder: nope, cache_size: 0, .nan and .inf passed the schema and failed every asset at build time
    # (cache_size: 0 of skip-strip/mixed a ValueError, a traceback in `build`); they are config errors now
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    text = (
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\n"
        "defaults: {encoding: mixed, params: {boundary_weight: .nan}}\n"
        "rules:\n"
        "  - {name: a, encoding: sliding-window, params: {builder: nope, mu: 1.0, cache_size: 2}}\n"
        "  - {name: b, encoding: skip-strip, params: {primitive: fan, degenerate_threshold: .nan}}\n"
        "  - {name: c, encoding: mixed, params: {cache_size: 0}}\n"
    )
    assert _config_problems(cfg, text) == [
        "c.yaml:4:55: $.defaults.params.boundary_weight: nan is not a finite number",
        "c.yaml:6:59: $.rules[0].params.builder: 'nope' is not one of ['topology', 'forsyth']",
        "c.yaml:6:69: $.rules[0].params.mu: must be in [0, 1), got 1.0",
        "c.yaml:6:86: $.rules[0].params.cache_size: must be in [3, 1024], got 2",
        "c.yaml:7:57: $.rules[1].params.primitive: 'fan' is not one of ['strip', 'list']",
        "c.yaml:7:84: $.rules[1].params.degenerate_threshold: nan is not a finite number",
        "c.yaml:8:53: $.rules[2].params.cache_size: must be in [1, 1024], got 0",
    ]
    result = CliRunner().invoke(main, ["build", str(tmp_path / "m" / "a.obj"), "--encoding", "mixed",
                                       "-p", "cache_size=0"])  # fmt: skip
    assert result.exit_code == 2 and "cache_size: must be in [1, 1024], got 0" in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)


def test_scene_and_report_no_longer_asked_for_are_named_and_pruned(tmp_path):
    # scene: false (or report: false) since left scene.usda and report.html as the last run wrote them,
    # named nowhere: after --prune deleted a removed asset's layer, the scene referenced a missing file
    cfg = _project(tmp_path, meshes=("suzanne.obj",))
    shutil.copy(tmp_path / "meshes" / "suzanne.obj", tmp_path / "meshes" / "b.obj")
    head = "version: 1\nassets: [{glob: 'meshes/*.obj'}]\ndefaults: {encoding: vanilla}\n"
    cfg.write_text(head + "output: {dir: out, usd: true, scene: true}\n")
    assert run(cfg).failed == 0
    out = tmp_path / "out"
    assert "b.usdc" in (out / "scene.usda").read_text()
    (tmp_path / "meshes" / "b.obj").unlink()
    cfg.write_text(head + "output: {dir: out, usd: true, scene: false, report: false}\n")
    res = run(cfg)
    assert sorted(res.unlisted) == ["b.swpm", "b.usdc", "report.html", "scene.usda"]
    res = run(cfg, prune=True)
    assert sorted(res.pruned) == ["b.swpm", "b.usdc", "report.html", "scene.usda"]
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "manifest.json",
        "suzanne.swpm",
        "suzanne.usdc",
    ]
    # asked for again: written and recorded anew, never an orphan
    cfg.write_text(head + "output: {dir: out, usd: true, scene: true}\n")
    res = run(cfg)
    assert res.unlisted == [] and (out / "scene.usda").is_file() and (out / "report.html").is_file()
    recorded = json.loads((out / "manifest.json").read_text())["run_outputs"]
    assert sorted(recorded) == ["report", "scene"] and recorded["scene"]["path"] == "scene.usda"
    # a file changed since the run wrote it is not the run's: left in place, named nowhere
    (out / "report.html").write_text("mine")
    cfg.write_text(head + "output: {dir: out, usd: true, scene: true, report: false}\n")
    assert run(cfg, prune=True).pruned == [] and (out / "report.html").read_text() == "mine"


def test_scene_without_usd_layers_is_a_config_error(tmp_path):
    # scene: true with usd: false wrote a scene.usda with nothing in it, silently
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\n"
    assert _config_problems(cfg, head + "output: {dir: out, scene: true}\n") == [
        "c.yaml:3:27: $.output.scene: scene: true needs usd: true "
        "(scene.usda references each asset's USD layer)"
    ]


def test_legacy_layout_without_swpm_files_is_a_config_error(tmp_path):
    # the layout of .swpm files a config does not write: accepted without a word
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\n"
    assert _config_problems(
        cfg, head + "output: {dir: out, swpm: false, usd: true, legacy_layout: true}\n"
    ) == [
        "c.yaml:3:59: $.output.legacy_layout: legacy_layout: true needs swpm: true "
        "(it is the .swpm files' layout; USD layers have none)"
    ]


def test_instances_changed_rebuild_only_what_depends_on_them(tmp_path):
    # the instance count was in every asset's digest: a source's `instances` changed rebuilt assets whose
    # build it does not change (an encoding named by a rule, not auto), as if their mesh had changed
    config = """\
version: 1
assets:
  - {glob: "meshes/cow.obj", instances: 1}
  - {glob: "meshes/spot.obj", instances: 1}
output: {dir: out, usd: true, scene: true}
rules:
  - {name: hero, match: {path: "meshes/spot.obj"}, encoding: auto}
  - {name: crowd, match: {instances: {min: 1000}}, encoding: skip-strip}
defaults: {encoding: vanilla}
"""
    cfg = _project(tmp_path, config=config)
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    cow_swpm = _files_as_written(out)["cow.swpm"]
    scene = (out / "scene.usda").read_text()

    def instances(cow: int, spot: int, budget: str = "") -> None:
        text = config.replace('cow.obj", instances: 1', f'cow.obj", instances: {cow}')
        cfg.write_text(text.replace('spot.obj", instances: 1', f'spot.obj", instances: {spot}') + budget)

    instances(40, 40)
    res = run(cfg, echo=lambda m: None)
    assert res.built_ids == ["meshes/spot.obj"] and res.skipped == 1  # (auto chooses by the count)
    assert (
        res.records["meshes/cow.obj"]["instances"] == 40 and res.records["meshes/spot.obj"]["instances"] == 40
    )
    assert _files_as_written(out)["cow.swpm"] == cow_swpm
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["assets"]["meshes/cow.obj"]["instances"] == 40
    assert "<td>40</td>" in (out / "report.html").read_text().split("meshes/cow.obj", 1)[1].split("</tr>")[0]
    assert (out / "scene.usda").read_text() == scene  # (one prim an asset, whatever its count)
    assert run(cfg, echo=lambda m: None).skipped == 2
    # a rule on the count that now picks another treatment rebuilds it
    instances(1000, 40)
    res = run(cfg, echo=lambda m: None)
    assert res.built_ids == ["meshes/cow.obj"] and res.records["meshes/cow.obj"]["encoding"] == "skip-strip"
    instances(40, 40)
    assert run(cfg, echo=lambda m: None).built_ids == ["meshes/cow.obj"]
    # budgets.total_bytes: checked again with the new count, from the recorded memory
    s = json.loads((out / "manifest.json").read_text())["assets"]["meshes/cow.obj"]["summary"]
    budget = f"budgets: {{total_bytes: {s['global_bytes'] + 50 * s['instance_bytes']}}}\n"
    instances(40, 40, budget)
    built = run(cfg, echo=lambda m: None).built_ids
    assert sorted(built) == ["meshes/cow.obj", "meshes/spot.obj"]  # (a budget added: checked)
    instances(50, 40, budget)
    res = run(cfg, echo=lambda m: None)
    assert res.skipped == 2 and res.records["meshes/cow.obj"]["instances"] == 50  # (fits: not rebuilt)
    instances(51, 40, budget)
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and "total_bytes" in res.failures["meshes/cow.obj"]["error"]
    assert res.failures["meshes/cow.obj"]["kept_previous"]


def test_the_instance_count_is_not_in_the_digest_of_an_encoding_other_than_auto(tmp_path, monkeypatch):
    # the instance count left the digest of an encoding other than auto: a crowd of vanilla assets of 100
    # instances keeps its builds when the count changes (a record of when every count was in the digest held
    # the tool's version, 0.9.1 or before, and is rebuilt once as every record of those versions is)
    import hashlib

    from swpm_usd.pipeline import inputs
    from swpm_usd.pipeline.assets import canonical_treatment
    from swpm_usd.pipeline.build_version import build_version

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    config = MINIMAL.replace('glob: "meshes/*.obj"', 'glob: "meshes/*.obj"\n    instances: 40')
    cfg = _project(tmp_path, meshes=("cow.obj",), config=config)
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    path = out / "manifest.json"
    manifest = json.loads(path.read_text())
    rec = manifest["assets"]["meshes/cow.obj"]
    assert rec["instances"] == 40 and rec["encoding"] == "skip-strip"

    def digest(count: int) -> str:  # (the digest with ``count`` in it)
        treatment = canonical_treatment({"encoding": "skip-strip", "params": {}})  # (the rule "small"'s)
        payload = [rec["input_digest"], None, count, treatment, {}, build_version(treatment)]
        return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()

    assert rec["digest"] == digest(1)  # (the default count's, whatever the asset's)
    swpm = _files_as_written(out)["cow.swpm"]
    cfg.write_text(cfg.read_text().replace("instances: 40", "instances: 39"))
    res = run(cfg, echo=lambda m: None)  # (the record and the report are given the new count)
    assert res.skipped == 1 and _files_as_written(out)["cow.swpm"] == swpm
    assert json.loads(path.read_text())["assets"]["meshes/cow.obj"]["instances"] == 39
    # a digest that is not today's (another count's) is not this build's: built again
    manifest = json.loads(path.read_text())
    manifest["assets"]["meshes/cow.obj"]["digest"] = digest(39)
    path.write_text(json.dumps(manifest, indent=1))
    assert run(cfg, echo=lambda m: None).built == 1


def test_instances_on_a_stage_source_is_a_config_error(tmp_path):
    # `instances` beside `stage` was ignored silently (its assets had the instances the stage composes)
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    text = "version: 1\nassets: [{glob: 'm/*.obj'}, {stage: s.usda, instances: 7}]\noutput: {dir: out}\n"
    assert _config_problems(cfg, text) == [
        "c.yaml:2:56: $.assets[1].instances: instances is for glob assets; a stage's Mesh prims are "
        "counted from its composition (instanceable prims, point instancers)"
    ]


def test_a_dangling_link_a_glob_matches_is_a_failed_asset(tmp_path):
    # a mesh-typed symlink to a missing file (a moved asset library) was dropped silently: not an asset,
    # not a failure, its build's outputs named as those of an asset no longer in the config
    cfg = _project(tmp_path, meshes=("suzanne.obj",))
    (tmp_path / "meshes" / "gone.obj").symlink_to(tmp_path / "library" / "gone.obj")
    cfg.write_text("version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out}\n")
    res = run(cfg)
    assert res.built == 1 and res.failed == 1
    assert "meshes/gone.obj" in res.failures and "not found" in res.failures["meshes/gone.obj"]["error"]


def test_a_usd_file_a_glob_matches_is_rebuilt_when_a_layer_it_uses_changes(tmp_path):
    # a glob's .usda referencing its mesh from another layer recorded the .usda alone as its input: the
    # layer edited (another mesh), the rerun said up to date and kept the old build
    from pxr import Usd, UsdGeom

    def mesh_layer(name: str) -> None:
        mesh = swpm_usd.load_mesh(SHARED_MESHES / name)
        (tmp_path / "lib").mkdir(exist_ok=True)
        st = Usd.Stage.CreateNew(str(tmp_path / "lib" / "geo.usda"))
        m = UsdGeom.Mesh.Define(st, "/Geo")
        st.SetDefaultPrim(m.GetPrim())
        m.CreatePointsAttr(mesh.points)
        m.CreateFaceVertexCountsAttr([3] * mesh.triangle_count)
        m.CreateFaceVertexIndicesAttr(mesh.triangles.reshape(-1))
        st.GetRootLayer().Save()

    mesh_layer("suzanne.obj")
    (tmp_path / "assets").mkdir()
    st = Usd.Stage.CreateNew(str(tmp_path / "assets" / "prop.usda"))
    prop = st.DefinePrim("/Prop")
    prop.GetReferences().AddReference("../lib/geo.usda")
    st.SetDefaultPrim(prop)
    st.GetRootLayer().Save()
    del st, prop
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text("version: 1\nassets: [{glob: 'assets/*.usda'}]\noutput: {dir: out}\n")
    res = run(cfg)
    assert res.built == 1
    triangles = res.records["assets/prop.usda"]["triangles_in"]
    assert run(cfg).built == 0
    (tmp_path / "lib" / "geo.usda").unlink()
    mesh_layer("beetle.obj")
    res = run(cfg)
    assert res.built == 1 and res.records["assets/prop.usda"]["triangles_in"] != triangles


def test_two_rules_of_one_name_are_a_config_error(tmp_path):
    # the manifest's `rule`, the report and --explain name the rule an asset matched: two of one name
    # (a copied rule) made that name ambiguous, silently
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    text = (
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\nrules:\n"
        "  - {name: props, match: {triangles: {max: 10}}, encoding: vanilla}\n"
        "  - {name: props, encoding: mixed}\n"
    )
    assert _config_problems(cfg, text) == [
        "c.yaml:6:12: $.rules[1].name: duplicate rule name (first given on line 5)"
    ]


def test_run_json_names_the_assets_built(tmp_path):
    # `run --json` counted the assets built but named only the failed ones: a script could not tell which
    # outputs a rerun replaced
    cfg = _project(tmp_path, meshes=("suzanne.obj",))
    shutil.copy(tmp_path / "meshes" / "suzanne.obj", tmp_path / "meshes" / "b.obj")
    cfg.write_text("version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out}\n")
    r = CliRunner().invoke(main, ["run", str(cfg), "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["built_assets"] == ["meshes/b.obj", "meshes/suzanne.obj"]
    (tmp_path / "meshes" / "b.obj").write_text(TWO_TRIANGLES)
    r = CliRunner().invoke(main, ["run", str(cfg), "--json"])
    summary = json.loads(r.stdout)
    assert summary["built"] == 1 and summary["built_assets"] == ["meshes/b.obj"]


def test_an_integer_parameter_given_as_a_float_is_a_config_error_at_its_line(tmp_path):
    # `cache_size: 16.0` passed the schema (JSON Schema's integer takes 16.0) and failed every asset at build
    # time (check_params: "must be an integer, got 16.0"); a whole float for a real-valued one still builds
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    text = (
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\n"
        "defaults: {encoding: mixed, params: {cache_size: 16.0, level_threshold: 0}}\n"
        "rules:\n"
        "  - {name: a, encoding: sliding-window, params: {inner_vertices: 2.0, mu: 0, order_passes: 1.0}}\n"
    )
    assert _config_problems(cfg, text) == [
        "c.yaml:4:50: $.defaults.params.cache_size: must be an integer, got 16.0",
        "c.yaml:6:66: $.rules[0].params.inner_vertices: must be an integer, got 2.0",
        "c.yaml:6:92: $.rules[0].params.order_passes: must be an integer, got 1.0",
    ]
    cfg.write_text(text.replace("16.0", "16").replace("2.0", "2").replace("1.0", "1"))
    assert run(cfg).built == 1


def test_scene_and_report_stay_recorded_through_an_interrupted_run(tmp_path, monkeypatch):
    # a run stopped (Ctrl-C, an error) wrote a manifest without `run_outputs`: the scene and report the run
    # before wrote were recorded nowhere, so once the config stopped asking for them they were never named
    from swpm_usd.pipeline import runner

    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\ndefaults: {encoding: vanilla}\n"
    cfg.write_text(head + "output: {dir: out, usd: true, scene: true}\n")
    assert run(cfg).built == 1

    def interrupted(tasks, *args):
        raise KeyboardInterrupt
        yield

    with monkeypatch.context() as m:
        m.setattr(runner, "execute", interrupted)
        with pytest.raises(KeyboardInterrupt):
            run(cfg, force=True, echo=lambda m: None)
    cfg.write_text(head + "output: {dir: out, usd: true, scene: false, report: false}\n")
    res = run(cfg)
    assert sorted(res.unlisted) == ["report.html", "scene.usda"]
    assert sorted(
        (o["path"], o["asset"], o["because"]["code"], o["because"]["detail"]) for o in res.orphans
    ) == [
        ("report.html", None, "run-output-unwanted", "report: false"),
        ("scene.usda", None, "run-output-unwanted", "scene: false"),
    ]


@pytest.mark.parametrize("suffix", [".obj", ".usda"])
def test_a_symlink_loop_a_glob_matches_is_a_failed_asset(tmp_path, suffix):
    # a mesh-typed link in a loop (a.obj -> b.obj -> a.obj) is a link to no file, which 949b7a2 made a
    # glob's asset; resolving it for the duplicate check raised RuntimeError, a traceback in every run. A
    # .usda one raised it again, resolved for the files of its layers before it was known to be no file
    cfg = _vanilla_project(tmp_path)
    cfg.write_text(VANILLA_M.replace("m/*.obj", "m/*"))
    (tmp_path / "m" / f"loop1{suffix}").symlink_to(f"loop2{suffix}")
    (tmp_path / "m" / f"loop2{suffix}").symlink_to(f"loop1{suffix}")
    r = CliRunner().invoke(main, ["run", str(cfg), "--dry-run", "--json"])
    assert r.exit_code == 0 and "Traceback" not in r.output, r.output
    res = run(cfg)
    assert res.built == 1 and sorted(res.failures) == [f"m/loop1{suffix}", f"m/loop2{suffix}"]
    # (named a link loop, not "file not found": no file was missing)
    assert res.failures[f"m/loop1{suffix}"]["error"].endswith(
        f"m/loop1{suffix}: a link loop (to loop2{suffix}): following it comes back round, to no file"
    ), res.failures


def test_defaults_params_without_an_encoding_are_checked_as_sliding_windows(tmp_path):
    # `defaults` without `encoding` builds sliding-window, but its params passed the schema unchecked (the
    # encodings' params are checked under `if encoding is ...`): mu: 1.5, a name of no encoding, cache_size
    # 16.0 failed every asset at build time
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\n"
    problems = _config_problems(cfg, head + "defaults: {params: {mu: 1.5, nope: 1, cache_size: 16.0}}\n")
    assert problems == [
        "c.yaml:4:25: $.defaults.params.mu: must be in [0, 1), got 1.5",
        "c.yaml:4:30: $.defaults.params.nope: unknown key (not a parameter of sliding-window)",
        "c.yaml:4:51: $.defaults.params.cache_size: must be an integer, got 16.0",
    ]
    cfg.write_text(head + "defaults: {params: {mu: 0.5, cache_size: 8}}\n")
    assert run(cfg).built == 1


def _fake_asset(task):
    """A worker's process_asset for the pool tests: dies, crashes, exits or hangs as its id says."""
    if task["id"] == "killed":
        os.kill(os.getpid(), signal.SIGKILL)
    if task["id"] == "aborted":
        import faulthandler

        faulthandler.disable()  # (pytest's: its dump of the crash is noise here)
        os.kill(os.getpid(), signal.SIGABRT)
    if task["id"] == "exits":
        os._exit(3)
    if task["id"] == "hangs":
        time.sleep(120)
    if task["id"] == "slow":
        time.sleep(0.5)
    return {"id": task["id"], "digest": task["digest"], "status": "built", "pid": os.getpid()}


def test_a_worker_that_dies_or_overruns_fails_its_asset_alone(monkeypatch):
    # a worker killed (the out-of-memory killer's SIGKILL), crashed in native code or exited stopped the
    # whole run (BrokenProcessPool: every asset not yet finished failed with it); one that hung held it
    # for ever. Now that asset alone fails, with its cause, and another worker takes the rest
    import multiprocessing as mp

    from swpm_usd.pipeline import runner, worker

    monkeypatch.setattr(worker, "process_asset", _fake_asset)  # (inherited: fork)
    ids = ["a", "killed", "b", "hangs", "c", "aborted", "d", "exits", "e", "f"]
    t = time.monotonic()
    recs = list(runner._local_pool([{"id": i, "digest": i} for i in ids], 2, mp.get_context("fork"), 3.0))
    assert time.monotonic() - t < 60
    by_id = {r["id"]: r for r in recs}
    assert sorted(by_id) == sorted(ids) and len(recs) == len(ids)
    for i in "abcdef":
        assert by_id[i]["status"] == "built" and "worker_lost" not in by_id[i]
    lost = {i: by_id[i] for i in ("killed", "hangs", "aborted", "exits")}
    assert all(r["status"] == "failed" and r["worker_lost"] and r["digest"] == i for i, r in lost.items())
    assert "killed by SIGKILL" in lost["killed"]["error"] and "out of memory" in lost["killed"]["error"]
    assert "killed by SIGABRT" in lost["aborted"]["error"] and "native code" in lost["aborted"]["error"]
    assert "exited with code 3" in lost["exits"]["error"]
    assert lost["hangs"]["error"].startswith("stopped after 3 s (limits.seconds)")
    assert 3.0 <= lost["hangs"]["seconds"] < 30
    assert len({by_id[i]["pid"] for i in "abcdef"}) >= 3  # (each lost worker was replaced)
    assert not mp.active_children()  # every worker stopped when the pool ends


def _torus_stl(path: Path, rings: int, sides: int) -> None:
    """A binary STL of a torus of ``2 * rings * sides`` triangles."""
    u, v = np.meshgrid(
        np.linspace(0, 2 * np.pi, rings, endpoint=False),
        np.linspace(0, 2 * np.pi, sides, endpoint=False),
        indexing="ij",
    )
    pts = np.stack([(3 + np.cos(v)) * np.cos(u), (3 + np.cos(v)) * np.sin(u), np.sin(v)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(rings), np.arange(sides), indexing="ij")
    a, b = i * sides + j, ((i + 1) % rings) * sides + j
    c, d = ((i + 1) % rings) * sides + (j + 1) % sides, i * sides + (j + 1) % sides
    tris = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    rec = np.zeros(tris.shape[0], [("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["v"] = pts[tris]
    with open(path, "wb") as f:
        f.write(b"\0" * 80 + np.uint32(tris.shape[0]).tobytes() + rec.tobytes())


def test_limits_seconds_stops_an_asset_that_builds_too_long(tmp_path):
    from swpm_usd.pipeline.outputs import _TEMPORARY

    cfg = _project(tmp_path, ("spot.obj",))
    _torus_stl(tmp_path / "meshes" / "big.stl", 500, 500)  # 500,000 triangles: many seconds to build
    head = "version: 1\nassets: [{glob: 'meshes/*'}]\noutput: {dir: out, usd: true}\n"
    cfg.write_text(head)
    (tmp_path / "meshes" / "big.stl").rename(tmp_path / "big.stl")  # built first without it
    assert run(cfg, echo=lambda m: None).built == 1
    (tmp_path / "big.stl").rename(tmp_path / "meshes" / "big.stl")
    # (the limited run writes no USD: a fresh worker's import of pxr was half of spot's 1 s at a load of 10,
    # the rest the load; the limit is what is tested, not how fast a busy machine builds spot)
    cfg.write_text(
        head.replace("usd: true", "usd: false") + "limits: {seconds: 2}\ndefaults: {encoding: vanilla}\n"
    )
    spot_before = sha256_of(tmp_path / "out" / "spot.swpm")
    t = time.monotonic()
    res = run(cfg, jobs=1, echo=lambda m: None)  # (with a limit, --jobs 1 builds in a worker too)
    assert time.monotonic() - t < 120
    assert res.failed == 1 and res.built == 1, res.failures  # spot: its rule changed
    err = res.failures["meshes/big.stl"]["error"]
    assert err == "stopped after 2 s (limits.seconds): its build took longer"
    out = tmp_path / "out"
    assert not [p.name for pattern in _TEMPORARY for p in out.glob(pattern)]
    assert not (out / "big.swpm").exists() and sha256_of(out / "spot.swpm") != spot_before
    manifest = json.loads((out / "manifest.json").read_text())["assets"]
    assert (
        manifest["meshes/big.stl"]["status"] == "failed" and "worker_lost" not in manifest["meshes/big.stl"]
    )
    assert manifest["meshes/spot.obj"]["status"] == "built"


def test_limits_are_checked(tmp_path):
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\n"
    for bad in ("0", "-1", ".nan", ".inf", "soon", "1" * 400):  # (a 400-digit deadline overflowed a float)
        problems = _config_problems(cfg, head + f"limits: {{seconds: {bad}}}\n")
        assert len(problems) == 1 and problems[0].startswith("c.yaml:4:") and "seconds" in problems[0], bad
    assert _config_problems(cfg, head + "limits: {minutes: 3}\n")
    cfg.write_text(head + "limits: {seconds: 30}\n")
    with pytest.raises(ConfigError, match="limits.seconds needs the local executor"):
        run(cfg, executor="dask", echo=lambda m: None)
    assert run(cfg, echo=lambda m: None).built == 1


def _serve_once(conn):
    """A worker's serve for the pool tests: builds one task, sends its record and exits (a worker killed
    right after it sent its record, while idle)."""
    from swpm_usd.pipeline import worker

    worker.ignore_interrupts()
    task = conn.recv()
    conn.send(worker.process_asset(task))
    os._exit(0)


def test_a_worker_that_dies_after_sending_its_record_is_replaced(monkeypatch):
    # the record and the worker's end ready together (a worker killed just after it sent its record): the
    # pool took the record and, the worker dead, gave it no task and started none in its place, so with
    # every worker so gone the tasks left were dropped (neither built nor failed: a run that exits 0)
    import multiprocessing as mp
    import multiprocessing.connection

    from swpm_usd.pipeline import pool, runner, worker

    monkeypatch.setattr(worker, "process_asset", _fake_asset)
    monkeypatch.setattr(pool, "serve", _serve_once)
    real_wait = multiprocessing.connection.wait

    def wait(objects, timeout=None):  # (the worker gone by the time its record is read: both ready)
        if real_wait(objects, timeout):
            time.sleep(0.3)
        return real_wait(objects, 0)

    monkeypatch.setattr(multiprocessing.connection, "wait", wait)
    ids = ["a", "b", "c", "d"]
    for jobs in (1, 2):
        recs = list(
            runner._local_pool([{"id": i, "digest": i} for i in ids], jobs, mp.get_context("fork"), None)
        )
        assert sorted(r["id"] for r in recs) == ids and all(r["status"] == "built" for r in recs), recs
        assert not mp.active_children()


def test_a_worker_dead_before_its_task_is_sent_gives_it_to_another(monkeypatch):
    # a send to a worker that had died (a broken pipe) was raised out of the pool: the whole run stopped
    import multiprocessing as mp

    from swpm_usd.pipeline import pool, runner, worker

    monkeypatch.setattr(worker, "process_asset", _fake_asset)
    ctx = mp.get_context("fork")
    real = pool._Worker
    for seen_alive in (False, True):  # (its death seen, or not yet: the send is what fails)
        made = []

        def new(ctx, seen_alive=seen_alive, made=made):
            w = real(ctx)
            if not made:
                w.process.kill()
                w.process.join()
                if seen_alive:
                    w.process.is_alive = lambda: True
            made.append(w)
            return w

        monkeypatch.setattr(pool, "_Worker", new)
        recs = list(runner._local_pool([{"id": "a", "digest": "a"}], 1, ctx, None))
        assert [(r["id"], r["status"]) for r in recs] == [("a", "built")], recs
        assert len(made) == 2 and not mp.active_children()


def test_a_worker_done_while_the_caller_held_the_pool_is_not_stopped_as_overrun(monkeypatch):
    # the readiness the pool had waited for went stale while the caller handled another record (the
    # runner hashes outputs, writes the manifest): a worker that had sent its record meanwhile was then
    # past its deadline, and killed as overrun, its asset failed though built (its outputs in place)
    import multiprocessing as mp

    from swpm_usd.pipeline import runner, worker

    monkeypatch.setattr(worker, "process_asset", _fake_asset)
    tasks = [{"id": "a", "digest": "a"}, {"id": "slow", "digest": "slow"}]
    recs = []
    for rec in runner._local_pool(tasks, 2, mp.get_context("fork"), 1.0):
        recs.append(rec)
        time.sleep(1.5)  # (the caller busy past the other's deadline, which finished at 0.5 s)
    assert sorted((r["id"], r["status"]) for r in recs) == [("a", "built"), ("slow", "built")], recs


def _serve_late(conn):
    """A worker's serve for the pool tests, reached 2 s after the process started (a fork from the server
    under load, with its imports)."""
    from swpm_usd.pipeline import worker

    time.sleep(2.0)
    worker.serve(conn)


def test_a_limit_times_the_build_not_the_worker_start_up(monkeypatch):
    # the deadline started when the task was sent: a worker started for it (the first, or one in place of a
    # worker stopped) spent its start-up, 1 s and more of a 2 s limit on a loaded 2-core machine, on the
    # limit, and an asset that builds in a moment was stopped (tests' spot.obj beside an overrunning asset)
    import multiprocessing as mp

    from swpm_usd.pipeline import pool, runner, worker

    monkeypatch.setattr(worker, "process_asset", _fake_asset)
    monkeypatch.setattr(pool, "serve", _serve_late)
    tasks = [{"id": "a", "digest": "a"}, {"id": "hangs", "digest": "hangs"}, {"id": "b", "digest": "b"}]
    recs = {r["id"]: r for r in runner._local_pool(tasks, 1, mp.get_context("fork"), 1.0)}
    assert recs["a"]["status"] == "built" and recs["b"]["status"] == "built", recs  # (b: a new worker)
    assert recs["hangs"]["error"] == "stopped after 1 s (limits.seconds): its build took longer"
    assert not mp.active_children()


def test_a_limit_of_weeks_is_waited_for(monkeypatch):
    # a timeout over 2**31 ms (24.8 days) made the pool's wait raise OverflowError: the run stopped
    import multiprocessing as mp

    from swpm_usd.pipeline import runner, worker

    monkeypatch.setattr(worker, "process_asset", _fake_asset)
    for limit in (3e6, 1e12):
        recs = list(runner._local_pool([{"id": "a", "digest": "a"}], 1, mp.get_context("fork"), limit))
        assert [(r["id"], r["status"]) for r in recs] == [("a", "built")]


def test_clean_after_worker_deletes_that_assets_temporaries_alone(tmp_path):
    # usd-core writes a layer to ``.<name less .usdc>.XXXXXX`` and renames it (strace): a worker stopped as
    # it exported its layer left ``.<stem>.XXXXXXXX.tmp.XXXXXX``, which nothing deleted until the next run
    from swpm_usd.pipeline.runner import _clean_after_worker

    def temporaries(stem):
        return [
            f".{stem}.swpm.ab12cd34.tmp",
            f".{stem}.k2_9zq0x.tmp.usdc",
            f".{stem}.k2_9zq0x.tmp.jU5dcx",  # (usd-core's, as it writes the one above)
            f".{stem}.swpm.ab12cd34.prev.tmp",
            f".{stem}.usdc.ab12cd34.prev.tmp",
        ]

    others = ["a.b", "ab", "[a]", "a*", "a?", "b"]
    for stem in ["a", *others]:
        for name in temporaries(stem) + [f"{stem}.swpm", f"{stem}.usdc"]:
            (tmp_path / name).write_bytes(b"x")
    _clean_after_worker(tmp_path, {}, "a")
    left = {p.name for p in tmp_path.iterdir()}
    assert not left & set(temporaries("a")), sorted(left & set(temporaries("a")))
    assert {n for s in others for n in temporaries(s)} <= left and {"a.swpm", "a.usdc"} <= left
    _clean_after_worker(tmp_path, {}, "[a]")  # (a stem with glob's characters: its own files alone)
    assert {n for s in others if s != "[a]" for n in temporaries(s)} <= {p.name for p in tmp_path.iterdir()}
    assert not {p.name for p in tmp_path.iterdir()} & set(temporaries("[a]"))


def test_a_glob_reaching_into_output_dir_never_takes_the_run_s_outputs(tmp_path):
    # `glob: "**/*"` with output.dir below the config passed its first run, and the second took its own
    # outputs (out/a.usdc, out/scene.usda) as assets: exit 2, "out/a.usdc and m/a.obj would both write a.swpm"
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: '**/*'}]\noutput: {dir: out, usd: true, scene: true}\n"
        "defaults: {encoding: vanilla}\n"
    )
    assert run(cfg, echo=lambda m: None).built == 1
    assert (tmp_path / "out" / "a.usdc").is_file() and (tmp_path / "out" / "scene.usda").is_file()
    for _ in range(2):
        result = CliRunner().invoke(main, ["run", str(cfg), "--json"])
        assert result.exit_code == 0, result.output
        summary = json.loads(result.stdout)
        assert (summary["built"], summary["skipped"], summary["failed"]) == (0, 1, 0)
    assert set(json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]) == {"m/a.obj"}
    # output.dir "." holds the inputs too: the outputs the manifest records are left out there
    (tmp_path / "flat").mkdir()
    (tmp_path / "flat" / "b.obj").write_text(TWO_TRIANGLES)
    flat = tmp_path / "flat" / "c.yaml"
    flat.write_text(
        "version: 1\nassets: [{glob: '*'}]\noutput: {dir: '.', usd: true, scene: true}\n"
        "defaults: {encoding: vanilla}\n"
    )
    assert run(flat, echo=lambda m: None).built == 1 and (tmp_path / "flat" / "b.usdc").is_file()
    res = run(flat, echo=lambda m: None)
    assert (res.built, res.skipped, res.failed) == (0, 1, 0) and set(res.records) == {"b.obj"}
    # a glob that matches nothing but the outputs is an error naming the glob and output.dir
    cfg.write_text("version: 1\nassets: [{glob: 'out/*'}]\noutput: {dir: out}\n")
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=lambda m: None)
    assert exc.value.problems[0].endswith(
        ":2:17: $.assets[0].glob: the glob matches only files in output.dir (out), which are never assets: "
        "the run writes there"
    )


def test_config_problems_name_the_config_as_given(tmp_path, monkeypatch):
    # they named the file alone ("pipeline.yaml:4:11: ..."): from another folder, or with several configs
    # of one name, an editor could not find it
    (tmp_path / "proj" / "m").mkdir(parents=True)
    (tmp_path / "proj" / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "proj" / "pipeline.yaml"
    cfg.write_text("version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out, colour: red}\n")
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["run", "proj/pipeline.yaml"])
    assert result.exit_code == 2
    assert result.stderr.splitlines() == ["proj/pipeline.yaml:3:20: $.output.colour: unknown key"]
    with pytest.raises(ConfigError) as exc:  # (an absolute path as given: it)
        load_config(cfg)
    assert exc.value.problems == [f"{cfg}:3:20: $.output.colour: unknown key"]
    # the run's own checks, unreadable files and YAML errors too; problems sorted by line, colons or not
    cfg.write_text("version: 1\nassets: [{glob: 'nothing/*.obj'}]\noutput: {dir: out}\n")
    result = CliRunner().invoke(main, ["run", "proj/pipeline.yaml", "--dry-run"])
    assert result.stderr.splitlines() == [
        "proj/pipeline.yaml:2:17: $.assets[0].glob: the glob matches no file"
    ]
    cfg.write_text("version: 1\nassets: [\n")
    with pytest.raises(ConfigError, match=r"^proj/pipeline.yaml:3:1: \$: invalid YAML"):
        load_config("proj/pipeline.yaml")
    # an empty config (or comments alone) says so; a list is named (both said "must be a mapping")
    for text, says in (
        ("", "holds no configuration; a pipeline config is a mapping with version, assets and output"),
        ("# to do\n", "holds no configuration"),
        ("- a\n", "must be a mapping (version, assets, output), not a list"),
        ("3\n", "must be a mapping (version, assets, output), not a scalar"),
    ):
        cfg.write_text(text)
        with pytest.raises(ConfigError, match=r"^proj/pipeline.yaml:1:1: \$: .*" + re.escape(says)):
            load_config("proj/pipeline.yaml")
    odd = tmp_path / "a:1:2: b.yaml"
    odd.write_text("version: 2\noutput: {dir: out, colour: red}\nassets: []\n")
    with pytest.raises(ConfigError) as exc:
        load_config(odd)
    assert [p.removeprefix(f"{odd}:")[:4] for p in exc.value.problems] == ["1:10", "2:20", "3:9:"]
    with pytest.raises(ConfigError, match=r"^missing.yaml:1:1: \$: file not found$"):
        load_config("missing.yaml")


def test_a_rule_shadowed_by_earlier_rules_is_named_so(tmp_path):
    # a rule whose every asset an earlier rule takes was reported as "matches no asset", which sent the user
    # looking at its match conditions instead of the rule order
    (tmp_path / "m").mkdir()
    for name in ("a", "b"):
        (tmp_path / "m" / f"{name}.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\nrules:\n"
        "  - {name: first, match: {path: 'm/a.*', triangles: {max: 100}}, encoding: vanilla}\n"
        "  - {name: second, match: {path: 'm/b.*'}, encoding: mixed}\n"
        "  - {name: a-again, match: {path: 'm/a.obj'}, encoding: skip-strip}\n"
        "  - {name: huge, match: {triangles: {min: 1000000}}, encoding: vanilla}\n"
        "  - {name: rest, encoding: vanilla}\n"
    )
    expected = [
        f"{cfg}:7:5: $.rules[2]: rule 'a-again' is shadowed by rule 'first': every asset it matches is taken "
        "by an earlier rule",
        f"{cfg}:8:5: $.rules[3]: rule 'huge' matches no asset",
        f"{cfg}:9:5: $.rules[4]: rule 'rest' is shadowed by rules 'first' and 'second': every asset it "
        "matches is taken by an earlier rule",
    ]
    # planned (the triangles counted by the plan) and run (the worker matches the rules on triangles)
    messages: list[str] = []
    assert run(cfg, dry_run=True, echo=messages.append).warnings == expected
    assert [m for m in messages if m.startswith("warning:")] == [f"warning: {w}" for w in expected]
    result = CliRunner().invoke(main, ["run", str(cfg)])
    assert result.exit_code == 0, result.output
    assert [line for line in result.output.splitlines() if line.startswith("warning:")] == [
        f"warning: {w}" for w in expected
    ]
    assert run(cfg, echo=lambda m: None).warnings == expected  # (up to date: from the manifest's counts)


def test_jobs_has_an_upper_bound(tmp_path, monkeypatch):
    # `--jobs 100000` was taken: a worker process per asset, up to the asset count, started at once
    from swpm_usd import cli

    cfg = _vanilla_project(tmp_path)
    for jobs in ("100000", str(cli.MAX_JOBS + 1)):
        result = CliRunner().invoke(main, ["run", str(cfg), "--jobs", jobs])
        assert result.exit_code == 2 and "--jobs" in result.output and "1<=x<=256" in result.output
        assert not (tmp_path / "out").exists()
    assert "1<=x<=256" in CliRunner().invoke(main, ["run", "--help"]).output
    # the bound itself is taken, and no more workers start than there are assets to build
    from swpm_usd.pipeline import pool

    started = []

    class Worker(pool._Worker):
        def __init__(self, ctx):
            started.append(1)
            super().__init__(ctx)

    monkeypatch.setattr(pool, "_Worker", Worker)
    result = CliRunner().invoke(main, ["run", str(cfg), "--jobs", str(cli.MAX_JOBS)])
    assert result.exit_code == 0, result.output
    assert started == [1]


def _glb_with_external_buffer(mesh, path: Path, bin_name: str) -> None:
    """``mesh`` (a trimesh) as a .glb whose one buffer is the file ``bin_name`` beside it, no binary chunk."""
    import struct

    import trimesh

    data = trimesh.Scene(mesh).export(file_type="glb")
    magic, version, _ = struct.unpack_from("<4sII", data, 0)
    json_length, json_type = struct.unpack_from("<II", data, 12)
    doc = json.loads(data[20 : 20 + json_length])
    bin_length = struct.unpack_from("<I", data, 20 + json_length)[0]
    used = doc["buffers"][0]["byteLength"]
    (path.parent / bin_name).write_bytes(data[28 + json_length : 28 + json_length + bin_length][:used])
    doc["buffers"] = [{"uri": bin_name, "byteLength": used}]
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    path.write_bytes(struct.pack("<4sIIII", magic, version, 20 + len(text), len(text), json_type) + text)


def _spot_glb_with_external_buffer(tmp_path: Path):
    """spot as ``m/spot.glb`` keeping its buffer in ``m/spot-data.bin``: (the trimesh, the .glb, the .bin)."""
    import trimesh

    (tmp_path / "m").mkdir()
    spot = swpm_usd.load_mesh(SHARED_MESHES / "spot.obj")
    mesh = trimesh.Trimesh(spot.points, spot.triangles, process=False)
    glb, data = tmp_path / "m" / "spot.glb", tmp_path / "m" / "spot-data.bin"
    _glb_with_external_buffer(mesh, glb, data.name)
    return mesh, glb, data


def test_a_glb_s_external_buffer_files_are_its_inputs(tmp_path, monkeypatch):
    # a .glb may keep its buffers in files beside it (a `uri` in its JSON chunk), which the loader reads as
    # it does a .gltf's: they were no input of the asset, so an edited .bin left the stale build "up to date"
    import trimesh

    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    mesh, glb, data = _spot_glb_with_external_buffer(tmp_path)
    points = swpm_usd.load_mesh(glb).points
    assert len(points) > 0
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: m/*.glb}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    assert run(cfg, echo=lambda m: None).built == 1
    (entries,) = _recorded_inputs(tmp_path / "out").values()
    assert [(tmp_path / e["path"]) for e in entries] == [glb, data]
    assert run(cfg, echo=lambda m: None).skipped == 1
    # the buffer of the mesh scaled by 2 (the same name and size), the .glb left as it is
    _glb_with_external_buffer(mesh.copy().apply_scale(2.0), tmp_path / "scaled.glb", data.name)
    assert (tmp_path / data.name).stat().st_size == data.stat().st_size
    os.replace(tmp_path / data.name, data)
    assert np.allclose(swpm_usd.load_mesh(glb).points, 2 * points)
    assert run(cfg, echo=lambda m: None).built == 1
    # a .glb with its own binary chunk has no other input; one whose header is not a .glb's, none either
    trimesh.Scene(mesh).export(tmp_path / "m" / "whole.glb")
    (tmp_path / "m" / "broken.glb").write_bytes(b"glTF" + b"\xff" * 40)
    from swpm_usd.pipeline.assets import _gltf_buffers

    assert _gltf_buffers(tmp_path / "m" / "whole.glb") == _gltf_buffers(tmp_path / "m" / "broken.glb") == []


def test_a_stage_s_prims_share_one_list_of_its_layers_in_the_manifest(tmp_path, monkeypatch):
    # each prim's record listed every layer of its stage (10,000 prims of a 50-layer stage: about 75 MB of
    # manifest): the list is written once, in `input_lists`, and each record names it by `inputs_ref`
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg, layer = _two_layer_stage(tmp_path)
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg.write_text(
        "version: 1\nassets: [{stage: stage/scene.usda}, {glob: 'm/*.obj'}]\noutput: {dir: out}\n"
        "defaults: {encoding: vanilla}\n"
    )
    assert run(cfg, echo=lambda m: None).built == 3
    path = tmp_path / "out" / "manifest.json"
    manifest = json.loads(path.read_text())
    (key, entries), *more = manifest["input_lists"].items()
    assert not more and sorted(Path(e["path"]).name for e in entries) == ["scene.usda", "spot_asset.usda"]
    prims = {aid: rec for aid, rec in manifest["assets"].items() if aid.startswith("stage/")}
    assert len(prims) == 2 and all(rec["inputs_ref"] == key and "inputs" not in rec for rec in prims.values())
    # (an input list no other record holds stays in its record)
    assert [e["path"] for e in manifest["assets"]["m/a.obj"]["inputs"]] == ["m/a.obj"]
    assert "inputs_ref" not in manifest["assets"]["m/a.obj"]
    # read back: a rerun trusts the shared list, reading no input
    reads = _input_reads(monkeypatch, tmp_path / "stage")
    assert run(cfg, echo=lambda m: None).skipped == 3 and reads == []
    # a manifest written before (each record listing them) is read as well, and written compact again
    for rec in prims.values():
        rec["inputs"] = entries
        del rec["inputs_ref"]
    del manifest["input_lists"]
    path.write_text(json.dumps(manifest, indent=1))
    assert run(cfg, echo=lambda m: None).skipped == 3 and reads == []
    rewritten = json.loads(path.read_text())
    assert list(rewritten["input_lists"]) == [key]
    assert rewritten["assets"] == manifest["assets"] | {
        aid: {**{k: v for k, v in rec.items() if k != "inputs"}, "inputs_ref": key}
        for aid, rec in prims.items()
    }
    # a reference to no list (a hand edit): the layers are hashed, and the prims still up to date
    text = path.read_text().replace(f'"inputs_ref": "{key}"', '"inputs_ref": "nothing"')
    path.write_text(text)
    reads.clear()
    res = run(cfg, echo=lambda m: None)
    assert res.skipped == 3
    assert sorted(reads) == ["scene.usda", "spot_asset.usda"]
    # (named in a warning, as a hand-edited record is)
    assert sorted(w for w in res.warnings if "inputs_ref" in w) == [
        f"out/manifest.json: the record of {aid} names no list of its inputs (inputs_ref 'nothing', which "
        "the manifest's input_lists does not hold); they are hashed"
        for aid in sorted(prims)
    ]
    # an input_lists that is not an object: the same
    manifest = json.loads(path.read_text())
    manifest["input_lists"] = list(manifest["input_lists"].values())
    path.write_text(json.dumps(manifest, indent=1))
    res = run(cfg, echo=lambda m: None)
    assert res.skipped == 3
    assert len([w for w in res.warnings if "input_lists is a list, not an object" in w]) == 2
    # the stage changed: both prims rebuilt, sharing the new list
    _same_size_edit(layer, b"points = [(")
    assert run(cfg, echo=lambda m: None).built == 2
    recorded = _recorded_inputs(tmp_path / "out")
    assert recorded["stage/scene.usda:/World/spot/Body"] == recorded["stage/scene.usda:/World/spot/Copy"]
    assert all(_as_hashed(e, tmp_path / e["path"]) for e in recorded["stage/scene.usda:/World/spot/Body"])
    assert len(json.loads(path.read_text())["input_lists"]) == 1


def test_a_rerun_takes_a_gltf_s_or_usd_file_s_inputs_from_its_record_when_they_are_as_recorded(
    tmp_path, monkeypatch
):
    # a no-change rerun read every glob-matched .gltf's JSON and opened every USD file as a stage to list its
    # inputs (about 4 ms a small .usda): the list its record holds is taken while every file in it is as
    # recorded (the trust the input digest is taken by), and read again once one is not
    import trimesh
    from pxr import Usd, UsdGeom

    from swpm_usd.pipeline import assets, inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    (tmp_path / "m" / "geo").mkdir(parents=True)
    mesh = trimesh.creation.icosphere(subdivisions=1)
    for name, data in trimesh.Scene(mesh).export(file_type="gltf").items():
        (tmp_path / "m" / name).write_bytes(data)

    def geo_layer(name: str, scale: float) -> Path:
        path = tmp_path / "m" / "geo" / name
        st = Usd.Stage.CreateInMemory()
        st.SetDefaultPrim(UsdGeom.Xform.Define(st, "/G").GetPrim())
        m = UsdGeom.Mesh.Define(st, "/G/Mesh")
        m.CreatePointsAttr((mesh.vertices * scale).tolist())
        m.CreateFaceVertexCountsAttr([3] * len(mesh.faces))
        m.CreateFaceVertexIndicesAttr(mesh.faces.reshape(-1).tolist())
        st.GetRootLayer().Export(str(path))
        return path

    geo_layer("a.usda", 1.0)
    top = tmp_path / "m" / "s.usda"
    st = Usd.Stage.CreateNew(str(top))
    st.SetDefaultPrim(st.DefinePrim("/S", "Xform"))
    st.GetDefaultPrim().GetReferences().AddReference("./geo/a.usda")
    st.GetRootLayer().Save()
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.*'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    listed: list[str] = []
    for name in ("_gltf_buffer_files", "_usd_layer_files"):
        real = getattr(assets, name)

        def spy(path, real=real):
            listed.append(path.name)
            return real(path)

        monkeypatch.setattr(assets, name, spy)
    assert run(cfg, echo=lambda m: None).built == 2
    assert sorted(set(listed)) == ["model.gltf", "s.usda"]
    recorded = _recorded_inputs(tmp_path / "out")
    assert [Path(e["path"]).name for e in recorded["m/s.usda"]] == ["s.usda", "a.usda"]
    assert len(recorded["m/model.gltf"]) > 1  # (its .bin files)
    listed.clear()
    assert run(cfg, echo=lambda m: None).skipped == 2 and listed == []
    # --verify lists (and hashes) them all
    assert run(cfg, echo=lambda m: None, verify=True).skipped == 2 and sorted(set(listed)) == [
        "model.gltf", "s.usda"
    ]  # fmt: skip
    # a layer it uses changed: listed again, and rebuilt
    listed.clear()
    geo_layer("a.usda", 2.0)
    res = run(cfg, echo=lambda m: None)
    assert res.built_ids == ["m/s.usda"] and sorted(set(listed)) == ["s.usda"]
    listed.clear()
    assert run(cfg, echo=lambda m: None).skipped == 2 and listed == []
    # the file itself now references another layer: listed again, the new layer an input
    geo_layer("b.usda", 3.0)
    st = Usd.Stage.Open(str(top))
    refs = st.GetDefaultPrim().GetReferences()
    refs.ClearReferences()
    refs.AddReference("./geo/b.usda")
    st.GetRootLayer().Save()
    del st, refs  # (an open layer is the one USD gives the loader, whatever the file holds)
    assert run(cfg, echo=lambda m: None).built_ids == ["m/s.usda"] and "s.usda" in listed
    assert [Path(e["path"]).name for e in _recorded_inputs(tmp_path / "out")["m/s.usda"]] == [
        "s.usda",
        "b.usda",
    ]
    # a failed build's record lists nothing to trust: a file of one is listed again
    top.write_text("not a USD file\n")
    assert run(cfg, echo=lambda m: None).failed == 1
    listed.clear()
    assert run(cfg, echo=lambda m: None).failed == 1 and "s.usda" in listed


def test_a_record_listing_a_glb_s_inputs_the_old_way_is_never_taken_as_its_list(tmp_path, monkeypatch):
    # a record written before a .glb's buffer files were inputs (the same tool_version) lists the .glb
    # alone: a rerun took that list as the asset's inputs (every file in it as recorded) instead of reading
    # the .glb, so an edited .bin left the stale build "up to date" for good

    from swpm_usd.pipeline import assets, inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    mesh, glb, data = _spot_glb_with_external_buffer(tmp_path)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: m/*.glb}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    # the older version: the .glb read as no buffer file's, and no word in its record of how it was listed
    with monkeypatch.context() as m:
        m.setattr(assets, "_gltf_buffer_files", lambda path: ([], True))
        assert run(cfg, echo=lambda m: None).built == 1
    path = tmp_path / "out" / "manifest.json"
    manifest = json.loads(path.read_text())
    (rec,) = manifest["assets"].values()
    rec.pop("inputs_listed", None)
    assert [(tmp_path / e["path"]) for e in rec["inputs"]] == [glb]
    path.write_text(json.dumps(manifest, indent=1))
    # read again (its buffer file now an input: the digest changes, and it is built once more)
    assert run(cfg, echo=lambda m: None).built == 1
    (entries,) = _recorded_inputs(tmp_path / "out").values()
    assert [(tmp_path / e["path"]) for e in entries] == [glb, data]
    # an older record whose list is the .glb's inputs: up to date, and marked as a list to take from now on
    manifest = json.loads(path.read_text())
    assert manifest["assets"]["m/spot.glb"].pop("inputs_listed") == 1
    path.write_text(json.dumps(manifest, indent=1))
    assert run(cfg, echo=lambda m: None).skipped == 1
    assert json.loads(path.read_text())["assets"]["m/spot.glb"]["inputs_listed"] == 1
    _glb_with_external_buffer(mesh.copy().apply_scale(2.0), tmp_path / "scaled.glb", data.name)
    os.replace(tmp_path / data.name, data)
    assert run(cfg, echo=lambda m: None).built == 1


def test_a_gltf_buffer_found_by_its_last_name_is_listed_again_once_its_name_as_written_appears(
    tmp_path, monkeypatch
):
    # the loader reads a buffer `uri: bin/data.bin` from bin/data.bin, or else from data.bin beside the
    # .gltf: built from data.bin, the record lists it; bin/data.bin written later is what the loader reads,
    # with every file of the record as recorded, so the record's list is not the asset's inputs any more
    import trimesh

    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    (tmp_path / "m" / "bin").mkdir(parents=True)
    mesh = trimesh.creation.icosphere(subdivisions=1)
    files = trimesh.Scene(mesh).export(file_type="gltf")
    doc = json.loads(files["model.gltf"])
    uris = [b["uri"] for b in doc["buffers"]]
    for b in doc["buffers"]:
        b["uri"] = f"bin/{b['uri']}"
    (tmp_path / "m" / "model.gltf").write_text(json.dumps(doc))
    for uri in uris:
        (tmp_path / "m" / uri).write_bytes(files[uri])
    points = swpm_usd.load_mesh(tmp_path / "m" / "model.gltf").points
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: m/*.gltf}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    assert run(cfg, echo=lambda m: None).built == 1
    assert run(cfg, echo=lambda m: None).skipped == 1
    scaled = trimesh.Scene(mesh.copy().apply_scale(2.0)).export(file_type="gltf")
    for uri in uris:
        (tmp_path / "m" / "bin" / uri).write_bytes(scaled[uri])
    assert np.allclose(swpm_usd.load_mesh(tmp_path / "m" / "model.gltf").points, 2 * points)
    assert run(cfg, echo=lambda m: None).built == 1
    (entries,) = _recorded_inputs(tmp_path / "out").values()
    assert {tmp_path / "m" / "bin" / uri for uri in uris} <= {(tmp_path / e["path"]) for e in entries}
    assert run(cfg, echo=lambda m: None).skipped == 1


def test_a_record_listing_a_usd_file_alone_the_old_way_is_never_taken_as_its_list(tmp_path, monkeypatch):
    # a record written before a glob-matched USD file's layers were inputs lists the file alone: taken as
    # its list (the file unchanged), an edited layer it references left the stale build "up to date"
    import trimesh
    from pxr import Usd, UsdGeom

    from swpm_usd.pipeline import assets, inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    (tmp_path / "m" / "geo").mkdir(parents=True)
    mesh = trimesh.creation.icosphere(subdivisions=1)
    layer = tmp_path / "m" / "geo" / "a.usda"

    def write_layer(scale: float) -> None:
        st = Usd.Stage.CreateInMemory()
        st.SetDefaultPrim(UsdGeom.Xform.Define(st, "/G").GetPrim())
        m = UsdGeom.Mesh.Define(st, "/G/Mesh")
        m.CreatePointsAttr((mesh.vertices * scale).tolist())
        m.CreateFaceVertexCountsAttr([3] * len(mesh.faces))
        m.CreateFaceVertexIndicesAttr(mesh.faces.reshape(-1).tolist())
        st.GetRootLayer().Export(str(layer))

    write_layer(1.0)
    top = tmp_path / "m" / "s.usda"
    st = Usd.Stage.CreateNew(str(top))
    st.SetDefaultPrim(st.DefinePrim("/S", "Xform"))
    st.GetDefaultPrim().GetReferences().AddReference("./geo/a.usda")
    st.GetRootLayer().Save()
    del st
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.usda'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    with monkeypatch.context() as m:
        m.setattr(assets, "_usd_layer_files", lambda path: ([], True))
        assert run(cfg, echo=lambda m: None).built == 1
    path = tmp_path / "out" / "manifest.json"
    manifest = json.loads(path.read_text())
    manifest["assets"]["m/s.usda"].pop("inputs_listed", None)
    assert [(tmp_path / e["path"]) for e in manifest["assets"]["m/s.usda"]["inputs"]] == [top]
    path.write_text(json.dumps(manifest, indent=1))
    # listed again: the layer is an input (the digest changes, and it is built once more)
    assert run(cfg, echo=lambda m: None).built == 1
    recorded = _recorded_inputs(tmp_path / "out")["m/s.usda"]
    assert [Path(e["path"]).name for e in recorded] == ["s.usda", "a.usda"]
    assert run(cfg, echo=lambda m: None).skipped == 1
    write_layer(2.0)
    assert run(cfg, echo=lambda m: None).built == 1


def test_a_gltf_whose_json_did_not_read_while_listed_is_listed_again(tmp_path, monkeypatch):
    # a .gltf whose JSON did not read as the run listed its inputs (being written, unreadable a moment) was
    # listed alone, and the loader, reading it after, built it: the record of a build then kept that list
    # for good, as the .gltf's own (unchanged), and an edited .bin left the stale build "up to date"
    import trimesh

    from swpm_usd.pipeline import assets, inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    (tmp_path / "m").mkdir()
    mesh = trimesh.creation.icosphere(subdivisions=1)
    files = trimesh.Scene(mesh).export(file_type="gltf")
    for name, data in files.items():
        (tmp_path / "m" / name).write_bytes(data)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: m/*.gltf}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    with monkeypatch.context() as m:
        m.setattr(assets, "_gltf_document", lambda path: None)
        assert run(cfg, echo=lambda m: None).built == 1
    (entries,) = _recorded_inputs(tmp_path / "out").values()
    assert [Path(e["path"]).name for e in entries] == ["model.gltf"]
    # read again: its buffer files are inputs now (built again, the digest being another)
    assert run(cfg, echo=lambda m: None).built == 1
    (entries,) = _recorded_inputs(tmp_path / "out").values()
    assert len(entries) > 1
    assert run(cfg, echo=lambda m: None).skipped == 1
    scaled = trimesh.Scene(mesh.copy().apply_scale(2.0)).export(file_type="gltf")
    for name in files:
        if name != "model.gltf":
            (tmp_path / "m" / name).write_bytes(scaled[name])
    assert run(cfg, echo=lambda m: None).built == 1


def _files_written(out: Path) -> dict[str, tuple[int, int]]:
    """manifest.json, scene.usda and report.html by (inode, mtime): each write (a temporary file renamed
    into place) gives another inode; a file missing is absent."""
    names = ("manifest.json", "scene.usda", "report.html")
    return {n: (st.st_ino, st.st_mtime_ns) for n in names if (p := out / n).exists() and (st := p.stat())}


def test_a_rerun_that_changes_nothing_rewrites_no_manifest_scene_or_report(tmp_path, monkeypatch):
    # a rerun with nothing to build serialised and rewrote the whole manifest, the scene and the report
    # (10,000 small assets: a 47 MB manifest, 2.5-2.9 s of a 7-9 s rerun); each is written again when what
    # it holds would change, or when the file is not the one the last run wrote
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)  # (inputs just written: see the racily clean test)
    (tmp_path / "m").mkdir()
    for name in ("a", "b", "c"):
        (tmp_path / "m" / f"{name}.obj").write_text(TWO_TRIANGLES + f"# {name}\n")
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\ndefaults: {encoding: vanilla}\n"
    cfg.write_text(head + "output: {dir: out, usd: true, scene: true}\n")
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 3
    first = _files_written(out)
    assert sorted(first) == ["manifest.json", "report.html", "scene.usda"]
    res = run(cfg, echo=lambda m: None)
    assert res.skipped == 3 and _files_written(out) == first  # nothing written
    # (the mark: the digest of the manifest's records as written, see runner.CURRENT)
    marks = [o["current"] for o in json.loads((out / "manifest.json").read_text())["run_outputs"].values()]
    assert len(marks) == 2 and all(isinstance(m, str) and len(m) == 16 for m in marks)

    def rewritten() -> list[str]:
        nonlocal first
        now = _files_written(out)
        changed = sorted(n for n in set(first) | set(now) if first.get(n) != now.get(n))
        first = now
        return changed

    # a file the user deleted or edited: written again (and its record, so the manifest)
    (out / "report.html").unlink()
    assert run(cfg, echo=lambda m: None).skipped == 3
    assert rewritten() == ["manifest.json", "report.html"]
    (out / "scene.usda").write_text("#usda 1.0\n")
    run(cfg, echo=lambda m: None)
    assert rewritten() == ["manifest.json", "scene.usda"] and "b.usdc" in (out / "scene.usda").read_text()
    assert run(cfg, echo=lambda m: None).skipped == 3 and rewritten() == []
    # the output options changed: the report no longer asked for (an orphan, recorded), then asked again
    cfg.write_text(head + "output: {dir: out, usd: true, scene: true, report: false}\n")
    assert run(cfg, echo=lambda m: None).unlisted == ["report.html"]
    assert rewritten() == ["manifest.json", "scene.usda"]
    cfg.write_text(head + "output: {dir: out, usd: true, scene: true}\n")
    run(cfg, echo=lambda m: None)
    assert rewritten() == ["manifest.json", "report.html", "scene.usda"]
    assert run(cfg, echo=lambda m: None).skipped == 3 and rewritten() == []
    # the config changed: an asset rebuilt; the config's path (the manifest and the report name it)
    cfg.write_text(head.replace("vanilla", "skip-strip") + "output: {dir: out, usd: true, scene: true}\n")
    assert run(cfg, echo=lambda m: None).built == 3
    assert rewritten() == ["manifest.json", "report.html", "scene.usda"]
    moved = tmp_path / "d.yaml"
    shutil.copy(cfg, moved)
    assert run(moved, echo=lambda m: None).skipped == 3
    assert rewritten() == ["manifest.json", "report.html", "scene.usda"]
    assert str(moved) in (out / "report.html").read_text()
    assert run(moved, echo=lambda m: None).skipped == 3 and rewritten() == []
    # an asset removed: its record, its layer in the scene and its row in the report go
    (tmp_path / "m" / "b.obj").unlink()
    assert run(moved, echo=lambda m: None, prune=True).pruned == ["b.swpm", "b.usdc"]
    assert rewritten() == ["manifest.json", "report.html", "scene.usda"]
    assert (
        "b.usdc" not in (out / "scene.usda").read_text()
        and "m/b.obj" not in (out / "report.html").read_text()
    )
    assert run(moved, echo=lambda m: None).skipped == 2 and rewritten() == []


def test_a_run_stopped_before_its_scene_and_report_leaves_them_to_be_written_again(tmp_path, monkeypatch):
    # the manifest a run writes as assets finish (or when it is stopped) holds their new records while the
    # scene and report recorded are the last run's: the next run, with nothing left to build, writes them
    from swpm_usd.pipeline import inputs, runner

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out, usd: true, scene: true}\n"
    cfg.write_text(head + "defaults: {encoding: vanilla}\n")
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    cfg.write_text(head + "defaults: {encoding: skip-strip}\n")

    def stopped(tasks, *args):  # (every asset built, then Ctrl-C: as a kill after the manifest's last write)
        yield from execute(tasks, *args)
        raise KeyboardInterrupt

    execute = runner.execute
    with monkeypatch.context() as m:
        m.setattr(runner, "execute", stopped)
        with pytest.raises(KeyboardInterrupt):
            run(cfg, echo=lambda m: None)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["assets"]["m/a.obj"]["encoding"] == "skip-strip"  # (recorded, the scene not written)
    assert sorted(manifest["run_outputs"]) == ["report", "scene"]
    assert all("current" not in o for o in manifest["run_outputs"].values())
    before = _files_written(out)
    assert run(cfg, echo=lambda m: None).skipped == 1
    after = _files_written(out)
    assert all(before[n] != after[n] for n in before), "the last run's scene and report were kept"
    assert "skip-strip" in (out / "report.html").read_text()
    assert run(cfg, echo=lambda m: None).skipped == 1 and _files_written(out) == after


def _report_manifest(tmp_path: Path, monkeypatch) -> dict:
    """The manifest of a run of two small assets, its records copied under three more ids (one an id that
    would end a script element were it written as it is)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m").mkdir()
    shutil.copy(SHARED_MESHES / "suzanne.obj", tmp_path / "m" / "a.obj")
    (tmp_path / "m" / "b.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    assert run(cfg, echo=lambda m: None).built == 2
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    a = manifest["assets"]["m/a.obj"]
    manifest["assets"] |= {f"m/c{i}.obj": a for i in range(2)} | {"m/</script><b>.obj": a}
    return manifest


def test_a_report_s_curve_table_holds_a_figure_not_finite_as_null(tmp_path, monkeypatch):
    from swpm_usd.pipeline import report

    manifest = _report_manifest(tmp_path, monkeypatch)
    rec = manifest["assets"]["m/a.obj"]
    curve = [dict(c) for c in rec["summary"]["curve"]]
    curve[1]["error"] = float("nan")
    manifest["assets"]["m/a.obj"] = {**rec, "summary": {**rec["summary"], "curve": curve}}
    monkeypatch.setattr(report, "INLINE_CURVES", 0)
    report.write_report(tmp_path / "report.html", manifest)
    text = (tmp_path / "report.html").read_text()
    start = text.index("id=curve-data>") + len("id=curve-data>")

    def invalid(token: str):
        raise AssertionError(f"{token} is not JSON (a browser's JSON.parse refuses it)")

    table = json.loads(text[start : text.index("</script>", start)], parse_constant=invalid)
    assert table["m/a.obj"][2][1] is None and table["m/c0.obj"][2][1] is not None


def test_a_report_of_many_assets_draws_their_curves_on_demand(tmp_path, monkeypatch):
    # a report of 10,000 assets held 20,000 inline SVG plots (11 MB for a browser to lay out on opening):
    # beyond INLINE_CURVES built assets each curve is a compact entry a script draws when asked
    from swpm_usd.pipeline import report

    manifest = _report_manifest(tmp_path, monkeypatch)
    path = tmp_path / "report.html"
    report.write_report(path, manifest)  # (5 built assets: inline, as before; no script)
    text = path.read_text()
    assert text.count("<svg") == 10 and "<script" not in text
    monkeypatch.setattr(report, "INLINE_CURVES", 4)
    report.write_report(path, manifest)
    text = path.read_text()
    assert text.count("<svg") == report._CURVE_SCRIPT.count("<svg")  # (the script's alone)
    # every asset's row still, its name the link that draws its curves
    for aid in manifest["assets"]:
        assert f"<a class=curve href='#curves'>{html.escape(aid)}</a>" in text
    assert "m/</script><b>.obj" not in text  # (escaped in the table and in the curve data)
    start = text.index("<script type=application/json id=curve-data>") + len(
        "<script type=application/json id=curve-data>"
    )
    table = json.loads(text[start : text.index("</script>", start)])
    assert sorted(table) == sorted(manifest["assets"])
    for aid, rec in manifest["assets"].items():
        curve = rec["summary"]["curve"]
        encoding, *figures, error_labels, acmr_labels = table[aid]
        assert encoding == rec["encoding"] and len(curve) > 1
        for got, key in zip(figures, ("triangles", "error", "lod", "acmr"), strict=True):
            assert got == pytest.approx([c[key] for c in curve], rel=1e-3, abs=1e-12), (aid, key)
        # the axis ends' labels: the fewest and most triangles, the least and largest error, LODs, ACMR
        tri, err = [c["triangles"] for c in curve], [c["error"] for c in curve]
        assert error_labels[:2] == [str(min(tri)), str(max(tri))]
        assert float(error_labels[3]) == pytest.approx(max(err), rel=6e-3)
        lods = [c["lod"] for c in curve]
        assert acmr_labels[:2] == [str(min(lods)), str(max(lods))]
    assert "click an asset's name" in text and "summary.curve" in text


@pytest.mark.skipif(shutil.which("node") is None, reason="needs node to run the report's script")
def test_the_report_s_script_draws_the_plots_the_report_draws_inline(tmp_path, monkeypatch):
    from swpm_usd.pipeline import report

    manifest = _report_manifest(tmp_path, monkeypatch)
    monkeypatch.setattr(report, "INLINE_CURVES", 0)
    path = tmp_path / "report.html"
    report.write_report(path, manifest)
    text = path.read_text()
    start = text.index("id=curve-data>") + len("id=curve-data>")
    data, script = text[start:].split("</script>", 1)
    script = script[script.index("<script>") + len("<script>") : script.index("</script>")]
    aid = "m/a.obj"
    harness = (
        "function el(t){return {children:[],className:'',textContent:'',innerHTML:'',"
        "appendChild:function(c){this.children.push(c)},insertBefore:function(c){this.children.unshift(c)}};}"
        "var box=el('div'),on={};var document={createElement:el,getElementById:function(id){"
        f"if(id==='curve-data')return {{textContent:{json.dumps(data)}}};if(id==='curves')return box;"
        "return {addEventListener:function(t,f){on[t]=f}};}};\n" + script + "\n"
        f"on.click({{target:{{closest:function(){{return {{textContent:{json.dumps(aid)}}}}}}}}});"
        "var c=box.children[0];console.log(JSON.stringify([c.children[0].textContent,"
        "c.children[0].children[0].textContent,c.children[1].innerHTML,c.children[2].innerHTML]));"
    )
    (tmp_path / "h.js").write_text(harness)
    done = subprocess.run(["node", str(tmp_path / "h.js")], capture_output=True, text=True, check=True)
    title, encoding, errors, acmr = json.loads(done.stdout)
    assert title.strip() == aid and encoding == "vanilla"
    curve = manifest["assets"][aid]["summary"]["curve"]
    compact = [float(f"{c['error']:.4g}") for c in curve]  # (the figures as the table holds them)
    assert errors == "triangles (x) vs error (y, log)<br>" + report._polyline(
        [c["triangles"] for c in curve], compact, log_y=True
    )
    assert acmr == "LOD (x) vs ACMR (y)<br>" + report._polyline(
        [c["lod"] for c in curve], [float(f"{c['acmr']:.4g}") for c in curve]
    )


def test_a_run_leaves_the_garbage_collector_as_it_found_it(tmp_path):
    # the run pauses the cyclic collector while it reads the manifest and plans (10,000 assets: 0.4 s of its
    # full collections in a 2.4 s rerun); it is running again after, or still paused if the caller paused it
    import gc

    cfg = _vanilla_project(tmp_path)
    assert gc.isenabled()
    assert run(cfg, echo=lambda m: None).built == 1 and gc.isenabled()
    assert run(cfg, echo=lambda m: None).skipped == 1 and gc.isenabled()
    gc.disable()
    try:
        assert run(cfg, echo=lambda m: None, force=True).built == 1 and not gc.isenabled()
    finally:
        gc.enable()
    (tmp_path / "m" / "a.obj").write_text("not a mesh")  # (a run that fails: the collector running again)
    assert run(cfg, echo=lambda m: None).failed == 1 and gc.isenabled()


def test_a_manifest_whose_records_were_edited_since_its_scene_and_report_has_them_written_again(
    tmp_path, monkeypatch
):
    # the scene and report a run wrote are kept only while the manifest holds the records they were written
    # from: a record edited by hand since (its text, or the whole file reformatted) has them written again
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    (tmp_path / "m").mkdir()
    for name in ("a", "b"):
        (tmp_path / "m" / f"{name}.obj").write_text(TWO_TRIANGLES + f"# {name}\n")
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\ndefaults: {encoding: vanilla}\n"
        "output: {dir: out, usd: true, scene: true}\n"
    )
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 2
    manifest_path = out / "manifest.json"
    text = manifest_path.read_text()
    # (a field the run keeps as recorded: a rule or why it corrects to today's, see the test after it)
    seconds = json.loads(text)["assets"]["m/a.obj"]["seconds"]
    manifest_path.write_text(text.replace(json.dumps(seconds), "1234.5", 1))
    written = _files_written(out)
    assert run(cfg, echo=lambda m: None).skipped == 2
    assert "<td>1234.50</td>" in (out / "report.html").read_text()
    now = _files_written(out)
    assert all(written[n] != now[n] for n in written), "the scene and report of other records were kept"
    assert run(cfg, echo=lambda m: None).skipped == 2 and _files_written(out) == now
    # the same records, the file reformatted (json.dumps): not the text the run wrote, so written again
    manifest = json.loads(manifest_path.read_text())
    manifest["assets"]["m/b.obj"]["seconds"] = 4321.0
    manifest_path.write_text(json.dumps(manifest))
    assert run(cfg, echo=lambda m: None).skipped == 2
    assert "<td>4321.00</td>" in (out / "report.html").read_text()
    now = _files_written(out)
    assert run(cfg, echo=lambda m: None).skipped == 2 and _files_written(out) == now


def test_a_report_s_link_to_an_asset_s_curves_is_its_id_as_a_browser_reads_it(tmp_path, monkeypatch):
    # the script draws an asset's curves by the text of its link: a browser's parser reads a carriage return
    # (a file name may hold one) as a line feed, an id no curve has, unless written as a character reference
    from swpm_usd.pipeline import report

    manifest = _report_manifest(tmp_path, monkeypatch)
    aid = "m/two\rlines.obj"
    manifest["assets"][aid] = manifest["assets"]["m/a.obj"]
    monkeypatch.setattr(report, "INLINE_CURVES", 0)
    report.write_report(tmp_path / "report.html", manifest)
    text = (tmp_path / "report.html").read_bytes().decode()
    assert "\r" not in text
    links = [html.unescape(t.split("</a>")[0]) for t in text.split("<a class=curve href='#curves'>")[1:]]
    assert aid in links and sorted(links) == sorted(manifest["assets"])


def test_a_stage_that_does_not_open_is_named_without_usd_core_s_source_locations(tmp_path):
    """A missing or unparsable stage was reported with usd-core's C++ function, source file and line
    ("Error in 'pxrInternal_v0_26_11__pxrReserved__::UsdStage::Open' at line 1287 in file .../stage.cpp")."""
    import contextlib

    (tmp_path / "c.yaml").write_text("version: 1\nassets: [{stage: scene.usda}]\noutput: {dir: out}\n")

    def problem() -> str:
        with contextlib.chdir(tmp_path):
            result = CliRunner().invoke(main, ["run", "c.yaml", "--dry-run"])
        assert result.exit_code == 2 and "Traceback" not in result.output, result.output
        [line] = result.stderr.splitlines()
        return line

    assert problem() == "c.yaml:2:18: $.assets[0].stage: cannot open stage scene.usda: no such file"
    (tmp_path / "scene.usda").write_text('#usda 1.0\ndef Mesh "M" {\n  point3f[] points = [(0,0,0)\n}\n')
    line = problem()
    assert line.startswith("c.yaml:2:18: $.assets[0].stage: cannot open stage scene.usda: ")
    assert "scene.usda:4:1: parse error" in line
    assert "Error in '" not in line and ".cpp" not in line


def test_a_path_rule_matches_a_file_whose_name_holds_a_colon(tmp_path):
    # the rule's path was the asset id cut at its first ':' (a stage asset's id is "<stage>:<prim>"), so
    # `m/x:y.obj` was matched as `m/x` and fell to the defaults, and a stage in `d:1/` was matched as `d`
    from pxr import Usd, UsdGeom

    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "x:y.obj").write_text(TWO_TRIANGLES)
    (tmp_path / "d:1").mkdir()
    st = Usd.Stage.CreateNew(str(tmp_path / "d:1" / "s.usda"))
    m = UsdGeom.Mesh.Define(st, "/World/solid")
    m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)])
    m.CreateFaceVertexCountsAttr([3, 3])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
    st.GetRootLayer().Save()
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}, {stage: 'd:1/s.usda'}]\noutput: {dir: out}\n"
        "defaults: {encoding: vanilla}\nrules:\n"
        "  - {name: objs, match: {path: 'm/*.obj'}, encoding: skip-strip}\n"
        "  - {name: stage, match: {path: 'd:1/s.usda', prim: '/World/*'}, encoding: mixed}\n"
    )
    res = run(cfg, dry_run=True, echo=lambda m: None)
    assert {p["id"]: p["encoding"] for p in res.plan} == {
        "m/x:y.obj": "skip-strip",
        "d:1/s.usda:/World/solid": "mixed",
    }


def test_an_up_to_date_record_names_the_rule_that_chooses_it_today(tmp_path):
    # a rule renamed, or another rule giving the same treatment (the defaults' before it), kept the build, as
    # it should, and its record's `rule` and `why` as the first build wrote them: the manifest and the
    # report named a rule the config no longer has, or "defaults" for an asset a rule takes
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    head = (
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out, report: true}\n"
        "defaults: {encoding: vanilla}\n"
    )
    cfg.write_text(head)
    assert run(cfg, echo=lambda m: None).built == 1
    for name in ("small", "tiny"):
        cfg.write_text(
            head + f"rules:\n  - {{name: {name}, match: {{triangles: {{max: 10}}}}, encoding: vanilla}}\n"
        )
        res = run(cfg, echo=lambda m: None)
        assert (res.built, res.skipped) == (0, 1)
        rec = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]["m/a.obj"]
        assert (rec["rule"], rec["why"]) == (name, f"rule '{name}' matched (triangles=2)")
        assert f"<td>{name}</td>" in (tmp_path / "out" / "report.html").read_text()
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped, res.records["m/a.obj"]["rule"]) == (0, 1, "tiny")


def test_an_up_to_date_auto_record_keeps_the_choice_its_build_recorded(tmp_path, monkeypatch):
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)  # (inputs just written: see the racily clean test)
    # an `auto` asset's why is the rule's and then auto's choice ("...; auto: vanilla has ..."): a rerun that
    # changed nothing took the rule's alone as changed, rewrote the manifest, scene and report, and dropped
    # the choice from the record; a renamed rule keeps it too
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    text = (
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out, report: true, scene: true, usd: true}\n"
        "rules: [{name: pick, encoding: auto}]\n"
    )
    cfg.write_text(text)
    assert run(cfg, echo=lambda m: None).built == 1
    out = tmp_path / "out"
    why = json.loads((out / "manifest.json").read_text())["assets"]["m/a.obj"]["why"]
    assert why.startswith("rule 'pick' matched (no match conditions); auto: ")
    names = ("manifest.json", "scene.usda", "report.html")
    files = {n: ((out / n).read_bytes(), (out / n).stat().st_mtime_ns) for n in names}
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped, res.records["m/a.obj"]["why"]) == (0, 1, why)
    assert {n: ((out / n).read_bytes(), (out / n).stat().st_mtime_ns) for n in names} == files
    cfg.write_text(text.replace("name: pick", "name: chosen"))
    res = run(cfg, echo=lambda m: None)
    rec = json.loads((out / "manifest.json").read_text())["assets"]["m/a.obj"]
    assert (res.built, rec["rule"]) == (0, "chosen")
    assert rec["why"] == why.replace("rule 'pick'", "rule 'chosen'")


def test_deleting_the_outputs_of_a_kind_no_longer_asked_for_rebuilds_nothing(tmp_path):
    # `usd: false`, then the .usdc layers deleted (the config no longer wants them): every asset was rebuilt,
    # its .swpm current, as a recorded output was missing; the record now drops it, and `usd: true` again
    # builds the layers
    (tmp_path / "m").mkdir()
    for name in ("a", "b"):
        (tmp_path / "m" / f"{name}.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    config = (
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out, usd: %s}\n"
        "defaults: {encoding: vanilla}\n"
    )
    cfg.write_text(config % "true")
    assert run(cfg, echo=lambda m: None).built == 2
    cfg.write_text(config % "false")
    (tmp_path / "out" / "a.usdc").unlink()
    (tmp_path / "out" / "b.usdc").write_text("edited")
    swpm = (tmp_path / "out" / "a.swpm").stat().st_mtime_ns
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped) == (0, 2)
    assert (tmp_path / "out" / "a.swpm").stat().st_mtime_ns == swpm
    assert {k: set(r["outputs"]) for k, r in res.records.items()} == {
        "m/a.obj": {"swpm"},
        "m/b.obj": {"swpm"},
    }
    assert (tmp_path / "out" / "b.usdc").read_text() == "edited"  # (not the run's: left alone)
    cfg.write_text(config % "true")
    res = run(cfg, echo=lambda m: None)
    assert res.built == 2 and all(set(r["outputs"]) == {"swpm", "usd"} for r in res.records.values())
    assert (tmp_path / "out" / "a.usdc").is_file()


def test_two_configs_sharing_an_output_dir_are_warned_of(tmp_path):
    # two configs writing in one output.dir take each other's assets as removed: each run rebuilt the other's
    # assets, and `--prune` deleted its outputs, without a word on why
    (tmp_path / "m").mkdir()
    for name in ("a", "b"):
        (tmp_path / "m" / f"{name}.obj").write_text(TWO_TRIANGLES)
        (tmp_path / f"{name}.yaml").write_text(
            f"version: 1\nassets: [{{glob: 'm/{name}.obj'}}]\noutput: {{dir: out}}\n"
            "defaults: {encoding: vanilla}\n"
        )
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    assert run(a, echo=lambda m: None).warnings == []
    expected = (
        f"out/manifest.json was written by a run of another config ({a}): 1 of its assets is not in {b} "
        "and taken as removed (outputs left unlisted, rebuilt by that config's next run); give each config "
        "its own output.dir"
    )
    assert run(b, dry_run=True, echo=lambda m: None).warnings == [expected]
    assert run(b, echo=lambda m: None).warnings == [expected]
    assert run(b, echo=lambda m: None).warnings == []  # (its own manifest now)
    # the config moved or renamed (the file it was is gone): not another config
    (tmp_path / "m" / "c.obj").write_text(TWO_TRIANGLES)
    b.rename(tmp_path / "c.yaml")
    (tmp_path / "c.yaml").write_text((tmp_path / "c.yaml").read_text().replace("m/b.obj", "m/c.obj"))
    res = run(tmp_path / "c.yaml", echo=lambda m: None)
    assert res.warnings == [] and sorted(res.unlisted) == ["a.swpm", "b.swpm"]


def test_a_copied_project_is_not_warned_of_as_sharing_its_output_dir(tmp_path):
    # the project copied with its output.dir (cp -r): the copy's manifest names the original config, still
    # there; an asset removed from the copy warned that another config shared its output.dir, which it does
    # not (the original writes in its own)
    proj = tmp_path / "proj"
    (proj / "m").mkdir(parents=True)
    for name in ("a", "b"):
        (proj / "m" / f"{name}.obj").write_text(TWO_TRIANGLES)
    (proj / "c.yaml").write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    assert run(proj / "c.yaml", echo=lambda m: None).built == 2
    shutil.copytree(proj, tmp_path / "copy")
    (tmp_path / "copy" / "m" / "b.obj").unlink()
    res = run(tmp_path / "copy" / "c.yaml", echo=lambda m: None)
    assert res.warnings == [] and res.unlisted == ["b.swpm"]
    # the original pointed at the copy's output.dir: it is another config writing there
    (proj / "c.yaml").write_text((proj / "c.yaml").read_text().replace("dir: out", "dir: ../copy/out"))
    shutil.copy(proj / "m" / "b.obj", tmp_path / "copy" / "m" / "b.obj")
    assert run(proj / "c.yaml", echo=lambda m: None).warnings == []  # (a superset: nothing lost)
    (tmp_path / "copy" / "m" / "b.obj").unlink()
    res = run(tmp_path / "copy" / "c.yaml", echo=lambda m: None)
    assert len(res.warnings) == 1
    assert res.warnings[0].startswith(
        f"out/manifest.json was written by a run of another config ({proj / 'c.yaml'})"
    )


def test_a_matched_link_to_another_matched_file_is_named_in_a_warning(tmp_path):
    # a mesh replaced by a link to another the glob matches (a library deduplicated by links) is one asset
    # with it: the link's asset, its outputs and its place in the scene went, without a word
    cfg = _vanilla_project(tmp_path)
    (tmp_path / "m" / "b.obj").symlink_to("a.obj")
    expected = [
        f"{cfg}:2:17: $.assets[0].glob: m/b.obj and m/a.obj are one file (a link to the other or to one "
        "file), one asset built as m/a.obj: m/b.obj has no outputs of its own (copy the file to build it "
        "apart)"
    ]
    assert run(cfg, dry_run=True, echo=lambda m: None).warnings == expected
    res = run(cfg, echo=lambda m: None)
    assert res.warnings == expected and list(res.records) == ["m/a.obj"]
    # the same file matched by two entries under one name is not a link: no warning
    cfg.write_text(cfg.read_text().replace("[{glob: 'm/*.obj'}]", "[{glob: 'm/a.obj'}, {glob: 'm/a.*'}]"))
    assert run(cfg, echo=lambda m: None).warnings == []


def test_matched_links_to_one_missing_file_fail_each_and_a_linked_folder_is_one_warning(tmp_path):
    # two dangling links to one missing file were one asset (the second left out, against "a link to a
    # missing file is an asset that fails"), and then named as "one file" with the first; a linked folder
    # doubling a library gave a warning for each of its files
    (tmp_path / "m").mkdir()
    for name in ("a", "b", "c", "d"):
        (tmp_path / "m" / f"{name}.obj").write_text(TWO_TRIANGLES + f"# {name}\n")
    (tmp_path / "m" / "x.obj").symlink_to("missing.obj")
    (tmp_path / "m" / "y.obj").symlink_to("missing.obj")
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: '*/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    res = run(cfg, echo=lambda m: None)
    assert res.warnings == [] and (res.built, res.failed) == (4, 2)
    assert all("file not found" in res.failures[f"m/{n}.obj"]["error"] for n in "xy")
    (tmp_path / "n").symlink_to("m")
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped, res.failed) == (0, 4, 2) and len(res.warnings) == 1
    assert res.warnings[0] == (
        f"{cfg}:2:17: $.assets[0].glob: 6 matched paths are each one file with another (a link to it or to "
        "one file, a linked folder), one asset built under the other's name, and have no outputs of their "
        "own: n/a.obj as m/a.obj, n/b.obj as m/b.obj, n/c.obj as m/c.obj, ... (copy a file to build it apart)"
    )


def test_a_dry_run_with_force_counts_no_asset_up_to_date(tmp_path):
    # `--dry-run --force` planned every asset "to build" and counted them `skipped` (up to date) in the
    # summary (`--json`)
    cfg = _vanilla_project(tmp_path)
    assert run(cfg, echo=lambda m: None).built == 1
    res = run(cfg, dry_run=True, echo=lambda m: None)
    assert res.skipped == 1 and [p["state"] for p in res.plan] == ["up to date"]
    res = run(cfg, dry_run=True, force=True, echo=lambda m: None)
    assert res.skipped == 0 and [p["state"] for p in res.plan] == ["to build"]
    r = CliRunner().invoke(main, ["run", str(cfg), "--dry-run", "--force", "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["skipped"] == 0


def test_a_manifest_that_does_not_read_is_named_in_a_warning(tmp_path):
    # a cut or hand-broken manifest.json was taken for none without a word: every asset built again (hours
    # of a studio's library) and the outputs it recorded forgotten (never listed or pruned)
    cfg = _vanilla_project(tmp_path)
    assert run(cfg, echo=lambda m: None).built == 1
    manifest = tmp_path / "out" / "manifest.json"
    text = manifest.read_text()
    tail = "; the run takes it for no manifest: every asset is built again, and the outputs it recorded are "
    tail += "no longer known (not pruned)"
    for broken, why in [
        (text[:40], "it does not read (JSONDecodeError: "),
        ("[]", "it is a list, not an object"),
        ('{"assets": 1}', "its assets is a number, not an object"),
    ]:
        manifest.write_text(broken)
        (warning,) = run(cfg, dry_run=True, echo=lambda m: None).warnings
        assert warning.startswith(f"out/manifest.json: {why}") and warning.endswith(tail), warning
    res = run(cfg, echo=lambda m: None)
    assert res.built == 1 and len(res.warnings) == 1
    assert run(cfg, echo=lambda m: None).warnings == []
    manifest.unlink()  # (none at all: no warning)
    assert run(cfg, echo=lambda m: None).warnings == []


def test_a_stage_that_is_a_link_in_a_loop_is_a_config_error(tmp_path):
    # resolving the stage's path raised out of the run (a RuntimeError's traceback) instead of a located error
    (tmp_path / "a.usda").symlink_to("b.usda")
    (tmp_path / "b.usda").symlink_to("a.usda")
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{stage: a.usda}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    )
    with pytest.raises(ConfigError) as exc:
        run(cfg, dry_run=True, echo=lambda m: None)
    (problem,) = exc.value.problems
    assert problem.startswith(f"{cfg}:2:18: $.assets[0].stage: cannot open stage a.usda: Symlink loop")
    r = CliRunner().invoke(main, ["run", str(cfg)])
    assert r.exit_code == 2 and "Traceback" not in r.output


def test_a_stage_given_as_a_link_keeps_its_assets_names_as_it_is_pointed_elsewhere(tmp_path):
    # the stage's path was resolved before naming its prims' assets: `scene.usda -> versions/v1.usda` gave
    # ids `versions/v1.usda:/World/m` and outputs `v1__World_m.*`, so pointing the link at v2 renamed every
    # asset (all rebuilt, the old outputs unlisted, the scene's prims renamed), and a rule's `path:
    # scene.usda` never matched; a glob's link keeps its own name
    from pxr import Usd, UsdGeom

    (tmp_path / "versions").mkdir()
    for version, x in (("v1", 1.0), ("v2", 2.0)):
        st = Usd.Stage.CreateNew(str(tmp_path / "versions" / f"{version}.usda"))
        m = UsdGeom.Mesh.Define(st, "/World/m")
        m.CreatePointsAttr([(0, 0, 0), (x, 0, 0), (0, 1, 0), (x, 1, 0)])
        m.CreateFaceVertexCountsAttr([3, 3])
        m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
        st.GetRootLayer().Save()
    (tmp_path / "scene.usda").symlink_to("versions/v1.usda")
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{stage: scene.usda}]\noutput: {dir: out, usd: true, scene: true}\n"
        "defaults: {encoding: vanilla}\nrules: [{name: s, match: {path: scene.usda}, encoding: skip-strip}]\n"
    )
    res = run(cfg, echo=lambda m: None)
    assert (
        res.built_ids == ["scene.usda:/World/m"]
        and res.records["scene.usda:/World/m"]["encoding"] == "skip-strip"
    )
    assert (tmp_path / "out" / "scene__World_m.usdc").is_file()
    assert run(cfg, echo=lambda m: None).skipped == 1
    (tmp_path / "scene.usda").unlink()
    (tmp_path / "scene.usda").symlink_to("versions/v2.usda")
    res = run(cfg, echo=lambda m: None)
    assert res.built_ids == ["scene.usda:/World/m"] and res.unlisted == []
    stage = Usd.Stage.Open(str(tmp_path / "out" / "scene.usda"))
    assert [p.GetName() for p in stage.GetPrimAtPath("/Scene").GetChildren()] == ["scene__World_m"]


def test_outputs_whose_names_differ_only_in_case_are_a_collision(tmp_path):
    # m/Rock.obj and m/rock.obj wrote out/Rock.swpm and out/rock.swpm: one file on a case-insensitive
    # filesystem (macOS, Windows), where the second build replaced the first and the manifest listed both.
    # It is reported as two assets writing one name are (exit 2, before anything is built); so is a name
    # that differs only in its Unicode normalization (macOS compares "café" composed and decomposed alike)
    cfg = _vanilla_project(tmp_path, "Rock", "rock")
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=lambda m: None)
    assert exc.value.problems == [
        f"{cfg}:2:10: $.assets[0]: m/rock.obj and m/Rock.obj would both write rock.swpm on a "
        "case-insensitive filesystem (macOS, Windows): rock.swpm and Rock.swpm differ only in case; "
        "rename one"
    ]
    assert not (tmp_path / "out").exists()
    result = CliRunner().invoke(main, ["run", str(cfg), "--json"])
    assert result.exit_code == 2 and "differ only in case" in json.loads(result.stdout)["problems"][0]
    (tmp_path / "m" / "rock.obj").unlink()
    (tmp_path / "m" / "caf\u00e9.obj").write_text(TWO_TRIANGLES)
    (tmp_path / "m" / "cafe\u0301.obj").write_text(TWO_TRIANGLES)
    with pytest.raises(ConfigError, match="differ only in Unicode normalization") as exc:
        run(cfg, echo=lambda m: None)
    assert len(exc.value.problems) == 1
    (tmp_path / "m" / "cafe\u0301.obj").unlink()
    assert run(cfg, echo=lambda m: None).built == 2  # (Rock.obj and café.obj: no collision)


def test_a_collision_by_unicode_normalization_alone_is_not_called_a_case_difference(tmp_path):
    # café.obj composed and decomposed write café.swpm twice on macOS: the names have one case, and the
    # message said they "differ only in case" (both shown alike): it names what differs
    cfg = _vanilla_project(tmp_path, "caf\u00e9", "cafe\u0301")
    with pytest.raises(ConfigError) as exc:
        run(cfg, echo=lambda m: None)
    (problem,) = exc.value.problems
    assert "differ only in Unicode normalization" in problem and "differ only in case" not in problem
    assert "m/caf\u00e9.obj" in problem and "m/cafe\u0301.obj" in problem


def _quad_stage(path: Path) -> None:
    from pxr import Usd, UsdGeom

    st = Usd.Stage.CreateNew(str(path))
    m = UsdGeom.Mesh.Define(st, "/Quad")
    m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)])
    m.CreateFaceVertexCountsAttr([3, 3])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
    st.GetRootLayer().Save()


def test_an_input_named_like_a_temporary_file_but_for_case_is_refused(tmp_path):
    # the temporary-file names were matched case-sensitively: on a case-insensitive filesystem an input
    # out/.B.TMP.USDA is the .b.tmp.usda the run deletes (or a scene's temporary file it writes)
    for name in (".B.TMP.USDA", ".Quad.Tmp.usdc"):
        d = tmp_path / name.strip(".")
        (d / "out").mkdir(parents=True)
        _quad_stage(d / "quad.usda")
        from pxr import Sdf

        suffix = Path(name).suffix.lower()
        stage = d / "out" / name
        Sdf.Layer.FindOrOpen(str(d / "quad.usda")).Export(
            str(stage), args={"format": "usdc" if suffix != ".usda" else "usda"}
        )
        before = _digest(stage)
        cfg = d / "c.yaml"
        cfg.write_text(
            f"version: 1\nassets: [{{stage: 'out/{name}'}}]\noutput: {{dir: out}}\n"
            "defaults: {encoding: vanilla}\n"
        )
        with pytest.raises(ConfigError, match="is named like a temporary file the run deletes"):
            run(cfg, echo=lambda m: None)
        assert _digest(stage) == before and not (d / "out" / "manifest.json").exists(), name


def test_the_folded_name_refusal_is_the_configs_alone_not_the_history_of_the_outputs(tmp_path):
    # an output not yet written was compared with the inputs by folded name, one written by an earlier run
    # by inode alone: on a case-sensitive filesystem a stage out/Scene.usda was refused by a first run and
    # allowed once an earlier run had written out/scene.usda (other inodes), which a case-insensitive one
    # then wrote over
    from pxr import Sdf

    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}"
    tail = "]\noutput: {dir: out, usd: true, scene: true}\ndefaults: {encoding: vanilla}\n"
    cfg.write_text(head + tail)
    assert run(cfg, echo=lambda m: None).built == 1
    assert (tmp_path / "out" / "scene.usda").is_file()
    _quad_stage(tmp_path / "quad.usda")
    Sdf.Layer.FindOrOpen(str(tmp_path / "quad.usda")).Export(str(tmp_path / "out" / "Scene.usda"))
    written = _files_as_written(tmp_path / "out")
    cfg.write_text(head + ", {stage: out/Scene.usda}" + tail)
    with pytest.raises(ConfigError, match="the scene layer would overwrite out/Scene.usda"):
        run(cfg, echo=lambda m: None)
    assert _files_as_written(tmp_path / "out") == written
    # and as a first run does (no scene.usda yet)
    (tmp_path / "out" / "scene.usda").unlink()
    with pytest.raises(ConfigError, match="the scene layer would overwrite out/Scene.usda"):
        run(cfg, echo=lambda m: None)


def test_a_rerun_with_nothing_to_do_leaves_the_lock_file_as_it_was_and_still_excludes(tmp_path, monkeypatch):
    # every run truncated the lock file and wrote its pid in it, a no-change rerun too (which writes nothing
    # else in output.dir): its pid is written once the run writes there, the lock taken as before
    from swpm_usd.errors import OutputLockedError
    from swpm_usd.pipeline import inputs, runner

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("sliding-window", "vanilla"))
    out = tmp_path / "out"
    lock = out / runner.LOCK
    assert run(cfg, echo=lambda m: None).built == 1
    assert lock.read_text() == f"{os.getpid()}\n"  # (a run that writes: its pid, for a run it stops)
    lock.write_text("999999999\n")  # (an ended run's)
    written = _files_as_written(out)
    refused = []
    real_plan = runner.plan

    def plan_and_try(*args, **kwargs):  # a second run while the first holds the lock
        with pytest.raises(OutputLockedError) as err:
            runner._OutputLock(out, print).acquire()
        refused.append(err.value.pid)
        return real_plan(*args, **kwargs)

    monkeypatch.setattr(runner, "plan", plan_and_try)
    for _ in range(2):
        res = run(cfg, echo=lambda m: None)
        assert (res.built, res.skipped) == (0, 1)
        assert _files_as_written(out) == written and lock.read_text() == "999999999\n"
    # (excluded; the ended run's pid not shown, the holder's, this process's, where the kernel lists it)
    assert refused == [os.getpid() if _KERNEL_LISTS_LOCKS else None] * 2 and _lock_is_free(lock)
    # a run that writes (here the report, deleted) writes its pid
    (out / "report.html").unlink()
    assert run(cfg, echo=lambda m: None).skipped == 1 and refused[-1] == refused[0]
    assert lock.read_text() == f"{os.getpid()}\n" and _lock_is_free(lock)


def _scene_open_here_and_an_asset_added(tmp_path: Path, monkeypatch):
    """A project of cow built with ``scene: true``, its scene.usda open in this process, then spot added:
    (the config, output.dir, the open layer)."""
    from pxr import Sdf

    monkeypatch.setattr("swpm_usd.pipeline.inputs._RACY_NS", 0)
    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("dir: out", "{dir: out, usd: true, scene: true}"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    opened = Sdf.Layer.FindOrOpen(str(out / "scene.usda"))  # (open in this process)
    shutil.copy(SHARED_MESHES / "spot.obj", tmp_path / "meshes" / "spot.obj")
    return cfg, out, opened


def _failing_reload(self, force=False):
    """``Sdf.Layer.Reload`` failing as usd-core does (a real error: "cannot use empty identifier")."""
    from pxr import Sdf

    Sdf.Layer.CreateNew("")


def test_a_scene_written_whose_open_layer_does_not_reload_is_recorded_before_the_error(tmp_path, monkeypatch):
    # scene.usda renamed into place, then the layer of its name open in this process failing to reload: the
    # error was raised at once, the manifest written by the run's stop() without the scene (on disk, new,
    # unrecorded: never pruned, rewritten by the next run) and this run's report never written. The scene is
    # recorded as written, the report and the manifest written, and the error raised after them
    from pxr import Sdf

    from swpm_usd.usd.writer import LayerReloadError

    cfg, out, opened = _scene_open_here_and_an_asset_added(tmp_path, monkeypatch)
    assert [p.name for p in opened.GetPrimAtPath("/Scene").nameChildren] == ["cow"]
    with monkeypatch.context() as m, pytest.raises(LayerReloadError) as err:
        m.setattr(Sdf.Layer, "Reload", _failing_reload)
        run(cfg, echo=lambda m: None)
    assert err.value.path == str(out / "scene.usda")
    manifest = json.loads((out / "manifest.json").read_text())
    assert sorted(manifest["assets"]) == ["meshes/cow.obj", "meshes/spot.obj"]
    recorded = manifest["run_outputs"]
    # the scene on disk is the new one, with both assets, and the manifest records it as it is
    assert recorded["scene"]["sha256"] == sha256_of(out / "scene.usda")
    scene = Sdf.Layer.OpenAsAnonymous(str(out / "scene.usda"))
    assert sorted(p.name for p in scene.GetPrimAtPath("/Scene").nameChildren) == ["cow", "spot"]
    # this run's report, written and recorded
    assert recorded["report"]["sha256"] == sha256_of(out / "report.html")
    assert "meshes/spot.obj" in (out / "report.html").read_text()
    assert all(o.get("current") for o in recorded.values())
    # so a rerun has nothing to do, and writes nothing
    written = _files_as_written(out)
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped) == (0, 2) and _files_as_written(out) == written
    # and the error held (as a caller may keep it), the scene is written again in this process: the error
    # does not keep the temporary layer alive, which usd-core then refused to create anew
    (out / "scene.usda").unlink()
    assert run(cfg, echo=lambda m: None).skipped == 2 and err.value.path == str(out / "scene.usda")
    assert Sdf.Layer.OpenAsAnonymous(str(out / "scene.usda")) is not None


def test_a_report_that_fails_after_the_scene_did_not_reload_says_both(tmp_path, monkeypatch):
    # the scene's reload error is raised once the report and the manifest are written: a report that then
    # failed was raised alone, and the reload's error (the layer open in this process is stale) was lost
    from pxr import Sdf

    from swpm_usd.pipeline import report

    cfg, out, opened = _scene_open_here_and_an_asset_added(tmp_path, monkeypatch)
    assert opened is not None

    def failing_report(path, manifest, because=None):
        raise OSError(28, "No space left on device", str(path))

    with monkeypatch.context() as m, pytest.raises(OSError) as err:
        m.setattr(Sdf.Layer, "Reload", _failing_reload)
        m.setattr(report, "write_report", failing_report)
        run(cfg, echo=lambda m: None)
    assert "No space left on device" in str(err.value)
    notes = getattr(err.value, "__notes__", [])
    assert len(notes) == 1 and notes[0].startswith("before it: LayerReloadError: "), notes
    assert str(out / "scene.usda") in notes[0]


def test_a_manifest_whose_report_record_names_no_config_has_the_report_written_once(tmp_path, monkeypatch):
    # a manifest of the version before the report's record held the config it names: read as it is, the
    # report written once (no asset rebuilt, no input read), its record given the config; then nothing
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("sliding-window", "vanilla"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    text = (out / "manifest.json").read_text()
    older = text.replace(f',\n   "config": {json.dumps(str(cfg))}', "")
    assert older != text and json.loads(text)["run_outputs"]["report"]["config"] == str(cfg)
    (out / "manifest.json").write_text(older)
    assert json.loads(older)["run_outputs"]["report"]["current"]  # (still the records' mark)
    written = _files_as_written(out)
    reads = _input_reads(monkeypatch, tmp_path / "meshes")
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.skipped) == (0, 1) and reads == []
    now = _files_as_written(out)
    assert now["cow.swpm"] == written["cow.swpm"] and now["report.html"] != written["report.html"]
    assert json.loads((out / "manifest.json").read_text())["run_outputs"]["report"]["config"] == str(cfg)
    assert run(cfg, echo=lambda m: None).skipped == 1 and _files_as_written(out) == now


def _quads_over_a_sublayer(d: Path, prims: int) -> Path:
    """d/stage/scene.usda: ``prims`` quads over the sublayer d/stage/sub.usda; the config of the stage."""
    from pxr import Sdf, Usd, UsdGeom

    (d / "stage").mkdir(parents=True)
    sub = Sdf.Layer.CreateNew(str(d / "stage" / "sub.usda"))
    Sdf.CreatePrimInLayer(sub, "/World/extra")
    sub.Save()
    st = Usd.Stage.CreateNew(str(d / "stage" / "scene.usda"))
    st.GetRootLayer().subLayerPaths = ["./sub.usda"]
    for i in range(prims):
        m = UsdGeom.Mesh.Define(st, f"/World/q{i}")
        m.CreatePointsAttr([(0, 0, i), (1, 0, i), (0, 1, i), (1, 1, i)])
        m.CreateFaceVertexCountsAttr([3, 3])
        m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
    st.GetRootLayer().Save()
    cfg = d / "pipeline.yaml"
    cfg.write_text("version: 1\nassets: [{stage: stage/scene.usda}]\noutput: {dir: out}\n")
    return cfg


def test_a_rerun_stats_a_stage_s_layers_once_not_once_a_prim(tmp_path, monkeypatch):
    # a no-change rerun checked the recorded stat of every layer of a stage for each of its prims (and
    # looked each up again to guard the inputs from the outputs): 1,000 prims of a 51-layer stage, 51,000
    # stats of 51 files. A stage's layer list is checked once a run; the result is the same, an edited
    # layer rebuilding every prim
    from swpm_usd.pipeline import inputs

    monkeypatch.setattr(inputs, "_RACY_NS", 0)
    stats = {}
    for prims in (1, 8):
        cfg = _quads_over_a_sublayer(tmp_path / str(prims), prims)
        assert run(cfg, echo=lambda m: None).built == prims
        assert run(cfg, echo=lambda m: None).skipped == prims  # (settled)
        sub = str(tmp_path / str(prims) / "stage" / "sub.usda")
        seen = []
        real_stat = os.stat

        def counting(path, *args, real_stat=real_stat, sub=sub, seen=seen, **kwargs):
            if os.fspath(path) == sub:
                seen.append(path)
            return real_stat(path, *args, **kwargs)

        with monkeypatch.context() as m:
            m.setattr(os, "stat", counting)
            res = run(cfg, echo=lambda m: None)
        assert (res.built, res.skipped) == (0, prims)
        stats[prims] = len(seen)
    assert stats[8] == stats[1] and stats[1] >= 1, stats
    # the layer edited (its stat moved): hashed, every prim rebuilt
    sub = tmp_path / "8" / "stage" / "sub.usda"
    sub.write_text(sub.read_text().replace("extra", "other"))
    res = run(tmp_path / "8" / "pipeline.yaml", echo=lambda m: None)
    assert res.built == 8


@pytest.mark.skipif(not _KERNEL_LISTS_LOCKS, reason="the holder of a lock is known from /proc/locks (Linux)")
def test_a_run_refused_while_another_plans_or_has_nothing_to_do_names_that_one(tmp_path, monkeypatch):
    # a run writes its pid in the lock file once it writes in output.dir: a run refused while another planned
    # or reran with nothing to do read the pid of the last run that wrote, and named it when a process had
    # it: here this process, which wrote last (a notebook that ran the pipeline), named as the holder by the
    # run it started itself. The holder is the kernel's (/proc/locks), and the lock file still as it was
    from swpm_usd.errors import OutputLockedError
    from swpm_usd.pipeline import inputs, runner

    monkeypatch.setattr(inputs, "_RACY_NS", 0)  # (and in the other process: a rerun that writes nothing)
    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("sliding-window", "vanilla"))
    out = tmp_path / "out"
    assert run(cfg, echo=lambda m: None).built == 1
    lock = out / runner.LOCK
    assert lock.read_text() == f"{os.getpid()}\n"
    before = _files_as_written(out)
    racy = "from swpm_usd.pipeline import inputs\ninputs._RACY_NS = 0\n"
    with _run_held_in(tmp_path, cfg, "plan", racy) as (first, release):  # (planning)
        with pytest.raises(OutputLockedError) as err:
            run(cfg, echo=lambda m: None)
        release.touch()
        assert first.wait(timeout=FIRST_ASSET_S) == 0, first.stderr.read().decode()
    assert err.value.pid == first.pid, (err.value.pid, first.pid, os.getpid())
    assert f"another swpm-pipeline run (pid {first.pid}) is writing" in str(err.value)
    assert _files_as_written(out) == before and lock.read_text() == f"{os.getpid()}\n"  # (nothing to do)


def test_the_holder_of_the_lock_as_the_kernel_lists_it(tmp_path, monkeypatch):
    # /proc/locks numbers a file by the device of the filesystem that holds it: on an overlayfs (a container)
    # or a btrfs subvolume another device than stat's, where the one lock of the inode is the holder's
    from swpm_usd.pipeline import lock as output_lock

    lock = tmp_path / "lock"
    lock.write_text("")
    fd = os.open(lock, os.O_RDONLY)
    try:
        st = os.fstat(fd)
        ours = f"{os.major(st.st_dev):02x}:{os.minor(st.st_dev):02x}:{st.st_ino}"
        other = f"{os.major(st.st_dev) + 1:02x}:{os.minor(st.st_dev):02x}:{st.st_ino}"
        listed = tmp_path / "locks"
        monkeypatch.setattr("swpm_usd.pipeline.lock._PROC_LOCKS", str(listed))
        for lines, holder in (
            ([f"1: FLOCK  ADVISORY  WRITE 4117 {ours} 0 EOF"], 4117),
            ([f"1: FLOCK  ADVISORY  WRITE 4117 {other} 0 EOF"], 4117),  # (another device: the one lock)
            (
                [
                    f"1: FLOCK  ADVISORY  WRITE 7 {other} 0 EOF",
                    f"2: FLOCK  ADVISORY  WRITE 4117 {ours} 0 EOF",
                ],
                4117,
            ),
            (
                [
                    f"1: FLOCK  ADVISORY  WRITE 7 {other} 0 EOF",
                    f"2: FLOCK  ADVISORY  WRITE 8 {os.major(st.st_dev) + 2:02x}:00:{st.st_ino} 0 EOF",
                ],
                None,
            ),  # (two files of that inode elsewhere: which is not known)
            (
                [f"1: -> FLOCK  ADVISORY  WRITE 9 {ours} 0 EOF", f"1: POSIX  ADVISORY  WRITE 5 {ours} 0 EOF"],
                None,
            ),
            (
                [f"1: FLOCK  ADVISORY  WRITE 4117 {ours[:-1]}{int(ours[-1]) ^ 1} 0 EOF"],
                None,
            ),  # (another inode)
            ([], None),
        ):
            listed.write_text("".join(f"{line}\n" for line in lines))
            assert output_lock._lock_holder(fd) == holder, lines
        listed.unlink()  # (no list: not Linux)
        assert output_lock._lock_holder(fd) is None
    finally:
        os.close(fd)


def test_a_lock_file_the_disk_cannot_take_the_pid_of_is_no_raw_error(tmp_path, monkeypatch):
    # the pid a run writes in the lock file once it writes in output.dir only names it to a run it refuses
    # (the kernel's list of locks names it too): a full disk there raised a bare OSError out of `run`
    # before any output was attempted; the run goes on, and its own writes report the disk
    import errno

    from swpm_usd.pipeline import runner

    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("sliding-window", "vanilla"))
    real_pwrite = os.pwrite

    def full(fd, data, offset):
        if os.path.basename(os.readlink(f"/proc/self/fd/{fd}")) == runner.LOCK:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_pwrite(fd, data, offset)

    monkeypatch.setattr(os, "pwrite", full)
    res = run(cfg, echo=lambda m: None)
    assert res.built == 1 and res.failed == 0
    assert (tmp_path / "out" / runner.LOCK).read_text() == ""  # (no pid: the write failed)


def test_a_run_whose_own_files_cannot_be_written_is_an_error_not_a_traceback(tmp_path, monkeypatch):
    # a full disk (or no permission) writing the run's report: `swpm-pipeline run` printed a traceback
    # (OSError out of click); it is one line naming the file, exit 1, and --json says it too
    import errno

    from swpm_usd.pipeline import report

    cfg = _project(tmp_path, ("cow.obj",), MINIMAL.replace("sliding-window", "vanilla"))

    def full(path, manifest, because=None):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(report, "write_report", full)
    for args in ([], ["--json"]):
        r = CliRunner().invoke(main, ["run", str(cfg), "--force", *args])
        assert r.exit_code == 1 and not isinstance(r.exception, OSError), (r.exception, r.output)
        where = tmp_path / "out" / "report.html"
        assert f"error: {where}: No space left on device" in r.stderr, r.stderr
        assert "Traceback" not in r.output + r.stderr
        if args:
            assert json.loads(r.stdout)["error"] == f"{where}: No space left on device"


def test_limits_max_triangles_fails_an_asset_over_it_and_builds_the_others(tmp_path):
    """``limits.max_triangles``: the asset over it fails with the loader's message naming the file, the count
    and the budget; the others are built; a budget lowered under an asset built before fails it on the next
    run (its record is not taken as current)."""
    cfg = _project(tmp_path, ("spot.obj", "suzanne.obj"))
    head = "version: 1\nassets: [{glob: 'meshes/*'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    cfg.write_text(head)
    assert run(cfg, echo=lambda m: None).built == 2
    cfg.write_text(head + "limits: {max_triangles: 1000}\n")  # suzanne: 968 triangles, spot: 5856
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1, res.failures
    err = res.failures["meshes/spot.obj"]["error"]
    assert "spot.obj" in err and "5856 triangles" in err and "max_triangles=1000" in err
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]
    assert "max_triangles=1000" in manifest["meshes/spot.obj"]["last_failure"]["error"]  # (its build kept)
    assert manifest["meshes/suzanne.obj"]["status"] == "built"
    (tmp_path / "meshes" / "cow.obj").write_bytes((SHARED_MESHES / "cow.obj").read_bytes())  # never built
    res = run(cfg, echo=lambda m: None)
    assert sorted(res.failures) == ["meshes/cow.obj", "meshes/spot.obj"] and res.built == 0
    assert "max_triangles=1000" in res.failures["meshes/cow.obj"]["error"]
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]
    assert manifest["meshes/cow.obj"]["status"] == "failed"
    assert _config_problems(cfg, head + "limits: {max_triangles: -1}\n")


def test_progress_line_of_a_failed_asset_keeps_its_cause_under_a_deep_folder(tmp_path, capsys):
    """The progress line keeps 100 characters of a failure; the error names the asset's file by its absolute
    path, which a studio's nested folders make longer than that: the line showed the path and no cause."""
    deep = Path("meshes", *["a folder of props, rocks and stones"] * 4)
    (tmp_path / deep).mkdir(parents=True)
    (tmp_path / deep / "broken.obj").write_bytes(b"")
    shutil.copy(SHARED_MESHES / "suzanne.obj", tmp_path / deep / "suzanne.obj")
    cfg = tmp_path / "pipeline.yaml"
    config = MINIMAL.replace("meshes/*.obj", "meshes/**/*.obj")
    cfg.write_text(config.replace("dir: out", "{dir: out, report: false}"))
    capsys.readouterr()
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and res.built == 1
    lines = [ln for ln in capsys.readouterr().err.splitlines() if "broken.obj: FAILED" in ln]
    assert len(lines) == 1, lines
    # the asset is named once (its id, relative), and the cause follows
    assert "MeshLoadError: no triangles: the file is empty (0 bytes)" in lines[0]
    assert str(tmp_path) not in lines[0]


def test_plain_text_failed_lines_carry_the_problem_code(tmp_path):
    """--json and the manifest give a failed asset's ``code``; the plain-text progress and summary lines gave
    English alone, so a studio's log of thousands of assets could not be grepped by cause: both now bracket
    the code after FAILED, the same code --json gives."""
    cfg = _project(
        tmp_path, meshes=("suzanne.obj",), config=MINIMAL.replace("dir: out", "{dir: out, report: false}")
    )
    (tmp_path / "meshes" / "empty.obj").write_bytes(b"")
    (tmp_path / "meshes" / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 x 1\nf 1 2 3\n")
    r = CliRunner().invoke(main, ["run", str(cfg)])
    assert r.exit_code == 1
    lines = r.stderr.splitlines()
    r = CliRunner().invoke(main, ["run", str(cfg), "--json"])  # (the failures retried: the same codes)
    codes = {f["id"]: f["code"] for f in json.loads(r.stdout)["failures"]}
    assert codes == {"meshes/empty.obj": "INPUT_EMPTY", "meshes/bad.obj": "INPUT_MALFORMED"}, codes
    for rid, code in codes.items():
        summary = [ln for ln in lines if ln.startswith(f"FAILED [{code}] {rid}: ")]
        progress = [ln for ln in lines if f"{rid}: FAILED [{code}] (" in ln]
        assert len(summary) == 1 and len(progress) == 1, (rid, code, lines)


def test_bench_scale_edits_an_input_without_breaking_it(tmp_path):
    """bench_pipeline's scale section times a rerun after editing 1 % of the inputs: each edit must change the
    file's bytes and leave its mesh readable (a trailing byte made binary PLY and STL fail, not rebuild)."""
    import importlib.util

    from swpm_usd.io import load_mesh

    spec = importlib.util.spec_from_file_location(
        "bench_pipeline", Path(swpm_usd.__file__).resolve().parents[1] / "benchmarks" / "bench_pipeline.py"
    )
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    good = bench._scale_assets(tmp_path, 12)
    assert {p.suffix for p in good} == {".obj", ".ply", ".stl", ".glb", ".gltf", ".usda"}
    for p in good:
        before, triangles = p.read_bytes(), len(load_mesh(p).triangles)
        bench._edit_input(p)
        assert p.read_bytes() != before, p
        assert len(load_mesh(p).triangles) == triangles, p


#: :data:`swpm_usd.pipeline.worker.WARM_ENCODINGS_ENV`
WARM_ENCODINGS_ENV = "SWPM_USD_WARM_ENCODINGS"


def _forkserver_start(monkeypatch, tasks: list[dict]) -> tuple[str | None, list[str]]:
    """(the encodings the fork server is told to warm, the modules it preloads) when :func:`runner.execute`
    starts it for ``tasks`` (stopped there: no server started)."""
    import multiprocessing.forkserver as forkserver

    from swpm_usd.pipeline import runner

    seen: dict[str, object] = {}

    class Started(Exception):
        pass

    def ensure_running() -> None:
        seen["env"] = os.environ.get(WARM_ENCODINGS_ENV)
        raise Started

    monkeypatch.setattr(forkserver, "set_forkserver_preload", lambda names: seen.update(preload=list(names)))
    monkeypatch.setattr(forkserver, "ensure_running", ensure_running)
    monkeypatch.setattr(runner, "_SERVER_GIVEN", {})  # (a server of an earlier test: not this run's sets)
    with pytest.raises(Started):
        next(runner.execute(tasks, 2, "local", None))
    assert WARM_ENCODINGS_ENV not in os.environ  # (set for the server's start alone)
    return seen["env"], seen["preload"]


def test_the_fork_server_warms_the_pending_tasks_encodings_and_preloads_usd_when_used(monkeypatch):
    # a rerun whose only tasks were a few broken assets (retried) had the server warm every encoding, and
    # each worker of a run writing USD imported usd-core itself (the server had not)
    task = {"path": "a.obj", "encoding": "vanilla", "write_usd": False, "config_data": None}
    # (and trimesh, scipy's import, for an OBJ, PLY, STL, OFF or glTF: each worker imported it on its first)
    trimesh = ["trimesh", "swpm_usd.io.trimesh_loader"]
    assert _forkserver_start(monkeypatch, [task, {**task, "path": "b.ply"}]) == (
        "vanilla",
        ["swpm_usd.pipeline._warm", *trimesh],
    )
    env, preload = _forkserver_start(monkeypatch, [{**task, "write_usd": True}])
    assert env == "vanilla" and "swpm_usd.usd.writer" in preload and "trimesh" in preload
    env, preload = _forkserver_start(monkeypatch, [{**task, "path": "a.usda", "encoding": "skip-strip"}])
    assert env == "skip-strip" and "swpm_usd.io.usd_loader" in preload
    assert "trimesh" not in preload  # (a run of USD assets alone does not import it)
    assert "trimesh" not in _forkserver_start(monkeypatch, [{**task, "failed_loading": True}])[1]
    # a rule left to the worker (on triangles): any rule's encoding or the defaults'; auto: its candidates
    rules = {"rules": [{"encoding": "skip-strip"}, {"encoding": "vanilla"}]}
    rules["defaults"] = {"encoding": "mixed"}
    env, _ = _forkserver_start(monkeypatch, [{**task, "encoding": None, "config_data": rules}])
    assert env == "skip-strip,vanilla,mixed"
    env, _ = _forkserver_start(monkeypatch, [{**task, "encoding": "auto"}])
    assert set(env.split(",")) == set(BUILDERS)
    # a broken input retried (it failed to load, and is the same file): nothing to warm for it
    broken = {**task, "write_usd": True, "failed_loading": True}
    assert _forkserver_start(monkeypatch, [broken]) == ("", ["swpm_usd.pipeline._warm"])
    # nothing pending: no server
    monkeypatch.setattr("multiprocessing.forkserver.ensure_running", lambda: pytest.fail("started"))
    from swpm_usd.pipeline import runner

    assert list(runner.execute([], 2, "local", None)) == []


def test_the_warm_up_builds_the_encodings_it_is_given_alone(monkeypatch):
    from swpm_usd.pipeline import _warm

    build_module = sys.modules["swpm_usd.build"]  # (swpm_usd.build is the function of that name)

    built: list[str] = []
    real = build_module.build
    monkeypatch.setattr(build_module, "build", lambda m, enc, **kw: (built.append(enc), real(m, enc))[1])
    monkeypatch.setattr(_warm, "WARMED", [])
    _warm.warm(["skip-strip", "not-an-encoding"])
    assert built == ["skip-strip"] and _warm.WARMED == ["skip-strip"]
    monkeypatch.setenv("SWPM_USD_WARM_ENCODINGS", "")
    _warm.warm()
    assert built == ["skip-strip"]  # (none named: none built)
    monkeypatch.setenv("SWPM_USD_WARM_ENCODINGS", "vanilla,mixed")
    _warm.warm()
    assert built == ["skip-strip", "vanilla", "mixed"]
    # every encoding warmed whole: skip-strip's strip read as a triangle list ended the warm-up before mixed
    monkeypatch.delenv("SWPM_USD_WARM_ENCODINGS")
    _warm.WARMED.clear()
    _warm.warm()
    assert _warm.WARMED == list(BUILDERS)


def test_a_failure_that_fails_again_the_same_way_rewrites_nothing(tmp_path, monkeypatch):
    # retried, as the README promises (and reported failed), but its record, and so the manifest, the
    # scene and the report, are as they were: a rerun of 500 assets with 10 broken rewrote all three
    from swpm_usd.pipeline import inputs, runner

    monkeypatch.setattr(inputs, "_RACY_NS", 0)  # (inputs just written: see the racily clean test)
    (tmp_path / "m").mkdir()
    for name in ("a", "b"):
        (tmp_path / "m" / f"{name}.obj").write_text(TWO_TRIANGLES + f"# {name}\n")
    (tmp_path / "m" / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 9\n")
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*.obj'}]\ndefaults: {encoding: vanilla}\n"
        "output: {dir: out, usd: true, scene: true}\n"
    )
    out = tmp_path / "out"
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.failed) == (2, 1)
    first = _files_written(out)
    tried = []
    real = runner.process_asset
    monkeypatch.setattr(runner, "process_asset", lambda t: (tried.append(t["id"]), real(t))[1])
    res = run(cfg, echo=lambda m: None)
    assert tried == ["m/broken.obj"] and res.failed == 1 and "vertex" in res.failures["m/broken.obj"]["error"]
    assert (res.built, res.skipped) == (0, 2)
    assert _files_written(out) == first  # nothing written
    # a build kept after a failure (its input broken since): the second failure the same, nothing written
    (tmp_path / "m" / "a.obj").write_text("v 0 0 0\nf 1 1 1\n")
    res = run(cfg, echo=lambda m: None)
    assert res.failures["m/a.obj"]["kept_previous"] and _files_written(out) != first
    first = _files_written(out)
    tried.clear()
    res = run(cfg, echo=lambda m: None)
    assert sorted(tried) == ["m/a.obj", "m/broken.obj"] and res.failed == 2 and _files_written(out) == first
    # another failure: its record changes, so the manifest and report (the scene: its layers are the same)
    (tmp_path / "m" / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 2
    now = _files_written(out)
    assert now["manifest.json"] != first["manifest.json"] and now["report.html"] != first["report.html"]
    manifest = json.loads((out / "manifest.json").read_text())
    assert "7" in manifest["assets"]["m/broken.obj"]["error"]
    first = now
    assert run(cfg, echo=lambda m: None).failed == 2 and _files_written(out) == first


def test_a_dry_run_counts_triangles_from_what_the_files_tell_before_their_geometry(tmp_path, monkeypatch):
    # a dry run loaded every new asset to count its triangles (1,000 assets: one after another); it takes
    # the count the loaders check max_triangles by early, and says how each count is known
    import trimesh

    import swpm_usd.io as io

    (tmp_path / "m").mkdir()
    shutil.copy(SHARED_MESHES / "suzanne.obj", tmp_path / "m" / "s.obj")
    sphere = trimesh.creation.icosphere(subdivisions=1)  # 80 triangles
    sphere.export(tmp_path / "m" / "b.stl")
    sphere.export(tmp_path / "m" / "c.glb")
    sphere.export(tmp_path / "m" / "d.ply")
    (tmp_path / "m" / "e.usda").write_text(
        '#usda 1.0\ndef Mesh "m"\n{\n    int[] faceVertexCounts = [3, 4]\n'
        "    int[] faceVertexIndices = [0, 1, 2, 0, 2, 3, 1]\n"
        "    point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]\n}\n"
    )
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    cfg.write_text(head + "rules:\n  - {name: tiny, match: {triangles: {max: 100}}, encoding: skip-strip}\n")
    loaded: list[str] = []
    real = io.load_mesh
    monkeypatch.setattr(io, "load_mesh", lambda p, **kw: (loaded.append(Path(p).name), real(p, **kw))[1])
    lines: list[str] = []
    res = run(cfg, dry_run=True, echo=lines.append)
    assert loaded == ["d.ply"]  # (a PLY's header tells no lower bound)
    got = {p["id"]: (p["triangles"], p["triangles_count"], p["encoding"]) for p in res.plan}
    assert got == {
        "m/b.stl": (80, "declared before cleaning", "skip-strip"),
        "m/c.glb": (80, "declared before cleaning", "skip-strip"),
        "m/d.ply": (80, "exact", "skip-strip"),
        "m/e.usda": (3, "declared before cleaning", "skip-strip"),
        "m/s.obj": (500, "lower bound", "vanilla"),  # (500 face lines: 968 triangles)
    }
    shown = {ln.split(":")[0]: ln for ln in lines}
    assert "triangles>=500 (at least" in shown["m/s.obj"]
    assert "triangles=80 (declared, before cleaning)" in shown["m/b.stl"]
    assert "triangles=80 " in shown["m/d.ply"]
    # no rule on triangles: none counted, and the plan says why
    cfg.write_text(head)
    loaded.clear()
    res = run(cfg, dry_run=True, echo=lines.append)
    assert loaded == [] and {p["triangles_count"] for p in res.plan} == {"not needed"}
    assert "triangles=? (not needed: no rule on triangles)" in lines[-1]


def test_a_triangle_budget_set_since_is_checked_on_the_count_before_cleaning(tmp_path):
    # limits.max_triangles counts a file's triangles before cleaning; a build recorded before the budget was
    # compared by its cleaned count, so a file over it only by duplicate triangles stayed current
    (tmp_path / "m").mkdir()
    faces = "f 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n"
    (tmp_path / "m" / "t.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n" + faces * 2)  # 8, 4 kept
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*.obj'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    cfg.write_text(head)
    assert run(cfg, echo=lambda m: None).built == 1
    cfg.write_text(head + "limits: {max_triangles: 6}\n")
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 1 and "max_triangles=6" in res.failures["m/t.obj"]["error"], res.failures
    record = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]["m/t.obj"]
    assert (record["triangles_in"], record["triangles_read"]) == (4, 8)  # (the build kept)
    cfg.write_text(head + "limits: {max_triangles: 8}\n")
    assert run(cfg, echo=lambda m: None).skipped == 1
    # a record of a version before the count: built again (and counted)
    path = tmp_path / "out" / "manifest.json"
    manifest = json.loads(path.read_text())
    del manifest["assets"]["m/t.obj"]["triangles_read"]
    path.write_text(json.dumps(manifest))
    assert run(cfg, echo=lambda m: None).built == 1
    assert json.loads(path.read_text())["assets"]["m/t.obj"]["triangles_read"] == 8


def test_bench_cli_rusage_fails_on_a_run_that_did_not_end_as_expected(tmp_path):
    """bench_pipeline's scale section read the exit status of none of its runs: a run that failed outright
    (a usage error, a crash) was timed as one that did the work."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "bench_pipeline", Path(swpm_usd.__file__).resolve().parents[1] / "benchmarks" / "bench_pipeline.py"
    )
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    with pytest.raises(RuntimeError, match="exited with code 2"):
        bench._cli_rusage(["run", str(tmp_path / "missing.yaml"), "--json"], tmp_path)


def test_a_dry_run_routes_by_an_objs_lower_bound_only_where_no_rule_above_it_matches_otherwise(
    tmp_path, monkeypatch
):
    # suzanne.obj: 500 face lines, 967 triangles once cleaned. Under `max: 600` its lower bound (500) named
    # rule tiny, which the run, counting 967, did not use: the dry run's plan was another encoding. The file
    # loaded after its face lines were counted is read once, not once for each (the count's bytes loaded)
    import swpm_usd.io.trimesh_loader as loader

    (tmp_path / "m").mkdir()
    shutil.copy(SHARED_MESHES / "suzanne.obj", tmp_path / "m" / "s.obj")
    cfg = tmp_path / "c.yaml"
    head = "version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
    loaded: list[str] = []
    read: list[str] = []
    real, real_read = loader.load_trimesh, Path.read_bytes
    monkeypatch.setattr(
        loader, "load_trimesh", lambda p, **kw: (loaded.append(Path(p).name), real(p, **kw))[1]
    )
    monkeypatch.setattr(Path, "read_bytes", lambda p: (read.append(p.name), real_read(p))[1])
    for bounds, encoding, count in (
        ("{max: 600}", "vanilla", (967, "exact")),  # (loaded: 500 is under the max, 967 is not)
        ("{min: 600}", "skip-strip", (967, "exact")),  # (a min above the bound: loaded too)
        ("{max: 100}", "vanilla", (500, "lower bound")),  # (over the max at 500: over it at any count up)
        ("{min: 400}", "skip-strip", (500, "lower bound")),
    ):
        rule = f"{{name: tiny, match: {{triangles: {bounds}}}, encoding: skip-strip}}"
        cfg.write_text(head + f"rules:\n  - {rule}\n")
        loaded.clear()
        read.clear()
        (plan,) = run(cfg, dry_run=True, echo=lambda m: None).plan
        assert (plan["encoding"], (plan["triangles"], plan["triangles_count"])) == (encoding, count), bounds
        assert loaded == ([] if count[1] == "lower bound" else ["s.obj"]), bounds
        assert read.count("s.obj") == 1, (bounds, read)


def test_a_dry_run_holds_one_objs_bytes_at_a_time(tmp_path):
    # the dry run keeps an OBJ's bytes its face lines were counted from, to load them when that lower bound
    # does not settle its rule: they were kept past it, so the next OBJ was read with them still held (a
    # folder of large scans planned at twice the memory of the largest)
    import tracemalloc

    (tmp_path / "m").mkdir()
    size = 16 * 2**20
    for name in ("a", "b", "c"):
        # (a comment of 16 MB: one face line, a lower bound of 1 that no rule above it matches)
        body = b"# " + b"x" * size + b"\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
        (tmp_path / "m" / f"{name}.obj").write_bytes(body)
    cfg = tmp_path / "c.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'm/*'}]\noutput: {dir: out}\ndefaults: {encoding: vanilla}\n"
        "rules:\n  - {name: none, match: {triangles: {max: 0}}, encoding: skip-strip}\n"
    )
    tracemalloc.start()
    try:
        plans = run(cfg, dry_run=True, echo=lambda m: None).plan
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert [(p["triangles"], p["triangles_count"]) for p in plans] == [(1, "lower bound")] * 3, plans
    assert peak < 1.5 * size, f"{peak / 2**20:.1f} MiB held for OBJs of 16 MiB"


def _fake_forkserver(monkeypatch) -> tuple[list[tuple[str | None, list[str]]], list[int]]:
    """:func:`runner.execute`'s fork server faked: (each start's warmed encodings and preloads, each stop)."""
    import multiprocessing.forkserver as forkserver

    from swpm_usd.pipeline import runner

    server = forkserver._forkserver
    started: list[tuple[str | None, list[str]]] = []
    stopped: list[int] = []
    preload: list[str] = []
    monkeypatch.setattr(server, "_forkserver_pid", None)  # (a real one, of another test, left alone)
    monkeypatch.setattr(runner, "_SERVER_GIVEN", {})

    def ensure_running() -> None:
        if server._forkserver_pid is None:
            started.append((os.environ.get(WARM_ENCODINGS_ENV), list(preload)))
            server._forkserver_pid = -len(started)  # (no process: never signalled, see stop)

    def stop() -> None:
        stopped.append(server._forkserver_pid)
        server._forkserver_pid = None

    monkeypatch.setattr(
        forkserver, "set_forkserver_preload", lambda names: preload.__setitem__(slice(None), names)
    )
    monkeypatch.setattr(forkserver, "ensure_running", ensure_running)
    monkeypatch.setattr(runner, "_stop_forkserver", stop)
    monkeypatch.setattr(runner, "_forkserver_ready", lambda ctx: None)
    monkeypatch.setattr(runner, "_local_pool", lambda *a: iter(()))
    return started, stopped


def test_a_fork_server_that_warmed_less_than_a_later_run_uses_is_started_again(monkeypatch):
    # the server outlives its run: one started for a rerun of broken inputs alone (nothing warmed, no
    # usd-core) served every later run of the process, whose workers then loaded their kernels each
    from swpm_usd.pipeline import runner

    started, stopped = _fake_forkserver(monkeypatch)
    task = {"path": "a.obj", "encoding": "vanilla", "write_usd": False, "config_data": None}
    warm = ["swpm_usd.pipeline._warm"]
    meshes = [*warm, "trimesh", "swpm_usd.io.trimesh_loader"]
    usd = [*meshes, "swpm_usd.usd.writer", "swpm_usd.io.usd_loader"]
    list(runner.execute([{**task, "failed_loading": True}], 2, "local", None))
    assert started == [("", warm)] and stopped == []
    list(runner.execute([task], 2, "local", None))  # (vanilla: not warmed by the first server)
    assert started[1:] == [("vanilla", meshes)] and stopped == [-1]
    list(runner.execute([task, {**task, "failed_loading": True}], 2, "local", None))  # (covered: kept)
    assert len(started) == 2 and stopped == [-1]
    list(runner.execute([{**task, "encoding": "mixed", "write_usd": True}], 2, "local", None))
    assert started[2:] == [("vanilla,mixed", usd)] and stopped == [-1, -2]


def test_a_fork_server_without_trimesh_is_not_started_again_for_it_alone(monkeypatch):
    # trimesh is preloaded for an OBJ, PLY, STL, OFF or glTF (~0.6 s a worker saved, in parallel: about
    # wall-neutral): a later run of the process with an OBJ stopped a server that had warmed its encodings
    # for USD assets alone, and waited for a new one's whole warm-up (seconds) to save that import
    from swpm_usd.pipeline import runner

    started, stopped = _fake_forkserver(monkeypatch)
    task = {"path": "a.usda", "encoding": "vanilla", "write_usd": True, "config_data": None}
    list(runner.execute([task], 2, "local", None))
    assert len(started) == 1 and "trimesh" not in started[0][1]
    list(runner.execute([{**task, "path": "b.obj"}], 2, "local", None))
    assert len(started) == 1 and stopped == [], started
    # started again for another reason (an encoding it did not warm): trimesh preloaded then too
    list(runner.execute([{**task, "path": "b.obj", "encoding": "mixed"}], 2, "local", None))
    assert stopped == [-1] and started[1][0] == "vanilla,mixed" and "trimesh" in started[1][1], started


@pytest.mark.parametrize("link", ["loop", "loop-under", "nothing"])
def test_an_output_dir_that_is_a_link_loop_or_to_nothing_is_a_config_error(tmp_path, link):
    # output.dir a link in a loop: a traceback (RuntimeError: Symlink loop from '.../manifest.json'), exit 1,
    # no JSON; a link to nothing: "cannot create ...: File exists"
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.obj").write_text(TWO_TRIANGLES)
    if link == "nothing":
        (tmp_path / "out").symlink_to("nowhere")
        says = f"{tmp_path / 'out'} is a link to nothing (to nowhere), not a folder"
        out = "out"
    else:
        (tmp_path / "out").symlink_to("round")
        (tmp_path / "round").symlink_to("out")
        out = "out" if link == "loop" else "out/deeper"
        under = "" if link == "loop" else f": its folder {tmp_path / 'out'}"
        says = f"{tmp_path / out}{under} is a link loop (to round), not a folder"
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"version: 1\nassets: [{{glob: 'm/*.obj'}}]\noutput: {{dir: {out}}}\n")
    r = CliRunner().invoke(main, ["run", str(cfg), "--json"])
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output
    assert json.loads(r.stdout)["problems"] == [f"{cfg}:3:15: $.output.dir: {says}"]


def test_a_report_s_plots_label_their_axis_ends(tmp_path, monkeypatch):
    # report.html's plots had no values on their axes: a curve's shape, but not its triangles, error or ACMR
    from swpm_usd.pipeline import report

    manifest = _report_manifest(tmp_path, monkeypatch)
    report.write_report(tmp_path / "report.html", manifest)
    text = (tmp_path / "report.html").read_text()
    curve = manifest["assets"]["m/a.obj"]["summary"]["curve"]
    tri, err = [c["triangles"] for c in curve], [c["error"] for c in curve]
    card = text[text.index("<h3>m/a.obj") :]
    errors_svg = card[card.index("<svg") : card.index("</svg>")]
    labels = re.findall(r"<text [^>]*>([^<]*)</text>", errors_svg)
    assert labels == [f"{max(err):.3g}", f"{min(err):.3g}", str(min(tri)), str(max(tri))]
    assert report._tick(69451.0) == "69451" and report._tick(0.000123456) == "0.000123"
    assert report._tick(float("nan")) == "?" and report._tick(2.5e6) == "2.5e+06"
