"""Which assets a run builds with ``only`` (``run --only PATTERN``): the patterns matched against the asset
ids (fnmatch, ``*`` crossing ``/`` and ``:``, an id matching itself), a near pattern suggested for one that
matches nothing, and the selected builds that would overwrite an unselected asset's recorded outputs (after an
``output.names`` flip), each a usage error raised before the run builds or writes anything. The runner plans
the whole config and builds the selection (:func:`.runner.run`).
"""

from __future__ import annotations

import fnmatch
import functools
import re
import unicodedata
from collections.abc import Iterable

from .assets import _folded
from .config import Config
from .rules import OUTPUT_SUFFIXES, _wanted_outputs

#: how many asset ids the error of an ``only`` pattern that matches none shows, so the user sees how ids look
_IDS_SHOWN = 5


class SelectionError(ValueError):
    """``only`` patterns that match no asset of the config: a usage error (``run --only``: exit 2), raised
    before the run builds or writes anything. ``patterns``: those; ``ids``: the config's first asset ids;
    ``total``: how many it has; ``hints``: a pattern -> the pattern written as an id that matches (and how
    many it takes), where one is near (:func:`_selection_hint`)."""

    def __init__(
        self, patterns: list[str], ids: list[str], total: int, hints: dict[str, tuple[str, int]] | None = None
    ) -> None:
        self.patterns, self.ids, self.total, self.hints = patterns, ids, total, hints or {}
        which = ", ".join(repr(p) for p in patterns)
        if not ids:
            how = "the config has no assets"
        else:
            more = f", ... ({total} assets)" if total > len(ids) else ""
            how = (
                "an asset's id is its path relative to the config (a stage's prim: path:/prim/path), as "
                f"--dry-run shows it: {', '.join(ids)}{more}"
            )
        guesses = "".join(
            f" (did you mean '{h}'? {n} {'asset' if n == 1 else 'assets'})" for h, n in self.hints.values()
        )
        super().__init__(f"{which} {'matches' if len(patterns) == 1 else 'match'} no asset{guesses}; {how}")


def _selection_hint(pattern: str, ids: list[str]) -> tuple[str, int] | None:
    """A pattern near ``pattern`` that matches some of ``ids``: one written from the glob's folder rather
    than the config's (``set03/*`` for ``lib/set03/*``), without the file's suffix (``lib/set03/rock``), or
    as an output's name (``set03--rock``, the name under ``output.names: path``); the first that matches."""
    from .assets import PATH_NAME_SEPARATOR

    bases = dict.fromkeys([pattern, pattern.replace(PATH_NAME_SEPARATOR, "/")])
    for base in bases:
        for c in (f"*/{base}", f"{base}.*", f"*/{base}.*"):
            rx = _pattern(c)
            found = [aid for aid in ids if rx.match(aid)]
            if len(found) == 1:
                return found[0], 1
            if found:
                if c.startswith("*/"):  # the folders the ids put before it, when they all put the same
                    c = _common_folders(c[2:], found) or c
                return c, len(found)
    return None


def _common_folders(pattern: str, ids: list[str]) -> str | None:
    """``pattern`` after the folders every id of ``ids`` has before what it matches (``lib/`` for ``set03/*``
    of ``lib/set03/rock.obj``...), or None when they differ."""
    heads = set()
    for aid in ids:
        cuts = [i + 1 for i, ch in enumerate(aid) if ch == "/"]
        head = next((aid[:i] for i in cuts if _pattern(aid[:i] + pattern).match(aid)), None)
        heads.add(head)
        if head is None or len(heads) > 1:
            return None
    return heads.pop() + pattern


