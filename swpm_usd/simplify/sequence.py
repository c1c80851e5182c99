"""The half-edge collapse sequence of a mesh (Garland-Heckbert quadrics; Svarovsky, Forsyth).

:func:`collapse_sequence` welds the mesh's vertices into positions, classifies edges (boundary, attribute
seam, non-manifold), seeds the quadrics and runs the numba kernels of :mod:`.kernels`. The result lists
*vertex* collapses (``binned`` -> ``kept``) grouped into *steps*: one step bins one position, i.e. all the
vertices a seam put there, at once. Every step is a level of detail; ``triangles_after(n)`` rebuilds the
triangle set after any number of vertex collapses by replaying them with numpy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import BuildError
from ..mesh import Mesh
from . import kernels
from .topology import classify_edges

if TYPE_CHECKING:
    from . import fan_deviation


@dataclass(frozen=True, eq=False)
class MeshTopology:
    """Welded view of a mesh: positions and the classification of its edges."""

    vertex_pos: np.ndarray  # (V,) i32
    pos_points: np.ndarray  # (P,3) f64
    tri_pos: np.ndarray  # (T,3) i32
    boundary_edges: np.ndarray  # (nb,2) position pairs with one triangle
    boundary_faces: np.ndarray  # (nb,)
    seam_edges: np.ndarray  # (ns,2) manifold edges whose two triangles use different vertices
    seam_faces: np.ndarray  # (ns,)
    pos_boundary: np.ndarray  # (P,) bool
    pos_nonmanifold: np.ndarray  # (P,) bool: on a non-manifold or inconsistently oriented edge
    pos_complex: np.ndarray  # (P,) bool: on an edge of three or more triangles


def _weld(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(pts, axis=0, return_inverse=True)`` (distinct points in lexicographic order, and each
    point's index among them) by a lexicographic sort of the columns: the same result at a third of the
    time (``unique`` sorts rows as structured records)."""
    if pts.shape[0] == 0:
        return pts.reshape(0, 3), np.zeros(0, np.int32)
    order = np.lexsort((pts[:, 2], pts[:, 1], pts[:, 0]))
    s = pts[order]
    new = np.r_[True, np.any(s[1:] != s[:-1], axis=1)]
    inverse = np.empty(pts.shape[0], np.int32)
    inverse[order] = np.cumsum(new) - 1
    return s[new], inverse


def _unbuildable(mesh: Mesh, problem: str) -> BuildError:
    where = mesh.source if mesh.source is not None else "<mesh>"
    return BuildError(
        f"{where}: {problem} (Mesh.from_arrays and load_mesh check and clean a mesh)", code="MESH_INVALID"
    )


def check_buildable(mesh: Mesh) -> None:
    """Raise :class:`BuildError` naming ``mesh.source`` if a :class:`Mesh` made directly (not through
    :meth:`Mesh.from_arrays` or a loader, which check and clean) is not one the kernels can take: no
    triangles, an index outside ``[0, V)`` (the loaders' own check), a NaN/inf point. The kernels index
    without bounds checks, so this is what stands between a bad array and a corrupt heap."""
    from ..errors import MeshLoadError
    from ..io.clean import _as_triangles

    V = mesh.vertex_count
    try:
        _as_triangles(mesh.triangles, V, mesh.source)
    except MeshLoadError as e:
        raise _unbuildable(mesh, e.problem) from None
    finite = np.isfinite(mesh.points).all(axis=1)
    if not finite.all():
        raise _unbuildable(
            mesh,
            f"{int(np.count_nonzero(~finite))} of {V} points have NaN/inf coordinates "
            f"(first: point {int(np.argmin(finite))})",
        )
    # a triangle naming one vertex twice is dead in the collapse state from the start, while the encoders
    # would draw it at LOD 0: LOD 0 would not be the sequence's first mesh (the cleaners drop it)
    t = mesh.triangles
    repeat = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 0] == t[:, 2])
    if repeat.any():
        raise _unbuildable(
            mesh,
            f"{int(np.count_nonzero(repeat))} of {t.shape[0]} triangles name one vertex twice "
            f"(first: triangle {int(np.argmax(repeat))})",
        )


