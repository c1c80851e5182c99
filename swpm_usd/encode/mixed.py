"""Mixed-mode VIPM with indexed lists (Forsyth, "Comparison of VIPM Methods", Game Programming Gems 2, 4.1).

Levels as in multilevel skip lists (a new level when the level's binned fraction would exceed
``level_threshold``). Within a level, its collapses split the level's triangles into Forsyth's four lists:

1. untouched by the level's collapses, 2. binned without being changed first, 3. changed but never binned,
4. changed, then binned.

Lists 1 and 3 are in vertex-cache order, lists 2 and 4 in bin order (first binned last). ``static`` = 1 + 2 is
shared by every instance and only shortens (``collapse_static_tris_removed``); ``dynamic`` = 3 + 4 is copied
per instance and edited with vanilla records (changed slots, ``collapse_dynamic_tris_removed``). A LOD draws
two lists: the live prefix of the level's dynamic copy and of its static list. Each level also stores its
fully collapsed dynamic list so crossing a level boundary upwards costs no re-collapsing.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..build import check_cache_size
from ..encodings import MIXED_PARAMS
from ..errors import BuildError
from ..format.layout import draw_index_width
from ..mesh import Mesh
from ..simplify import CollapseSequence, collapse_sequence
from .base import ProgressiveMesh, register
from .instance import LevelledInstance, apply_records
from .skipstrip import cache_permutation, next_level_lod, vertex_order
from .vanilla import collapse_records, index_size

__all__ = ["MIXED_PARAMS", "MixedInstance", "MixedProgressiveMesh", "build_mixed", "build_mixed_mesh"]


_BUFFER_NAMES = (
    "level_first_lod",
    "level_record_start",
    "level_static_start",
    "level_static_indices",
    "level_dynamic_start",
    "level_dynamic_indices",
    "level_dynamic_collapsed_indices",
    "collapse_kept",
    "collapse_static_tris_removed",
    "collapse_dynamic_tris_removed",
    "collapse_change_count",
    "collapse_change_offsets",
    "lod_record_counts",
)


@register
class MixedProgressiveMesh(ProgressiveMesh):
    """Mixed-mode lists: per level a static (shared) and a dynamic (per-instance) triangle list.

    Level ``l`` draws LODs from ``level_first_lod[l]``; its records are ``level_record_start[l]`` up to
    ``level_record_start[l+1]``; its static list is ``level_static_indices[level_static_start[l]: ...[l+1]]``
    and its dynamic list (uncollapsed / fully collapsed, same length) the same range of
    ``level_dynamic_indices`` / ``level_dynamic_collapsed_indices`` with ``level_dynamic_start``. Record ``r``
    bins vertex ``V - 1 - r`` onto ``collapse_kept[r]``, drops triangles off the end of both lists and
    changes slots of the dynamic list.
    """

    encoding = "mixed"

    def __init__(
        self,
        points: np.ndarray,
        attributes: Mapping[str, np.ndarray],
        vertex_counts: np.ndarray,
        triangle_counts: np.ndarray,
        lod_errors: np.ndarray,
        buffers: Mapping[str, np.ndarray],
        params: Mapping[str, Any] | None = None,
    ) -> None:
        super().__init__(points, attributes, vertex_counts, triangle_counts, lod_errors, params)
        for name in _BUFFER_NAMES:
            setattr(self, name, np.asarray(buffers[name]).reshape(-1))
        R = self.record_count
        self._start = np.zeros(R + 1, np.int64)
        np.cumsum(self.collapse_change_count, out=self._start[1:])
        self._offsets = self.collapse_change_offsets.astype(np.int64)
        self._kept = self.collapse_kept.astype(np.int64)
        self._binned = (self.vertex_count - 1 - np.arange(R)).astype(np.int64)
        self._lrs = self.level_record_start.astype(np.int64)
        # live triangle counts of each list after r records (within r's level, from the level's full lists)
        ns = np.diff(self.level_static_start.astype(np.int64)) // 3
        nd = np.diff(self.level_dynamic_start.astype(np.int64)) // 3
        st = self.collapse_static_tris_removed.astype(np.int64)
        dy = self.collapse_dynamic_tris_removed.astype(np.int64)
        self._static_after = np.zeros(R + 1, np.int64)
        self._dynamic_after = np.zeros(R + 1, np.int64)
        for lvl in range(self.level_count):  # per level, vectorised over its records
            r0, r1 = int(self._lrs[lvl]), int(self._lrs[lvl + 1])
            self._static_after[r0 : r1 + 1] = ns[lvl] - np.r_[0, np.cumsum(st[r0:r1])]
            self._dynamic_after[r0 : r1 + 1] = nd[lvl] - np.r_[0, np.cumsum(dy[r0:r1])]

    level_first_lod: np.ndarray
    level_record_start: np.ndarray
    level_static_start: np.ndarray
    level_static_indices: np.ndarray
    level_dynamic_start: np.ndarray
    level_dynamic_indices: np.ndarray
    level_dynamic_collapsed_indices: np.ndarray
    collapse_kept: np.ndarray
    collapse_static_tris_removed: np.ndarray
    collapse_dynamic_tris_removed: np.ndarray
    collapse_change_count: np.ndarray
    collapse_change_offsets: np.ndarray
    lod_record_counts: np.ndarray

    @property
    def level_count(self) -> int:
        return int(self.level_first_lod.shape[0])

    @property
    def record_count(self) -> int:
        return int(self.collapse_kept.shape[0])

    @property
    def collapse_prev_change_count(self) -> np.ndarray:
        return np.r_[0, self.collapse_change_count[:-1]].astype(np.uint32)

    def level_of_records(self, r: int) -> int:
        return int(np.searchsorted(self._lrs[1:-1], int(r), side="right"))

    def static_list(self, level: int) -> np.ndarray:
        s = self.level_static_start
        return self.level_static_indices[s[level] : s[level + 1]]

    def dynamic_list(self, level: int, collapsed: bool = False) -> np.ndarray:
        s = self.level_dynamic_start
        src = self.level_dynamic_collapsed_indices if collapsed else self.level_dynamic_indices
        return src[s[level] : s[level + 1]]

    def instance(self) -> MixedInstance:
        return MixedInstance(self)

    def draw_calls(self, k: int) -> list[tuple[str, np.ndarray]]:
        """The two draws of LOD ``k``: the dynamic (per-instance) list, then the static (shared) one."""
        inst = MixedInstance(self)
        inst.set_lod(k)
        return inst.draw_calls()

    def triangles_at(self, k: int) -> np.ndarray:
        calls = self.draw_calls(k)
        return np.concatenate([c[1] for c in calls]).reshape(-1, 3).astype(np.int32)

    # -- memory ----------------------------------------------------------------------------------------
    @property
    def _index_bytes(self) -> int:
        # (u32 from 65,536 vertices on: vertex 65,535 would be u16's restart index, spec 1)
        return draw_index_width(self.vertex_count)

    @property
    def global_bytes(self) -> int:
        isz = self._index_bytes
        nd = np.diff(self.level_dynamic_start.astype(np.int64))
        offset_size = index_size(max(int(nd.max()) - 1, 0) if nd.size else 0)
        lists = isz * (
            self.level_static_indices.shape[0]
            + self.level_dynamic_indices.shape[0]
            + self.level_dynamic_collapsed_indices.shape[0]
        )
        # record: kept vertex, static and dynamic tri counts, change counts (10 bytes) + offsets
        records = 10 * self.record_count + offset_size * int(self.collapse_change_offsets.shape[0])
        return int(self.vertex_bytes() + lists + records + 20 * self.level_count + 4 * self.lod_count)

    @property
    def instance_bytes(self) -> int:
        nd = np.diff(self.level_dynamic_start.astype(np.int64))
        return int(self._index_bytes * (int(nd.max()) if nd.size else 0) + 20)

    def buffers(self) -> dict[str, np.ndarray]:
        out = {name: getattr(self, name).astype(np.uint32, copy=False) for name in _BUFFER_NAMES}
        out["collapse_prev_change_count"] = self.collapse_prev_change_count
        return out

    @classmethod
    def _from_buffers(cls, points, attributes, vertex_counts, triangle_counts, lod_errors, buffers, params):
        return cls(points, attributes, vertex_counts, triangle_counts, lod_errors, buffers, params)


class MixedInstance(LevelledInstance):
    """One drawn instance: a private copy of the current level's dynamic list; the static list is shared."""

    def _level_list(self, level: int, collapsed: bool) -> np.ndarray:
        return self.pm.dynamic_list(level, collapsed)

    def draw_calls(self) -> list[tuple[str, np.ndarray]]:
        """The two draws as they are now: dynamic live prefix, static live prefix (uint32)."""
        r = self.records_applied
        nd = int(self.pm._dynamic_after[r])
        ns = int(self.pm._static_after[r])
        return [
            ("triangles", self._buf[: 3 * nd].astype(np.uint32)),
            ("triangles", np.asarray(self.pm.static_list(self.level)[: 3 * ns], np.uint32)),
        ]

    def draw_stream(self, k: int | None = None) -> tuple[str, np.ndarray]:
        """Both draws concatenated (after moving to LOD ``k`` when given)."""
        if k is not None:
            self.set_lod(k)
        return "triangles", np.concatenate([c[1] for c in self.draw_calls()])

    def triangles(self) -> np.ndarray:
        return self.draw_stream()[1].reshape(-1, 3)


