"""Hostile but loadable meshes through every encoder: each builds, every LOD of the per-collapse encodings
(and every sampled one of the sliding window's: all, or 25 to 50 of them) indexes only its vertex prefix, the
sampled sliding-window LODs equal its collapse sequence replayed, the three per-collapse encodings draw the
same surface at the sampled LODs, and every build round-trips through the binary format (points, counts,
errors and every LOD's triangles).

The meshes are suzanne (967 triangles) mutated the ways real assets are broken: random holes, duplicated,
flipped, double-sided and degenerate faces, split vertices (copies with their own uv, so the seams stay),
non-manifold fins and fans, strips standing on edge paths (whose inner points slide along them), two shells
glued at one vertex, a flattened copy with coincident points, a soup of disjoint triangles, and meshes of one
to five triangles (whose coarsest LOD may be empty). They go in through :meth:`Mesh.from_arrays`, as a
loader's do: it welds equal vertices and drops degenerate and repeated faces, so for those mutations the cases
check the cleaner and the encoders on what it leaves (a :class:`Mesh` made directly with a face naming one
vertex twice is a ``BuildError``: ``test_simplify``).
The same meshes made directly (``Mesh(...)``, no cleaning) must build consistent LODs or fail with a
``BuildError`` naming the mesh.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import shared_mesh
from test_slidingwindow import _canonical, _check_all

import swpm_usd
from swpm_usd.mesh import Mesh

#: the sliding-window settings every mutation is built with
SW_SETTINGS = [
    {},
    {"inner_vertices": 3},
    {"cluster": True},
    {"optimize_connectivity": True},
    {"builder": "forsyth"},
]
PER_COLLAPSE = ["vanilla", "skip-strip", "mixed"]


def _mutate(kind: str, points: np.ndarray, tris: np.ndarray, rng: np.random.Generator):
    p, t = points.copy(), tris.copy()
    n = len(t)
    if kind == "holes":
        t = t[rng.random(n) < 0.6]
    elif kind == "duplicated":
        t = np.concatenate([t, t[rng.integers(0, n, n // 10)]])
    elif kind == "flipped":
        f = rng.random(n) < 0.2
        t[f] = t[f][:, ::-1]
    elif kind == "degenerate":
        k = rng.integers(0, n, n // 20)
        t[k, 1] = t[k, 0]
    elif kind == "split":  # about 30 % of the faces on a copy of the vertices (given its own uv below)
        p = np.concatenate([p, p])
        t[rng.random(n) < 0.3] += len(points)
    elif kind == "fins":  # a third face on a tenth of the edges
        k = rng.integers(0, n, n // 10)
        tip = np.arange(len(p), len(p) + len(k))
        p = np.concatenate([p, p[t[k]].mean(1) + rng.normal(0, 0.01, (len(k), 3))])
        t = np.concatenate([t, np.stack([t[k, 0], t[k, 1], tip], 1)])
    elif kind == "fin-strips":  # strips standing on edge paths: the paths' inner points are complex
        for _ in range(6):
            path = [int(rng.integers(len(points)))]
            for _ in range(5):  # a walk along the mesh's edges, never back onto itself
                nxt = np.setdiff1d(t[(t == path[-1]).any(1)], path)
                if nxt.size:
                    path.append(int(rng.choice(nxt)))
            top = np.arange(len(p), len(p) + len(path))
            p = np.concatenate([p, p[path] + rng.normal(0, 0.05, 3) + rng.normal(0, 0.005, (len(path), 3))])
            a, b = np.array(path[:-1]), np.array(path[1:])
            t = np.concatenate([t, np.stack([a, b, top[1:]], 1), np.stack([a, top[1:], top[:-1]], 1)])
    elif kind == "fan":  # forty faces on one edge
        tip = np.arange(len(p), len(p) + 40)
        p = np.concatenate([p, rng.normal(size=(40, 3))])
        t = np.concatenate([t, np.stack([np.full(40, t[0, 0]), np.full(40, t[0, 1]), tip], 1)])
    elif kind == "glued":  # a shifted copy sharing one vertex
        t = np.concatenate([t, t + len(p)])
        p = np.concatenate([p, p + 0.5])
        t[t == len(points)] = 0
    elif kind == "double-sided":
        t = np.concatenate([t, t[:, ::-1]])
    elif kind == "flat":  # z dropped, a tenth of the points at the origin
        p[:, 2] = 0.0
        p[rng.random(len(p)) < 0.1] = 0.0
    elif kind == "soup":
        p = rng.normal(size=(300, 3))
        t = np.arange(300).reshape(-1, 3)
    elif kind.startswith("tiny"):
        t = t[: int(kind[4:])]
    return p, t


KINDS = ["holes", "duplicated", "flipped", "degenerate", "split", "fins", "fan", "glued", "double-sided"]
KINDS += ["flat", "soup", "tiny1", "tiny2", "tiny5", "fin-strips"]


def _mutated(kind: str) -> tuple[Mesh, np.ndarray, np.ndarray]:
    """Suzanne, and its points and triangles mutated by ``kind`` (seeded by the kind)."""
    base = shared_mesh("suzanne.obj")
    rng = np.random.default_rng(KINDS.index(kind))
    return base, *_mutate(kind, np.asarray(base.points, np.float64), np.asarray(base.triangles), rng)


def _assert_counts(pm: swpm_usd.ProgressiveMesh) -> None:
    """Every LOD draws as many triangles as its record says, inside its vertex prefix."""
    for k in range(pm.lod_count):
        tris_k = pm.triangles_at(k)
        assert tris_k.shape[0] == pm.triangle_count_at(k), f"{pm.encoding} LOD {k}"
        assert tris_k.size == 0 or tris_k.max() < pm.vertex_count_at(k)


def _by_position(pm: swpm_usd.ProgressiveMesh, k: int) -> np.ndarray:
    """LOD ``k``'s triangles over position ids (ids in sorted coordinate order, so the same in every
    encoding's vertex order), each rotated to its smallest id, rows sorted."""
    _, pos_id = np.unique(pm.points, axis=0, return_inverse=True)
    return _canonical(pos_id.reshape(-1)[pm.triangles_at(k)])


