"""The sliding-window pool assembled from its levels (Forsyth, "Comparison of VIPM Methods", sliding window;
SWPM eq. 1 per level): the levels' blocks concatenated into one static index pool, one window record per
LOD (first index offset, triangle count, vertex count), the vertices renumbered so that every LOD uses a
prefix of them (the ``c``-th binned vertex at ``V - 1 - c``, as in vanilla VIPM), the builder's collapse
sequence, and optionally the coarsest LOD stored once more as one cache-ordered block (``coarsest_copy``).
"""

from __future__ import annotations

import numpy as np

from ..mesh import Mesh
from ..metrics import cache_misses
from ..simplify import CollapseSequence
from . import sw_layout as swl
from .sw_mesh import SlidingWindowProgressiveMesh

#: ``coarsest_copy=True``: the coarsest LOD is stored again after the last level, its triangles cache-ordered
#: as one block (a window there reloads the vertices on the front between the ``P`` and ``Q`` parts), when
#: the copy is at most this share of the pool without it (inclusive) and saves at least
#: ``_COARSEST_COPY_MIN_GAIN`` of the window's misses. The ten benchmark meshes: copies of 21-210
#: triangles, up to 1.8 % of the pool, on six of them; the coarsest LOD's ACMR ratio to meshoptimizer
#: 1.00-1.25 -> 1.00-1.01 (``slidingwindow.md``)
COARSEST_COPY_MAX_SHARE = 1 / 32
#: a copy saving less is not worth its pool (those of the ten meshes save 9.5-20 %)
_COARSEST_COPY_MIN_GAIN = 0.05


def _coarsest_copy(window: np.ndarray, pool_size: int, cache_size: int) -> np.ndarray | None:
    """The coarsest LOD's triangles (``window``, as its window draws them) ordered for the cache as one
    block, if that draws them with at least :data:`_COARSEST_COPY_MIN_GAIN` fewer FIFO misses than the window
    does and they are at most :data:`COARSEST_COPY_MAX_SHARE` of ``pool_size`` triangles (the pool without
    the copy); else None."""
    count = window.shape[0]
    if count < 2 or count > COARSEST_COPY_MAX_SHARE * pool_size:
        return None
    # int32 whichever builder's pool it comes from (Forsyth's and the clustered layout's are int64): one
    # compile of vcache._rotate_rows, not two; the copy only indexes the new vertex ids
    window = window.astype(np.int32, copy=False)
    copy = swl.block_order(window, np.array([0, count], np.int64), cache_size)
    if (
        cache_misses(copy, cache_size)[0]
        > (1.0 - _COARSEST_COPY_MIN_GAIN) * cache_misses(window, cache_size)[0]
    ):
        return None
    return copy


def _pool_slice(parts: list[np.ndarray], part_start: np.ndarray, first: int, count: int) -> np.ndarray:
    """Triangles ``[first, first + count)`` of the pool that is ``parts`` concatenated (a window can start
    in the part before its level's: a linked level's head is the previous level's tail; an empty window at
    the pool's end, ``first`` = its length, comes out of the last part empty)."""
    i = min(int(np.searchsorted(part_start, first, side="right")) - 1, len(parts) - 1)
    return np.concatenate(parts[i:])[first - int(part_start[i]) :][:count]


