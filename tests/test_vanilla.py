"""Vanilla VIPM: record layout, vertex prefix property and the runtime instance along random LOD walks."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import shared_mesh, shared_sequence
from hypothesis import given, settings
from hypothesis import strategies as st

import swpm_usd
from swpm_usd.encode.vanilla import VanillaProgressiveMesh, build_vanilla


def _canonical(tris: np.ndarray) -> np.ndarray:
    """Rows rotated so the smallest index comes first (keeps winding), then sorted."""
    tris = np.asarray(tris).reshape(-1, 3)
    r = np.argmin(tris, axis=1)
    idx = (np.arange(3)[None, :] + r[:, None]) % 3
    rot = np.take_along_axis(tris, idx, axis=1)
    return rot[np.lexsort(rot.T[::-1])]


class _Case:
    def __init__(self, name: str) -> None:
        self.seq = shared_sequence(name)
        self.pm = build_vanilla(self.seq)
        mesh = self.seq.mesh
        # original vertex id -> LOD-order id, recovered from the points and attributes permutation
        V = mesh.vertex_count
        self.new_id = np.empty(V, np.int64)
        is_binned = np.zeros(V, bool)
        is_binned[self.seq.binned] = True
        survivors = np.flatnonzero(~is_binned)
        self.new_id[survivors] = np.arange(survivors.size)
        self.new_id[self.seq.binned] = V - 1 - np.arange(self.seq.collapse_count)

    def reference(self, k: int) -> np.ndarray:
        return _canonical(self.new_id[self.seq.triangles_at_step(k)])


_cases: dict[str, _Case] = {}


def case(name: str) -> _Case:
    if name not in _cases:
        _cases[name] = _Case(name)
    return _cases[name]


@pytest.mark.parametrize("name", ["cow.obj", "spot.obj"])
def test_points_and_attributes_follow_lod_order(name):
    c = case(name)
    mesh = c.seq.mesh
    assert np.array_equal(c.pm.points[c.new_id], mesh.points)
    for attr, a in mesh.attributes.items():
        assert np.array_equal(c.pm.attributes[attr][c.new_id], a)


@pytest.mark.parametrize("name", ["cow.obj", "spot.obj"])
def test_every_sampled_lod_matches_reference_and_vertex_prefix(name):
    c = case(name)
    pm = c.pm
    assert pm.lod_count == c.seq.step_count + 1
    for k in np.unique(np.linspace(0, pm.lod_count - 1, 40).astype(int)):
        tris = pm.triangles_at(k)
        assert tris.shape[0] == pm.triangle_count_at(k)
        assert tris.size == 0 or tris.max() < pm.vertex_count_at(k)
        assert np.array_equal(_canonical(tris), c.reference(k))
    assert np.all(np.diff(pm.vertex_counts) <= 0) and np.all(np.diff(pm.triangle_counts) <= 0)
    assert np.all(np.diff(pm.lod_errors) >= 0) and pm.error_at(0) == 0


def test_records_follow_forsyth():
    pm = case("cow.obj").pm
    # binned triangles are the last ones: the live list is always a prefix
    assert np.array_equal(pm.collapse_prev_change_count[1:], pm.collapse_change_count[:-1])
    assert pm.collapse_prev_change_count[0] == 0
    assert pm.collapse_change_offsets.max() < pm.indices.shape[0]
    # the kept vertex of record r is in use while vertex V-1-r is binned
    r = np.arange(pm.record_count)
    assert np.all(pm.collapse_kept < pm.vertex_count - 1 - r)
    assert int(pm.collapse_change_count.sum()) == pm.collapse_change_offsets.shape[0]


@settings(max_examples=25, deadline=None, derandomize=True)
@given(data=st.data())
def test_random_lod_walks_match_reference_and_restore(data):
    name = data.draw(st.sampled_from(["cow.obj", "spot.obj"]))
    c = case(name)
    pm = c.pm
    inst = pm.instance()
    original = inst.indices().copy()
    for _ in range(6):
        move = data.draw(st.sampled_from(["jump", "collapse", "split"]))
        if move == "jump":
            k = data.draw(st.integers(0, pm.lod_count - 1))
            inst.set_lod(k)
        else:
            for _ in range(data.draw(st.integers(1, 40))):
                (inst.collapse if move == "collapse" else inst.split)()
        k = inst.lod
        live = inst.indices().reshape(-1, 3)
        assert live.size == 0 or live.max() < inst.vertex_count
        if k is not None:
            assert np.array_equal(_canonical(live), c.reference(k))
            assert np.array_equal(live, pm.triangles_at(k))
    inst.set_lod(0)
    assert np.array_equal(inst.indices(), original)
    assert np.array_equal(original, pm.indices.astype(np.int64))


def test_one_record_at_a_time_down_and_back_up():
    pm = case("cow.obj").pm
    inst = pm.instance()
    steps = 0
    while inst.collapse():
        steps += 1
    assert steps == pm.record_count and inst.lod == pm.lod_count - 1
    assert inst.vertex_count == pm.vertex_count_at(pm.lod_count - 1)
    while inst.split():
        pass
    assert np.array_equal(inst.indices(), pm.indices.astype(np.int64))
    assert not inst.split()


def test_from_buffers_roundtrip_and_memory():
    pm = case("spot.obj").pm
    again = swpm_usd.from_buffers(
        "vanilla", pm.points, pm.attributes, pm.vertex_counts, pm.triangle_counts, pm.lod_errors, pm.buffers()
    )
    assert isinstance(again, VanillaProgressiveMesh)
    for k in (0, pm.lod_count // 3, pm.lod_count - 1):
        assert np.array_equal(again.triangles_at(k), pm.triangles_at(k))
    # the shared part holds the vertices, the master index buffer and the records; an instance its buffer
    assert pm.global_bytes > pm.vertex_bytes() + pm.instance_bytes - 64
    assert pm.instance_bytes >= 2 * pm.indices.shape[0]


def test_lod_selection_helpers():
    pm = case("cow.obj").pm
    t0 = pm.triangle_count_at(0)
    k = pm.lod_for_triangles(t0 // 2)
    assert pm.triangle_count_at(k) <= t0 // 2 and (k == 0 or pm.triangle_count_at(k - 1) > t0 // 2)
    e = pm.error_at(pm.lod_count // 2)
    k2 = pm.lod_for_error(e)
    assert pm.error_at(k2) <= e and (k2 == pm.lod_count - 1 or pm.error_at(k2 + 1) > e)
    assert pm.lod_for_triangles(0) == pm.lod_count - 1


@pytest.mark.parametrize("encoding", ["vanilla", "skip-strip", "mixed", "sliding-window"])
def test_a_lod_number_must_be_an_integer_in_range(encoding):
    pm = swpm_usd.build(shared_mesh("cow.obj"), encoding)
    np.testing.assert_array_equal(pm.triangles_at(np.int64(3)), pm.triangles_at(3))
    with pytest.raises(TypeError):
        pm.triangles_at(1.5)  # was LOD 1
    with pytest.raises(IndexError, match="out of range"):
        pm.vertex_count_at(pm.lod_count)
    with pytest.raises(ValueError, match="NaN"):
        pm.lod_for_error(float("nan"))  # was the coarsest LOD
    assert pm.lod_for_error(float("inf")) == pm.lod_count - 1
    with pytest.raises(ValueError, match="max_error"):
        pm.lod_for_error(-1.0)  # was LOD 0: a negative bound is a mistake (test_lod_selection.py)


@pytest.mark.parametrize(
    ("encoding", "params", "message"),
    [
        ("sliding-window", {"mu": "abc"}, "parameter mu must be a finite number, got 'abc'"),  # TypeError
        ("sliding-window", {"mu": float("nan")}, "parameter mu must be a finite number"),
        ("sliding-window", {"cluster": 1}, "parameter cluster must be true or false"),
        ("sliding-window", {"cache_size": 16.5}, "parameter cache_size must be an integer"),
        ("sliding-window", {"cache_size": 10**9}, "cache_size must be at most 1024"),  # 7.5 GiB arrays
        ("skip-strip", {"cache_size": 10**9}, "cache_size must be at most 1024"),
        ("mixed", {"cache_size": True}, "parameter cache_size must be an integer"),
        ("sliding-window", {"tolerance": -1.0}, "tolerance must be a finite number >= 0"),
        ("vanilla", {"seam_weight": 1e308}, "seam_weight must be in [0, 1e+06]"),  # inf errors
        ("vanilla", {"boundary_weight": -5}, "boundary_weight must be in [0, 1e+06]"),
        ("skip-strip", {"primitive": 3}, "parameter primitive must be a string"),
    ],
)
def test_a_parameter_of_the_wrong_type_or_out_of_bounds_is_a_build_error(encoding, params, message):
    with pytest.raises(swpm_usd.BuildError) as err:
        swpm_usd.build(shared_mesh("suzanne.obj"), encoding, **params)
    assert message in str(err.value)


def test_build_entry_point_validates_parameters(tmp_path):
    mesh = shared_mesh("cow.obj")
    with pytest.raises(swpm_usd.BuildError, match="do not belong"):
        swpm_usd.build(mesh, "vanilla", mu=0.2)
    with pytest.raises(swpm_usd.BuildError, match="unknown encoding"):
        swpm_usd.build(mesh, "nope")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\n")
    with pytest.raises(swpm_usd.MeshLoadError, match="bad.obj"):
        swpm_usd.build(bad, "vanilla")
