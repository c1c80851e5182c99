"""A strips' restart index is all ones of the file's index type (spec/format.md 3.5, 3.7): 0xFFFF in a u16
file, 0xFFFFFFFF in a u32 one, decided by the format writer's width rule (``layout.restart_index_for``), so an
engine uploads ``INDX`` as it is with the restart value Vulkan, D3D12 and Metal take. Sliding-window and
skip-strip strips on meshes whose tables need u32 (bunny; bob, whose 5,647 vertices fit u16 but whose pools'
offsets do not: OFFSET32 since 0.9.0, ``idx`` and the restart stay u16) and on one whose file is all u16
(suzanne), through the format reader and USD; and files of the writers before 0.8.0 (0xFFFF in a u32 file)
and before 0.9.0 (0xFFFFFFFF in a u32 file, ``legacy``) saved again."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT, shared_mesh

import swpm_usd
from swpm_usd.format import layout as L
from swpm_usd.format.reader import load_bytes
from swpm_usd.format.writer import choose_index_width, encode_bytes

#: (mesh, encoding, build parameters, the arrays holding strips)
CASES = {
    "bunny-sliding-strip": ("stanford-bunny.obj", "sliding-window", {"primitive": "strip"}, ("index_pool",)),
    "bob-sliding-strip": ("bob.obj", "sliding-window", {"primitive": "strip"}, ("index_pool",)),
    "bob-skip-strip": ("bob.obj", "skip-strip", {}, ("level_indices", "level_collapsed_indices")),
    "suzanne-sliding-strip": ("suzanne.obj", "sliding-window", {"primitive": "strip"}, ("index_pool",)),
    "suzanne-skip-strip": ("suzanne.obj", "skip-strip", {}, ("level_indices", "level_collapsed_indices")),
}
#: the restart each case must get: 0xFFFF, all ones of idx, u16 in every case (fewer than 65,536 vertices)
EXPECTED = {
    "bunny-sliding-strip": 0xFFFF,
    "bob-sliding-strip": 0xFFFF,
    "bob-skip-strip": 0xFFFF,
    "suzanne-sliding-strip": 0xFFFF,
    "suzanne-skip-strip": 0xFFFF,
}
#: the cases whose tables need u32 (a pool or level lists longer than 65,535 indices): OFFSET32
OFFSET32 = {"bunny-sliding-strip", "bob-sliding-strip", "bob-skip-strip"}


@pytest.fixture(scope="module", params=list(CASES))
def case(request):
    mesh, enc, kw, lists = CASES[request.param]
    return request.param, swpm_usd.build(shared_mesh(mesh), encoding=enc, **kw), lists


def test_the_restart_index_is_all_ones_of_the_file_index_type(case) -> None:
    name, pm, lists = case
    rv = EXPECTED[name]
    W = 2 if rv == 0xFFFF else 4
    assert pm.restart_index == pm.params["restart_index"] == rv
    assert choose_index_width(L.index_buffers(pm.buffers()), pm.vertex_count) == W
    assert L.choose_offset_width(pm.buffers()) == (4 if name in OFFSET32 else 2)
    # every vertex id fits u16 (fewer than 65,535 vertices); the pool's length widens only the tables
    assert pm.vertex_count <= 0xFFFF
    assert (max(int(pm.buffers()[n].shape[0]) for n in lists) > 0xFFFF) == (name in OFFSET32)
    data = encode_bytes(pm)
    features = int(np.frombuffer(data[: L.HEADER_SIZE], L.HEADER)[0]["features"])
    assert bool(features & L.FEATURE_INDEX32) == (W == 4)
    assert bool(features & L.FEATURE_OFFSET32) == (name in OFFSET32)
    back = load_bytes(data)
    assert back.restart_index == back.params["restart_index"] == rv
    for n in lists:
        stored = np.asarray(getattr(back, n))
        assert stored.dtype.itemsize == W  # the file's idx, as the reader exposes it
        restarts = stored == rv
        assert restarts.any() and np.all(restarts | (stored < pm.vertex_count)), n
        assert np.array_equal(stored, getattr(pm, n)), n
    for k in range(0, pm.lod_count, max(1, pm.lod_count // 20)):
        assert np.array_equal(back.triangles_at(k), pm.triangles_at(k)), k


def test_the_restart_index_round_trips_through_usd(case, tmp_path) -> None:
    """USD stores the restart index as it is in a uint[] array; swpm:indexWidth is the width an engine draws
    at, 2 while vertex ids fit u16 (``layout.draw_index_width``), whatever the file's width (4 beside
    0xFFFFFFFF, the stored u32 values drawn as they are, is accepted too: checked by the older file in
    :func:`test_resaving_an_older_file_writes_restart_all_ones`), and the stage validates clean."""
    from pxr import Usd

    from swpm_usd import usd
    from swpm_usd.usd.validate import validate_stage

    name, pm, lists = case
    path = usd.write(pm, tmp_path / f"{name}.usdc")
    assert validate_stage(path, builtin=False) == []
    stage = Usd.Stage.Open(str(path))
    prim = usd.find_encoded(stage)[0]
    width = prim.GetAttribute("swpm:indexWidth")
    assert width.Get() == L.draw_index_width(pm.vertex_count, pm.restart_index) == 2
    back = usd.read(prim)
    assert back.restart_index == back.params["restart_index"] == EXPECTED[name]
    for n in lists:
        assert np.array_equal(np.asarray(getattr(back, n)), getattr(pm, n)), n
    last = pm.lod_count - 1
    assert np.array_equal(back.triangles_at(last), pm.triangles_at(last))
    for w, ok in ((4, EXPECTED[name] == 0xFFFFFFFF), (3, False)):  # 4 beside 0xFFFFFFFF: drawn as stored
        width.Set(w)
        found = [f.code for f in validate_stage(stage, builtin=False)]
        assert found == ([] if ok else ["SWPM_USD_INDEX_WIDTH"]), (name, w)


def _strip_window(pool: list[int], V: int, first: int = 0):
    """A one-LOD sliding-window strip pool of ``V`` vertices whose window starts at ``first``, restart index
    0xFFFFFFFF (the value a build joins strips with until the file's width is known)."""
    from swpm_usd.encode.sw_mesh import SlidingWindowProgressiveMesh

    return SlidingWindowProgressiveMesh(
        np.zeros((V, 3), np.float32),
        {},
        np.array([V]),
        np.array([1]),
        np.zeros(1, np.float32),
        index_pool=np.array(pool, np.uint32),
        window_records=np.array([[first, 1, V]], np.uint32),
        params={"primitive": "strip", "restart_index": 0xFFFFFFFF},
        window_index_counts=np.array([len(pool) - first], np.uint32),
    )


@pytest.mark.parametrize(
    ("pool", "V", "first", "rv"),
    [
        ([0, 1, 2], 3, 0, 0xFFFF),  # everything fits u16: 0xFFFFFFFF itself does not make the file u32
        ([0, 1, 2, 0xFFFFFFFF, 0, 1, 2], 3, 4, 0xFFFF),
        ([0, 1, 2], 0x10000, 0, 0xFFFFFFFF),  # a vertex count of 65,536: a u32 file (0xFFFF a vertex id)
        # an offset past 65,535 widens the tables (OFFSET32), not idx (since 0.9.0)
        ([0xFFFFFFFF] * 0x10000 + [0, 1, 2], 3, 0x10000, 0xFFFF),
    ],
)
def test_settle_restart_follows_the_writer_width(pool, V, first, rv) -> None:
    """``settle_restart`` keeps 0xFFFFFFFF exactly when the writer then writes u32, rewriting the pool's
    restart entries otherwise; the file written holds the chosen value and reads back."""
    from swpm_usd.encode.skipstrip import settle_restart
    from swpm_usd.format.layout import restart_index_for

    pm = _strip_window(pool, V, first)
    assert restart_index_for(pm.buffers(), 0xFFFFFFFF, V) == rv
    settle_restart(pm, ("index_pool",))
    assert pm.restart_index == pm.params["restart_index"] == rv
    restarts = np.asarray(pool, np.int64) == 0xFFFFFFFF
    assert np.array_equal(pm.index_pool == rv, restarts)
    assert choose_index_width(L.index_buffers(pm.buffers()), V) == (2 if rv == 0xFFFF else 4)
    back = load_bytes(encode_bytes(pm))
    assert back.restart_index == rv and np.array_equal(back.index_pool, pm.index_pool)
    assert back.triangles_at(0).tolist() == [[0, 1, 2]]


def test_a_restart_of_0xffff_is_never_a_vertex() -> None:
    """At 65,536 vertices every vertex id and every other value may fit u16 (a skip-strip's buffers hold no
    vertex count), but 0xFFFF is vertex 65,535: the restart index is 0xFFFFFFFF and the file u32."""
    from swpm_usd.format.layout import restart_index_for

    R = 0xFFFFFFFF
    top = np.array([0, 1, 0xFFFF, R, 2, 3, 4], np.uint32)  # vertex 65,535 in a strip
    assert restart_index_for({"level_indices": top}, R, 0x10000) == R
    below = np.array([0, 1, 0xFFFE, R, 2, 3, 4], np.uint32)  # 65,535 vertices: 0xFFFF is no vertex
    assert restart_index_for({"level_indices": below}, R, 0xFFFF) == 0xFFFF
    # an offset past 65,535 makes the tables u32 (OFFSET32), not idx: the restart stays u16's (since 0.9.0)
    start = np.array([0, 0x10000], np.uint32)
    assert restart_index_for({"level_indices": below, "level_index_start": start}, R, 9) == 0xFFFF


def test_an_older_u32_file_with_restart_0xffff_still_reads() -> None:
    """A writer before 0.8.0 wrote 0xFFFF in a u32 file (``keep_restart_index``, as the vector generator
    writes it): the reader keeps accepting any restart >= V."""
    from swpm_usd.format.vectors import fan_sliding_strips

    old = encode_bytes(fan_sliding_strips(), index_width=4, keep_restart_index=True)
    back = load_bytes(old)
    assert back.restart_index == 0xFFFF and np.asarray(back.index_pool).dtype.itemsize == 4
    new = load_bytes(encode_bytes(fan_sliding_strips(0xFFFFFFFF), index_width=4))
    assert new.restart_index == 0xFFFFFFFF
    for k in range(back.lod_count):
        assert np.array_equal(back.triangles_at(k), new.triangles_at(k))


def _with_restart(pm, lists, value: int):
    """``pm``'s strips joined by ``value``: 0xFFFFFFFF as a build before 0.9.0 joined bunny's and bob's (the
    file u32 through the pool's offsets), 0xFFFF as any build of these meshes did before 0.8.0."""
    b = {n: np.asarray(a) for n, a in pm.buffers().items()}
    for n in lists:
        b[n] = np.where(b[n] == pm.restart_index, value, b[n]).astype(np.uint32)
    params = {**pm.params, "restart_index": value}
    return swpm_usd.from_buffers(
        pm.encoding, pm.points, pm.attributes, pm.vertex_counts, pm.triangle_counts, pm.lod_errors, b, params
    )


def test_memory_figures_do_not_depend_on_the_restart_value(case) -> None:
    """An engine draws strips of vertex ids below 65,535 from u16 indices whichever all ones joins them (a
    u32 -> u16 copy turns 0xFFFFFFFF into 0xFFFF), as it draws a list pool: the memory figures count 2 bytes
    an index for both (counted at 4 bytes for strips joined by 0xFFFFFFFF, as a build before 0.9.0 joined
    bob's, its strip pool, a third smaller than its list pool, would come out larger)."""
    name, pm, lists = case
    old = _with_restart(pm, lists, 0xFFFFFFFF)
    assert (pm.global_bytes, pm.instance_bytes) == (old.global_bytes, old.instance_bytes), name
    n = sum(int(getattr(pm, x).shape[0]) for x in lists)
    if pm.encoding == "skip-strip":
        longest = int(np.max(np.diff(pm.level_index_start)))
        assert pm.instance_bytes == 2 * longest + 16
    else:
        assert pm.global_bytes - pm.vertex_bytes() - 2 * n in (8 * pm.lod_count, 12 * pm.lod_count)


@pytest.mark.parametrize(
    ("V", "restart", "width"),
    [
        (3, None, 2),
        (0xFFFF, None, 2),  # a list: vertex ids up to 65,534 fit u16
        (0x10000, None, 4),  # vertex 65,535 would be u16's 0xFFFF, where WebGL 2 always restarts (spec 1)
        (0x10001, None, 4),
        (3, 0xFFFF, 2),
        (3, 0xFFFFFFFF, 2),  # narrows to u16's all ones
        (0xFFFF, 0xFFFFFFFF, 2),
        (0x10000, 0xFFFFFFFF, 4),  # 0xFFFF is vertex 65,535: no u16 restart left
        (3, 0x10000, 4),  # a restart index a u16 copy cannot keep
    ],
)
def test_draw_index_width(V, restart, width) -> None:
    assert L.draw_index_width(V, restart) == width


def _list_window(V: int):
    from swpm_usd.encode.sw_mesh import SlidingWindowProgressiveMesh

    return SlidingWindowProgressiveMesh(
        np.zeros((V, 3), np.float32),
        {},
        np.array([V]),
        np.array([1]),
        np.zeros(1, np.float32),
        index_pool=np.array([0, 1, 2], np.uint32),
        window_records=np.array([[0, 1, V]], np.uint32),
        params={"primitive": "list"},
    )


@pytest.mark.parametrize(
    ("pm", "isz"),
    [
        (_list_window(0xFFFF), 2),  # vertex ids up to 65,534: u16
        (_list_window(0x10000), 4),  # vertex 65,535 is no u16 index (spec 1): global_bytes counts 4 too
        (_list_window(0x10001), 4),
        (_strip_window([0, 1, 2], 3), 2),  # joined by 0xFFFFFFFF, drawn from u16
        (_strip_window([0, 1, 2], 0x10000), 4),
    ],
)
def test_the_coarsest_lod_bytes_use_the_draw_width(pm, isz) -> None:
    """The pipeline's ``streaming.coarsest_lod_bytes`` counts the coarsest LOD's indices at the width
    ``global_bytes`` counts (:func:`layout.draw_index_width`), not from the vertex count alone."""
    from swpm_usd.pipeline.worker import check_streaming

    need = pm.vertex_count * 12 + 3 * isz
    assert check_streaming(pm, {"coarsest_lod_bytes": need}) == []
    assert "coarsest LOD needs" in check_streaming(pm, {"coarsest_lod_bytes": need - 1})[0]


def test_settle_restart_leaves_the_arrays_it_was_given_alone() -> None:
    """``settle_restart`` rebinds the strips it rewrites: an array the mesh shares with its caller (as
    ``from_buffers`` keeps them), or a read-only one (a file's), is not written (it was, in place)."""
    from swpm_usd.encode.skipstrip import settle_restart

    pm = _strip_window([0, 1, 2], 3)
    given = pm.index_pool
    given.setflags(write=False)
    settle_restart(pm, ("index_pool",))
    assert pm.restart_index == 0xFFFF and pm.index_pool.tolist() == [0, 1, 2]
    shared = np.array([0, 1, 2, 0xFFFFFFFF, 0, 1, 2], np.uint32)
    pm = _strip_window(shared.tolist(), 3, 4)
    pm.index_pool = shared
    settle_restart(pm, ("index_pool",))
    assert pm.index_pool.tolist() == [0, 1, 2, 0xFFFF, 0, 1, 2] and pm.index_pool.dtype == np.uint32
    assert shared[3] == 0xFFFFFFFF


@pytest.mark.parametrize(
    ("raw", "width"),
    [
        ("sliding-list-ignored-restart", 2),  # a list pool's restart_index is ignored (spec 3.5)
        ("skip-strip-no-primitive", 4),  # skip-strip's missing primitive reads as "strip": 70,000 restarts
        ("sliding-strips-u32", 2),
    ],
)
def test_index_values_width_reads_a_restart_only_where_strips_use_it(raw, width) -> None:
    from swpm_usd.format import vectors as vec
    from swpm_usd.format.reader import validate_bytes

    if raw == "sliding-list-ignored-restart":
        pm = vec.fan_sliding()
        pm.params["restart_index"] = 70000
    elif raw == "skip-strip-no-primitive":
        pm = vec.fan_skip_strip(70000)
        del pm.params["primitive"]
    else:
        pm = vec.fan_sliding_strips(0xFFFFFFFF)
    # (kept as given: the writer would write 70,000 as 0xFFFF, all ones of the file's u16)
    rep = validate_bytes(encode_bytes(pm, keep_restart_index=True))
    assert rep.valid, rep.format()
    assert rep.summary["index_width"] == (2 if raw == "sliding-list-ignored-restart" else 4)
    assert rep.summary["index_values_width"] == width


VECTOR_FFFF = ROOT / "spec/vectors/valid/sliding-window-strips-u32-restart-ffff.swpm"


def _assert_resaved(old, data: bytes, rv: int) -> None:
    """``data``, ``old`` (strips joined by its restart index) as the writer saved it: a clean file whose index
    type's all ones ``rv`` joins the strips exactly where ``old``'s restart did, every LOD drawing ``old``'s
    triangles."""
    from swpm_usd.format.reader import validate_bytes
    from swpm_usd.format.writer import STRIP_ARRAYS

    features = int(np.frombuffer(data[: L.HEADER_SIZE], L.HEADER)[0]["features"])
    assert bool(features & L.FEATURE_INDEX32) == (rv == 0xFFFFFFFF)
    rep = validate_bytes(data)
    assert rep.valid and not rep.problems, rep.format()
    back = load_bytes(data)
    assert back.restart_index == back.params["restart_index"] == rv
    for n in STRIP_ARRAYS[old.encoding]:
        was, now = np.asarray(getattr(old, n)), np.asarray(getattr(back, n))
        restarts = was == old.restart_index
        assert restarts.any() and np.array_equal(now == rv, restarts), n
        assert np.array_equal(now[~restarts], was[~restarts]), n
    assert back.lod_count == old.lod_count
    for k in range(0, old.lod_count, max(1, old.lod_count // 20)):
        assert np.array_equal(back.triangles_at(k), old.triangles_at(k)), k


def test_resaving_the_older_vector_writes_restart_all_ones(tmp_path) -> None:
    """Vector ``sliding-window-strips-u32-restart-ffff`` (0xFFFF in a u32 file, a writer before 0.8.0's),
    loaded and saved in a u32 file (``index_width=4``, the width it came in), gets restart 0xFFFFFFFF (it was
    copied with its 0xFFFF); saved by ``swpm_usd.save``, whose width rule finds every value fits u16, it is a
    u16 file joined by 0xFFFF. The loaded mesh, its (mapped) arrays and params are left as they were."""
    from swpm_usd import usd

    old = swpm_usd.load(VECTOR_FFFF)
    assert old.restart_index == old.params["restart_index"] == 0xFFFF
    kept = {n: np.array(a) for n, a in old.buffers().items()}
    _assert_resaved(old, encode_bytes(old, index_width=4), 0xFFFFFFFF)
    _assert_resaved(old, swpm_usd.save(old, tmp_path / "new.swpm").read_bytes(), 0xFFFF)
    assert old.restart_index == old.params["restart_index"] == 0xFFFF
    assert all(np.array_equal(old.buffers()[n], a) for n, a in kept.items())
    # the same through USD: the stage keeps 0xFFFF in its uint[] arrays
    from pxr import Usd

    path = usd.write(old, tmp_path / "old.usdc")
    stage = Usd.Stage.Open(str(path))
    staged = usd.read(usd.find_encoded(stage)[0])
    assert staged.restart_index == 0xFFFF
    _assert_resaved(staged, encode_bytes(staged, index_width=4), 0xFFFFFFFF)


@pytest.mark.parametrize("restart", [0xFFFF, 0xFFFFFFFF])
def test_resaving_an_older_file_writes_restart_all_ones(case, restart, tmp_path) -> None:
    """A build's file as a writer before 0.9.0 wrote it (``legacy``: one width, u32 for bunny and bob, whose
    pools or level lists pass 65,535 indices), its strips joined by 0xFFFF (a writer before 0.8.0,
    ``keep_restart_index``) or 0xFFFFFFFF (0.8.0: all ones of that u32), loaded and saved by
    ``swpm_usd.save``, and the same read from a USD stage and saved: restart all ones of the new file's
    ``idx``, 0xFFFF (OFFSET32 where the tables need u32), the bytes of the build's own file. The stage of
    the older u32 file joined by 0xFFFFFFFF takes swpm:indexWidth 4 as well (drawn as stored)."""
    from pxr import Usd

    from swpm_usd import usd
    from swpm_usd.usd.validate import validate_stage

    name, pm, lists = case
    src = tmp_path / "old.swpm"
    src.write_bytes(encode_bytes(_with_restart(pm, lists, restart), keep_restart_index=True, legacy=True))
    features = int(np.frombuffer(src.read_bytes()[: L.HEADER_SIZE], L.HEADER)[0]["features"])
    # (suzanne's strips joined by 0xFFFFFFFF, which a build never made, are a u32 file through that value)
    u32 = name in OFFSET32 or restart == 0xFFFFFFFF
    assert bool(features & L.FEATURE_INDEX32) == u32 and not features & L.FEATURE_OFFSET32
    old = swpm_usd.load(src)
    assert old.restart_index == restart
    data = swpm_usd.save(old, tmp_path / "new.swpm").read_bytes()
    _assert_resaved(old, data, EXPECTED[name])
    assert data == encode_bytes(pm), name
    path = usd.write(old, tmp_path / "old.usdc")
    stage = Usd.Stage.Open(str(path))
    prim = usd.find_encoded(stage)[0]
    staged = usd.read(prim)
    assert staged.restart_index == restart
    _assert_resaved(staged, swpm_usd.save(staged, tmp_path / "usd.swpm").read_bytes(), EXPECTED[name])
    prim.GetAttribute("swpm:indexWidth").Set(4)
    found = [f.code for f in validate_stage(stage, builtin=False)]
    assert found == ([] if restart == 0xFFFFFFFF else ["SWPM_USD_INDEX_WIDTH"]), name


@pytest.mark.parametrize("restart", [0xFFFF, 0xFFFFFFFF])
def test_resaving_writes_the_bytes_of_a_new_build(case, restart) -> None:
    """A build's strips given back joined by 0xFFFF (as a writer before 0.8.0 stored them) or 0xFFFFFFFF (as
    a build before 0.9.0 joined bunny's and bob's), through ``from_buffers`` over writable arrays, are
    written byte for byte as the build itself is, the arrays given untouched."""
    name, pm, lists = case
    old = _with_restart(pm, lists, restart)
    given = {n: np.array(getattr(old, n)) for n in lists}
    assert encode_bytes(old) == encode_bytes(pm), name
    assert old.restart_index == restart and all(np.array_equal(getattr(old, n), given[n]) for n in lists)


def test_a_restart_of_a_u16_file_is_written_0xffff() -> None:
    """Another restart index >= V in a u16 file (5 among 5 vertices: valid, not all ones) is written as
    0xFFFF; ``keep_restart_index`` writes it as it is."""
    from swpm_usd.format.vectors import fan_sliding_strips

    kept = load_bytes(encode_bytes(fan_sliding_strips(5), keep_restart_index=True))
    assert kept.restart_index == 5 and np.asarray(kept.index_pool).dtype.itemsize == 2
    back = load_bytes(encode_bytes(kept))
    assert back.restart_index == back.params["restart_index"] == 0xFFFF
    assert np.array_equal(np.asarray(back.index_pool) == 0xFFFF, np.asarray(kept.index_pool) == 5)
    for k in range(back.lod_count):
        assert np.array_equal(back.triangles_at(k), kept.triangles_at(k)), k
