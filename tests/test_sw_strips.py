"""The sliding-window pool stored as triangle strips (``primitive="strip"``, :mod:`.sw_strips`): every
window of a strip build is one range of the pool, starting at the pool's start or after a restart index,
and decodes to the list build's window (oriented triangle multisets); the counts, the vertex prefix, the
buffers and the parameters' checks."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import shared_mesh

import swpm_usd
import swpm_usd.encode.slidingwindow
from swpm_usd.encode.strips import _stripify, _stripify_barriers, decode_strip
from swpm_usd.encode.sw_strips import SEARCH_BLOCK, _strip_pieces, search_block, strip_pool
from swpm_usd.errors import BuildError

OPTIONS = {"defaults": {}, "cluster-swap": {"cluster": True, "optimize_connectivity": True}}


def _canonical(tris: np.ndarray) -> np.ndarray:
    """Triangles rotated so the smallest index comes first (winding kept), rows sorted."""
    t = np.asarray(tris, np.int64).reshape(-1, 3)
    r = np.argmin(t, axis=1)
    t = np.take_along_axis(t, (r[:, None] + np.arange(3)[None, :]) % 3, axis=1)
    return t[np.lexsort(t.T[::-1])]


@pytest.fixture(scope="module", params=["suzanne", "beetle", "spot"])
def builds(request):
    mesh = shared_mesh(f"{request.param}.obj")
    out = {}
    for name, kw in OPTIONS.items():
        lst = swpm_usd.build(mesh, encoding="sliding-window", **kw)
        strip = swpm_usd.build(mesh, encoding="sliding-window", primitive="strip", **kw)
        out[name] = (lst, strip)
    return out


@pytest.mark.parametrize("option", list(OPTIONS))
def test_every_window_decodes_to_the_list_window(builds, option) -> None:
    lst, strip = builds[option]
    assert strip.primitive == "strip" and lst.primitive == "list"
    assert strip.index_pool.shape[0] < lst.index_pool.shape[0]  # (what strips are for)
    assert np.array_equal(strip.window_records[:, 1:], lst.window_records[:, 1:])
    for k in range(strip.lod_count):
        tris = strip.triangles_at(k)
        assert tris.shape[0] == strip.window_records[k, 1] == lst.triangle_count_at(k)
        assert np.array_equal(_canonical(tris), _canonical(lst.triangles_at(k))), f"LOD {k}"


@pytest.mark.parametrize("option", list(OPTIONS))
def test_windows_are_strip_ranges_after_a_restart(builds, option) -> None:
    lst, strip = builds[option]
    pool = strip.index_pool.astype(np.int64)
    rv = strip.params["restart_index"]
    assert rv == strip.restart_index == 0xFFFF  # (a u16 file: its pool and vertex ids fit u16, spec 3.5)
    first = strip.window_records[:, 0].astype(np.int64)
    count = strip.window_index_counts.astype(np.int64)
    assert np.array_equal(lst.window_index_counts, 3 * lst.window_records[:, 1])
    assert np.all(first + count <= pool.shape[0])
    live = count > 0
    assert np.array_equal(live, strip.window_records[:, 1] > 0)  # (a window of triangles draws indices)
    # a window starts at the pool's start or right after a restart (it may end inside a strip)
    assert np.all((first[live] == 0) | (pool[np.maximum(first[live] - 1, 0)] == rv))
    # where only windows end the strip goes on (or restarts when it cannot): some windows end inside a strip,
    # and there are fewer restarts and indices than with cuts at every window's first and last triangle (the
    # former writer)
    end = first[live] + count[live]
    assert np.any((end < pool.shape[0]) & (pool[np.minimum(end, pool.shape[0] - 1)] != rv))
    tris = lst.index_pool.astype(np.int64).reshape(-1, 3)
    rec = lst.window_records.astype(np.int64)
    cuts = np.unique(np.r_[0, tris.shape[0], rec[:, 0] // 3, rec[:, 0] // 3 + rec[:, 1]])
    old, _, _, _ = _strip_pieces(
        tris, cuts, np.empty(0, np.int64), rv, strip.params["strip_window"], SEARCH_BLOCK, 300
    )
    assert np.count_nonzero(pool == rv) < np.count_nonzero(old == rv) and pool.shape[0] < old.shape[0]
    # a window ends on its last triangle's index, never on a join's degenerate triangles after it (three
    # indices of one strip, distinct)
    e = end[:, None] - np.arange(1, 4)[None, :]
    assert np.all(e >= first[live, None]) and not np.any(pool[e] == rv)
    last = pool[e]
    assert np.all((last[:, 0] != last[:, 1]) & (last[:, 1] != last[:, 2]) & (last[:, 0] != last[:, 2]))
    for k in range(strip.lod_count):
        kind, stream = strip.draw_stream(k)
        assert kind == "strip" and stream.shape[0] == count[k]
        ids = stream[stream != rv]
        # the vertex prefix: the restart index is exempt
        assert ids.size == 0 or int(ids.max()) < strip.vertex_count_at(k)
        rec = strip.record_for_triangles(int(strip.triangle_counts[k]))
        assert rec.shape == (4,) and rec[3] == count[strip.lod_for_triangles(int(strip.triangle_counts[k]))]


def test_strip_buffers_round_trip_and_memory(builds) -> None:
    lst, pm = builds["defaults"]
    b = pm.buffers()
    assert set(b) == {"index_pool", "window_records", "window_index_counts"}
    assert set(lst.buffers()) == {"index_pool", "window_records"}

    def rebuild(buffers):
        return swpm_usd.from_buffers(
            "sliding-window",
            pm.points,
            pm.attributes,
            pm.vertex_counts,
            pm.triangle_counts,
            pm.lod_errors,
            buffers,
            params=pm.params,
        )

    pm2 = rebuild(b)
    for k in (0, pm.lod_count // 3, pm.lod_count - 1):
        assert np.array_equal(pm2.triangles_at(k), pm.triangles_at(k))
    assert pm.params["primitive"] == "strip" and pm.params["strip_window"] == 4
    assert lst.params["primitive"] == "list" and lst.params["restart_index"] is None
    assert pm.global_bytes == pm.vertex_bytes() + 2 * pm.index_pool.shape[0] + 8 * pm.lod_count
    with pytest.raises(BuildError, match="window_index_counts"):
        rebuild({k: v for k, v in b.items() if k != "window_index_counts"})


def test_strip_pool_by_hand() -> None:
    """Two windows of a four-triangle fan pool: cut at 0, 1 (window 1's start), 4; window 0 spans both pieces
    across the restart between them."""
    pool = np.array([0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5], np.uint32)
    rec = np.array([[0, 4, 6], [3, 3, 6]], np.uint32)
    strips, out, counts, rv = strip_pool(pool, rec, 6)
    assert rv == 0xFFFF
    assert strips[:4].tolist() == [0, 1, 2, rv] and out[1, 0] == 4
    assert out[:, 1].tolist() == [4, 3] and out[:, 2].tolist() == [6, 6]
    assert out[0, 0] == 0 and counts[0] == strips.shape[0]
    assert strips[out[1, 0] - 1] == rv and out[1, 0] + counts[1] == strips.shape[0]
    for k in range(2):
        a = int(out[k, 0])
        got = decode_strip(strips[a : a + int(counts[k])], rv)
        want = pool[int(rec[k, 0]) : int(rec[k, 0]) + 3 * int(rec[k, 1])].reshape(-1, 3)
        assert np.array_equal(_canonical(got), _canonical(want))


def _grid_triangles(rng: np.random.Generator, n: int) -> np.ndarray:
    """An n x n grid's triangles (so strips go on), in an order shuffled by blocks of a few triangles."""
    v = np.arange((n + 1) * (n + 1)).reshape(n + 1, n + 1)
    a, b, c, d = v[:-1, :-1].ravel(), v[:-1, 1:].ravel(), v[1:, :-1].ravel(), v[1:, 1:].ravel()
    tris = np.stack([np.c_[a, b, d], np.c_[a, d, c]], axis=1).reshape(-1, 3)
    blocks = np.array_split(np.arange(tris.shape[0]), tris.shape[0] // 5)
    order = np.concatenate([blocks[i] for i in rng.permutation(len(blocks))])
    return tris[order].astype(np.int64)


@pytest.mark.parametrize("seed", range(6))
def test_stripify_never_crosses_a_barrier(seed) -> None:
    """The strip's prefix up to a barrier's position decodes to exactly the input triangles before it."""
    rng = np.random.default_rng(seed)
    tris = _grid_triangles(rng, 6 + seed)
    T = tris.shape[0]
    barriers = np.unique(rng.integers(0, T + 1, size=3 + 2 * seed))
    rv = 0xFFFF
    runs = [
        (1, False, 0),
        (4, False, 0),
        (8, False, 0),
        (1, True, 0),
        (4, True, 0),
        (8, True, 0),
        (4, True, 5),
    ]
    for window, joins, exact in runs + [(1, True, 8)]:
        strip, pos = _stripify_barriers(tris, True, rv, window, barriers, joins, exact)
        assert pos.shape == barriers.shape and np.all(np.diff(pos) >= 0)
        assert np.array_equal(_canonical(decode_strip(strip, rv)), _canonical(tris))
        for b, p in zip(barriers.tolist(), pos.tolist(), strict=True):
            got = decode_strip(strip[:p], rv)
            assert np.array_equal(_canonical(got), _canonical(tris[:b])), (window, joins, exact, b)
        # no barrier: the skip strips' stripifier bit for bit
        assert np.array_equal(
            _stripify_barriers(tris, True, rv, window, barriers[:0], False, 0)[0],
            _stripify(tris, True, rv, window),
        )


def test_strip_pool_window_ends_inside_a_strip() -> None:
    """A four-triangle fan, window 1 its first two triangles: it ends at a barrier inside the one strip (no
    restart at all), drawing the strip's prefix."""
    pool = np.array([0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5], np.uint32)
    rec = np.array([[0, 4, 6], [0, 2, 6]], np.uint32)
    strips, out, counts, rv = strip_pool(pool, rec, 6)
    assert rv not in strips.tolist() and out[:, 0].tolist() == [0, 0]
    assert counts[0] == strips.shape[0] and counts[1] < counts[0]
    for k in range(2):
        got = decode_strip(strips[: int(counts[k])], rv)
        assert np.array_equal(_canonical(got), _canonical(pool[: 3 * int(rec[k, 1])].reshape(-1, 3)))


@pytest.mark.parametrize(
    "bad",
    [
        {"primitive": "fan"},
        {"primitive": 1},
        {"strip_window": 0},
        {"strip_window": 65},
        {"strip_window": True},
        {"strip_window": 2.0},
        {"strip_window": "4"},
    ],
)
def test_bad_primitive_or_strip_window_is_a_build_error(bad) -> None:
    mesh = shared_mesh("suzanne.obj")
    with pytest.raises(BuildError, match=next(iter(bad))):
        swpm_usd.build(mesh, encoding="sliding-window", **bad)
    with pytest.raises(BuildError, match=next(iter(bad))):  # (the builder itself checks them too)
        swpm_usd.encode.slidingwindow.build_sliding_window(mesh, **bad)


@pytest.mark.parametrize("option", list(OPTIONS))
def test_swpm_round_trip_and_validate(builds, option, tmp_path) -> None:
    """A strip pool's ``.swpm``: the SW_STRIPS bit, WREC rows of four fields, valid with no problem, and read
    back to the same windows; a list pool's file keeps three fields and no bit."""
    from swpm_usd.format import layout as L
    from swpm_usd.format import validate

    lst, pm = builds[option]
    for p, strips in ((pm, True), (lst, False)):
        path = swpm_usd.save(p, tmp_path / f"{p.primitive}.swpm")
        rep = validate(path)
        assert rep.valid and rep.problems == [], rep.format()
        data = path.read_bytes()
        assert bool(int.from_bytes(data[20:24], "little") & L.FEATURE_SW_STRIPS) == strips
        back = swpm_usd.load(path)
        assert back.primitive == p.primitive and back.params["primitive"] == p.primitive
        assert np.array_equal(back.window_records, p.window_records)
        assert np.array_equal(back.window_index_counts, p.window_index_counts)
        for k in range(0, p.lod_count, max(1, p.lod_count // 50)):
            assert np.array_equal(back.triangles_at(k), p.triangles_at(k)), k


def test_usd_round_trip_and_validate(builds, tmp_path) -> None:
    """A strip pool on a USD prim: swpm:windowIndexCounts beside indexPool and windowRecords, primitive and
    restart index in swpm:params; the stage validates clean and reads back to the same windows. A window
    index count past the pool is SWPM_USD_WINDOW_RANGE (the validator measured 3 x triangle count)."""
    from pxr import Usd, Vt

    from swpm_usd import usd
    from swpm_usd.usd.validate import validate_stage

    _, pm = builds["cluster-swap"]
    path = usd.write(pm, tmp_path / "strips.usda")
    assert validate_stage(path) == []
    stage = Usd.Stage.Open(str(path))
    prim = usd.find_encoded(stage)[0]
    assert "swpm:windowIndexCounts" in [a.GetName() for a in prim.GetAttributes()]
    back = usd.read(prim)
    assert back.primitive == "strip" and back.restart_index == pm.restart_index
    for k in range(pm.lod_count):
        assert np.array_equal(back.triangles_at(k), pm.triangles_at(k)), k
    counts = np.asarray(pm.window_index_counts, np.uint32).copy()
    counts[-1] = pm.index_pool.shape[0] + 1
    prim.GetAttribute("swpm:windowIndexCounts").Set(Vt.UIntArray.FromNumpy(counts))
    stage.GetRootLayer().Save()
    assert [f.code for f in validate_stage(path)] == ["SWPM_USD_WINDOW_RANGE"]


def _drop_buffer(prim, name: str) -> None:
    """``name`` taken out of the prim's parallel swpm:bufferNames / Dtypes / Columns."""
    from pxr import Vt

    names = list(prim.GetAttribute("swpm:bufferNames").Get())
    i = names.index(name)
    for attr in ("swpm:bufferNames", "swpm:bufferDtypes", "swpm:bufferColumns"):
        values = list(prim.GetAttribute(attr).Get())
        del values[i]
        prim.GetAttribute(attr).Set(Vt.UIntArray(values) if attr == "swpm:bufferColumns" else values)


@pytest.mark.parametrize(
    ("edit", "code"),
    [("short", "SWPM_USD_STRIDE"), ("zero", "SWPM_USD_STRIDE"), ("unlisted", "SWPM_USD_MISSING")],
)
def test_usd_strip_prim_without_its_index_counts_names_them(edit, code, tmp_path) -> None:
    """A strip prim whose swpm:windowIndexCounts is short, empty or not among its buffers is reported as
    that (it was measured as a list pool, 3 x triangle count, and reported SWPM_USD_WINDOW_RANGE: a window
    "outside indexPool", naming the wrong attribute)."""
    from pxr import Usd, Vt

    from swpm_usd import usd
    from swpm_usd.usd.validate import validate_stage

    pm = swpm_usd.build(shared_mesh("suzanne.obj"), encoding="sliding-window", primitive="strip")
    path = usd.write(pm, tmp_path / "strips.usda")
    stage = Usd.Stage.Open(str(path))
    prim = usd.find_encoded(stage)[0]
    counts = np.asarray(pm.window_index_counts, np.uint32)
    if edit == "unlisted":
        _drop_buffer(prim, "window_index_counts")
    else:
        kept = counts[:-1] if edit == "short" else counts[:0]
        prim.GetAttribute("swpm:windowIndexCounts").Set(Vt.UIntArray.FromNumpy(kept.copy()))
    stage.GetRootLayer().Save()
    found = validate_stage(path)
    assert [f.code for f in found] == [code]
    assert "swpm:windowIndexCounts" in found[0].message


def test_usd_list_prim_ignores_stray_index_counts(tmp_path) -> None:
    """A list prim (no params primitive 'strip') listing a swpm:windowIndexCounts buffer: the windows are
    3 x their triangle counts, as the rebuilt mesh reads them (the validator measured them by the stray
    counts and reported a window outside indexPool that the mesh never draws)."""
    from pxr import Sdf, Usd, Vt

    from swpm_usd import usd
    from swpm_usd.usd.validate import validate_stage

    pm = swpm_usd.build(shared_mesh("suzanne.obj"), encoding="sliding-window")
    path = usd.write(pm, tmp_path / "list.usda")
    stage = Usd.Stage.Open(str(path))
    prim = usd.find_encoded(stage)[0]
    for attr, extra in (
        ("swpm:bufferNames", "window_index_counts"),
        ("swpm:bufferDtypes", "uint32"),
        ("swpm:bufferColumns", 0),
    ):
        values = list(prim.GetAttribute(attr).Get()) + [extra]
        prim.GetAttribute(attr).Set(Vt.UIntArray(values) if attr == "swpm:bufferColumns" else values)
    stray = np.full(pm.lod_count, pm.index_pool.shape[0] + 1, np.uint32)
    prim.CreateAttribute("swpm:windowIndexCounts", Sdf.ValueTypeNames.UIntArray).Set(
        Vt.UIntArray.FromNumpy(stray)
    )
    stage.GetRootLayer().Save()
    assert validate_stage(path) == []


STRIP_CONFIG = """\
version: 1
assets:
  - glob: "*.obj"
output:
  dir: out
  swpm: true
  usd: true
rules:
  - name: strips
    encoding: sliding-window
    params: {primitive: strip, strip_window: %s, cluster: true, optimize_connectivity: true}
"""


def test_a_pipeline_config_with_primitive_strip_runs(tmp_path) -> None:
    """``swpm-pipeline run`` with ``primitive: strip`` for the sliding window: a strip pool in the .swpm and
    on the USD prim, both valid; a strip_window out of bounds fails the config at its line."""
    import json
    import shutil

    from click.testing import CliRunner
    from conftest import SHARED_MESHES

    from swpm_usd.cli import main
    from swpm_usd.usd.validate import validate_stage

    shutil.copy(SHARED_MESHES / "suzanne.obj", tmp_path / "suzanne.obj")
    cfg = tmp_path / "pipeline.yaml"
    cfg.write_text(STRIP_CONFIG % 4)
    r = CliRunner().invoke(main, ["run", str(cfg)])
    assert r.exit_code == 0, r.output
    asset = json.loads((tmp_path / "out" / "manifest.json").read_text())["assets"]["suzanne.obj"]
    assert asset["encoding"] == "sliding-window"
    pm = swpm_usd.load(tmp_path / "out" / "suzanne.swpm")
    assert pm.primitive == "strip" and pm.params["strip_window"] == 4
    assert swpm_usd.validate(tmp_path / "out" / "suzanne.swpm").valid
    assert asset["summary"]["lambda"] == pytest.approx(pm.index_pool.shape[0] / (3 * pm.triangle_counts[0]))
    assert validate_stage(tmp_path / "out" / "suzanne.usdc") == []
    cfg.write_text(STRIP_CONFIG % 65)
    r = CliRunner().invoke(main, ["run", str(cfg)])
    assert r.exit_code == 2 and "$.rules[0].params.strip_window" in r.output


def test_usd_index_width_counts_the_restart_index() -> None:
    """At exactly 65,536 vertices every vertex id fits 16 bits but the strips' restart index is 0xFFFFFFFF:
    swpm:indexWidth must say 4 (it said 2, from the vertex count alone)."""
    from swpm_usd.usd.writer import swpm_values

    V = 0x10000
    pm = swpm_usd.from_buffers(
        "sliding-window",
        np.zeros((V, 3), np.float32),
        {},
        np.array([V]),
        np.array([1]),
        np.zeros(1, np.float32),
        {
            "index_pool": np.array([0, 1, 2], np.uint32),
            "window_records": np.array([[0, 1, V]], np.uint32),
            "window_index_counts": np.array([3], np.uint32),
        },
        params={"primitive": "strip", "restart_index": 0xFFFFFFFF},
    )
    assert pm.triangles_at(0).tolist() == [[0, 1, 2]]
    assert swpm_values(pm)["swpm:indexWidth"][1] == 4


@pytest.fixture(scope="module")
def vectors() -> dict[str, bytes]:
    from swpm_usd.format.vectors import build_all

    return build_all()


@pytest.mark.parametrize(
    ("vector", "code"),
    [
        ("strips-bit-without-sliding", "SWPM_HEADER_STRIPS_NOT_SLIDING"),
        ("sliding-strips-wrec-three-fields", "SWPM_CHUNK_BAD_LENGTH"),
        ("sliding-strips-primitive-list", "SWPM_META_BAD_FIELD"),
        ("sliding-list-primitive-strip", "SWPM_META_BAD_FIELD"),
        ("sliding-strips-restart-null", "SWPM_META_BAD_FIELD"),
        ("sliding-strips-restart-below-vertex-count", "SWPM_META_BAD_FIELD"),
        ("sliding-strips-window-outside-pool", "SWPM_WINDOW_OUT_OF_POOL"),
        ("sliding-strips-window-mid-strip", "SWPM_WINDOW_MID_STRIP"),
        ("sliding-strips-triangle-count", "SWPM_WINDOW_STRIP_TRIANGLES"),
    ],
)
def test_the_reader_rejects_each_malformed_strip_pool(vectors, vector, code) -> None:
    """Each rejection of spec/format.md 3.5 with its code, and nothing else (the vectors are rebuilt here
    from :mod:`swpm_usd.format.vectors`, so a stale spec/vectors cannot hide a change)."""
    from swpm_usd.format import validate_bytes

    data = vectors[f"invalid/{vector}.swpm"]
    assert [q.code for q in validate_bytes(data).problems] == [code]


def test_errors_md_places_the_strip_pool_meta_checks() -> None:
    """spec/errors.md's SWPM_META_BAD_FIELD row says where a strip pool's params problems are found (it
    listed only skip-strip's params, so the four sliding-window vectors expecting this code at META had no
    row that explained them)."""
    from pathlib import Path

    from swpm_usd.format.errors import CATALOGUE

    where = CATALOGUE["SWPM_META_BAD_FIELD"].offset
    assert "sliding-window" in where and "SW_STRIPS" in where and "stage (a)" in where
    row = next(
        line
        for line in (Path(__file__).resolve().parent.parent / "spec" / "errors.md").read_text().splitlines()
        if line.startswith("| `SWPM_META_BAD_FIELD`")
    )
    assert where in row


def test_reader_steps_place_the_strips_bit_check() -> None:
    """format.md §5 step 1, the header checks in their order, names where SWPM_HEADER_STRIPS_NOT_SLIDING
    comes (only §2.1 said it, so a reader written from §5 had no place for it among the header checks)."""
    from pathlib import Path

    text = (Path(__file__).resolve().parent.parent / "spec" / "format.md").read_text()
    step1 = text[text.index("1. Header, in this order:") : text.index("2. Table entries in table order")]
    at = step1.index("SWPM_HEADER_STRIPS_NOT_SLIDING")
    assert step1.index("encoding bits") < at < step1.index("reserved")


def _by_hand(pool: list[int], rec: list[list[int]], V: int) -> tuple[list[int], np.ndarray, int]:
    """:func:`strip_pool` of a small list pool, every window checked against its list triangles: (the strip
    pool, the index counts, the restart index)."""
    p = np.array(pool, np.uint32)
    r = np.array(rec, np.uint32)
    strips, out, counts, rv = strip_pool(p, r, V)
    for k in range(r.shape[0]):
        a = int(out[k, 0])
        got = decode_strip(strips[a : a + int(counts[k])], rv)
        assert got.shape[0] == int(r[k, 1])
        want = p[int(r[k, 0]) : int(r[k, 0]) + 3 * int(r[k, 1])].reshape(-1, 3)
        assert np.array_equal(_canonical(got), _canonical(want)), k
    return strips.tolist(), counts, rv


def test_a_window_end_joins_through_a_shared_vertex() -> None:
    """Two triangles sharing only vertex 2, window 1 the first: no edge goes on, so the strip repeats 2 (two
    degenerate triangles) and draws (2, 3, 4) at its parity: 6 indices, not 7 with a restart."""
    strips, counts, rv = _by_hand([0, 1, 2, 2, 3, 4], [[0, 2, 5], [0, 1, 3]], 5)
    assert strips == [0, 1, 2, 2, 4, 3] and counts.tolist() == [6, 3]


def test_a_window_end_turns_a_strips_first_triangle() -> None:
    """Window 1 is the strip's first triangle (0, 1, 2), written 0 1 2 with nothing to continue in its window;
    the next window's triangle (1, 0, 5) is across its edge 0-1, so it is rewritten 2 0 1 (the same triangle)
    and the strip goes on by one index."""
    strips, counts, rv = _by_hand([0, 1, 2, 1, 0, 5], [[0, 2, 6], [0, 1, 3]], 6)
    assert strips == [2, 0, 1, 5] and counts.tolist() == [4, 3]


def test_a_window_end_swaps_before_its_last_triangle() -> None:
    """(0, 1, 2) then (2, 1, 3) go on as one strip; the next window's (3, 1, 6) is across the last triangle's
    edge 1-3, not its last edge 2-3: a swap written before that triangle (0 1 2 1 3) reaches it, one index
    more than going on and three fewer than a restart."""
    strips, counts, rv = _by_hand([0, 1, 2, 2, 1, 3, 3, 1, 6], [[0, 3, 7], [0, 2, 4]], 7)
    assert rv not in strips and len(strips) == 6 and counts.tolist() == [6, 5]


@pytest.mark.parametrize("option", list(OPTIONS))
def test_strip_builds_join_without_restarts(builds, option) -> None:
    """The shared meshes' strip pools hold joins through a vertex ("q q": a repeated index), each window
    still its list window (:func:`test_every_window_decodes_to_the_list_window`), and fewer indices than the
    same pieces stripified with a restart wherever a strip cannot go on."""
    lst, strip = builds[option]
    pool = strip.index_pool.astype(np.int64)
    rv = strip.restart_index
    assert np.count_nonzero((pool[1:] == pool[:-1]) & (pool[1:] != rv)) > 0
    tris = lst.index_pool.astype(np.int64).reshape(-1, 3)
    rec = lst.window_records.astype(np.int64)
    T = tris.shape[0]
    cuts = np.unique(np.r_[0, T, rec[:, 0] // 3])
    ends = rec[:, 0] // 3 + rec[:, 1]
    barriers = np.setdiff1d(ends[(ends > 0) & (ends < T)], cuts)
    w = strip.params["strip_window"]
    block, budget = search_block(T, option == "defaults")
    joined, _, _, _ = _strip_pieces(tris, cuts, barriers, rv, w, block, budget)
    assert np.array_equal(joined, pool)
    # (_stripify_barriers without vertex joins inside a piece: a restart there)
    plain = []
    for a, b in zip(cuts[:-1].tolist(), cuts[1:].tolist(), strict=True):
        bs = barriers[(barriers > a) & (barriers < b)] - a
        plain.append(_stripify_barriers(tris[a:b], True, rv, max(1, min(w, b - a)), bs, False, 0)[0])
    n_plain = sum(p.shape[0] for p in plain) + len(plain) - 1
    assert pool.shape[0] < n_plain


def test_join_vectors_are_the_writers_pool() -> None:
    """The vectors ``sliding-window-strip-join`` / ``-end-degenerate`` (format.md 3.5) hold what the writer
    makes of their list: window 1's end joined to 3 4 1 through its last index repeated (``3 3``), window 1
    stopping before it; the degenerate variant only lengthens window 1 by one index and draws the same."""
    from swpm_usd.format.vectors import fan_sliding_strip_join

    strips, counts, rv = _by_hand([0, 1, 2, 0, 2, 3, 3, 4, 1, 1, 4, 0], [[0, 4, 5], [0, 2, 4]], 5)
    assert strips == [1, 2, 0, 3, 3, 4, 1, 0] and counts.tolist() == [8, 4]
    for n1 in (4, 5):
        bufs = fan_sliding_strip_join(window1_count=n1).raw_buffers
        assert list(bufs["index_pool"]) == strips and list(bufs["window_index_counts"]) == [8, n1]
        got = decode_strip(np.array(strips[:n1]), rv)
        assert np.array_equal(_canonical(got), _canonical([[0, 1, 2], [0, 2, 3]]))


@pytest.mark.parametrize("seed", range(4))
def test_block_search_without_restarts_keeps_degenerate_joins(seed) -> None:
    """``_stripify_barriers`` with degenerate joins (``use_restart`` False) and the block search (``exact``):
    the search writes new strips after a restart index, so it is not used there; the strip holds only
    vertices and decodes, whole and up to every barrier, to the input (it held the restart value -1 between
    strips, each a vertex -1 to a decoder without restarts, 13 triangles for 4)."""
    rng = np.random.default_rng(seed)
    tris = np.array([[0, 1, 2], [3, 4, 5], [6, 7, 8], [2, 1, 9]], np.int64)
    if seed:
        tris = _grid_triangles(rng, 3 + seed)
    barriers = np.unique(rng.integers(1, tris.shape[0], size=2 + seed)) if seed else np.array([2], np.int64)
    for exact in (2, 5, 8):
        strip, pos = _stripify_barriers(tris, False, -1, 4, barriers, True, exact)
        assert strip.min() >= 0
        assert np.array_equal(_canonical(decode_strip(strip)), _canonical(tris))
        for b, p in zip(barriers.tolist(), pos.tolist(), strict=True):
            assert np.array_equal(_canonical(decode_strip(strip[:p])), _canonical(tris[:b])), (exact, b)


def _decode_by_the_spec(s: list[int], rv: int) -> list[tuple[int, int, int]]:
    """format.md 3.5 / 3.7 read on their own (not :func:`decode_strip`): triangle i of a strip, counted from
    its start, is (s[i], s[i+1], s[i+2]) for even i, (s[i+1], s[i], s[i+2]) for odd; degenerate ones
    skipped."""
    out, run = [], 0
    for j, c in enumerate(s):
        if c == rv:
            run = 0
            continue
        if run >= 2:
            i = run - 2
            t = (s[j - 2], s[j - 1], c) if i % 2 == 0 else (s[j - 1], s[j - 2], c)
            if len(set(t)) == 3:
                out.append(t)
        run += 1
    return out


@pytest.mark.parametrize("seed", range(8))
def test_strip_pool_random_windows_draw_their_list_triangles(seed) -> None:
    """Random small pools (triangles sharing edges, only vertices, duplicated or reversed) and random
    overlapping windows: every window of :func:`strip_pool` starts a strip, ends on a triangle (its last three
    indices distinct) and draws exactly its list window's triangles with their winding (a turned first
    triangle, a swap or a ``q q`` join across another window's end included), for look-aheads 1, 4 and 8."""
    rng = np.random.default_rng(seed)
    for _ in range(40):
        V = int(rng.integers(3, 12))
        T = int(rng.integers(1, 40))
        tris = np.array([rng.choice(V, 3, replace=False) for _ in range(T)], np.int64)
        if seed % 2:  # a grid's triangles in a shuffled order: long strips, joins by edges
            n = int(rng.integers(1, 5))
            v = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
            a, b, c, d = v[:-1, :-1].ravel(), v[:-1, 1:].ravel(), v[1:, :-1].ravel(), v[1:, 1:].ravel()
            tris = np.r_[np.c_[a, c, b], np.c_[b, c, d]][rng.permutation(2 * n * n)]
            V, T = (n + 1) ** 2, 2 * n * n
        starts = rng.integers(0, T + 1, int(rng.integers(1, 10)))
        rec = np.array([[3 * s, int(rng.integers(0, T - s + 1)), V] for s in starts.tolist()], np.uint32)
        for window in (1, 4, 8):
            strips, out, counts, rv = strip_pool(tris.reshape(-1).astype(np.uint32), rec, V, window)
            s = strips.astype(np.int64).tolist()
            for k in range(rec.shape[0]):
                f, c = int(out[k, 0]), int(counts[k])
                want = tris[int(rec[k, 0]) // 3 : int(rec[k, 0]) // 3 + int(rec[k, 1])]
                if c == 0:
                    assert want.shape[0] == 0
                    continue
                assert f == 0 or s[f - 1] == rv
                assert rv not in s[f + c - 3 : f + c] and len(set(s[f + c - 3 : f + c])) == 3
                got = _decode_by_the_spec(s[f : f + c], rv)
                assert np.array_equal(_canonical(got), _canonical(want)), (seed, window, k)


def test_search_block_by_pool_size_and_order() -> None:
    """The block search is sized by the pool (:data:`.sw_strips.SEARCH_TIERS`: smaller pools, larger blocks)
    unless its order was searched for the cache, which keeps :data:`.sw_strips.SEARCH_BLOCK`."""
    from swpm_usd.encode import sw_strips

    sizes = [sw_strips.search_block(t) for t in (10, 10_000, 100_000, 300_000, 10**9)]
    assert [b for b, _ in sizes] == sorted((b for b, _ in sizes), reverse=True)
    assert sizes[0][0] > sw_strips.SEARCH_BLOCK and sizes[-1][0] >= sw_strips.SEARCH_BLOCK
    assert sw_strips.search_block(10, ordered=True) == (sw_strips.SEARCH_BLOCK, 300)


@pytest.mark.parametrize("option", list(OPTIONS))
def test_strip_builds_size_their_block_search(builds, option) -> None:
    """A build's strip pool is :func:`strip_pool` of its list pool at :func:`.sw_strips.search_block`'s size:
    the defaults (an order searched for the cache) at :data:`.sw_strips.SEARCH_BLOCK`; a clustered build's
    small pool searched in larger blocks, which stores fewer indices than that."""
    from swpm_usd.encode import sw_strips

    lst, strip = builds[option]
    ordered = option == "defaults"
    T = lst.index_pool.shape[0] // 3
    block, budget = sw_strips.search_block(T, ordered)
    assert (block == sw_strips.SEARCH_BLOCK) == ordered
    args = (lst.index_pool, lst.window_records, lst.vertex_count, strip.params["strip_window"])
    got = strip_pool(*args, block, budget)
    assert np.array_equal(got[0], strip.index_pool) and np.array_equal(got[2], strip.window_index_counts)
    if not ordered:
        assert strip.index_pool.shape[0] < strip_pool(*args, sw_strips.SEARCH_BLOCK, 300)[0].shape[0]


@pytest.mark.parametrize("block", [0, 1, 7, 12, 16])
def test_strip_pool_any_block_size_draws_the_list_windows(block) -> None:
    """Random pools and overlapping windows, the block search from none (the look-ahead only) to blocks of 16
    triangles: every window draws exactly its list window's triangles, starting a strip."""
    rng = np.random.default_rng(block)
    for _ in range(30):
        n = int(rng.integers(1, 5))
        v = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
        a, b, c, d = v[:-1, :-1].ravel(), v[:-1, 1:].ravel(), v[1:, :-1].ravel(), v[1:, 1:].ravel()
        tris = np.r_[np.c_[a, c, b], np.c_[b, c, d]][rng.permutation(2 * n * n)]
        V, T = (n + 1) ** 2, 2 * n * n
        starts = rng.integers(0, T + 1, int(rng.integers(1, 6)))
        rec = np.array([[3 * s, int(rng.integers(0, T - s + 1)), V] for s in starts.tolist()], np.uint32)
        strips, out, counts, rv = strip_pool(tris.reshape(-1).astype(np.uint32), rec, V, 4, block, 500)
        s = strips.astype(np.int64).tolist()
        for k in range(rec.shape[0]):
            f, c = int(out[k, 0]), int(counts[k])
            want = tris[int(rec[k, 0]) // 3 : int(rec[k, 0]) // 3 + int(rec[k, 1])]
            assert c > 0 or want.shape[0] == 0
            if c:
                assert f == 0 or s[f - 1] == rv
                assert np.array_equal(_canonical(_decode_by_the_spec(s[f : f + c], rv)), _canonical(want))
