"""The PLY reading the loader does around trimesh's: the header parsed (:func:`_ply_header`), an element's
rows counted against it (:func:`ply_problem`: trimesh loads the rows of a cut ASCII file without a word, and
says only "PLY is unexpected length!" of a cut binary one), faces of varying corner counts fan-triangulated
before trimesh reads them (:func:`ply_polygons_as_triangles`: it read such lists wrongly), and what is wrong
with a header or an ASCII row trimesh failed on (:func:`_ply_header_problem`, :func:`_ply_ascii_problem`)."""

from __future__ import annotations

import re
import struct

import numpy as np

from .text_rows import _not_numbers, _shown, _undecoded

#: PLY scalar types (both spellings) -> numpy dtype
_PLY_TYPES = {
    **dict.fromkeys(("char", "int8"), "i1"),
    **dict.fromkeys(("uchar", "uint8"), "u1"),
    **dict.fromkeys(("short", "int16"), "i2"),
    **dict.fromkeys(("ushort", "uint16"), "u2"),
    **dict.fromkeys(("int", "int32"), "i4"),
    **dict.fromkeys(("uint", "uint32"), "u4"),
    **dict.fromkeys(("float", "float32"), "f4"),
    **dict.fromkeys(("double", "float64"), "f8"),
}
#: the struct format character of each of the PLY types above
_STRUCT_CODES = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I", "f4": "f", "f8": "d"}
#: how much of a PLY's start the header is looked for in
_PLY_HEADER_BYTES = 1 << 16
#: the rows of a binary element with lists of varying length counted one by one at most (past it the
#: message gives no count)
_PLY_ROW_WALK = 2_000_000

#: a PLY property: (dtype) for a scalar, (count dtype, item dtype) for a list
_PlyProperty = tuple[str] | tuple[str, str]


def _ply_header(head: bytes) -> tuple[str, int, list[tuple[str, int, list[_PlyProperty]]]] | None:
    """(format, header length in bytes, [(element, count, properties)]) of a PLY file's start ``head``, or
    None when it is not a header this check understands (trimesh then says what is wrong)."""
    end = re.search(rb"(?m)^end_header[ \t]*\r?\n", head)
    if not head.startswith(b"ply") or end is None:
        return None
    fmt = None
    elements: list[tuple[str, int, list[_PlyProperty]]] = []
    # (lines split at '\n' alone, as trimesh reads them: splitlines() also splits at '\x1c'-'\x1e', '\x85')
    for line in head[: end.start()].decode("ascii", "replace").split("\n")[1:]:
        words = line.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) >= 2:
            fmt = words[1]
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements and len(words) == 3 and words[1] in _PLY_TYPES:
            elements[-1][2].append((_PLY_TYPES[words[1]],))
        elif (
            words[0] == "property"
            and elements
            and len(words) == 5
            and words[1] == "list"
            and words[2] in _PLY_TYPES
            and words[3] in _PLY_TYPES
        ):
            elements[-1][2].append((_PLY_TYPES[words[2]], _PLY_TYPES[words[3]]))
        else:
            return None
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        return None
    return fmt, end.end(), elements


