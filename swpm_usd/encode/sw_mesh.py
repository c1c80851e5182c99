"""The sliding-window progressive mesh as stored and drawn (Forsyth, "Comparison of VIPM Methods", sliding
window): one static ``index_pool`` and one ``window_records`` row per LOD (Forsyth's ``SlidingWindowRecord``:
first index offset, triangle count, vertex count), the LOD look-ups on them, the memory it costs and its
buffers. The builders (:mod:`.slidingwindow`) make it; :mod:`.sw_assemble` fills it from the levels.
With ``params["primitive"] == "strip"`` the pool is triangle strips joined by ``params["restart_index"]``
(:mod:`.sw_strips`): a window is ``window_index_counts[k]`` indices from its first, drawn as one strip.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..encodings import PRIMITIVES
from ..errors import BuildError
from ..format.layout import draw_index_width
from ..simplify import CollapseSequence
from .base import ProgressiveMesh, lod_at_error, register
from .screen import error_for_pixels
from .strips import decode_strip


@register
class SlidingWindowProgressiveMesh(ProgressiveMesh):
    """Sliding-window VIPM: a static ``index_pool`` and one ``window_records`` row per LOD.

    ``window_records[k] = (first index offset, triangle count, vertex count)``; LOD ``k`` draws
    ``index_pool[first : first + window_index_counts[k]]`` (``3 * count`` indices of a list pool; a strip
    pool, ``params["primitive"] == "strip"``, as one strip with ``restart_index``) and only vertices
    ``[0, vertex count)``. The triangle count is the window's non-degenerate triangles either way.
    """

    encoding = "sliding-window"

    def __init__(
        self,
        points: np.ndarray,
        attributes: Mapping[str, np.ndarray],
        vertex_counts: np.ndarray,
        triangle_counts: np.ndarray,
        lod_errors: np.ndarray,
        index_pool: np.ndarray,
        window_records: np.ndarray,
        params: Mapping[str, Any] | None = None,
        window_index_counts: np.ndarray | None = None,
    ) -> None:
        super().__init__(points, attributes, vertex_counts, triangle_counts, lod_errors, params)
        self.index_pool = np.asarray(index_pool).reshape(-1)
        self.window_records = np.asarray(window_records).reshape(-1, 3)
        if self.window_records.shape[0] != self.lod_count:
            raise BuildError("window_records needs one row per LOD", code="BUILD_FAILED")
        # a pool without the parameter (a file or stage written before strips) is a list pool
        self.primitive: str = str(self.params.get("primitive", "list"))
        if self.primitive not in PRIMITIVES:
            raise BuildError(f"primitive must be one of {PRIMITIVES}, got {self.primitive!r}")
        if self.primitive == "strip":
            ri = self.params.get("restart_index")
            if ri is None or window_index_counts is None:
                raise BuildError("a strip pool needs params['restart_index'] and window_index_counts")
            self.restart_index = int(ri)
            #: every window's number of pool indices (3 x its triangle count for a list pool)
            self.window_index_counts = np.asarray(window_index_counts).reshape(-1)
        else:
            self.window_index_counts = (3 * self.window_records[:, 1].astype(np.int64)).astype(np.uint32)
        if self.window_index_counts.shape != (self.lod_count,):
            raise BuildError("window_index_counts needs one count per LOD", code="BUILD_FAILED")
        #: build-time extras (not stored in buffers): the builder's own collapse sequence, the number of its
        #: steps behind every LOD, the source vertex of every stored vertex and the level of every LOD
        self.collapse_sequence: CollapseSequence | None = None
        self.lod_steps: np.ndarray | None = None
        self.source_vertex: np.ndarray | None = None
        self.lod_level: np.ndarray | None = None

    # -- drawing -------------------------------------------------------------------------------------------
    def window(self, k: int) -> tuple[int, int, int]:
        """The record of LOD ``k``: (first index offset, triangle count, vertex count)."""
        r = self.window_records[self._check_lod(k)]
        return int(r[0]), int(r[1]), int(r[2])

    def window_indices(self, k: int) -> np.ndarray:
        """The pool indices LOD ``k`` draws (a list's ``3 x`` triangle count, or one strip), a view."""
        first = int(self.window_records[self._check_lod(k), 0])
        return self.index_pool[first : first + int(self.window_index_counts[k])]

    def triangles_at(self, k: int) -> np.ndarray:
        if self.primitive == "strip":  # decoded: the non-degenerate triangles in strip order, winding kept
            return decode_strip(self.window_indices(k), self.restart_index).astype(np.int32)
        first, count, _ = self.window(k)
        return self.index_pool[first : first + 3 * count].reshape(-1, 3).astype(np.int32)

    def draw_stream(self, k: int) -> tuple[str, np.ndarray]:
        if self.primitive == "strip":
            return "strip", self.window_indices(k)
        return super().draw_stream(k)

    @property
    def level_count(self) -> int:
        """Number of levels in the pool (LOD 0 and every later level's first LOD start one; the coarsest
        LOD's copy, ``coarsest_copy``, counts as a level)."""
        return int(np.unique(self.lod_level).shape[0]) if self.lod_level is not None else 0

    def _record(self, k: int) -> np.ndarray:
        """LOD ``k``'s window record; a strip pool's with its index count appended (what a draw needs: the
        triangle count alone would draw ``3 x`` it list indices)."""
        if self.primitive == "strip":
            row = np.r_[self.window_records[k], self.window_index_counts[k]]
            return row.astype(self.window_records.dtype)
        return self.window_records[k]

    def record_for_triangles(self, target: int) -> np.ndarray:
        """The window record of the finest LOD drawing at most ``target`` triangles
        (:meth:`~.ProgressiveMesh.lod_for_triangles`: NaN or a negative target is a :class:`ValueError`).
        A strip pool's records (here and below) have a 4th field, the window's index count."""
        return self._record(self.lod_for_triangles(target))

    def record_for_error(self, max_error: float, lod_errors: np.ndarray | None = None) -> np.ndarray:
        """The window record of the coarsest LOD whose error (``lod_errors``, default this mesh's,
        non-decreasing, one per LOD) is at most ``max_error`` (a number >= 0, ``inf`` allowed). A
        ``lod_errors`` not one per LOD is a :class:`ValueError` naming it (a shorter one never reached the
        last LODs, a longer one picked past them, clamped to the last, without a word)."""
        errs = self._checked_lod_errors(lod_errors)
        return self._record(min(lod_at_error(errs, max_error), self.lod_count - 1))

    def _checked_lod_errors(self, lod_errors: np.ndarray | None) -> np.ndarray:
        """``lod_errors`` one per LOD (this mesh's when None), else a :class:`ValueError`; kept in their own
        type (:func:`.lod_at_error` compares a float32 bound with float32 errors, others as float64)."""
        errs = self.lod_errors if lod_errors is None else np.asarray(lod_errors)
        if errs.shape != (self.lod_count,):
            n = self.lod_count
            raise ValueError(f"lod_errors must hold one error per LOD ({n}), got shape {errs.shape}")
        return errs

    def record_for_screen_error(
        self,
        max_pixels: float,
        distance: float,
        fov_y: float,
        viewport_height: int,
        lod_errors: np.ndarray | None = None,
    ) -> np.ndarray:
        """The window record whose object-space error projects to at most ``max_pixels`` on screen for an
        object at ``distance`` seen with vertical field of view ``fov_y`` (radians): the record of
        :meth:`~.ProgressiveMesh.lod_for_screen_error`'s LOD (LOD 0's at ``distance <= 0``; its arguments
        checked the same; ``lod_errors`` too, at any distance)."""
        e = error_for_pixels(max_pixels, distance, fov_y, viewport_height)
        if e is None:  # (the camera at or inside the object: LOD 0, whatever the errors say)
            self._checked_lod_errors(lod_errors)
            return self._record(0)
        return self.record_for_error(e, lod_errors)

    # -- memory --------------------------------------------------------------------------------------------
    @property
    def global_bytes(self) -> int:
        if self.primitive == "strip":
            # (drawn from u16 while vertex ids fit, a u32 file's restart 0xFFFFFFFF copied as 0xFFFF, as a
            # list pool is: draw_index_width)
            isz = draw_index_width(self.vertex_count, self.restart_index)
            # a strip draw's record: 32-bit first index, 16-bit index and vertex counts
            wide = max(int(self.window_index_counts.max(initial=0)), int(self.vertex_counts.max())) > 0xFFFF
        else:
            isz = draw_index_width(self.vertex_count)  # (u32 from 65,536 vertices on, spec 1)
            # Forsyth's record: 32-bit first index, 16-bit counts (32-bit when they do not fit)
            wide = int(self.window_records[:, 1:].max(initial=0)) > 0xFFFF
        rec = 12 if wide else 8
        return int(self.vertex_bytes() + isz * self.index_pool.shape[0] + rec * self.lod_count)

    @property
    def instance_bytes(self) -> int:
        return 4  # the current LOD number: nothing else is per instance

    # -- buffers -------------------------------------------------------------------------------------------
    def buffers(self) -> dict[str, np.ndarray]:
        out = {
            "index_pool": self.index_pool.astype(np.uint32, copy=False),
            "window_records": self.window_records.astype(np.uint32, copy=False),
        }
        if self.primitive == "strip":  # (a list pool's are 3 x its triangle counts: not stored)
            out["window_index_counts"] = self.window_index_counts.astype(np.uint32, copy=False)
        return out

    @classmethod
    def _from_buffers(cls, points, attributes, vertex_counts, triangle_counts, lod_errors, buffers, params):
        return cls(
            points,
            attributes,
            vertex_counts,
            triangle_counts,
            lod_errors,
            index_pool=buffers["index_pool"],
            window_records=buffers["window_records"],
            params=params,
            window_index_counts=buffers.get("window_index_counts"),
        )
