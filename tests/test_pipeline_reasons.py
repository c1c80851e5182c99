"""Why the pipeline builds an asset again: each reason's code in the plan (``--json``'s ``because``), its
text on the plan line, the run's counts and the report; and that the reasons explain the decision without
changing it (an asset is to build exactly when it has reasons)."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner
from conftest import SHARED_MESHES

from swpm_usd.cli import main
from swpm_usd.pipeline import run
from swpm_usd.pipeline.config import load_config
from swpm_usd.pipeline.manifest import _read_manifest
from swpm_usd.pipeline.reasons import REASONS, shown
from swpm_usd.pipeline.runner import plan


def _config(
    defaults: str = "encoding: vanilla",
    output: str = "",
    extra: str = "",
    instances: int = 1,
) -> str:
    return (
        "version: 1\n"
        f'assets:\n  - glob: "meshes/*.obj"\n    instances: {instances}\n'
        f"output:\n  dir: out\n  report: false\n{output}"
        f"defaults:\n  {defaults}\n{extra}"
    )


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    """A project of two copies of suzanne (``a.obj``, ``b.obj``), built with vanilla."""
    root = tmp_path_factory.mktemp("built")
    (root / "meshes").mkdir()
    for name in ("a.obj", "b.obj"):
        shutil.copy(SHARED_MESHES / "suzanne.obj", root / "meshes" / name)
    (root / "pipeline.yaml").write_text(_config())
    res = run(root / "pipeline.yaml", echo=lambda m: None)
    assert (res.built, res.failed) == (2, 0), res.failures
    return root


@pytest.fixture
def project(built: Path, tmp_path: Path) -> Path:
    """A copy of the built project (its config at ``pipeline.yaml``)."""
    shutil.copytree(built, tmp_path / "p")
    return tmp_path / "p" / "pipeline.yaml"


def _dry(cfg: Path, **kw) -> tuple[dict[str, list[dict]], dict[str, str]]:
    """A dry run's plan: asset id -> its ``because``, and asset id -> its plan line; each plan entry checked
    to be to build exactly when it has reasons (``--force`` aside), and its line to show them."""
    lines: list[str] = []
    res = run(cfg, dry_run=True, echo=lines.append, **kw)
    by_id = {}
    text = {}
    for entry in res.plan:
        aid, because = entry["id"], entry["because"]
        assert all(r["code"] in REASONS and isinstance(r["detail"], str) for r in because)
        assert [r["code"] for r in because] == sorted((r["code"] for r in because), key=REASONS.index), (
            because
        )  # (in the fixed order)
        if not kw.get("force"):
            assert (entry["state"] == "to build") == bool(because), entry
        (line,) = [x for x in lines if x.startswith(f"{aid}: ")]
        assert f"[{entry['state']}]" in line
        if because:
            assert line.endswith(f"; because: {shown(because)}"), line
        else:
            assert "because" not in line, line
        by_id[aid], text[aid] = because, line
    return by_id, text


def _codes(because: list[dict]) -> list[str]:
    return [r["code"] for r in because]


def _edit_manifest(cfg: Path, edit) -> None:
    path = cfg.parent / "out" / "manifest.json"
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data, indent=1))


def test_a_new_project_is_new_and_a_built_one_has_no_reasons(tmp_path, project):
    (tmp_path / "q" / "meshes").mkdir(parents=True)
    shutil.copy(SHARED_MESHES / "suzanne.obj", tmp_path / "q" / "meshes" / "a.obj")
    (tmp_path / "q" / "pipeline.yaml").write_text(_config())
    because, text = _dry(tmp_path / "q" / "pipeline.yaml")
    assert because == {"meshes/a.obj": [{"code": "new", "detail": "no record"}]}
    assert "[to build]" in text["meshes/a.obj"] and text["meshes/a.obj"].endswith(
        "; because: new (no record)"
    )
    # built: up to date, no reasons; a new asset beside them is new, the others untouched
    assert _dry(project)[0] == {"meshes/a.obj": [], "meshes/b.obj": []}
    shutil.copy(SHARED_MESHES / "suzanne.obj", project.parent / "meshes" / "c.obj")
    because, _ = _dry(project)
    assert because == {
        "meshes/a.obj": [],
        "meshes/b.obj": [],
        "meshes/c.obj": [{"code": "new", "detail": "no record"}],
    }


def test_an_input_edited_names_the_file(project):
    with open(project.parent / "meshes" / "a.obj", "a") as f:
        f.write("# edited\n")
    because, text = _dry(project)
    assert because["meshes/a.obj"] == [{"code": "inputs-changed", "detail": "meshes/a.obj"}]
    assert because["meshes/b.obj"] == []
    assert text["meshes/a.obj"].endswith(
        "[to build] triangles=? (not needed: no rule on triangles) instances=1; "
        "no rule matched: defaults; because: inputs changed (meshes/a.obj)"
    )
    # touched alone (its bytes the same): hashed, up to date, no reason
    b = project.parent / "meshes" / "b.obj"
    b.write_bytes(b.read_bytes())
    assert _dry(project)[0]["meshes/b.obj"] == []


def test_params_and_encoding_changed_name_what_moved(project):
    # a default written out is no change
    project.write_text(_config("encoding: vanilla\n  params: {seam_weight: 2.0, boundary_weight: 8}"))
    assert _dry(project)[0] == {"meshes/a.obj": [], "meshes/b.obj": []}
    project.write_text(_config("encoding: vanilla\n  params: {seam_weight: 3}"))
    because, text = _dry(project)
    assert because["meshes/a.obj"] == [{"code": "treatment-changed", "detail": "seam_weight 2.0 -> 3.0"}]
    assert text["meshes/b.obj"].endswith("; because: treatment changed (seam_weight 2.0 -> 3.0)")
    project.write_text(_config("encoding: skip-strip"))
    because, _ = _dry(project)
    assert because["meshes/b.obj"] == [
        {"code": "treatment-changed", "detail": "encoding vanilla -> skip-strip"}
    ]
    # another rule giving the same treatment is no change; one giving another says the rule moved too
    rules = "rules:\n  - name: hero\n    match: {path: meshes/a.obj}\n    encoding: {enc}\n"
    project.write_text(_config(extra=rules.replace("{enc}", "vanilla")))
    assert _dry(project)[0] == {"meshes/a.obj": [], "meshes/b.obj": []}
    project.write_text(_config(extra=rules.replace("{enc}", "skip-strip")))
    because, _ = _dry(project)
    assert because["meshes/a.obj"] == [
        {"code": "treatment-changed", "detail": "encoding vanilla -> skip-strip, rule defaults -> 'hero'"}
    ]
    assert because["meshes/b.obj"] == []


def test_another_tool_version_alone_rebuilds_nothing(project, monkeypatch):
    # a release that changes no output bumps no build version (build_version.py): nothing is to build
    from swpm_usd.pipeline import runner

    monkeypatch.setattr(runner, "__version__", "99.0.0")
    because, _ = _dry(project)
    assert because == {"meshes/a.obj": [], "meshes/b.obj": []}


@pytest.mark.parametrize(("part", "rebuilt"), [("vanilla", True), ("sliding-window", False), ("base", True)])
def test_a_build_version_bumped_rebuilds_the_assets_it_changes(project, monkeypatch, part, rebuilt):
    from swpm_usd.pipeline.build_version import BUILD_VERSIONS

    then = BUILD_VERSIONS[part]
    monkeypatch.setitem(BUILD_VERSIONS, part, "99.0.0")
    because, _ = _dry(project)
    expected = [{"code": "version-changed", "detail": f"{part} {then} -> 99.0.0"}] if rebuilt else []
    assert because == {"meshes/a.obj": expected, "meshes/b.obj": expected}
    if rebuilt:  # with a parameter changed too: both (the record's digest reproduced with its build version)
        project.write_text(_config("encoding: vanilla\n  params: {seam_weight: 3}"))
        assert _codes(_dry(project)[0]["meshes/a.obj"]) == ["treatment-changed", "version-changed"]
        res = run(project, echo=lambda m: None)
        assert (res.built, res.failed) == (2, 0), res.failures
        assert _dry(project)[0] == {"meshes/a.obj": [], "meshes/b.obj": []}


def test_a_record_of_a_tool_before_build_versions_is_rebuilt_once(project):
    # its digest held the tool's version (0.9.1 and before): rebuilt, saying from which version
    from swpm_usd.pipeline.assets import Asset, treatment_digest

    def edit(data):
        data["tool_version"] = "0.9.1"
        for key, rec in data["assets"].items():
            asset = Asset(key, project.parent / key, None, 1, ())
            treatment = {"encoding": "vanilla", "params": {}}
            rec["digest"] = treatment_digest(rec["input_digest"], asset, treatment, "0.9.1", None)
            del rec["build_version"]

    _edit_manifest(project, edit)
    because, _ = _dry(project)
    (entry,) = because["meshes/a.obj"]
    assert entry["code"] == "version-changed" and entry["detail"].startswith("0.9.1 -> base ")
    res = run(project, echo=lambda m: None)
    assert (res.built, res.failed) == (2, 0), res.failures
    assert _dry(project)[0] == {"meshes/a.obj": [], "meshes/b.obj": []}


def test_a_digest_not_reproduced_is_said_so(project):
    def edit(data):
        data["assets"]["meshes/a.obj"]["digest"] = "0" * 64

    _edit_manifest(project, edit)
    because, _ = _dry(project)
    assert _codes(because["meshes/a.obj"]) == ["digest-changed"]
    assert because["meshes/b.obj"] == []


def test_a_record_ignored_is_new_with_why(project):
    def edit(data):
        data["assets"]["meshes/a.obj"]["outputs"]["swpm"]["size"] = "big"

    _edit_manifest(project, edit)
    because, _ = _dry(project)
    ((code, detail),) = [(r["code"], r["detail"]) for r in because["meshes/a.obj"]]
    assert code == "new" and detail == "its record is ignored: outputs.swpm.size is 'big', not a whole number"


def test_outputs_deleted_edited_and_wanted(project):
    out = project.parent / "out"
    (out / "a.swpm").unlink()
    data = bytearray((out / "b.swpm").read_bytes())
    data[-1] ^= 1
    (out / "b.swpm").write_bytes(bytes(data))
    because, _ = _dry(project)
    assert because["meshes/a.obj"] == [{"code": "output-missing", "detail": "out/a.swpm"}]
    assert because["meshes/b.obj"] == [{"code": "output-changed", "detail": "out/b.swpm"}]
    # usd: true added: the layers wanted; with a parameter changed too, the missing .swpm still named
    project.write_text(_config("encoding: vanilla\n  params: {seam_weight: 3}", output="  usd: true\n"))
    because, _ = _dry(project)
    assert _codes(because["meshes/a.obj"]) == ["treatment-changed", "output-wanted", "output-missing"]
    assert because["meshes/b.obj"][1:] == [{"code": "output-wanted", "detail": "usd"}]  # (edited: not hashed)


def test_legacy_layout_flipped(project):
    project.write_text(_config(output="  legacy_layout: true\n"))
    because, text = _dry(project)
    assert because["meshes/a.obj"] == [{"code": "layout-changed", "detail": "legacy_layout false -> true"}]
    assert text["meshes/a.obj"].endswith("because: layout changed (legacy_layout false -> true)")
    project.write_text(_config(output="  legacy_layout: true\n").replace("report: false", "report: true"))
    res = run(project, echo=lambda m: None)
    assert res.built_because == {"layout-changed": 2}
    report = (project.parent / "out" / "report.html").read_text()
    assert report.count(" legacy</td>") == 2 and "layout changed (legacy_layout false -&gt; true)" in report


def test_output_names_flipped(project):
    # (a glob from the config's folder: under output.names: path the outputs are named meshes--a.*)
    text = _config(output="  names: path\n").replace('glob: "meshes/*.obj"', 'glob: "*/*.obj"')
    project.write_text(text)
    because, line = _dry(project)
    assert because["meshes/a.obj"] == [{"code": "names-changed", "detail": "a.swpm -> meshes--a.swpm"}]
    assert line["meshes/a.obj"].endswith("because: names changed (a.swpm -> meshes--a.swpm)")
    res = run(project, echo=lambda m: None)
    assert res.built_because == {"names-changed": 2}
    assert (project.parent / "out" / "meshes--a.swpm").is_file()
    again, _ = _dry(project)
    assert again == {"meshes/a.obj": [], "meshes/b.obj": []}


def test_no_output_wanted(project):
    project.write_text(_config(output="  swpm: false\n  usd: false\n"))
    because, _ = _dry(project)
    assert because["meshes/a.obj"] == [{"code": "outputs-unwanted", "detail": "swpm"}]


def test_stricter_checks_and_budgets(project):
    rec = json.loads((project.parent / "out" / "manifest.json").read_text())["assets"]["meshes/a.obj"]
    g, i = rec["summary"]["global_bytes"], rec["summary"]["instance_bytes"]
    read = rec["triangles_read"]  # (counted before cleaning, as the limit counts them)
    project.write_text(_config(extra=f"budgets: {{global_bytes: {g - 1}}}\nlimits: {{max_triangles: 900}}\n"))
    because, _ = _dry(project)
    assert because["meshes/a.obj"] == [
        {"code": "checks-stricter", "detail": f"budgets.global_bytes (none) -> {g - 1}"},
        {"code": "over-triangle-budget", "detail": f"{read} > limits.max_triangles 900"},
    ]
    # a looser budget (one dropped, one raised) is no reason
    project.write_text(_config(extra=f"budgets: {{global_bytes: {g}}}\n"))
    run(project, echo=lambda m: None)  # (built: its record holds the budget it passed)
    project.write_text(_config(extra=f"budgets: {{global_bytes: {g + 10}}}\n"))
    assert _dry(project)[0] == {"meshes/a.obj": [], "meshes/b.obj": []}
    # more instances than budgets.total_bytes holds
    total = f"budgets: {{total_bytes: {g + 2 * i}}}\n"
    project.write_text(_config(extra=total))
    run(project, echo=lambda m: None)
    project.write_text(_config(extra=total, instances=3))
    because, _ = _dry(project)
    assert because["meshes/b.obj"] == [
        {
            "code": "over-total-bytes",
            "detail": f"{g} + 3 x {i} = {g + 3 * i} > budgets.total_bytes {g + 2 * i}",
        }
    ]


def test_auto_instances_and_checks(project):
    project.write_text(_config("encoding: auto", extra="budgets: {total_bytes: 100000000}\n"))
    res = run(project, echo=lambda m: None)
    assert res.built_because == {"treatment-changed": 2}
    project.write_text(_config("encoding: auto", extra="budgets: {total_bytes: 90000000}\n", instances=2))
    because, _ = _dry(project)
    assert because["meshes/a.obj"] == [
        {"code": "instances-changed", "detail": "1 -> 2"},
        {"code": "checks-changed", "detail": "budgets.total_bytes 100000000 -> 90000000"},
    ]
    project.write_text(
        _config(
            "encoding: auto\n  params: {select: misses-at-error}", extra="budgets: {total_bytes: 100000000}\n"
        )
    )
    assert _dry(project)[0]["meshes/a.obj"] == [
        {"code": "treatment-changed", "detail": 'select "acmr" -> "misses-at-error"'}
    ]


def test_a_failed_build_then_fixed(project):
    a = project.parent / "meshes" / "a.obj"
    a.write_text("v 0 0 0\nv 1 0 0\n")  # (no face: the build fails)
    res = run(project, echo=lambda m: None)
    assert res.failed == 1
    # its previous build kept: the rebuild failed, and its inputs are not those of the build kept
    because, _ = _dry(project)
    (failed, changed) = because["meshes/a.obj"]
    assert failed["code"] == "failed" and failed["detail"].startswith(
        f"[{res.failures['meshes/a.obj']['code']}] "
    )
    assert failed["detail"].endswith("; its previous build kept")
    assert changed == {"code": "inputs-changed", "detail": "meshes/a.obj"}
    shutil.copy(SHARED_MESHES / "suzanne.obj", a)  # (its bytes as built: the kept build is current again)
    assert _dry(project)[0]["meshes/a.obj"] == []
    # a new asset that fails, then is fixed: failed, and its inputs changed
    c = project.parent / "meshes" / "c.obj"
    c.write_text("v 0 0 0\n")
    run(project, echo=lambda m: None)
    assert _codes(_dry(project)[0]["meshes/c.obj"]) == ["failed"]
    # a parameter changed since: its record, of a build that failed before any encoding, cannot tell which
    project.write_text(_config("encoding: vanilla\n  params: {seam_weight: 3}"))
    (_, digest) = _dry(project)[0]["meshes/c.obj"]
    assert digest["code"] == "digest-changed" and "holds none to compare" in digest["detail"]
    project.write_text(_config())
    shutil.copy(SHARED_MESHES / "suzanne.obj", c)
    because, _ = _dry(project)
    assert because["meshes/c.obj"][1] == {"code": "inputs-changed", "detail": "meshes/c.obj"}
    assert _codes(because["meshes/c.obj"]) == ["failed", "inputs-changed"]


def test_force_is_a_reason_of_every_asset(project):
    with open(project.parent / "meshes" / "a.obj", "a") as f:
        f.write("# edited\n")
    because, text = _dry(project, force=True)
    assert _codes(because["meshes/a.obj"]) == ["forced", "inputs-changed"]
    assert because["meshes/b.obj"] == [{"code": "forced", "detail": "--force"}]
    assert "[to build]" in text["meshes/b.obj"] and text["meshes/b.obj"].endswith("because: forced (--force)")


def test_layer_without_units(project):
    project.write_text(_config(output="  usd: true\n"))
    run(project, echo=lambda m: None)
    layer = project.parent / "out" / "a.usdc"
    layer.write_bytes(b"not a layer")

    def edit(data):  # (a record of 0.7.2, before the units were recorded, of a layer that does not read)
        rec = data["assets"]["meshes/a.obj"]["outputs"]["usd"]
        for k in ("up_axis", "meters_per_unit", "mtime_ns", "ctime_ns", "ino", "dev"):
            rec.pop(k, None)
        rec.update(size=layer.stat().st_size, sha256=hashlib.sha256(layer.read_bytes()).hexdigest())

    _edit_manifest(project, edit)
    because, _ = _dry(project)
    assert because["meshes/a.obj"] == [{"code": "layer-units", "detail": "out/a.usdc"}]


def test_a_rule_left_to_the_worker(project):
    # a rule on triangles, and a record without its count: a run (not a dry one) leaves the rule to the worker
    project.write_text(
        _config(extra="rules:\n  - name: small\n    match: {triangles: {max: 5000}}\n    encoding: vanilla\n")
    )

    def edit(data):
        del data["assets"]["meshes/a.obj"]["triangles_in"]

    _edit_manifest(project, edit)
    cfg = load_config(project)
    items, _, _ = plan(cfg, _read_manifest(project.parent / "out" / "manifest.json"), count_triangles=False)
    by_id = {it.asset.id: it for it in items}
    assert not by_id["meshes/a.obj"].up_to_date and by_id["meshes/a.obj"].rule_pending
    assert _codes(by_id["meshes/a.obj"].because) == ["rule-pending"]
    assert by_id["meshes/b.obj"].up_to_date and by_id["meshes/b.obj"].because == []


def test_the_run_counts_its_reasons_and_the_report_shows_them(project):
    with open(project.parent / "meshes" / "a.obj", "a") as f:
        f.write("# edited\n")
    shutil.copy(SHARED_MESHES / "suzanne.obj", project.parent / "meshes" / "c.obj")
    project.write_text(_config().replace("report: false", "report: true"))
    result = CliRunner().invoke(main, ["run", str(project), "--explain"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert [x for x in lines if x.startswith("meshes/c.obj: ")][0].endswith(
        "[to build] triangles=? (not needed: "
        "no rule on triangles) instances=1; no rule matched: defaults; because: new (no record)"
    )
    assert [x for x in lines if x.startswith("meshes/b.obj: ")][0].endswith("; no rule matched: defaults")
    assert "2 built (new 1, inputs changed 1), 1 up to date, 0 failed in " in result.output
    report = (project.parent / "out" / "report.html").read_text()
    assert "new (no record)" in report and "inputs changed (meshes/a.obj)" in report
    swpm = json.loads((project.parent / "out" / "manifest.json").read_text())["assets"]["meshes/c.obj"][
        "outputs"
    ]
    layout = f"W{swpm['swpm']['index_width']} O{swpm['swpm']['offset_width']}"
    assert report.count(f"<td>{layout}</td>") == 3  # (each asset's .swpm layout, as its record holds it)
    with open(project.parent / "meshes" / "b.obj", "a") as f:
        f.write("# edited\n")
    result = CliRunner().invoke(main, ["run", str(project), "--json"])
    summary = json.loads(result.stdout)
    assert summary["built_because"] == {"inputs-changed": 1} and summary["built_assets"] == ["meshes/b.obj"]
    result = CliRunner().invoke(main, ["run", str(project), "--dry-run", "--json"])
    plan_entries = json.loads(result.stdout)["plan"]
    assert [e["because"] for e in plan_entries] == [[], [], []]
    # a dry run's totals: what it would build and why (JSON and the last plain line)
    with open(project.parent / "meshes" / "a.obj", "a") as f:
        f.write("# edited\n")
    summary = json.loads(CliRunner().invoke(main, ["run", str(project), "--dry-run", "--json"]).stdout)
    assert (summary["would_build"], summary["would_build_because"]) == (1, {"inputs-changed": 1})
    plain = CliRunner().invoke(main, ["run", str(project), "--dry-run", "--force"]).output.splitlines()
    assert plain[-1] == "3 to build (forced 3, inputs changed 1), 0 up to date; dry run: nothing written"


def test_params_of_encodings_whose_build_resolves_more(tmp_path):
    # a sliding-window record holds order_passes and restart_index as the build chose them, a skip-strip
    # one its restart_index: the record's treatment is still told, not left as digest-changed
    (tmp_path / "meshes").mkdir()
    for name in ("a.obj", "b.obj"):
        shutil.copy(SHARED_MESHES / "suzanne.obj", tmp_path / "meshes" / name)
    rules = (
        "rules:\n  - name: a\n    match: {path: meshes/a.obj}\n"
        "    encoding: sliding-window\n    params: {A}\n"
        "  - name: b\n    match: {path: meshes/b.obj}\n    encoding: skip-strip\n    params: {B}\n"
    )
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(_config(extra=rules.replace("{A}", "{}").replace("{B}", "{}")))
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.failed) == (2, 0), res.failures
    recs = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]
    # (what makes the record's params not the config's)
    assert "restart_index" in recs["meshes/b.obj"]["params"]
    cfg.write_text(_config(extra=rules.replace("{A}", "{mu: 0.2}").replace("{B}", "{strip_window: 8}")))
    because, _ = _dry(cfg)
    assert because == {
        "meshes/a.obj": [{"code": "treatment-changed", "detail": "mu 0.1 -> 0.2"}],
        "meshes/b.obj": [{"code": "treatment-changed", "detail": "strip_window 4 -> 8"}],
    }


def test_a_stage_layer_changed_added_or_gone_is_named(tmp_path):
    from pxr import Usd, UsdGeom

    from swpm_usd.io import load_mesh

    mesh = load_mesh(SHARED_MESHES / "suzanne.obj")
    (tmp_path / "layers").mkdir()
    (tmp_path / "meshes").mkdir()
    stage = Usd.Stage.CreateNew(str(tmp_path / "layers" / "geo.usda"))
    prim = UsdGeom.Mesh.Define(stage, "/root/m")
    prim.GetPointsAttr().Set([tuple(map(float, p)) for p in mesh.points])
    prim.GetFaceVertexCountsAttr().Set([3] * len(mesh.triangles))
    prim.GetFaceVertexIndicesAttr().Set([int(i) for i in mesh.triangles.ravel()])
    stage.GetRootLayer().Save()
    (tmp_path / "layers" / "extra.usda").write_text('#usda 1.0\n(\n    doc = "an empty layer"\n)\n')
    main_layer = tmp_path / "meshes" / "main.usda"

    def sublayers(*names: str) -> None:
        listed = ", ".join(f"@../layers/{n}@" for n in names)
        main_layer.write_text(f"#usda 1.0\n(\n    subLayers = [{listed}]\n)\n")

    sublayers("geo.usda")
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(_config().replace("meshes/*.obj", "meshes/*.usda"))
    res = run(cfg, echo=lambda m: None)
    assert (res.built, res.failed) == (1, 0), res.failures
    aid = "meshes/main.usda"
    assert _dry(cfg)[0] == {aid: []}
    with open(tmp_path / "layers" / "geo.usda", "a") as f:
        f.write("\n")
    assert _dry(cfg)[0][aid] == [{"code": "inputs-changed", "detail": "layers/geo.usda"}]
    sublayers("geo.usda", "extra.usda")
    # (geo.usda too: its record is of the bytes before the line added, which a dry run records not)
    assert _dry(cfg)[0][aid] == [
        {"code": "inputs-changed", "detail": "layers/extra.usda added, meshes/main.usda, layers/geo.usda"}
    ]
    run(cfg, echo=lambda m: None)
    sublayers("geo.usda")
    assert _dry(cfg)[0][aid] == [
        {"code": "inputs-changed", "detail": "layers/extra.usda gone, meshes/main.usda"}
    ]


def test_canonical_treatments_are_looked_up_by_value_and_type():
    from swpm_usd.pipeline.assets import canonical_treatment
    from swpm_usd.pipeline.reasons import _canonical

    for params in ({"seam_weight": 1}, {"seam_weight": 1.0}, {"seam_weight": True}, {"seam_weight": [1]}, {}):
        t = {"encoding": "vanilla", "params": params}
        assert _canonical(t) == canonical_treatment(t)
        # (True == 1 == 1.0 in Python: a cache keyed by value alone would give one the other's canonical form)
        assert type(_canonical(t)["params"]["seam_weight"]) is type(
            canonical_treatment(t)["params"]["seam_weight"]
        )


def test_every_encoding_has_a_build_version_and_auto_takes_them_all():
    from swpm_usd.encodings import ENCODING_PARAMS
    from swpm_usd.pipeline.build_version import BUILD_VERSIONS, build_version

    assert set(BUILD_VERSIONS) == {"base", "auto", *ENCODING_PARAMS}
    auto = build_version({"encoding": "auto", "params": {}})
    assert all(f"{part} {v}" in auto for part, v in BUILD_VERSIONS.items())
    for encoding in ENCODING_PARAMS:
        parts = build_version({"encoding": encoding}).split(", ")
        assert parts == [f"base {BUILD_VERSIONS['base']}", f"{encoding} {BUILD_VERSIONS[encoding]}"]
