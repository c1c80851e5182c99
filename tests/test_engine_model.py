"""The product's `.swpm` files drawn by an engine that knows only spec/format.md (tests/engine_model.py).

Every LOD an engine draws (window look-up, or instance edited by records, rasterised with Vulkan's strip rule)
must be the product's ``triangles_at(k)``, same winding; instances walked by random jumps must end as fresh
ones; every draw stays under its LOD's vertex count; the streaming map's prefixes draw their bands; and the
conformance vectors get the verdict their expected results give.
"""

from __future__ import annotations

import json
import struct
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, shared_mesh

import swpm_usd

sys.path.insert(0, str(Path(__file__).resolve().parent))
import engine_model as em  # noqa: E402

VECTORS = ROOT / "spec" / "vectors"

# (mesh, encoding, options): every encoding and its main options on small meshes; bunny and bob where tables
# outgrow u16: OFFSET32 (u16 idx, u32 off) since spec §1 split the table type off from the index type
CASES = [
    ("suzanne.obj", "vanilla", {}),
    ("suzanne.obj", "sliding-window", {}),
    ("suzanne.obj", "sliding-window", {"primitive": "strip"}),
    ("suzanne.obj", "sliding-window", {"cluster": True, "optimize_connectivity": True}),
    ("suzanne.obj", "sliding-window", {"inner_vertices": 3}),
    ("suzanne.obj", "skip-strip", {}),
    ("suzanne.obj", "skip-strip", {"restart": False}),
    ("suzanne.obj", "skip-strip", {"primitive": "list"}),
    ("suzanne.obj", "mixed", {}),
    ("cow.obj", "vanilla", {}),
    ("cow.obj", "sliding-window", {}),  # OFFSET32: the pool is longer than 65,535 indices
    ("cow.obj", "sliding-window", {"primitive": "strip", "cluster": True}),
    ("cow.obj", "skip-strip", {"primitive": "list"}),  # OFFSET32: level_index_start
    ("cow.obj", "mixed", {}),
    ("spot.obj", "vanilla", {}),
    ("spot.obj", "sliding-window", {"primitive": "strip"}),
    ("spot.obj", "skip-strip", {}),
    ("spot.obj", "skip-strip", {"restart": False}),
    ("spot.obj", "mixed", {}),
    ("stanford-bunny.obj", "sliding-window", {"primitive": "strip"}),  # OFFSET32 strips, V < 65,536
    ("stanford-bunny.obj", "vanilla", {}),  # OFFSET32 (change offsets), V < 65,536
    ("stanford-bunny.obj", "sliding-window", {}),  # OFFSET32: first_index past 65,535, V < 65,536
    ("bob.obj", "skip-strip", {}),  # OFFSET32: level_index_start past 65,535, restart 0xFFFF
]
IDS = [f"{m.split('.')[0]}-{e}" + "".join(f"-{k}={v}" for k, v in o.items()) for m, e, o in CASES]
LARGE = {"stanford-bunny.obj"}

_built: dict[int, tuple[object, bytes]] = {}


def built(i: int) -> tuple[object, bytes]:
    """The product's ProgressiveMesh and the bytes ``swpm_usd.save`` writes for case i (built once)."""
    if i not in _built:
        mesh, enc, opts = CASES[i]
        pm = swpm_usd.build(shared_mesh(mesh), encoding=enc, **opts)
        path = Path(_tmp[0]) / f"case{i}.swpm"
        swpm_usd.save(pm, path)
        _built[i] = (pm, path.read_bytes())
    return _built[i]


_tmp: list[Path] = []


@pytest.fixture(scope="module", autouse=True)
def _store(tmp_path_factory: pytest.TempPathFactory):
    _tmp.append(tmp_path_factory.mktemp("engine"))
    yield
    _built.clear()
    _loaded.clear()
    _tmp.clear()


_loaded: dict[int, tuple[em.SwpmFile, em.Engine]] = {}


def loaded(i: int) -> tuple[em.SwpmFile, em.Engine]:
    """The engine's load of case i (the file and its shared buffers do not change after load)."""
    if i not in _loaded:
        _loaded[i] = em.load(built(i)[1])
    return _loaded[i]


def lods_to_check(L: int, large: bool) -> list[int]:
    if L <= 600:
        return list(range(L))
    n = 25 if large else 80
    return sorted(set(np.linspace(0, L - 1, n).astype(int).tolist()) | set(range(L - 5, L)))


