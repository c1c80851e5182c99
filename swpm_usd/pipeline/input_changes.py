"""Whether an input file changed while the worker read it, or since the plan hashed it: then the asset is not
built from it (:class:`InputChangedError`) and the next run builds it again.

Separate from :mod:`.worker`'s build, which calls these before and after the load: the checks of the input
files' stat are one question, read on their own.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ..errors import SwpmError
from .file_hash import stat_fields


class InputChangedError(SwpmError, RuntimeError):
    """The input file changed while the worker read it (an exporter still writing it, a sync replacing it):
    the mesh read may be part of one version and part of another, so it is not built (the asset's previous
    build is kept), and the next run, finding the file's stat moved, hashes and builds it again. ``path``:
    the file, for a JSON error's ``file`` and ``format`` (``encode``'s; a run's record names its asset)."""

    code = "INPUT_CHANGED"

    def __init__(self, message: str, path: str | None = None) -> None:
        from ..codes import format_of

        super().__init__(message)
        self.file, self.format = path, format_of(path)


def _stat_of(path: str) -> os.stat_result | None:
    try:
        return os.stat(path)
    except OSError:  # (gone: the loader says so, naming the file)
        return None


def _check_unchanged_by_the_read(path: str, before: os.stat_result | None) -> None:
    """Raise :class:`InputChangedError` when the file at ``path`` is not the one stat ``before`` saw as the
    read began (its size, mtime, ctime or inode moved). A change before the read began is not one: that file
    is read whole, and the next run hashes it (the record keeps the stat taken as the plan hashed it)."""
    after = _stat_of(path)
    if before is None or after is None:
        return
    if (before.st_size, *stat_fields(before).values()) != (after.st_size, *stat_fields(after).values()):
        moved = (
            f"size {before.st_size} -> {after.st_size} bytes"
            if before.st_size != after.st_size
            else "same size, modified or replaced"
        )
        raise InputChangedError(
            f"{path}: changed while it was read ({moved}): not built from it; the next run builds it again"
        )


def _moved_since_the_plan(task: dict[str, Any], before: dict[str, os.stat_result | None]) -> list[str]:
    """The inputs whose stat ``before`` the load is not the one the plan hashed (or trusted) them at (the
    task's ``input_stats``: each input's size and :data:`STAT_KEYS`; None for one it has no stat for, hashed
    while it changed or unreadable, which is one): the task's input digest is not of the bytes the worker
    loads. A file gone is not one (the loader says so, naming it), nor one ``input_stats`` does not name."""
    planned = task.get("input_stats") or {}
    return [
        path
        for path, st in before.items()
        if st is not None and path in planned and planned[path] != [st.st_size, *stat_fields(st).values()]
    ]


def _refuse_a_moved_listing(moved: list[str]) -> None:
    """Raise :class:`InputChangedError` for an input moved since the plan whose bytes list the asset's other
    inputs (a glTF's buffers, a USD file's layers: :data:`.assets.LISTED_SUFFIXES`): the files the loader
    reads may be others than the plan's, which the record would list as the asset's, unread by the next run
    (it takes a built record's list while the files it names are unchanged)."""
    from .assets import LISTED_SUFFIXES

    for path in moved:
        if Path(path).suffix.lower() in LISTED_SUFFIXES:
            raise InputChangedError(
                f"{path}: changed since the run hashed it (an exporter still writing it?): not built from "
                "it (the files it names may be others); the next run builds it again"
            )


def _hashed_as_loaded(
    inputs: list[str], before: dict[str, os.stat_result | None]
) -> tuple[str, list[dict[str, Any]]]:
    """The digest of ``inputs`` and their entries (:func:`.assets.hash_inputs`), hashed once the load has
    read them, each the file stat ``before`` saw as the load began (so the bytes loaded): else
    :class:`InputChangedError`."""
    from .assets import hash_inputs

    digest, entries = hash_inputs([Path(p) for p in inputs])
    for path, entry in zip(inputs, entries, strict=True):
        st = before.get(path)
        seen = None if st is None else {"size": st.st_size, **stat_fields(st)}
        if seen is None or {k: entry.get(k) for k in seen} != seen:
            raise InputChangedError(
                f"{path}: changed while it was read (hashed once loaded, it was another): not built from it; "
                "the next run builds it again"
            )
    return digest, entries
