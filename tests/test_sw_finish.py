"""Tests of the sliding-window level steps fused into one kernel call each.

A level's finishing (:func:`.sw_layout._finish`) gives the same pool, patch order and renumbered records
as its steps called one by one (:func:`.sw_layout.level_pool`, :func:`.sw_refine.refine_patch_order`,
:func:`.sw_refine.reorder_patches`); a level's patches (:func:`.sw_order.ordered_patches`) the same
patches, absorbed middle and order as theirs (:func:`.sw_patches.patch_triangles`,
:func:`.sw_patches.absorb_middle`, :func:`.sw_order.order_patches`, :func:`.sw_order.reassign_middle`)."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from conftest import shared_mesh

import swpm_usd
from swpm_usd.encode import slidingwindow as sw
from swpm_usd.encode import sw_layout as swl
from swpm_usd.encode import sw_refine as swr


def _captured_levels(name: str, monkeypatch: pytest.MonkeyPatch) -> list[tuple]:
    """The inputs of every :func:`.sw_layout.finish_level` call of a default build of ``name``."""
    real = swl.finish_level
    calls = []

    def capture(*args):
        calls.append(copy.deepcopy(args))
        return real(*args)

    monkeypatch.setattr(swl, "finish_level", capture)
    with sw.inline_finishing():
        swpm_usd.build(shared_mesh(f"{name}.obj"), "sliding-window")
    monkeypatch.setattr(swl, "finish_level", real)
    return calls


def _step_by_step(gtris, start_gids, collapsed, step0, V, P, cache_size, passes, reach):
    """The finishing as ``sw_layout`` called its steps before :func:`.sw_layout._finish`: the pool and the
    level's ``(p_start, p_out, q_start, q_out, patch_steps, recs, info)``, and whether the search moved a
    patch."""
    p_start, p_out, q_start, q_out, patch_steps, recs, info = collapsed
    n = patch_steps.shape[0]
    tris, starts = swl.level_pool(gtris, start_gids, p_start, p_out, q_start, q_out, cache_size)
    if passes == 0 or n < 3:
        return tris, collapsed, False
    step_start = np.concatenate(([0], np.cumsum(patch_steps)))
    targets = info[: step_start[n], 2].astype(np.int64)
    perm = swr.refine_patch_order(
        3 * starts,
        np.ascontiguousarray(tris, np.int64).reshape(-1),
        n,
        step_start,
        targets,
        P,
        V,
        cache_size,
        reach,
        swl._REFINE_RUN,
        passes,
        True,
        swl._LONG_REACH,
    )
    if np.array_equal(perm, np.arange(n)):
        return tris, collapsed, False
    if (n + 1) * tris.size <= swl._EXACT_CHECK:  # a small level: the greedy order unless the search is better
        orders = np.stack((np.arange(n), perm)).astype(np.int64)
        flat = np.ascontiguousarray(tris, np.int64).reshape(-1)
        greedy, searched = swr.exact_window_misses(3 * starts, flat, n, orders, cache_size)
        if searched > greedy:
            return tris, collapsed, False
    moved, pool = swr.reorder_patches(
        perm, starts, tris, p_start, p_out, q_start, q_out, patch_steps, info, recs, step0
    )
    return pool, moved, True


@pytest.mark.parametrize("name", ["suzanne", "teapot"])
def test_finish_in_one_call_is_the_steps_one_by_one(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every level of a build finished by :func:`.sw_layout.finish_level` (one kernel call) and by its steps
    one by one: the same pool, offsets, steps, records and step info, with the search (two passes) and
    without it; among the levels some the search reordered and (teapot's small levels of a mesh of 3,644
    vertices) some whose vertex ids the cache ordering renumbers densely."""
    levels = _captured_levels(name, monkeypatch)
    assert len(levels) >= 10
    reordered = compacted = 0
    for args in levels:
        gtris, start_gids, collapsed, step0, V, P, cache_size, passes, reach = args
        assert passes == 2
        for p in (passes, 0):
            want_pool, want, moved = _step_by_step(*copy.deepcopy((*args[:7], p, reach)))
            reordered += moved
            got = swl._finish(
                *copy.deepcopy((gtris, start_gids, *collapsed[:5], collapsed[5], collapsed[6])),
                step0,
                V,
                P,
                cache_size,
                *swl._score_tables(cache_size),
                swl._HEAVY,
                p,
                reach,
                swl._REFINE_RUN,
                swl._LONG_REACH,
                swl._EXACT_CHECK,
            )
            assert np.array_equal(got[0], want_pool)
            for a, b in zip(got[1:], want, strict=True):
                assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)
            lev, recs, info = swl.finish_level(*copy.deepcopy((*args[:7], p, reach)))
            assert lev.pool.dtype == np.int32 and np.array_equal(lev.pool, want_pool)
            assert np.array_equal(lev.p_start, want[0]) and np.array_equal(lev.q_start, want[2])
            assert np.array_equal(recs, want[5]) and np.array_equal(info, want[6])
        tris, _, _, nvert = swl._level_triangles(gtris, start_gids, *collapsed[:4])
        compacted += nvert > 4 * tris.size + 1024  # (as vcache._compact)
    assert reordered > 0
    if name == "teapot":
        assert compacted > 0