class SelectionConflictError(SelectionError):
    """``only`` selects an asset to build whose output would replace a file an asset it leaves out holds: its
    recorded output, at the name it had before ``output.names`` changed (``x/a--b.obj``'s ``a--b.swpm``
    and ``a/b.obj`` named by path). A usage error (``run --only``: exit 2), raised before the run builds or
    writes anything: built, it overwrote the other's build, which the manifest and the scene still gave it.
    ``clashes``: (selected id, output file, the id not selected that holds it)."""

    def __init__(self, clashes: list[tuple[str, str, str]]) -> None:
        self.clashes = clashes
        pairs: dict[tuple[str, str], list[str]] = {}
        for a, f, b in clashes:
            pairs.setdefault((a, b), []).append(f)
        shown = "; ".join(
            f"{a} would write {' and '.join(files)}, the recorded output{'s' * (len(files) > 1)} of {b}, "
            "which is not selected"
            for (a, b), files in list(pairs.items())[:_IDS_SHOWN]
        )
        more = f"; ... ({len(pairs)} assets)" if len(pairs) > _IDS_SHOWN else ""
        others = " ".join(f"--only '{b}'" for b in dict.fromkeys(b for _, b in list(pairs)[:_IDS_SHOWN]))
        ValueError.__init__(
            self,
            f"{shown}{more} (its names before output.names or its glob changed): built, it would replace "
            f"that asset's build; select it too ({others}) or run without --only",
        )


def _selection_clashes(cfg: Config, items: list, picked: list, force: bool) -> list[tuple[str, str, str]]:
    """(selected id, file, unselected id) for each output a selected asset to build writes that an
    unselected asset's record lists (compared as a case-insensitive filesystem names them)."""
    chosen = {id(it) for it in picked}
    held: dict[str, tuple[str, str]] = {}
    for it in items:
        if id(it) in chosen or not isinstance(it.previous, dict):
            continue
        for o in (it.previous.get("outputs") or {}).values():
            if isinstance(o, dict) and isinstance(o.get("path"), str):
                held[_folded(o["path"])] = (o["path"], it.asset.id)
    if not held:
        return []
    clashes = []
    for it in picked:
        if not (force or not it.up_to_date):
            continue
        for kind in sorted(_wanted_outputs(cfg)):
            found = held.get(_folded(f"{it.asset.output_stem}{OUTPUT_SUFFIXES[kind]}"))
            if found is not None:
                clashes.append((it.asset.id, found[0], found[1]))
    return clashes


@functools.lru_cache(maxsize=1024)
def _pattern(pattern: str) -> re.Pattern[str]:
    """``pattern`` as fnmatch reads it (``*`` any characters, ``/`` and ``:`` too; ``?`` one; ``[seq]``),
    case-sensitive on every system (ids are the config's paths), or the id it is written as. Cached: the
    hints try one pattern on every id (:func:`_common_folders`: 100 unmatched rules' hints on 10,000 ids
    translated it 1,000,000 times, 10 s of a 15 s dry run)."""
    return re.compile(f"{re.escape(pattern)}\\Z|{fnmatch.translate(pattern)}")


def selected_ids(ids: Iterable[str], patterns: Iterable[str]) -> set[str]:
    """The ids of ``ids`` that any of ``patterns`` matches (:func:`_pattern`: ``meshes/hero_*`` also takes
    ``meshes/hero_a/b.obj`` and the prims of ``meshes/hero_set.usda``; a plain id, ``[`` and all, matches
    itself; pattern and id compared in Unicode NFC, as macOS compares file names); raises
    :class:`SelectionError` naming each pattern that matches none."""
    ids = list(ids)
    # compared in one Unicode normalization: a pattern typed or pasted on macOS (`café`, e and an accent)
    # matched no id written with one code point, and its error showed the same-looking text
    nfc = [unicodedata.normalize("NFC", aid) for aid in ids]
    chosen: set[str] = set()
    unmatched = []
    for p in dict.fromkeys(patterns):  # (a pattern given twice: once)
        rx = _pattern(unicodedata.normalize("NFC", p))
        found = [aid for aid, n in zip(ids, nfc, strict=True) if rx.match(n)]
        if not found:
            unmatched.append(p)
        chosen.update(found)
    if unmatched:
        hints = {p: h for p in unmatched if (h := _selection_hint(p, ids)) is not None}
        raise SelectionError(unmatched, ids[:_IDS_SHOWN], len(ids), hints)
    return chosen
