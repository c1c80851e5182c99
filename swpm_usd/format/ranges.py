"""Reading byte ranges of an SWPM file (spec/format.md 4.2): a band's LODs from the ranges ``SMAP`` names.

A prefix (4.1) holds every table and all of ``INDX`` before the first vertex, so the coarsest LOD needs most
of a file. ``SMAP`` (spec 4) names, per band of LODs, the byte ranges they need: (a) every byte before
``INDX``, (b) the hull of the ``INDX`` elements they draw, (c) a ``VERT`` prefix. :func:`ranges_for_lod`
plans those ranges from the file's first bytes; :func:`open_ranges` takes the bytes held, ``{offset:
bytes}``, and checks them with the codec's own checks (:func:`.reader._check` with ``held``: CRCs over bytes
not all held, padding not held and the length wait for the whole file; without all of ``INDX`` the
encoding's checks of its content wait too) and then each drawable LOD's ``INDX`` elements against its
vertex count here. :meth:`FileRanges.finish` takes the whole file and gives the whole-file verdict.
HTTP range requests or a pak file read in pieces fetch this way: Forsyth's VIPM ("Comparison of VIPM
Methods", Game Programming Gems 2) keeps coarse LODs' windows and vertices compact, which is what makes the
coarse bands small.
"""

from __future__ import annotations

import mmap
import sys
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from ..encode.base import ProgressiveMesh, from_buffers
from . import layout as L
from .errors import Report, SwpmFormatError
from .parsed import _Parsed, _Spans
from .prefix import _as_buf, _Bytes, _lod_fields, _Lods, _whole
from .reader import _check, _Report
from .writer import needed_index_ranges

Held = Mapping[int, _Bytes]  # byte ranges of the file: {absolute offset: its bytes}
_Pieces = Iterable[tuple[int, _Bytes]]  # (offset, bytes) pairs, offsets repeating (FileRanges.extend)


def ranges_for_lod(head: _Bytes, lod: int) -> list[tuple[int, int]]:
    """The ``(offset, length)`` byte ranges ``SMAP`` names for the band holding LOD ``lod``, read from
    ``head``, the file's first bytes (through the header, the chunk table and ``SMAP``). Raises
    :class:`ValueError` when ``head`` is too short, or the file has no ``SMAP`` or it does not name the LOD
    (then fetch [0, INDX) and use :meth:`FileRanges.needed_ranges`). ``SMAP`` is ancillary: what these
    ranges draw is decided by :func:`open_ranges`, which may ask for more."""
    buf = _as_buf(head)
    if buf.shape[0] < L.HEADER_SIZE or bytes(buf[:8]) != L.MAGIC:
        raise ValueError("the first bytes do not hold an SWPM header")
    h = buf[: L.HEADER_SIZE].view(L.HEADER)[0]
    to, count = int(h["table_offset"]), int(h["chunk_count"])
    end = to + count * L.CHUNK_ENTRY.itemsize
    if count > L.MAX_CHUNKS or end > buf.shape[0]:
        raise ValueError(f"the chunk table needs the first {end} bytes, {buf.shape[0]} given")
    table = buf[to:end].view(L.CHUNK_ENTRY)
    smap = [e for e in table if bytes(e["type"]) == L.SMAP]
    if not smap:
        raise ValueError("the file has no SMAP")
    off, ln = int(smap[0]["offset"]), int(smap[0]["length"])
    if off + ln > buf.shape[0] or ln < 8:
        raise ValueError(f"SMAP needs the first {off + max(ln, 8)} bytes, {buf.shape[0]} given")
    sh = buf[off : off + 8].view(L.SMAP_HEADER)[0]
    B, N = int(sh["band_count"]), int(sh["range_count"])
    if 8 + 24 * B + 16 * N != ln:
        raise ValueError("SMAP's length does not match its counts")
    bands = buf[off + 8 : off + 8 + 24 * B].view(L.SMAP_BAND)
    rng = buf[off + 8 + 24 * B : off + ln].view(L.SMAP_RANGE)
    for b in bands:
        first, n = int(b["first_lod"]), int(b["lod_count"])
        if first <= lod < first + n:
            rs, rn = int(b["range_start"]), int(b["range_count"])
            if rs + rn > N:
                raise ValueError("SMAP names ranges outside its range table")
            fsz = int(h["file_size"])  # (a wrong map may name bytes past the file: not fetched)
            out = [(int(r["offset"]), int(r["length"])) for r in rng[rs : rs + rn]]
            return [(o, min(n, fsz - o)) for o, n in out if o < fsz and n]
    raise ValueError(f"SMAP names no band for LOD {lod}")


