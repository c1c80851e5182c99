"""The command line's remaining warts from a studio walk-through (helper-248): a slow ``inspect``/``validate``
start, a dry run's Ctrl-C note, ``--prefix`` past the end, usd-core's raw warnings on a missing layer, a dry
run's ``? {}`` for a rule the path decides, and the direct skip-strip/mixed builds' unbounded cache size."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _square():
    import swpm_usd

    return swpm_usd.Mesh.from_arrays(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0.1]],
        [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
    )


@pytest.mark.parametrize("encoding", ["skip-strip", "mixed"])
@pytest.mark.parametrize("cache_size", [0, 1025, 10**9])
def test_direct_skip_strip_and_mixed_builds_bound_their_cache_size_as_build_does(encoding, cache_size):
    """``build()`` refused ``cache_size=10**9`` (the FIFO simulations allocate that many entries); the
    encoders called directly took it (and ran for minutes)."""
    import swpm_usd
    from swpm_usd.encode.mixed import build_mixed, build_mixed_mesh
    from swpm_usd.encode.skipstrip import build_skipstrip, build_skipstrip_mesh
    from swpm_usd.errors import BuildError
    from swpm_usd.simplify import collapse_sequence

    mesh = _square()
    direct_seq, direct_mesh = {
        "skip-strip": (build_skipstrip, build_skipstrip_mesh),
        "mixed": (build_mixed, build_mixed_mesh),
    }[encoding]
    with pytest.raises(BuildError) as via_build:
        swpm_usd.build(mesh, encoding=encoding, cache_size=cache_size)
    with pytest.raises(BuildError) as direct:
        direct_seq(collapse_sequence(mesh), cache_size=cache_size)
    assert str(direct.value) == str(via_build.value)
    with pytest.raises(BuildError) as direct:
        direct_mesh(mesh, cache_size=cache_size)
    assert str(direct.value) == str(via_build.value)
    assert ("at least 1" if cache_size < 1 else "at most 1024") in str(direct.value)


@pytest.mark.parametrize("dry_run", [True, False])
def test_a_dry_run_stopped_by_ctrl_c_does_not_say_it_recorded_anything(tmp_path, monkeypatch, dry_run):
    """A dry run interrupted said "the assets finished are recorded in the manifest, and a rerun builds the
    rest": it records nothing. A run's note is as it was."""
    from click.testing import CliRunner

    import swpm_usd.pipeline
    from swpm_usd.cli import main

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(swpm_usd.pipeline, "run", interrupted)
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text("inputs: []\n")
    r = CliRunner().invoke(main, ["run", str(cfg), *(["--dry-run"] if dry_run else [])])
    assert r.exit_code == 130, r.output
    if dry_run:
        assert r.stderr == "swpm-pipeline run: interrupted; a dry run builds and writes nothing\n"
        assert "recorded" not in r.stderr and "rerun" not in r.stderr
    else:
        assert r.stderr == (
            "swpm-pipeline run: interrupted; the assets finished are recorded in the manifest, and a rerun "
            "builds the rest\n"
        )
    assert r.stdout == ""


_BROKEN_PLY = b"ply\nformat ascii 1.0\nelement vertex 3\nend_header\n1 2\n"


@pytest.mark.parametrize(
    ("rules", "encoding", "params", "why"),
    [
        (  # the first rule that matches it checks its path alone: that rule, whatever its triangles
            "  - {name: plys, match: {path: '*.ply'}, encoding: skip-strip, params: {primitive: list}}\n"
            "  - {name: tiny, match: {triangles: {max: 100}}, encoding: mixed}\n",
            "skip-strip",
            {"primitive": "list"},
            "rule 'plys' matched (path) before any rule on triangles: the file did not load",
        ),
        (  # a rule on triangles whose path it fails does not decide; the defaults do
            "  - {name: tiny-objs, match: {path: '*.obj', triangles: {max: 100}}, encoding: mixed}\n",
            "vanilla",
            {},
            "no rule matched, whatever the triangles: defaults: the file did not load",
        ),
        (  # a rule on triangles first: the worker's, once it counts them (as it was)
            "  - {name: tiny, match: {triangles: {max: 100}}, encoding: mixed}\n"
            "  - {name: plys, match: {path: 'meshes/*.ply'}, encoding: skip-strip}\n",
            None,
            {},
            "rule chosen by the worker: the file did not load",
        ),
    ],
)
def test_a_dry_run_shows_the_rule_the_path_decides_for_a_file_that_does_not_load(
    tmp_path, rules, encoding, params, why
):
    """``run --dry-run`` showed ``? {}`` ("rule chosen by the worker") for an input that did not load even
    when the first rule it matches checks its path alone."""
    from swpm_usd.pipeline import run

    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "broken.ply").write_bytes(_BROKEN_PLY)
    (tmp_path / "meshes" / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'meshes/*'}]\noutput: {dir: out, report: false}\n"
        f"defaults: {{encoding: vanilla}}\nrules:\n{rules}"
    )
    lines: list[str] = []
    res = run(cfg, dry_run=True, echo=lines.append)
    entry = next(p for p in res.plan if p["id"] == "meshes/broken.ply")
    assert (entry["encoding"], entry["params"], entry["triangles_count"]) == (encoding, params, "unknown")
    assert entry["why"].startswith(why), entry["why"]
    shown = next(ln for ln in lines if ln.startswith("meshes/broken.ply: "))
    assert shown.startswith(f"meshes/broken.ply: {encoding or '?'} {json.dumps(params)} [to build] "), shown
    assert f"; {entry['why']}" in shown
    assert not (tmp_path / "out").exists()


