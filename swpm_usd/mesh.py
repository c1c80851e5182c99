"""The immutable triangle mesh every encoder starts from.

Points are float32 (what a GPU vertex buffer holds), triangles int32, and every named attribute is a
per-vertex array with one row per point. Vertices that share a position but not their attributes (UV or
normal seams) are distinct vertices: nothing here welds them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from .errors import MeshLoadError


def _frozen(a: np.ndarray) -> np.ndarray:
    """A read-only contiguous array that the caller cannot mutate behind the mesh's back."""
    a = np.ascontiguousarray(a)
    if a.flags.writeable:
        a = a.copy()
        a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Mesh:
    """An indexed triangle mesh with named per-vertex attributes.

    ``points``: (V, 3) float32. ``triangles``: (T, 3) int32, counter-clockwise front faces.
    ``attributes``: name -> (V, k) array (e.g. ``normal`` (V,3) f32, ``uv`` (V,2) f32, ``color`` (V,3|4) f32).
    ``stats``: what cleaning did on load (``degenerate_dropped``, ``duplicate_dropped``,
    ``unreferenced_dropped``).
    """

    points: np.ndarray
    triangles: np.ndarray
    attributes: Mapping[str, np.ndarray] = field(default_factory=dict)
    source: str | None = None
    stats: Mapping[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=np.float32).reshape(-1, 3)
        tri = np.asarray(self.triangles)
        if tri.size and not np.issubdtype(tri.dtype, np.integer):
            raise MeshLoadError(self.source, f"triangle indices must be integers, got {tri.dtype}")
        tri = tri.astype(np.int32, copy=False).reshape(-1, 3)
        attrs = {}
        for name, a in dict(self.attributes).items():
            a = np.asarray(a)
            if a.ndim == 1:
                a = a[:, None]
            if a.shape[0] != pts.shape[0]:
                raise MeshLoadError(
                    self.source, f"attribute {name!r} has {a.shape[0]} rows for {pts.shape[0]} points"
                )
            attrs[name] = _frozen(a)
        object.__setattr__(self, "points", _frozen(pts))
        object.__setattr__(self, "triangles", _frozen(tri))
        object.__setattr__(self, "attributes", MappingProxyType(attrs))
        object.__setattr__(self, "stats", MappingProxyType(dict(self.stats)))

    @property
    def vertex_count(self) -> int:
        return int(self.points.shape[0])

    @property
    def triangle_count(self) -> int:
        return int(self.triangles.shape[0])

    def bbox_diagonal(self) -> float:
        if self.points.shape[0] == 0:
            return 0.0
        lo = self.points.min(axis=0).astype(np.float64)
        hi = self.points.max(axis=0).astype(np.float64)
        return float(np.linalg.norm(hi - lo))

    @staticmethod
    def from_arrays(
        points: np.ndarray,
        triangles: np.ndarray,
        attributes: Mapping[str, np.ndarray] | None = None,
        source: str | Path | None = None,
    ) -> Mesh:
        """Validate and clean raw arrays (see :func:`swpm_usd.io.clean_mesh`)."""
        from .io.clean import clean_mesh

        return clean_mesh(points, triangles, attributes or {}, None if source is None else str(source))