def mesh_topology(mesh: Mesh) -> MeshTopology:
    """Weld positions and classify every edge (:func:`.topology.classify_edges`). Raises :class:`BuildError`
    for a mesh the kernels cannot take (:func:`check_buildable`, and the degenerate triangles below)."""
    check_buildable(mesh)
    pts = mesh.points
    tris = mesh.triangles
    uniq, vertex_pos = _weld(pts)
    P = uniq.shape[0]
    tri_pos = vertex_pos[tris]
    # A triangle with two corners at one position (a seam's two vertices) is taken: the kernels list it
    # twice in that position's star. One with all three there has no edge, and a star longer than the mesh
    # would overrun the kernels' star buffers (any star fits in T rows).
    point = (tri_pos[:, 0] == tri_pos[:, 1]) & (tri_pos[:, 1] == tri_pos[:, 2])
    if point.any():
        raise _unbuildable(
            mesh,
            f"{int(np.count_nonzero(point))} of {tris.shape[0]} triangles have all three corners at one "
            f"position (first: triangle {int(np.argmax(point))})",
        )
    corners = np.bincount(tri_pos.reshape(-1), minlength=P)
    if corners.max() > tris.shape[0]:
        p = int(np.argmax(corners))
        raise _unbuildable(
            mesh,
            f"the position of vertex {int(np.argmax(vertex_pos == p))} is {int(corners[p])} triangle "
            f"corners, more than the mesh's {tris.shape[0]} triangles (triangles with two corners there)",
        )
    # every edge classified in one kernel pass (:func:`.topology.classify_edges`)
    (
        boundary_edges,
        boundary_faces,
        seam_edges,
        seam_faces,
        pos_boundary,
        pos_nonmanifold,
        on_fin,
    ) = classify_edges(tri_pos, np.ascontiguousarray(tris, np.int32), P)
    return MeshTopology(
        vertex_pos=vertex_pos,
        pos_points=uniq.astype(np.float64),
        tri_pos=tri_pos.astype(np.int32),
        boundary_edges=boundary_edges,
        boundary_faces=boundary_faces,
        seam_edges=seam_edges,
        seam_faces=seam_faces,
        pos_boundary=pos_boundary,
        pos_nonmanifold=pos_nonmanifold,
        pos_complex=on_fin,
    )


#: a collapse may not leave a triangle of doubled area at most this fraction of the bounding diagonal
#: squared (numerically flat: its normal is rounding noise) ...
_FLAT_AREA = 2e-10
#: ... nor smaller than this fraction of the input's smallest triangle, where the input has smaller ones
#: (a strip 1000 long and 1e-4 wide is all below the first bound: every collapse was refused) ...
_FLAT_INPUT_SHARE = 0.5
#: ... but never below this fraction of the diagonal squared (float64 rounding of a cross product of
#: edges as long as the diagonal is about 1e-16 of it)
_FLAT_AREA_FLOOR = 1e-13


def _min_area2(pos_points: np.ndarray, tri_pos: np.ndarray, diag: float) -> float:
    """The squared doubled area at or below which a triangle a collapse leaves counts as zero-area."""
    bound = _FLAT_AREA * diag * diag
    smallest2 = kernels.min_doubled_area2(pos_points, tri_pos)  # (inf: no triangle, or none with an area)
    return max(min(bound * bound, _FLAT_INPUT_SHARE**2 * smallest2), (_FLAT_AREA_FLOOR * diag * diag) ** 2)


def make_state(
    mesh: Mesh,
    topo: MeshTopology,
    *,
    boundary_weight: float = 8.0,
    seam_weight: float = 2.0,
    locked_positions: np.ndarray | None = None,
    count_hub_edges: bool = True,
) -> kernels.CollapseState:
    """Fresh simplifier state (quadrics, corner lists, locks) for ``mesh``. ``count_hub_edges`` False: a
    hub's boundary and fin edges are found by sorting its star after each collapse around it, not kept
    counted (the same states, for tests)."""
    P = topo.pos_points.shape[0]
    V = mesh.vertex_count
    edges = np.concatenate([topo.boundary_edges, topo.seam_edges]).reshape(-1, 2)
    faces = np.concatenate([topo.boundary_faces, topo.seam_faces])
    weights = np.r_[
        np.full(len(topo.boundary_faces), boundary_weight), np.full(len(topo.seam_faces), seam_weight)
    ]
    q, w = kernels.init_quadrics(
        topo.pos_points,
        topo.tri_pos,
        edges.astype(np.int32),
        faces.astype(np.int32),
        weights.astype(np.float64),
    )
    # int64 keys as the edge sort's: one numba specialisation of stable_order
    order = kernels.stable_order(topo.vertex_pos.astype(np.int64), P).astype(np.int32)
    pos_vstart = np.zeros(P + 1, np.int32)
    np.cumsum(np.bincount(topo.vertex_pos, minlength=P), out=pos_vstart[1:])
    head, nxt = kernels.build_corner_lists(topo.tri_pos, P)
    diag = float(np.linalg.norm(topo.pos_points.max(0) - topo.pos_points.min(0))) if P else 1.0
    min_area2 = np.array([_min_area2(topo.pos_points, topo.tri_pos, diag)])
    # a complex position slides along its non-manifold edges (kernels.LOCK_COMPLEX) unless it is also on
    # the boundary (where a fin's free edge meets the curve): then it is fixed while it is both. An edge whose
    # two faces run the same way (inconsistent orientation) is a two-face edge like any other: collapses
    # test each face against its own winding
    locked = np.where(topo.pos_complex, kernels.LOCK_COMPLEX, kernels.LOCK_FREE).astype(np.uint8)
    locked[topo.pos_complex & topo.pos_boundary] |= kernels.LOCK_FIXED
    if locked_positions is not None:
        locked[np.asarray(locked_positions, bool)] = kernels.LOCK_FIXED
    st = kernels.CollapseState(
        pos_points=np.ascontiguousarray(topo.pos_points),
        vertex_pos=topo.vertex_pos,
        pos_vstart=pos_vstart,
        pos_verts=order,
        tri_verts=np.array(mesh.triangles, dtype=np.int32, copy=True),
        tri_alive=np.ones(mesh.triangle_count, bool),
        corner_head=head,
        corner_next=nxt,
        quadric=q,
        quadric_weight=w,
        pos_alive=np.bincount(topo.vertex_pos, minlength=P)[:P] > 0,
        pos_locked=locked,
        pos_boundary=topo.pos_boundary.copy(),
        min_area2=min_area2,
        pos_edge_kinds=np.full((P if count_hub_edges else 0, 2), -1, np.int32),
    )
    # pinch vertices (several fans) are non-manifold too
    st.pos_locked[kernels.fan_counts(st) > 1] = kernels.LOCK_FIXED
    assert V == st.vertex_pos.shape[0]
    return st


