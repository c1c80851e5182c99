"""SWPM v1 writer: :func:`encode_bytes` lays a :class:`ProgressiveMesh` out as spec/format.md describes and
:func:`save` writes it atomically (temporary file in the same directory, then ``os.replace``)."""

from __future__ import annotations

import json
import os
import zlib
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import __version__
from ..fileio import atomic_write_bytes
from . import layout as L
from .errors import SwpmEncodeError
from .layout import STRIP_ARRAYS, choose_index_width
from .meta import parse_meta_json

if TYPE_CHECKING:  # (a type only: the reader's checks import this module, and validate starts without
    # the encoders)
    from ..encode.base import ProgressiveMesh

#: LOD bands of the streaming map: one per halving of the vertex count
GENERATOR = f"swpm-usd {__version__}"
#: the columns of an MREC record row, in order (spec section "MLVL and MREC")
MIXED_RECORD_COLUMNS = L.MIXED_RECORD_COLUMNS  # (in layout: the reader's check reads it without the encoders)


def _pad(b: bytes, a: int = L.ARRAY_ALIGN) -> bytes:
    return b + b"\0" * (L.align(len(b), a) - len(b))


def _u(a: np.ndarray, dt: np.dtype) -> bytes:
    return _pad(np.ascontiguousarray(a, dtype=dt).tobytes())


def _vert_payload(pm: ProgressiveMesh) -> tuple[bytes, int, int]:
    """VERT payload, its stride and its data offset (relative to the payload)."""
    V = pm.vertex_count
    names, descs, fields = [], [], [("f0", "<f4", (3,))]
    offset, max_elem = 12, 4
    blob = b""
    attrs = list(pm.attributes.items())
    hdr_len = L.VERT_HEADER.itemsize + L.ATTR_DESC.itemsize * len(attrs)
    for i, (name, a) in enumerate(attrs):
        a = np.asarray(a)
        if a.ndim == 1:
            a = a[:, None]
        dt = a.dtype.newbyteorder("<") if a.dtype.byteorder == ">" else a.dtype
        code = L.ELEM_CODES.get(np.dtype(dt).newbyteorder("<").str)
        if code is None or a.ndim != 2 or a.shape[0] != V or not 1 <= a.shape[1] <= 255:
            raise SwpmEncodeError(
                f"attribute {name!r} ({a.dtype}, shape {a.shape}) cannot be stored in SWPM v1: one row per "
                f"vertex ({V}) of 1 to 255 components of {' '.join(L.ELEM_NAMES.values())}"
            )
        elem = L.ELEM_TYPES[code]
        offset = L.align(offset, elem.itemsize)
        raw = name.encode("utf-8")
        descs.append((hdr_len + len(blob), len(raw), code, a.shape[1], offset, 0))
        blob += raw
        fields.append((f"f{i + 1}", elem.str, (a.shape[1],)))
        names.append((name, a))
        offset += elem.itemsize * a.shape[1]
        max_elem = max(max_elem, elem.itemsize)
    stride = L.align(offset, max_elem)
    data_offset = L.align(hdr_len + len(blob), L.CHUNK_ALIGN)
    dtype = np.dtype(
        {
            "names": [f[0] for f in fields],
            "formats": [(f[1], f[2]) for f in fields],
            "offsets": [0] + [int(d[4]) for d in descs],
            "itemsize": stride,
        }
    )
    data = np.zeros(V, dtype)
    data["f0"] = pm.points
    for i, (_, a) in enumerate(names):
        data[f"f{i + 1}"] = a
    head = np.array([(V, len(attrs), stride, data_offset)], L.VERT_HEADER).tobytes()
    table = np.array(descs, L.ATTR_DESC).tobytes() if descs else b""
    pre = head + table + blob
    return pre + b"\0" * (data_offset - len(pre)) + data.tobytes(), stride, data_offset


