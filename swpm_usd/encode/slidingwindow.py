"""Sliding-window VIPM (Forsyth, "Comparison of VIPM Methods"; TD-VIPM; SWPM index-dataset reduction).

One static index pool serves every level of detail; changing LOD is a look-up in ``window_records`` (first
index offset, triangle count, vertex count: Forsyth's ``SlidingWindowRecord``) and nothing is edited at run
time, so an instance needs only its LOD number.

Layout. The pool is a cascade of *levels*. A level starts from a mesh ``T_L`` and a list of disjoint
patches ``P_1..P_n`` (``P_i``: the triangles around the inner vertices of patch ``i``); ``Q_i`` is ``P_i``
after its inner vertices are removed by half-edge collapses, and ``M`` the level's triangles in no patch.
The level is stored as (SWPM eq. 1, with the untouched middle of Forsyth's three sections)::

    P_1 || P_2 || ... || P_n || M || Q_1 || Q_2 || ... || Q_n

and the LOD after the first ``j`` patches of the level is the ONE contiguous window
``P_{j+1} .. P_n || M || Q_1 .. Q_j`` (it starts ``|P_1..P_j|`` triangles in and holds
``|T_L| - |P_1..P_j| + |Q_1..Q_j|`` triangles): the window slides towards the end of the pool as detail
drops. The next level starts from the level's simplest mesh ``M || Q_1..Q_n``; levels are concatenated.
LOD ``k`` counts patches over all levels, finest first (``lod_count = patches + 1``); the last LOD of a
level is the first window of the next one. The coarsest LOD may be stored once more after the last level,
as one cache-ordered block (``coarsest_copy``): its record then points there.

Vertices. Vertex collapses are numbered in build order over all levels; the vertex the ``c``-th one bins is
stored at index ``V - 1 - c`` (as in vanilla VIPM), never-binned vertices first, so LOD ``k`` uses exactly
the prefix ``[0, vertex_count_at(k))``. An attribute seam puts several vertices at one position: the step
that bins the position bins all of them (``vertex_map``).

Builders and options, in short (``slidingwindow.md`` next to this file has the design notes: why each
choice, what was measured and what was tried and dropped):

* ``builder="topology"`` (TD-VIPM, the default): per level, a greedy minimum-degree maximal independent set of
  patch centres (TD-VIPM 3.1, :mod:`.sw_centres`) in which a fraction ``mu`` of the highest-error vertices may
  not be centres (SWPM 3; a vertex's error: its best collapse's quadric cost or how far that collapse's new
  fan lies from the input, whichever is larger, :mod:`.sw_deviation`); each centre goes by its best valid
  half-edge collapse, or to a neighbour of higher degree costing at most ``target_slack`` of the level's
  ``mu`` cut more; the triangles of no patch join a patch (``absorb_middle``; ``absorb_rounds`` rings of them,
  0 for all, a warmer cache at high ``mu``); the patches are ordered for a FIFO vertex cache (TD-VIPM 3.2,
  :func:`.sw_order.order_patches`) and the triangles inside every block after them
  (:func:`swpm_usd.vcache.optimize_block_order`). ``inner_vertices > 1`` (SWPM 3.3): patches of several inner
  vertices, fewer LODs, a smaller pool. ``order_passes`` (None: 2 here, 0 with ``cluster``) passes of a local
  search then move patches up to ``order_reach`` places (default 2) wherever the FIFO misses summed over the
  level's windows fall (:mod:`.sw_refine`; a warmer cache, the same pool and errors; more passes and a longer
  reach for a longer build). ``coarsest_copy`` (default True): the coarsest LOD also stored on its own after
  the last level, cache-ordered as one block, where it is small and that saves misses. ``error_bound``
  (default None, off): a level's vertices ranked above ``error_bound`` times the plain quadric sequence's
  error at the level's expected end are barred too (:mod:`.sw_bound`; pool for error on the meshes whose
  levels take collapses far dearer than the quadric order's; ``builder="forsyth"`` refuses it).
* ``builder="forsyth"``: Forsyth's quadric-error order with the error-tolerance reordering
  (:mod:`.sw_forsyth`); the topology builder's own parameters (``encodings.TOPOLOGY_ONLY_PARAMS``,
  ``cluster``, ``order_passes``, ``error_bound``) are refused with it unless left at their defaults.
* ``optimize_connectivity=True`` (SWPM 3.1): edge swaps creating low-degree vertices first, each moving the
  surface by at most ``swap_max_deviation`` of the bounding-box diagonal (:mod:`.sw_swaps`).
* ``cluster=True`` (SWPM 3.2): a level's patches read out of the previous level's tail, so consecutive
  levels share storage, where that costs fewer pool triangles per collapse
  (:func:`.sw_cluster.cluster_patches`; with ``inner_vertices > 1`` patches of several adjacent positions,
  :func:`.sw_cluster.cluster_components`).
* ``primitive="strip"`` (default ``"list"``): the pool stored as triangle strips, a new strip (after a
  restart index) at every window's first triangle, a window's end a barrier the stripifier does not reorder
  across, so a window is still one range, one strip draw (:mod:`.sw_strips`; ``strip_window``: the
  stripifier's look-ahead, default 4, as skip-strip's).

Every ordering is for a FIFO cache of ``cache_size`` entries (default 16).

Where the code is: this module checks the parameters and builds the levels one after another
(:func:`_build_levels`, with the tuning constants and their measurements above it; :func:`_build_topology`
runs it beside the worker threads); :mod:`.sw_assemble` assembles the pool, its records and the vertex order
from the levels (and the coarsest LOD's copy) into a :class:`.sw_mesh.SlidingWindowProgressiveMesh` (the
pool and records as stored, the LOD look-ups, the memory figures and buffers); :mod:`.sw_layout` finishes a
level (its patch order search and block layout), :mod:`.sw_threads` shares the main thread's work with a
helper thread. The numba kernels, in the order a level runs them: :mod:`.sw_levels` (a level's positions,
edge graph and error ranking), :mod:`.sw_bound` (``error_bound``'s reference), :mod:`.sw_centres` (patch
centres), :mod:`.sw_cluster` (clustered patches),
:mod:`.sw_patches` (the patches' triangles, the absorbed middle), :mod:`.sw_order` (the patch order for the
cache), :mod:`.sw_collapse` (collapsing the patches), :mod:`.sw_refine` (patch order search); with
:mod:`.sw_fans` (fan order of a few triangles), :mod:`.sw_deviation` (fan deviation), :mod:`.sw_swaps` (edge
swaps, and their entry point
:func:`.sw_swaps.optimize_mesh_connectivity`) and :mod:`.sw_forsyth` (Forsyth's builder, and
:func:`.sw_forsyth._build_forsyth`, which cuts its run into levels). The names that moved out of this module
are imported back (``SlidingWindowProgressiveMesh``, ``optimize_mesh_connectivity``,
``COARSEST_COPY_MAX_SHARE``, ``_assemble``, ``_build_forsyth``); a constant is patched where the code that
reads it lives (``sw_assemble.COARSEST_COPY_MAX_SHARE``: patched here it changes nothing).

The builders also keep their own collapse sequence (:attr:`SlidingWindowProgressiveMesh.collapse_sequence`,
a :class:`swpm_usd.simplify.CollapseSequence`; ``lod_steps[k]`` steps of it give LOD ``k``), against which
the tests replay every window.
"""