@dataclass
class FileRanges(_Lods):
    """An SWPM file of which the byte ranges :attr:`held` are held, checked as far as they go (spec 4.2).
    :attr:`drawable_lods` are the LODs whose ``INDX`` elements and vertex records are held; their points,
    attributes and draw streams equal the whole file's. :attr:`complete` when every byte is held."""

    path: str | None
    report: Report
    held: list[tuple[int, int]]  # (offset, length), sorted, merged
    file_size: int
    complete: bool
    encoding: str
    vertex_counts: np.ndarray
    triangle_counts: np.ndarray
    lod_errors: np.ndarray
    points: np.ndarray  # (held records, 3) f32: VERT's records held from record 0 on
    attributes: dict[str, np.ndarray]
    vertex_count: int
    vertex_data_offset: int
    vertex_stride: int
    index_offset: int  # INDX's offset
    index_width: int
    index_need: np.ndarray  # (L, 2) INDX element range each LOD draws (spec 4 (b))
    _p: _Parsed = field(repr=False)
    _pm: ProgressiveMesh | None = field(default=None, repr=False)
    _ok: np.ndarray | None = field(default=None, repr=False)

    def __repr__(self) -> str:
        n = sum(ln for _, ln in self.held)
        return (
            f"FileRanges({self.path or '<bytes>'}, {self.encoding}, {n} of {self.file_size} bytes held, "
            f"drawable LODs {self.drawable_lods.tolist()} of {self.lod_count})"
        )

    @property
    def held_bytes(self) -> int:
        return sum(ln for _, ln in self.held)

    def needed_ranges(self, lod: int) -> list[tuple[int, int]]:
        """The ``(offset, length)`` ranges LOD ``lod`` needs (spec 4: (a), (b) unless empty, (c))."""
        if not 0 <= lod < self.lod_count:
            raise IndexError(f"LOD {lod} of {self.lod_count}")
        lo, hi = (int(x) for x in self.index_need[lod])
        vend = self.vertex_data_offset + int(self.vertex_counts[lod]) * self.vertex_stride
        vert = self._p.chunks[L.VERT].offset
        out = [(0, self.index_offset)]
        if hi > lo:
            out.append((self.index_offset + lo * self.index_width, (hi - lo) * self.index_width))
        return out + [(vert, vend - vert)]

    def _drawable(self) -> np.ndarray:
        if self._ok is None:  # (vectorised over LODs: each [a, b) against the held spans, sorted and merged)
            p = self._p
            starts = np.array([o for o, _ in self.held], np.int64)
            ends = starts + np.array([n for _, n in self.held], np.int64)
            lo, hi = (
                self.index_offset + self.index_need[:, i].astype(np.int64) * self.index_width for i in (0, 1)
            )
            vert = p.chunks[L.VERT].offset
            vend = self.vertex_data_offset + self.vertex_counts.astype(np.int64) * self.vertex_stride

            def held(a: np.ndarray | int, b: np.ndarray) -> np.ndarray:  # every byte of [a, b) held
                i = np.searchsorted(starts, a, side="right") - 1  # the span starting at or before a
                return (i >= 0) & (ends[np.maximum(i, 0)] >= b)

            ok = held(0, np.full(self.lod_count, self.index_offset)) & held(vert, vend)
            self._ok = ok & ((hi <= lo) | held(lo, hi))
        return self._ok

    @property
    def drawable_lods(self) -> np.ndarray:
        """The LODs the ranges held draw, finest first (not always consecutive: a band's ranges draw the
        band's LODs, not always the coarser ones)."""
        return np.flatnonzero(self._drawable())

    def _need_drawable(self, lod: int) -> None:
        if not 0 <= lod < self.lod_count or not self._drawable()[lod]:
            raise IndexError(f"{self.path or '<file>'}: LOD {lod} is not drawable from the ranges held")

    def lod_points(self, lod: int) -> np.ndarray:
        """The points LOD ``lod`` draws; IndexError when its ranges are not held."""
        self._need_drawable(lod)
        return self.points[: int(self.vertex_counts[lod])]

    def lod_index_elements(self, lod: int) -> np.ndarray:
        """The ``INDX`` elements LOD ``lod`` draws (its window, level list or static list; a view)."""
        self._need_drawable(lod)
        lo, hi = (int(x) for x in self.index_need[lod])
        it = L.index_dtype(self.index_width)
        return self._p.buf[
            self.index_offset + lo * self.index_width : self.index_offset + hi * self.index_width
        ].view(it)

    def draw_stream(self, lod: int) -> tuple[str, np.ndarray]:
        """What the GPU gets at LOD ``lod`` (:meth:`ProgressiveMesh.draw_stream`), from held bytes only."""
        self._need_drawable(lod)
        if self._pm is None:
            p = self._p
            assert p.lods is not None and p.meta is not None
            self._pm = from_buffers(
                self.encoding,
                # (the draw streams read no point: V of them, none allocated, for the mesh's own checks)
                np.broadcast_to(np.zeros(3, np.float32), (p.vertex_count, 3)),
                {},
                p.lods["vertex_count"],
                p.lods["triangle_count"],
                p.lods["error"],
                p.buffers,
                p.meta.get("params", {}),
            )
        return self._pm.draw_stream(lod)

    def extend(self, more: Held) -> FileRanges:
        """These ranges and ``more``, opened again (:class:`ValueError` if ``more`` gives a byte held a
        different value; a range of ``more`` at an offset held adds to it, never replaces it)."""
        pieces = [(o, self._p.buf[o : o + n]) for o, n in self.held]
        return _open(pieces + list(more.items()), self.path)

    def finish(self, data: _Bytes) -> ProgressiveMesh:
        """Complete the file with all of its bytes ``data`` (each held range must be its bytes there, else
        :class:`ValueError`): the whole-file verdict (spec 4.2), the mesh as :func:`.load_bytes` returns it,
        or :class:`SwpmFormatError` with the whole-file report."""
        buf = _as_buf(data)
        for o, n in self.held:
            if o + n > buf.shape[0] or not np.array_equal(buf[o : o + n], self._p.buf[o : o + n]):
                raise ValueError(
                    f"{self.path or '<file>'}: the bytes given differ from the range [{o}, {o + n})"
                )
        return _whole(buf, self.path)