def _records(table: list[np.ndarray], offsets: np.ndarray, it: np.dtype) -> bytes:
    R, M = int(table[0].shape[0]), int(offsets.shape[0])
    head = np.array([(R, M)], L.REC_HEADER).tobytes()
    return (
        head
        + _u(np.stack(table, axis=1) if R else np.zeros((0, len(table))), it)
        + np.ascontiguousarray(offsets, it).tobytes()
    )


def _bands(vc: np.ndarray) -> np.ndarray:
    """Band of each LOD: floor(log2(V0 / vertex_count)), non-decreasing because counts do not grow."""
    v0 = max(int(vc[0]), 1)
    return np.floor(np.log2(v0 / np.maximum(vc.astype(np.float64), 1.0))).astype(np.int64)


def _strips_restart(pm: ProgressiveMesh, bufs: dict[str, np.ndarray]) -> int | None:
    """The restart index ``pm``'s strips are joined by, as a reader takes it from the file the writer makes
    (a sliding window's pool is strips with the ``SW_STRIPS`` bit, which ``window_index_counts`` sets; a
    skip-strip's missing primitive reads as "strip"), or None: lists, strips joined by degenerate triangles,
    a value that is no restart index (not an integer, or below V: a vertex, the reader's to reject)."""
    enc = pm.encoding
    if enc not in STRIP_ARRAYS or (enc == "sliding-window" and "window_index_counts" not in bufs):
        return None
    ri = L.strips_restart_index(enc, pm.params)
    return ri if ri is not None and pm.vertex_count <= ri < 2**32 else None


def _settled_restart(
    pm: ProgressiveMesh, bufs: dict[str, np.ndarray], width: int, old: int | None
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``pm``'s buffers and params with its strips' restart index ``old`` (:func:`_strips_restart`) made the
    largest value of ``width``, the writer's rule (spec 3.5, 3.7), when it is another (a file of a writer
    before 0.8.0 loaded, 0xFFFF in a u32 file, or a USD stage of one read): the strips rewritten into new
    arrays, the caller's left alone."""
    ones = 0xFFFF if width == 2 else 0xFFFFFFFF
    if old is None or old == ones:
        return bufs, pm.params
    strips = {name: bufs[name] for name in STRIP_ARRAYS[pm.encoding]}
    return {**bufs, **L.rejoin_strips(strips, old, ones)}, {**pm.params, "restart_index": ones}


def needed_index_ranges(encoding: str, buffers: dict[str, np.ndarray], lods: int, n_index: int) -> np.ndarray:
    """(L, 2) element range of INDX each LOD needs (spec: "Streaming map")."""
    if encoding == "sliding-window":
        w = np.asarray(buffers["window_records"], np.int64).reshape(-1, 3)
        n = buffers.get("window_index_counts")  # a strip pool's windows (spec 3.5)
        n = 3 * w[:, 1] if n is None else np.asarray(n, np.int64).reshape(-1)
        return np.stack([w[:, 0], w[:, 0] + n], axis=1)
    if encoding == "skip-strip":
        first = np.asarray(buffers["level_first_lod"], np.int64)
        start = np.asarray(buffers["level_index_start"], np.int64)
        lev = np.searchsorted(first, np.arange(lods), side="right") - 1
        return np.stack([start[lev], start[lev + 1]], axis=1)
    if encoding == "mixed":  # INDX holds the static lists; the dynamic ones are in MLVL, before INDX
        first = np.asarray(buffers["level_first_lod"], np.int64)
        start = np.asarray(buffers["level_static_start"], np.int64)
        lev = np.searchsorted(first, np.arange(lods), side="right") - 1
        return np.stack([start[lev], start[lev + 1]], axis=1)
    return np.tile(np.array([[0, n_index]], np.int64), (lods, 1))


