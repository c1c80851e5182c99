"""Byte layout of SWPM v1 (spec/format.md): every fixed-size structure as a little-endian numpy dtype.

Each dtype below is one byte table of the spec; ``tests/test_format.py`` asserts that their sizes equal the
sizes the spec states. Offsets in the file are absolute; payloads start on 8-byte boundaries and every
array inside a payload on a 4-byte boundary, padding is zero.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

MAGIC = b"SWPM\r\n\x1a\n"
VERSION_MAJOR = 1
VERSION_MINOR = 0
CHUNK_ALIGN = 8
MAX_CHUNKS = 1024
#: META: arrays and objects nest at most this deep (the top-level object is depth 1; spec 3.1)
META_MAX_DEPTH = 128
MAX_ATTRIBUTES = 255
MAX_BAND_RANGES = 16
ARRAY_ALIGN = 4

#: file header, 64 bytes (spec section "Header")
HEADER = np.dtype(
    [
        ("magic", "S8"),
        ("major", "<u2"),
        ("minor", "<u2"),
        ("header_size", "<u4"),
        ("flags", "<u4"),
        ("features", "<u4"),
        ("chunk_count", "<u4"),
        ("reserved0", "<u4"),
        ("table_offset", "<u8"),
        ("file_size", "<u8"),
        ("file_crc", "<u4"),
        ("reserved1", "<u4", (3,)),
    ]
)
HEADER_SIZE = 64
FILE_CRC_OFFSET = 48

#: one chunk-table entry, 32 bytes
CHUNK_ENTRY = np.dtype(
    [
        ("type", "S4"),
        ("flags", "<u4"),
        ("offset", "<u8"),
        ("length", "<u8"),
        ("crc", "<u4"),
        ("reserved", "<u4"),
    ]
)
CHUNK_CRITICAL = 0x1

# required-feature bits (a reader MUST reject a file with a bit it does not know)
FEATURE_INDEX32 = 1 << 0
FEATURE_VANILLA = 1 << 1
FEATURE_SLIDING_WINDOW = 1 << 2
FEATURE_SKIP_STRIP = 1 << 3
FEATURE_MIXED = 1 << 4
#: sliding-window only: the pool is triangle strips, WREC rows have a 4th field, index_count (spec 3.5)
FEATURE_SW_STRIPS = 1 << 5
#: the table type ``off`` is u32 while ``idx`` is u16 (spec 1; not allowed with INDEX32): a sliding-window
#: pool longer than 65,535 indices of fewer than 65,536 vertices stays u16 (since swpm-usd 0.9.0)
FEATURE_OFFSET32 = 1 << 6
KNOWN_FEATURES = (
    FEATURE_INDEX32
    | FEATURE_VANILLA
    | FEATURE_SLIDING_WINDOW
    | FEATURE_SKIP_STRIP
    | FEATURE_MIXED
    | FEATURE_SW_STRIPS
    | FEATURE_OFFSET32
)
ENCODING_FEATURES = {
    "vanilla": FEATURE_VANILLA,
    "sliding-window": FEATURE_SLIDING_WINDOW,
    "skip-strip": FEATURE_SKIP_STRIP,
    "mixed": FEATURE_MIXED,
}

#: LOD table row (LODS), 12 bytes
LOD_ROW = np.dtype([("vertex_count", "<u4"), ("triangle_count", "<u4"), ("error", "<f4")])

#: VERT payload header, 16 bytes, followed by attribute descriptors
VERT_HEADER = np.dtype(
    [("vertex_count", "<u4"), ("attribute_count", "<u4"), ("stride", "<u4"), ("data_offset", "<u4")]
)
#: one attribute descriptor, 16 bytes
ATTR_DESC = np.dtype(
    [
        ("name_offset", "<u4"),
        ("name_length", "<u2"),
        ("elem_type", "u1"),
        ("components", "u1"),
        ("offset", "<u4"),
        ("reserved", "<u4"),
    ]
)
#: element type codes of attributes
ELEM_TYPES: dict[int, np.dtype] = {
    1: np.dtype("u1"),
    2: np.dtype("i1"),
    3: np.dtype("<u2"),
    4: np.dtype("<i2"),
    5: np.dtype("<u4"),
    6: np.dtype("<i4"),
    7: np.dtype("<f2"),
    8: np.dtype("<f4"),
    9: np.dtype("<f8"),
}
ELEM_CODES = {dt.str: code for code, dt in ELEM_TYPES.items()}
ELEM_NAMES = {1: "u8", 2: "i8", 3: "u16", 4: "i16", 5: "u32", 6: "i32", 7: "f16", 8: "f32", 9: "f64"}

#: collapse-record chunk (VREC / SREC / MREC) header, 8 bytes
REC_HEADER = np.dtype([("record_count", "<u4"), ("offset_count", "<u4")])
#: skip-strip level chunk (SKIP) header, 8 bytes
SKIP_HEADER = np.dtype([("level_count", "<u4"), ("collapsed_count", "<u4")])
#: mixed level chunk (MLVL) header, 8 bytes
MLVL_HEADER = np.dtype([("level_count", "<u4"), ("dynamic_count", "<u4")])
#: streaming-map header, 8 bytes; band, 24 bytes; range, 16 bytes
SMAP_HEADER = np.dtype([("band_count", "<u4"), ("range_count", "<u4")])
SMAP_BAND = np.dtype(
    [
        ("first_lod", "<u4"),
        ("lod_count", "<u4"),
        ("range_start", "<u4"),
        ("range_count", "<u4"),
        ("prefix_length", "<u8"),
    ]
)
SMAP_RANGE = np.dtype([("offset", "<u8"), ("length", "<u8")])

# chunk types: (critical?, encodings that use it or None for all)
META = b"META"
LODS = b"LODS"
SMAP = b"SMAP"
VERT = b"VERT"
INDX = b"INDX"
WREC = b"WREC"
VREC = b"VREC"
SREC = b"SREC"
SKIP = b"SKIP"
RCNT = b"RCNT"
MLVL = b"MLVL"
MREC = b"MREC"
CHUNK_TYPES: dict[bytes, tuple[bool, frozenset[str]]] = {
    META: (True, frozenset(ENCODING_FEATURES)),
    LODS: (True, frozenset(ENCODING_FEATURES)),
    SMAP: (False, frozenset(ENCODING_FEATURES)),
    VERT: (True, frozenset(ENCODING_FEATURES)),
    INDX: (True, frozenset(ENCODING_FEATURES)),
    WREC: (True, frozenset({"sliding-window"})),
    VREC: (True, frozenset({"vanilla"})),
    RCNT: (True, frozenset({"vanilla", "skip-strip", "mixed"})),
    SKIP: (True, frozenset({"skip-strip"})),
    SREC: (True, frozenset({"skip-strip"})),
    MLVL: (True, frozenset({"mixed"})),
    MREC: (True, frozenset({"mixed"})),
}
#: the chunks each encoding requires, in the order a writer lays them out (coarse-to-fine streaming order)
REQUIRED_CHUNKS: dict[str, tuple[bytes, ...]] = {
    "vanilla": (META, LODS, SMAP, RCNT, VREC, INDX, VERT),
    "sliding-window": (META, LODS, SMAP, WREC, INDX, VERT),
    "skip-strip": (META, LODS, SMAP, RCNT, SKIP, SREC, INDX, VERT),
    "mixed": (META, LODS, SMAP, RCNT, MLVL, MREC, INDX, VERT),
}

#: sizes the spec's byte tables state, checked by the tests
SPEC_SIZES = {
    "HEADER": 64,
    "CHUNK_ENTRY": 32,
    "LOD_ROW": 12,
    "VERT_HEADER": 16,
    "ATTR_DESC": 16,
    "REC_HEADER": 8,
    "SKIP_HEADER": 8,
    "MLVL_HEADER": 8,
    "SMAP_HEADER": 8,
    "SMAP_BAND": 24,
    "SMAP_RANGE": 16,
}


def align(n: int, a: int) -> int:
    """``n`` rounded up to a multiple of ``a``."""
    return (n + a - 1) // a * a


def index_dtype(width: int) -> np.dtype:
    """The stored dtype of encoding arrays for a width (``idx``'s W or ``off``'s O) of 2 or 4 bytes."""
    return np.dtype("<u2") if width == 2 else np.dtype("<u4")


#: the encoding arrays typed ``idx`` (spec 1, 7): the ones an engine uploads as index buffers; every other
#: integer array of the encodings (windows, records, level tables, RCNT) is typed ``off``
INDEX_ARRAYS = (
    "indices",
    "index_pool",
    "level_indices",
    "level_collapsed_indices",
    "level_static_indices",
    "level_dynamic_indices",
    "level_dynamic_collapsed_indices",
)


def index_buffers(buffers: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The ``idx`` arrays of an encoding's buffers (:data:`INDEX_ARRAYS`)."""
    return {k: v for k, v in buffers.items() if k in INDEX_ARRAYS}


