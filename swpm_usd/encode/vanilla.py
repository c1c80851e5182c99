"""Vanilla VIPM (Svarovsky; Forsyth, "Comparison of VIPM Methods", VanillaCollapseRecord).

Vertices are stored in reverse collapse order, so the vertex a collapse bins is always the last one in use,
and triangles in bin order, so the triangles a collapse removes are always the last ones drawn. Each
instance owns a copy of the index buffer; a collapse record says which vertex is kept, how many triangles
fall off the end and which index slots change from the binned vertex to the kept one. The records are flat
arrays (one entry per record, plus one flat array of slot offsets) instead of variable-length structs;
``collapse_prev_change_count`` is kept so a reader walking records backwards (splits) needs no prefix sum.

The triangle order is the collapse order reversed, near-random for the vertex cache (ACMR 3.34 times
meshoptimizer's on the ten shared meshes). Reordering the collapses that commute was measured on 2026-12-05
and not landed (9 % better within the error, 2.69 times at best): see ``vanilla.md``.

:func:`collapse_records` is shared with the skip-strip encoder: it replays vertex collapses over any
triangle list and reports, per collapse, the triangles it removes and the index slots it changes.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numba as nb
import numpy as np

from ..format.layout import draw_index_width
from ..simplify import CollapseSequence
from .base import ProgressiveMesh, register
from .instance import RecordInstance, apply_records


def index_size(max_value: int) -> int:
    """Bytes an offset or count a GPU buffer holds needs: 2 while every value fits in u16, else 4 (vertex ids
    follow :func:`..format.layout.draw_index_width`: 0xFFFF is no vertex id in u16)."""
    return 2 if max_value <= 0xFFFF else 4


@nb.njit(cache=True)
def _replay(tris: np.ndarray, binned: np.ndarray, kept: np.ndarray, vertex_count: int):
    """Apply vertex collapses to ``tris`` in order. Returns ``die`` (collapse that removes each triangle,
    C for survivors), the CSR start of each collapse's changed corners, and the corners (3*t + i)."""
    T = tris.shape[0]
    C = binned.shape[0]
    head = np.full(vertex_count, -1, np.int64)
    nxt = np.full(3 * T, -1, np.int64)
    for t in range(T - 1, -1, -1):
        for i in range(2, -1, -1):
            c = 3 * t + i
            v = tris[t, i]
            nxt[c] = head[v]
            head[v] = c
    tv = tris.copy()
    die = np.full(T, C, np.int64)
    start = np.zeros(C + 1, np.int64)
    corners = np.empty(max(16, 3 * T), np.int64)
    n = 0
    for ci in range(C):
        b = binned[ci]
        k = kept[ci]
        start[ci] = n
        # b's corners of surviving triangles move onto k and are spliced in front of k's list; the corners
        # of dead triangles are unlinked on the way, so each is walked once: kept in the list, a chain of
        # collapses (b onto k, k onto k2, ...) walked its whole history again at every step (a flat strip
        # of 20,000 triangles: 7 s)
        c = head[b]
        first = -1
        last = -1
        while c >= 0:
            c_next = nxt[c]
            t = c // 3
            if die[t] == C:
                if tv[t, 0] == k or tv[t, 1] == k or tv[t, 2] == k:
                    die[t] = ci
                else:
                    tv[t, c - 3 * t] = k
                    if n == corners.shape[0]:
                        grown = np.empty(2 * n, np.int64)
                        for i in range(n):  # a loop, not grown[:n] = corners: see sw_collapse._grow_tris
                            grown[i] = corners[i]
                        corners = grown
                    corners[n] = c
                    n += 1
                    if last >= 0:
                        nxt[last] = c
                    else:
                        first = c
                    last = c
            c = c_next
        if last >= 0:
            nxt[last] = head[k]
            head[k] = first
        head[b] = -1
    start[C] = n
    return die, start, corners[:n].copy()