def _level_misses(lev: swl.Level, cache_size: int) -> tuple[int, int]:
    """A finished level's FIFO misses summed over its ``n + 1`` windows (each from a cold cache, read back
    from its pool and offsets), and ``n + 1`` times the level's indices (what ``_EXACT_CHECK`` bounds)."""
    n = lev.patch_count
    rows = lev.pool.shape[0]
    middle = rows - lev.p_start[n] - lev.q_start[n]
    starts = np.concatenate((lev.p_start, lev.p_start[n] + middle + lev.q_start)).astype(np.int64)
    blocks = lev.pool.astype(np.int64).reshape(-1)
    misses = swr.window_misses(3 * starts, blocks, n, np.arange(n), cache_size)
    return misses, (n + 1) * blocks.shape[0]


def test_exact_window_misses_is_window_misses() -> None:
    """The kernel's exact count (cold cache per window, dense ids) is :func:`.sw_refine.window_misses`' on
    random levels: empty blocks, an empty ``M``, repeated and far vertex ids, one to eight patches."""
    rng = np.random.default_rng(7)
    for _ in range(40):
        n = int(rng.integers(1, 9))
        block_start = np.concatenate(([0], np.cumsum(3 * rng.integers(0, 8, 2 * n + 1)))).astype(np.int64)
        blocks = rng.integers(10**6, 10**6 + 40, block_start[-1]).astype(np.int64)
        orders = np.stack((np.arange(n), rng.permutation(n))).astype(np.int64)
        got = swr.exact_window_misses(block_start, blocks, n, orders, 16)
        assert got.tolist() == [swr.window_misses(block_start, blocks, n, o, 16) for o in orders]


