"""What the checks of a mesh file's text share to say where it is wrong: its rows of tokens with their line
numbers, the first word that is not a number, a word as a message shows it, and where bytes stop being
UTF-8 (the OBJ, OFF, STL and PLY checks of :mod:`.obj`, :mod:`.off`, :mod:`.stl`, :mod:`.ply`, and the
glTF ones of :mod:`.gltf_checks`)."""

from __future__ import annotations

import re
from collections.abc import Iterator

#: the UTF-8 byte-order mark Windows tools write before a text file's first line (no part of its first word)
BOM = b"\xef\xbb\xbf"


def _without_bom(data: bytes) -> bytes:
    """The bytes ``data`` of a text mesh file without its UTF-8 byte-order mark, if it starts with one (its
    lines unchanged: the mark is no line of its own)."""
    return data[len(BOM) :] if data.startswith(BOM) else data


def _cr_only(data: bytes) -> bool:
    """Whether the text ``data`` ends its lines in CR alone (classic Mac OS): a CR and no LF."""
    return b"\n" not in data and b"\r" in data


def _text_lines(data: bytes) -> bytes:
    """The bytes ``data`` of a text mesh file (OBJ, OFF, ASCII STL) as its checks and trimesh read it: without
    its byte-order mark, and its lines ended by LF if each ends in CR alone (trimesh's OBJ and STL readers and
    our checks split lines at LF only: the whole file read as one line). Lines, and so messages' line
    numbers, unchanged; a file of LF or CRLF lines is returned as it is."""
    data = _without_bom(data)
    return data.replace(b"\r", b"\n") if _cr_only(data) else data


#: a CR that ends a line alone, in a file of LF or CRLF lines
_LONE_CR = re.compile(rb"\r(?!\n)")


def _off_lines(data: bytes) -> bytes:
    """The bytes ``data`` of an OFF file as trimesh's OFF reader splits them (str.splitlines: at CR, LF and
    CRLF) and the checks read them: :func:`_text_lines`, and a CR alone in a file with LFs as an LF too (the
    checks, splitting at LF, read such a line and the next as one: a file trimesh read whole was 'the header
    declares 4 faces, the file has 3', its colours lost). A file with no such CR is returned as it is."""
    data = _text_lines(data)
    return _LONE_CR.sub(b"\n", data) if b"\r" in data and _LONE_CR.search(data) else data


def _numbered_rows(data: bytes) -> Iterator[tuple[int, list[bytes]]]:
    """(line number from 1, tokens) of each line of a text mesh file holding any, comments left out."""
    for number, line in enumerate(data.split(b"\n"), 1):
        words = line.split(b"#", 1)[0].split()
        if words:
            yield number, words


def _not_numbers(words: list[bytes]) -> bytes | None:
    """The first of ``words`` that is not a number, or None."""
    for w in words:
        try:
            float(w)
        except ValueError:
            return w
    return None


def _shown(word: bytes) -> str:
    return repr(word[:40].decode("utf-8", "replace"))


def _undecoded(data: bytes, at: int, e: UnicodeDecodeError) -> str:
    """Where the bytes ``data`` (from byte ``at`` of the file) stop being UTF-8, as a message's end."""
    offset = at + e.start
    line = data.count(b"\n", 0, e.start) + 1
    return f"byte 0x{data[e.start]:02x} at byte offset {offset} (line {line}) is not UTF-8 text"
