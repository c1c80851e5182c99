"""Multilevel skip strips (Forsyth, "Comparison of VIPM Methods", Game Programming Gems 2, 4.1; the name
from El-Sana et al., "Skip Strips", 1999) and their indexed-list variant.

A collapse does not drop triangles off the end of the index buffer as in vanilla VIPM: every index slot that
holds the binned vertex is redirected to the kept vertex, so the binned triangles become degenerate in place
and the triangle order is free to follow the vertex cache (and to form strips). Per level, the level's
triangles are put in vertex-cache order (:func:`swpm_usd.vcache.optimize_triangle_order`) and, for
``primitive="strip"``, turned into strips by :func:`.strips.stripify`. A new level starts at the first LOD
whose degenerate fraction (triangles of the level made degenerate by its collapses, over the level's
triangles) would exceed ``degenerate_threshold``: its degenerate triangles are dropped and the rest
re-ordered and re-stripped. Each level stores its uncollapsed list and its fully collapsed list (its state at
the next level's first LOD), so a runtime instance that oscillates across a level boundary copies the nearer
one and applies only the records in between.

Vertices are in vanilla order (the vertex collapse ``c`` bins is ``V - 1 - c``), so LOD ``k`` uses the vertex
prefix. Strip joins are restart indices (``restart=True``; the restart value is the largest value of the
file's index type, ``0xFFFF`` when every vertex id is below 0xFFFF and every other value of every buffer
fits u16 (the format writer's width rule), else ``0xFFFFFFFF``, stored in ``params["restart_index"]``) or
degenerate triangles (``restart=False``), which are joins, not collapses, and are not counted against the
level threshold. Strip collapse records change *slots*: a strip slot is shared by up to three triangles.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import Any

import numba as nb
import numpy as np

from ..build import check_cache_size
from ..encodings import MAX_STRIP_WINDOW, PRIMITIVES, SKIPSTRIP_PARAMS, combination_problem
from ..errors import BuildError
from ..format.layout import STRIP_ARRAYS, draw_index_width, rejoin_strips, restart_index_for
from ..mesh import Mesh
from ..simplify import CollapseSequence, collapse_sequence
from .base import ProgressiveMesh, register
from .instance import LevelledInstance
from .strips import decode_strip, stripify
from .vanilla import collapse_records, index_size

__all__ = [
    "SKIPSTRIP_PARAMS",
    "SkipStripInstance",
    "SkipStripProgressiveMesh",
    "build_skipstrip",
    "build_skipstrip_mesh",
]


# ---------------------------------------------------------------------------------------------------------
# shared helpers (also used by the mixed-mode encoder)
# ---------------------------------------------------------------------------------------------------------


def vertex_order(seq: CollapseSequence) -> tuple[np.ndarray, np.ndarray]:
    """Vanilla vertex order: ``(new_id, perm)``; never-binned vertices first, the binned ones in reverse
    collapse order (collapse ``c`` bins ``V - 1 - c``)."""
    V, C = seq.mesh.vertex_count, seq.collapse_count
    new_id = np.empty(V, np.int64)
    is_binned = np.zeros(V, bool)
    is_binned[seq.binned] = True
    survivors = np.flatnonzero(~is_binned)
    new_id[survivors] = np.arange(survivors.shape[0])
    new_id[seq.binned] = V - 1 - np.arange(C)
    perm = np.empty(V, np.int64)
    perm[new_id] = np.arange(V)
    return new_id, perm


_warned = False


def cache_permutation(tris: np.ndarray, vertex_count: int, cache_size: int) -> np.ndarray:
    """Order of ``tris`` (n, 3) for a FIFO vertex cache, from :mod:`swpm_usd.vcache` (identity if absent)."""
    global _warned
    tris = np.ascontiguousarray(tris, dtype=np.int64).reshape(-1, 3)
    n = tris.shape[0]
    if n < 2:
        return np.arange(n, dtype=np.int64)
    try:
        from ..vcache import optimize_triangle_order
    except ImportError:
        if not _warned:
            warnings.warn("swpm_usd.vcache not available: triangles keep their order", stacklevel=2)
            _warned = True
        return np.arange(n, dtype=np.int64)
    res = np.asarray(optimize_triangle_order(tris, int(vertex_count), int(cache_size)))
    if res.ndim == 1 and res.shape[0] == n:
        return res.astype(np.int64)
    # reordered (possibly rotated) triangles: recover the permutation (equal rows are interchangeable)
    ordered = _rotate_min_first(np.ascontiguousarray(res, dtype=np.int64).reshape(-1, 3))
    perm = np.empty(n, np.int64)
    perm[np.lexsort(ordered.T[::-1])] = np.lexsort(_rotate_min_first(tris).T[::-1])
    return perm


def _rotate_min_first(t: np.ndarray) -> np.ndarray:
    r = np.argmin(t, axis=1)
    return np.take_along_axis(t, (np.arange(3)[None, :] + r[:, None]) % 3, axis=1)


def cache_order(tris: np.ndarray, vertex_count: int, cache_size: int) -> np.ndarray:
    """``tris`` (n, 3) reordered by :func:`cache_permutation`."""
    tris = np.ascontiguousarray(tris, dtype=np.int64).reshape(-1, 3)
    return tris[cache_permutation(tris, vertex_count, cache_size)]


def next_level_lod(
    tris: np.ndarray,
    binned: np.ndarray,
    kept: np.ndarray,
    lod_records: np.ndarray,
    k: int,
    V: int,
    thr: float,
) -> tuple[int, np.ndarray]:
    """For a level starting at LOD ``k`` with ``tris`` (non-degenerate), the first LOD ``k' > k`` whose
    fraction of binned (degenerate) level triangles exceeds ``thr`` (``len(lod_records)`` if none), and the
    number of level triangles binned after each record of the level (from record ``lod_records[k]``)."""
    L = lod_records.shape[0]
    c0 = int(lod_records[k])
    if tris.shape[0] == 0:
        return L, np.zeros(binned.shape[0] - c0 + 1, np.int64)
    _, removed, _, _ = collapse_records(tris, binned[c0:], kept[c0:], V)
    dead = np.r_[0, np.cumsum(removed)]
    frac = dead[lod_records[k + 1 :] - c0] / tris.shape[0]
    over = np.flatnonzero(frac > thr)
    return (k + 1 + int(over[0])) if over.size else L, dead


@nb.njit(cache=True)
def _slot_replay(buf: np.ndarray, binned: np.ndarray, kept: np.ndarray, V: int):
    """Collapse every slot of ``buf`` (values >= V, e.g. restart indices, are not vertices) holding
    ``binned[r]`` to ``kept[r]``, in record order, in place. Returns the CSR start and slot of each change."""
    n = buf.shape[0]
    R = binned.shape[0]
    head = np.full(V, -1, np.int64)
    nxt = np.full(n, -1, np.int64)
    for i in range(n - 1, -1, -1):
        v = buf[i]
        if 0 <= v < V:
            nxt[i] = head[v]
            head[v] = i
    start = np.zeros(R + 1, np.int64)
    out = np.empty(max(16, n), np.int64)
    m = 0
    for r in range(R):
        b = binned[r]
        k = kept[r]
        start[r] = m
        s = head[b]
        last = -1
        while s >= 0:
            buf[s] = k
            if m == out.shape[0]:
                grown = np.empty(2 * m, np.int64)
                for i in range(m):  # a loop, not grown[:m] = out: see sw_collapse._grow_tris
                    grown[i] = out[i]
                out = grown
            out[m] = s
            m += 1
            last = s
            s = nxt[s]
        if last >= 0:
            nxt[last] = head[k]
            head[k] = head[b]
            head[b] = -1
    start[R] = m
    return start, out[:m].copy()


def _nondegenerate(t: np.ndarray) -> np.ndarray:
    t = t.reshape(-1, 3)
    return t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])]


def restart_value(vertex_count: int) -> int:
    """The restart index strips are built with: the largest value of the smallest index type that also holds
    every vertex id. Not yet the file's: :func:`settle_restart` makes it all ones of the file's ``idx`` (the
    same value since 0.9.0, whose tables widen apart from ``idx``, OFFSET32)."""
    return 0xFFFF if vertex_count <= 0xFFFF else 0xFFFFFFFF


def settle_restart(pm: ProgressiveMesh, lists: tuple[str, ...] | None = None) -> None:
    """Give ``pm``, whose arrays ``lists`` are strips joined by ``pm.restart_index`` (:func:`restart_value`),
    the restart index of its file: the largest value of the file's index type by the format writer's width
    rule over ``pm.buffers()`` (:func:`..format.layout.restart_index_for`), so an engine uploads the file's
    indices as they are with the restart value Vulkan, D3D12 and Metal take (spec 3.5, 3.7). When it differs
    (a mesh given strips joined by another value; before 0.9.0 also a pool longer than 65,535 indices, which
    made the file u32 through its offsets: now only the tables' ``off`` widens) the restart entries of
    ``lists`` (default: the encoding's, :data:`..format.layout.STRIP_ARRAYS`) are rewritten into new uint32
    arrays (:func:`..format.layout.rejoin_strips`), with ``restart_index`` and
    ``params["restart_index"]``."""
    old = int(pm.restart_index)
    rv = restart_index_for(pm.buffers(), old, pm.vertex_count)
    if rv != old:
        names = STRIP_ARRAYS[pm.encoding] if lists is None else lists
        for name, a in rejoin_strips({n: getattr(pm, n) for n in names}, old, rv).items():
            setattr(pm, name, a)
    pm.restart_index = rv
    pm.params["restart_index"] = rv


# ---------------------------------------------------------------------------------------------------------
# the encoding
# ---------------------------------------------------------------------------------------------------------


@register
class SkipStripProgressiveMesh(ProgressiveMesh):
    """Multilevel skip strips (``params["primitive"] == "strip"``) or skip lists (``"list"``).

    Level ``l`` draws LODs ``level_first_lod[l]`` up to the next level's first LOD; its lists are
    ``level_indices[level_index_start[l]:level_index_start[l+1]]`` (uncollapsed) and the same range of
    ``level_collapsed_*`` (all its records applied), and its records are ``level_record_start[l]`` up to
    ``level_record_start[l+1]``. Record ``r`` bins vertex ``V - 1 - r`` onto ``collapse_kept[r]`` and rewrites
    the ``collapse_change_count[r]`` slots of its level's list listed in ``collapse_change_offsets``.
    """

    encoding = "skip-strip"

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
        self.params.setdefault("primitive", "strip")
        if self.params["primitive"] not in PRIMITIVES:
            raise BuildError(f"primitive must be one of {PRIMITIVES}, got {self.params['primitive']!r}")
        ri = self.params.get("restart_index")
        self.restart_index = None if ri is None or self.params["primitive"] == "list" else int(ri)
        b = {name: np.asarray(buffers[name]).reshape(-1) for name in _BUFFER_NAMES}
        self.level_first_lod = b["level_first_lod"]
        self.level_index_start = b["level_index_start"]
        self.level_indices = b["level_indices"]
        self.level_collapsed_start = b["level_collapsed_start"]
        self.level_collapsed_indices = b["level_collapsed_indices"]
        self.level_record_start = b["level_record_start"]
        self.collapse_kept = b["collapse_kept"]
        self.collapse_binned = b["collapse_binned"]
        self.collapse_change_count = b["collapse_change_count"]
        self.collapse_change_offsets = b["collapse_change_offsets"]
        self.lod_record_counts = b["lod_record_counts"]
        # int64 working copies for the kernels
        self._start = np.zeros(self.record_count + 1, np.int64)
        np.cumsum(self.collapse_change_count, out=self._start[1:])
        self._offsets = self.collapse_change_offsets.astype(np.int64)
        self._kept = self.collapse_kept.astype(np.int64)
        self._binned = self.collapse_binned.astype(np.int64)
        self._lrs = self.level_record_start.astype(np.int64)

    # -- structure -------------------------------------------------------------------------------------
    @property
    def primitive(self) -> str:
        return str(self.params["primitive"])

    @property
    def level_count(self) -> int:
        return int(self.level_first_lod.shape[0])

    @property
    def record_count(self) -> int:
        return int(self.collapse_kept.shape[0])

    @property
    def collapse_prev_change_count(self) -> np.ndarray:
        """Forsyth's bPrevNumChanges: the change count of the previous record (0 for the first)."""
        return np.r_[0, self.collapse_change_count[:-1]].astype(np.uint32)

    def level_of_lod(self, k: int) -> int:
        return int(np.searchsorted(self.level_first_lod, self._check_lod(k), side="right")) - 1

    def level_of_records(self, r: int) -> int:
        """The level that draws the state after ``r`` records (a boundary state belongs to the next level)."""
        return int(np.searchsorted(self._lrs[1:-1], int(r), side="right"))

    def level_list(self, level: int, collapsed: bool = False) -> np.ndarray:
        """Level ``level``'s stored list (uncollapsed or fully collapsed), a view."""
        if collapsed:
            s = self.level_collapsed_start
            return self.level_collapsed_indices[s[level] : s[level + 1]]
        s = self.level_index_start
        return self.level_indices[s[level] : s[level + 1]]

    def level_triangle_count(self, level: int) -> int:
        """Triangles of a level's uncollapsed list (none degenerate except strip joins)."""
        return int(len(self._decode(self.level_list(level))))

    # -- drawing ---------------------------------------------------------------------------------------
    @property
    def _kind(self) -> str:
        return "strip" if self.primitive == "strip" else "triangles"

    def _decode(self, stream: np.ndarray) -> np.ndarray:
        if self.primitive == "strip":
            return decode_strip(stream, self.restart_index)
        return _nondegenerate(np.asarray(stream, np.int64))

    def instance(self) -> SkipStripInstance:
        return SkipStripInstance(self)

    def draw_stream(self, k: int) -> tuple[str, np.ndarray]:
        inst = SkipStripInstance(self)
        inst.set_lod(k)
        return inst.draw_stream()

    def triangles_at(self, k: int) -> np.ndarray:
        return self._decode(self.draw_stream(k)[1]).astype(np.int32)

    # -- memory ----------------------------------------------------------------------------------------
    @property
    def _index_bytes(self) -> int:
        # (the width an engine draws at, a u32 file's restart 0xFFFFFFFF copied as u16's 0xFFFF while vertex
        # ids fit: the strips count what the lists of the same file count)
        return draw_index_width(self.vertex_count, self.restart_index)

    @property
    def global_bytes(self) -> int:
        isz = self._index_bytes
        longest = int(np.max(np.diff(self.level_index_start))) if self.level_count else 0
        offset_size = index_size(max(longest - 1, 0))
        lists = isz * (self.level_indices.shape[0] + self.level_collapsed_indices.shape[0])
        # record: kept vertex, change count, previous change count (8 bytes with padding) + offsets
        records = 8 * self.record_count + offset_size * int(self.collapse_change_offsets.shape[0])
        # level table: first LOD, list offsets (2), record start; LOD table: record count
        return int(self.vertex_bytes() + lists + records + 16 * self.level_count + 4 * self.lod_count)

    @property
    def instance_bytes(self) -> int:
        # a private copy of the longest level list (level 0) plus level / record / count counters
        longest = int(np.max(np.diff(self.level_index_start))) if self.level_count else 0
        return int(self._index_bytes * longest + 16)

    # -- buffers ---------------------------------------------------------------------------------------
    def buffers(self) -> dict[str, np.ndarray]:
        out = {name: getattr(self, name).astype(np.uint32, copy=False) for name in _BUFFER_NAMES}
        out["collapse_prev_change_count"] = self.collapse_prev_change_count
        return out

    @classmethod
    def _from_buffers(cls, points, attributes, vertex_counts, triangle_counts, lod_errors, buffers, params):
        return cls(points, attributes, vertex_counts, triangle_counts, lod_errors, buffers, params)


_BUFFER_NAMES = (
    "level_first_lod",
    "level_index_start",
    "level_indices",
    "level_collapsed_start",
    "level_collapsed_indices",
    "level_record_start",
    "collapse_kept",
    "collapse_binned",
    "collapse_change_count",
    "collapse_change_offsets",
    "lod_record_counts",
)


class SkipStripInstance(LevelledInstance):
    """One drawn instance: a private copy of the current level's list, edited one record at a time.

    ``records_applied`` is the global record count; the instance switches level (copying the nearer of the
    target level's uncollapsed and fully collapsed lists) whenever the target state belongs to another level.
    """

    def _level_list(self, level: int, collapsed: bool) -> np.ndarray:
        return self.pm.level_list(level, collapsed)

    def indices(self) -> np.ndarray:
        """The instance's list (a view): all of it is drawn, degenerate triangles included."""
        return self._buf

    def draw_stream(self, k: int | None = None) -> tuple[str, np.ndarray]:
        """Exactly what is drawn (after moving to LOD ``k`` when given): ``(kind, uint32 indices)``."""
        if k is not None:
            self.set_lod(k)
        return self.pm._kind, self._buf.astype(np.uint32)

    def triangles(self) -> np.ndarray:
        """The visible (non-degenerate) triangles drawn now, (n, 3)."""
        return self.pm._decode(self._buf)


# ---------------------------------------------------------------------------------------------------------
# builder
# ---------------------------------------------------------------------------------------------------------


def build_skipstrip(
    seq: CollapseSequence,
    *,
    primitive: str = "strip",
    restart: bool = True,
    degenerate_threshold: float = 0.25,
    cache_size: int = 16,
    strip_window: int = 4,
) -> SkipStripProgressiveMesh:
    """Multilevel skip strips (or skip lists) for a collapse sequence; see the module docstring."""
    if primitive not in PRIMITIVES:
        raise BuildError(f"primitive must be one of {PRIMITIVES}, got {primitive!r}")
    check_cache_size(cache_size)  # (build()'s bounds, called directly too)
    if not 0.0 <= float(degenerate_threshold) < 1.0:
        raise BuildError(f"degenerate_threshold must be in [0, 1), got {degenerate_threshold}")
    if isinstance(strip_window, bool) or not isinstance(strip_window, (int, np.integer)):
        raise BuildError(f"strip_window must be an integer, got {strip_window!r}")
    if not 1 <= int(strip_window) <= MAX_STRIP_WINDOW:
        raise BuildError(f"strip_window must be in [1, {MAX_STRIP_WINDOW}], got {strip_window}")
    problem = combination_problem(  # (as the command line and a config refuse it, before a mesh is read)
        "skip-strip", {"primitive": primitive, "restart": restart, "strip_window": strip_window}
    )
    if problem:
        raise BuildError(problem)
    mesh = seq.mesh
    V, C = mesh.vertex_count, seq.collapse_count
    new_id, perm = vertex_order(seq)
    binned = (V - 1 - np.arange(C)).astype(np.int64)
    kept = new_id[seq.kept].astype(np.int64)
    lod_records = seq.step_offsets.astype(np.int64)
    L = lod_records.shape[0]
    rv = restart_value(V) if (primitive == "strip" and restart) else None

    tris = new_id[mesh.triangles].astype(np.int64)
    first_lod: list[int] = []
    lists: list[np.ndarray] = []
    collapsed_lists: list[np.ndarray] = []
    rec_start: list[int] = []
    change_starts: list[np.ndarray] = []
    change_offsets: list[np.ndarray] = []
    tri_counts = np.zeros(L, np.int64)
    k = 0
    while True:
        k_end, dead = next_level_lod(tris, binned, kept, lod_records, k, V, float(degenerate_threshold))
        c0 = int(lod_records[k])
        c1 = int(lod_records[k_end]) if k_end < L else C
        tri_counts[k:k_end] = tris.shape[0] - dead[lod_records[k:k_end] - c0]
        ordered = cache_order(tris, V, cache_size)
        if primitive == "strip":
            lst = stripify(ordered, V, rv, strip_window)
        else:
            lst = ordered.reshape(-1)
        col = lst.copy()
        start, offs = _slot_replay(col, binned[c0:c1], kept[c0:c1], V)
        first_lod.append(k)
        rec_start.append(c0)
        lists.append(lst)
        collapsed_lists.append(col)
        change_starts.append(np.diff(start))
        change_offsets.append(offs)
        if k_end >= L:
            break
        tris = decode_strip(col, rv) if primitive == "strip" else _nondegenerate(col)
        k = k_end
    rec_start.append(C)

    def _cat(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(parts).astype(np.uint32) if parts else np.zeros(0, np.uint32)

    def _starts(parts: list[np.ndarray]) -> np.ndarray:
        return np.r_[0, np.cumsum([p.shape[0] for p in parts])].astype(np.uint32)

    buffers = {
        "level_first_lod": np.asarray(first_lod, np.uint32),
        "level_index_start": _starts(lists),
        "level_indices": _cat(lists),
        "level_collapsed_start": _starts(collapsed_lists),
        "level_collapsed_indices": _cat(collapsed_lists),
        "level_record_start": np.asarray(rec_start, np.uint32),
        "collapse_kept": kept.astype(np.uint32),
        "collapse_binned": binned.astype(np.uint32),
        "collapse_change_count": _cat(change_starts),
        "collapse_change_offsets": _cat(change_offsets),
        "lod_record_counts": lod_records.astype(np.uint32),
    }
    params: dict[str, Any] = {
        "primitive": primitive,
        "restart": bool(restart),
        "restart_index": rv,
        "degenerate_threshold": float(degenerate_threshold),
        "cache_size": int(cache_size),
        "strip_window": int(strip_window),
    }
    pm = SkipStripProgressiveMesh(
        points=mesh.points[perm],
        attributes={name: a[perm] for name, a in mesh.attributes.items()},
        vertex_counts=V - lod_records,
        triangle_counts=tri_counts,
        lod_errors=seq.lod_errors(),
        buffers=buffers,
        params=params,
    )
    if rv is not None:
        settle_restart(pm)
    return pm


def build_skipstrip_mesh(
    mesh: Mesh, *, boundary_weight: float = 8.0, seam_weight: float = 2.0, **params: Any
) -> SkipStripProgressiveMesh:
    """``BUILDERS`` entry: collapse sequence of ``mesh``, then :func:`build_skipstrip` with ``params``."""
    seq = collapse_sequence(mesh, boundary_weight=boundary_weight, seam_weight=seam_weight)
    pm = build_skipstrip(seq, **params)
    pm.params.update(boundary_weight=boundary_weight, seam_weight=seam_weight)
    return pm
