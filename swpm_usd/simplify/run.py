"""The whole collapse sequence: greedy collapses in quadric-error order until none is valid.

:func:`run_sequence` queues every position's best collapse (:mod:`.best`), pops the cheapest, re-checks
it, applies it (:mod:`.apply`) and re-evaluates the kept position's ring; it records the vertex collapses
(binned vertex, kept vertex) in the order Svarovsky's VIPM bins them (references/001).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .apply import apply_collapse
from .best import best_collapse, best_collapse_sized
from .heap import _heap_pop, _heap_push
from .quadrics import collapse_cost
from .stars import gather_triangles, neighbours, triangle_positions
from .state import HUB_SIZE, CollapseState
from .validity import _alive_more_than, valid_collapse, vertex_map


@nb.njit(cache=True, nogil=True)
def run_sequence(st: CollapseState, max_passes: int, full_ring_update: bool = False):
    """Collapse greedily in quadric-error order until nothing valid remains. ``full_ring_update``: after a
    collapse, re-evaluate every ring position's whole star, not only its collapse onto the kept position
    (the same sequence up to ties of equal cost; for tests).

    Returns per vertex collapse: binned vertex, kept vertex, step (position collapse it belongs to), and per
    step its error (sqrt of the quadric cost, a distance) and the binned / kept positions.
    """
    P = st.pos_points.shape[0]
    V = st.vertex_pos.shape[0]
    binned = np.empty(V, np.int32)
    kept = np.empty(V, np.int32)
    step_of = np.empty(V, np.int32)
    step_error = np.empty(P, np.float64)
    step_b = np.empty(P, np.int32)
    step_k = np.empty(P, np.int32)
    n_rec = 0
    n_step = 0
    stamp = np.zeros(P, np.int64)
    # int64 targets: position arguments of one type for every callee (one numba specialisation each)
    target = np.full(P, -1, np.int64)
    target_cost = np.full(P, np.inf)  # the cost of ``target``, as pushed
    # the target is the cheapest neighbour, valid or not (not after a failed check picked a costlier one)
    cheapest = np.zeros(P, np.bool_)
    # collapses next to a position with no valid target left before it is checked again (see HUB_SIZE)
    wait = np.zeros(P, np.int64)
    # collapses onto each position while it was a hub, its star at the last of them, and their count when
    # each position's target was pushed: a collapse onto a hub re-evaluates only the binned position's ring
    # (see the ring loop)
    hub_grown = np.zeros(P, np.int64)
    hub_star = np.zeros(P, np.int64)
    target_grown = np.zeros(P, np.int64)
    keys = np.empty(max(16, P), np.float64)
    ids = np.empty(max(16, P), np.int64)
    stamps = np.empty(max(16, P), np.int64)
    size = np.int64(0)  # not a literal 0: one specialisation of the heap calls
    for _ in range(max_passes):
        progress = 0
        for p in range(P):
            k, cost = best_collapse(st, p, np.bool_(False))  # (np.bool_: one compile, not one per literal)
            wait[p] = 0
            stamp[p] += 1
            target[p] = k
            target_cost[p] = cost
            cheapest[p] = True
            target_grown[p] = hub_grown[k] if k >= 0 else 0
            if k >= 0:
                keys, ids, stamps, size = _heap_push(keys, ids, stamps, size, cost, p, stamp[p])
        while size > 0:
            cost, b, s, size = _heap_pop(keys, ids, stamps, size)
            if s != stamp[b] or not st.pos_alive[b]:
                continue
            k = target[b]
            if k >= 0 and hub_grown[k] - target_grown[b] > hub_star[k] // HUB_SIZE:
                # the target is a hub that took more than star // HUB_SIZE collapses since b's entry was
                # pushed: evaluate b again (after each one, most of the heap's top was such entries: 3.2
                # million evaluations for 5,819 collapses)
                k2, c2 = best_collapse(st, b, np.bool_(False))
                stamp[b] += 1
                target[b] = k2
                target_cost[b] = c2
                cheapest[b] = True
                if k2 >= 0:
                    target_grown[b] = hub_grown[k2]
                    keys, ids, stamps, size = _heap_push(keys, ids, stamps, size, c2, b, stamp[b])
                continue
            tris_b = gather_triangles(st, b)
            tp_b = triangle_positions(st, tris_b)
            nbr_b = neighbours(b, tp_b)
            if k < 0 or not valid_collapse(st, b, k, tris_b, tp_b, nbr_b, None):
                k2, c2 = best_collapse(st, b, np.bool_(True))
                wait[b] = tris_b.shape[0] // HUB_SIZE
                stamp[b] += 1
                target[b] = k2
                target_cost[b] = c2
                cheapest[b] = False
                target_grown[b] = hub_grown[k2] if k2 >= 0 else 0
                if k2 >= 0:
                    keys, ids, stamps, size = _heap_push(keys, ids, stamps, size, c2, b, stamp[b])
                continue
            cost = collapse_cost(st, b, k)
            vmap = vertex_map(st, b, k, tris_b, tp_b)
            v0 = st.pos_vstart[b]
            for r in range(vmap.shape[0]):
                binned[n_rec] = st.pos_verts[v0 + r]
                kept[n_rec] = vmap[r]
                step_of[n_rec] = n_step
                n_rec += 1
            step_error[n_step] = np.sqrt(cost)
            step_b[n_step] = b
            step_k[n_step] = k
            n_step += 1
            progress += 1
            apply_collapse(st, b, k, vmap)
            stamp[b] += 1
            # the kept position and its new ring see changed quadrics and topology. A ring position q's
            # collapses onto anything but k cost what they did (q's quadric and theirs are unchanged), so
            # unless its target was b or k (or a costlier valid one, ``cheapest``), its best is the old one
            # or k: one cost, not its whole star (run time halved: bunny 0.83 -> 0.52 s)
            #
            # A hub's ring is most of the mesh: a collapse onto a hub visits b's old ring alone (the
            # positions whose stars changed) and counts the collapse in ``hub_grown``. The rest of its ring
            # keep their entries, and an entry whose target is the hub is evaluated again when it comes up
            # (a random non-manifold hub, one vertex of all 10,000 triangles: a quadratic number of ring
            # visits, 18.6 million). The order is then approximate (a cost may fall as the hub's quadric
            # grows), which a hub's neighbourhood affords. A pass can then end with valid collapses left
            # around a hub (a position that waits is not queued again in it): the next pass finds them
            k_hub = not full_ring_update and _alive_more_than(st, k, HUB_SIZE)
            if k_hub:
                hub_grown[k] += 1
                ring = nbr_b
            else:
                ring = neighbours(k, triangle_positions(st, gather_triangles(st, k)))
            for i in range(ring.shape[0] + 1):
                q = k if i == ring.shape[0] else np.int64(ring[i])
                if q == k and i < ring.shape[0]:
                    continue
                tq = target[q]
                if q == k and k_hub:
                    # the hub itself is evaluated again every star // HUB_SIZE collapses onto it
                    if hub_grown[k] % max(1, hub_star[k] // HUB_SIZE) != 0:
                        continue
                    hub_star[k] = gather_triangles(st, k).shape[0]
                if wait[q] > 0 and q != k:
                    wait[q] -= 1
                    continue
                if q != k and tq >= 0 and tq != b and tq != k and cheapest[q] and not full_ring_update:
                    c2 = collapse_cost(st, q, k)
                    if not c2 < target_cost[q]:
                        continue  # a tie keeps the old target (a whole star's first minimum may differ)
                    k2 = k
                else:
                    k2, c2, n_q = best_collapse_sized(st, q, np.bool_(False), None)
                    if q != k:
                        wait[q] = n_q // HUB_SIZE
                stamp[q] += 1
                target[q] = k2
                target_cost[q] = c2
                cheapest[q] = True
                if k2 >= 0:
                    target_grown[q] = hub_grown[k2]
                    keys, ids, stamps, size = _heap_push(keys, ids, stamps, size, c2, q, stamp[q])
        if progress == 0:
            break
    return (
        binned[:n_rec].copy(),
        kept[:n_rec].copy(),
        step_of[:n_rec].copy(),
        step_error[:n_step].copy(),
        step_b[:n_step].copy(),
        step_k[:n_step].copy(),
    )
