"""The OFF handling of the loader around trimesh's reader: the vertex and face colours trimesh's OFF reader
drops, read from the file (:func:`_off_colours`: ``COFF`` vertex colours, values after a face's indices),
and what is wrong with the header or a row trimesh failed on (:func:`_off_problem`)."""

from __future__ import annotations

import io
import re
from collections.abc import Iterator

import numpy as np

from .clean import rgba_float
from .text_rows import _not_numbers, _numbered_rows, _shown

_OFF_HEADER = re.compile(rb"(ST)?C?N?4?n?OFF", re.IGNORECASE)


def _counts_row(
    first: tuple[int, list[bytes]], rows: Iterator[tuple[int, list[bytes]]]
) -> tuple[int, list[bytes]]:
    """(line, tokens) of an OFF file's counts, given its first row ``first`` (the header word's) and the rows
    after it: the rest of that row ('OFF V F E' on one line), else the next row (``first``'s line and no
    token when there is none)."""
    return (first[0], first[1][1:]) if len(first[1]) > 1 else next(rows, (first[0], []))


def _off_problem(data: bytes) -> str | None:
    """What is wrong with the header or a row of the OFF file of bytes ``data`` (counts that are not whole
    numbers; a vertex row of too few values, or one that is not a number; a face row whose corner count or
    index is not a whole number, with fewer corners than it declares, or an index to no vertex), or None
    (asked once trimesh has failed on it: "invalid literal for int() with base 10: '0.5'", "setting an array
    element with a sequence", "cannot reshape array of size 14 into shape (5,3)")."""
    rows = _numbered_rows(data)
    first = next(rows, None)
    if first is None:
        return None
    if _OFF_HEADER.fullmatch(first[1][0]) is None:
        return f"line {first[0]}: {_shown(first[1][0])} is not 'OFF' (nor a variant of it: COFF, NOFF...)"
    number, counts = _counts_row(first, rows)
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
        if len(counts) > 2:
            int(counts[2])  # (the edge count: trimesh reads it as a whole number too)
    except (IndexError, ValueError):
        return f"line {number}: the counts line {_shown(b' '.join(counts))} is not vertices, faces, edges"
    if n_vertices < 0 or n_faces < 0:  # (trimesh read none: "no triangles")
        return f"line {number}: the counts line {_shown(b' '.join(counts))} holds a negative count"
    for k in range(n_vertices):
        number, words = next(rows, (None, []))
        if number is None:
            return f"the header declares {n_vertices} vertices, the file has {k}"
        bad = _not_numbers(words[:3])
        if bad is not None:
            return f"line {number}: vertex {k} holds {_shown(bad)}, not a number"
        if len(words) < 3:
            return f"line {number}: vertex {k} holds {len(words)} values, not 3"
    for k in range(n_faces):
        number, words = next(rows, (None, []))
        if number is None:
            return f"the header declares {n_faces} faces, the file has {k}"
        try:
            corners = [int(w) for w in words[: 1 + max(int(words[0]), 0)]]
        except ValueError:
            return f"line {number}: face {k}: {_shown(b' '.join(words[:8]))} are not whole numbers"
        if len(corners) - 1 < corners[0] or corners[0] < 3:
            return f"line {number}: face {k} declares {corners[0]} corners and lists {len(words) - 1} values"
        out = [i for i in corners[1:] if not 0 <= i < n_vertices]
        if out:
            return f"line {number}: face {k} refers to vertex {out[0]}, the file has {n_vertices}"
    return None


def _off_short(data: bytes) -> str | None:
    """What an OFF file of bytes ``data`` that trimesh read lacks, or None: face rows past its last (the
    header's count more than the file holds: a cut file) or a face row listing fewer indices than it
    declares. trimesh takes what there is (its slice of rows, each row's slice of indices), so a file cut
    in its faces loaded as a smaller mesh, no word said. Its other problems are :func:`_off_problem`'s
    (asked when trimesh fails); faces of fewer than 3 corners trimesh drops are left to it."""
    if b"#" not in data and _off_whole(data):
        return None
    rows = _numbered_rows(data)
    first = next(rows, None)
    if first is None:
        return None
    number, counts = _counts_row(first, rows)
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
    except (IndexError, ValueError):
        return None  # (trimesh read it: nothing of ours to say)
    if n_vertices < 0 or n_faces < 0:
        return f"line {number}: the counts line {_shown(b' '.join(counts))} holds a negative count"
    for _ in range(max(n_vertices, 0)):
        if next(rows, None) is None:
            return None  # (trimesh checks the vertices' count)
    for k in range(max(n_faces, 0)):
        number, words = next(rows, (None, []))
        if number is None:
            return f"the header declares {n_faces} faces, the file has {k}"
        try:
            declared = int(words[0])
        except ValueError:
            continue
        if len(words) - 1 < declared:
            return f"line {number}: face {k} declares {declared} corners and lists {len(words) - 1} values"
    return None