def _round_trip(pm: swpm_usd.ProgressiveMesh, path: Path) -> None:
    swpm_usd.save(pm, path)
    assert not swpm_usd.validate(path).problems
    back = swpm_usd.load(path)
    assert back.lod_count == pm.lod_count
    assert np.array_equal(back.points, pm.points)
    assert np.array_equal(back.vertex_counts, pm.vertex_counts)
    assert np.array_equal(back.triangle_counts, pm.triangle_counts)
    assert np.array_equal(back.lod_errors, pm.lod_errors)
    for k in range(pm.lod_count):
        assert np.array_equal(back.triangles_at(k), pm.triangles_at(k))


@pytest.mark.parametrize("kind", KINDS)
def test_hostile_meshes_build_valid_lods(kind: str, tmp_path: Path) -> None:
    base, points, tris = _mutated(kind)
    uv = None
    if kind == "split":  # the copies' uv differ from the originals': the cleaner keeps them apart
        uv = {"uv": np.repeat([[0.0, 0.0], [1.0, 0.0]], len(points) // 2, axis=0)}
    mesh = Mesh.from_arrays(points, tris, uv)
    if kind == "split":
        assert mesh.vertex_count > base.vertex_count
    for i, settings in enumerate(SW_SETTINGS):
        pm = swpm_usd.build(mesh, encoding="sliding-window", **settings)
        _check_all(pm, mesh, closed=False, every=max(1, pm.lod_count // 25))
        _round_trip(pm, tmp_path / f"sw{i}.swpm")
    built = [swpm_usd.build(mesh, encoding=e) for e in PER_COLLAPSE]
    assert len({pm.lod_count for pm in built}) == 1
    for pm in built:
        _assert_counts(pm)
    for k in sorted(
        set(range(0, built[0].lod_count, max(1, built[0].lod_count // 25))) | {built[0].lod_count - 1}
    ):
        ref = _by_position(built[0], k)
        for pm in built[1:]:
            assert np.array_equal(_by_position(pm, k), ref), f"{pm.encoding} draws another surface at LOD {k}"
    for pm in built:
        _round_trip(pm, tmp_path / f"{pm.encoding}.swpm")


@pytest.mark.parametrize("kind", KINDS)
def test_hostile_meshes_made_directly_build_or_fail_clearly(kind: str) -> None:
    # Mesh(...) does not clean: each encoder either builds LODs that agree with their own counts (and, for
    # the sliding window, with its collapse sequence) or raises a BuildError naming the mesh
    from swpm_usd.errors import BuildError

    _, points, tris = _mutated(kind)
    mesh = Mesh(points, tris, source=f"{kind}.obj")
    for encoding in ["sliding-window", *PER_COLLAPSE]:
        try:
            pm = swpm_usd.build(mesh, encoding=encoding)
        except BuildError as e:
            assert str(e).startswith(f"{kind}.obj: ")
            continue
        _assert_counts(pm)
        if encoding == "sliding-window":
            _check_all(pm, mesh, closed=False, every=max(1, pm.lod_count // 25))
