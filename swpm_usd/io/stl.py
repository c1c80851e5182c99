"""The STL checks of the loader: :func:`check_stl` says, before trimesh reads the file, that an STL is cut
short (trimesh takes a binary STL whose length disagrees with its header for ASCII, and drops an ASCII solid
without its ``endsolid``, so a cut file loaded as "no triangles" or as part of its triangles), and
:func:`_stl_ascii_problem` says which row of an ASCII STL trimesh failed on is wrong."""

from __future__ import annotations

import os
import re
from pathlib import Path

from ..errors import MeshLoadError
from .text_rows import _not_numbers, _numbered_rows, _shown

#: a binary STL: an 80-byte header, the triangle count (uint32), then 50 bytes per triangle
_STL_HEADER_BYTES = 84
_STL_TRIANGLE_BYTES = 50


#: how much of an STL's start and end the check looks at (a valid file is not read further)
_STL_PROBE_BYTES = 1 << 16
#: a facet's keywords (``outer loop``: ``outer``), as whole words
_STL_FACET_WORD = re.compile(rb"\b(?:facet|outer|vertex|endloop|endfacet)\b")
_STL_ENDSOLID = re.compile(rb"\bendsolid\b")


def check_stl(path: Path, data: bytes | None = None) -> None:
    """Raise a :class:`MeshLoadError` if the STL file ``path`` (or ``data``, its bytes) is cut short.

    A binary STL must be exactly 84 + 50 x (its header's triangle count) bytes (the test trimesh reads it
    by); anything else is taken for ASCII when its start holds ``solid`` (after a byte-order mark, blanks or
    a comment, in any case) and no NUL byte (trailing NUL padding aside). A file that is neither is reported
    with the sizes: expected by its header against actual. An ASCII STL must close its last facet with an
    ``endsolid``: text whose last facet keyword comes after its last ``endsolid`` line is reported with the
    line it stops at (a solid's name, on the ``endsolid`` line, may hold any word).

    Only the file's size and its first and last 64 KiB are read (a cut ASCII file is then read through, in
    chunks, for the message): a large valid file is not read into memory for the check.
    """
    if data is None:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            head = f.read(_STL_PROBE_BYTES)
            f.seek(max(size - _STL_PROBE_BYTES, 0))
            tail = f.read()
    else:
        size, head, tail = len(data), data[:_STL_PROBE_BYTES], data[-_STL_PROBE_BYTES:]
    _check_stl(path, size, head, tail, data)


def _stl_text_counts(path: Path, data: bytes | None) -> tuple[int, int]:
    """(lines, complete facets) of an ASCII STL, read in chunks."""
    if data is not None:
        return data.count(b"\n") + (not data.endswith(b"\n")), data.lower().count(b"endfacet")
    lines = facets = 0
    carry = last = b""
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            lines += chunk.count(b"\n")
            low = carry + chunk.lower()
            facets += low.count(b"endfacet")  # (carry is shorter than the word: none is counted twice)
            carry, last = low[-7:], chunk[-1:]
    return lines + (last != b"\n"), facets


def _check_stl(path: Path, size: int, head: bytes, tail: bytes, data: bytes | None) -> None:
    if size >= _STL_HEADER_BYTES:
        count = int.from_bytes(head[80:84], "little")
        expected = _STL_HEADER_BYTES + _STL_TRIANGLE_BYTES * count
        if size == expected:
            return
    head = head.rstrip(b"\x00\x1a \t\r\n")
    if b"solid" in head.lower() and b"\x00" not in head:
        tail = tail.rstrip(b"\x00\x1a \t\r\n").lower()
        ends = list(_STL_ENDSOLID.finditer(tail))
        after = tail
        if ends:
            line_end = tail.find(b"\n", ends[-1].end())
            after = b"" if line_end < 0 else tail[line_end:]
        if _STL_FACET_WORD.search(after):  # a facet after the last endsolid, or no endsolid at all
            lines, facets = _stl_text_counts(path, data)
            raise MeshLoadError(
                path,
                f"truncated ASCII STL: the text stops at line {lines} after {facets} "
                f"complete facets, without the closing 'endsolid'",
            )
        return
    if size == 0:
        raise MeshLoadError(path, "no triangles: the file is empty (0 bytes)", code="INPUT_EMPTY")
    if size < _STL_HEADER_BYTES:
        raise MeshLoadError(
            path,
            f"truncated binary STL: {size} bytes, shorter than the {_STL_HEADER_BYTES}-byte header "
            f"(and not ASCII STL: it does not start with 'solid')",
        )
    what = f"header says {count} triangles ({expected} bytes), the file has {size} bytes"
    if b"\x00" not in head:  # text, but no 'solid'
        raise MeshLoadError(
            path, f"not an STL file: not ASCII STL (no 'solid' at the start) nor binary STL ({what})"
        )
    if size < expected:
        raise MeshLoadError(path, f"truncated binary STL: {what}")
    raise MeshLoadError(path, f"not a valid binary STL: {what} ({size - expected} bytes too many)")


_STL_NUMBERS = {b"vertex": 3, b"normal": 3}


def _stl_ascii_problem(data: bytes) -> str | None:
    """What is wrong with a row of the ASCII STL file of bytes ``data`` (a ``vertex`` or ``facet normal``
    row whose values are not 3 numbers, a facet without 3 vertices), or None (asked once trimesh has failed
    on it: "string or file could not be read to its end", "incorrect number of vertices")."""
    if data.lstrip()[:5].lower() != b"solid":
        return None
    corners = None
    for number, words in _numbered_rows(data):
        key = words[0].lower()
        values = words[2:] if key == b"facet" else words[1:]
        if key == b"facet" or key == b"vertex":
            bad = _not_numbers(values)
            if bad is not None:
                return f"line {number}: a '{key.decode()}' row holds {_shown(bad)}, not a number"
            if len(values) != 3 and (key == b"vertex" or values):
                return f"line {number}: a '{key.decode()}' row holds {len(values)} values, not 3"
        if key == b"facet":
            corners = 0
        elif key == b"vertex":
            corners = (corners or 0) + 1
        elif key == b"endfacet":
            if corners != 3:
                return f"line {number}: a facet of {corners or 0} vertices, not 3"
            corners = None
    return None