def _assemble(
    mesh: Mesh,
    gtris: np.ndarray,
    levels: list[swl.Level],
    recs: np.ndarray,
    info: np.ndarray,
    cache_size: int,
    coarsest_copy: bool = True,
    step_geometric: np.ndarray | None = None,
) -> SlidingWindowProgressiveMesh:
    """The pool, records and vertex order from the levels. ``step_geometric``: per step, the error the LODs
    accumulate (:func:`swpm_usd.simplify.sequence.step_geometric_errors`; default the quadric error)."""
    V, T = mesh.vertex_count, mesh.triangle_count
    binned, kept, step = recs[:, 0], recs[:, 1], recs[:, 2]
    C = binned.shape[0]
    S = info.shape[0]
    # vertex order: never-binned first (original order), then binned in reverse collapse order
    is_binned = np.zeros(V, bool)
    is_binned[binned] = True
    new_id = np.empty(V, np.int64)
    survivors = np.flatnonzero(~is_binned)
    new_id[survivors] = np.arange(survivors.shape[0])
    new_id[binned] = V - 1 - np.arange(C)
    perm = np.empty(V, np.int64)
    perm[new_id] = np.arange(V)
    rec_after_step = np.zeros(S + 1, np.int64)
    np.cumsum(np.bincount(step, minlength=S), out=rec_after_step[1:])
    step_err = info[:, 0] if S else np.zeros(0)
    lod_err = step_err if step_geometric is None else step_geometric
    err_after = np.r_[0.0, np.maximum.accumulate(lod_err)] if S else np.zeros(1)

    parts = []
    # per level: the first triangle and the triangle count of every window (from its offset, triangle count
    # and the first ``m`` entries of its P and Q offsets), gathered into one table after the loop (a table
    # per level cost suzanne's 15 levels about 0.3 ms)
    offsets, level_tris, p_heads, q_heads, patch_steps = [], [], [], [], []
    head_next = 0
    if not levels:  # nothing to collapse: one level, one window
        levels = [
            swl.Level(
                np.arange(T),
                np.zeros(1, np.int64),
                np.zeros(0, np.int64),
                np.zeros(1, np.int64),
                np.zeros(0, np.int64),
                np.zeros(0, np.int64),
            )
        ]
    pool_len = 0
    for li, lev in enumerate(levels):
        n = lev.patch_count
        if lev.shared:  # cluster: the head is the previous level's tail, already in the pool
            offset = head_next
        else:
            offset = pool_len
        if lev.stored is not None:
            parts.append(gtris[lev.stored])
        elif lev.pool is not None:
            parts.append(lev.pool)
        else:
            tris, _ = swl.level_pool(
                gtris, lev.start_gids, lev.p_start, lev.p_out, lev.q_start, lev.q_out, cache_size
            )
            parts.append(tris)
        pool_len += parts[-1].shape[0]
        head_next = offset + int(lev.p_start[n])
        m = n + 1 if li == len(levels) - 1 else n  # the last level also keeps its final window
        offsets.append(offset)
        level_tris.append(lev.triangle_count)
        p_heads.append(lev.p_start[:m])
        q_heads.append(lev.q_start[:m])
        patch_steps.append(lev.patch_steps[:n])
    # the windows of all levels: level ``li``'s ``m`` rows take its offset and triangle count; the steps
    # done before each window are the running sum of every patch's steps (level by level, and a level's
    # windows are its patches, the last level's final window after its last patch): all of them
    counts = [h.shape[0] for h in p_heads]
    p_all = np.concatenate(p_heads).astype(np.int64)
    rows_a = np.empty((p_all.shape[0], 4), np.int64)
    rows_a[:, 0] = np.repeat(np.array(offsets, np.int64), counts) + p_all
    rows_a[:, 1] = np.repeat(np.array(level_tris, np.int64), counts) - p_all + np.concatenate(q_heads)
    rows_a[0, 2] = 0
    np.cumsum(np.concatenate(patch_steps), out=rows_a[1:, 2])
    rows_a[:, 3] = np.repeat(np.arange(len(levels), dtype=np.int64), counts)
    part_start = np.concatenate(([0], np.cumsum([part.shape[0] for part in parts], dtype=np.int64)))
    copy = None
    if coarsest_copy:
        first, count = int(rows_a[-1, 0]), int(rows_a[-1, 1])
        copy = _coarsest_copy(_pool_slice(parts, part_start, first, count), int(part_start[-1]), cache_size)
    if copy is not None:  # the coarsest LOD becomes a level of its own: one block, no patches
        rows_a[-1, 0] = part_start[-1]
        rows_a[-1, 3] = len(levels)
        parts.append(copy)
        part_start = np.append(part_start, part_start[-1] + copy.shape[0])
    # the stored ids part by part, straight into the final array (one pool-sized int64 temporary for the
    # whole pool cost 1 M triangles 260 MB at the peak)
    pool = np.empty(3 * int(part_start[-1]), np.uint32)
    for part, a in zip(parts, part_start[:-1], strict=True):
        pool[3 * a : 3 * (a + part.shape[0])] = new_id[part.reshape(-1)]
    lod_steps = rows_a[:, 2]
    vertex_counts = V - rec_after_step[lod_steps]
    records = np.stack([3 * rows_a[:, 0], rows_a[:, 1], vertex_counts], axis=1)
    pm = SlidingWindowProgressiveMesh(
        points=mesh.points[perm],
        attributes={name: a[perm] for name, a in mesh.attributes.items()},
        vertex_counts=vertex_counts,
        triangle_counts=rows_a[:, 1],
        lod_errors=err_after[lod_steps],
        index_pool=pool,
        window_records=records.astype(np.uint32),
        params={},
    )
    step_offsets = rec_after_step
    pm.collapse_sequence = CollapseSequence(
        mesh=mesh,
        binned=binned.astype(np.int32),
        kept=kept.astype(np.int32),
        step=step.astype(np.int32),
        error=step_err[step] if C else np.zeros(0),
        step_error=step_err,
        step_offsets=step_offsets,
        binned_position=info[:, 1].astype(np.int32) if S else np.zeros(0, np.int32),
        kept_position=info[:, 2].astype(np.int32) if S else np.zeros(0, np.int32),
        step_geometric_error=step_geometric,
    )
    pm.lod_steps = lod_steps
    pm.source_vertex = perm
    pm.lod_level = rows_a[:, 3]
    return pm