def draws_at(eng: em.Engine, inst: em.Instance | None, k: int) -> list[em.Draw]:
    if inst is None:
        return eng.draws(k)
    inst.set_lod(k)
    return inst.draws()


def same_oriented(a: np.ndarray, b: np.ndarray) -> bool:
    ca, cb = em.canonical(a), em.canonical(b)
    return ca.shape == cb.shape and bool(np.all(ca == cb))


@pytest.mark.parametrize("i", range(len(CASES)), ids=IDS)
def test_every_lod_draws_the_products_triangles(i: int) -> None:
    pm, data = built(i)
    f, eng = loaded(i)
    assert f.L == pm.lod_count and f.encoding == CASES[i][1]
    inst = None if f.encoding == "sliding-window" else eng.instance()
    for k in lods_to_check(f.L, CASES[i][0] in LARGE):
        ds = draws_at(eng, inst, k)
        drawn = em.drawn_triangles(ds)
        assert same_oriented(drawn, np.asarray(pm.triangles_at(k))), f"LOD {k}"
        assert len(drawn) == f.triangle_counts[k], f"LOD {k}: LODS triangle_count"
        # the vertex prefix property: an engine binds only vertex_count(k) vertices
        assert f.vertex_counts[k] == pm.vertex_count_at(k)
        assert all(d.vertex_count == f.vertex_counts[k] and d.max_vertex() < d.vertex_count for d in ds), k


@pytest.mark.parametrize("i", range(len(CASES)), ids=IDS)
def test_upload_as_the_gpu_takes_it(i: int) -> None:
    """Index types u16/u32, 4-byte aligned views of the file where no conversion is needed, restart at all
    ones of the uploaded type, and a conversion only where the spec's informative note allows one."""
    pm, data = built(i)
    f, eng = loaded(i)
    assert eng.pool.dtype in (np.uint16, np.uint32)
    assert (eng.pool.dtype == np.uint32) == (f.W == 4) or eng.notes, "a narrowed pool says why"
    off = eng.file_offset(eng.pool)
    restart = f.arrays.get("restart_index")
    if restart is None or restart == np.iinfo(f.idx).max:
        assert off is not None and off % 4 == 0 and off == f.chunks["INDX"].offset, "zero-copy upload"
    else:
        # §3.5: draw from u16 indices, which every value then fits, or with the restarts rewritten
        assert restart == 0xFFFF and f.W == 4 and f.V <= 0xFFFF
        assert eng.pool.dtype == np.uint16 and eng.notes
    if restart is not None:
        src = f.arrays.get("index_pool", f.arrays.get("level_indices"))
        ones = np.iinfo(eng.pool.dtype).max
        assert np.array_equal(eng.pool == ones, src == restart), "restarts exactly where the file has them"
    elif f.encoding == "skip-strip" and f.arrays["primitive"] == "strip":
        # strips joined by degenerate triangles: no index may be what a restart-enabled GPU restarts at
        assert not np.any(eng.pool == np.iinfo(eng.pool.dtype).max)
    for t in ("INDX", "WREC", "VREC", "SREC", "MREC", "RCNT", "SKIP", "MLVL", "VERT"):
        if t in f.chunks:
            assert f.chunks[t].offset % 8 == 0
    assert (f.data_offset % 8, f.stride % 4) == (0, 0)
    # the other lists the GPU takes (§3.7, §3.8) are idx too, uploaded as views of the file
    lists = {"skip-strip": ["collapsed"], "mixed": ["dyn", "dyn_collapsed"]}.get(f.encoding, [])
    if restart is not None and restart != np.iinfo(f.idx).max:
        lists = []  # rewritten or narrowed with the pool (checked above)
    for name in lists:
        arr = getattr(eng, name)
        at = eng.file_offset(arr)
        assert arr.dtype == f.idx and at is not None and at % 4 == 0, name


def _table_values_max(f: em.SwpmFile) -> int:
    """The largest value of the arrays spec §1 types ``off``: windows, records, change offsets, RCNT, level
    tables (the lists after the level tables are ``idx``)."""
    a = f.arrays
    parts = [a.get(k) for k in ("windows", "records", "change_offsets", "record_counts")]
    if f.encoding == "sliding-window":
        parts.append(a["window_index_counts"])
    for name, arr in a.get("levels", {}).items():
        if name.startswith("level_") and name.endswith(("_start", "_lod")):
            parts.append(arr)
    return max(int(np.max(p)) for p in parts if p is not None and np.size(p))