def index_hulls(need: np.ndarray, first: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per band (band b starts at LOD ``first[b]`` and ends where the next starts), the hull [lo, hi) of the
    INDX elements its LODs ``need`` (spec 4): an LOD that needs none (an empty window or list) adds nothing,
    wherever its empty range lies; a band whose LODs need none has the empty hull lo = hi = 0."""
    need = np.asarray(need, np.int64)
    empty = need[:, 1] <= need[:, 0]
    lo = np.minimum.reduceat(np.where(empty, np.iinfo(np.int64).max, need[:, 0]), first)
    hi = np.maximum.reduceat(np.where(empty, -1, need[:, 1]), first)
    none = hi < 0
    return np.where(none, 0, lo), np.where(none, 0, hi)


def smap_payload(
    vc: np.ndarray,
    idx_need: np.ndarray,
    width: int,
    indx_off: int,
    vert_off: int,
    vert_data: int,
    stride: int,
) -> bytes:
    """Streaming map: per band of LODs, three ranges (prefix before INDX, INDX hull, VERT hull)."""
    band = _bands(vc)
    starts = np.flatnonzero(np.r_[True, np.diff(band) != 0])
    counts = np.diff(np.r_[starts, len(vc)])
    lows, highs = index_hulls(idx_need, starts)
    bands, ranges = [], []
    for b, (s, n) in enumerate(zip(starts, counts, strict=True)):
        lo, hi = int(lows[b]) * width + indx_off, int(highs[b]) * width + indx_off
        vend = vert_off + vert_data + int(vc[s : s + n].max()) * stride
        rs = [(0, indx_off), (lo, hi - lo), (vert_off, vend - vert_off)]
        # an empty INDX hull (the band's LODs draw nothing from INDX) does not count for the prefix
        prefix = max(indx_off, vend, hi if hi > lo else 0)
        bands.append((int(s), int(n), 3 * b, 3, prefix))
        ranges.extend(rs)
    head = np.array([(len(bands), len(ranges))], L.SMAP_HEADER).tobytes()
    return head + np.array(bands, L.SMAP_BAND).tobytes() + np.array(ranges, L.SMAP_RANGE).tobytes()


def _check_flag(name: str, value: object) -> None:
    """A layout switch is True or False: a truthy string (``legacy_layout="false"``, a config value read as
    text) wrote the other layout without a word."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, not {value!r}")


