"""The optional streaming map, ``SMAP`` (spec 4), checked after an encoding's chunks are found valid.

:func:`_smap` checks that the bands cover the LODs in order and name at most ``MAX_BAND_RANGES`` ranges
inside the file, then that each band's ranges cover the bytes its LODs need (the prefix before ``INDX``,
the ``INDX`` elements they draw, the ``VERT`` prefix of their vertices) and that its ``prefix_length`` is
their end; every problem is ``SWPM_SMAP_INVALID``, a warning. Separate from the reader because it reads
the decoded buffers of every encoding (through the writer's :func:`.writer.needed_index_ranges`).
"""

from __future__ import annotations

import numpy as np

from . import layout as L
from .errors import Report
from .parsed import _Parsed, _view
from .writer import index_hulls, needed_index_ranges


def _smap(p: _Parsed, rep: Report) -> None:
    c = p.chunks.get(L.SMAP)
    if c is None or not c.ok or not p.content_ok or p.lods is None:
        return
    if not p.holds(c.offset, c.offset + c.length):  # (byte ranges without all of it, spec 4.2: not read)
        return
    if c.length < 8:
        rep.add("SWPM_SMAP_INVALID", c.offset, reason="shorter than its header")
        return
    h = _view(p.buf, c.offset, 1, L.SMAP_HEADER)[0]
    B, N = int(h["band_count"]), int(h["range_count"])
    if 8 + 24 * B + 16 * N != c.length:
        rep.add(
            "SWPM_SMAP_INVALID",
            c.offset,
            reason=f"{B} bands and {N} ranges need {8 + 24 * B + 16 * N} bytes, the chunk has {c.length}",
        )
        return
    bands = _view(p.buf, c.offset + 8, B, L.SMAP_BAND)
    ranges = _view(p.buf, c.offset + 8 + 24 * B, N, L.SMAP_RANGE)
    Lc = p.lods.shape[0]
    fl, lc = bands["first_lod"].astype(np.int64), bands["lod_count"].astype(np.int64)
    if (
        B == 0
        or fl[0] != 0
        or np.any(lc == 0)
        or np.any(fl[1:] != (fl + lc)[:-1])
        or int((fl + lc)[-1]) != Lc
    ):
        rep.add("SWPM_SMAP_INVALID", c.offset + 8, reason="bands do not cover the LODs in order")
        return
    rs, rn = bands["range_start"].astype(np.int64), bands["range_count"].astype(np.int64)
    if np.any(rs + rn > N):
        rep.add("SWPM_SMAP_INVALID", c.offset + 8, reason="a band's ranges lie outside the range table")
        return
    if int(rn.max()) > L.MAX_BAND_RANGES:  # a band check too: before the ranges against the file
        rep.add(
            "SWPM_SMAP_INVALID", c.offset + 8, reason=f"a band names more than {L.MAX_BAND_RANGES} ranges"
        )
        return
    ro, rl = ranges["offset"].astype(np.uint64), ranges["length"].astype(np.uint64)
    fsz = np.uint64(p.size)  # the file as read: bytes after file_size are not part of it
    if np.any(ro > fsz) or np.any(rl > fsz - np.minimum(ro, fsz)):
        rep.add("SWPM_SMAP_INVALID", c.offset + 8 + 24 * B, reason="a range lies outside the file")
        return
    indx, vert = p.chunks[L.INDX], p.chunks[L.VERT]
    need = needed_index_ranges(p.encoding or "", p.buffers, Lc, indx.length // p.width)
    ro, rl = ro.astype(np.int64), rl.astype(np.int64)
    vc = p.lods["vertex_count"].astype(np.int64)
    # hulls of (a) prefix before INDX, (b) INDX elements, (c) VERT prefix, per band (vectorised over bands);
    # (b) ignores LODs that need no INDX element and is empty (lo = hi) when none of the band's LODs needs one
    lo, hi = (indx.offset + h * p.width for h in index_hulls(need, fl))
    vend = vert.offset + p.vert_data + np.maximum.reduceat(vc, fl) * p.vert_stride
    want_a = np.stack([np.zeros(B, np.int64), lo, np.full(B, vert.offset, np.int64)], axis=1)
    want_e = np.stack([np.full(B, indx.offset, np.int64), hi, vend], axis=1)
    slot = rs[:, None] + np.arange(L.MAX_BAND_RANGES)[None, :]  # (B, 16) range ids, masked past rn
    used = np.arange(L.MAX_BAND_RANGES)[None, :] < rn[:, None]
    slot = np.where(used, slot, 0) if N else np.zeros_like(slot)
    r_lo = ro[slot] if N else np.zeros(slot.shape, np.int64)
    r_hi = r_lo + (rl[slot] if N else 0)
    inside = (
        used[:, None, :] & (r_lo[:, None, :] <= want_a[:, :, None]) & (r_hi[:, None, :] >= want_e[:, :, None])
    ).any(axis=2) | (want_e <= want_a)
    if not inside.all():
        b, j = (int(x) for x in np.argwhere(~inside)[0])
        rep.add(
            "SWPM_SMAP_INVALID",
            c.offset + 8 + 24 * b,
            reason=f"band {b} (LODs {int(fl[b])}..{int(fl[b] + lc[b] - 1)}) does not cover bytes "
            f"[{int(want_a[b, j])}, {int(want_e[b, j])})",
        )
        return
    prefix = np.where(want_e > want_a, want_e, 0).max(axis=1)  # the largest end of the non-empty hulls
    bad = np.flatnonzero(bands["prefix_length"].astype(np.int64) != prefix)
    if bad.size:
        b = int(bad[0])
        rep.add(
            "SWPM_SMAP_INVALID",
            c.offset + 8 + 24 * b + 16,
            reason=f"band {b} prefix_length is {int(bands['prefix_length'][b])}, LODs need {int(prefix[b])}",
        )
