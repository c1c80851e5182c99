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
    """One catalogue entry: ``template`` is a ``str.format`` template over the problem's arguments."""

    code: str
    severity: str
    template: str
    meaning: str


_ENTRIES = [
    # -- file and header ----------------------------------------------------------------------------------
    Entry("SWPM_IO_ERROR", ERROR, "cannot read file: {reason}", "The file could not be opened or mapped."),
    Entry(
        "SWPM_HEADER_TRUNCATED",
        ERROR,
        "file has {size} bytes, the header needs {need}",
        "The file is shorter than the 64-byte header.",
    ),
    Entry(
        "SWPM_HEADER_BAD_MAGIC",
        ERROR,
        "magic is {found}, expected {expected}",
        "The first 8 bytes are not the SWPM signature.",
    ),
    Entry(
        "SWPM_HEADER_UNSUPPORTED_MAJOR",
        ERROR,
        "major version {major} is not supported (this reader: 1)",
        "The major version is not 1; nothing after the version fields can be interpreted.",
    ),
    Entry(
        "SWPM_HEADER_NEWER_MINOR",
        INFO,
        "minor version {minor} is newer than 0; reading the parts v1.0 defines",
        "A newer minor version: only ancillary chunks, flags and reserved fields can differ.",
    ),
    Entry(
        "SWPM_HEADER_BAD_SIZE",
        ERROR,
        "header_size {value} is below 64 or past the end of the file",
        "The header size field is invalid.",
    ),
    Entry(
        "SWPM_HEADER_UNKNOWN_FEATURE",
        ERROR,
        "required-feature bits {bits:#x} are unknown",
        "A required feature this reader does not implement.",
    ),
    Entry(
        "SWPM_HEADER_BAD_ENCODING",
        ERROR,
        "feature bits {bits:#x} must select exactly one encoding",
        "Exactly one of the encoding feature bits must be set.",
    ),
    Entry(
        "SWPM_HEADER_RESERVED_NONZERO",
        WARNING,
        "reserved header field {field} is {value}, expected 0",
        "A reserved header field is not zero.",
    ),
    Entry(
        "SWPM_FILE_SIZE_MISMATCH",
        ERROR,
        "header says {declared} bytes, the file has {actual}",
        "The file is shorter than its header declares (truncated download).",
    ),
    Entry(
        "SWPM_FILE_TRAILING_BYTES",
        WARNING,
        "{extra} bytes follow the declared end of file",
        "The file is longer than declared; the extra bytes are ignored.",
    ),
    Entry(
        "SWPM_CHECKSUM_MISMATCH",
        ERROR,
        "file CRC-32 is {found:#010x}, computed {computed:#010x}",
        "The CRC-32 over header and chunk table does not match.",
    ),
    # -- chunk table --------------------------------------------------------------------------------------
    Entry(
        "SWPM_TABLE_TRUNCATED",
        ERROR,
        "chunk table of {count} entries needs {need} bytes at {at}, the file has {size}",
        "The chunk table runs past the end of the file.",
    ),
    Entry(
        "SWPM_TABLE_TOO_LARGE",
        ERROR,
        "chunk_count {count} exceeds the limit of {limit}",
        "A v1 file has at most 1024 chunks.",
    ),
    Entry(
        "SWPM_TABLE_BAD_OFFSET",
        ERROR,
        "chunk table offset {value} overlaps the header or is misaligned",
        "The chunk table must start at or after the header, on an 8-byte boundary.",
    ),
    Entry(
        "SWPM_CHUNK_BAD_TYPE",
        ERROR,
        "chunk type {type} is not four ASCII letters or digits",
        "A chunk type must be four characters from A-Z, a-z, 0-9.",
    ),
    Entry(
        "SWPM_CHUNK_OUT_OF_BOUNDS",
        ERROR,
        "chunk {type} [{start}, {end}) extends past the end of file ({size})",
        "A chunk's payload lies (partly) outside the file.",
    ),
    Entry(
        "SWPM_CHUNK_MISALIGNED",
        ERROR,
        "chunk {type} starts at {start}, not a multiple of 8",
        "Payloads start on 8-byte boundaries.",
    ),
    Entry(
        "SWPM_CHUNK_OVERLAP",
        ERROR,
        "chunk {type} [{start}, {end}) overlaps {other}",
        "Two chunks, or a chunk and the header or table, share bytes.",
    ),
    Entry(
        "SWPM_CHUNK_OUT_OF_ORDER",
        ERROR,
        "chunk {type} at {start} is listed after a chunk that follows it",
        "Chunk-table entries are listed in increasing offset order.",
    ),
    Entry(
        "SWPM_CHUNK_CRC_MISMATCH",
        ERROR,
        "chunk {type} CRC-32 is {found:#010x}, computed {computed:#010x}",
        "A chunk's CRC-32 over its type and payload does not match.",
    ),
    Entry(
        "SWPM_CHUNK_DUPLICATE",
        ERROR,
        "chunk {type} appears more than once",
        "Every v1 chunk type occurs at most once.",
    ),
    Entry(
        "SWPM_CHUNK_UNKNOWN_CRITICAL",
        ERROR,
        "unknown critical chunk {type}",
        "A chunk marked critical that this reader does not know: the file cannot be decoded.",
    ),
    Entry(
        "SWPM_CHUNK_UNKNOWN_ANCILLARY",
        INFO,
        "unknown ancillary chunk {type} ignored",
        "An ancillary chunk this reader does not know; it is skipped.",
    ),
    Entry(
        "SWPM_CHUNK_MISSING",
        ERROR,
        "required chunk {type} is missing",
        "A chunk the encoding needs is absent.",
    ),
    Entry(
        "SWPM_CHUNK_NOT_ALLOWED",
        ERROR,
        "chunk {type} does not belong to encoding {encoding}",
        "A known chunk of another encoding.",
    ),
    Entry(
        "SWPM_CHUNK_BAD_FLAGS",
        ERROR,
        "chunk {type} has flags {flags:#x}; its critical bit must be {critical}",
        "A known chunk with the wrong critical bit.",
    ),
    Entry(
        "SWPM_CHUNK_BAD_LENGTH",
        ERROR,
        "chunk {type} is {length} bytes, its contents need {need}",
        "A chunk's length does not match the counts it declares.",
    ),
    Entry(
        "SWPM_COUNT_EXCEEDS_CHUNK",
        ERROR,
        "{what} = {count} needs {need} bytes, only {remain} remain in {type}",
        "A count that would need more bytes than remain (checked before anything is allocated).",
    ),
    Entry(
        "SWPM_PADDING_NONZERO",
        ERROR,
        "padding byte(s) at {start} are not zero",
        "Alignment padding between or inside chunks must be zero.",
    ),
    Entry(
        "SWPM_STREAM_ORDER",
        WARNING,
        "chunk {type} is not laid out in streaming order ({reason})",
        "Chunks are not in the coarse-to-fine order of the spec; the file decodes but does not stream.",
    ),
    # -- content ------------------------------------------------------------------------------------------
    Entry(
        "SWPM_META_BAD_JSON",
        ERROR,
        "META is not a UTF-8 JSON object: {reason}",
        "The metadata chunk cannot be decoded.",
    ),
    Entry(
        "SWPM_META_BAD_FIELD", ERROR, "META field {field}: {reason}", "A metadata field has the wrong type."
    ),
    Entry("SWPM_LOD_EMPTY", ERROR, "LODS has no LOD", "At least one LOD is required."),
    Entry(
        "SWPM_LOD_NOT_MONOTONE",
        ERROR,
        "LOD {lod}: {what} is not {order}",
        "Vertex and triangle counts must not increase, errors must not decrease (no NaN).",
    ),
    Entry(
        "SWPM_LOD_VERTEX_COUNT",
        ERROR,
        "LOD {lod} uses {count} vertices, expected {expected}",
        "LOD 0 must use every vertex, no LOD more than there are.",
    ),
    Entry(
        "SWPM_VERT_BAD_LAYOUT",
        ERROR,
        "vertex layout: {reason}",
        "The VERT header or attribute table is invalid.",
    ),
    Entry(
        "SWPM_VERT_NONFINITE",
        WARNING,
        "{count} point coordinate(s) are NaN or infinite",
        "Points should be finite.",
    ),
    Entry(
        "SWPM_INDEX_WIDTH",
        ERROR,
        "value {value} in {what} does not fit the declared index width",
        "A u32 file whose values all fit u16 is allowed; this reports a u16 file that needs u32.",
    ),
    Entry(
        "SWPM_INDEX_OUT_OF_RANGE",
        ERROR,
        "{what} holds {value} at element {index}, limit {limit}",
        "An index at or above the vertex count (or an offset past its list).",
    ),
    Entry(
        "SWPM_WINDOW_OUT_OF_POOL",
        ERROR,
        "window of LOD {lod} [{start}, {end}) lies outside the pool of {pool}",
        "A sliding window that is not inside the index pool.",
    ),
    Entry(
        "SWPM_WINDOW_NOT_MONOTONE",
        ERROR,
        "window of LOD {lod}: {what}",
        "Windows are ordered finest to coarsest with non-increasing triangle counts.",
    ),
    Entry(
        "SWPM_WINDOW_COUNT_MISMATCH",
        ERROR,
        "window of LOD {lod} says {what} {value}, LODS says {expected}",
        "A window's counts differ from the LOD table.",
    ),
    Entry(
        "SWPM_PREFIX_VIOLATION",
        ERROR,
        "LOD {lod} draws vertex {vertex}, but only [0, {limit}) is in use",
        "The vertex prefix property: LOD k draws only vertices below vertex_count_at(k).",
    ),
    Entry(
        "SWPM_RECORD_BAD_KEPT",
        ERROR,
        "record {record} keeps vertex {kept}, not below the binned vertex {binned}",
        "A collapse must keep a vertex that stays in use.",
    ),
    Entry(
        "SWPM_RECORD_BAD_COUNTS",
        ERROR,
        "collapse records: {reason}",
        "Change counts, previous change counts, removed triangles or per-LOD record counts are inconsistent.",
    ),
    Entry(
        "SWPM_RECORD_BAD_CHANGE",
        ERROR,
        "record {record} changes slot {slot}, which does not hold the binned vertex",
        "A change offset must point at a live index slot holding the binned vertex.",
    ),
    Entry("SWPM_LEVEL_BAD_TABLE", ERROR, "skip-strip levels: {reason}", "The level table is inconsistent."),
    Entry(
        "SWPM_MIXED_BAD_LEVELS",
        ERROR,
        "mixed levels: {reason}",
        "The mixed level table (MLVL) is inconsistent with itself, its arrays, MREC or RCNT.",
    ),
    Entry(
        "SWPM_SMAP_INVALID",
        WARNING,
        "streaming map: {reason}",
        "The (ancillary) streaming map is malformed or does not cover what a LOD needs; ignore it.",
    ),
    Entry(
        "SWPM_ENCODING_UNAVAILABLE",
        ERROR,
        "encoding {encoding} has no registered implementation",
        "The file is valid but this installation cannot build its ProgressiveMesh.",
    ),
    Entry(
        "SWPM_BUFFERS_REJECTED",
        ERROR,
        "the {encoding} implementation rejected the buffers: {reason}",
        "from_buffers raised on the decoded arrays.",
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


class SwpmFormatError(SwpmError):
    """A .swpm file could not be read; ``report`` lists every problem found (see :data:`CATALOGUE`)."""

    def __init__(self, report: Report) -> None:
        self.report = report
        first = report.errors[0] if report.errors else None
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
        "concerns (`null` when it concerns the file as a whole). A file is valid when it has no `error`.",
        "Loading a file with an error raises `SwpmFormatError` carrying the full report.",
        "",
        "| Code | Severity | Message template | Meaning |",
        "|---|---|---|---|",
    ]
    for e in _ENTRIES:
        lines.append(f"| `{e.code}` | {e.severity} | {e.template.replace('|', '/')} | {e.meaning} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":  # pragma: no cover
    print(render_markdown(), end="")
