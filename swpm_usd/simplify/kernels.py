"""Numba kernels of the half-edge collapse simplifier (Garland-Heckbert quadrics, Svarovsky's VIPM).

The mesh is held twice: *vertices* (what the GPU draws, split at attribute seams) and *positions* (welded
points). Collapses are decided on positions: binning position ``b`` onto position ``k`` moves every vertex at
``b`` onto the vertex at ``k`` it shares an edge triangle with (Svarovsky's "difficult edges" are banned:
a vertex at ``b`` that touches no triangle of the edge, or two different vertices at ``k``, refuses the
collapse). The kept position never moves (half-edge collapse, no new vertices).

State lives in a namedtuple of arrays (:class:`CollapseState`) so that other builders (the sliding-window
levels) can reuse :func:`valid_collapse`, :func:`collapse_cost` and :func:`apply_collapse`.

Per position: a linked list of the triangle corners that sit on it (``corner_head``/``corner_next``,
corner ``3*t+i``), compacted lazily when walked; a quadric ``quadric[p, 0:10]`` (upper triangle of the 4x4
matrix) and the face area it sums in ``quadric_weight[p]``.

The kernels live one algorithm to a module, in the order they call each other:

- :mod:`.state`: :class:`CollapseState`, the lock kinds, :data:`HUB_SIZE`, the corner lists;
- :mod:`.stars`: a position's star (its triangles, their positions, its neighbours), one or all at once;
- :mod:`.quadrics`: seeding the quadrics, :func:`collapse_cost`, the triangle normal;
- :mod:`.validity`: :func:`valid_collapse` and :func:`vertex_map` (topology, geometry, seams);
- :mod:`.apply`: :func:`apply_collapse` and the boundary / complex kinds it keeps;
- :mod:`.best`: :func:`best_collapse`, a position's cheapest valid target;
- :mod:`.heap`: the array min-heap of the collapse queue;
- :mod:`.run`: :func:`run_sequence`, the greedy sequence;
- :mod:`.topology`: counting sorts and :func:`fan_counts`.

This module re-exports every name of them: callers write ``from swpm_usd.simplify import kernels as K`` and
``K.valid_collapse`` whichever module defines it.
"""

from __future__ import annotations

from .apply import (
    _corners_at,
    _count_hub_edges,
    _edge_count,
    _recount_edge,
    _refresh_kind,
    _row_corners_at,
    _set_kind,
    apply_collapse,
)
from .best import (
    MAX_TARGET_TRIES,
    best_collapse,
    best_collapse_sized,
    best_of_star,
)
from .heap import (
    _heap_pop,
    _heap_push,
    _heap_push_into,
)
from .quadrics import (
    _add_plane,
    _cost_of,
    _eval_quadric2,
    collapse_cost,
    init_quadrics,
    min_doubled_area2,
    tri_normal,
)
from .run import (
    run_sequence,
)
from .stars import (
    _LARGE_STAR,
    Stars,
    _gather_into,
    _gather_rows,
    _has,
    _neighbours_into,
    _neighbours_rows,
    _neighbours_rows_sorted,
    _positions_into,
    _positions_rows,
    _star_arrays_at,
    gather_triangles,
    neighbours,
    star_buffers,
    star_into,
    star_rows,
    star_snapshot,
    triangle_positions,
)
from .state import (
    HUB_SIZE,
    LOCK_COMPLEX,
    LOCK_FIXED,
    LOCK_FREE,
    CollapseState,
    build_corner_lists,
    is_hub,
)
from .topology import (
    _SMALL_SORT,
    _find_root,
    fan_counts,
    group_by,
    stable_order,
)
from .validity import (
    _alive_more_than,
    _hub_side_of,
    _moved_face_ok,
    _single_vertex_maps,
    _valid_complex_collapse,
    _vertex_map,
    alive_more_than_in,
    edge_count_ok,
    edge_count_ok_in,
    hub_side_rows,
    valid_collapse,
    valid_collapse_in,
    vertex_map,
)

# every name of the collapse kernels, whichever module defines it: the encoders' ``K.xxx`` and the tests
# read them here
__all__ = [
    "CollapseState",
    "LOCK_FREE",
    "LOCK_FIXED",
    "LOCK_COMPLEX",
    "HUB_SIZE",
    "is_hub",
    "build_corner_lists",
    "Stars",
    "gather_triangles",
    "_gather_into",
    "_gather_rows",
    "triangle_positions",
    "neighbours",
    "_neighbours_into",
    "_LARGE_STAR",
    "_neighbours_rows_sorted",
    "_neighbours_rows",
    "_positions_rows",
    "_star_arrays_at",
    "star_snapshot",
    "star_into",
    "_positions_into",
    "star_rows",
    "star_buffers",
    "_has",
    "_add_plane",
    "_eval_quadric2",
    "init_quadrics",
    "tri_normal",
    "min_doubled_area2",
    "collapse_cost",
    "_cost_of",
    "vertex_map",
    "_vertex_map",
    "_single_vertex_maps",
    "valid_collapse",
    "_alive_more_than",
    "alive_more_than_in",
    "_hub_side_of",
    "hub_side_rows",
    "edge_count_ok",
    "edge_count_ok_in",
    "_moved_face_ok",
    "valid_collapse_in",
    "_valid_complex_collapse",
    "apply_collapse",
    "_corners_at",
    "_row_corners_at",
    "_edge_count",
    "_recount_edge",
    "_count_hub_edges",
    "_refresh_kind",
    "_set_kind",
    "best_collapse",
    "best_collapse_sized",
    "MAX_TARGET_TRIES",
    "best_of_star",
    "_heap_push",
    "_heap_push_into",
    "_heap_pop",
    "run_sequence",
    "group_by",
    "stable_order",
    "_find_root",
    "_SMALL_SORT",
    "fan_counts",
]