def _off_fanned(text: bytes) -> bytes | None:
    """The OFF text ``text`` (no comments) with each face of more than 4 corners as its fan of triangle rows
    (0, k, k + 1) and the header's face count to match, for trimesh to read; None when it has no such face,
    or a row this does not read (trimesh's and :func:`_off_problem`'s to report). trimesh reads triangles and
    quads but fails on polygons of 5 or more corners beside faces of another count ("The 'out' kwarg is
    necessary when using the string multiply ufunc directly"): asked only then, so a file trimesh reads is
    read as before. Values after a face's indices (its colour) are left out: :func:`_off_colours` reads
    them from the file."""
    lines = text.split(b"\n")
    rows = ((i, line.split()) for i, line in enumerate(lines))
    rows = ((i, words) for i, words in rows if words)
    first = next(rows, None)
    if first is None or _OFF_HEADER.fullmatch(first[1][0]) is None:
        return None
    at, counts = _counts_row(first, rows)
    head = first[1][:1] if at == first[0] else []  # ('OFF V F E' on one line: the line keeps its word)
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
    except (IndexError, ValueError):
        return None
    for _ in range(max(n_vertices, 0)):
        if next(rows, None) is None:
            return None
    fanned = False
    extra = 0
    for _ in range(max(n_faces, 0)):
        i, words = next(rows, (None, []))
        if i is None:
            return None
        try:
            corners = [int(w) for w in words[: 1 + int(words[0])]]
        except ValueError:
            return None
        n = corners[0]
        if n > 4 and len(corners) == n + 1:
            c = corners[1:]
            lines[i] = b"\n".join(b"3 %d %d %d" % (c[0], c[k], c[k + 1]) for k in range(1, n - 1))
            fanned, extra = True, extra + n - 3
    if not fanned:
        return None
    lines[at] = b" ".join([*head, str(n_vertices).encode(), str(n_faces + extra).encode(), *counts[2:]])
    return b"\n".join(lines)


_BLANK = np.zeros(256, bool)  # (what bytes.split() splits at)
_BLANK[list(b" \t\n\r\x0b\x0c")] = True


def _off_whole(data: bytes) -> bool:
    """True when the OFF file of bytes ``data`` (no comment in it) certainly holds every face row its header
    declares, each listing at least the indices it declares: :func:`_off_short`'s rows and tokens in numpy
    (bunny: 10 ms, its loop 43 ms); False when it may not, for that loop to tell."""
    a = np.frombuffer(data, np.uint8)
    blank = _BLANK[a]
    starts = np.flatnonzero(~blank & np.concatenate(([True], blank[:-1])))  # (each token's first byte)
    ends = np.flatnonzero(~blank & np.append(blank[1:], True))  # (and its last)
    if starts.shape[0] < 3:
        return False
    # (the line of each token: the newlines before it; a cumsum over the bytes held 8 bytes a byte)
    line = np.searchsorted(np.flatnonzero(a == ord("\n")), starts)
    row = np.concatenate(([0], np.flatnonzero(line[1:] != line[:-1]) + 1))  # (each row's first token)
    tokens = np.diff(np.append(row, starts.shape[0]))
    head = 1 if tokens[0] > 1 else 2  # ('OFF V F E', or 'OFF' then the counts)
    if row.shape[0] < head:
        return False
    at = 1 if head == 1 else int(row[1])
    try:
        n_vertices, n_faces = (int(data[starts[at + i] : ends[at + i] + 1]) for i in (0, 1))
    except (IndexError, ValueError):
        return False
    at = head + max(n_vertices, 0)
    faces = row[at : at + max(n_faces, 0)]
    if faces.shape[0] < max(n_faces, 0):
        return False
    first, last = starts[faces], ends[faces]
    width = last - first + 1
    if faces.shape[0] == 0 or width.max() > 9:
        return faces.shape[0] == 0
    declared = np.zeros(faces.shape[0], np.int64)
    for k in range(int(width.max())):  # (each row's first token, a whole number of at most 9 digits)
        digit = a[np.minimum(first + k, last)].astype(np.int64) - ord("0")
        if ((digit < 0) | (digit > 9)).any():
            return False
        declared = np.where(k < width, declared * 10 + digit, declared)
    return bool((tokens[at : at + faces.shape[0]] - 1 >= declared).all())


def _off_rows(data: bytes) -> Iterator[list[bytes]]:
    """The tokens of each non-empty line of an OFF file, comments left out, lazily."""
    for line in io.BytesIO(data):
        words = line.split(b"#", 1)[0].split()
        if words:
            yield words


def _off_colour_values(rows: list[list[bytes]]) -> np.ndarray | None:
    """The colours ``rows`` (each row's tokens) hold as (N, 4) float RGBA in [0, 1]: integers 0-255 (all of
    them integers) or floats in [0, 1], 3 or 4 per row; None when the rows differ in length, hold another
    count (a colour-map index) or a token that is not a number."""
    k = {len(r) for r in rows}
    if len(k) != 1 or k.pop() not in (3, 4):
        return None
    try:
        values = np.array([[float(t) for t in r] for r in rows], dtype=np.float64)
    except ValueError:
        return None
    if not np.isfinite(values).all():
        return None
    if all(t.lstrip(b"+-").isdigit() for r in rows for t in r):
        values = values / 255.0
    return rgba_float(values)