@pytest.mark.parametrize("i", range(len(CASES)), ids=IDS)
def test_the_writer_takes_the_narrowest_types(i: int) -> None:
    """§1: idx is u32 only from 65,536 vertices on (or a value of the uploaded arrays past 65,535); off is u32
    (INDEX32, else OFFSET32) exactly when a table value needs it; never OFFSET32 with INDEX32."""
    _, data = built(i)
    f, eng = loaded(i)
    assert f.W == (4 if f.V > 0xFFFF else 2)
    wide = _table_values_max(f) > 0xFFFF
    assert bool(f.features & em.OFFSET32) == (wide and f.W == 2)
    assert f.O == (4 if wide or f.W == 4 else 2)
    assert not (f.features & em.OFFSET32 and f.features & em.INDEX32)


OFFSET32_CASES = [
    i
    for i, c in enumerate(CASES)
    if c
    in (
        ("stanford-bunny.obj", "sliding-window", {}),
        ("stanford-bunny.obj", "sliding-window", {"primitive": "strip"}),
        ("bob.obj", "skip-strip", {}),
    )
]


@pytest.mark.parametrize("i", OFFSET32_CASES, ids=lambda i: IDS[i])
def test_offset32_pool_uploads_as_u16(i: int) -> None:
    """An OFFSET32 file (bunny's sliding-window pools of 1.1 M and 0.7 M indices, bob's skip-strip levels):
    the pool is a u16 view of INDX, strips restart at 0xFFFF (what WebGL 2 and OpenGL ES 3 restart at), and
    the tables, read in u32, address elements past 65,535; every LOD draws under its vertex count."""
    pm, data = built(i)
    f, eng = loaded(i)
    assert f.features & em.OFFSET32 and not f.features & em.INDEX32
    assert (f.W, f.O, f.idx, f.off) == (2, 4, np.uint16, np.uint32)
    assert eng.pool.dtype == np.uint16 and not eng.notes
    assert eng.file_offset(eng.pool) == f.chunks["INDX"].offset, "zero-copy upload"
    assert len(eng.pool) > 0xFFFF, "the pool is longer than u16 offsets reach"
    hdr = struct.unpack_from("<I", data, 20)[0]
    assert hdr == f.features
    if f.encoding == "sliding-window":
        ends = f.arrays["windows"][:, 0] + f.arrays["window_index_counts"]
        assert int(ends.max()) > 0xFFFF
        assert f.chunks["WREC"].length == (4 if f.features & em.SW_STRIPS else 3) * 4 * f.L
    else:
        assert int(f.arrays["levels"]["level_index_start"][-1]) > 0xFFFF
        assert eng.collapsed.dtype == np.uint16 and eng.file_offset(eng.collapsed) is not None
    restart = f.arrays.get("restart_index")
    strips = f.arrays.get("primitive", "strip" if f.features & em.SW_STRIPS else "list") == "strip"
    if strips:
        assert restart == 0xFFFF and f.params["restart_index"] == 0xFFFF
        assert np.any(eng.pool == 0xFFFF)
    else:
        assert restart is None and not np.any(eng.pool == 0xFFFF)
    inst = None if f.encoding == "sliding-window" else eng.instance()
    for k in lods_to_check(f.L, True):
        ds = draws_at(eng, inst, k)
        assert all(d.buffer.dtype == np.uint16 and d.max_vertex() < f.vertex_counts[k] for d in ds), k
        assert len(em.drawn_triangles(ds)) == f.triangle_counts[k], k


def product_indices(inst: object) -> np.ndarray:
    """What the product's runtime instance draws now (vanilla, skip-strip: one list; mixed: two draws)."""
    if hasattr(inst, "draw_calls"):
        return np.concatenate([c[1] for c in inst.draw_calls()])
    return np.asarray(inst.indices())


