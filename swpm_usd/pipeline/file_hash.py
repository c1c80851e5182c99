"""A file's sha256 with the stat it was hashed at, and a new output's manifest record.

The stat is taken through the descriptor the bytes are read from, so a record's size and :data:`STAT_KEYS`
describe the bytes hashed: a later run that finds them as recorded trusts the file unread
(:func:`.outputs._checked_output`, :func:`.inputs._inputs_unchanged`). Separate from :mod:`.worker`, which
uses it to record outputs, because the plan, the records' checks and the outputs' checks use it too.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Any

#: the fields of ``os.stat`` an output's manifest record keeps beside its ``size`` and ``sha256``: a later run
#: that finds the file with the same size and all of these trusts it unchanged without reading it
#: (:func:`.outputs._checked_output`). ``ctime_ns`` moves on any change to the file's data or metadata and
#: cannot be set back (``os.utime`` sets the mtime, not the ctime); ``ino`` and ``dev`` change when another
#: file is renamed over it (a copy written into it, ``cp`` or ``cp -p``, keeps its inode: its ctime moves)
STAT_KEYS = ("mtime_ns", "ctime_ns", "ino", "dev")


def stat_fields(st: os.stat_result) -> dict[str, int]:
    """The :data:`STAT_KEYS` of a stat result."""
    return {"mtime_ns": st.st_mtime_ns, "ctime_ns": st.st_ctime_ns, "ino": st.st_ino, "dev": st.st_dev}


def hash_with_stat(path: Path) -> tuple[str, os.stat_result | None]:
    """The sha256 of ``path`` and its stat, taken through the descriptor it is read from, before the read;
    the stat is None when the file changed while it was read (its size, mtime or ctime moved), so it
    describes the bytes hashed (a file renamed over ``path`` meanwhile is another inode, which the stat of
    the one read does not match)."""
    h = hashlib.sha256()
    st = update_with_stat(h, path)
    return h.hexdigest(), st


def update_with_stat(h: Any, path: Path) -> os.stat_result | None:
    """Feed ``path``'s bytes to the hash object ``h``; its stat as :func:`hash_with_stat` takes it (None
    when the file changed while it was read), for a digest of several files (an asset's inputs)."""
    with open(path, "rb") as f:
        before = os.fstat(f.fileno())
        while chunk := f.read(1 << 20):
            h.update(chunk)
        after = os.fstat(f.fileno())
    same = (before.st_size, before.st_mtime_ns, before.st_ctime_ns) == (
        after.st_size,
        after.st_mtime_ns,
        after.st_ctime_ns,
    )
    return before if same else None


def sha256_file(path: Path) -> str:
    """The sha256 of ``path`` (:func:`hash_with_stat`'s)."""
    return hash_with_stat(path)[0]


def output_record(path: Path) -> dict[str, Any]:
    """A new output's manifest record: its name (``path`` is in output.dir), sha256, size, and the
    :data:`STAT_KEYS` of the bytes hashed (none when the file changed while it was read)."""
    sha, st = hash_with_stat(path)
    rec: dict[str, Any] = {"path": path.name, "sha256": sha}
    if st is not None:
        rec.update(size=st.st_size, **stat_fields(st))
    return rec
