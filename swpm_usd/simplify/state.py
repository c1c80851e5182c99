"""The collapse state the simplifier edits in place, and the kinds of position it knows.

:class:`CollapseState` holds the mesh twice, as *vertices* (split at attribute seams) and as welded
*positions*, with a linked list of the triangle corners on each position (:func:`build_corner_lists`);
``pos_locked`` marks positions that never move (``LOCK_FIXED``) or only slide along a non-manifold edge
(``LOCK_COMPLEX``); :data:`HUB_SIZE` is the star size above which a position is a hub. Svarovsky's VIPM
(references/001, half-edge collapse onto a kept vertex, "difficult edges" at seams).
"""

from __future__ import annotations

from collections import namedtuple

import numba as nb
import numpy as np

CollapseState = namedtuple(
    "CollapseState",
    [
        "pos_points",  # (P,3) f64 welded positions
        "vertex_pos",  # (V,) i32 position of every vertex
        "pos_vstart",  # (P+1,) i32 CSR of the vertices at each position
        "pos_verts",  # (V,) i32
        "tri_verts",  # (T,3) i32 current vertex ids (edited by collapses)
        "tri_alive",  # (T,) bool
        "corner_head",  # (P,) i32 first corner on each position, -1 if none
        "corner_next",  # (3T,) i32 next corner on the same position, -1 at the end
        "quadric",  # (P,10) f64
        "quadric_weight",  # (P,) f64
        "pos_alive",  # (P,) bool
        "pos_locked",  # (P,) u8: LOCK_FREE or the bits LOCK_FIXED (never binned), LOCK_COMPLEX (below)
        "pos_boundary",  # (P,) bool
        "min_area2",  # (1,) f64: squared doubled-area below which a triangle counts as zero-area
        # (P,2) i32: a hub's edges of one triangle and of three or more, -1 until counted; (0,2): none
        # counted (see _refresh_kind)
        "pos_edge_kinds",
    ],
)

#: ``pos_locked`` bits. A free position (0) may be binned by any valid collapse; a fixed one never. A complex
#: one lies on an edge of three or more triangles (a fin, two sheets along a crease): it may only slide along
#: such an edge onto another complex position, so a non-manifold curve shortens without dragging a sheet off
#: it (meshoptimizer's "complex" vertices move onto each other too). A complex position on the boundary (where
#: a fin's free edge meets the curve) is fixed as well. Both bits of a complex position, and ``pos_boundary``,
#: follow the mesh: once its last edge of three triangles or its last boundary edge is gone (a fin collapsed
#: away, :func:`apply_collapse`), the bits and the flag drop. A plain fixed position (a pinch vertex, the
#: caller's choice: ``LOCK_FIXED`` alone) stays fixed. A complex centre's sliding-window patch is its whole
#: star.
LOCK_FREE = 0
LOCK_FIXED = 1
LOCK_COMPLEX = 2


# A position or vertex with more neighbours or patches than this is a hub (a cone's apex, a cap's centre:
# thousands of triangles). The builders that look for a neighbouring centre or patch through the vertices
# it shares with others do not look through a hub's list: its members lie all over the mesh and along the
# whole patch order, and each look was linear in the mesh (a cone of 12,000 triangles spent 17 s of its
# sliding-window build in reassign_middle alone). Ordinary vertices have a few neighbours each. And a
# position found with no valid target is checked again only after ``star size // HUB_SIZE`` collapses
# next to it (run_sequence, Forsyth's builder; a star of 64 triangles or more waits), not after every
# one: a hub that no collapse suits was re-queued by each collapse of its ring and checked against its
# targets at once, a cubic sequence (a cone of 16,000 triangles: 372 s). In run_sequence a hub evaluated
# in a ring waits so too, whatever it found. Around a hub of more than HUB_SIZE alive triangles, as a
# non-manifold hub in every triangle makes (vanilla: 99 s at 3,000 triangles, cubic), nothing reads the
# hub's whole star per collapse: a collapse onto it refreshes the binned ring alone (run_sequence,
# Forsyth's builder) and the hub every star // HUB_SIZE collapses, a target's test reads the hub's star
# around the binned ring (hub_side_rows), and its boundary and fin edges are counted (pos_edge_kinds)
HUB_SIZE = 64


@nb.njit(cache=True, inline="always")
def is_hub(start: np.ndarray, i: int) -> bool:
    """Whether entry ``i`` of a CSR listing (``start``: offsets) lists more than :data:`HUB_SIZE` items."""
    return start[i + 1] - start[i] > HUB_SIZE


@nb.njit(cache=True, nogil=True)
def build_corner_lists(tri_pos: np.ndarray, P: int) -> tuple[np.ndarray, np.ndarray]:
    head = np.full(P, -1, np.int32)
    nxt = np.full(3 * tri_pos.shape[0], -1, np.int32)
    for t in range(tri_pos.shape[0] - 1, -1, -1):
        for i in range(2, -1, -1):
            c = 3 * t + i
            p = tri_pos[t, i]
            nxt[c] = head[p]
            head[p] = c
    return head, nxt