def collapse_records(
    triangles: np.ndarray, binned: np.ndarray, kept: np.ndarray, vertex_count: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Replay vertex collapses over ``triangles`` (any vertex ids).

    Returns ``(die, tris_removed, change_start, change_corners)``: for each triangle the collapse that
    removes it (``len(binned)`` if none), per collapse the number of triangles removed, and the CSR list of
    index slots (``3 * triangle + corner``, in the input order) it redirects from binned to kept.
    """
    tris = np.ascontiguousarray(triangles, dtype=np.int64)
    die, start, corners = _replay(
        tris, np.asarray(binned, np.int64), np.asarray(kept, np.int64), vertex_count
    )
    C = len(binned)
    removed = np.bincount(die[die < C], minlength=C).astype(np.int64)
    return die, removed, start, corners


@register
class VanillaProgressiveMesh(ProgressiveMesh):
    """Vanilla VIPM: LOD-0 ``indices`` plus collapse records; see the module docstring.

    Record ``r`` bins vertex ``vertex_count - 1 - r`` onto ``collapse_kept[r]``, removes the last
    ``collapse_tris_removed[r]`` live triangles and rewrites ``collapse_change_count[r]`` index slots listed
    in ``collapse_change_offsets`` (records are consecutive there). LOD ``k`` has applied
    ``lod_record_counts[k]`` records.
    """

    encoding = "vanilla"

    def __init__(
        self,
        points: np.ndarray,
        attributes: Mapping[str, np.ndarray],
        vertex_counts: np.ndarray,
        triangle_counts: np.ndarray,
        lod_errors: np.ndarray,
        indices: np.ndarray,
        collapse_kept: np.ndarray,
        collapse_tris_removed: np.ndarray,
        collapse_change_count: np.ndarray,
        collapse_change_offsets: np.ndarray,
        lod_record_counts: np.ndarray,
        params: Mapping[str, Any] | None = None,
    ) -> None:
        super().__init__(points, attributes, vertex_counts, triangle_counts, lod_errors, params)
        self.indices = np.asarray(indices).reshape(-1)
        self.collapse_kept = np.asarray(collapse_kept)
        self.collapse_tris_removed = np.asarray(collapse_tris_removed)
        self.collapse_change_count = np.asarray(collapse_change_count)
        self.collapse_change_offsets = np.asarray(collapse_change_offsets)
        self.lod_record_counts = np.asarray(lod_record_counts)
        self._change_start = np.zeros(self.record_count + 1, np.int64)
        np.cumsum(self.collapse_change_count, out=self._change_start[1:])
        # the vertex record r bins: always the last one in use
        self._binned_id = (self.vertex_count - 1 - np.arange(self.record_count)).astype(np.int64)
        self._tri_after = np.empty(self.record_count + 1, np.int64)
        self._tri_after[0] = self.indices.shape[0] // 3
        self._tri_after[1:] = self._tri_after[0] - np.cumsum(self.collapse_tris_removed)

    @property
    def record_count(self) -> int:
        return int(self.collapse_kept.shape[0])

    @property
    def collapse_prev_change_count(self) -> np.ndarray:
        """Forsyth's bPrevNumChanges: the change count of the previous record (0 for the first)."""
        return np.r_[0, self.collapse_change_count[:-1]].astype(self.collapse_change_count.dtype)

    def indices_after(self, records: int) -> np.ndarray:
        """The live index buffer after applying the first ``records`` records (flat, copy)."""
        buf = np.array(self.indices, dtype=np.int64)
        apply_records(
            buf,
            self.collapse_change_offsets.astype(np.int64, copy=False),
            self._change_start,
            self.collapse_kept.astype(np.int64, copy=False),
            self._binned_id,
            0,
            int(records),
        )
        return buf[: 3 * self._tri_after[records]]

    def triangles_at(self, k: int) -> np.ndarray:
        n = int(self.lod_record_counts[self._check_lod(k)])
        return self.indices_after(n).reshape(-1, 3).astype(np.int32)

    def instance(self) -> VanillaInstance:
        return VanillaInstance(self)

    @property
    def _index_bytes(self) -> int:
        # (u32 from 65,536 vertices on: vertex 65,535 would be u16's restart index, spec 1)
        return draw_index_width(self.vertex_count)

    @property
    def global_bytes(self) -> int:
        isz = self._index_bytes
        # Forsyth's record: kept vertex, tri count, change count, previous change count (8 bytes with
        # wider fields) + one offset per changed index; plus the master copy of the index buffer
        offset_size = index_size(max(self.indices.shape[0] - 1, 0))
        records = 8 * self.record_count + offset_size * int(self.collapse_change_offsets.shape[0])
        return int(self.vertex_bytes() + isz * self.indices.shape[0] + records + 8 * self.lod_count)

    @property
    def instance_bytes(self) -> int:
        # a private index buffer plus the current record / vertex / triangle counters
        return int(self._index_bytes * self.indices.shape[0] + 12)

    def buffers(self) -> dict[str, np.ndarray]:
        return {
            "indices": self.indices.astype(np.uint32, copy=False),
            "collapse_kept": self.collapse_kept.astype(np.uint32, copy=False),
            "collapse_tris_removed": self.collapse_tris_removed.astype(np.uint32, copy=False),
            "collapse_change_count": self.collapse_change_count.astype(np.uint32, copy=False),
            "collapse_prev_change_count": self.collapse_prev_change_count.astype(np.uint32, copy=False),
            "collapse_change_offsets": self.collapse_change_offsets.astype(np.uint32, copy=False),
            "lod_record_counts": self.lod_record_counts.astype(np.uint32, copy=False),
        }

    @classmethod
    def _from_buffers(cls, points, attributes, vertex_counts, triangle_counts, lod_errors, buffers, params):
        return cls(
            points,
            attributes,
            vertex_counts,
            triangle_counts,
            lod_errors,
            indices=buffers["indices"],
            collapse_kept=buffers["collapse_kept"],
            collapse_tris_removed=buffers["collapse_tris_removed"],
            collapse_change_count=buffers["collapse_change_count"],
            collapse_change_offsets=buffers["collapse_change_offsets"],
            lod_record_counts=buffers["lod_record_counts"],
            params=params,
        )


class VanillaInstance(RecordInstance):
    """One drawn instance: a private index buffer edited one record at a time."""

    def __init__(self, pm: VanillaProgressiveMesh) -> None:
        super().__init__(pm)
        self._buf = np.array(pm.indices, dtype=np.int64)
        self._offsets = pm.collapse_change_offsets.astype(np.int64, copy=False)
        self._kept = pm.collapse_kept.astype(np.int64, copy=False)

    @property
    def triangle_count(self) -> int:
        return int(self.pm._tri_after[self.records_applied])

    def indices(self) -> np.ndarray:
        """The live part of the index buffer (a view: what would be drawn)."""
        return self._buf[: 3 * self.triangle_count]

    def _move(self, target: int) -> None:
        apply_records(
            self._buf,
            self._offsets,
            self.pm._change_start,
            self._kept,
            self.pm._binned_id,
            self.records_applied,
            target,
        )
        self.records_applied = target


def build_vanilla(seq: CollapseSequence) -> VanillaProgressiveMesh:
    """Vanilla VIPM buffers for a collapse sequence (pure function of the sequence)."""
    mesh = seq.mesh
    V, T, C = mesh.vertex_count, mesh.triangle_count, seq.collapse_count
    # vertices: never-binned first (original order), then binned in reverse collapse order
    new_id = np.empty(V, np.int64)
    is_binned = np.zeros(V, bool)
    is_binned[seq.binned] = True
    survivors = np.flatnonzero(~is_binned)
    new_id[survivors] = np.arange(survivors.shape[0])
    new_id[seq.binned] = V - 1 - np.arange(C)
    perm = np.empty(V, np.int64)
    perm[new_id] = np.arange(V)

    die, removed, start, corners = collapse_records(mesh.triangles, seq.binned, seq.kept, V)
    # triangles: survivors first, then the triangles of later collapses before earlier ones
    order = np.argsort(-die, kind="stable")
    new_pos = np.empty(T, np.int64)
    new_pos[order] = np.arange(T)
    indices = new_id[mesh.triangles[order]].reshape(-1)
    offsets = new_pos[corners // 3] * 3 + corners % 3
    change_count = np.diff(start)

    lod_records = seq.step_offsets.astype(np.int64)
    tri_after = T - np.r_[0, np.cumsum(removed)]
    return VanillaProgressiveMesh(
        points=mesh.points[perm],
        attributes={name: a[perm] for name, a in mesh.attributes.items()},
        vertex_counts=V - lod_records,
        triangle_counts=tri_after[lod_records],
        lod_errors=seq.lod_errors(),
        indices=indices.astype(np.uint32),
        collapse_kept=new_id[seq.kept].astype(np.uint32),
        collapse_tris_removed=removed.astype(np.uint32),
        collapse_change_count=change_count.astype(np.uint32),
        collapse_change_offsets=offsets.astype(np.uint32),
        lod_record_counts=lod_records.astype(np.uint32),
        params={},
    )