def test_validate_prefix_past_the_end_of_the_file_says_so():
    """``validate ok.swpm --prefix N`` with N past the end was taken as the whole file without a word. It
    still checks the whole file (a script's one N for files of every size keeps working) and says so."""
    from click.testing import CliRunner

    from swpm_usd.cli import main

    path = str(ROOT / "spec" / "vectors" / "valid" / "minimal-vanilla.swpm")
    size = Path(path).stat().st_size
    for n in (size + 1, 1 << 60):
        r = CliRunner().invoke(main, ["validate", path, "--prefix", str(n)])
        assert r.exit_code == 0, r.output
        assert f"{size} of {size} bytes draw LODs" in r.stdout
        assert r.stderr == (
            f"note: --prefix {n} is past the end of {path} ({size} bytes): the whole file was checked\n"
        )
        r = CliRunner().invoke(main, ["validate", path, "--prefix", str(n), "--json"])
        assert r.exit_code == 0, r.output
        prefix = json.loads(r.stdout)["summary"]["prefix"]
        assert (prefix["bytes"], prefix["file_size"], prefix["requested_bytes"]) == (size, size, n)
    for n in (size, size - 12):  # (a prefix of the file: no note, no requested_bytes)
        r = CliRunner().invoke(main, ["validate", path, "--prefix", str(n)])
        assert r.exit_code == 0 and r.stderr == "", r.output
        r = CliRunner().invoke(main, ["validate", path, "--prefix", str(n), "--json"])
        assert "requested_bytes" not in json.loads(r.stdout)["summary"]["prefix"]


_SCENE_MISSING_LAYERS = """#usda 1.0
(
    defaultPrim = "World"
    metersPerUnit = 1
    upAxis = "Y"
    subLayers = [@./gone_sub.usda@]
)

def Xform "World"
{
    def "A" (
        prepend references = @./gone_a.usdc@
    )
    {
    }
    def "B" (
        prepend payload = @./gone_b.usdc@</Root>
    )
    {
    }
}
"""


