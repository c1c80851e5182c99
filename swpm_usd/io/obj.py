"""The OBJ handling of the loader around trimesh's reader: its face lines of 3 or more corners counted before
parsing (:data:`_OBJ_FACE_LINE`, a lower bound of its triangles), trimesh's reading of face lines of differing
lengths done in numpy (:func:`_obj_faces_fallback`, within :func:`_obj_faces_in_numpy` alone: trimesh read
them corner by corner in Python), a warning when the texture coordinates or normals the faces refer to were
all dropped (:func:`_report_dropped_obj_attributes`), and what is wrong with a row trimesh failed on
(:func:`_obj_problem`)."""

from __future__ import annotations

import contextlib
import contextvars
import functools
import itertools
import re
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from .text_rows import _not_numbers, _numbered_rows, _shown, _text_lines

#: a row's indentation: blanks at a line's start, unless the line before ends in '\\' (which continues
#: that line here: trimesh joins them, blanks and all)
_OBJ_INDENT = re.compile(rb"(?m)(?<!\\\n)(?<!\\\r\n)^ +")
_OBJ_INDENTED = re.compile(rb"\n ")


def _obj_text(data: bytes) -> bytes:
    """The OBJ file of bytes ``data`` as trimesh and the checks below read it, its lines unchanged: without
    its byte-order mark (trimesh took ``\\ufeffv`` for no vertex: every index after it off by one), its lines
    ended by LF if they end in CR alone (:func:`.text_rows._text_lines`), its tabs
    as spaces and its rows' indentation dropped (trimesh finds rows by ``'\\nv '`` and ``'\\nf '``: a file
    of tab-separated rows was "no triangles", an indented face dropped, no word said). A file without any
    is returned as it is, not copied (bunny, 2.4 MB: 1 ms)."""
    data = _text_lines(data)
    if b"\t" in data:
        data = data.replace(b"\t", b" ")
    # (re's search, not "b'\n ' in data": 2.3 ms, nor numpy's compare of neighbours: 1.9 ms)
    if data.startswith(b" ") or _OBJ_INDENTED.search(data) is not None:
        data = _OBJ_INDENT.sub(b"", data)
    return data


def _obj_problem(data: bytes) -> str | None:
    """What is wrong with a row of the OBJ file of bytes ``data`` (a ``v``/``vt``/``vn`` value that is not a
    number, or too few; a face corner whose index is not an integer, or refers to no vertex), or None (asked
    once trimesh has failed on it: "string or file could not be read to its end due to unmatched data",
    "invalid literal for int() with base 10", "index 3000 is out of bounds for axis 0"). ``data``: the file
    as the loader reads it (:func:`_obj_text`)."""
    for number, line in enumerate(data.split(b"\n"), 1):  # (trimesh takes the comment for values)
        values, hash_, comment = line.partition(b"#")
        key = values.split()[:1]
        if hash_ and key and key[0] in (b"v", b"vt", b"vn", b"f"):
            return (
                f"line {number}: a comment after a '{key[0].decode()}' row's values "
                f"({_shown(hash_ + comment)}): trimesh reads one only on a line of its own"
            )
    vertices = 0
    for number, words in _numbered_rows(data):
        key = words[0]
        if key in (b"v", b"vt", b"vn"):
            bad = _not_numbers(words[1:])
            if bad is not None:
                return f"line {number}: a '{key.decode()}' row holds {_shown(bad)}, not a number"
            need = 1 if key == b"vt" else 3
            if len(words) - 1 < need:
                return f"line {number}: a '{key.decode()}' row holds {len(words) - 1} values, not {need}"
            vertices += key == b"v"
    for number, words in _numbered_rows(data):
        if words[0].startswith(b"f") and words[0] != b"f":  # (trimesh reads a line of 'f' and more as one)
            return f"line {number}: {_shown(b' '.join(words[:6]))} starts with 'f', not a face ('f ...')"
        if words[0] != b"f":
            continue
        for corner in words[1:]:
            for kind, part in zip(("vertex", "uv", "normal"), corner.split(b"/"), strict=False):
                if part == b"" and kind != "vertex":
                    continue
                try:
                    index = int(part)
                except ValueError:
                    return (
                        f"line {number}: face corner {_shown(corner)}: its {kind} index is not a whole number"
                    )
                if kind == "vertex" and not (-vertices <= index <= vertices and index != 0):
                    where = f"line {number}: face corner {_shown(corner)}"
                    return f"{where} refers to vertex {index}, the file has {vertices}"
    return None


