"""Reading a prefix of an SWPM file (spec/format.md 4.1): draw coarse LODs before the whole file arrives.

Writers lay a file out ``META LODS SMAP [tables] INDX VERT`` with ``VERT``'s records in LOD order, so LOD k
needs only the file's first :meth:`FilePrefix.needed_bytes` ``(k)`` bytes (spec 4: (a) + (b) + (c)).
:func:`open_prefix` checks the bytes it is given with the codec's own checks (:func:`.reader._check` in its
prefix mode: the end of the file is the header's file_size; ``VERT``'s CRC, the padding and the length the
prefix lacks, and the non-finite point count, wait for the whole file) and returns a :class:`FilePrefix`
whose arrays are views of those bytes. :meth:`FilePrefix.finish` takes the whole file and gives the
whole-file verdict (this reference codec checks it all again: same verdict by construction; the C reader's
``swpm_prefix_finish`` checks only the deferred parts). Forsyth's VIPM ("Comparison of VIPM Methods", Game
Programming Gems 2) keeps a LOD's vertices a prefix of the vertex buffer; this is that prefix on the wire.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..encode.base import ProgressiveMesh
from . import layout as L
from .errors import Report, SwpmFormatError
from .parsed import _Parsed
from .reader import _build, _check

_Bytes = bytes | bytearray | memoryview | np.ndarray


def _as_buf(data: _Bytes) -> np.ndarray:
    if isinstance(data, np.ndarray):
        return data.view(np.uint8).reshape(-1)
    return np.frombuffer(data, np.uint8)


class _Lods:
    """What :class:`FilePrefix` and :class:`.ranges.FileRanges` share: the LOD count and a drawn LOD's
    attributes (each defines ``vertex_counts`` and ``lod_points``, which raises for a LOD not drawable)."""

    vertex_counts: np.ndarray
    attributes: dict[str, np.ndarray]

    def lod_points(self, lod: int) -> np.ndarray:
        raise NotImplementedError

    @property
    def lod_count(self) -> int:
        return int(self.vertex_counts.shape[0])

    def lod_attributes(self, lod: int) -> dict[str, np.ndarray]:
        """The attributes of LOD ``lod``'s vertices, as :meth:`lod_points`."""
        n = self.lod_points(lod).shape[0]
        return {k: a[:n] for k, a in self.attributes.items()}


@dataclass
class FilePrefix(_Lods):
    """The first :attr:`size` bytes of an SWPM file, checked as far as they go (spec 4.1). Arrays are
    read-only views of the bytes given; the points and attributes hold the first :attr:`held_vertices`
    records. :attr:`complete` when the bytes held the whole file (then every LOD of a valid file draws)."""

    path: str | None
    report: Report
    size: int  # bytes held
    file_size: int  # the header's
    complete: bool
    encoding: str
    vertex_counts: np.ndarray  # LODS column vertex_count, per LOD
    triangle_counts: np.ndarray
    lod_errors: np.ndarray
    points: np.ndarray  # (held_vertices, 3) f32
    attributes: dict[str, np.ndarray]
    buffers: dict[str, np.ndarray]  # the encoding's arrays (spec 7): every one lies before VERT
    params: dict[str, object]
    vertex_count: int  # V
    vertex_data_offset: int  # absolute offset of vertex record 0
    vertex_stride: int
    _buf: np.ndarray = field(repr=False)

    def __repr__(self) -> str:
        lods = self.drawable_lods
        return (
            f"FilePrefix({self.path or '<bytes>'}, {self.encoding}, {self.size} of {self.file_size} bytes, "
            f"drawable LODs {f'{lods.start}..{lods.stop - 1}' if lods else 'none'} of {self.lod_count})"
        )

    @property
    def held_vertices(self) -> int:
        return int(self.points.shape[0])

    def needed_bytes(self, lod: int) -> int:
        """The file prefix LOD ``lod`` needs (spec 4: every byte before its last vertex record's end)."""
        if not 0 <= lod < self.lod_count:
            raise IndexError(f"LOD {lod} of {self.lod_count}")
        return self.vertex_data_offset + int(self.vertex_counts[lod]) * self.vertex_stride

    @property
    def drawable_lods(self) -> range:
        """The LODs the bytes held draw, finest first: [k, L) for the smallest k whose needed bytes they
        hold (vertex counts do not increase with k), empty when not even the coarsest's."""
        need = self.vertex_data_offset + self.vertex_counts.astype(np.int64) * self.vertex_stride
        return range(int(np.count_nonzero(need > self.size)), self.lod_count)

    @property
    def coarsest_drawable(self) -> int | None:
        """L - 1 when the coarsest LOD draws, else None."""
        lods = self.drawable_lods
        return lods[-1] if lods else None

    @property
    def finest_drawable(self) -> int | None:
        """The finest LOD the bytes held draw (the one an engine draws until more arrives), else None."""
        lods = self.drawable_lods
        return lods[0] if lods else None

    def lod_points(self, lod: int) -> np.ndarray:
        """The points LOD ``lod`` draws (its first vertex_count(lod) records); IndexError if not held."""
        if lod not in self.drawable_lods:
            raise IndexError(
                f"{self.path or '<file>'}: LOD {lod} needs {self.needed_bytes(lod)} bytes, {self.size} held"
            )
        return self.points[: int(self.vertex_counts[lod])]

    def extend(self, more: _Bytes) -> FilePrefix:
        """The prefix with ``more`` bytes appended, opened again (a copy of the bytes)."""
        joined = np.concatenate([self._buf, _as_buf(more)])
        return open_prefix(joined, path=self.path)

    def finish(self, data: _Bytes) -> ProgressiveMesh:
        """Complete the file with all of its bytes ``data`` (its first :attr:`size` must be the prefix's,
        else :class:`ValueError`): the whole-file verdict (spec 4.1), the mesh as :func:`.load_bytes`
        returns it, or :class:`SwpmFormatError` with the whole-file report, e.g. a ``VERT`` CRC, trailing
        padding or length the prefix could not check."""
        buf = _as_buf(data)
        if buf.shape[0] < self.size or not np.array_equal(buf[: self.size], self._buf):
            raise ValueError(f"{self.path or '<file>'}: the bytes given do not start with the prefix read")
        return _whole(buf, self.path)