@dataclass(frozen=True, eq=False)
class CollapseSequence:
    """Ordered half-edge collapses of ``mesh``.

    Per vertex collapse ``c``: ``binned[c]`` moves onto ``kept[c]`` (original vertex ids), ``step[c]`` is
    the position collapse it belongs to and ``error[c]`` that step's quadric error (a distance).
    Errors are raw (not monotone); :meth:`lod_errors` gives the non-decreasing per-step figure.
    ``step_geometric_error[s]`` (when measured): the larger of step ``s``'s quadric error and how far its new
    triangles lie from the input (:mod:`.fan_deviation`) where that raises the running maximum, else the
    quadric error: exact for the running maximum, the figure :meth:`lod_errors` accumulates.
    ``step_offsets[s]`` is the number of vertex collapses done after ``s`` steps (``step_count + 1``
    entries): a level of detail is a whole number of steps.
    """

    mesh: Mesh
    binned: np.ndarray
    kept: np.ndarray
    step: np.ndarray
    error: np.ndarray
    step_error: np.ndarray
    step_offsets: np.ndarray
    binned_position: np.ndarray
    kept_position: np.ndarray
    step_geometric_error: np.ndarray | None = None

    @property
    def collapse_count(self) -> int:
        return int(self.binned.shape[0])

    @property
    def step_count(self) -> int:
        return int(self.step_error.shape[0])

    def vertex_map_after(self, n: int) -> np.ndarray:
        """(V,) the vertex each original vertex has become after the first ``n`` vertex collapses."""
        n = int(n)
        if not 0 <= n <= self.collapse_count:
            raise IndexError(f"collapse count {n} out of range [0, {self.collapse_count}]")
        m = np.arange(self.mesh.vertex_count, dtype=np.int32)
        m[self.binned[:n]] = self.kept[:n]
        while True:  # pointer jumping: a kept vertex may itself be binned later
            m2 = m[m]
            if np.array_equal(m2, m):
                return m
            m = m2

    def triangles_after(self, n: int) -> np.ndarray:
        """Triangles (original vertex ids, original order) after the first ``n`` vertex collapses."""
        t = self.vertex_map_after(n)[self.mesh.triangles]
        keep = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])
        return t[keep]

    def lod_errors(self) -> np.ndarray:
        """(step_count + 1,) error after ``s`` steps: the worst step so far (0 at full detail), by
        ``step_geometric_error`` when measured, else by the quadric error."""
        err = self.step_error if self.step_geometric_error is None else self.step_geometric_error
        return np.r_[0.0, np.maximum.accumulate(err)] if self.step_count else np.zeros(1)

    def triangles_at_step(self, s: int) -> np.ndarray:
        """Triangles after ``s`` whole steps (``s`` in ``[0, step_count]``)."""
        return self.triangles_after(int(self.step_offsets[s]))


