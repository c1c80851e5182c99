"""The one interface every encoding implements: :class:`ProgressiveMesh`.

A progressive mesh has ``lod_count`` levels of detail; LOD 0 is full detail, LOD ``lod_count - 1`` the
coarsest. Vertices are stored in LOD order, so LOD k uses exactly the vertex prefix
``[0, vertex_count_at(k))``. Each encoding keeps its own buffers (``buffers()``, a dict of named numpy
arrays); the format codec and the USD schema store exactly those arrays, one chunk / attribute each, and
rebuild the object with :func:`from_buffers`.
"""

from __future__ import annotations

import math
import numbers
import operator
from abc import ABC, abstractmethod
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np

from ..errors import BuildError
from ..format.layout import stored_index_count  # noqa: F401 (its home: read without the encoders)
from .screen import budget, error_for_pixels

ENCODINGS: dict[str, type[ProgressiveMesh]] = {}


def register(cls: type[ProgressiveMesh]) -> type[ProgressiveMesh]:
    """Class decorator: make an encoding reachable by name from :func:`from_buffers`."""
    ENCODINGS[cls.encoding] = cls
    return cls


class ProgressiveMesh(ABC):
    """Common state and behaviour of all encodings.

    Subclasses set ``encoding`` and implement :meth:`triangles_at`, :meth:`buffers`, the memory figures and
    ``_from_buffers``. ``points`` is (V, 3) float32 in LOD order; ``attributes`` maps names to (V, k) arrays
    in the same order; ``vertex_counts``, ``triangle_counts`` and ``lod_errors`` have one entry per LOD.
    ``lod_errors`` is non-decreasing, in mesh units (a distance), for screen-space LOD selection.
    """

    encoding: ClassVar[str] = ""
    #: index value that restarts a strip in :meth:`draw_stream`, or None when strips are joined otherwise
    restart_index: int | None = None

    def __init__(
        self,
        points: np.ndarray,
        attributes: Mapping[str, np.ndarray],
        vertex_counts: np.ndarray,
        triangle_counts: np.ndarray,
        lod_errors: np.ndarray,
        params: Mapping[str, Any] | None = None,
    ) -> None:
        self.points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        self.attributes: Mapping[str, np.ndarray] = MappingProxyType(dict(attributes))
        self.vertex_counts = np.asarray(vertex_counts, dtype=np.int64)
        self.triangle_counts = np.asarray(triangle_counts, dtype=np.int64)
        # float32 as stored; an error beyond its range (points near its largest value: errors are distances,
        # up to the bounding box's diagonal) is stored as its largest value, not as inf, which no reader takes
        self.lod_errors = np.minimum(np.asarray(lod_errors, np.float64), np.finfo(np.float32).max).astype(
            np.float32
        )
        self.params: dict[str, Any] = dict(params or {})
        n = self.vertex_counts.shape[0]
        if n == 0 or self.triangle_counts.shape[0] != n or self.lod_errors.shape[0] != n:
            raise BuildError(
                "vertex_counts, triangle_counts and lod_errors need one entry per LOD (>= 1)",
                code="BUILD_FAILED",
            )
        vc = self.vertex_counts
        if vc[0] != self.points.shape[0] or (np.diff(vc) > 0).any() or vc.min() < 0:
            # LOD k draws the prefix [0, vertex_counts[k]): the format writer sizes its chunks from these
            raise BuildError(
                f"vertex_counts must start at the {self.points.shape[0]} points and not grow",
                code="BUILD_FAILED",
            )

    # -- LOD table -------------------------------------------------------------------------------------
    @property
    def lod_count(self) -> int:
        return int(self.vertex_counts.shape[0])

    @property
    def vertex_count(self) -> int:
        return int(self.points.shape[0])

    def _check_lod(self, k: int) -> int:
        k = operator.index(k)  # an int or numpy integer; 1.5 is a TypeError, not LOD 1
        if not 0 <= k < self.lod_count:
            raise IndexError(f"LOD {k} out of range [0, {self.lod_count})")
        return k

    def vertex_count_at(self, k: int) -> int:
        """Number of vertices LOD k uses: it draws only vertices ``[0, vertex_count_at(k))``."""
        return int(self.vertex_counts[self._check_lod(k)])

    def triangle_count_at(self, k: int) -> int:
        """Number of visible (non-degenerate) triangles at LOD k."""
        return int(self.triangle_counts[self._check_lod(k)])

    def error_at(self, k: int) -> float:
        """Geometric error estimate of LOD k in mesh units (0 at LOD 0, non-decreasing)."""
        return float(self.lod_errors[self._check_lod(k)])

    def lod_for_triangles(self, target: int) -> int:
        """The finest LOD that draws at most ``target`` triangles (the coarsest LOD if none does; LOD 0 for
        ``inf``). ``target`` is a number >= 0 (a fraction is rounded down: at most 99.5 triangles is at most
        99); NaN or a negative one is a :class:`ValueError`."""
        t = budget("target", target)
        tc = self.triangle_counts
        t0 = int(tc[0])
        # (an integer exactly, a float rounded down; past LOD 0's count (inf, a huge integer): LOD 0's count)
        if isinstance(target, numbers.Integral):
            t_int = min(operator.index(target), t0)
        else:
            t_int = math.floor(min(t, t0))
        # triangle counts are non-increasing with k: first k with tc[k] <= target
        k = int(np.searchsorted(-tc, -t_int, side="left"))
        return min(k, self.lod_count - 1)

    def lod_for_error(self, max_error: float) -> int:
        """The coarsest LOD whose error does not exceed ``max_error`` (LOD 0 if none is that good; the
        coarsest for ``inf``). ``max_error`` is a number >= 0; NaN or a negative one is a
        :class:`ValueError`."""
        return lod_at_error(self.lod_errors, max_error)

    def lod_for_screen_error(
        self, max_pixels: float, distance: float, fov_y: float, viewport_height: int
    ) -> int:
        """The coarsest LOD whose error projects to at most ``max_pixels`` on screen for an object at
        ``distance`` (mesh units) seen with vertical field of view ``fov_y`` (radians) on a viewport
        ``viewport_height`` pixels high: what an engine asks each frame (the sliding window's
        ``record_for_screen_error`` gives the same LOD's window record).

        ``distance <= 0`` (the camera at or inside the object) picks LOD 0. A non-finite argument,
        ``max_pixels < 0``, ``fov_y`` outside (0, pi) or ``viewport_height <= 0`` is a :class:`ValueError`
        naming it (:mod:`swpm_usd.encode.screen`: the one projection)."""
        e = error_for_pixels(max_pixels, distance, fov_y, viewport_height)
        return 0 if e is None else lod_at_error(self.lod_errors, e)

    # -- drawing ---------------------------------------------------------------------------------------
    @abstractmethod
    def triangles_at(self, k: int) -> np.ndarray:
        """Visible triangles at LOD k in draw order, (n, 3) int32, indices into ``points``."""

    def draw_stream(self, k: int) -> tuple[str, np.ndarray]:
        """What the GPU receives at LOD k: ``("triangles", flat indices)`` or ``("strip", indices)``.

        Degenerate triangles are included; strips may use ``restart_index``.
        """
        return "triangles", np.ascontiguousarray(self.triangles_at(k)).reshape(-1)

    # -- memory ----------------------------------------------------------------------------------------
    @property
    @abstractmethod
    def global_bytes(self) -> int:
        """Bytes shared by every instance (vertex data, static index data, records)."""

    @property
    @abstractmethod
    def instance_bytes(self) -> int:
        """Bytes each drawn instance needs of its own (e.g. a private index buffer)."""

    def vertex_bytes(self) -> int:
        """Bytes of the vertex buffer: points and every attribute, as stored."""
        return int(self.points.nbytes + sum(a.nbytes for a in self.attributes.values()))

    # -- buffers (format codec / USD contract) ----------------------------------------------------------
    @abstractmethod
    def buffers(self) -> dict[str, np.ndarray]:
        """The encoding-specific arrays that, with points, attributes and the LOD table, define it."""

    @classmethod
    @abstractmethod
    def _from_buffers(
        cls,
        points: np.ndarray,
        attributes: Mapping[str, np.ndarray],
        vertex_counts: np.ndarray,
        triangle_counts: np.ndarray,
        lod_errors: np.ndarray,
        buffers: Mapping[str, np.ndarray],
        params: Mapping[str, Any],
    ) -> ProgressiveMesh: ...

    def __repr__(self) -> str:
        return (
            f"<{type(self).__name__} encoding={self.encoding!r} V={self.vertex_count} "
            f"T0={int(self.triangle_counts[0])} lods={self.lod_count}>"
        )