@pytest.mark.parametrize(
    "i", [i for i, c in enumerate(CASES) if c[1] != "sliding-window"], ids=lambda i: IDS[i]
)
def test_instance_random_jumps_end_where_a_fresh_one_would(i: int) -> None:
    pm, data = built(i)
    f, eng = loaded(i)
    rng = np.random.default_rng(185 + i)
    inst = eng.instance()
    inst.set_lod(0)
    product = pm.instance()
    buf, addr = inst.buf, inst.buf.ctypes.data
    k = 0
    for step in range(40):
        if step % 2:
            k = int(rng.integers(0, f.L))  # a jump of many LODs, either way
        else:
            k = int(np.clip(k + rng.integers(-6, 7), 0, f.L - 1))  # a few LODs, either way
        inst.set_lod(k)
        fresh = eng.instance()
        fresh.set_lod(k)
        got, want = inst.draws(), fresh.draws()
        assert len(got) == len(want)
        for g, w in zip(got, want, strict=True):
            assert np.array_equal(g.indices, w.indices), f"step {step}: LOD {k}"
            assert g.max_vertex() < f.vertex_counts[k]
        if step % 8 == 0:
            assert same_oriented(em.drawn_triangles(got), np.asarray(pm.triangles_at(k)))
        # the product's own instance, walked the same way, holds the same indices (restarts as uploaded)
        product.set_lod(k)
        mine = np.concatenate([d.indices.astype(np.int64) for d in got])
        theirs = product_indices(product).astype(np.int64)
        restart = f.arrays.get("restart_index")
        if restart is not None:
            theirs[theirs == restart] = np.iinfo(got[0].buffer.dtype).max
        assert np.array_equal(mine, theirs), f"step {step}: LOD {k}"
    # no per-frame allocation: the instance's index buffer is the one it was created with
    assert inst.buf is buf and inst.buf.ctypes.data == addr


