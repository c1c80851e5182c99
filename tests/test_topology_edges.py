"""mesh_topology's edge classification kernel (simplify.topology.classify_edges) against the numpy steps it
replaced, array for array (dtype, shape, order): the boundary and seam edges feed the quadrics in this
order, so any difference would change every build."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import shared_mesh

from swpm_usd.mesh import Mesh
from swpm_usd.simplify import mesh_topology
from swpm_usd.simplify.sequence import _weld
from swpm_usd.simplify.topology import classify_edges, stable_order


def _numpy_edges(tri_pos: np.ndarray, tris: np.ndarray, P: int) -> tuple:
    """The numpy steps mesh_topology ran until 2026-12-06 (h236), verbatim."""
    T = tris.shape[0]
    ha = tri_pos.reshape(-1)
    hb = tri_pos[:, [1, 2, 0]].reshape(-1)
    va = tris.reshape(-1)
    vb = tris[:, [1, 2, 0]].reshape(-1)
    face = np.repeat(np.arange(T, dtype=np.int64), 3)
    lo = np.minimum(ha, hb).astype(np.int64)
    hi = np.maximum(ha, hb).astype(np.int64)
    key = lo * P + hi
    order = stable_order(hi, P)
    order = order[stable_order(lo[order], P)]
    key_s = key[order]
    starts = np.flatnonzero(np.r_[True, key_s[1:] != key_s[:-1]])
    counts = np.diff(np.r_[starts, key_s.shape[0]])
    first = order[starts]
    bmask = counts == 1
    bh = first[bmask]
    boundary_edges = np.stack([ha[bh], hb[bh]], axis=1).astype(np.int32)
    boundary_faces = face[bh].astype(np.int32)
    pos_boundary = np.zeros(P, bool)
    pos_boundary[boundary_edges.reshape(-1)] = True
    two = counts == 2
    h0 = order[starts[two]]
    h1 = order[starts[two] + 1]
    ha0 = ha[h0]
    ha1 = ha[h1]
    consistent = ha0 == hb[h1]
    up0 = ha0 == lo[h0]
    up1 = ha1 == lo[h1]
    va0, vb0, va1, vb1 = va[h0], vb[h0], va[h1], vb[h1]
    seam = (np.where(up0, va0, vb0) != np.where(up1, va1, vb1)) | (
        np.where(up0, vb0, va0) != np.where(up1, vb1, va1)
    )
    sh0 = h0[seam]
    sh1 = h1[seam]
    seam_edges = np.concatenate([np.stack([ha[sh0], hb[sh0]], 1), np.stack([ha[sh1], hb[sh1]], 1)]).astype(
        np.int32
    )
    seam_faces = np.concatenate([face[sh0], face[sh1]]).astype(np.int32)

    def ends(edge_starts: np.ndarray) -> np.ndarray:
        on = np.zeros(P, bool)
        on[(key_s[edge_starts] // P).astype(np.int64)] = True
        on[(key_s[edge_starts] % P).astype(np.int64)] = True
        return on

    on_fin = ends(starts[counts > 2])
    on_inconsistent = ends(starts[two][~consistent])
    return (
        boundary_edges,
        boundary_faces,
        seam_edges.reshape(-1, 2),
        seam_faces,
        pos_boundary,
        on_fin | on_inconsistent,
        on_fin,
    )


def _check(tris: np.ndarray, vertex_pos: np.ndarray, P: int) -> tuple:
    tris = np.ascontiguousarray(tris, np.int32)
    tri_pos = vertex_pos[tris]
    got = classify_edges(tri_pos, tris, P)
    ref = _numpy_edges(tri_pos, tris, P)
    for g, r in zip(got, ref, strict=True):
        assert g.dtype == r.dtype
        assert g.shape == r.shape
        np.testing.assert_array_equal(g, r)
    return got


@pytest.mark.parametrize("name", ["suzanne.obj", "teapot.obj", "fandisk.obj", "beetle.obj"])
def test_classify_edges_matches_numpy_on_shared_meshes(name: str) -> None:
    mesh = shared_mesh(name)
    uniq, vertex_pos = _weld(mesh.points)
    got = _check(mesh.triangles, vertex_pos, uniq.shape[0])
    topo = mesh_topology(mesh)
    np.testing.assert_array_equal(topo.boundary_edges, got[0])
    np.testing.assert_array_equal(topo.seam_edges, got[2])


def test_classify_edges_matches_numpy_on_seams_fins_and_flips() -> None:
    # random triangles over few positions, each position split into several vertices (seams): edges of one,
    # two (consistent or not, seam or not) and three or more triangles all occur
    rng = np.random.default_rng(236)
    P, split = 12, 3
    vertex_pos = np.repeat(np.arange(P, dtype=np.int32), split)
    rows = []
    while len(rows) < 80:
        a, b, c = rng.choice(P, 3, replace=False)
        rows.append([split * x + rng.integers(split) for x in (a, b, c)])
    tris = np.array(rows, np.int32)
    got = _check(tris, vertex_pos, P)
    assert got[0].shape[0] > 0 and got[2].shape[0] > 0  # boundary and seam edges
    assert got[6].any() and got[5].any()  # fins
    # two triangles running the same way along positions (0, 1): non-manifold, not a fin
    got = _check(np.array([[0, 3, 6], [0, 3, 9]], np.int32), vertex_pos, P)
    assert got[5][[0, 1]].all() and not got[6].any()
    # a two-corner triangle (vertices 0 and 1 at position 0) beside one of them: its edge (0, 1) is a fin
    got = _check(np.array([[0, 3, 6], [0, 1, 3]], np.int32), vertex_pos, P)
    assert got[6][[0, 1]].all()


def test_mesh_topology_through_a_mesh() -> None:
    # a closed tetrahedron: no boundary, no seam, manifold
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    tris = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int32)
    topo = mesh_topology(Mesh(pts, tris))
    assert topo.boundary_edges.shape == (0, 2) and topo.seam_edges.shape == (0, 2)
    assert not topo.pos_boundary.any() and not topo.pos_nonmanifold.any()
    # one face removed: its three edges are the boundary, in the order of (lo, hi)
    topo = mesh_topology(Mesh(pts, tris[:3]))
    assert sorted(map(tuple, np.sort(topo.boundary_edges, 1))) == [(1, 2), (1, 3), (2, 3)]
    assert topo.pos_boundary[[1, 2, 3]].all() and not topo.pos_boundary[0]