def _pieces(held: Held | _Pieces) -> list[tuple[int, np.ndarray]]:
    pairs = held.items() if isinstance(held, Mapping) else held
    return sorted(((int(o), _as_buf(b)) for o, b in pairs if len(b)), key=lambda t: t[0])


def _fill(buf: np.ndarray, have: np.ndarray, o: int, b: np.ndarray, path: str | None) -> None:
    """Put ``b`` at ``o``; two ranges that give one byte different values are the caller's error."""
    n = min(b.shape[0], buf.shape[0] - o)
    m = have[o : o + n]
    if m.any():
        differ = m & (buf[o : o + n] != b[:n])
        if differ.any():
            at = o + int(np.flatnonzero(differ)[0])
            raise ValueError(f"{path or '<file>'}: the ranges held give byte {at} two different values")
    buf[o : o + n], have[o : o + n] = b[:n], True


#: how far into a file a range reader holds bytes: its buffer is virtual memory of that many bytes at most
#: (x86-64 gives a process 2^47), of which only the held bytes' pages are committed
MAX_RANGE_END = 1 << 46


#: reserve no swap for the mapping (Linux's value: Python's mmap module names it from 3.13 on); without it a
#: mapping larger than memory is refused under the default heuristic overcommit
_MAP_NORESERVE = getattr(mmap, "MAP_NORESERVE", 0x4000 if sys.platform.startswith("linux") else 0)