_F32_MAX = float(np.finfo(np.float32).max)


def _float32_at_most(x: float) -> np.float32:
    """The largest float32 <= ``x`` (a float64 >= 0 or ``inf``): the bound a float32 error is compared
    with. ``np.float32(x)`` rounds to nearest, up as often as down: an error 1 ulp above ``x`` passed."""
    if x > _F32_MAX:
        # (a finite bound above float32's range admits every error, as its largest value: np.float32 of it
        # warned of an overflow)
        return np.float32(math.inf if math.isinf(x) else _F32_MAX)
    bound = np.float32(x)
    return bound if float(bound) <= x else np.nextafter(bound, np.float32(-math.inf))


def lod_at_error(lod_errors: np.ndarray, max_error: float) -> int:
    """The last LOD whose error in ``lod_errors`` (non-decreasing) is at most ``max_error``, or 0.
    ``max_error`` as :func:`.screen.budget` checks it (a number >= 0, ``inf`` allowed)."""
    max_error = budget("max_error", max_error)
    errors = np.asarray(lod_errors)
    if errors.dtype == np.float32:
        bound = _float32_at_most(max_error)
    else:  # (a caller's errors of another type: compared as float64, each exactly)
        errors, bound = errors.astype(np.float64, copy=False), np.float64(max_error)
    k = int(np.searchsorted(errors, bound, side="right")) - 1
    return max(0, min(k, errors.shape[0] - 1))


def from_buffers(
    encoding: str,
    points: np.ndarray,
    attributes: Mapping[str, np.ndarray],
    vertex_counts: np.ndarray,
    triangle_counts: np.ndarray,
    lod_errors: np.ndarray,
    buffers: Mapping[str, np.ndarray],
    params: Mapping[str, Any] | None = None,
) -> ProgressiveMesh:
    """Rebuild a :class:`ProgressiveMesh` of ``encoding`` from stored arrays (no copy where possible)."""
    try:
        cls = ENCODINGS[encoding]
    except KeyError:
        raise BuildError(f"unknown encoding {encoding!r}; known: {sorted(ENCODINGS)}") from None
    return cls._from_buffers(
        points, attributes, vertex_counts, triangle_counts, lod_errors, buffers, dict(params or {})
    )


def with_attributes(pm: ProgressiveMesh, attributes: Mapping[str, np.ndarray]) -> ProgressiveMesh:
    """``pm`` with other per-vertex ``attributes`` (in its vertex order), its buffers shared."""
    return from_buffers(
        pm.encoding,
        pm.points,
        attributes,
        pm.vertex_counts,
        pm.triangle_counts,
        pm.lod_errors,
        pm.buffers(),
        pm.params,
    )