_SEPARATOR = np.zeros(256, bool)  # (bytes that end an index: the next corner's part, a blank, a comment)
_SEPARATOR[list(b"/ \t\r\n#")] = True
_BLANK = np.zeros(256, bool)
_BLANK[list(b" \t")] = True


def _obj_zero_corner(data: bytes) -> str | None:
    """The first face corner of the OBJ file of bytes ``data`` whose vertex index is 0 (``0``, ``-0``,
    ``00``), as :func:`_obj_problem` words it, or None. OBJ counts from 1 (and back from -1): trimesh reads
    a 0 as the first vertex, so ``f 0 2 3`` was the triangle of vertices 1, 2, 3, no word said. In numpy
    (bunny: about 12 ms of its 130 ms load): the '0's that end an index, those on face lines, then their
    index's start."""
    a = np.frombuffer(data, np.uint8)
    zero = a == ord("0")
    end = np.flatnonzero(zero[1:] & np.append(_SEPARATOR[a[2:]], True)) + 1
    if end.shape[0] == 0:
        return None
    breaks = np.concatenate(([-1], np.flatnonzero(a == ord("\n"))))
    first = breaks[np.searchsorted(breaks, end) - 1] + 1  # (each one's line start)
    face = (a[first] == ord("f")) & _BLANK[a[np.minimum(first + 1, a.shape[0] - 1)]] & (end > first + 1)
    end, first = end[face], first[face]
    if end.shape[0] == 0:
        return None
    runs = np.flatnonzero(zero[1:] & ~zero[:-1]) + 1  # (where each run of zeros starts)
    start = runs[np.searchsorted(runs, end, side="right") - 1]
    start -= a[start - 1] == ord("-")
    hashes = np.concatenate(([-1], np.flatnonzero(a == ord("#"))))
    commented = hashes[np.searchsorted(hashes, start) - 1] >= first
    hit = np.flatnonzero(_BLANK[a[start - 1]] & ~commented)
    if hit.shape[0] == 0:
        return None
    problem = _obj_problem(data)  # (the first problem of the file, in its words: this one or one before)
    if problem is None:  # (not expected: the same rule)
        at = int(start[hit[0]])
        line = data.count(b"\n", 0, at) + 1
        problem = f"line {line}: face corner {_shown(data[at : at + 40].split()[0])} refers to vertex 0"
    return problem


#: an OBJ face corner of each form (v, v/vt, v//vn, v/vt/vn) -> the columns of its texture and normal indices
_OBJ_CORNER_FORMS = {
    "{i}": (None, None),
    "{i}/{i}": (1, None),
    "{i}//{i}": (None, 1),
    "{i}/{i}/{i}": (1, 2),
}
#: an index as the vectorised reading below takes it (anything else: trimesh's own reading)
_OBJ_INDEX = "-?[0-9]{1,18}"


def _obj_faces_fallback(lines: list[str], original: Callable) -> tuple:
    """trimesh's ``_parse_faces_fallback`` (``original``: OBJ face lines of differing lengths, which it reads
    corner by corner in Python: a 200,000-corner polygon beside a triangle took 4.5 s) in numpy, with the
    same triangles in the same order (a quad as (0, 1, 2), (2, 3, 0), a polygon of more corners as the fan
    (0, k, k + 1), a line of fewer than 3 corners skipped) and the same indices. Only when every corner has
    the first's form and plain integer indices; any other lines are ``original``'s."""
    rows = [line.strip().split("\n")[0].split() for line in lines]
    counts = np.fromiter(map(len, rows), np.int64, len(rows))
    if counts.shape[0] == 0 or (counts < 3).all():
        return original(lines)
    first = rows[int(np.argmax(counts >= 3))][0]
    form = re.sub(r"[^/]+", "{i}", first)
    if form not in _OBJ_CORNER_FORMS:
        return original(lines)
    text = " ".join(itertools.chain.from_iterable(rows))
    token = form.replace("{i}", _OBJ_INDEX)
    if re.fullmatch(f"{token}(?: {token})*", text) is None:
        return original(lines)
    width = form.count("{i}")
    values = np.array(text.replace("/", " ").split(), np.int64).reshape(-1, width)
    n_tris = np.where(counts >= 3, counts - 2, 0)
    face = np.repeat(np.arange(counts.shape[0]), n_tris)
    k = np.arange(face.shape[0]) - (np.cumsum(n_tris) - n_tris)[face]  # (the triangle's place in its face)
    corners = np.stack([np.zeros_like(k), k + 1, k + 2], axis=1)
    corners[(counts[face] == 4) & (k == 1)] = (2, 3, 0)  # (trimesh's quad split)
    read = values[(np.cumsum(counts) - counts)[face][:, None] + corners]

    def column(c: int | None) -> np.ndarray | None:
        if c is None:
            return None
        out = np.ascontiguousarray(read[:, :, c])
        out[out > 0] -= 1  # (1-based; negative indices count from the end, as trimesh leaves them)
        return out

    tex, norm = _OBJ_CORNER_FORMS[form]
    return column(0), column(tex), column(norm)


