"""Numba kernels of the sliding-window builders (see :mod:`.slidingwindow`).

Both builders work on the half-edge collapse state of :mod:`swpm_usd.simplify.kernels` and describe each level
of detail step as a *patch*: the triangles it replaces (``P``, the star of its inner vertices) and the
triangles that replace them (``Q``). Triangles are named by *global triangle ids* (``gid``): the input
triangles are ``0..T-1`` and every triangle a collapse rewrites gets a fresh id whose vertices are appended
to ``gtris``; ``cur_gid[t]`` is the id of the current version of state triangle ``t``.

* :func:`position_graph` - the edge graph of a level's triangles (CSR over positions).
* :func:`level_costs` - best valid collapse of every position (the error ranking behind ``mu``, with
  :mod:`.sw_deviation`'s distance of the collapse's new fan from the input).
* patch centres (independent sets, patches of several inner vertices): :mod:`.sw_centres`.
* :func:`cluster_patches` - patch centres whose stars are disjoint intervals of the previous level's tail
  (``cluster=True``, SWPM section 3.2).
* :func:`patch_triangles` - the triangles of every patch, ordered as fans (edge-adjacent chains).
* :func:`absorb_middle` - grows the patches by the triangles of no patch (the static middle).
* :func:`reassign_middle` - moves those triangles to the patch where the patch order draws them cheapest.
* :func:`order_patches` - greedy vertex-cache order of the patches for the ``P`` and the ``Q`` sequence
  (TD-VIPM section 3.2).
* :func:`collapse_patches` - removes the inner vertices of every patch, in that order.
* Forsyth's builder (QEM order, error-tolerance reordering, level restarts): :mod:`.sw_forsyth`.
* SWPM 3.1's edge swaps creating low-degree vertices (``optimize_connectivity``): :mod:`.sw_swaps`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..simplify import kernels as K
from .sw_fans import _chain_order_into, _chain_work, _chain_work_for, chain_order  # noqa: F401
from .sw_levels import level_costs, level_positions, position_graph, rank_centres, ties_by_index  # noqa: F401
from .sw_cluster import _cheapest_prefix, _tail_intervals, cluster_components, cluster_patches  # noqa: F401
from .sw_patches import absorb_middle, patch_triangles  # noqa: F401
from .sw_order import ORDER_LIVE_WEIGHT, ORDER_LIVE_WEIGHT_CLUSTER, _fifo_misses, _fifo_push, order_patches, reassign_middle  # noqa: F401
from .sw_collapse import _emit_into, _grow_tris, _record_collapse, _record_collapse_into, _shaped_collapse, _target_rows, collapse_patches  # noqa: F401