def _zeros(n: int, path: str | None) -> np.ndarray:
    """``n`` zero bytes, writable, as virtual memory: a page is committed only where it is written (the held
    ranges), so a range held far past the others (at 2^40 of a file whose header claims 2^41) costs its own
    pages, not the gap's (spec 5: no giant allocation on a corrupt file)."""
    if n > MAX_RANGE_END:
        raise ValueError(f"{path or '<file>'}: a range ends at {n}, past the {MAX_RANGE_END} held at most")
    if n == 0:
        return np.zeros(0, np.uint8)
    try:
        if hasattr(mmap, "MAP_ANONYMOUS"):
            flags = mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS | _MAP_NORESERVE
            return np.frombuffer(mmap.mmap(-1, n, flags=flags), np.uint8)
        # Windows: an anonymous mapping without flags, backed by the paging file, which Windows may charge
        # in full against its commit limit: a range far past the others may be refused there (ValueError)
        return np.frombuffer(mmap.mmap(-1, n), np.uint8)
    except OSError as exc:  # (an address space or overcommit limit: the caller's ranges cannot be held)
        raise ValueError(f"{path or '<file>'}: cannot hold ranges up to byte {n}: {exc.strerror}") from None


def _merge(
    items: list[tuple[int, np.ndarray]], file_size: int | None, path: str | None = None
) -> list[tuple[int, int]]:
    spans: list[tuple[int, int]] = []
    for o, b in items:
        if o < 0 or (file_size is not None and o + b.shape[0] > file_size):
            raise ValueError(
                f"{path or '<file>'}: range [{o}, {o + b.shape[0]}) lies outside the file ({file_size} bytes)"
            )
        if spans and o <= spans[-1][0] + spans[-1][1]:
            s, n = spans[-1]
            spans[-1] = (s, max(n, o + b.shape[0] - s))
        else:
            spans.append((o, b.shape[0]))
    return spans


def _check_ranges(
    held: Held | _Pieces, path: str | None
) -> tuple[Report, _Parsed | None, list[tuple[int, int]]]:
    """The report of ranges ``held`` (spec 4.2) and the parsed state, with the held spans."""
    items = _pieces(held)
    head = np.zeros(L.HEADER_SIZE, np.uint8)  # the header from whichever ranges hold its bytes
    have = np.zeros(L.HEADER_SIZE, bool)
    for o, b in items:
        if 0 <= o < L.HEADER_SIZE:
            _fill(head, have, o, b, path)
    if not have.all():
        rep = _Report(path=path)
        if have[:8].all() and bytes(head[:8]) != L.MAGIC:
            rep.add("SWPM_HEADER_BAD_MAGIC", 0, found=bytes(head[:8]).hex(), expected=L.MAGIC.hex())
        else:
            rep.add("SWPM_RANGES_NOT_HELD", int(np.argmin(have)), start=0, end=L.HEADER_SIZE)
            rep.summary["range_need"] = [0, L.HEADER_SIZE]
        return rep, None, []
    file_size = int(head.view(L.HEADER)[0]["file_size"])
    # a file_size below the header puts the header past it: no range is then the caller's error, and the file
    # is read as format.md 5 reads it, its length the last byte held (spec 4.2 step 1): its table ends past
    # file_size, which stops the checks before any byte past the header is read
    below = file_size < L.HEADER_SIZE
    spans = _merge(items, None if below else file_size, path)
    # up to the last byte held, not file_size (a hostile header's): bytes not held read as zero, so padding
    # there reads clean; the checks take file_size as the end of the file (as a prefix's, spec 4.1). Only
    # the held bytes' pages are ever touched: the checks read held bytes only (_Spans)
    top = max((o + n for o, n in spans), default=0)
    buf = _zeros(top, path)
    end = 0  # (items sorted by offset: of [o, o + n) an earlier range gave exactly [o, end))
    for o, b in items:
        k = min(b.shape[0], max(end - o, 0))
        if k and not np.array_equal(buf[o : o + k], b[:k]):  # one byte two values: the caller's error
            at = o + int(np.flatnonzero(buf[o : o + k] != b[:k])[0])
            raise ValueError(f"{path or '<file>'}: the ranges held give byte {at} two different values")
        buf[o + k : o + b.shape[0]] = b[k:]
        end = max(end, o + b.shape[0])
    buf.setflags(write=False)
    if below or (top == file_size and spans == [(0, top)]):
        rep, p = _check(buf, path)
        return rep, p, spans
    rep, p = _check(buf, path, held=_Spans(spans))
    if p is not None and rep.valid and p.indx_partial:
        _check_drawn(p, rep)
    return rep, p, spans


