"""Multilevel skip strips / skip lists: stripifier, random LOD walks against the reference triangle sets,
level switching, degenerate budget, vertex prefix and the buffer contract."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from conftest import shared_sequence
from hypothesis import given, settings
from hypothesis import strategies as st

import swpm_usd
from swpm_usd.encode.instance import apply_records as _apply
from swpm_usd.encode.skipstrip import (
    SkipStripProgressiveMesh,
    _nondegenerate,
    build_skipstrip,
    cache_order,
    vertex_order,
)
from swpm_usd.encode.strips import decode_strip, stripify
from swpm_usd.metrics import cache_misses

MESH = "cow.obj"
VARIANTS = {
    "strip-restart": {"primitive": "strip", "restart": True},
    "strip-degenerate": {"primitive": "strip", "restart": False},
    "list": {"primitive": "list"},
}


def _canonical(tris: np.ndarray) -> np.ndarray:
    """Rows rotated so the smallest index comes first (keeps winding), then sorted."""
    tris = np.asarray(tris, np.int64).reshape(-1, 3)
    r = np.argmin(tris, axis=1)
    idx = (np.arange(3)[None, :] + r[:, None]) % 3
    rot = np.take_along_axis(tris, idx, axis=1)
    return rot[np.lexsort(rot.T[::-1])]


@cache
def _case(variant: str) -> tuple[SkipStripProgressiveMesh, np.ndarray]:
    seq = shared_sequence(MESH)
    pm = build_skipstrip(seq, **VARIANTS[variant])
    new_id, _ = vertex_order(seq)
    return pm, new_id


def _reference(k: int) -> np.ndarray:
    seq = shared_sequence(MESH)
    new_id = vertex_order(seq)[0]
    return _canonical(new_id[seq.triangles_at_step(k)])


# --------------------------------------------------------------------------------------------------------
# stripifier
# --------------------------------------------------------------------------------------------------------


@st.composite
def _triangle_sets(draw: st.DrawFn) -> tuple[np.ndarray, int]:
    V = draw(st.integers(3, 12))
    n = draw(st.integers(0, 40))
    rows = []
    for _ in range(n):
        how = draw(st.sampled_from(["new", "new", "copy", "flip"])) if rows else "new"
        if how == "new":
            a, b, c = draw(st.lists(st.integers(0, V - 1), min_size=3, max_size=3, unique=True))
        else:  # a duplicate, or the other winding of an earlier triangle (all three vertices shared)
            a, b, c = rows[draw(st.integers(0, len(rows) - 1))]
            if how == "flip":
                b, c = c, b
        rows.append((a, b, c))
    return np.array(rows, np.int64).reshape(-1, 3), V


@settings(max_examples=150, deadline=None)
@given(_triangle_sets(), st.booleans(), st.sampled_from([1, 2, 3, 4, 5, 8, 16, 64]))
def test_strip_decodes_to_input_with_winding(
    case: tuple[np.ndarray, int], restart: bool, window: int
) -> None:
    tris, V = case
    rv = 0xFFFF if restart else None
    s = stripify(tris, V, rv, window)
    assert len(s) <= 5 * len(tris)  # the kernel's buffer: a join 2 + 3 indices, a swap 2
    assert np.array_equal(_canonical(decode_strip(s, rv)), _canonical(tris))
    if not restart:  # every extra triangle is a degenerate join
        allt = decode_strip(s, None, keep_degenerate=True)
        assert len(_nondegenerate(allt)) == len(tris)


def test_strip_on_real_mesh_is_short_and_exact() -> None:
    seq = shared_sequence(MESH)
    tris = seq.mesh.triangles
    s = stripify(tris, seq.mesh.vertex_count, 0xFFFF)
    assert np.array_equal(_canonical(decode_strip(s, 0xFFFF)), _canonical(tris))
    assert len(s) < 2 * len(tris)  # far below the 3 indices per triangle of a list


@pytest.mark.parametrize("restart", [0xFFFF, None])
def test_strip_swaps_keep_a_fan_in_one_strip(restart: int | None) -> None:
    # consecutive triangles of a fan share their centre, so a strip goes round it only by swaps (a repeated
    # index), not by restarts or degenerate joins
    fan = np.array([[0, i, i + 1] for i in range(1, 9)], np.int64)
    s = stripify(fan, 10, restart)
    assert restart not in s.tolist()
    assert np.array_equal(_canonical(decode_strip(s, restart)), _canonical(fan))
    assert len(s) == 15  # 3 + one index per triangle after the first + one per swap (six)
    # drawn in the fan's order: each triangle rotated to start at the centre
    drawn = decode_strip(s, restart)
    drawn = np.take_along_axis(drawn, (np.arange(3) + np.argmin(drawn, axis=1)[:, None]) % 3, axis=1)
    assert np.array_equal(drawn, fan)


def test_strip_keeps_the_cache_order() -> None:
    # the stripifier takes a triangle ahead of the cache order only from a small window, so the strip
    # misses about as often as the list it was made from (the former window of 8, without swaps: +17 %)
    seq = shared_sequence(MESH)
    V = seq.mesh.vertex_count
    ordered = cache_order(seq.mesh.triangles, V, 16)
    s = stripify(ordered, V, 0xFFFF)
    list_misses, _ = cache_misses(ordered.reshape(-1), 16)
    strip_misses, drawn = cache_misses(s, 16, "strip", 0xFFFF)
    assert drawn == len(ordered)
    assert strip_misses <= 1.03 * list_misses
    assert len(s) < 2.05 * len(ordered)


def test_stripify_refuses_an_index_past_the_vertex_count() -> None:
    with pytest.raises(ValueError, match=r"\[0, 3\)"):
        stripify(np.array([[0, 1, 3]]), 3, 0xFFFF)


def test_stripify_window_past_the_triangle_count_and_not_an_integer() -> None:
    # the window buffer was allocated at the window's size: 2**40 asked for 8 TB (a MemoryError); past the
    # triangle count every window draws the same strip
    fan = np.array([[0, i, i + 1] for i in range(1, 9)], np.int64)
    for restart in (0xFFFF, None):
        whole = stripify(fan, 10, restart, len(fan))
        for window in (len(fan) + 1, 64, 2**40, 10**30, np.int64(2**62)):
            assert np.array_equal(stripify(fan, 10, restart, window), whole)
    for bad in (True, 2.5, 4.0, "4", None):
        with pytest.raises(ValueError, match="window must be an integer"):
            stripify(fan, 10, 0xFFFF, bad)


# --------------------------------------------------------------------------------------------------------
# encoding
# --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("variant", list(VARIANTS))
@settings(max_examples=6, deadline=None)
@given(data=st.data())
def test_random_lod_walk_matches_reference(variant: str, data: st.DataObject) -> None:
    pm, _ = _case(variant)
    inst = pm.instance()
    walk = data.draw(st.lists(st.integers(0, pm.lod_count - 1), min_size=1, max_size=6))
    for k in walk:
        if data.draw(st.booleans()):
            inst.set_lod(k)
        else:  # single records, crossing level boundaries one at a time
            target = int(pm.lod_record_counts[k])
            while inst.records_applied < target:
                inst.collapse()
            while inst.records_applied > target:
                inst.split()
        assert inst.lod == k
        kind, stream = inst.draw_stream()
        assert (kind, stream.tolist()) == (pm.draw_stream(k)[0], pm.draw_stream(k)[1].tolist())
        ref = _reference(k)
        assert np.array_equal(_canonical(inst.triangles()), ref)
        assert np.array_equal(_canonical(pm.triangles_at(k)), ref)
        assert pm.triangle_count_at(k) == len(ref)
        # vertex prefix: LOD k draws only vertices [0, vertex_count_at(k))
        verts = stream if pm.restart_index is None else stream[stream != pm.restart_index]
        assert verts.max() < pm.vertex_count_at(k)
    inst.set_lod(0)
    assert inst.level == 0
    assert np.array_equal(inst.indices(), pm.level_list(0))


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_levels_collapsed_lists_and_degenerate_budget(variant: str) -> None:
    pm, _ = _case(variant)
    thr = pm.params["degenerate_threshold"]
    assert pm.level_count > 3
    assert pm.level_first_lod[0] == 0 and np.all(np.diff(pm.level_first_lod.astype(np.int64)) > 0)
    inst = pm.instance()
    worst = 0.0
    for lvl in range(pm.level_count):
        k0 = int(pm.level_first_lod[lvl])
        k1 = int(pm.level_first_lod[lvl + 1]) if lvl + 1 < pm.level_count else pm.lod_count
        inst.set_lod(k0)
        assert inst.level == lvl
        assert np.array_equal(inst.indices(), pm.level_list(lvl))  # a level starts uncollapsed
        level_tris = pm.level_triangle_count(lvl)
        assert level_tris == pm.triangle_count_at(k0)
        # walk every record of the level, checking the degenerate budget at every LOD
        for _ in range(int(pm.lod_record_counts[k1 - 1]) - int(pm.lod_record_counts[k0])):
            inst.collapse()
            if inst.lod is not None:
                worst = max(worst, 1 - len(inst.triangles()) / level_tris)
        if lvl + 1 < pm.level_count:
            # the stored fully collapsed list is the level's state at the next level's first LOD
            r_end = int(pm.level_record_start[lvl + 1])
            buf = inst.indices().copy()
            _apply(buf, pm._offsets, pm._start, pm._kept, pm._binned, inst.records_applied, r_end)
            assert np.array_equal(buf, pm.level_list(lvl, collapsed=True))
            # and the next level draws the same visible triangles
            nxt = pm._decode(pm.level_list(lvl + 1))
            assert np.array_equal(_canonical(nxt), _canonical(pm._decode(buf)))
    assert worst <= thr


def test_level_oscillation_uses_collapsed_list() -> None:
    pm, _ = _case("strip-restart")
    k = int(pm.level_first_lod[2])
    inst = pm.instance()
    inst.set_lod(k)
    done = inst.records_done
    inst.set_lod(k - 1)  # one step up: copy level 1's collapsed list, undo one step
    step = int(pm.lod_record_counts[k] - pm.lod_record_counts[k - 1])
    assert inst.level == 1 and inst.records_done - done == step
    assert np.array_equal(_canonical(inst.triangles()), _reference(k - 1))


def test_restart_and_index_size() -> None:
    pm, _ = _case("strip-restart")
    assert pm.restart_index == 0xFFFF  # cow's file is u16 (its level lists fit): all ones of u16
    kind, s = pm.draw_stream(0)
    assert kind == "strip" and (s == 0xFFFF).any()
    pm2, _ = _case("strip-degenerate")
    assert pm2.restart_index is None
    pm3, _ = _case("list")
    assert pm3.draw_stream(0)[0] == "triangles" and pm3.restart_index is None


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_buffers_roundtrip_and_memory(variant: str) -> None:
    pm, _ = _case(variant)
    b = pm.buffers()
    for name in (
        "level_first_lod",
        "level_index_start",
        "level_indices",
        "level_collapsed_start",
        "level_collapsed_indices",
        "level_record_start",
        "collapse_kept",
        "collapse_binned",
        "collapse_change_count",
        "collapse_prev_change_count",
        "collapse_change_offsets",
        "lod_record_counts",
    ):
        assert b[name].dtype == np.uint32, name
    assert len(b["level_record_start"]) == pm.level_count + 1
    pm2 = swpm_usd.from_buffers(
        "skip-strip",
        pm.points,
        pm.attributes,
        pm.vertex_counts,
        pm.triangle_counts,
        pm.lod_errors,
        b,
        pm.params,
    )
    for k in (0, pm.lod_count // 3, pm.lod_count - 1):
        assert np.array_equal(pm2.draw_stream(k)[1], pm.draw_stream(k)[1])
    assert pm2.restart_index == pm.restart_index
    assert 0 < pm.instance_bytes < pm.global_bytes
    assert pm.global_bytes > pm.vertex_bytes()


def test_build_entry_point_and_cache_beats_vanilla() -> None:
    mesh = shared_sequence(MESH).mesh
    pm = swpm_usd.build(mesh, "skip-strip", primitive="list", degenerate_threshold=0.5)
    assert pm.params["primitive"] == "list" and pm.params["degenerate_threshold"] == 0.5
    with pytest.raises(swpm_usd.BuildError):
        swpm_usd.build(mesh, "skip-strip", primitive="fan")
    van = swpm_usd.build(mesh, "vanilla")
    ss, _ = _case("strip-restart")
    for k in (0, ss.lod_for_triangles(ss.triangle_counts[0] // 2)):
        m, t = cache_misses(ss.draw_stream(k)[1], 16, "strip", ss.restart_index)
        vm, vt = cache_misses(van.draw_stream(k)[1], 16)
        assert t == vt and m < vm


def test_strip_window_trades_indices_for_cache_misses() -> None:
    seq = shared_sequence(MESH)
    narrow = _case("strip-restart")[0]
    wide = build_skipstrip(seq, strip_window=16)
    assert narrow.params["strip_window"] == 4 and wide.params["strip_window"] == 16
    # a wider window makes longer strips (fewer indices) from triangles taken further ahead of the cache order
    assert wide.buffers()["level_indices"].size < 0.9 * narrow.buffers()["level_indices"].size
    misses = [cache_misses(pm.draw_stream(0)[1], 16, "strip", pm.restart_index)[0] for pm in (narrow, wide)]
    assert misses[1] > 1.1 * misses[0]
    for k in (0, wide.lod_count // 2, wide.lod_count - 1):
        assert np.array_equal(_canonical(wide.triangles_at(k)), _canonical(narrow.triangles_at(k)))
    for bad in (0, 65, 2.5, True):
        with pytest.raises(swpm_usd.BuildError, match="strip_window"):
            swpm_usd.build(seq.mesh, "skip-strip", strip_window=bad)
