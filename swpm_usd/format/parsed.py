"""The parsed state of one SWPM file and the checked views into it, shared by every check of the reader.

:class:`_Parsed` is what the structure pass (:mod:`.reader`) finds and each chunk check fills in; the helpers
view arrays of the mapping only after checking their counts against the bytes that remain (spec 5: a hostile
count never makes the reader allocate or read past a chunk), and report index values out of range (spec 3.4,
``SWPM_INDEX_OUT_OF_RANGE``). Separate from the reader so that the per-chunk and per-encoding check modules
share them without importing the reader (which imports them).
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import layout as L
from .errors import Report


@dataclass
class _Chunk:
    type: bytes
    flags: int
    offset: int
    length: int
    entry_offset: int
    ok: bool = True  # in bounds and CRC matches: content may be decoded

    @property
    def name(self) -> str:
        return self.type.decode("latin-1")


class _Spans:
    """Byte ranges held (spec 4.2), sorted and merged: [starts[i], ends[i]) each. Every query costs the
    logarithm or the number of spans, never the bytes between them: a range held far past the others (at
    2^40 of a file whose header claims 2^41) adds one span, not a mask up to it."""

    def __init__(self, spans: list[tuple[int, int]]) -> None:  # (offset, length), sorted and merged
        self.starts = [o for o, _ in spans]
        self.ends = [o + n for o, n in spans]

    def run_end(self, a: int) -> int:
        """The end of the run of held bytes from ``a`` (``a`` when it is not held)."""
        i = bisect.bisect_right(self.starts, a) - 1
        return self.ends[i] if i >= 0 and a < self.ends[i] else a

    def holds(self, a: int, b: int) -> bool:
        return self.run_end(a) >= b > a or b <= a

    def parts(self, a: int, b: int) -> list[tuple[int, int]]:
        """The held parts of [a, b)."""
        out = []
        for i in range(bisect.bisect_right(self.ends, a), len(self.starts)):
            if self.starts[i] >= b:
                break
            out.append((max(self.starts[i], a), min(self.ends[i], b)))
        return out


@dataclass
class _Parsed:
    buf: np.ndarray
    encoding: str | None = None
    width: int = 4  # W, the byte size of idx (spec 1)
    offset_width: int = 4  # O, the byte size of off, the table type
    minor: int = 0
    features: int = 0
    chunks: dict[bytes, _Chunk] = field(default_factory=dict)
    order: list[_Chunk] = field(default_factory=list)
    meta: dict[str, Any] | None = None
    lods: np.ndarray | None = None
    points: np.ndarray | None = None
    attributes: dict[str, np.ndarray] = field(default_factory=dict)
    vert_stride: int = 0
    vert_data: int = 0
    buffers: dict[str, np.ndarray] = field(default_factory=dict)
    content_ok: bool = True
    size: int = 0  # the end of the file as read: its first file_size bytes, fewer if it is shorter
    vertex_count: int = 0  # V, from VERT's header (a prefix holds the first records only: spec 4.1)
    prefix: bool = False  # read as a prefix of the file (spec 4.1): buf ends before ``size``
    # byte ranges (spec 4.2): which bytes of ``buf`` (up to the last byte held, the rest zero) are held;
    # None: all
    held: _Spans | None = None
    indx_partial: bool = False  # ranges without all of INDX: checks of its content wait for the whole file

    def holds(self, start: int, end: int) -> bool:
        """Whether bytes [start, end) are held: inside ``buf`` and, reading ranges, every one held (an empty
        range is, wherever it lies: spec 4.2's held(a, b), so an empty payload's CRC is checked at once)."""
        if self.held is not None and end <= start:
            return True
        if end > self.buf.shape[0]:
            return False
        return self.held is None or self.held.holds(start, end)

    def held_end(self, start: int) -> int:
        """The end of the run of held bytes from ``start`` (a prefix: its length)."""
        if self.held is None:
            return max(int(self.buf.shape[0]), start)
        return self.held.run_end(start)

    def first_missing(self, start: int, end: int) -> int:
        """The first byte of [start, end) not held (``end`` when every one is)."""
        return min(self.held_end(start), end)  # (the spans are merged: a run ends at a byte not held)

    def nonzero(self, start: int, end: int) -> bool:
        """Whether a byte of [start, end) at hand is non-zero (padding, spec 1): reading ranges only the held
        ones are read, so a gap far longer than what is held costs what is held."""
        if self.held is None:
            return bool(np.any(self.buf[start:end]))
        return any(bool(np.any(self.buf[a:b])) for a, b in self.held.parts(start, end))


def _frozen(a: np.ndarray) -> np.ndarray:
    """``a`` as a contiguous read-only array, for the replay kernels: numba compiles a kernel again for a
    strided ('A') record field, and again for a writable copy of one (cold suite: vanilla_replay 4
    signatures, mixed_replay and skip_replay 3 each, where one per index type does). ``a`` is untouched."""
    view = np.ascontiguousarray(a).view()
    view.setflags(write=False)
    return view


def _view(buf: np.ndarray, start: int, count: int, dtype: np.dtype | str) -> np.ndarray:
    dt = np.dtype(dtype)
    return buf[start : start + count * dt.itemsize].view(dt)


def _get(p: _Parsed, t: bytes) -> _Chunk | None:
    c = p.chunks.get(t)
    if c is None or not c.ok:
        p.content_ok = False
        return None
    return c


def _arrays(
    p: _Parsed,
    rep: Report,
    c: _Chunk,
    start: int,
    spec: list[tuple[str, int, np.dtype]],
    exact: bool = True,
    at: dict[str, int] | None = None,
) -> dict[str, np.ndarray] | None:
    """View consecutive arrays (name, count, dtype) each padded to 4 bytes, from payload offset ``start``;
    every count is checked against the bytes that remain first. ``at`` receives each array's absolute
    offset (for problem offsets)."""
    out, pos = {}, start
    for name, count, dt in spec:
        need = count * dt.itemsize
        remain = c.length - pos
        if need > remain:
            rep.add(
                "SWPM_COUNT_EXCEEDS_CHUNK",
                c.offset + pos,
                what=name,
                count=count,
                need=need,
                remain=max(remain, 0),
                type=c.name,
            )
            return None
        out[name] = _view(p.buf, c.offset + pos, count, dt)
        if at is not None:
            at[name] = c.offset + pos
        pos += need if name == spec[-1][0] else L.align(need, L.ARRAY_ALIGN)
    if exact and pos != c.length:
        rep.add("SWPM_CHUNK_BAD_LENGTH", c.entry_offset + 16, type=c.name, length=c.length, need=pos)
        return None
    return out


def _index_check(
    p: _Parsed,
    rep: Report,
    c: _Chunk,
    arr: np.ndarray,
    what: str,
    limit: int,
    base: int,
    exempt: int | None = None,
) -> bool:
    """Report (at most 3) values of ``arr`` (a view of the file) >= ``limit``; element 0 lies at ``base``,
    element i ``arr.strides[0]`` bytes per step further (a record-table column steps a whole row)."""
    if arr.size == 0:
        return True
    if int(arr.max()) < limit:  # one vectorised pass in the common case
        return True
    bad = arr >= limit
    if exempt is not None:
        bad &= arr != exempt
    first = np.flatnonzero(bad)
    n = first.shape[0]
    for i in first[:3]:
        rep.add(
            "SWPM_INDEX_OUT_OF_RANGE",
            base + int(i) * arr.strides[0],
            what=what,
            value=int(arr[i]),
            index=int(i),
            limit=limit,
        )
    return n == 0