from __future__ import annotations

import numbers
import os
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import Any

import numpy as np

from ..build import check_cache_size
from ..encodings import (
    MAX_ORDER_PASSES,
    MAX_ORDER_REACH,
    MAX_STRIP_WINDOW,
    PRIMITIVES,
    SLIDING_WINDOW_PARAMS,
    SWAP_MAX_DEVIATION,
    combination_problem,
)
from ..errors import BuildError
from ..mesh import Mesh
from ..simplify import make_state, mesh_topology
from ..simplify.fan_deviation import replay_state
from ..simplify.kernels import star_snapshot
from ..simplify.sequence import replay_steps, replay_surface
from . import sw_bound, sw_cluster, sw_collapse, sw_levels, sw_order, sw_patches
from . import sw_centres as swc
from . import sw_deviation as swd
from . import sw_layout as swl
from . import sw_threads as swt
from .screen import screen_space_error
from .sw_assemble import COARSEST_COPY_MAX_SHARE, _assemble
from .sw_forsyth import _build_forsyth
from .sw_mesh import SlidingWindowProgressiveMesh
from .sw_strips import use_strips
from .sw_swaps import optimize_mesh_connectivity

__all__ = [
    "COARSEST_COPY_MAX_SHARE",
    "SLIDING_WINDOW_PARAMS",
    "SlidingWindowProgressiveMesh",
    "build_sliding_window",
    "optimize_mesh_connectivity",
    "screen_space_error",
]


#: ``order_passes=None`` (the default): passes of the patch-order search for ``builder="topology"`` without
#: ``cluster`` (whose linked levels take their order from the previous level's tail; 0 there). Ten meshes,
#: ACMR ratio to meshoptimizer over 40 fractions from 100 to 5 % (400 points): no search 1.0588 (350 within
#: 1.10, 179 within 1.05); two passes of reach 1 1.0436 (365, 241). With the coarsest LOD's copy: no search
#: 1.0577 (353, 182); two passes of reach 1 1.0425 (368, 244), of reach 2 (``order_reach``'s default) 1.0357
#: (377, 268), of reach 3 1.0345 (377, 275). CPU time over no search, inline, ten meshes, medians of
#: three: 1.25x / 1.46x / 1.68x for reach 1 / 2 / 3. With each level searched on the worker thread
#: (``FINISH_IN_THREAD``) the wall time on two cores grows less (ten builds 3.4 s with reach 1, 4.1 s with
#: reach 2; bunny's LOD chain 5.1-6.1x meshoptimizer's -> 5.8-6.6x, cow's 7.9-8.6x -> 8.1-9.1x, three
#: alternating runs)
DEFAULT_ORDER_PASSES = 2


# --------------------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------------------