def encode_bytes(
    pm: ProgressiveMesh,
    *,
    source_digest: str | None = None,
    generator: str = GENERATOR,
    extra_chunks: Sequence[tuple[bytes, bool, bytes]] = (),
    minor: int = L.VERSION_MINOR,
    index_width: int | None = None,
    keep_restart_index: bool = False,
    offset_width: int | None = None,
    legacy: bool = False,
) -> bytes:
    """The complete file for ``pm``. ``extra_chunks`` (type, critical, payload) go right after SMAP;
    ``index_width`` (2 or 4) overrides the smallest ``idx`` width that fits (u32 is always allowed; from
    65,536 vertices on it is required, spec 1): 4 sets INDEX32, and ``off`` is u32 with it. ``idx`` is u16
    when V <= 65,535 and every value of the ``idx`` arrays (:data:`.layout.INDEX_ARRAYS`) but a strips'
    restart index fits; ``off`` (every other integer array) is u16 when its values fit, else u32 with the
    OFFSET32 bit (a sliding-window pool longer than 65,535 indices). ``offset_width`` 4 forces OFFSET32 on a
    u16 file (spec 1: a writer SHOULD NOT, the file is valid; the vector generator's small OFFSET32 files).
    ``legacy`` writes the layout of a writer before 0.9.0: one width, the smallest that fits every integer
    array and every vertex id, for ``idx`` and the tables alike, never OFFSET32 (the vectors of older
    files). Strips joined by a restart index other than the largest value of ``idx`` are written joined by
    that value, ``params.restart_index`` with them (spec 3.5, 3.7); ``keep_restart_index`` writes them as
    they are, as a writer before 0.8.0 did (the vector generator's older-file vector).
    :class:`SwpmEncodeError` when ``pm.params`` would make a ``META`` the reader rejects (spec 3.1: nested
    more than 128 deep, an integer too large for binary64); NaN or infinity is a ``ValueError``, as is a
    width other than 2 or 4; a ``legacy`` other than True or False is a ``TypeError``, as is a ``pm`` that
    is not a progressive mesh (a path, or a mesh before its build)."""
    _check_progressive_mesh(pm)
    enc = pm.encoding
    if enc not in L.ENCODING_FEATURES:
        raise ValueError(f"encoding {enc!r} has no SWPM v1 layout")
    for name, w in (("index_width", index_width), ("offset_width", offset_width)):
        # (another width has no feature bit: offset_width=3 wrote u32 tables without OFFSET32)
        if w is not None and w not in (2, 4):
            raise ValueError(f"{name} must be 2 or 4 bytes (or None), not {w!r}")
    _check_flag("legacy", legacy)
    bufs = pm.buffers()
    strips_restart = _strips_restart(pm, bufs)
    if legacy:  # (before 0.9.0: one width over every array, a restart index counted as it stands)
        W = max(choose_index_width(bufs, pm.vertex_count), int(index_width or 2))
        O, width_bits = W, L.FEATURE_INDEX32 if W == 4 else 0
    else:
        # a restart index about to be settled to W's all ones does not count for W (a re-saved file of a
        # writer before 0.9.0 joined by 0xFFFFFFFF comes out u16, joined by 0xFFFF)
        restart = None if keep_restart_index else strips_restart
        W = choose_index_width(L.index_buffers(bufs), pm.vertex_count, restart=restart)
        W = max(W, int(index_width or 2))
        O = max(L.choose_offset_width(bufs), int(offset_width or 2))
        W, O, width_bits = L.file_widths(W, O)
    # (rewriting keeps W: every value but the restart already fits it, and the new restart is W's all ones)
    bufs, params = (bufs, pm.params) if keep_restart_index else _settled_restart(pm, bufs, W, strips_restart)
    it, ot = L.index_dtype(W), L.index_dtype(O)
    lods = pm.lod_count
    meta = {
        "encoding": enc,
        "generator": generator,
        "params": params,
        "source_digest": source_digest,
    }
    # allow_nan=False: NaN and Infinity are not JSON; a reader rejects them (ValueError here)
    meta_text = json.dumps(
        meta, sort_keys=True, separators=(",", ":"), default=_json_default, allow_nan=False
    )
    try:  # nor do we write what a reader rejects under spec 3.1's limits: params 200 deep, an integer 10^400
        parse_meta_json(meta_text)
    except (ValueError, RecursionError) as e:
        raise SwpmEncodeError(f"META (params) is not JSON a reader accepts (spec 3.1): {e}") from e
    payload: dict[bytes, bytes] = {L.META: meta_text.encode("utf-8")}
    rows = np.zeros(lods, L.LOD_ROW)
    rows["vertex_count"] = pm.vertex_counts
    rows["triangle_count"] = pm.triangle_counts
    rows["error"] = pm.lod_errors
    payload[L.LODS] = rows.tobytes()
    vert, stride, vert_data = _vert_payload(pm)
    payload[L.VERT] = vert
    if enc == "vanilla":
        payload[L.RCNT] = np.ascontiguousarray(bufs["lod_record_counts"], ot).tobytes()
        cols = [
            "collapse_kept",
            "collapse_tris_removed",
            "collapse_change_count",
            "collapse_prev_change_count",
        ]
        payload[L.VREC] = _records([np.asarray(bufs[c]) for c in cols], bufs["collapse_change_offsets"], ot)
        index = bufs["indices"]
    elif enc == "sliding-window":
        rec = np.asarray(bufs["window_records"]).reshape(-1, 3)
        if "window_index_counts" in bufs:  # a strip pool: index_count is WREC's 4th field (spec 3.5)
            rec = np.c_[rec, np.asarray(bufs["window_index_counts"]).reshape(-1)]
        payload[L.WREC] = np.ascontiguousarray(rec, ot).tobytes()
        index = bufs["index_pool"]
    elif enc == "mixed":
        payload[L.RCNT] = np.ascontiguousarray(bufs["lod_record_counts"], ot).tobytes()
        first = np.asarray(bufs["level_first_lod"])
        dyn = np.asarray(bufs["level_dynamic_indices"])
        payload[L.MLVL] = (
            np.array([(first.shape[0], dyn.shape[0])], L.MLVL_HEADER).tobytes()
            + b"".join(
                _u(bufs[k], ot)
                for k in (
                    "level_first_lod",
                    "level_static_start",
                    "level_dynamic_start",
                    "level_record_start",
                )
            )
            + _u(dyn, it)
            + np.ascontiguousarray(bufs["level_dynamic_collapsed_indices"], it).tobytes()
        )
        payload[L.MREC] = _records(
            [np.asarray(bufs[c]) for c in MIXED_RECORD_COLUMNS], bufs["collapse_change_offsets"], ot
        )
        index = bufs["level_static_indices"]
    else:
        payload[L.RCNT] = np.ascontiguousarray(bufs["lod_record_counts"], ot).tobytes()
        first = np.asarray(bufs["level_first_lod"])
        coll = np.asarray(bufs["level_collapsed_indices"])
        payload[L.SKIP] = (
            np.array([(first.shape[0], coll.shape[0])], L.SKIP_HEADER).tobytes()
            + b"".join(
                _u(bufs[k], ot)
                for k in (
                    "level_first_lod",
                    "level_index_start",
                    "level_collapsed_start",
                    "level_record_start",
                )
            )
            + np.ascontiguousarray(coll, it).tobytes()
        )
        cols = ["collapse_kept", "collapse_binned", "collapse_change_count", "collapse_prev_change_count"]
        payload[L.SREC] = _records([np.asarray(bufs[c]) for c in cols], bufs["collapse_change_offsets"], ot)
        index = bufs["level_indices"]
    payload[L.INDX] = np.ascontiguousarray(index, it).tobytes()
    n_index = int(np.asarray(index).shape[0])

    order = list(L.REQUIRED_CHUNKS[enc])
    at = order.index(L.SMAP) + 1
    types = order[:at] + [c[0] for c in extra_chunks] + order[at:]
    crit = {t: L.CHUNK_TYPES[t][0] for t in order} | {c[0]: c[1] for c in extra_chunks}
    payload.update({c[0]: c[2] for c in extra_chunks})
    table_end = L.HEADER_SIZE + L.CHUNK_ENTRY.itemsize * len(types)

    def offsets(smap_len: int) -> dict[bytes, int]:
        pos, out = L.align(table_end, L.CHUNK_ALIGN), {}
        for t in types:
            out[t] = pos
            n = smap_len if t == L.SMAP else len(payload[t])
            pos = L.align(pos + n, L.CHUNK_ALIGN)
        return out

    vc = np.asarray(pm.vertex_counts, np.int64)
    band_n = len(np.unique(_bands(vc)))
    offs = offsets(L.SMAP_HEADER.itemsize + band_n * (L.SMAP_BAND.itemsize + 3 * L.SMAP_RANGE.itemsize))
    idx_need = needed_index_ranges(enc, bufs, lods, n_index)
    payload[L.SMAP] = smap_payload(vc, idx_need, W, offs[L.INDX], offs[L.VERT], vert_data, stride)

    file_size = offs[types[-1]] + len(payload[types[-1]])
    out = bytearray(file_size)
    entries = np.zeros(len(types), L.CHUNK_ENTRY)
    for i, t in enumerate(types):
        p = payload[t]
        out[offs[t] : offs[t] + len(p)] = p
        entries[i] = (t, L.CHUNK_CRITICAL if crit[t] else 0, offs[t], len(p), zlib.crc32(p, zlib.crc32(t)), 0)
    features = L.ENCODING_FEATURES[enc] | width_bits
    if enc == "sliding-window" and "window_index_counts" in bufs:
        features |= L.FEATURE_SW_STRIPS
    head = np.zeros(1, L.HEADER)
    head[0] = (
        L.MAGIC,
        L.VERSION_MAJOR,
        minor,
        L.HEADER_SIZE,
        0,
        features,
        len(types),
        0,
        L.HEADER_SIZE,
        file_size,
        0,
        (0, 0, 0),
    )
    out[: L.HEADER_SIZE] = head.tobytes()
    out[L.HEADER_SIZE : table_end] = entries.tobytes()
    crc = zlib.crc32(bytes(out[:table_end]))
    out[L.FILE_CRC_OFFSET : L.FILE_CRC_OFFSET + 4] = crc.to_bytes(4, "little")
    return bytes(out)