#: set (in this thread or task only) while :func:`.trimesh_loader.load_trimesh` has trimesh read an OBJ:
#: only those reads take :func:`_obj_faces_fallback`; any other code's trimesh calls in the process get
#: trimesh's own function
_OBJ_FACES_IN_NUMPY: contextvars.ContextVar[bool] = contextvars.ContextVar("swpm_obj_faces", default=False)


def _install_obj_faces_fallback() -> None:
    """Put a wrapper in place of trimesh's ``_parse_faces_fallback`` (once; ``__wrapped__`` is trimesh's own):
    it calls trimesh's own function unless :data:`_OBJ_FACES_IN_NUMPY` is set, so a user's trimesh calls in
    the same process (other threads included) run trimesh's code unchanged; our OBJ reads, inside
    :func:`_obj_faces_in_numpy`, take :func:`_obj_faces_fallback` (the same result, fuzzed against it)."""
    import trimesh.exchange.obj as obj

    original = obj._parse_faces_fallback
    if getattr(original, "swpm_usd", False):
        return

    @functools.wraps(original)
    def fallback(lines: list[str]) -> tuple:
        if not _OBJ_FACES_IN_NUMPY.get():
            return original(lines)
        return _obj_faces_fallback(lines, original)

    fallback.swpm_usd = True  # type: ignore[attr-defined]
    obj._parse_faces_fallback = fallback


@contextlib.contextmanager
def _obj_faces_in_numpy() -> Iterator[None]:
    """Within it, trimesh's OBJ reads in this thread or task take :func:`_obj_faces_fallback`."""
    _install_obj_faces_fallback()
    token = _OBJ_FACES_IN_NUMPY.set(True)
    try:
        yield
    finally:
        _OBJ_FACES_IN_NUMPY.reset(token)


#: an OBJ face line of at least 3 corners, as trimesh reads them (from a line's start, in the text of
#: :func:`_obj_text`: no tab, no indentation; a line of fewer corners is skipped; '#' starts a comment): each
#: is at least a triangle
_OBJ_FACE_LINE = re.compile(rb"(?m)^f [ \t]*[^\s#]+(?:[ \t]+[^\s#]+){2}")


#: an OBJ face corner that refers to a texture coordinate (v/vt, v/vt/vn) or a normal (v//vn, v/vt/vn); each
#: starts at a digit before a '/' (not '-?\d+', which the lazy scan would re-try over a whole digit run at
#: every position of it: quadratic in a long face line)
_OBJ_FACE_UV = re.compile(rb"(?m)^[ \t]*f[ \t][^\n]*?\d/-?\d")
_OBJ_FACE_NORMAL = re.compile(rb"(?m)^[ \t]*f[ \t][^\n]*?\d/-?\d*/-?\d")


def _report_dropped_obj_attributes(path: Path, data: bytes, parts: list) -> None:
    """Warn when the OBJ's faces refer to texture coordinates or normals that no part came out with: trimesh
    drops all of them when one face refers to none, or to one out of range."""
    dropped = [
        name
        for name, pattern in (("normal", _OBJ_FACE_NORMAL), ("uv", _OBJ_FACE_UV))
        # (no '/' in the file, no corner that refers to either: the scan of every line start is skipped)
        if not any(name in attrs for _, _, attrs in parts) and b"/" in data and pattern.search(data)
    ]
    if dropped:
        warnings.warn(
            f"{path}: its faces refer to {', '.join(dropped)} values (vt/vn), but trimesh dropped them all "
            "(a face that refers to none, or to one out of range?): loaded without them",
            stacklevel=4,
        )
