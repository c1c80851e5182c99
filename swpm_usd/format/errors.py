"""The SWPM error catalogue: every problem a reader can report, with a stable code, a severity and a message.

This module is the single source of truth: ``spec/errors.md`` is generated from :data:`CATALOGUE` by
:func:`render_markdown` (``python -m swpm_usd.format.errors > spec/errors.md``) and a test fails when they
differ. Codes never change meaning; new codes may be added in minor versions.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from ..errors import SwpmError

ERROR = "error"
WARNING = "warning"
INFO = "info"


@dataclass(frozen=True)
class Entry:
    """One catalogue entry: ``template`` is a ``str.format`` template over the problem's arguments;
    ``offset`` says exactly which absolute byte offset the reader reports (column "Offset reported")."""

    code: str
    severity: str
    template: str
    meaning: str
    offset: str


_ENTRIES = [
    # -- file and header ----------------------------------------------------------------------------------
    Entry(
        "SWPM_IO_ERROR",
        ERROR,
        "cannot read file: {reason}",
        "The file could not be opened or mapped.",
        "null (the whole file)",
    ),
    Entry(
        "SWPM_HEADER_TRUNCATED",
        ERROR,
        "file has {size} bytes, the header needs {need}",
        "The file is shorter than the 64-byte header.",
        "0 (the start of the file)",
    ),
    Entry(
        "SWPM_HEADER_BAD_MAGIC",
        ERROR,
        "magic is {found}, expected {expected}",
        "The first 8 bytes are not the SWPM signature.",
        "0 (the magic field), also when a file shorter than 64 bytes has a wrong magic",
    ),
    Entry(
        "SWPM_HEADER_UNSUPPORTED_MAJOR",
        ERROR,
        "major version {major} is not supported (this reader: 1)",
        "The major version is not 1; nothing after the version fields can be interpreted.",
        "8 (the major field)",
    ),
    Entry(
        "SWPM_HEADER_NEWER_MINOR",
        INFO,
        "minor version {minor} is newer than 0; reading the parts v1.0 defines",
        "A newer minor version: only ancillary chunks, flags and reserved fields can differ.",
        "10 (the minor field)",
    ),
    Entry(
        "SWPM_HEADER_BAD_SIZE",
        ERROR,
        "header_size {value} is below 64 or past the end of the file",
        "The header size field is invalid.",
        "12 (the header_size field)",
    ),
    Entry(
        "SWPM_HEADER_UNKNOWN_FEATURE",
        ERROR,
        "required-feature bits {bits:#x} are unknown",
        "A required feature this reader does not implement.",
        "20 (the features field)",
    ),
    Entry(
        "SWPM_HEADER_BAD_ENCODING",
        ERROR,
        "feature bits {bits:#x} must select exactly one encoding",
        "Exactly one of the encoding feature bits must be set.",
        "20 (the features field)",
    ),
    Entry(
        "SWPM_HEADER_STRIPS_NOT_SLIDING",
        ERROR,
        "feature bits {bits:#x} set SW_STRIPS without SLIDING_WINDOW",
        "The SW_STRIPS feature bit (0x20) is allowed only with the sliding-window encoding.",
        "20 (the features field)",
    ),
    Entry(
        "SWPM_HEADER_OFFSET32_WITH_INDEX32",
        ERROR,
        "feature bits {bits:#x} set OFFSET32 with INDEX32",
        "The OFFSET32 feature bit (0x40) widens only the tables of a file whose index type is u16; with "
        "INDEX32 it is not allowed.",
        "20 (the features field)",
    ),
    Entry(
        "SWPM_HEADER_RESERVED_NONZERO",
        WARNING,
        "reserved header field {field} is {value}, expected 0",
        "A reserved header field is not zero.",
        "the reserved field itself: 28 (reserved0), 52 (reserved1) or entry + 28 (a chunk entry's "
        "reserved field); one problem per non-zero field, checked only when minor is 0",
    ),
    Entry(
        "SWPM_FILE_SIZE_MISMATCH",
        ERROR,
        "header says {declared} bytes, the file has {actual}",
        "The file is shorter than its header declares (truncated download).",
        "40 (the file_size field)",
    ),
    Entry(
        "SWPM_FILE_TRAILING_BYTES",
        WARNING,
        "{extra} bytes follow the declared end of file",
        "The file is longer than declared; the extra bytes are ignored.",
        "the declared file_size, i.e. the first byte past the declared end",
    ),
    Entry(
        "SWPM_CHECKSUM_MISMATCH",
        ERROR,
        "file CRC-32 is {found:#010x}, computed {computed:#010x}",
        "The CRC-32 over header and chunk table does not match.",
        "48 (the file_crc field)",
    ),
    # -- chunk table --------------------------------------------------------------------------------------
    Entry(
        "SWPM_TABLE_TRUNCATED",
        ERROR,
        "chunk table of {count} entries needs {need} bytes at {at}, the file has {size}",
        "The chunk table runs past the end of the file.",
        "24 (the chunk_count field)",
    ),
    Entry(
        "SWPM_TABLE_TOO_LARGE",
        ERROR,
        "chunk_count {count} exceeds the limit of {limit}",
        "A v1 file has at most 1024 chunks.",
        "24 (the chunk_count field)",
    ),
    Entry(
        "SWPM_TABLE_BAD_OFFSET",
        ERROR,
        "chunk table offset {value} overlaps the header or is misaligned",
        "The chunk table must start at or after the header, on an 8-byte boundary.",
        "32 (the table_offset field)",
    ),
    Entry(
        "SWPM_CHUNK_BAD_TYPE",
        ERROR,
        "chunk type {type} is not four ASCII letters or digits",
        "A chunk type must be four characters from A-Z, a-z, 0-9.",
        "entry (its type field); the entry is then also an unknown chunk (critical or ancillary)",
    ),
    Entry(
        "SWPM_CHUNK_OUT_OF_BOUNDS",
        ERROR,
        "chunk {type} [{start}, {end}) extends past the end of file ({size})",
        "A chunk's payload lies (partly) outside the file.",
        "entry + 8 (its offset field)",
    ),
    Entry(
        "SWPM_CHUNK_MISALIGNED",
        ERROR,
        "chunk {type} starts at {start}, not a multiple of 8",
        "Payloads start on 8-byte boundaries.",
        "entry + 8 (its offset field)",
    ),
    Entry(
        "SWPM_CHUNK_OVERLAP",
        ERROR,
        "chunk {type} [{start}, {end}) overlaps {other}",
        "Two chunks, or a chunk and the header or table, share bytes.",
        "entry + 8 (the offset field of the later-listed of the two entries)",
    ),
    Entry(
        "SWPM_CHUNK_OUT_OF_ORDER",
        ERROR,
        "chunk {type} at {start} is listed after a chunk that follows it",
        "Chunk-table entries are listed in increasing offset order.",
        "entry + 8 (the offset field of the entry whose offset is below the one listed before it)",
    ),
    Entry(
        "SWPM_CHUNK_CRC_MISMATCH",
        ERROR,
        "chunk {type} CRC-32 is {found:#010x}, computed {computed:#010x}",
        "A chunk's CRC-32 over its type and payload does not match.",
        "entry + 24 (its crc field)",
    ),
    Entry(
        "SWPM_CHUNK_DUPLICATE",
        ERROR,
        "chunk {type} appears more than once",
        "Every v1 chunk type occurs at most once.",
        "entry of the second (and every later) occurrence",
    ),
    Entry(
        "SWPM_CHUNK_UNKNOWN_CRITICAL",
        ERROR,
        "unknown critical chunk {type}",
        "A chunk marked critical that this reader does not know: the file cannot be decoded.",
        "entry (its type field)",
    ),
    Entry(
        "SWPM_CHUNK_UNKNOWN_ANCILLARY",
        INFO,
        "unknown ancillary chunk {type} ignored",
        "An ancillary chunk this reader does not know; it is skipped.",
        "entry (its type field)",
    ),
    Entry(
        "SWPM_CHUNK_MISSING",
        ERROR,
        "required chunk {type} is missing",
        "A chunk the encoding needs is absent.",
        "null; one problem per missing chunk type",
    ),
    Entry(
        "SWPM_CHUNK_NOT_ALLOWED",
        ERROR,
        "chunk {type} does not belong to encoding {encoding}",
        "A known chunk of another encoding.",
        "entry (its type field)",
    ),
    Entry(
        "SWPM_CHUNK_BAD_FLAGS",
        ERROR,
        "chunk {type} has flags {flags:#x}; its critical bit must be {critical}",
        "A known chunk with the wrong critical bit.",
        "entry + 4 (its flags field)",
    ),
    Entry(
        "SWPM_CHUNK_BAD_LENGTH",
        ERROR,
        "chunk {type} is {length} bytes, its contents need {need}",
        "A chunk's length does not match the counts it declares.",
        "entry + 16 (the length field of the chunk whose length is wrong); exception: an RCNT whose "
        "number of counts differs from the LOD count is reported at RCNT's payload (a stage (a) check, "
        "after the change counts and prev_change_count)",
    ),
    Entry(
        "SWPM_COUNT_EXCEEDS_CHUNK",
        ERROR,
        "{what} = {count} needs {need} bytes, only {remain} remain in {type}",
        "A count that would need more bytes than remain (checked before anything is allocated).",
        "where the array the count sizes starts (payload + its 4-aligned position), not the count "
        "field: record chunks: payload + 8 for record_count, the change_offsets start for "
        "offset_count; SKIP, MLVL: the first array that does not fit. Exception, VERT: the count "
        "field itself, payload + 4 (attribute_count) or payload (vertex_count)",
    ),
    Entry(
        "SWPM_PADDING_NONZERO",
        ERROR,
        "padding byte(s) at {start} are not zero",
        "Padding before the chunk table, between chunks and after the last payload must be zero (padding "
        "inside payloads is not checked).",
        "the first byte of the gap that holds a non-zero byte, not that byte: header_size for the gap "
        "before the chunk table, else the end of the chunk table or of the preceding payload (the "
        "highest end so far); one problem per gap; a gap before a chunk that starts past the end of the "
        "file is checked up to the end of the file, after that chunk's SWPM_CHUNK_OUT_OF_BOUNDS",
    ),
    Entry(
        "SWPM_STREAM_ORDER",
        WARNING,
        "chunk {type} is not laid out in streaming order ({reason})",
        "Chunks are not in the coarse-to-fine order of the spec; the file decodes but does not stream.",
        "entry at the first position where the encoding's chunks, in table order with duplicates, differ "
        "from the streaming order restricted to the types present (format.md 2.3; a position past the end "
        "of that order, i.e. a trailing duplicate, differs), else the (first) VERT entry when the last "
        "entry is not a VERT; once per file",
    ),
    Entry(
        "SWPM_PREFIX_TOO_SHORT",
        ERROR,
        "the prefix has {size} bytes, opening it needs {need}",
        "A prefix reader (format.md 4.1) was given fewer bytes than opening the file takes: its header and "
        "chunk table, every payload before VERT and VERT's first data_offset bytes; read on when more "
        "bytes have arrived (only a prefix reader reports it).",
        "the prefix's length, the first byte it lacks",
    ),
    Entry(
        "SWPM_PREFIX_NOT_STREAMABLE",
        ERROR,
        "chunk {type} is the last table entry: a prefix reader needs VERT last",
        "The last entry of the chunk table is not a VERT, so a prefix of the file cannot hold every table "
        "before the vertices (format.md 4.1); read the whole file (only a prefix reader reports it).",
        "the last chunk-table entry",
    ),
    Entry(
        "SWPM_RANGES_NOT_HELD",
        ERROR,
        "opening the file's byte ranges needs bytes [{start}, {end}), not all held",
        "A range reader (format.md 4.2) was given byte ranges that lack what opening the file takes: its "
        "header and chunk table (every byte up to the table's end), every byte before INDX, VERT's bytes "
        "before its vertex records, and each table that lies after INDX in a file not in streaming order; "
        "fetch [start, end) and open again (only a range reader reports it).",
        "the first byte of [start, end) not held",
    ),
    # -- content ------------------------------------------------------------------------------------------
    Entry(
        "SWPM_META_BAD_JSON",
        ERROR,
        "META is not a UTF-8 JSON object: {reason}",
        "The metadata chunk cannot be decoded.",
        "META payload",
    ),
    Entry(
        "SWPM_META_BAD_FIELD",
        ERROR,
        "META field {field}: {reason}",
        "A metadata field has the wrong type.",
        "META payload, for every field: params not an object (ends the checks), then encoding, then "
        "skip-strip params.primitive or params.restart_index (each ends the checks; a strips' restart "
        "index below V is found with the level table), or sliding-window params.primitive or "
        "params.restart_index disagreeing with the SW_STRIPS bit (each ends the checks; a strip pool's "
        "restart index below V is found in sliding-window stage (a), before the windows)",
    ),
    Entry("SWPM_LOD_EMPTY", ERROR, "LODS has no LOD", "At least one LOD is required.", "LODS payload"),
    Entry(
        "SWPM_LOD_NOT_MONOTONE",
        ERROR,
        "LOD {lod}: {what} is not {order}",
        "Vertex and triangle counts must not increase, errors must not decrease (no NaN).",
        "vertex_count or triangle_count: the start of LODS row k, k the first row above row k - 1 "
        "(one problem per column); error: the error field of row k (row + 8), k the first non-finite "
        "row, else the first row below row k - 1 (one problem)",
    ),
    Entry(
        "SWPM_LOD_VERTEX_COUNT",
        ERROR,
        "LOD {lod} uses {count} vertices, expected {expected}",
        "LOD 0 must use every vertex, no LOD more than there are.",
        "the start of LODS row k (its vertex_count field): row 0 when it differs from VERT's vertex "
        "count; vanilla, skip-strip and mixed also the first row that differs from the records (row 0 "
        "again when it differs from VERT's vertex count and that stage runs)",
    ),
    Entry(
        "SWPM_VERT_BAD_LAYOUT",
        ERROR,
        "vertex layout: {reason}",
        "The VERT header or attribute table is invalid.",
        "VERT payload, whatever the reason (also for a bad attribute descriptor)",
    ),
    Entry(
        "SWPM_VERT_NONFINITE",
        WARNING,
        "{count} point coordinate(s) are NaN or infinite",
        "Points should be finite.",
        "VERT payload + data_offset (the first vertex record); one problem with the count",
    ),
    Entry(
        "SWPM_INDEX_WIDTH",
        ERROR,
        "value {value} in {what} does not fit the declared index width",
        "A u32 file whose values all fit u16 is allowed; this reports a u16 file that needs u32.",
        "never reported by this reader (reserved)",
    ),
    Entry(
        "SWPM_INDEX_OUT_OF_RANGE",
        ERROR,
        "{what} holds {value} at element {index}, limit {limit}",
        "An index at or above the vertex count (or an offset past its list).",
        "the offending element of INDX, level_collapsed_indices, level_dynamic_indices or "
        "level_dynamic_collapsed_indices (array start + W x i) or of change_offsets (array start + O x i), "
        "or the kept / binned field of record i in SREC (table + O x (4 i + column)); first 3 per array",
    ),
    Entry(
        "SWPM_WINDOW_OUT_OF_POOL",
        ERROR,
        "window of LOD {lod} [{start}, {end}) lies outside the pool of {pool}",
        "A sliding window that is not inside the index pool.",
        "the start of WREC window k (its first_index field); first 3 windows",
    ),
    Entry(
        "SWPM_WINDOW_NOT_MONOTONE",
        ERROR,
        "window of LOD {lod}: {what}",
        "Windows are ordered finest to coarsest with non-increasing triangle counts.",
        "the triangle_count field of window k (window + O), k the first window whose triangle_count "
        "exceeds window k - 1's; one problem",
    ),
    Entry(
        "SWPM_WINDOW_COUNT_MISMATCH",
        ERROR,
        "window of LOD {lod} says {what} {value}, LODS says {expected}",
        "A window's counts differ from the LOD table.",
        "the differing field of window k, triangle_count (window + O) or vertex_count (window + 2 O); "
        "first differing window per field, triangle_count's listed first",
    ),
    Entry(
        "SWPM_WINDOW_MID_STRIP",
        ERROR,
        "window of LOD {lod} starts at {start}, inside a strip",
        "A strip pool's window (SW_STRIPS) must start at the pool's start or right after a restart index, "
        "so that its strips take the parity the pool's decoding gives them (it may end inside a strip).",
        "the first_index field of window k, the first such window; one problem",
    ),
    Entry(
        "SWPM_WINDOW_STRIP_TRIANGLES",
        ERROR,
        "window of LOD {lod} decodes to {decoded} triangles, its triangle_count is {expected}",
        "A strip pool's window (SW_STRIPS) must decode to exactly triangle_count non-degenerate triangles.",
        "the index_count field of window k (window + 3 O), the first such window; one problem",
    ),
    Entry(
        "SWPM_PREFIX_VIOLATION",
        ERROR,
        "LOD {lod} draws vertex {vertex}, but only [0, {limit}) is in use",
        "The vertex prefix property: LOD k draws only vertices below vertex_count_at(k).",
        "the first offending element of INDX (sliding-window, skip-strip; mixed: static lists), of "
        "level_dynamic_indices, or of level_collapsed_indices / level_dynamic_collapsed_indices (first "
        "offending level); found while replaying records (vanilla, mixed): the start of record r's row; "
        "one problem per check",
    ),
    Entry(
        "SWPM_RECORD_BAD_KEPT",
        ERROR,
        "record {record} keeps vertex {kept}, not below the binned vertex {binned}",
        "A collapse must keep a vertex that stays in use.",
        "the start of record r's row in VREC, SREC or MREC (its kept field); first 3 records",
    ),
    Entry(
        "SWPM_RECORD_BAD_BINNED",
        ERROR,
        "record {record} bins vertex {binned}; record r must bin V - 1 - r",
        "Skip-strip record r must bin the last vertex still in use, V - 1 - r (vertex prefix property).",
        "record r's binned field in SREC (table + O x (4 r + 1)); first 3 records",
    ),
    Entry(
        "SWPM_RECORD_BAD_COUNTS",
        ERROR,
        "collapse records: {reason}",
        "Change counts, previous change counts, removed triangles or per-LOD record counts are inconsistent.",
        "change counts do not sum to offset_count: the record table (payload + 8); prev_change_count "
        "of record r wrong: that field, payload + 8 + O x (c r + c - 1) with c columns (4, MREC 5), "
        "for the first such r; RCNT not from 0, decreasing or above R: RCNT "
        "payload (one problem however many of the three); R >= V: the record chunk's payload; too many "
        "triangles removed: record 0's "
        "tris_removed (table + O; MREC: static + O, dynamic + 2 O, whatever the level, one problem per "
        "column); LODS triangle_count differs (vanilla: also row 0 against T0 = INDX count / 3): the "
        "start of the first differing LODS row",
    ),
    Entry(
        "SWPM_RECORD_BAD_CHANGE",
        ERROR,
        "record {record} changes slot {slot}, which does not hold the binned vertex",
        "A change offset must point at a live index slot holding the binned vertex; a record's changes are "
        "made in the order listed, so a slot listed twice no longer holds it the second time.",
        "the start of record r's row in VREC, SREC or MREC, not the change_offsets element; first bad "
        "record only",
    ),
    Entry(
        "SWPM_LEVEL_BAD_TABLE",
        ERROR,
        "skip-strip levels: {reason}",
        "The level table is inconsistent.",
        "SKIP payload (its level_count field), whatever the reason, except a collapsed list that differs "
        "from its level's replayed records: that element of level_collapsed_indices; one problem",
    ),
    Entry(
        "SWPM_MIXED_BAD_LEVELS",
        ERROR,
        "mixed levels: {reason}",
        "The mixed level table (MLVL) is inconsistent with itself, its arrays, MREC or RCNT.",
        "level_first_lod bad: its start (MLVL payload + 8); else level_static_start, "
        "level_dynamic_start or level_record_start bad: the start of that array (the last bad one in "
        "this order); level_record_start[l] != RCNT[level_first_lod[l]]: that element, first such l; "
        "a collapsed dynamic list that replay contradicts: the first differing element of "
        "level_dynamic_collapsed_indices; one problem",
    ),
    Entry(
        "SWPM_SMAP_INVALID",
        WARNING,
        "streaming map: {reason}",
        "The (ancillary) streaming map is malformed or does not cover what a LOD needs; ignore it.",
        "the first problem only, in this order (format.md 4): SMAP payload when its length is wrong; "
        "band 0 (payload + 8) when bands do not cover the LODs, or any band's ranges lie outside the "
        "range table or exceed 16; the range table start (payload + 8 + 24 B, B = band_count) when any "
        "range lies outside the file (its first file_size bytes); band b, the first band not covering "
        "what its LODs need; band b's prefix_length (band + 16), first wrong band",
    ),
    Entry(
        "SWPM_ENCODING_UNAVAILABLE",
        ERROR,
        "encoding {encoding} has no registered implementation",
        "The file is valid but this installation cannot build its ProgressiveMesh.",
        "null (the whole file)",
    ),
    Entry(
        "SWPM_BUFFERS_REJECTED",
        ERROR,
        "the {encoding} implementation rejected the buffers: {reason}",
        "from_buffers raised on the decoded arrays.",
        "null (the whole file)",
    ),
]
CATALOGUE: dict[str, Entry] = {e.code: e for e in _ENTRIES}


@dataclass(frozen=True)
class Problem:
    """One problem: stable ``code``, ``severity``, formatted ``message``, absolute byte ``offset``."""

    code: str
    severity: str
    message: str
    offset: int | None

    def to_dict(self) -> dict[str, Any]:
        return {"code": self.code, "severity": self.severity, "message": self.message, "offset": self.offset}


@dataclass
class Report:
    """Every problem found in one file, plus what could be decoded (``summary``) for ``inspect``."""

    path: str | None = None
    problems: list[Problem] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)

    def add(self, code: str, offset: int | None, **args: Any) -> None:
        entry = CATALOGUE[code]
        self.problems.append(Problem(code, entry.severity, entry.template.format(**args), offset))

    @property
    def errors(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == ERROR]

    @property
    def valid(self) -> bool:
        return not self.errors

    def codes(self) -> list[str]:
        return [p.code for p in self.problems]

    def to_dict(self) -> dict[str, Any]:
        return {
            "path": self.path,
            "valid": self.valid,
            "problems": [p.to_dict() for p in self.problems],
            "summary": self.summary,
        }

    def to_json(self, **kw: Any) -> str:
        return json.dumps(self.to_dict(), **kw)

    def format(self) -> str:
        """Human-readable listing: one line per problem, ``severity CODE @offset: message``."""
        lines = [f"{self.path or '<file>'}: {'valid' if self.valid else 'INVALID'}"]
        for p in self.problems:
            where = "" if p.offset is None else f" @{p.offset}"
            lines.append(f"  {p.severity:<7} {p.code}{where}: {p.message}")
        return "\n".join(lines)


class SwpmEncodeError(SwpmError, ValueError):
    """A progressive mesh cannot be written as SWPM v1 (an attribute of an element type or width the format
    has no code for, params a reader would reject as META: spec 3.1's limits); a :class:`ValueError` too, as
    it was before it had a type of its own."""

    code = "OUTPUT_UNSUPPORTED"


class SwpmFormatError(SwpmError):
    """A .swpm file could not be read; ``report`` lists every problem found (see :data:`CATALOGUE`). Its
    ``code`` is ``INPUT_MALFORMED`` (:mod:`swpm_usd.codes`), ``offset`` the first error's."""

    code = "INPUT_MALFORMED"
    format = "swpm"

    def __init__(self, report: Report) -> None:
        self.report = report
        first = report.errors[0] if report.errors else None
        self.file, self.offset = report.path, None if first is None else first.offset
        detail = f"{first.code}: {first.message}" if first else "invalid file"
        more = len(report.errors) - 1
        suffix = f" (+{more} more)" if more > 0 else ""
        super().__init__(f"{report.path or '<file>'}: {detail}{suffix}")


def render_markdown() -> str:
    """``spec/errors.md``: the catalogue as a table (generated; do not edit by hand)."""
    lines = [
        "# SWPM v1 error catalogue",
        "",
        "<!-- Generated from swpm_usd/format/errors.py (`python -m swpm_usd.format.errors`); do not edit -->",
        "",
        "Every problem a reader reports has a stable code, a severity and the absolute byte offset it",
        "concerns (`null` when it concerns the file as a whole); the column *Offset reported* says exactly",
        "which byte that is. A file is valid when it has no `error`. Loading a file with an error raises",
        "`SwpmFormatError` carrying the full report.",
        "",
        "In that column a bare number is an absolute offset into the header; *entry* is the first byte of",
        "the chunk's 32-byte chunk-table entry and *payload* the first byte of the chunk's payload (the",
        "chunk named, else the one the code concerns); W is the index width and O the table width (2 or 4",
        "bytes each: format.md 1). *Element i* of an array is its start + i x element size; LODS row k is",
        "payload + 12 k; WREC window k is payload + 3 O k (4 O k with SW_STRIPS); record r's row in VREC,",
        "SREC or MREC (the record table starts at payload + 8) is payload + 8 + C O r with C = 4 columns",
        "(MREC: 5); SMAP band b is payload + 8 + 24 b. *First* means the",
        "lowest offending index, in the order the array is stored; where a code comes from several checks,",
        "each is listed. This reader lists at most 20 problems of one code; further ones are only counted.",
        "",
        "| Code | Severity | Message template | Meaning | Offset reported |",
        "|---|---|---|---|---|",
    ]
    for e in _ENTRIES:
        template = e.template.replace("|", "/")
        lines.append(f"| `{e.code}` | {e.severity} | {template} | {e.meaning} | {e.offset} |")
    from ..codes import render_markdown as codes_table  # (the other codes of the package, documented here)

    return "\n".join(lines) + "\n\n" + codes_table()


#: the C reader's own codes (runtime/c/swpm_reader.h): answers about the call, not the file, so not in the
#: catalogue above; runtime/c/swpm_codes.h lists them beside it
C_READER_CODES = [
    Entry(
        "SWPM_READER_SCRATCH_TOO_SMALL",
        ERROR,
        "",
        "The replay needs more scratch memory than swpm_open_ex was given (swpm_result.need bytes); the file "
        "is neither accepted nor rejected.",
        "",
    ),
    Entry(
        "SWPM_READER_BAD_RANGES",
        ERROR,
        "",
        "A held range lies past the buffer or past file_size or wraps, held is NULL with a count, or a held "
        "byte changed before finishing: the caller's error, not the file's.",
        "",
    ),
    Entry(
        "SWPM_READER_UNSUPPORTED_ENCODING",
        ERROR,
        "",
        "No longer returned (every encoding is read); defined for code that tests for it.",
        "",
    ),
]


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def render_c_header() -> str:
    """``runtime/c/swpm_codes.h``: every code a reader reports, its severity and meaning, for an engine's
    log (the C reader returns the code alone); generated, do not edit by hand."""
    rows = [
        f"    {{{_c_string(e.code)}, {_c_string(e.severity)},\n     {_c_string(e.meaning)}}},"
        for e in [*_ENTRIES, *C_READER_CODES]
    ]
    return "\n".join(
        [
            "/* swpm_codes.h: every code the SWPM readers report (spec/errors.md), with its severity and",
            " * meaning, for an engine's log: swpm_code_lookup(r.code)->meaning. Header-only, C99 and C++11;",
            " * include it beside swpm_reader.h. Generated from swpm_usd/format/errors.py",
            " * (`python -m swpm_usd.format.errors --c > runtime/c/swpm_codes.h`); do not edit. */",
            "#ifndef SWPM_CODES_H",
            "#define SWPM_CODES_H",
            "",
            "#include <string.h>",
            "",
            "typedef struct swpm_code_info {",
            "    const char *code;     /* the stable code, as swpm_result.code holds it */",
            '    const char *severity; /* "error", "warning" or "info" */',
            "    const char *meaning;  /* one or two sentences: what is wrong */",
            "} swpm_code_info;",
            "",
            f"#define SWPM_CODE_COUNT {len(rows)}",
            "",
            "static const swpm_code_info swpm_codes[SWPM_CODE_COUNT] = {",
            *rows,
            "};",
            "",
            "/* The entry of `code` (a swpm_result's code); NULL for NULL or an unlisted code. */",
            "static inline const swpm_code_info *swpm_code_lookup(const char *code) {",
            "    int i;",
            "    if (code == NULL) return NULL;",
            "    for (i = 0; i < SWPM_CODE_COUNT; i++)",
            "        if (strcmp(swpm_codes[i].code, code) == 0) return &swpm_codes[i];",
            "    return NULL;",
            "}",
            "",
            "#endif /* SWPM_CODES_H */",
            "",
        ]
    )


if __name__ == "__main__":  # pragma: no cover
    import sys

    print(render_c_header() if sys.argv[1:] == ["--c"] else render_markdown(), end="")