@pytest.mark.parametrize("options", [[], ["--no-builtin"], ["--json"]])
def test_validate_a_stage_missing_a_layer_reports_it_coded_and_prints_nothing_of_usd_cores(tmp_path, options):
    """``validate scene.usda`` with a reference that does not resolve: usd-core's raw warnings ("Warning: in
    _ReportErrors at line 3326 of .../stage.cpp -- ...", its MissingReferenceValidator's) reached stderr
    beside the report, and with ``--no-builtin`` the stage was "valid". Each missing layer is now one
    SWPM_USD_LAYER_MISSING naming it, at the prim that names it; the report is the only output."""
    scene = tmp_path / "scene.usda"
    scene.write_text(_SCENE_MISSING_LAYERS)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])}
    proc = subprocess.run(
        [sys.executable, "-c", "from swpm_usd.cli import main; main()", "validate", str(scene), *options],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert proc.stderr == ""
    expected = {
        ("/", f"sublayer {tmp_path / 'gone_sub.usda'}: file not found"),
        ("/World/A", f"reference {tmp_path / 'gone_a.usdc'}: file not found"),
        ("/World/B", f"payload {tmp_path / 'gone_b.usdc'}: file not found"),
    }
    if "--json" in options:
        found = json.loads(proc.stdout)["findings"]
        ours = {
            (f["prim"], f["message"].split(" (usd-core: ")[0])
            for f in found
            if f["code"] == ("SWPM_USD_LAYER_MISSING")
        }
        assert ours == expected
    else:
        lines = [ln for ln in proc.stdout.splitlines() if " SWPM_USD_LAYER_MISSING " in ln]
        ours = {(ln.split()[2].rstrip(":"), ln.split(": ", 1)[1].split(" (usd-core: ")[0]) for ln in lines}
        assert ours == expected, proc.stdout
        assert proc.stdout.splitlines()[-1].startswith(f"{scene}: INVALID")
    if "--no-builtin" in options:
        assert len(proc.stdout.splitlines()) == 4, proc.stdout  # (ours alone: three, and the verdict)


def test_validate_stage_keeps_usd_cores_other_warnings(tmp_path):
    """Only the warnings a finding reports are dropped: another of usd-core's is printed as before."""
    from pxr import Tf

    from swpm_usd.usd.validate import _reported_warnings_trapped

    with Tf.DiagnosticTrap() as outer:
        with _reported_warnings_trapped():
            Tf.Warn("another warning")
        assert [str(w.commentary) for w in outer.GetWarnings()] == ["another warning"]
        outer.Clear()


_MODULES_AT_EXIT = (
    "import atexit, sys\n"
    "loaded = lambda: sorted(m for m in ('numba', 'swpm_usd.encode') if m in sys.modules)\n"
    "atexit.register(lambda: print(loaded(), file=sys.stderr))\n"
    "from swpm_usd.cli import main\n"
    "main()\n"
)


@pytest.mark.parametrize(
    ("vector", "loaded"),
    [
        ("skip-strip-strip.swpm", []),
        ("skip-strip-list.swpm", []),
        ("minimal-vanilla.swpm", []),
        ("sliding-window-offset32.swpm", ["numba"]),
    ],
)
@pytest.mark.parametrize("command", ["inspect", "validate"])
def test_inspect_and_validate_start_without_the_encoders(command, vector, loaded):
    """``inspect``/``validate`` of one file took 1.5 s: the reader imported the encoders (numba and every
    encoder module: 1.0 s) and the skip-strip check loaded two numba kernels (0.7 s) for a check of
    milliseconds. The encoders are imported by ``load`` alone, a skip-strip or vanilla file is checked with
    numpy (no numba at all), the other encodings' checks load numba when they run."""
    path = ROOT / "spec" / "vectors" / "valid" / vector
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])}
    proc = subprocess.run(
        [sys.executable, "-c", _MODULES_AT_EXIT, command, str(path)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stderr.strip() == repr(loaded), proc.stderr


def test_the_numpy_skip_strip_kernels_give_the_jitted_ones_results():
    """:mod:`swpm_usd.format.kernels_np` against :mod:`swpm_usd.format.kernels` on random level tables and
    records, consistent ones (kind 0: the triangle counts compared too) and broken ones (kinds 1 and 3)."""
    import numpy as np

    from swpm_usd.format import kernels as jitted
    from swpm_usd.format import kernels_np as plain

    rng = np.random.default_rng(248)
    kinds: dict[int, int] = {}
    for _ in range(600):
        n, nv = int(rng.integers(1, 5)), int(rng.integers(3, 12))
        lens = rng.integers(0, 12, n)
        lstart = np.concatenate(([0], np.cumsum(lens))).astype(np.int64)
        strip, restart = bool(rng.integers(0, 2)), int(rng.choice([-1, 65535]))
        lst = rng.integers(0, nv, int(lstart[-1])).astype(np.int64)
        if restart >= 0 and lst.size:
            lst[rng.random(lst.size) < 0.1] = restart
        rstart = np.concatenate(([0], np.cumsum(rng.integers(0, 4, n)))).astype(np.int64)
        R = int(rstart[-1])
        kept = rng.integers(0, nv, R).astype(np.int64)
        cc = rng.integers(0, 4, R).astype(np.int64)
        offs, slots = [], []
        for lv in range(n):
            if lens[lv] == 0:
                cc[rstart[lv] : rstart[lv + 1]] = 0
            for r in range(rstart[lv], rstart[lv + 1]):
                for _ in range(cc[r]):
                    offs.append(int(rng.integers(0, lens[lv])))
                    slots.append((int(lstart[lv]) + offs[-1], r))
        offsets = np.array(offs, np.int64)
        if rng.random() < 0.7:  # records that hold: a slot's first change finds its binned vertex (mostly)
            seen: set[int] = set()
            for s, r in slots:
                if s not in seen and rng.random() < 0.97:
                    lst[s] = nv - 1 - r
                seen.add(s)
            buf = lst.copy()
            for s, r in slots:
                buf[s] = kept[r]
            coll = buf.copy()
            if rng.random() < 0.2 and coll.size:
                coll[rng.integers(0, coll.size)] += 1
        else:
            coll = rng.integers(0, nv, lst.size).astype(np.int64)
        args = (lst, lstart, coll, rstart, kept, cc, offsets, nv, strip, restart)
        want, got = jitted.skip_replay(*args), plain.skip_replay_np(*args)
        assert tuple(int(x) for x in want[:3]) == got[:3], args
        if got[0] == 0:
            assert np.array_equal(want[3], got[3]), args
        kinds[got[0]] = kinds.get(got[0], 0) + 1
        limits = rng.integers(0, nv + 1, n).astype(np.int64)
        for exempt in (-1, 65535):
            want_seg = tuple(int(x) for x in jitted.segment_limits(lst, lstart, limits, exempt))
            assert plain.segment_limits(lst, lstart, limits, exempt) == want_seg
    assert kinds.get(0, 0) > 100 and kinds.get(1, 0) > 20 and kinds.get(3, 0) > 20, kinds


def test_every_vector_reads_the_same_with_the_numpy_kernels(monkeypatch):
    """Each vector's report (problems, offsets, summary) with the numpy kernels (skip-strip and vanilla
    replays, segment limits) is the one the jitted kernels give (the C reader and the independent reader
    agree with it: test_conformance, test_c_reader)."""
    import swpm_usd.format.check_mixed as check_mixed
    import swpm_usd.format.check_skip as check_skip
    from swpm_usd.format import kernels as jitted
    from swpm_usd.format import kernels_np
    from swpm_usd.format.reader import validate

    def report(path):
        rep = validate(path)
        return [(p.code, p.offset, p.message) for p in rep.problems], json.dumps(rep.summary, default=str)

    files = sorted((ROOT / "spec" / "vectors").rglob("*.swpm"))
    replayed = [f for f in files if any(e in f.name for e in ("skip", "mixed", "vanilla"))]
    assert len(replayed) > 10
    monkeypatch.setattr(kernels_np, "use_jitted", lambda elements: False)
    plain = {f: report(f) for f in files}
    monkeypatch.setattr(kernels_np, "use_jitted", lambda elements: True)
    monkeypatch.setattr(check_skip, "segment_limits", jitted.segment_limits)
    monkeypatch.setattr(check_mixed, "segment_limits", jitted.segment_limits)
    assert {f: report(f) for f in files} == plain


def test_the_numpy_vanilla_replay_gives_the_jitted_ones_results():
    """:func:`swpm_usd.format.kernels_np.vanilla_replay_np` against the jitted kernel on random records: a
    change off its binned vertex or past the live triangles (kind 1), a binned vertex still referenced
    (kind 2), and records that hold (kind 0)."""
    import numpy as np

    from swpm_usd.format import kernels as jitted
    from swpm_usd.format import kernels_np as plain

    rng = np.random.default_rng(2048)
    kinds: dict[int, int] = {}
    for _ in range(1500):
        V, T0 = int(rng.integers(3, 10)), int(rng.integers(1, 8))
        n = 3 * T0 + (int(rng.integers(0, 3)) if rng.random() < 0.2 else 0)  # (a tail no record removes)
        indices = rng.integers(0, V, n).astype(np.int64)
        R = int(rng.integers(0, V))
        kept = rng.integers(0, V, R).astype(np.int64)
        removed = np.zeros(R, np.int64)
        left = T0
        for r in range(R):
            removed[r] = int(rng.integers(0, min(left, 3) + 1))
            left -= int(removed[r])
        cc = rng.integers(0, 4, R).astype(np.int64)
        offsets = rng.integers(0, 3 * T0, int(cc.sum())).astype(np.int64)
        if rng.random() < 0.6:  # changes that find their binned vertex, mostly
            j, buf = 0, indices.copy()
            for r in range(R):
                for _ in range(cc[r]):
                    s = offsets[j]
                    j += 1
                    if rng.random() < 0.95 and buf[s] == indices[s]:
                        indices[s] = V - 1 - r
                    buf[s] = kept[r]
        args = (indices, kept, removed, cc, offsets, V)
        want = tuple(int(x) for x in jitted.vanilla_replay(*args))
        assert plain.vanilla_replay_np(*args) == want, args
        kinds[want[0]] = kinds.get(want[0], 0) + 1
    assert min(kinds.get(kind, 0) for kind in (0, 1, 2)) > 100, kinds
