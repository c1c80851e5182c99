"""A position's best collapse: its cheapest valid target among its neighbours.

:func:`best_collapse` costs every neighbour (:func:`.quadrics.collapse_cost`) and tests them cheapest
first (:func:`.validity.valid_collapse`), at most :data:`MAX_TARGET_TRIES`; unvalidated it returns the
cheapest, for the queue's lazy evaluation.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .quadrics import collapse_cost
from .stars import Stars, gather_triangles, neighbours, triangle_positions
from .state import LOCK_FIXED, CollapseState
from .validity import valid_collapse


@nb.njit(cache=True, nogil=True)
def best_collapse(
    st: CollapseState, b: int, validate: bool = True, stars: Stars | None = None
) -> tuple[int, float]:
    """Cheapest target for binning ``b``: (k, cost), or (-1, inf). With ``validate`` False the cheapest
    neighbour is returned unchecked (the queue re-checks it when it comes up: lazy evaluation).
    ``stars``: a snapshot of ``st`` (:func:`star_snapshot`) to read the stars from instead of the
    corner lists."""
    k, cost, _ = best_collapse_sized(st, b, validate, stars)
    return k, cost


@nb.njit(cache=True, nogil=True)
def best_collapse_sized(
    st: CollapseState, b: int, validate: bool = True, stars: Stars | None = None
) -> tuple[int, float, int]:
    """:func:`best_collapse` and the number of ``b``'s triangles (0 if it was not read)."""
    if st.pos_locked[b] & LOCK_FIXED or not st.pos_alive[b]:
        return -1, np.inf, 0
    if stars is None:
        tris_b = gather_triangles(st, b)
        tp_b = triangle_positions(st, tris_b)
        nbr = neighbours(b, tp_b)
    else:
        tris_b = stars.tris[stars.start[b] : stars.start[b + 1]]
        tp_b = stars.tp[stars.start[b] : stars.start[b + 1]]
        nbr = stars.nbr[stars.nbr_start[b] : stars.nbr_start[b + 1]]
    if tris_b.shape[0] == 0:
        return -1, np.inf, 0
    k, cost = best_of_star(st, b, tris_b, tp_b, nbr, validate, stars, np.empty(nbr.shape[0]))
    return k, cost, tris_b.shape[0]


# The targets a position tries, cheapest first, before it counts as having no valid collapse: a hub of
# thousands of triangles that no collapse suits checked every target against its whole star (quadratic per
# check). A star of up to 32 neighbours tries them all (teapot's coarse end has positions of 40; its
# sequence, like the ten shared meshes', is the same as without the limit)
MAX_TARGET_TRIES = 32


@nb.njit(cache=True, inline="always")
def best_of_star(
    st: CollapseState,
    b: int,
    tris_b: np.ndarray,
    tp_b: np.ndarray,
    nbr: np.ndarray,
    validate: bool,
    stars: Stars | None,
    costs: np.ndarray,
) -> tuple[int, float]:
    """:func:`best_collapse` of ``b`` (alive, unlocked, with triangles) from its star read already
    (``tris_b``, ``tp_b``, ``nbr``), the costs written to ``costs`` (room for ``len(nbr)``).
    Returns the costs of all of ``nbr`` in ``costs[:len(nbr)]`` too."""
    # targets are passed on as int64 (``nbr`` holds int32): one numba specialisation of each callee for
    # every caller (the builders' own targets are int64)
    nn = nbr.shape[0]
    best = 0
    for i in range(nn):
        costs[i] = collapse_cost(st, b, np.int64(nbr[i]))
        if costs[i] < costs[best]:
            best = i
    if not validate:
        return nbr[best], costs[best]
    k = np.int64(nbr[best])
    if valid_collapse(st, b, k, tris_b, tp_b, nbr, stars):
        return k, costs[best]
    order = np.argsort(costs[:nn])
    for i in range(1, min(order.shape[0], MAX_TARGET_TRIES)):
        k = np.int64(nbr[order[i]])
        if valid_collapse(st, b, k, tris_b, tp_b, nbr, stars):
            return k, costs[order[i]]
    return -1, np.inf
