"""What the checks of a mesh file's text share to say where it is wrong: its rows of tokens with their line
numbers, the first word that is not a number, a word as a message shows it, and where bytes stop being
UTF-8 (the OBJ, OFF, STL and PLY checks of :mod:`.obj`, :mod:`.off`, :mod:`.stl`, :mod:`.ply`, and the
glTF ones of :mod:`.gltf_checks`)."""

from __future__ import annotations

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