@pytest.mark.parametrize(
    "i",
    [i for i, c in enumerate(CASES) if c[0] != "stanford-bunny.obj" or c[1] == "sliding-window"],
    ids=lambda i: IDS[i],
)
def test_streaming_prefixes_draw_the_coarse_lods(i: int) -> None:
    """§2.3 and §4: chunks in streaming order, the prefix a LOD needs shrinks with k, and every SMAP band's
    prefix_length bytes (a single range holding each hull) draw the band's LODs as the whole file does."""
    pm, data = built(i)
    f, eng = loaded(i)
    order = [c.type for c in f.table]
    assert order == [t for t in em.STREAM_ORDER[f.encoding] if t in order] and order[-1] == "VERT"
    need = [max(r[1] for r in f.needed_ranges(k) if r is not None) for k in range(f.L)]
    assert all(a >= b for a, b in zip(need, need[1:], strict=False)), "coarser LODs need no more bytes"
    bands = f.smap()
    assert bands and bands[0][0] == 0 and sum(b[1] for b in bands) == f.L
    # §4: writers form one band per halving of the vertex count, floor(log2(V / vertex_count(k)))
    halving = np.floor(np.log2(f.V / f.vertex_counts.astype(np.float64))).astype(int)
    assert [int(halving[b[0]]) for b in bands] == sorted(set(halving.tolist()))
    assert all(np.all(halving[b[0] : b[0] + b[1]] == halving[b[0]]) for b in bands)
    inst_full = None if f.encoding == "sliding-window" else eng.instance()
    for first, count, ranges, prefix in bands:
        lods = range(first, first + count)
        hulls = []
        for part in range(3):
            spans = [r for r in (f.needed_ranges(k)[part] for k in lods) if r is not None]
            if spans:  # an LOD that needs no INDX element adds nothing to the (b) hull
                hulls.append((min(r[0] for r in spans), max(r[1] for r in spans)))
        for lo, hi in hulls:
            assert any(a <= lo and hi <= b for a, b in ranges), f"band at LOD {first}: hull {lo}-{hi}"
        assert prefix == max(hi for _, hi in hulls)
        g, geng = em.load(data[:prefix], streaming=True)
        ginst = None if g.encoding == "sliding-window" else geng.instance()
        for k in sorted({first, first + count // 2, first + count - 1}):
            assert geng.can_draw(k)
            got = em.drawn_triangles(draws_at(geng, ginst, k))
            assert same_oriented(got, em.drawn_triangles(draws_at(eng, inst_full, k))), f"LOD {k}"
        if first > 0:
            assert not geng.can_draw(first - 1) or f.vertex_counts[first - 1] == f.vertex_counts[first]
    # the coarsest LOD from exactly the bytes it needs; one byte fewer misses a vertex it binds
    k = f.L - 1
    g, geng = em.load(data[: need[k]], streaming=True)
    assert geng.can_draw(k)
    g, geng = em.load(data[: need[k] - 1], streaming=True)
    assert not geng.can_draw(k)


def _vectors() -> list[dict]:
    return json.loads((VECTORS / "manifest.json").read_text())["vectors"]


@pytest.mark.parametrize("v", _vectors(), ids=lambda v: v["name"])
def test_conformance_vector_verdict(v: dict) -> None:
    data = (VECTORS / v["file"]).read_bytes()
    expected = json.loads((VECTORS / v["expected"]).read_text())
    errors = {p["code"] for p in expected["problems"] if p["severity"] == "error"}
    assert len(_vectors()) == 116  # (long-header, smap-two-bands: 4.1 prefix cases; 10 for 4.2 range cases)
    if v["valid"]:
        f, eng = em.load(data)
        inst = None if f.encoding == "sliding-window" else eng.instance()
        for k in range(f.L):
            ds = draws_at(eng, inst, k)
            assert all(d.max_vertex() < f.vertex_counts[k] for d in ds)
            assert len(em.drawn_triangles(ds)) == f.triangle_counts[k]
    else:
        with pytest.raises(em.EngineLoadError) as exc:
            em.load(data)
        assert exc.value.code in errors


def test_strip_parity_matters() -> None:
    """The comparison can fail: a strip read with the wrong parity gives the other winding."""
    s = np.array([0, 1, 2, 3, 0xFFFF, 4, 5, 6], np.uint16)
    vk = em.strip_triangles(s, 0xFFFF)
    gl = em.strip_triangles(s, 0xFFFF, opengl=True)
    assert same_oriented(vk, gl)
    assert same_oriented(vk, np.array([[0, 1, 2], [2, 1, 3], [4, 5, 6]]))
    assert not same_oriented(vk, np.array([[0, 1, 2], [1, 2, 3], [4, 5, 6]]))
    # no restart: the strip runs through 0xFFFF's place as a vertex
    assert len(em.strip_triangles(s, None)) == 6


@pytest.mark.parametrize(
    "i", [i for i, c in enumerate(CASES) if c[1] in ("skip-strip", "mixed")], ids=lambda i: IDS[i]
)
def test_level_switch_draws_what_the_previous_level_ended_on(i: int) -> None:
    """§3.7 (writers MUST, readers do not check): level l's list holds the non-degenerate triangles of level
    l-1's collapsed list, so an engine switching levels at LOD level_first_lod[l] draws no pop. Mixed levels
    are "as skip-strip" (§3.8): both lists together."""
    f, eng = loaded(i)
    lv = f.arrays["levels"]
    n = len(lv["level_first_lod"])
    assert n >= 2, "the case has several levels"
    for l in range(1, n):
        if f.encoding == "skip-strip":
            a, b = int(lv["level_index_start"][l - 1]), int(lv["level_index_start"][l])
            c = int(lv["level_index_start"][l + 1])
            topo = "strip" if f.arrays["primitive"] == "strip" else "list"
            before = em.Draw(eng.collapsed, a, b - a, topo, f.V).rasterise()
            after = em.Draw(eng.pool, b, c - b, topo, f.V).rasterise()
        else:
            sst, dst, rst = lv["level_static_start"], lv["level_dynamic_start"], lv["level_record_start"]
            rec = f.arrays["records"]
            r0, r1 = int(rst[l - 1]), int(rst[l])
            s_live = (int(sst[l] - sst[l - 1])) // 3 - int(rec[r0:r1, 1].sum())
            d_live = (int(dst[l] - dst[l - 1])) // 3 - int(rec[r0:r1, 2].sum())
            before = em.drawn_triangles(
                [
                    em.Draw(eng.dyn_collapsed, int(dst[l - 1]), 3 * d_live, "list", f.V),
                    em.Draw(eng.pool, int(sst[l - 1]), 3 * s_live, "list", f.V),
                ]
            )
            after = em.drawn_triangles(
                [
                    em.Draw(eng.dyn, int(dst[l]), int(dst[l + 1] - dst[l]), "list", f.V),
                    em.Draw(eng.pool, int(sst[l]), int(sst[l + 1] - sst[l]), "list", f.V),
                ]
            )
        assert same_oriented(before, after), f"level {l}"


def _fix_crcs(d: bytearray) -> bytes:
    """Recompute every chunk CRC and the file CRC (a mutation then reaches the checks behind them)."""
    chunk_count = struct.unpack_from("<I", d, 24)[0]
    table = struct.unpack_from("<Q", d, 32)[0]
    for e in range(table, table + 32 * chunk_count, 32):
        off, length = struct.unpack_from("<QQ", d, e + 8)
        struct.pack_into(
            "<I", d, e + 24, zlib.crc32(bytes(d[off : off + length]), zlib.crc32(bytes(d[e : e + 4])))
        )
    head = bytearray(d[: table + 32 * chunk_count])
    head[48:52] = bytes(4)
    struct.pack_into("<I", d, 48, zlib.crc32(head))
    return bytes(d)


SUZANNE = [i for i, c in enumerate(CASES) if c[0] == "suzanne.obj"]


@pytest.mark.parametrize(
    ("i", "offset32"),
    [pytest.param(i, o, id=IDS[i] + ("-offset32" if o else "")) for i in SUZANNE for o in (False, True)],
)
def test_model_and_product_validator_agree_on_mutated_files(i: int, offset32: bool) -> None:
    """One table or index value changed (CRCs fixed up): the engine refuses exactly the files the product's
    validator finds an error in, so an engine may trust what the validator passes, and nothing else. Also on
    the file rewritten as OFFSET32 (tests/offset32_transcode.py: u16 lists, u32 tables)."""
    from offset32_transcode import to_offset32

    from swpm_usd.format.reader import validate_bytes

    _, data = built(i)
    if offset32:
        data = to_offset32(data)
        f = em.load(data)[0]
    else:
        f, _ = loaded(i)
    rng = np.random.default_rng(1850 + i + 1000 * offset32)
    refused = 0
    for _ in range(30):
        t = str(rng.choice([c for c in f.chunks if c not in ("META", "SMAP", "VERT")]))
        c = f.chunks[t]
        # LODS u32; INDX idx; the tables off (SKIP/MLVL's idx lists after them are hit as O-byte values)
        size = 4 if t == "LODS" else (f.W if t == "INDX" else f.O)
        fmt = "<H" if size == 2 else "<I"
        pos = c.offset + size * int(rng.integers(0, c.length // size))
        old = struct.unpack_from(fmt, data, pos)[0]
        new = int(rng.choice([old + 1, old - 1, old + 3, 0, f.V - 1, f.V, int(rng.integers(0, f.V))]))
        new &= 0xFFFF if fmt == "<H" else 0xFFFFFFFF
        d = bytearray(data)
        struct.pack_into(fmt, d, pos, new)
        mutated = _fix_crcs(d)
        try:
            em.load(mutated)
            accepted = True
        except em.EngineLoadError:
            accepted, refused = False, refused + 1
        assert accepted == validate_bytes(mutated).valid, f"{t} +{pos - c.offset}: {old} -> {new}"
    assert refused > 0


@pytest.mark.parametrize(
    "i", [i for i, c in enumerate(CASES) if c[0] in ("suzanne.obj", "spot.obj")], ids=lambda i: IDS[i]
)
def test_offset32_rewrite_draws_the_same(i: int) -> None:
    """The product's file rewritten as OFFSET32 (tests/offset32_transcode.py, from the spec alone: u16 idx,
    u32 tables) loads with every list the GPU takes a u16 view of the file and draws every LOD as before."""
    from offset32_transcode import to_offset32

    pm, data = built(i)
    f, eng = em.load(to_offset32(data))
    assert (f.W, f.O) == (2, 4) and f.features & em.OFFSET32
    assert eng.pool.dtype == np.uint16 and eng.file_offset(eng.pool) == f.chunks["INDX"].offset
    for name in {"skip-strip": ["collapsed"], "mixed": ["dyn", "dyn_collapsed"]}.get(f.encoding, []):
        assert getattr(eng, name).dtype == np.uint16 and eng.file_offset(getattr(eng, name)) is not None
    inst = None if f.encoding == "sliding-window" else eng.instance()
    for k in lods_to_check(f.L, False):
        drawn = em.drawn_triangles(draws_at(eng, inst, k))
        assert same_oriented(drawn, np.asarray(pm.triangles_at(k))), f"LOD {k}"