def _off_may_have_colours(data: bytes) -> bool:
    """Whether the OFF file's bytes ``data`` may hold colours (``COFF``, values after its first vertex's x y
    z or after its last face's indices: a writer colours every row or none), looked at without reading every
    row."""
    rows = _off_rows(data)
    first = next(rows, None)
    if first is None or first[0].upper() == b"COFF":
        return first is not None
    if len(first) == 1:
        next(rows, None)  # (the counts)
    vertex = next(rows, None)
    if vertex is not None and len(vertex) > 3:
        return True
    end = len(data)
    while end > 0:  # (its lines from the last, not every line split: a copy of the file in small objects)
        start = data.rfind(b"\n", 0, end) + 1
        words = data[start:end].split(b"#", 1)[0].split()
        end = start - 1
        if words:
            try:
                return len(words) > 1 + int(words[0])
            except ValueError:
                return True
    return False


def _off_colours(data: bytes, faces: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None, list[str]]:
    """(vertex colours (V, 4), colours of trimesh's triangles ``faces`` (T, 4), colours found but not
    kept) of an OFF file's bytes ``data``: a vertex's colour (``COFF``, ``CNOFF``, ``STCOFF``...) and the
    values after a face's vertex indices, which trimesh's OFF reader drops. A face's colour goes to each
    triangle of its fan
    (trimesh triangulates it so, in another order: triangles are matched by their vertices)."""
    if not _off_may_have_colours(data):
        return None, None, []
    rows = list(_off_rows(data))
    # the variants' vertex rows: x y z [nx ny nz (N)] [colour (C)] [s t (ST)] (4OFF, nOFF: other rows)
    variant = re.fullmatch(rb"(ST)?(C)?(N)?OFF", rows[0][0].upper()) if rows else None
    if variant is None:
        return None, None, []
    texture, colour, normal = (g is not None for g in variant.groups())
    at = 1 if len(rows[0]) > 1 else 2
    counts = rows[0][1:] if len(rows[0]) > 1 else (rows[1] if len(rows) > 1 else [])
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
    except (IndexError, ValueError):
        return None, None, []
    vertex_rows = rows[at : at + n_vertices]
    face_rows = rows[at + n_vertices : at + n_vertices + n_faces]
    if len(vertex_rows) != n_vertices or len(face_rows) != n_faces:
        return None, None, []
    lost: list[str] = []
    vertex_colours = None
    first, last = 3 + 3 * normal, 2 * texture
    if (colour or not (normal or texture)) and any(len(r) > first + last for r in vertex_rows):
        vertex_colours = _off_colour_values([r[first : len(r) - last] for r in vertex_rows])
        if vertex_colours is None:
            lost.append("vertex colours")
    try:
        sizes = np.array([int(r[0]) for r in face_rows], np.int64)
    except ValueError:
        return vertex_colours, None, lost
    extra = [r[1 + n :] for r, n in zip(face_rows, sizes.tolist(), strict=True)]
    if not any(extra):
        return vertex_colours, None, lost
    face_colours = _off_colour_values(extra)
    complete = all(3 <= n < len(r) for r, n in zip(face_rows, sizes.tolist(), strict=True))
    tris = np.asarray(faces, np.int64).reshape(-1, 3)
    if face_colours is not None and complete and int((sizes - 2).sum()) == tris.shape[0] > 0:
        # each face's fan (0, c, c + 1), vectorised over the faces' indices laid end to end
        try:
            flat = np.array(
                [int(t) for r, n in zip(face_rows, sizes.tolist(), strict=True) for t in r[1 : 1 + n]]
            )
        except ValueError:
            flat = None
        if flat is not None:
            n_tris = sizes - 2
            face = np.repeat(np.arange(n_faces), n_tris)
            corner = np.arange(face.shape[0]) - (np.cumsum(n_tris) - n_tris)[face] + 1
            start = (np.cumsum(sizes) - sizes)[face]
            fans = np.stack([flat[start], flat[start + corner], flat[start + corner + 1]], axis=1)
            if np.array_equal(fans, tris):  # (triangles only: trimesh's are the file's, in order)
                return vertex_colours, face_colours[face], lost
            # trimesh's triangles in its order (triangles, then quads' halves, then fans): matched by vertices
            _, key = np.unique(np.sort(np.concatenate([fans, tris]), axis=1), axis=0, return_inverse=True)
            key = key.reshape(-1)
            of_key = np.full(int(key.max()) + 1, -1, np.int64)
            of_key[key[: fans.shape[0]]] = face
            found = of_key[key[fans.shape[0] :]]
            if (found >= 0).all():
                return vertex_colours, face_colours[found], lost
    lost.append("face colours")
    return vertex_colours, None, lost