def _ply_ascii_rows(tokens: list[bytes], at: int, count: int, props: list[_PlyProperty]) -> tuple[int, int]:
    """(complete rows, token index after them) of an ASCII element of ``count`` rows from ``tokens[at]``."""
    if all(len(p) == 1 for p in props):
        width = len(props)
        rows = count if width == 0 else min(count, (len(tokens) - at) // width)
        return rows, at + rows * width
    rows = 0
    while rows < count:
        i = at
        for p in props:
            if i >= len(tokens):
                return rows, at
            if len(p) == 1:
                i += 1
                continue
            try:
                n = int(float(tokens[i]))
            except (ValueError, OverflowError):  # (not a number, nan, inf, 1e400: no count)
                return rows, at
            i += 1 + max(n, 0)
        if i > len(tokens):
            return rows, at
        rows, at = rows + 1, i
    return rows, at


def _ply_binary_rows(
    data: bytes, at: int, count: int, props: list[_PlyProperty], order: str
) -> tuple[int | None, int]:
    """(complete rows, byte offset after them) of a binary element of ``count`` rows from ``data[at]``; None
    rows when its lists vary in length past :data:`_PLY_ROW_WALK` rows."""
    sizes = [np.dtype(p[0]).itemsize for p in props]
    if all(len(p) == 1 for p in props):
        width = sum(sizes)
        rows = count if width == 0 else min(count, (len(data) - at) // width)
        return rows, at + rows * width
    rows, at = _ply_uniform_rows(data, at, count, props, order)
    walked = 0
    while rows < count:
        if walked >= _PLY_ROW_WALK:
            return None, at
        walked += 1
        i = at
        for p, size in zip(props, sizes, strict=True):
            if i + size > len(data):
                return rows, at
            if len(p) == 2:
                value = np.frombuffer(data, order + p[0], 1, i)[0]
                if not np.isfinite(value):  # (a float count: nan or inf is no count)
                    return rows, at
                i += np.dtype(p[1]).itemsize * max(int(value), 0)
            i += size
        if i > len(data):
            return rows, at
        rows, at = rows + 1, i
    return rows, at


def _ply_uniform_rows(
    data: bytes, at: int, count: int, props: list[_PlyProperty], order: str
) -> tuple[int, int]:
    """(rows, byte offset after them) of the rows of a binary element from ``data[at]`` whose lists all have
    the first row's lengths (a mesh's faces, all triangles), counted at once in a strided look (one by one,
    2,000,000 faces took 3 s); the rows after them are walked."""
    lists = []
    i = at
    for p in props:
        size = np.dtype(p[0]).itemsize
        if i + size > len(data):
            return 0, at
        if len(p) == 2:
            value = np.frombuffer(data, order + p[0], 1, i)[0]
            if not np.isfinite(value):
                return 0, at
            lists.append((i - at, p[0], value))
            size += np.dtype(p[1]).itemsize * max(int(value), 0)
        i += size
    stride = i - at
    n = min(count, (len(data) - at) // stride)
    if n <= 0:
        return 0, at
    same = np.ones(n, bool)
    for offset, dtype, value in lists:
        same &= np.ndarray((n,), order + dtype, buffer=data, offset=at + offset, strides=(stride,)) == value
    n = n if same.all() else int(np.argmin(same))
    return n, at + n * stride


def ply_problem(data: bytes, ascii_only: bool = False) -> str | None:
    """Why the PLY file of bytes ``data`` holds fewer element rows than its header declares ("truncated ASCII
    PLY: element face declares 80, found 75"), or more bytes (binary), or None when it holds them all or its
    header is not one this check reads (trimesh then reports the file); ``ascii_only``: None for a binary one.

    An ASCII file is counted row by row (tokens, whatever the lines) only when it has fewer lines than rows
    declared (trimesh loads the rows of a cut ASCII file without a word, and says "no triangles" when its
    vertices are cut); a binary one, whose length trimesh checks, is for the message once trimesh has refused
    it ("PLY is unexpected length!")."""
    header = _ply_header(data[:_PLY_HEADER_BYTES])
    if header is None or (ascii_only and header[0] != "ascii"):
        return None
    fmt, at, elements = header
    declared = sum(count for _, count, _ in elements)
    if fmt == "ascii":
        # (its lines: a last line without its line end counts too)
        lines = data.count(b"\n", at) + (not data.endswith(b"\n") and len(data) > at)
        if lines >= declared:
            return None
        tokens = data[at:].split()
        i = 0
        for name, count, props in elements:
            rows, i = _ply_ascii_rows(tokens, i, count, props)
            if rows < count:
                return f"truncated ASCII PLY: element {name} declares {count}, found {rows}"
        return None
    order = "<" if fmt == "binary_little_endian" else ">"
    for name, count, props in elements:
        rows, at = _ply_binary_rows(data, at, count, props, order)
        if rows is None:  # (not counted)
            return None
        if rows < count:
            return f"truncated binary PLY: element {name} declares {count}, found {rows} ({len(data)} bytes)"
    if at < len(data):
        return f"not a valid binary PLY: {len(data) - at} bytes after the elements its header declares"
    return None


def ply_ascii_short(data: bytes) -> str | None:
    """The first row of an ASCII PLY file of bytes ``data`` whose list (``vertex_indices``) holds fewer values
    than it declares, in :func:`_ply_ascii_problem`'s words, or None (a binary file, or a header this does not
    read). trimesh reads a row a line and takes the values there are: a face row ``4 0 2 1`` was the triangle
    0 2 1, and a file cut inside its last row (as many lines as rows, so :func:`ply_problem` does not count
    them) loaded without that face, no word said. A row of more values than its properties is left to
    trimesh. Bunny as ASCII PLY: 27 ms of its 270 ms load."""
    header = _ply_header(data[:_PLY_HEADER_BYTES])
    if header is None or header[0] != "ascii":
        return None
    _, at, elements = header
    lines = data.split(b"\n")  # (the whole file's: data[at:] copied the body to split it)
    first = data.count(b"\n", 0, at)  # (the header's lines, each ended by one)
    for name, count, props in elements:
        lists = [j for j, p in enumerate(props) if len(p) == 2]
        if len(lists) == 1:
            li, fixed = lists[0], len(props) - 1
            for k, line in enumerate(lines[first : first + count]):
                words = line.split()
                try:
                    declared = int(words[li]) if li < len(words) else -1
                except ValueError:
                    return None  # (not a whole number: trimesh's or _ply_ascii_problem's to report)
                if declared < 0 or len(words) - 1 - fixed < declared:
                    number = first + k + 1
                    listed = max(len(words) - 1 - fixed, 0)
                    return (
                        f"not a valid PLY file: line {number}: {name} {k} declares {declared} values and "
                        f"lists {listed}"
                    )
        first += count
    return None


def _fan(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(face, its second corner's place in its list) of each fan triangle of faces of ``counts`` corners."""
    n_tris = np.maximum(counts - 2, 0)
    face = np.repeat(np.arange(counts.shape[0]), n_tris)
    return face, np.arange(face.shape[0]) - np.repeat(np.cumsum(n_tris) - n_tris, n_tris) + 1


def ply_polygons_as_triangles(data: bytes) -> bytes | None:
    """The PLY file of bytes ``data`` with its faces fan-triangulated (each triangle keeping its face's other
    properties) when their vertex lists vary in length; None when they do not, or the file is not one this
    reads (a face element with other than one list, rows cut short: trimesh then reports it).

    trimesh reads a binary PLY's lists at the first row's length (a mesh of triangles and quads was "PLY is
    unexpected length!") and an ASCII one's face properties after lists of varying length from the wrong
    columns (a mixed mesh's face colours came out as other colours)."""
    header = _ply_header(data[:_PLY_HEADER_BYTES])
    names = [] if header is None else [name for name, _, _ in header[2]]
    if header is None or "face" not in names:
        return None
    fmt, at, elements = header
    face_at = names.index("face")
    _, count, props = elements[face_at]
    lists = [j for j, p in enumerate(props) if len(p) == 2]
    if len(lists) != 1 or count == 0:
        return None
    li = lists[0]
    if fmt == "ascii":  # (a row a line, as trimesh reads it)
        lines = data[at:].splitlines()
        first = sum(n for _, n, _ in elements[:face_at])
        if li == 0 and len({line.split(None, 1)[0] for line in lines[first : first + count] if line}) <= 1:
            return None  # (every list of one length, the common case told at once)
        faces = []
        for line in lines[first : first + count]:
            words = line.split()
            try:
                c = max(int(words[li]), 0) if li < len(words) else -1
            except ValueError:
                return None
            if c < 0 or len(words) != len(props) + c:
                return None
            faces.append((words[:li], words[li + 1 : li + 1 + c], words[li + 1 + c :]))
        if len(faces) < count:
            return None
        counts = np.array([len(corners) for _, corners, _ in faces], np.int64)
        if (counts == counts[0]).all():
            return None
        rows = []
        for f, k in zip(*(a.tolist() for a in _fan(counts)), strict=True):
            before, corners, after = faces[f]
            rows.append(b" ".join([*before, b"3", corners[0], corners[k], corners[k + 1], *after]))
        body = [*lines[:first], *rows, *lines[first + count :]]
        out = data[:at] + b"\n".join(body) + b"\n"
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        i = at
        for _, n, ps in elements[:face_at]:
            rows, i = _ply_binary_rows(data, i, n, ps, order)
            if rows is None or rows < n:
                return None
        uniform, _ = _ply_uniform_rows(data, i, count, props, order)
        if uniform == count:  # (every list the first's length: trimesh reads it)
            return None
        sizes = [np.dtype(p[0]).itemsize for p in props]
        pre, post = sum(sizes[:li]), sum(sizes[li + 1 :])
        count_type, item_type = np.dtype(order + props[li][0]), np.dtype(order + props[li][1])
        if count > (len(data) - i) // (pre + count_type.itemsize + post):
            return None  # (cut short: no array of the header's count for it)
        # (struct, not np.frombuffer, a row: 1,000,000 mixed faces took 2 s)
        read_count = struct.Struct(order + _STRUCT_CODES[props[li][0]]).unpack_from
        starts_list, counts_list = [0] * count, [0] * count
        end, fixed, width, size = i, pre + count_type.itemsize + post, item_type.itemsize, len(data)
        floating = count_type.kind == "f"
        for r in range(count):
            if end + fixed > size:
                return None
            (c,) = read_count(data, end + pre)
            if floating:
                if not np.isfinite(c):
                    return None
                c = int(c)
            if c < 0:
                c = 0
            starts_list[r], counts_list[r] = end, c
            end += fixed + c * width
        if end > size:
            return None
        starts = np.array(starts_list, np.int64)
        counts = np.array(counts_list, np.int64)
        face, k = _fan(counts)
        raw = np.frombuffer(data, np.uint8)
        width = item_type.itemsize
        items = starts[face] + pre + count_type.itemsize
        three = np.frombuffer(np.array([3], count_type).tobytes(), np.uint8)
        columns = [raw[starts[face][:, None] + np.arange(pre)], np.tile(three, (face.shape[0], 1))]
        columns += [
            raw[(items + c * width)[:, None] + np.arange(width)] for c in (np.zeros_like(k), k, k + 1)
        ]
        columns.append(raw[(items + counts[face] * width)[:, None] + np.arange(post)])
        out = data[:i] + np.concatenate(columns, axis=1).tobytes() + data[end:]
    n_tris = str(int(np.maximum(counts - 2, 0).sum())).encode()
    return re.sub(rb"(?m)^(element[ \t]+face[ \t]+)\d+", rb"\g<1>" + n_tris, out[:at], count=1) + out[at:]


def _ply_ascii_problem(data: bytes) -> str | None:
    """What is wrong with a row of the ASCII PLY file of bytes ``data`` (a value that is not a number, a row
    of another length than its element's properties), or None (asked once trimesh has failed on it:
    "string or file could not be read to its end", "setting an array element with a sequence")."""
    header = _ply_header(data[:_PLY_HEADER_BYTES])
    if header is None or header[0] != "ascii":
        return None
    _, at, elements = header
    lines = iter(data[at:].split(b"\n"))
    number = data[:at].count(b"\n")
    for name, count, props in elements:
        fixed = all(len(p) == 1 for p in props)
        for k in range(count):
            line = next(lines, None)
            number += 1
            if line is None:
                return None  # (cut short: ply_problem's)
            words = line.split()
            bad = _not_numbers(words)
            if bad is not None:
                return f"line {number}: {name} {k} holds {_shown(bad)}, not a number"
            if fixed and len(words) != len(props):
                return f"line {number}: {name} {k} holds {len(words)} values, its element has {len(props)}"
            if not fixed and len(props) == 1 and words and len(words) != 1 + int(float(words[0])):
                declared = int(float(words[0]))
                return f"line {number}: {name} {k} declares {declared} values and lists {len(words) - 1}"
    return None


def _ply_header_problem(data: bytes) -> str | None:
    """What is wrong with the header of the PLY file of bytes ``data`` (no 'ply' line, no 'end_header', a
    byte that is not ASCII, a line that is not a PLY header line, a type or a count that is not one), with
    its line; or None (asked once trimesh has failed on it: "Not a ply file!", "'utf-8' codec can't
    decode byte 0xec in position 0", "PLY is unexpected length!", a KeyError of a type)."""
    if not data.startswith(b"ply"):
        return f"not a PLY file: it starts with {data[:8]!r}, not b'ply'"
    if data.startswith(b"ply\r") and not data.startswith(b"ply\r\n"):  # (trimesh: "no end_header")
        return "not a valid PLY file: its lines end in CR alone (classic Mac OS), not LF or CRLF"
    end = re.search(rb"(?m)^end_header[ \t]*\r?$", data[:_PLY_HEADER_BYTES])
    if end is None:
        within = f" in its first {_PLY_HEADER_BYTES} bytes" if len(data) > _PLY_HEADER_BYTES else ""
        return f"not a valid PLY file: no 'end_header' line{within}"
    head = data[: end.start()]
    try:
        text = head.decode("ascii")
    except UnicodeDecodeError as e:
        return f"not a valid PLY file: its header's {_undecoded(head, 0, e).replace('UTF-8', 'ASCII')}"
    elements: dict[str, list[str]] = {}  # {element: its properties' names}
    for number, line in enumerate(text.split("\n"), 1):
        words = line.split()
        if number == 1:
            if line.strip() != "ply":
                return f"not a valid PLY file: line 1 is {line[:40]!r}, not 'ply'"
            continue
        shown = repr(line.strip()[:60])
        if "end_header" in words:  # (trimesh ends the header at any line holding the word, a comment too)
            return f"not a valid PLY file: line {number}: {shown} holds 'end_header' before the header's end"
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format":
            if len(words) != 3 or words[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                return f"not a valid PLY file: line {number}: {shown} is not a PLY format"
        elif words[0] == "element":
            if len(words) != 3 or not words[2].isdigit():
                return f"not a valid PLY file: line {number}: {shown} is not 'element NAME COUNT'"
            elements[words[1]] = []
        elif words[0] == "property":
            if not elements:
                return f"not a valid PLY file: line {number}: {shown} is a property before any element"
            listed = len(words) == 5 and words[1] == "list"
            types = words[2:4] if listed else words[1:2] if len(words) == 3 else []
            bad = [t for t in types if t not in _PLY_TYPES]
            if not types or bad:
                what = f"{bad[0]!r} is not a PLY type" if bad else "not 'property TYPE NAME'"
                if not bad and words[1] == "list":
                    what = "not 'property list COUNT_TYPE ITEM_TYPE NAME'"
                return f"not a valid PLY file: line {number}: {shown}: {what}"
            elements[list(elements)[-1]].append(words[-1])
        else:
            return f"not a valid PLY file: line {number}: {shown} is not a PLY header line"
    if not re.search(rb"(?m)^format ", head):
        return "not a valid PLY file: its header has no 'format' line"
    missing = [c for c in ("x", "y", "z") if c not in elements.get("vertex", ["x", "y", "z"])]
    if missing:
        return f"not a valid PLY file: its element vertex has no property {missing[0]!r}"
    face = elements.get("face", ["vertex_indices"])
    named = {"vertex_indices", "vertex_index"} & set(face)  # (trimesh's names; a binary one's only list too)
    if not named and (len(face) > 1 or re.search(rb"(?m)^format[ \t]+ascii", head)):
        return "not a valid PLY file: its element face has no property 'vertex_indices' (nor 'vertex_index')"
    return None
