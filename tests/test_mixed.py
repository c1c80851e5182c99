"""Mixed-mode lists: the four lists per level, random LOD walks against the reference triangle sets, two
draws per LOD, and the buffer contract."""

from __future__ import annotations

from functools import cache

import numpy as np
from conftest import shared_sequence
from hypothesis import given, settings
from hypothesis import strategies as st

import swpm_usd
from swpm_usd.encode.mixed import MixedProgressiveMesh, build_mixed
from swpm_usd.encode.skipstrip import vertex_order

MESH = "cow.obj"


def _canonical(tris: np.ndarray) -> np.ndarray:
    tris = np.asarray(tris, np.int64).reshape(-1, 3)
    r = np.argmin(tris, axis=1)
    idx = (np.arange(3)[None, :] + r[:, None]) % 3
    rot = np.take_along_axis(tris, idx, axis=1)
    return rot[np.lexsort(rot.T[::-1])]


@cache
def _pm() -> MixedProgressiveMesh:
    return build_mixed(shared_sequence(MESH))


def _reference(k: int) -> np.ndarray:
    seq = shared_sequence(MESH)
    return _canonical(vertex_order(seq)[0][seq.triangles_at_step(k)])


@settings(max_examples=10, deadline=None)
@given(data=st.data())
def test_random_lod_walk_matches_reference(data: st.DataObject) -> None:
    pm = _pm()
    inst = pm.instance()
    for k in data.draw(st.lists(st.integers(0, pm.lod_count - 1), min_size=1, max_size=6)):
        if data.draw(st.booleans()):
            inst.set_lod(k)
        else:
            target = int(pm.lod_record_counts[k])
            while inst.records_applied < target:
                inst.collapse()
            while inst.records_applied > target:
                inst.split()
        calls = inst.draw_calls()
        assert len(calls) == 2 and all(kind == "triangles" for kind, _ in calls)
        tris = np.concatenate([c for _, c in calls]).reshape(-1, 3)
        ref = _reference(k)
        assert np.array_equal(_canonical(tris), ref)  # no degenerate triangle is ever drawn
        assert pm.triangle_count_at(k) == len(ref)
        assert tris.max() < pm.vertex_count_at(k)
        # the static draw is a prefix of the level's shared list
        static = pm.static_list(inst.level)
        assert np.array_equal(calls[1][1], static[: calls[1][1].size])
    inst.set_lod(0)
    assert np.array_equal(inst._buf, pm.dynamic_list(0))


def test_level_lists_partition() -> None:
    pm = _pm()
    assert pm.level_count > 3
    for lvl in range(pm.level_count):
        static = pm.static_list(lvl)
        dyn = pm.dynamic_list(lvl)
        assert pm.dynamic_list(lvl, collapsed=True).size == dyn.size
        k0 = int(pm.level_first_lod[lvl])
        both = np.concatenate([static, dyn])
        assert np.array_equal(_canonical(both), _reference(k0))
    # most of the mesh is static at full detail (shared between instances)
    assert pm.static_list(0).size > pm.dynamic_list(0).size


def test_buffers_roundtrip_and_memory() -> None:
    pm = _pm()
    b = pm.buffers()
    assert all(a.dtype == np.uint32 for a in b.values())
    pm2 = swpm_usd.from_buffers(
        "mixed", pm.points, pm.attributes, pm.vertex_counts, pm.triangle_counts, pm.lod_errors, b, pm.params
    )
    for k in (0, pm.lod_count // 2, pm.lod_count - 1):
        assert np.array_equal(pm2.triangles_at(k), pm.triangles_at(k))
    ss = swpm_usd.build(shared_sequence(MESH).mesh, "mixed", level_threshold=0.5)
    assert ss.params["level_threshold"] == 0.5
    assert 0 < pm.instance_bytes < pm.global_bytes