def validate_prefix(data: _Bytes, path: str | None = None) -> Report:
    """Every problem of a file prefix ``data`` (spec 4.1; never raises for its content): the whole-file
    report when ``data`` holds the whole file, else the prefix's, with ``summary["prefix_need"]`` the bytes
    to wait for when it is SWPM_PREFIX_TOO_SHORT."""
    return _check(_as_buf(data), path, prefix=True)[0]


def open_prefix(data: _Bytes, *, path: str | None = None) -> FilePrefix:
    """Open the first bytes of an SWPM file (spec 4.1); raises :class:`SwpmFormatError` with the report when
    they hold an error (SWPM_PREFIX_TOO_SHORT: wait for ``report.summary["prefix_need"]`` bytes;
    SWPM_PREFIX_NOT_STREAMABLE: the file does not stream, read it whole)."""
    rep, fp = _checked_prefix(data, path)
    if fp is None:
        raise SwpmFormatError(rep)
    return fp


def _checked_prefix(data: _Bytes, path: str | None) -> tuple[Report, FilePrefix | None]:
    """The report of prefix ``data`` and, when it opens, the prefix, from one check (``validate --prefix``
    called :func:`validate_prefix` then :func:`open_prefix`: every check ran twice)."""
    buf = _as_buf(data)
    rep, p = _check(buf, path, prefix=True)
    return rep, (_prefix(buf, p, rep, path) if rep.valid and p is not None else None)


def _lod_fields(p: _Parsed, rep: Report, path: str | None) -> dict[str, Any]:
    """The fields :class:`FilePrefix` and :class:`.ranges.FileRanges` both take from a checked file."""
    assert p.lods is not None and p.points is not None and p.meta is not None
    return {
        "path": path,
        "report": rep,
        "file_size": int(p.size),
        "complete": not p.prefix,
        "encoding": p.encoding or "",
        "vertex_counts": p.lods["vertex_count"],
        "triangle_counts": p.lods["triangle_count"],
        "lod_errors": p.lods["error"],
        "points": p.points,
        "attributes": p.attributes,
        "vertex_count": p.vertex_count,
        "vertex_data_offset": p.chunks[L.VERT].offset + p.vert_data,
        "vertex_stride": p.vert_stride,
    }


def _whole(buf: np.ndarray, path: str | None) -> ProgressiveMesh:
    """The whole file ``buf``'s verdict (finishing a prefix or ranges): its mesh, or SwpmFormatError."""
    rep, p = _check(buf, path)
    if not rep.valid or p is None:
        raise SwpmFormatError(rep)
    return _build(p, rep)


def _prefix(buf: np.ndarray, p: _Parsed, rep: Report, path: str | None) -> FilePrefix:
    assert p.meta is not None
    return FilePrefix(
        **_lod_fields(p, rep, path),
        size=int(buf.shape[0]),
        buffers=p.buffers,
        params=p.meta.get("params", {}),
        _buf=buf,
    )
