"""A binary min-heap on arrays (cost, position, stamp); stale entries are skipped on pop.

The caller keeps a stamp per position and bumps it when it pushes a new entry: an entry popped with an old
stamp is stale (the queue of the greedy collapse order, Garland-Heckbert's, and of Forsyth's builder).
"""

from __future__ import annotations

import numba as nb
import numpy as np


# push and pop are calls, not inlined: a kernel that pushes and pops at many places (run_sequence,
# sw_forsyth.forsyth_run) compiles seconds faster, at no cost in run time
@nb.njit(cache=True, nogil=True)
def _heap_push(keys, ids, stamps, size, key, pid, stamp):
    if size == keys.shape[0]:
        nk = np.empty(2 * size, keys.dtype)
        ni = np.empty(2 * size, ids.dtype)
        ns = np.empty(2 * size, stamps.dtype)
        # a loop, not nk[:size] = keys: numba compiles and links a slice assignment's shape-mismatch
        # message (string formatting), seconds of compile time
        for i in range(size):
            nk[i] = keys[i]
            ni[i] = ids[i]
            ns[i] = stamps[i]
        keys, ids, stamps = nk, ni, ns
    return keys, ids, stamps, _heap_push_into(keys, ids, stamps, size, key, pid, stamp)


@nb.njit(cache=True, inline="always")
def _heap_push_into(keys, ids, stamps, size, key, pid, stamp):
    """:func:`_heap_push` into arrays with room for it; returns the new size only. A hot loop that pushes into
    arrays sized for every push calls this one: reassigning the arrays returned by :func:`_heap_push` costs
    numba's reference counting on every iteration."""
    if size >= keys.shape[0]:  # numba checks no bounds: a wrong capacity must not write past the arrays
        raise IndexError("heap capacity exceeded")
    i = size
    while i > 0:
        parent = (i - 1) >> 1
        if keys[parent] <= key:
            break
        keys[i], ids[i], stamps[i] = keys[parent], ids[parent], stamps[parent]
        i = parent
    keys[i], ids[i], stamps[i] = key, pid, stamp
    return size + 1


@nb.njit(cache=True, nogil=True)
def _heap_pop(keys, ids, stamps, size):
    key, pid, stamp = keys[0], ids[0], stamps[0]
    size -= 1
    lk, li, ls = keys[size], ids[size], stamps[size]
    i = 0
    while True:
        child = 2 * i + 1
        if child >= size:
            break
        if child + 1 < size and keys[child + 1] < keys[child]:
            child += 1
        # the last entry sinks below children of its own key: with ``>=`` it stayed at the root, so of equal
        # keys the entry pushed last came out next. On a flat strip, where every collapse along the straight
        # boundary costs exactly 0, that popped each collapse's target next: chains that binned the strip
        # onto a few fans of thousands of triangles, which then moved along it (the sequence 3-5x slower per
        # doubling; bench_hostile's strip of 20,000 quads: vanilla 34.8 -> 1.3 s, mixed 42.7 -> 1.5 s)
        if keys[child] > lk:
            break
        keys[i], ids[i], stamps[i] = keys[child], ids[child], stamps[child]
        i = child
    if size > 0:
        keys[i], ids[i], stamps[i] = lk, li, ls
    return key, pid, stamp, size
