"""The ``LODS`` and ``VERT`` chunks, which every encoding shares (spec 3.2 and 3.3).

:func:`_lods` views the per-LOD rows and checks that the counts do not grow and the errors are finite and
do not fall (``SWPM_LOD_EMPTY``, ``SWPM_LOD_NOT_MONOTONE``); :func:`_vert` checks the vertex layout (the
attribute descriptors, their names, types, offsets and overlap: ``SWPM_VERT_BAD_LAYOUT``) before viewing the
points and attributes as one record array of the mapping, and counts non-finite positions. Separate from the
reader because they are the content checks that run before any encoding's.
"""

from __future__ import annotations

import numpy as np

from . import layout as L
from .errors import Report
from .parsed import _get, _Parsed, _view


def _lods(p: _Parsed, rep: Report) -> None:
    c = _get(p, L.LODS)
    if c is None:
        return
    if c.length % L.LOD_ROW.itemsize:
        rep.add(
            "SWPM_CHUNK_BAD_LENGTH",
            c.entry_offset + 16,
            type="LODS",
            length=c.length,
            need=c.length // 12 * 12,
        )
        p.content_ok = False
        return
    rows = _view(p.buf, c.offset, c.length // 12, L.LOD_ROW)
    if rows.shape[0] == 0:
        rep.add("SWPM_LOD_EMPTY", c.offset)
        p.content_ok = False
        return
    for col, order in (("vertex_count", "non-increasing"), ("triangle_count", "non-increasing")):
        bad = np.flatnonzero(np.diff(rows[col].astype(np.int64)) > 0)
        if bad.size:
            k = int(bad[0]) + 1
            rep.add("SWPM_LOD_NOT_MONOTONE", c.offset + 12 * k, lod=k, what=col, order=order)
            p.content_ok = False
    err = rows["error"]
    bad = np.flatnonzero(~np.isfinite(err))
    if bad.size:
        k = int(bad[0])
        rep.add("SWPM_LOD_NOT_MONOTONE", c.offset + 12 * k + 8, lod=k, what="error", order="finite")
        p.content_ok = False
    else:
        bad = np.flatnonzero(np.diff(err) < 0)
        if bad.size:
            k = int(bad[0]) + 1
            rep.add(
                "SWPM_LOD_NOT_MONOTONE", c.offset + 12 * k + 8, lod=k, what="error", order="non-decreasing"
            )
            p.content_ok = False
    p.lods = rows


def _vert(p: _Parsed, rep: Report) -> None:
    c = _get(p, L.VERT)
    if c is None:
        return
    o = c.offset
    if c.length < L.VERT_HEADER.itemsize:
        rep.add("SWPM_CHUNK_BAD_LENGTH", c.entry_offset + 16, type="VERT", length=c.length, need=16)
        p.content_ok = False
        return
    h = _view(p.buf, o, 1, L.VERT_HEADER)[0]
    V, A, stride, data = (int(h[k]) for k in ("vertex_count", "attribute_count", "stride", "data_offset"))
    bad = None
    if 16 + 16 * A > c.length:
        rep.add(
            "SWPM_COUNT_EXCEEDS_CHUNK",
            o + 4,
            what="attribute_count",
            count=A,
            need=16 + 16 * A,
            remain=c.length - 16,
            type="VERT",
        )
        p.content_ok = False
        return
    if A > L.MAX_ATTRIBUTES:
        bad = f"{A} attributes, at most {L.MAX_ATTRIBUTES} allowed"
    elif stride < 12 or stride % 4:
        bad = f"stride {stride} is below 12 or not a multiple of 4"
    elif data % 8 or data < 16 + 16 * A or data > c.length:
        bad = f"data_offset {data} is misaligned or outside the chunk"
    elif V * stride > c.length - data:
        rep.add(
            "SWPM_COUNT_EXCEEDS_CHUNK",
            o,
            what="vertex_count",
            count=V,
            need=V * stride,
            remain=c.length - data,
            type="VERT",
        )
        p.content_ok = False
        return
    elif data + V * stride != c.length:
        rep.add(
            "SWPM_CHUNK_BAD_LENGTH", c.entry_offset + 16, type="VERT", length=c.length, need=data + V * stride
        )
        p.content_ok = False
        return
    descs = _view(p.buf, o + 16, A, L.ATTR_DESC)
    names, formats, offsets, attr_names = ["f0"], [("<f4", (3,))], [0], []
    spans = [(0, 12)]
    for i in range(A if bad is None else 0):
        d = descs[i]
        no, nl, et, comp, off = (
            int(d[k]) for k in ("name_offset", "name_length", "elem_type", "components", "offset")
        )
        if no < 16 + 16 * A or no + nl > data or nl == 0:
            bad = f"attribute {i}: name bytes [{no}, {no + nl}) are outside the name area"
            break
        try:
            name = p.buf[o + no : o + no + nl].tobytes().decode("utf-8")
        except UnicodeDecodeError:
            bad = f"attribute {i}: name is not UTF-8"
            break
        if name in attr_names:
            bad = f"attribute {name!r} appears twice"
            break
        if et not in L.ELEM_TYPES or comp == 0:
            bad = f"attribute {name!r}: element type {et} / {comp} components is not valid"
            break
        dt = L.ELEM_TYPES[et]
        if off % dt.itemsize or stride % dt.itemsize or off + dt.itemsize * comp > stride:
            bad = f"attribute {name!r}: offset {off} or stride {stride} is misaligned, or past the stride"
            break
        spans.append((off, off + dt.itemsize * comp))
        attr_names.append(name)
        names.append(f"f{i + 1}")
        formats.append((dt.str, (comp,)))
        offsets.append(off)
    if bad is None:
        spans.sort()
        if any(a[1] > b[0] for a, b in zip(spans, spans[1:], strict=False)):
            bad = "attributes overlap"
    if bad is not None:
        rep.add("SWPM_VERT_BAD_LAYOUT", o, reason=bad)
        p.content_ok = False
        return
    dtype = np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": stride})
    held = V if not p.prefix else min(V, max(0, p.held_end(o + data) - o - data) // stride)
    recs = _view(p.buf, o + data, held, dtype)  # a prefix or ranges (spec 4.1-4.2): the records held
    p.points = recs["f0"]
    p.attributes = {n: recs[f"f{i + 1}"] for i, n in enumerate(attr_names)}
    p.vert_stride, p.vert_data, p.vertex_count = stride, data, V
    if p.prefix:  # the count covers every point: deferred to the whole file
        return
    nonfinite = int(np.count_nonzero(~np.isfinite(p.points)))
    if nonfinite:
        rep.add("SWPM_VERT_NONFINITE", o + data, count=nonfinite)