def _json_default(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (set, tuple)):
        return list(o)
    raise TypeError(f"parameter value {o!r} is not JSON-serialisable")


def _is_progressive_mesh(pm: object) -> bool:
    return all(hasattr(pm, a) for a in ("encoding", "buffers", "vertex_count"))


def _check_progressive_mesh(pm: object) -> None:
    """A :class:`TypeError` naming what ``pm`` is when it is not a progressive mesh: ``save(1, path)`` was an
    ``AttributeError`` from deep in the writer ('int' object has no attribute 'encoding')."""
    if _is_progressive_mesh(pm):
        return
    from ..mesh import Mesh

    if isinstance(pm, Mesh):
        hint = "a mesh before its build: swpm_usd.build(mesh, encoding=...) makes one"
    elif isinstance(pm, str | os.PathLike):
        hint = "a path: swpm_usd.build(path, encoding=...) builds the mesh file there"
    else:
        hint = "swpm_usd.build's result, or swpm_usd.load's"
    raise TypeError(f"an SWPM file is written from a progressive mesh, not {type(pm).__name__} ({hint})")


def save(
    pm: ProgressiveMesh,
    path: str | os.PathLike[str],
    *,
    source_digest: str | None = None,
    legacy_layout: bool = False,
) -> Path:
    """Write ``pm`` to ``path`` as SWPM v1, atomically: a reader sees the old file or the complete new one.

    ``legacy_layout`` writes a file a reader before 0.9.0 accepts (:func:`encode_bytes`' ``legacy``): one
    integer width for every array, never the OFFSET32 bit, so a sliding-window pool longer than 65,535
    indices makes the whole file u32 (INDEX32), the index lists an engine uploads too. It is True or False
    (a :class:`TypeError` otherwise: ``"false"`` would be truthy).

    An :class:`OSError` (of its errno's subclass) names ``path``, not the temporary file beside it. A path
    with a mesh file's suffix (``spot.obj``) is a :class:`SwpmEncodeError`, as ``encode -o`` refuses it: it
    wrote the SWPM bytes over a source mesh of that name."""
    from ..io import SUPPORTED_SUFFIXES

    if isinstance(pm, str | os.PathLike) and _is_progressive_mesh(path):
        # (``save("spot.swpm", pm)`` was pathlib's "expected str, bytes or os.PathLike object, not ...")
        raise TypeError(f"save(pm, path): the progressive mesh first, then the path ({os.fspath(pm)!r})")
    suffix = Path(path).suffix.lower()
    if suffix in SUPPORTED_SUFFIXES:
        raise SwpmEncodeError(
            f"{os.fspath(path)}: a mesh file's name ({suffix}); an SWPM file is written under a .swpm name"
        )
    _check_flag("legacy_layout", legacy_layout)
    data = encode_bytes(pm, source_digest=source_digest, legacy=legacy_layout)
    try:
        return atomic_write_bytes(path, data)
    except OSError as e:
        if e.errno is None:
            raise
        raise OSError(e.errno, e.strerror, os.fspath(path)) from e
