"""Which input files are still as recorded, so a rerun takes their recorded digest without reading them.

An asset's record lists each input file (its path relative to the config's folder, size and stat as it
was hashed); :func:`_inputs_unchanged` trusts them while each stat is as recorded and was taken long enough
after the file's last change (:data:`_RACY_NS`, git's "racily clean" rule), and :func:`_listed_inputs` takes
a glTF's buffers or a stage's layers from the record the same way. Separate from the runner: these are the
rules a rerun trusts files by, which the tests pin down one by one.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .assets import LISTED_SUFFIXES
from .file_hash import STAT_KEYS, stat_fields
from .records import INPUT_STAT_KEYS, record_problem, recorded_inputs

if TYPE_CHECKING:
    from .plan_item import PlanItem


#: an input's recorded stat is trusted only when its mtime and ctime were older than the moment it was
#: hashed by more than this, as git treats "racily clean" index entries: a file written in the timestamp
#: tick of its hash (coarse kernel clocks, 2 s on FAT, a file server's clock a little off this machine's)
#: can take a same-size edit that leaves its size, mtime and ctime as recorded, with other bytes. Older
#: than that, any later write (or os.utime setting the mtime back) stamps a later ctime, which the next run
#: sees. A racy entry is hashed by the next run, which records the stat again (trusted from then on)
_RACY_NS = 2_000_000_000


def recorded_path(base: Path, path: Path) -> str:
    """An input file's ``path`` as a record holds it: relative to the config's folder ``base`` when it is
    under it (so a project folder moved or renamed, its config, inputs and output.dir with it, is a rerun
    that changes nothing), else absolute (a stage given by an absolute path elsewhere)."""
    try:
        return path.relative_to(base).as_posix()
    except ValueError:
        return str(path)


def _recorded_paths(base: Path, entries: list[dict]) -> list[dict]:
    """Input entries (:func:`.assets.hash_inputs`, absolute paths) with their paths as a record holds them."""
    return [{**e, "path": recorded_path(base, Path(e["path"]))} for e in entries]


def _is_recorded_path(entry_path: str, path: Path, base: Path | None) -> bool:
    """Is ``entry_path``, a record's, the file ``path``: :func:`recorded_path`'s, or the absolute path a
    record of an older version holds? Compared as text (``base``, a separator and the relative path are
    ``path`` as pathlib spells it), not by :func:`recorded_path`: a rerun compares every input of every asset,
    a stage's layers once for each of its prims (``Path.relative_to``, 14 us a path: a no-change rerun of
    1,000 prims of a 51-layer stage took 1.27-1.52 s instead of 1.06-1.10; 1.13-1.17 s compared as text)."""
    text = str(path)
    if entry_path == text:
        return True
    if base is None or os.path.isabs(entry_path):
        return False
    folder = str(base)
    sep = "" if folder.endswith(os.sep) else os.sep  # (a root: "/")
    return text == f"{folder}{sep}{entry_path.replace('/', os.sep)}"


def _inputs_unchanged(paths: list[Path], entries: list[dict] | None, base: Path | None = None) -> bool:
    """Are ``paths``, an asset's input files, those its record's ``inputs`` (``entries``, validated by
    :func:`.records.recorded_inputs`; paths relative to the config's folder ``base``, or absolute)
    describe, each with the recorded size and stat (:data:`STAT_KEYS`), taken long enough after its last
    change (:data:`_RACY_NS`)? Then the recorded input digest still describes them, and they are not
    read."""
    if entries is None or len(entries) != len(paths):
        return False
    if not all(_is_recorded_path(e["path"], p, base) for p, e in zip(paths, entries, strict=True)):
        return False
    for p, e in zip(paths, entries, strict=True):
        if not all(k in e for k in INPUT_STAT_KEYS):  # (changed while it was hashed: no stat recorded)
            return False
        if max(e["mtime_ns"], e["ctime_ns"]) >= e["hashed_ns"] - _RACY_NS:
            return False
        try:
            st = os.stat(p)
        except (OSError, ValueError):
            return False
        if st.st_size != e["size"] or any(e[k] != v for k, v in stat_fields(st).items()):
            return False
    return True


def _same_stat(entries: list[dict], recorded: list[dict] | None) -> bool:
    """Are ``entries``, inputs just hashed (:func:`.assets.hash_inputs`), the ``recorded`` ones: the same
    paths, sizes and stat fields (the time each was hashed aside)?"""
    keys = ("path", "size", *STAT_KEYS)
    return recorded is not None and [[e.get(k) for k in keys] for e in entries] == [
        [e.get(k) for k in keys] for e in recorded
    ]


#: a record's mark that its ``inputs`` are the list of its file's inputs as this listing reads them
#: (:data:`LISTING`), which a rerun takes while they are all unchanged (:func:`_listed_inputs`). A record
#: without it (of an older version: a .glb listed alone, before its buffer files were inputs; a USD file
#: before its layers were) or of another listing is read again, and marked by the run
INPUTS_LISTED = "inputs_listed"
#: the listing's version: one more whenever a file's inputs are listed otherwise
LISTING = 1


def _listed_inputs(path: Path, record: Any, base: Path | None = None) -> list[Path] | None:
    """The input files of the glob-matched ``path`` as its manifest ``record`` lists them, without reading
    ``path`` (a glTF's buffer files, a USD file's layers), when the record is of a build (every buffer or
    layer found: the loader refuses a stage with a layer it cannot open) of ``path``, marked as this
    listing's (:data:`INPUTS_LISTED`: not an older version's, nor one a file written later could change),
    and every file it lists is as recorded (:func:`_inputs_unchanged`, the trust its digest is taken by):
    what they name is then what they named. Else None, and they are read."""
    if path.suffix.lower() not in LISTED_SUFFIXES or not isinstance(record, dict):
        return None
    if record.get(INPUTS_LISTED) != LISTING:  # (an older version's list, or one that may not hold)
        return None
    if record.get("status") != "built" or "input_digest" not in record or record_problem(record) is not None:
        return None
    entries = recorded_inputs(record)
    if not entries or not _is_recorded_path(entries[0]["path"], path, base):
        return None
    paths = [path, *(Path(e["path"]) if base is None else base / e["path"] for e in entries[1:])]
    return paths if _inputs_unchanged(paths, entries, base) else None


def _listing_mark(record: dict) -> bool:
    return record.get(INPUTS_LISTED) == LISTING


def _with_inputs(record: dict, item: PlanItem) -> dict:
    """``record`` with ``item``'s input digest, inputs (the stat of each as it was hashed to that digest)
    and :data:`INPUTS_LISTED` when they are a list a rerun may take (else without it)."""
    rec = {k: v for k, v in record.items() if k != INPUTS_LISTED}
    rec["input_digest"], rec["inputs"] = item.input_digest, item.input_stats
    if item.inputs_listed:
        rec[INPUTS_LISTED] = LISTING
    return rec


def _input_size(path: Path) -> int:
    """``path``'s size, 0 if it cannot be read (its asset then fails in the worker, naming the file)."""
    try:
        return path.stat().st_size
    except OSError:
        return 0