def build_mixed(
    seq: CollapseSequence, *, level_threshold: float = 0.25, cache_size: int = 16
) -> MixedProgressiveMesh:
    """Mixed-mode lists for a collapse sequence; see the module docstring."""
    if not 0.0 <= float(level_threshold) < 1.0:
        raise BuildError(f"level_threshold must be in [0, 1), got {level_threshold}")
    check_cache_size(cache_size)  # (build()'s bounds, called directly too)
    mesh = seq.mesh
    V, C = mesh.vertex_count, seq.collapse_count
    new_id, perm = vertex_order(seq)
    binned = (V - 1 - np.arange(C)).astype(np.int64)
    kept = new_id[seq.kept].astype(np.int64)
    lod_records = seq.step_offsets.astype(np.int64)
    L = lod_records.shape[0]

    tris = new_id[mesh.triangles].astype(np.int64)
    first_lod, rec_start = [], []
    statics, dynamics, dyn_collapsed = [], [], []
    st_removed, dy_removed, change_counts, change_offsets = [], [], [], []
    tri_counts = np.zeros(L, np.int64)
    k = 0
    while True:
        k_end, dead = next_level_lod(tris, binned, kept, lod_records, k, V, float(level_threshold))
        c0 = int(lod_records[k])
        c1 = int(lod_records[k_end]) if k_end < L else C
        n = c1 - c0
        tri_counts[k:k_end] = tris.shape[0] - dead[lod_records[k:k_end] - c0]
        die, _, start, corners = collapse_records(tris, binned[c0:c1], kept[c0:c1], V)
        T = tris.shape[0]
        first_change = np.full(T, n, np.int64)
        rec_of_corner = np.repeat(np.arange(n), np.diff(start))
        np.minimum.at(first_change, corners // 3, rec_of_corner)
        binned_t = die < n
        changed = first_change < die  # changed before being binned (or ever, for survivors)
        idx1 = np.flatnonzero(~binned_t & ~changed)
        idx2 = np.flatnonzero(binned_t & ~changed)
        idx3 = np.flatnonzero(~binned_t & changed)
        idx4 = np.flatnonzero(binned_t & changed)
        idx2 = idx2[np.argsort(-die[idx2], kind="stable")]
        idx4 = idx4[np.argsort(-die[idx4], kind="stable")]

        static_order = np.r_[idx1[cache_permutation(tris[idx1], V, cache_size)], idx2]
        dynamic_order = np.r_[idx3[cache_permutation(tris[idx3], V, cache_size)], idx4]
        pos = np.empty(T, np.int64)
        pos[dynamic_order] = np.arange(dynamic_order.size)
        dyn = tris[dynamic_order].reshape(-1)
        offs = pos[corners // 3] * 3 + corners % 3
        col = dyn.copy()
        apply_records(col, offs, start, kept[c0:c1], binned[c0:c1], 0, n)
        first_lod.append(k)
        rec_start.append(c0)
        statics.append(tris[static_order].reshape(-1))
        dynamics.append(dyn)
        dyn_collapsed.append(col)
        st_removed.append(np.bincount(die[idx2], minlength=n)[:n])
        dy_removed.append(np.bincount(die[idx4], minlength=n)[:n])
        change_counts.append(np.diff(start))
        change_offsets.append(offs)
        if k_end >= L:
            break
        live_d = dyn.size // 3 - int(dy_removed[-1].sum())
        live_s = statics[-1].size // 3 - int(st_removed[-1].sum())
        tris = np.concatenate([col[: 3 * live_d], statics[-1][: 3 * live_s]]).reshape(-1, 3)
        k = k_end
    rec_start.append(C)

    def _cat(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(parts).astype(np.uint32) if parts else np.zeros(0, np.uint32)

    def _starts(parts: list[np.ndarray]) -> np.ndarray:
        return np.r_[0, np.cumsum([p.shape[0] for p in parts])].astype(np.uint32)

    buffers = {
        "level_first_lod": np.asarray(first_lod, np.uint32),
        "level_record_start": np.asarray(rec_start, np.uint32),
        "level_static_start": _starts(statics),
        "level_static_indices": _cat(statics),
        "level_dynamic_start": _starts(dynamics),
        "level_dynamic_indices": _cat(dynamics),
        "level_dynamic_collapsed_indices": _cat(dyn_collapsed),
        "collapse_kept": kept.astype(np.uint32),
        "collapse_static_tris_removed": _cat(st_removed),
        "collapse_dynamic_tris_removed": _cat(dy_removed),
        "collapse_change_count": _cat(change_counts),
        "collapse_change_offsets": _cat(change_offsets),
        "lod_record_counts": lod_records.astype(np.uint32),
    }
    return MixedProgressiveMesh(
        points=mesh.points[perm],
        attributes={name: a[perm] for name, a in mesh.attributes.items()},
        vertex_counts=V - lod_records,
        triangle_counts=tri_counts,
        lod_errors=seq.lod_errors(),
        buffers=buffers,
        params={"level_threshold": float(level_threshold), "cache_size": int(cache_size)},
    )


def build_mixed_mesh(
    mesh: Mesh, *, boundary_weight: float = 8.0, seam_weight: float = 2.0, **params: Any
) -> MixedProgressiveMesh:
    """``BUILDERS`` entry: collapse sequence of ``mesh``, then :func:`build_mixed` with ``params``."""
    seq = collapse_sequence(mesh, boundary_weight=boundary_weight, seam_weight=seam_weight)
    pm = build_mixed(seq, **params)
    pm.params.update(boundary_weight=boundary_weight, seam_weight=seam_weight)
    return pm