@pytest.mark.parametrize("name", ["suzanne", "cow"])
def test_small_levels_end_no_worse_than_the_greedy(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """On every level small enough for the exact check (``sw_layout._EXACT_CHECK``) the searched order has no
    more misses over the level's windows than its greedy start (the search's local evaluation ended above it
    on suzanne's level of 5 patches, 194 -> 198, and cow's, 112 -> 114, before the check); some of them the
    search did reorder, and the larger levels are left to it."""
    levels = _captured_levels(name, monkeypatch)
    checked = 0
    for args in levels:
        greedy_lev = swl.finish_level(*copy.deepcopy((*args[:7], 0, args[8])))[0]
        searched_lev = swl.finish_level(*copy.deepcopy(args))[0]
        greedy, size = _level_misses(greedy_lev, args[6])
        searched, _ = _level_misses(searched_lev, args[6])
        if size <= swl._EXACT_CHECK and greedy_lev.patch_count >= 3:
            assert searched <= greedy, (name, greedy_lev.patch_count, greedy, searched)
            checked += not np.array_equal(greedy_lev.pool, searched_lev.pool)
    assert checked > 0


def _patches_step_by_step(st, inner_start, inner, stars, alive_t, min_shared, rounds, max_middle, V, C, w):
    """A level's patches as ``slidingwindow._build_levels`` made them one call each before
    :func:`.sw_order.ordered_patches`."""
    from swpm_usd.encode import sw_order, sw_patches

    pt_start, pt = sw_patches.patch_triangles(st, inner_start, inner, stars)
    own_start = pt_start
    absorb = min_shared > 0 and alive_t.shape[0] - pt_start[-1] <= max_middle * alive_t.shape[0]
    if absorb:
        for _ in range(rounds):
            grown_start, grown = sw_patches.absorb_middle(st, pt_start, pt, alive_t, min_shared, stars)
            if grown.shape[0] == pt.shape[0]:
                break
            pt_start, pt = grown_start, grown
    inner_pos = np.zeros(st.pos_points.shape[0], bool)
    inner_pos[inner] = True
    binned_vertex = inner_pos[st.vertex_pos]
    order = sw_order.order_patches(pt_start, pt, st.tri_verts, binned_vertex, np.diff(inner_start), V, C, w)
    if absorb:
        pt_start, pt = sw_order.reassign_middle(st, own_start, pt_start, pt, order, binned_vertex, C)
    return pt_start, pt, order


@pytest.mark.parametrize("name", ["suzanne", "beetle"])
def test_ordered_patches_is_the_steps_one_by_one(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """:func:`.sw_order.ordered_patches` (a level's patches, absorbed middle, order and reassignment in one
    kernel call) gives what its steps one by one give, on every level of a build: with the default one round
    of absorption, with rounds until none is left, without it, and on the coarse levels whose middle is not
    absorbed (beetle's)."""
    from swpm_usd.encode import sw_order

    real = sw_order.ordered_patches
    calls = []

    def capture(*args):
        calls.append(copy.deepcopy(args))  # (the state changes with the level's collapses)
        return real(*args)

    monkeypatch.setattr(sw_order, "ordered_patches", capture)
    with sw.inline_finishing():
        swpm_usd.build(shared_mesh(f"{name}.obj"), "sliding-window")
    monkeypatch.setattr(sw_order, "ordered_patches", real)
    assert len(calls) >= 8
    absorbed = kept = 0
    for args in calls:
        st, inner_start, inner, stars, alive_t, min_shared, rounds, max_middle = args[:8]
        assert (min_shared, rounds) == (1, 1)
        for shared, r in ((1, 1), (1, 64), (0, 1)):
            a = (*args[:5], shared, r, *args[7:])
            got = real(*copy.deepcopy(a))
            want = _patches_step_by_step(*copy.deepcopy(a))
            for x, y in zip(got, want, strict=True):
                assert x.dtype == y.dtype and np.array_equal(x, y)
        own = _patches_step_by_step(*copy.deepcopy((*args[:5], 0, 1, *args[7:])))[0][-1]
        absorbed += alive_t.shape[0] - own <= max_middle * alive_t.shape[0]
        kept += alive_t.shape[0] - own > max_middle * alive_t.shape[0]
    assert absorbed > 0
    if name == "beetle":
        assert kept > 0


@pytest.mark.parametrize("params", [{"inner_vertices": 3}, {"cluster": True, "inner_vertices": 3}])
def test_fused_steps_with_grown_patches_and_clusters(params: dict, monkeypatch: pytest.MonkeyPatch) -> None:
    """The paths the default builds above do not take: patches of several inner vertices (grown,
    ``inner_vertices=3``), and ``cluster=True`` (whose levels :mod:`.sw_layout`'s clustered layout finishes,
    not :func:`.sw_layout.finish_level`): :func:`.sw_order.ordered_patches` and :func:`.sw_layout._finish`
    give what their steps one by one give on every level."""
    from swpm_usd.encode import sw_order

    real_finish, real_patches = swl.finish_level, sw_order.ordered_patches
    finishes, patches = [], []

    def capture_finish(*args):
        finishes.append(copy.deepcopy(args))
        return real_finish(*args)

    def capture_patches(*args):
        patches.append(copy.deepcopy(args))  # (the state changes with the level's collapses)
        return real_patches(*args)

    monkeypatch.setattr(swl, "finish_level", capture_finish)
    monkeypatch.setattr(sw_order, "ordered_patches", capture_patches)
    with sw.inline_finishing():
        swpm_usd.build(shared_mesh("suzanne.obj"), "sliding-window", **params)
    monkeypatch.undo()
    assert len(patches) >= 3
    assert len(finishes) == (0 if params.get("cluster") else len(patches))
    grown = 0
    for args in patches:
        inner_start = args[1]
        grown += int(np.diff(inner_start).max(initial=0) > 1)
        got = real_patches(*copy.deepcopy(args))
        want = _patches_step_by_step(*copy.deepcopy(args))
        for x, y in zip(got, want, strict=True):
            assert x.dtype == y.dtype and np.array_equal(x, y)
    assert grown > 0  # (patches of several inner vertices were made)
    for args in finishes:
        assert args[7] == 2  # (the search's passes)
        want_pool, want, _ = _step_by_step(*copy.deepcopy(args))
        lev, recs, info = real_finish(*copy.deepcopy(args))
        assert lev.pool.dtype == np.int32 and np.array_equal(lev.pool, want_pool)
        assert np.array_equal(lev.p_start, want[0]) and np.array_equal(lev.q_start, want[2])
        assert np.array_equal(lev.patch_steps, want[4])
        assert np.array_equal(recs, want[5]) and np.array_equal(info, want[6])