def collapse_sequence(
    mesh: Mesh,
    *,
    boundary_weight: float = 8.0,
    seam_weight: float = 2.0,
    locked_positions: np.ndarray | None = None,
    geometric_error: bool = True,
) -> CollapseSequence:
    """Collapse ``mesh`` down to its coarsest valid form in quadric-error order. ``geometric_error``: also
    measure how far each step's new triangles lie from the input (``step_geometric_error``)."""
    topo = mesh_topology(mesh)

    def state():
        return make_state(
            mesh,
            topo,
            boundary_weight=boundary_weight,
            seam_weight=seam_weight,
            locked_positions=locked_positions,
        )

    from . import fan_deviation as fd

    st = state()
    # the LOD errors' replay collapses a light copy of the fresh state (what its searches read: corner
    # positions and lists), taken before the sequence collapses ``st``: one ``make_state``, not two (suzanne,
    # beetle, cow -10 to -15 % of a vanilla build). The collapsed state is let go before the input's BVH is
    # built, so the two are never held together (a 1.1M-triangle bunny's peak: 309 MB above the start, not
    # 343 MB)
    light = fd.replay_state(st) if geometric_error else None
    # (full_ring_update passed, not omitted: the omitted and the passed flag are two compiles of run_sequence)
    binned, kept, step, step_error, step_b, step_k = kernels.run_sequence(st, 3, False)
    del st
    geometric = None
    if geometric_error:
        geometric = np.zeros(0)
        if step_b.shape[0]:
            # (the surface from ``topo``: the positions and vertex positions the state had, which no
            # collapse changes)
            geometric = replay_steps(replay_surface(mesh, topo), light, step_b, step_k, step_error)
    offsets = np.zeros(step_error.shape[0] + 1, np.int64)
    np.cumsum(np.bincount(step, minlength=step_error.shape[0]), out=offsets[1:])
    return CollapseSequence(
        mesh=mesh,
        binned=binned,
        kept=kept,
        step=step,
        error=step_error[step] if step.size else np.zeros(0),
        step_error=step_error,
        step_offsets=offsets,
        binned_position=step_b,
        kept_position=step_k,
        step_geometric_error=geometric,
    )


def step_geometric_errors(
    mesh: Mesh, st: kernels.CollapseState, step_b: np.ndarray, step_k: np.ndarray, step_error: np.ndarray
) -> np.ndarray:
    """Per step of a sequence that starts from ``st`` (a fresh :func:`make_state` of ``mesh``, left as it
    is: the replay collapses its :func:`.fan_deviation.replay_state`): the larger of ``step_error`` and how
    far the step's new triangles lie from ``mesh`` where that raises the running maximum, else
    ``step_error`` (:func:`.fan_deviation.replay_deviations`, :func:`.fan_deviation.step_deviations`' values
    bit for bit)."""
    if step_b.shape[0] == 0:
        return np.zeros(0)
    from . import fan_deviation as fd

    return replay_steps(replay_surface(mesh, st), fd.replay_state(st), step_b, step_k, step_error)


def replay_surface(mesh: Mesh, st: kernels.CollapseState | MeshTopology) -> tuple:
    """What :func:`replay_steps` searches: the input's BVH, a BVH leaf per position and the distance floor
    (``st``: a simplifier state of ``mesh`` or its topology; only their positions and vertex positions,
    which no collapse changes, are read)."""
    from . import fan_deviation as fd

    pts = st.pos_points
    bvh, hints = fd.surface_with_hints(pts, st.vertex_pos[np.asarray(mesh.triangles)])
    diag = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))) if pts.shape[0] else 0.0
    return bvh, hints, fd.DISTANCE_FLOOR * diag


def replay_steps(
    surface: tuple,
    st: kernels.CollapseState | fan_deviation.ReplayState,
    step_b: np.ndarray,
    step_k: np.ndarray,
    step_error: np.ndarray,
    start2: float = 0.0,
) -> np.ndarray:
    """:func:`step_geometric_errors` of the steps that follow ``st``'s state (collapsed by the replay), the
    earlier steps' squared running maximum ``start2``; ``surface``: :func:`replay_surface`. A sequence
    replayed in consecutive parts on one state gives the values of one replay. ``st`` may be the
    :class:`.fan_deviation.ReplayState` of the state (:func:`.fan_deviation.replay_state`): the same values,
    for less work per step."""
    from . import fan_deviation as fd

    bvh, hints, floor = surface
    replay = fd.replay_deviations if isinstance(st, fd.ReplayState) else fd.step_deviations
    return replay(
        st,
        np.ascontiguousarray(step_b, np.int64),
        np.ascontiguousarray(step_k, np.int64),
        np.ascontiguousarray(step_error, np.float64),
        fd.SAMPLES,
        fd.SEARCH_BUDGET,
        floor,
        hints,
        *bvh,
        float(start2),
    )