def _check_drawn(p: _Parsed, rep: Report) -> None:
    """Each LOD's ``INDX`` elements that are held against the vertices it may name (spec 4, stage (b)): a
    window its own vertex count, a level's list (skip-strip, mixed) its level's first LOD's; a strips'
    restart index exempt. The rest of INDX's content waits for the whole file."""
    assert p.lods is not None
    indx = p.chunks[L.INDX]
    Lc = p.lods.shape[0]
    need = needed_index_ranges(p.encoding or "", p.buffers, Lc, indx.length // p.width)
    vc = p.lods["vertex_count"].astype(np.int64)
    params = (p.meta or {}).get("params", {})
    exempt = None
    if p.encoding == "sliding-window" and p.features & L.FEATURE_SW_STRIPS:
        exempt = int(params["restart_index"])
    elif p.encoding == "skip-strip" and params.get("primitive", "strip") == "strip":
        r = params.get("restart_index")
        exempt = int(r) if isinstance(r, int) else None
    limit = vc.copy()
    if p.encoding in ("skip-strip", "mixed"):  # a level's list names its first LOD's vertices
        first = np.asarray(p.buffers["level_first_lod"], np.int64)
        limit = vc[first[np.searchsorted(first, np.arange(Lc), side="right") - 1]]
    pool = p.buf[indx.offset : indx.offset + indx.length // p.width * p.width].view(L.index_dtype(p.width))
    for k in range(Lc):
        lo, hi = (int(x) for x in need[k])
        if hi <= lo or not p.holds(indx.offset + lo * p.width, indx.offset + hi * p.width):
            continue
        seg = pool[lo:hi].astype(np.int64)
        bad = (seg >= limit[k]) if exempt is None else (seg >= limit[k]) & (seg != exempt)
        if bad.any():
            j = int(np.flatnonzero(bad)[0])
            rep.add(
                "SWPM_PREFIX_VIOLATION",
                indx.offset + (lo + j) * p.width,
                lod=k,
                vertex=int(seg[j]),
                limit=int(limit[k]),
            )
            p.content_ok = False
            return


def validate_ranges(held: Held, path: str | None = None) -> Report:
    """Every problem of the byte ranges ``held`` of a file (spec 4.2; never raises for their content): the
    whole-file report when they hold every byte, else the ranges', with ``summary["range_need"]`` the
    [start, end) to fetch when it is SWPM_RANGES_NOT_HELD."""
    return _check_ranges(held, path)[0]


def open_ranges(held: Held, *, path: str | None = None) -> FileRanges:
    """Open the byte ranges ``held`` (``{offset: bytes}``) of an SWPM file (spec 4.2); raises
    :class:`SwpmFormatError` with the report when they hold an error (SWPM_RANGES_NOT_HELD: fetch
    ``report.summary["range_need"]`` and open again) and :class:`ValueError` for a range past the
    header's file_size (of 64 or more: below, the header itself lies past it, the file's error, spec 4.2
    step 1) or past :data:`MAX_RANGE_END`, or two ranges that give a byte different values."""
    return _open(held, path)


def _open(held: Held | _Pieces, path: str | None) -> FileRanges:
    rep, fr = _checked_ranges(held, path)
    if fr is None:
        raise SwpmFormatError(rep)
    return fr


def _checked_ranges(held: Held | _Pieces, path: str | None) -> tuple[Report, FileRanges | None]:
    """The report of ranges ``held`` and, when they open, the :class:`FileRanges`, from one check (for
    ``validate --ranges``: :func:`validate_ranges` then :func:`open_ranges` would check twice)."""
    rep, p, spans = _check_ranges(held, path)
    if not rep.valid or p is None:
        return rep, None
    assert p.lods is not None
    indx = p.chunks[L.INDX]
    need = needed_index_ranges(p.encoding or "", p.buffers, p.lods.shape[0], indx.length // p.width)
    return rep, FileRanges(
        **_lod_fields(p, rep, path),
        held=spans,
        index_offset=indx.offset,
        index_width=p.width,
        index_need=need,
        _p=p,
    )


def _declared_end(head: _Bytes) -> int | None:
    """The header's file_size, read from the file's first bytes ``head``: where ``read_lod``'s first read,
    of a fixed length, stops being the file's (bytes after it, SWPM_FILE_TRAILING_BYTES, are not held).
    None without a header, or for a file_size below it (the header is then held as read: the file's error,
    spec 4.2 step 1)."""
    buf = _as_buf(head)
    if buf.shape[0] < L.HEADER_SIZE or bytes(buf[:8]) != L.MAGIC:
        return None
    size = int(buf[: L.HEADER_SIZE].view(L.HEADER)[0]["file_size"])
    return size if size >= L.HEADER_SIZE else None


def _put(held: dict[int, _Bytes], offset: int, data: _Bytes) -> None:
    if len(data) > len(held.get(offset, b"")):  # (two fetches at one offset: the longer holds the other)
        held[offset] = data


def _fetch(held: dict[int, _Bytes], read: Callable[[int, int], _Bytes], offset: int, length: int) -> None:
    """Read the parts of [offset, offset + length) that ``held`` does not hold yet, each once: a range
    that overlaps one already fetched (SMAP's bytes before INDX and the first read, VERT's header) reads only
    what it adds."""
    at, end = offset, offset + length
    for s, n in _merge(_pieces(held), None):
        if s >= end:
            break
        if s > at:
            _put(held, at, read(at, s - at))
        at = max(at, s + n)
    if at < end:
        _put(held, at, read(at, end - at))


def read_lod(
    read: Callable[[int, int], _Bytes], lod: int, *, head: int = 4096, path: str | None = None
) -> FileRanges:
    """Fetch what LOD ``lod`` needs through ``read(offset, length)`` (an HTTP range request, a pak file read)
    and open it: the file's first ``head`` bytes, ``SMAP``'s ranges for the LOD's band, then what the reader
    asks for (SWPM_RANGES_NOT_HELD's range, the LOD's :meth:`FileRanges.needed_ranges`) until it draws.
    Raises :class:`SwpmFormatError` for an error of the file and :class:`IndexError` if it never draws."""
    first = read(0, head)
    end = _declared_end(first)
    if end is not None and end < len(first):  # (a held range past file_size is the caller's: spec 4.2 step 1)
        first = first[:end]
    held: dict[int, _Bytes] = {0: first}
    try:
        for o, n in ranges_for_lod(held[0], lod):
            _fetch(held, read, o, n)
    except ValueError:  # no usable SMAP: the reader names what it needs
        pass
    for _ in range(8):
        try:
            fr = open_ranges(held, path=path)
        except SwpmFormatError as exc:
            need = exc.report.summary.get("range_need")
            if need is None:
                raise
            _fetch(held, read, need[0], need[1] - need[0])
            continue
        if lod in fr.drawable_lods:
            return fr
        for o, n in fr.needed_ranges(lod):
            _fetch(held, read, o, n)
    raise IndexError(f"{path or '<file>'}: LOD {lod} did not become drawable")