def offset_buffers(buffers: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The ``off`` arrays of an encoding's buffers: every one not in :data:`INDEX_ARRAYS`."""
    return {k: v for k, v in buffers.items() if k not in INDEX_ARRAYS}


def file_widths(width: int, offset_width: int) -> tuple[int, int, int]:
    """(W, O, feature bits) of a file whose ``idx`` needs ``width`` and ``off`` ``offset_width`` bytes (spec
    1): ``idx`` u32 sets INDEX32 only, which makes ``off`` u32 too; ``idx`` u16 with ``off`` u32 sets
    OFFSET32."""
    if width == 4:
        return 4, 4, FEATURE_INDEX32
    return 2, offset_width, FEATURE_OFFSET32 if offset_width == 4 else 0


def read_widths(features: int) -> tuple[int, int]:
    """(W, O) a reader takes from the header's required-feature bits (spec 1): both u32 with INDEX32 (with
    OFFSET32 too: an error, read so), ``off`` u32 with OFFSET32 alone."""
    W = 4 if features & FEATURE_INDEX32 else 2
    return W, 4 if features & (FEATURE_INDEX32 | FEATURE_OFFSET32) else 2


def header_widths(data: bytes) -> tuple[int, int]:
    """(W, O) of the file whose first :data:`HEADER_SIZE` bytes are ``data`` (:func:`read_widths` of its
    features): what ``encode --json`` and the pipeline's manifest report of a file they wrote."""
    return read_widths(int(np.frombuffer(data, HEADER, count=1)[0]["features"]))


def vertex_ids_fit_u16(vertex_count: int) -> bool:
    """Whether every vertex id (0 .. ``vertex_count`` - 1) may be stored as u16 (spec 1): each must be below
    0xFFFF, since u16's all ones is the restart index WebGL 2 (always on there) and OpenGL ES 3 take for any
    draw, a list's too, and strips with restart enabled on every API: a vertex 65,535 would be dropped."""
    return int(vertex_count) <= 0xFFFF


def choose_index_width(
    buffers: Mapping[str, np.ndarray], vertex_count: int | None = None, restart: int | None = None
) -> int:
    """2 when every value of every integer buffer given fits u16 and no vertex id is 0xFFFF, else 4 (spec 1).
    Given the ``idx`` arrays (:func:`index_buffers`), the file's W; given all of an encoding's buffers, the
    single width a writer before 0.9.0 used for every array. ``vertex_count`` (V) makes it 4 from 65,536
    vertices on (:func:`vertex_ids_fit_u16`), whether or not a buffer holds vertex 65,535; None checks the
    values only. Entries equal to ``restart`` (a strips' restart index) are left out: the width their other
    values need."""
    if vertex_count is not None and not vertex_ids_fit_u16(vertex_count):
        return 4
    top = 0
    for a in buffers.values():
        a = np.asarray(a)
        if restart is not None:
            a = np.where(a == int(restart), 0, a)
        if a.size and np.issubdtype(a.dtype, np.integer):
            top = max(top, int(a.max()))
    return 2 if top <= 0xFFFF else 4


def choose_offset_width(buffers: Mapping[str, np.ndarray]) -> int:
    """2 when every value of the ``off`` arrays among ``buffers`` (:func:`offset_buffers`: window fields,
    records, level tables, RCNT) fits u16, else 4 (spec 1: a writer sets OFFSET32 then, unless ``idx`` is
    u32). Its values are offsets and counts, never a restart index, so none is left out."""
    return choose_index_width(offset_buffers(buffers))


#: the arrays holding strips joined by ``params["restart_index"]``, per encoding (spec 3.5, 3.7)
STRIP_ARRAYS = {
    "sliding-window": ("index_pool",),
    "skip-strip": ("level_indices", "level_collapsed_indices"),
}


def strips_restart_index(encoding: str | None, params: object) -> int | None:
    """The restart index ``params`` (a file's ``META.params``, a mesh's ``params``) join strips by: their
    integer ``restart_index`` when their ``primitive`` is ``"strip"``, a missing one reading as skip-strip's
    ``"strip"`` and the sliding window's ``"list"`` (spec 3.5, 3.7: a list's restart index is ignored); else
    None. Its range (>= V) is the caller's to check."""
    if not isinstance(params, dict):
        return None
    if params.get("primitive", "strip" if encoding == "skip-strip" else "list") != "strip":
        return None
    ri = params.get("restart_index")
    return int(ri) if isinstance(ri, (int, np.integer)) and not isinstance(ri, bool) else None


def rejoin_strips(arrays: Mapping[str, np.ndarray], old: int, new: int) -> dict[str, np.ndarray]:
    """``arrays`` (strips) with their restart entries ``old`` made ``new``, as new uint32 arrays: never in
    place, since an array may be a caller's (:func:`swpm_usd.from_buffers` keeps them) or a file's,
    read-only."""
    return {
        name: np.where(np.asarray(a) == old, np.uint32(new), np.asarray(a)).astype(np.uint32)
        for name, a in arrays.items()
    }


def restart_index_for(buffers: Mapping[str, np.ndarray], restart: int, vertex_count: int) -> int:
    """The restart index a writer stores (spec 3.5, 3.7): the largest value of the file's ``idx``, 0xFFFF in a
    u16 file, else 0xFFFFFFFF, so an engine uploads ``INDX`` as it is with the restart value its API takes.

    ``buffers`` are the encoding's integer buffers (``ProgressiveMesh.buffers()``) with strips joined by
    ``restart`` (any value >= ``vertex_count``). 0xFFFF when :func:`choose_index_width` finds ``idx`` u16 over
    the ``idx`` arrays (:func:`index_buffers`) with the restart entries left out (every vertex id below
    0xFFFF): the writer decides W by the same rule, so the restart chosen and the width written cannot
    disagree. Offsets and counts no longer count (since 0.9.0 they widen ``off``, OFFSET32, not ``idx``)."""
    W = choose_index_width(index_buffers(buffers), vertex_count, restart=int(restart))
    return 0xFFFF if W == 2 else 0xFFFFFFFF


def draw_index_width(vertex_count: int, restart: int | None = None) -> int:
    """The width (2 or 4) an engine draws index values at, whatever the file's ``idx``: 2 when every vertex
    id is below 0xFFFF (:func:`vertex_ids_fit_u16`, the rule :func:`choose_index_width` applies) and, for
    strips joined by ``restart``, the restart index is 0xFFFF or the all ones of u32, which a u32 -> u16 copy
    (a truncation) turns into u16's 0xFFFF; else 4. The file's ``idx`` may be wider (a file of a writer
    before 0.9.0, whose pool offsets widened it, spec 3.5, or a forced ``index_width``): the memory figures
    (``global_bytes``), the pipeline's coarsest-LOD bytes, ``swpm:indexWidth`` and inspect's
    ``index_values_width`` count this width, so a strip's restart index (all ones of ``idx``) does not
    double its indices' bytes where the list pool of the same file counts 2."""
    if not vertex_ids_fit_u16(vertex_count):
        return 4
    if restart is None:
        return 2
    return 2 if int(restart) <= 0xFFFF or int(restart) == 0xFFFFFFFF else 4


def stored_index_count(buffers: Mapping[str, np.ndarray]) -> int:
    """The indices an encoding stores for every instance, which lambda counts (a run's manifest and report,
    ``inspect``): the sliding window's pool, else every ``*indices`` buffer (skip-strip's level and collapsed
    lists, mixed's static and dynamic ones)."""
    if "index_pool" in buffers:
        return int(buffers["index_pool"].shape[0])
    return sum(int(v.shape[0]) for k, v in buffers.items() if k.endswith("indices"))


#: the columns of a mixed file's ``MREC`` records, in order (the writer writes them, the reader checks them)
MIXED_RECORD_COLUMNS = (
    "collapse_kept",
    "collapse_static_tris_removed",
    "collapse_dynamic_tris_removed",
    "collapse_change_count",
    "collapse_prev_change_count",
)