def _adjacency(tp: np.ndarray, P: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR of the position graph of the triangles ``tp`` (positions)."""
    return sw_levels.position_graph(np.ascontiguousarray(tp, np.int64), P)


#: weight of a vertex's error rank (0 = lowest error, 1 = highest) next to its remaining degree in the
#: greedy choice of patch centres (2: a vertex of the lowest error beats one of the highest even with two
#: more free neighbours; lambda +0.5 %, Hausdorff error at 10 % of the triangles -14 % on bunny)
_ERROR_WEIGHT = 2.0

#: rank a level's vertices (the ``mu`` cut and the error rank above) by their best collapse's quadric cost or
#: how far its new fan lies from the input, whichever is larger (:mod:`.sw_deviation`; False: the quadric cost
#: alone, until 2026-12-03). Ten shared meshes at the defaults, 100,000 samples: Hausdorff ratio to
#: meshoptimizer at 50/25/10 % (geometric mean of 30) 1.55 -> 1.34, within 1.5 16 -> 21 of 30; ACMR within
#: 1.10 36 -> 39 of 40; lambda mean 5.339 -> 5.303; builds about 1.3x as long (``slidingwindow.md``)
_RANK_BY_DEVIATION = True
#: fan samples nearer the input than this fraction of the bounding-box diagonal (and than the quadric cost)
#: are not searched exactly: rounding, far below any error that matters
_DEVIATION_FLOOR = 1e-6
#: levels before this one take only the binned point's distance from its fan. 0: every level samples its fans
#: (ten meshes, 100,000 samples: Hausdorff ratio within 1.5 on 23 of 30 points, geomean 1.291, against 21 and
#: 1.337 from level 1: level 0's costliest fans set the error of every window after it; cow builds 1.09x)
_DEVIATION_FROM_LEVEL = 0
#: the share of a level's vertices, the highest by quadric cost and binned point's distance, whose fan samples
#: are searched (bunny: 96-100 % of the top tenth by the full ranking are in the top half of that one)
_DEVIATION_SHARE = 0.5
#: nodes a sample's search may open (512: the ten shared meshes build the same pools as without a limit; a
#: cone of 80,000 sections 24 s without, 4.1 s with it)
_DEVIATION_BUDGET = 512

#: ``error_bound``: a level's expected end, the share of its triangles left after it (a level of single
#: inner vertices removes about 30 %), at which the plain quadric sequence's error is the bound's reference
_BOUND_END = 0.7
#: the bound is at least this fraction of the bounding-box diagonal (a flat start, where the quadric
#: sequence's error is 0, would bar every vertex of any cost)
_BOUND_FLOOR = 1e-5


#: iterations of the centre search (:func:`sw_centres.grow_independent_set`) per eligible vertex: the
#: minimum-degree greedy leaves 2-3 % of the possible centres (bunny, ``mu=0.1``, one run: lambda 5.68
#: with the greedy alone, 5.65 with the local search only, 5.56 / 5.53 / 5.50 with 0.5 / 1 / 2 iterations
#: per vertex for a build time of +10 / +21 / +44 %)
_CENTRE_SEARCH = 0.5
_CENTRE_SEARCH_SEED = 0x5EED

#: one inner vertex: the exchanges of :func:`sw_centres.lower_costly_centres` after the 1-for-1 swaps
#: lower ``sum(rank ** _TAIL_POWER)`` over the centres (error rank in [0, 1]), trying the ``_TAIL_TRIES``
#: cheapest neighbours of every centre, ``_TAIL_PASSES`` rounds. A LOD's Hausdorff maximum comes from the
#: top percent or two of its level's collapses (cow: the nearest collapse to the worst sample has rank
#: 0.96-0.99 among the level's), so the high power. The 10 shared meshes at 50/25/10 % of the triangles,
#: 100,000 samples, Hausdorff ratio to meshoptimizer's simplify (geometric mean of 30): 1.64 -> 1.54,
#: 11 -> 15 within 1.5 (at 9 fractions from 70 to 10 %, 30,000 samples: 1.78 -> 1.68, 24 -> 33 of 90
#: within 1.5), lambda within +0.4 %, bunny build time +8 %. Power 16 with 6 tries and 3 passes: 1.54 for
#: 2.5 times the build time; power 8, 6 tries, 4 passes: 1.61; only centres ranked 0.5 or more: 1.59 (single
#: ratios move by +-0.3 between near-identical centre sets)
_TAIL_POWER = 8.0
_TAIL_TRIES = 3
_TAIL_PASSES = 2


def _more_centres(adj_start: np.ndarray, adj: np.ndarray, eligible: np.ndarray, centres: np.ndarray):
    iterations = int(_CENTRE_SEARCH * np.count_nonzero(eligible))
    return swc.grow_independent_set(adj_start, adj, eligible, centres, iterations, _CENTRE_SEARCH_SEED)


#: finish each fully stored level (its patch order search and cache order, :func:`.sw_layout.finish_level`)
#: on a worker thread while the next level is built (the kernels release the GIL; the pool is the same bit
#: for bit). Bunny, medians of 3 alternating builds: 1.25 -> 0.98 s without the search, 2.48 -> 1.61 s with
#: two passes of reach 3; cow 0.11 -> 0.09 s and 0.25 -> 0.17 s. False: every level is finished inline (as
#: inside :func:`inline_finishing`, which the pipeline's workers use: ``--jobs`` is the pipeline's
#: parallelism), and no helper thread shares the main thread's work either (:mod:`.sw_threads`)
FINISH_IN_THREAD = True
_THIS_THREAD = threading.local()


@contextmanager
def inline_finishing() -> Iterator[None]:
    """Builds on this thread finish their levels inline (no worker thread) inside the block: for a process
    or thread that shares the cores with other builds. Per thread, so concurrent callers do not interfere."""
    before = getattr(_THIS_THREAD, "inline", False)
    _THIS_THREAD.inline = True
    try:
        yield
    finally:
        _THIS_THREAD.inline = before


#: ``inner_vertices > 1``: iterations of the patch search (:func:`sw_centres.grow_component_set`) per
#: eligible vertex, and the random jitter of its greedy refill (in free neighbours). Bunny with the edge
#: swaps (the former 10-degree guard), three inner vertices: lambda 3.32 without the search, 3.30 / 3.13 /
#: 3.10 with 0 / 1 / 3 iterations per vertex (jitter 0.5); jitter 1.0 at 1 iteration: 3.13 (build time +0.5 s)
_PATCH_SEARCH = 1.0
_PATCH_SEARCH_JITTER = 1.0

#: ``inner_vertices > 1``: an inner vertex may go to a neighbour of higher degree than its cheapest
#: target if that costs at most this fraction of the level's ``mu`` cut more (and stays under it): the
#: collapses pile the edges on fewer vertices, the next level has more low-degree vertices and its patches
#: take more of them (the bound is about half the vertices of a degree-6 mesh). Bunny with the edge swaps,
#: three inner vertices and the patch search: lambda 3.13 / 3.11 / 3.06 / 2.97 at 0 / 0.02 / 0.1 / 0.3;
#: the Hausdorff error (geometric mean of the 12 err ratios of bunny and cow, inner3 and inner3-swap) 1.75
#: before the search, 1.79 at 0.1, 2.00 at 0.3. With the 5e-4 swap bound, ten shared meshes, three inner
#: vertices with the edge swaps, 30,000 samples: slack 0.1 / 0.5 / 1.0 gives lambda mean 3.216 / 3.096 /
#: 3.056 (bunny 2.912 / 2.804 / 2.775), Hausdorff ratio geometric mean 1.86 / 1.97 / 2.03 at 50/25/10 %, the
#: ACMR unchanged (1.066 / 1.064 / 1.062); lowering ``mu`` to 0.05 instead reaches the same lambda (3.074,
#: bunny 2.773) at 2.19: the slack is the cheaper of the two ways to a smaller pool. Both constants are the
#: defaults of the ``target_slack`` parameter.
_TARGET_SLACK = 0.1
#: the same for one inner vertex (the patch centres). The ten shared meshes, 12 fractions from 90 to 5 % of
#: the triangles (120 points; Hausdorff at 30,000 samples), slack 0 / 0.05 / 0.1: lambda mean 5.61 / 5.39 /
#: 5.31 (bunny 5.55 / 5.37 / 5.25), ACMR ratio mean 1.059 / 1.070 / 1.070 (104 / 100 / 94 within 1.10),
#: Hausdorff ratio geometric mean 1.71 / 1.67 / 1.73 (45 / 45 / 49 within 1.5): a smaller pool for a
#: slightly colder cache, the error unchanged within its noise. Spent on ``mu`` (same ten meshes, 50/25/10 %,
#: 100,000 samples): ``mu=0.2, target_slack=1.0`` keeps the defaults' pool (lambda mean 5.343 against 5.354)
#: at a Hausdorff ratio of 1.46 against 1.59 (geometric means), for a colder cache (30 of 40 ACMR ratios
#: within 1.10, against 34)
_TARGET_SLACK_SINGLE = 0.05

#: topology builder with ``absorb_middle=True``: a triangle of no patch joins the patch with which it
#: shares the most, a shared vertex counting 2 and a shared position of another vertex (a seam) 1, if that
#: is at least this much (1: a corner, so nearly every one); it is then stored twice (in ``P_i`` and
#: ``Q_i``) instead of once in ``M``: lambda +15 %, but ``M`` is no longer drawn as a separate scattered
#: block in every window (bunny, FIFO 16, ACMR / meshoptimizer at 100/50/25/10 % of the triangles:
#: 1.26/1.60/1.60/1.47 -> 1.04/1.08/1.08/1.06, lambda 4.94 -> 5.68). ``absorb_middle=False`` keeps them
#: in the static middle.
_ABSORB_MIN_SHARED = 1
#: ... but only on a level whose patches (their own stars) cover at least ``1 - _ABSORB_MAX_MIDDLE`` of its
#: triangles. On a coarse level where few vertices can still go (beetle's last levels: 7-23 patches on
#: 220-300 triangles, 62-79 % of them in no star) the middle is one connected mesh that draws well as a
#: single block, and absorbing it would store most of the level twice as blobs around the few centres.
#: Ten shared meshes, ACMR ratio at 20 fractions (100 to 5 %): worst window 1.256 -> 1.157 (beetle at 10 %),
#: mean 1.0582 -> 1.0573, lambda mean 5.385 -> 5.354 (beetle 5.89 -> 5.62); with the edge swaps worst
#: 1.178 either way, lambda 4.906 -> 4.872. A bound of 0.4-0.5 leaves beetle levels of 42-48 % middle
#: unabsorbed, where the blobs draw better (worst window 1.34). With the patch order's live weight at 1.0
#: (``sw_order.ORDER_LIVE_WEIGHT``; 400 points, 100 to 5 %): worst 1.252 -> 1.205, mean 1.0329 ->
#: 1.0332, lambda mean 5.393 -> 5.362 (beetle 5.93 -> 5.69)
_ABSORB_MAX_MIDDLE = 0.6
#: ``absorb_rounds=0``: rounds of :func:`.sw_patches.absorb_middle` at most. Each round takes the middle
#: triangles next to the patches as grown by the round before. One round (the default) leaves the triangles
#: two or more steps from every star in ``M``, drawn as a scattered block in every window: 0.1-0.3 % of a
#: level at ``mu=0.1`` (spot), but 3.5-5 % at ``mu=0.3``. Ten shared meshes, one round -> until none is
#: left (``benchmarks/bench_slidingwindow.py --samples 30000``; ACMR ratio at 100/50/25/10 % within 1.10,
#: Hausdorff and RMS ratios at 50/25/10 % within 1.5):
#:
#: * ``mu=0.3``: ACMR 34 -> 37 of 40, Hausdorff 23 -> 26 of 30, RMS 27 -> 28, lambda mean 6.24 -> 6.35.
#:   Over 40 fractions, the ACMR ratio mean goes 1.073 -> 1.066 (cache 32: 1.041 -> 1.029); over 12
#:   fractions, the Hausdorff ratio geometric mean goes 1.20 -> 1.15.
#: * the defaults (``mu=0.1``): ACMR ratio mean over 40 fractions 1.0588 -> 1.0569, but Hausdorff ratio
#:   geometric mean over 12 fractions 1.73 -> 1.76 (about +-0.01 between runs of other settings), lambda
#:   mean 5.354 -> 5.372. So one round stays the default.
_ABSORB_ROUNDS = 64

#: ``cluster=True``: a linked level stops after the prefix of its patches that costs least per patch, but
#: has at least this many patches (fewer levels, less build time)
_CLUSTER_MIN_PATCHES = 16

#: ``cluster=True, inner_vertices > 1``: a linked patch takes one more inner position if that moves its
#: end in the previous level's tail by at most this many places (:func:`.sw_cluster.cluster_components`).
#: Five meshes (bunny, spot, cow, teapot, bob; three inner vertices with the edge swaps, 10,000 samples), with
#: :data:`_CLUSTER_RELINK_INNER` at 0.8: reach 4 / 8 / 16 lambda mean 2.90 / 2.82 / 2.83 (bunny 2.67 / 2.57
#: / 2.59), ACMR ratio mean 1.102 / 1.129 / 1.125 (within 1.10: 12 / 9 / 10 of 20)
_CLUSTER_REACH = 4
#: ``cluster=True, inner_vertices > 1``: :data:`_CLUSTER_RELINK` for patches of several inner positions,
#: against the pool triangles per collapse of the fully stored level's own grown patches (those of
#: :func:`_grow_patches`). Until 2026-12-04 it was 0.7 against their minimum-degree start, which removes
#: fewer positions: bob linked 2 of its 12 levels (lambda 3.18; now 8 of 16, 3.00). Beetle, five inner
#: vertices with the swaps: 0.8 / 0.85 / 0.9 / 1.0 lambda 3.08 / 2.82 / 2.97 / 2.97 (its stuck coarse levels
#: make it jumpy). Ten meshes, ``--options inner5-cluster-swap --samples 30000``: at 0.85 / 1.0 lambda
#: mean 2.634 / 2.601 (max 2.815 / 2.965), ACMR within 1.10 24 / 19 of 40, Hausdorff geomean 1.79 / 1.98
#: (slidingwindow.md)
_CLUSTER_RELINK_INNER = 0.85

#: a fully stored level after the first is built only if its centres remove at least this fraction of its
#: triangles (two per inner vertex, estimated before collapsing), or if it has at most ``_SMALL_LEVEL`` of LOD
#: 0's triangles. A mesh that gets stuck (boundaries it cannot close, welded points) otherwise trickles down
#: through levels that each store about its whole remaining mesh again to remove a few triangles. At 0.05, on
#: the hostile-mesh test's suzannes: holes lambda 4.83 -> 3.44 for a coarsest LOD of 389 triangles instead of
#: 382, flattened 5.75 -> 5.24 (242, 236); beetle 5.78 -> 5.59 (199, 189); the other nine shared meshes
#: unchanged. At 0.1 suzanne's coarse levels stop too (24 -> 26 triangles). The estimate can be far off (tips
#: of a fan on one edge, whose collapses onto its ends grow dearer than the cut one after another): after a
#: level that removed less than this fraction, the next one collapses its centres without the cut, and if
#: that one removes less too, it is the last
_MIN_LEVEL_GAIN = 0.05
_SMALL_LEVEL = 0.01


def _trickle(removed: int, level_triangles: int, lod0_triangles: int) -> bool:
    """Does a level of ``level_triangles`` that removes ``removed`` of them remove a trickle
    (:data:`_MIN_LEVEL_GAIN`; levels of at most :data:`_SMALL_LEVEL` of LOD 0's triangles never do)?"""
    return level_triangles > _SMALL_LEVEL * lod0_triangles and removed < _MIN_LEVEL_GAIN * level_triangles


#: ``cluster=True``: a level is linked only if, before its collapses, its linked patches cost at most this
#: many times the pool triangles per collapse of a fully stored level (``2 T_L / n - 2``, ``n`` the
#: minimum-degree centres; estimated once per run of linked levels). Deciding from the level itself rather
#: than from the previous linked level's outcome: bunny cluster-swap lambda 3.95 -> 3.74
_CLUSTER_RELINK = 1.0


def _build_levels(
    mesh: Mesh,
    st,
    pending: list,
    worker: ThreadPoolExecutor | None,
    helper: ThreadPoolExecutor | None,
    surface_of,
    replay,
    mu: float,
    inner_vertices: int,
    cache_size: int,
    absorb_min_shared: int,
    cluster: bool = False,
    target_slack: float | None = None,
    absorb_rounds: int = 1,
    order_passes: int = 0,
    order_reach: int = 2,
    error_bound: tuple[float, sw_bound.SequenceReference] | None = None,
):
    T = mesh.triangle_count
    P = st.pos_points.shape[0]
    V = mesh.vertex_count
    if target_slack is None:
        slack = _TARGET_SLACK if inner_vertices > 1 else _TARGET_SLACK_SINGLE
    else:
        slack = float(target_slack)
    gtris = np.empty((max(16, 2 * T), 3), np.int64)
    gtris[:T] = mesh.triangles
    ng = T
    cur_gid = np.arange(T, dtype=np.int64)
    levels: list[swl.Level] = []
    recs_all = []
    info_all = []
    nstep = 0
    fresh_cost = None  # cluster=True: pool triangles per collapse a fully stored level would cost
    relax = False  # the level after a trickle: no cost limit at collapse time (see ``last`` below)
    rank_by_deviation = _RANK_BY_DEVIATION and surface_of is not None
    if error_bound is not None or rank_by_deviation:
        diagonal = float(np.linalg.norm(st.pos_points.max(axis=0) - st.pos_points.min(axis=0)))
        bound_floor = _BOUND_FLOOR * diagonal
        floor2 = float((_DEVIATION_FLOOR * diagonal) ** 2)
    while True:
        alive_t = np.flatnonzero(st.tri_alive)
        if alive_t.shape[0] == 0:
            break
        tp, positions = sw_levels.level_positions(alive_t, st.tri_verts, st.vertex_pos, P)
        # the level's position graph (for its patch centres) on the helper meanwhile
        small = tp.shape[0] < swt._LEVEL_HAND_OFF  # (its hand-offs cost about what they save)
        adjacency = swt.beside(None if small else helper, _adjacency, tp, P)
        stars = star_snapshot(st, positions)  # the state is read-only until collapse_patches
        ks, cs = swt.level_costs_shared(helper, st, positions, stars)
        rank_cs = cs
        if rank_by_deviation:
            surface = surface_of()[0]
            rank_cs = swd.deviation_costs(
                st.pos_points, positions, ks, cs, stars.start, stars.tp, floor2, swd.SAMPLES[:0], 0, *surface
            )
            if len(levels) >= _DEVIATION_FROM_LEVEL and _DEVIATION_SHARE > 0:
                cand = np.flatnonzero(ks >= 0)
                n_pick = int(np.ceil(_DEVIATION_SHARE * cand.shape[0]))
                pick = np.sort(cand[np.argsort(rank_cs[cand])[cand.shape[0] - n_pick :]])
                rank_cs[pick] = swt.sampled_deviation(
                    helper,
                    (
                        st.pos_points,
                        positions[pick],
                        ks[pick],
                        cs[pick],
                        stars.start,
                        stars.tp,
                        floor2,
                        swd.SAMPLES,
                        _DEVIATION_BUDGET,
                        *surface,
                    ),
                )
        vc = rank_cs[ks >= 0]
        order = sw_levels.ties_by_index(vc, np.argsort(vc))  # np.argsort(vc, kind="stable"), faster
        # the valid positions eligible but the mu fraction of them ranked costliest, each with its rank as
        # a tiebreak; no collapse in this level may cost more than the mu cut (later inner vertices of a
        # patch, or a centre whose best collapse got worse after its neighbours' patches), in quadric cost,
        # as the collapses are checked: the costliest of the centres left
        eligible, tiebreak, max_cost, any_eligible = sw_levels.rank_centres(
            positions, ks, cs, order, P, int(round(mu * positions.shape[0])), _ERROR_WEIGHT
        )
        max_cost = float(max_cost)
        if error_bound is not None:
            # ``error_bound``: the vertices whose ranking cost passes the bound are barred too, and no
            # collapse of the level may cost more (the bound is the cut if it is the lower)
            c, reference = error_bound
            end_error = reference.error_at(_BOUND_END * alive_t.shape[0])
            bound2 = max(c * end_error, bound_floor) ** 2
            if sw_bound.bar_costly(eligible, positions, ks, rank_cs, bound2):
                any_eligible = bool(eligible.any())
            max_cost = min(max_cost, bound2)
        if not any_eligible:
            break
        link = False
        fresh = None
        grown = False  # ``fresh`` holds a fully stored level's grown patches (several inner vertices)
        if cluster and levels:
            # SWPM 3.2: this level's patches read out of the previous level's tail, if that costs no more
            # pool triangles per collapse than storing the level in full
            tail = levels[-1].tail
            place = np.full(ng, -1, np.int64)
            place[tail] = np.arange(tail.shape[0])
            tpos = np.full(st.tri_verts.shape[0], -1, np.int64)
            tpos[alive_t] = place[cur_gid[alive_t]]
            cands = np.flatnonzero(eligible).astype(np.int64)
            if inner_vertices == 1:
                inner_start, inner = sw_cluster.cluster_patches(
                    st, cands, tpos, tiebreak[cands], _CLUSTER_MIN_PATCHES
                )
            else:  # patches of several inner positions whose stars span disjoint intervals of the tail
                inner_start, inner = sw_cluster.cluster_components(
                    st,
                    cands,
                    tpos,
                    tiebreak[cands],
                    _CLUSTER_MIN_PATCHES,
                    *adjacency(),
                    int(inner_vertices),
                    _CLUSTER_REACH,
                )
            pt_start, pt = sw_patches.patch_triangles(st, inner_start, inner, stars)
            if fresh_cost is None:
                fresh = _select_fresh(adjacency(), eligible, tiebreak, int(inner_vertices))
                if inner_vertices > 1:
                    # the fully stored level's own patches (grown, merged, searched), not its minimum-degree
                    # start: they remove more positions, so cost fewer pool triangles per collapse
                    grown = True
                    grown_patches = _grow_patches(
                        fresh[0], fresh[1], eligible, tiebreak, inner_vertices, fresh[3]
                    )
                    fresh = (fresh[0], fresh[1], *grown_patches)
                fresh_cost = 2.0 * alive_t.shape[0] / max(fresh[3].shape[0], 1) - 2.0
            linked_cost = _linked_cost(tpos, pt, inner.shape[0]) if inner.shape[0] else np.inf
            relink = _CLUSTER_RELINK if inner_vertices == 1 else _CLUSTER_RELINK_INNER
            link = linked_cost <= relink * fresh_cost
        if link:
            order = np.arange(inner_start.shape[0] - 1, dtype=np.int64)
        else:
            fresh_cost = None  # a new run of linked levels starts after this one
            adj_start, adj, inner_start, inner = fresh or _select_fresh(
                adjacency(), eligible, tiebreak, int(inner_vertices)
            )
            if inner_vertices == 1:
                inner = _more_centres(adj_start, adj, eligible, inner)
                inner = swc.lower_error_centres(adj_start, adj, eligible, inner, tiebreak)
                rank = tiebreak / _ERROR_WEIGHT
                inner = swc.lower_costly_centres(
                    adj_start, adj, eligible, inner, rank, _TAIL_POWER, _TAIL_TRIES, _TAIL_PASSES
                )
                inner_start = np.arange(inner.shape[0] + 1, dtype=np.int64)
            elif not grown:
                inner_start, inner = _grow_patches(adj_start, adj, eligible, tiebreak, inner_vertices, inner)
            live_weight = sw_order.ORDER_LIVE_WEIGHT_CLUSTER if cluster else sw_order.ORDER_LIVE_WEIGHT
            # the patches' triangles, the absorbed middle, their order and the middle's reassignment in one
            # kernel call (:func:`.sw_order.ordered_patches`)
            pt_start, pt, order = sw_order.ordered_patches(
                st,
                inner_start,
                inner,
                stars,
                alive_t,
                int(absorb_min_shared),
                int(absorb_rounds) if absorb_rounds > 0 else _ABSORB_ROUNDS,
                _ABSORB_MAX_MIDDLE,
                V,
                int(cache_size),
                live_weight,
            )
        del stars  # stale from the first collapse on (and one level's snapshot at a time in memory)
        # a trickle of a fully stored level, dearer than the few triangles it removes
        if not link and levels and _trickle(2 * inner.shape[0], alive_t.shape[0], T):
            break
        start_gids = cur_gid[alive_t]  # (fancy indexing copies already)
        gtris, ng, p_start, p_out, q_start, q_out, recs, info, patch_steps = sw_collapse.collapse_patches(
            st,
            order,
            inner_start,
            inner,
            pt_start,
            pt,
            cur_gid,
            gtris,
            ng,
            nstep,
            np.inf if relax else max_cost,
            slack,
        )
        if patch_steps.shape[0] == 0:
            break
        # the estimate above can be far off: centres whose collapses grew dearer than the cut as their
        # neighbours' went first (many patches onto one target, whose quadric grows with each) are skipped.
        # A level that removed a trickle stays (its collapses are made); the next one lets its centres,
        # chosen under the cut, collapse whatever they cost by then, and if that one trickles too it is the
        # last
        trickle = (
            not link and len(levels) > 0 and _trickle(p_out.shape[0] - q_out.shape[0], alive_t.shape[0], T)
        )
        last = trickle and relax
        relax = trickle and not relax
        if not cluster:
            # the level's patch order search and cache order need nothing of the levels after it: a worker
            # thread finishes it while this one builds the next level (the kernels release the GIL)
            collapsed = (p_start, p_out, q_start, q_out, patch_steps, recs, info)
            args = (gtris, start_gids, collapsed, nstep, V, P, int(cache_size), order_passes, order_reach)
            if worker is not None and alive_t.shape[0] >= swt._FINISH_HAND_OFF:
                finishing = worker.submit(swl.finish_level, *args)
            else:
                finishing = swt.done_future(swl.finish_level(*args))
            pending.append((finishing, args))
            if replay is not None:
                replay.advance(pending)
            for i, (f, a) in enumerate(pending):  # a finished level's inputs are not needed any more
                if a is not None and f.done() and not f.cancelled():
                    pending[i] = (f, None)
            levels.append(None)  # filled in from ``pending``
        elif not link:
            lev = swl.first_clustered_level(
                gtris, start_gids, p_start, p_out, q_start, q_out, patch_steps, cache_size
            )
            levels.append(lev)
        else:
            lev = swl.linked_level(
                gtris, ng, levels[-1].tail, p_start, p_out, q_start, q_out, patch_steps, cache_size
            )
            levels.append(lev)
        recs_all.append(recs)
        info_all.append(info)
        nstep += info.shape[0]
        if last:
            break
    return levels, recs_all, info_all, gtris, ng


def _build_topology(mesh: Mesh, st, new_state, *args, **kwargs):
    """:func:`_build_levels` with its levels finished (:func:`.sw_layout.finish_level`) on a worker thread
    and part of each level's own work on a helper thread (:mod:`.sw_threads`) where the machine has a
    second core that the other processes leave free (:func:`.sw_threads.core_free`), inline otherwise (the
    same pool either way). ``new_state``: a fresh state of ``mesh`` for
    the replay of the LOD errors (:class:`.sw_threads.Replay`; None: the caller replays). Returns the
    triangles, levels, collapse records and step info, the LOD errors' replay (None if not done) and the
    input surface (:func:`swpm_usd.simplify.sequence.replay_surface`, None for no triangles)."""
    pending: list = []
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    # a mesh of fewer triangles than sw_threads._LEVEL_HAND_OFF starts no thread at all: the helper's share
    # costs more than it saves (suzanne, medians of 30 alternating builds: 24.1 -> 22.9 ms with a core free,
    # 25.4 -> 22.8 ms with another process on the cores; beetle, 2,053 triangles: 32-34 ms with the threads,
    # 40 ms without, with a core free), and so does the worker alone (suzanne, 2026-12-05: its levels of 256
    # triangles and more finished there, the main thread's CPU time 24.9 -> 22.4 ms, but the wall time 33 ->
    # 66 ms with other processes on the cores: the two threads wait for each other's GIL and for the cores)
    threads = (
        FINISH_IN_THREAD
        and not getattr(_THIS_THREAD, "inline", False)
        and cores > 1
        and mesh.triangle_count >= swt._LEVEL_HAND_OFF
        and swt.core_free(cores)  # (the threads cost more than they save on busy cores)
    )
    worker = ThreadPoolExecutor(max_workers=1) if threads else None
    helper = ThreadPoolExecutor(max_workers=1) if threads else None
    # the input's BVH on the helper while this thread starts level 0
    surface_of = swt.beside(helper, replay_surface, mesh, st) if mesh.triangle_count else None
    # the replay on the worker, after each level's finishing (which settles its steps' order): the helper
    # stays free for its shares of the main thread's work (on the helper, the replays queued ahead of them
    # and the main thread did nearly every share itself: nefertiti 8 of 152 cost blocks on the helper)
    replay = swt.Replay(worker, new_state, surface_of) if worker and new_state and surface_of else None
    try:
        levels, recs_all, info_all, gtris, ng = _build_levels(
            mesh, st, pending, worker, helper, surface_of, replay, *args, **kwargs
        )
        # the levels the worker has not started are finished here, last first, beside it
        finished = [None] * len(pending)
        for i in range(len(pending) - 1, -1, -1):
            if pending[i][1] is not None and pending[i][0].cancel():
                finished[i] = swl.finish_level(*pending[i][1])
        results = [r if r is not None else f.result() for r, (f, _) in zip(finished, pending, strict=True)]
        geometric = replay.result([r[2] for r in results]) if replay is not None else None
    finally:
        if worker is not None:
            worker.shutdown(wait=True, cancel_futures=True)
        if helper is not None:
            helper.shutdown(wait=True, cancel_futures=True)
    done = iter(results)
    for li, lev in enumerate(levels):
        if lev is None:
            lev, recs_all[li], info_all[li] = next(done)
            levels[li] = lev
    recs = np.concatenate(recs_all) if recs_all else np.zeros((0, 3), np.int64)
    info = np.concatenate(info_all) if info_all else np.zeros((0, 3))
    return gtris[:ng], levels, recs, info, geometric, surface_of() if surface_of is not None else None


def _grow_patches(
    adj_start: np.ndarray,
    adj: np.ndarray,
    eligible: np.ndarray,
    tiebreak: np.ndarray,
    inner_vertices: int,
    inner: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """A fully stored level's patches of up to ``inner_vertices`` positions, from its minimum-degree patches
    ``inner`` (:func:`_select_fresh`): ``(inner_start, inner)``."""
    # two ways to several inner vertices: grow patches, or merge two levels; keep the one that removes more
    # vertices (bunny with the edge swaps, three inner vertices: lambda 3.72 by growing alone, 3.37 with both)
    _, centres = swc.select_patches(adj_start, adj, eligible, tiebreak, 1)
    centres = _more_centres(adj_start, adj, eligible, centres)
    merged = swc.merge_patches(adj_start, adj, eligible, tiebreak, int(inner_vertices), centres)
    if merged[1].shape[0] > inner.shape[0]:
        inner = merged[1]
    # then a large-neighbourhood search for more inner vertices (components of at most ``inner_vertices``)
    iterations = int(_PATCH_SEARCH * np.count_nonzero(eligible))
    return swc.grow_component_set(
        adj_start,
        adj,
        eligible,
        tiebreak,
        int(inner_vertices),
        inner,
        iterations,
        _CENTRE_SEARCH_SEED,
        _PATCH_SEARCH_JITTER,
    )


def _select_fresh(adjacency: tuple, eligible: np.ndarray, tiebreak: np.ndarray, inner_vertices: int):
    """The position graph of a level (:func:`_adjacency`) and its minimum-degree patches (the start of a fully
    stored level)."""
    adj_start, adj = adjacency
    inner_start, inner = swc.select_patches(adj_start, adj, eligible, tiebreak, inner_vertices)
    return adj_start, adj, inner_start, inner


def _linked_cost(tpos: np.ndarray, pt: np.ndarray, patches: int) -> float:
    """Pool triangles per collapse of a linked level, before its collapses: its ``Q`` blocks store the
    previous tail up to the end of the last patch again, less two triangles per removed centre."""
    return (int(tpos[pt].max()) + 1) / patches - 2.0


#: meshes of at most this many triangles keep what the replay of the LOD errors reads of their fresh
#: simplifier state (:func:`.fan_deviation.replay_state`) instead of making the state again (``make_state``:
#: suzanne 0.35 ms, cow 1.5 ms, bunny 24 ms; a copy of the whole state 0.03 / 0.07 / 0.8 ms); a larger
#: mesh's would be held through its first level, at the peak of memory
_SPARE_STATE_MAX = 100_000


def _is_integer(value: Any) -> bool:
    """An integer (numpy's too), not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def build_sliding_window(
    mesh: Mesh,
    *,
    builder: str = "topology",
    mu: float = 0.1,
    tolerance: float = 0.1,
    optimize_connectivity: bool = False,
    swap_max_deviation: float = SWAP_MAX_DEVIATION,
    cluster: bool = False,
    inner_vertices: int = 1,
    cache_size: int = 16,
    absorb_middle: bool = True,
    absorb_rounds: int = 1,
    target_slack: float | None = None,
    order_passes: int | None = None,
    order_reach: int = 2,
    coarsest_copy: bool = True,
    primitive: str = "list",
    strip_window: int = 4,
    boundary_weight: float = 8.0,
    seam_weight: float = 2.0,
    error_bound: float | None = None,
) -> SlidingWindowProgressiveMesh:
    """Build a sliding-window progressive mesh of ``mesh`` (parameters: the module docstring; their design:
    ``slidingwindow.md``)."""
    if builder not in ("topology", "forsyth"):
        raise BuildError(f"unknown sliding-window builder {builder!r}; choose 'topology' or 'forsyth'")
    if not 0.0 <= mu < 1.0:
        raise BuildError(f"mu must be in [0, 1), got {mu}")
    if not 0.0 <= tolerance < np.inf:
        raise BuildError(f"tolerance must be a finite number >= 0, got {tolerance}")
    if int(inner_vertices) < 1:
        raise BuildError(f"inner_vertices must be >= 1, got {inner_vertices}")
    if not float(swap_max_deviation) >= 0.0:
        raise BuildError(f"swap_max_deviation must be >= 0, got {swap_max_deviation}")
    check_cache_size(cache_size)  # (build()'s bounds, called directly too)
    if int(cache_size) < 3:
        raise BuildError(f"cache_size must be >= 3, got {cache_size}")
    if target_slack is not None and not (
        isinstance(target_slack, numbers.Real)  # numpy scalars too (np.float32, np.int64), as ``mu``
        and not isinstance(target_slack, bool)
        and 0.0 <= float(target_slack) < np.inf
    ):
        raise BuildError(f"target_slack must be a finite number >= 0 or None, got {target_slack!r}")
    if error_bound is not None and not (
        isinstance(error_bound, numbers.Real)
        and not isinstance(error_bound, bool)
        and 0.0 < float(error_bound) < np.inf
    ):
        raise BuildError(f"error_bound must be a finite number > 0 or None, got {error_bound!r}")
    if not _is_integer(absorb_rounds) or absorb_rounds < 0:
        raise BuildError(f"absorb_rounds must be an integer >= 0, got {absorb_rounds!r}")
    if order_passes is None:  # a linked level's patch order is its tail's: no search with cluster
        order_passes = DEFAULT_ORDER_PASSES if builder == "topology" and not cluster else 0
    if not _is_integer(order_passes) or not 0 <= order_passes <= MAX_ORDER_PASSES:
        raise BuildError(
            f"order_passes must be None or an integer in [0, {MAX_ORDER_PASSES}], got {order_passes!r}"
        )
    if not _is_integer(order_reach) or not 1 <= order_reach <= MAX_ORDER_REACH:
        raise BuildError(f"order_reach must be an integer in [1, {MAX_ORDER_REACH}], got {order_reach!r}")
    if primitive not in PRIMITIVES:
        raise BuildError(f"primitive must be one of {PRIMITIVES}, got {primitive!r}")
    if not _is_integer(strip_window) or not 1 <= strip_window <= MAX_STRIP_WINDOW:
        raise BuildError(f"strip_window must be an integer in [1, {MAX_STRIP_WINDOW}], got {strip_window!r}")
    # (the command line and a config refuse these combinations before any mesh is read, in these words)
    problem = combination_problem(
        "sliding-window",
        {
            "builder": builder,
            "cluster": bool(cluster),
            "order_passes": int(order_passes),
            "error_bound": error_bound,
            # (each refused where the build would ignore it, unless it is its default)
            "tolerance": tolerance,
            "optimize_connectivity": optimize_connectivity,
            "swap_max_deviation": swap_max_deviation,
            "mu": mu,
            "inner_vertices": inner_vertices,
            "absorb_middle": absorb_middle,
            "absorb_rounds": absorb_rounds,
            "target_slack": target_slack,
            "order_reach": order_reach,
            "primitive": primitive,
            "strip_window": strip_window,
        },
    )
    if problem:
        raise BuildError(problem)
    if optimize_connectivity:
        mesh = optimize_mesh_connectivity(mesh, max_deviation=swap_max_deviation)
    topo = mesh_topology(mesh)
    st = make_state(mesh, topo, boundary_weight=boundary_weight, seam_weight=seam_weight)
    # the replay of the LOD errors needs a fresh state once, only what its collapses read of it
    # (:func:`.fan_deviation.replay_state`): taken from this one before the build changes it, held from now
    # on where that is small
    spare = [replay_state(st)] if mesh.triangle_count <= _SPARE_STATE_MAX else []

    def new_state():
        if spare:
            return spare.pop()
        return replay_state(make_state(mesh, topo, boundary_weight=boundary_weight, seam_weight=seam_weight))

    if builder == "topology":
        absorb = _ABSORB_MIN_SHARED if absorb_middle else 0
        bound = None
        if error_bound is not None:  # the plain quadric sequence on a state of its own
            ref_state = make_state(mesh, topo, boundary_weight=boundary_weight, seam_weight=seam_weight)
            bound = (float(error_bound), sw_bound.SequenceReference(ref_state, mesh.triangles))
        gtris, levels, recs, info, geometric, surface = _build_topology(
            mesh,
            st,
            None if cluster else new_state,  # (a linked level is not finished on the worker)
            float(mu),
            int(inner_vertices),
            int(cache_size),
            absorb,
            bool(cluster),
            target_slack,
            int(absorb_rounds),
            int(order_passes),
            int(order_reach),
            bound,
        )
    else:
        gtris, levels, recs, info = _build_forsyth(mesh, st, float(tolerance), boundary_weight, seam_weight)
        geometric = surface = None
    if geometric is None:
        # each step's error as the LODs report it: the quadric's, or how far its new triangles lie from LOD 0
        # if farther (a fresh state replays the steps; :class:`.sw_threads.Replay` does it level by level)
        if info.shape[0] == 0:
            geometric = np.zeros(0)
        else:
            fresh = new_state()
            surface = surface or replay_surface(mesh, st)  # (its points and vertex positions never change)
            geometric = replay_steps(surface, fresh, info[:, 1], info[:, 2], info[:, 0])
    pm = _assemble(mesh, gtris, levels, recs, info, int(cache_size), bool(coarsest_copy), geometric)
    pm.params["order_passes"] = int(order_passes)  # what ran (None resolved)
    if primitive == "strip":
        use_strips(pm, int(strip_window))
    else:
        pm.params.update(primitive="list", restart_index=None, strip_window=int(strip_window))
    return pm
