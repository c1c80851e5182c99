"""Runtime instances of the record-based encodings (vanilla, skip-strip, mixed): one private index list per
drawn instance, edited by collapse records one at a time (Forsyth's collapse/split) or in a jump.

:class:`RecordInstance` holds what they share: the record count, ``collapse``/``split``/``set_lod`` and the
LOD the instance shows. :class:`LevelledInstance` adds multilevel lists (skip strips, mixed mode): the
instance owns a copy of one level's list; reaching another level copies the nearer of that level's stored
uncollapsed and fully collapsed lists, so oscillating across a level boundary costs no re-collapsing.
"""

from __future__ import annotations

from typing import Any

import numba as nb
import numpy as np


@nb.njit(cache=True)
def apply_records(buf, offsets, start, kept, binned_id, r0, r1):
    """Collapse records r0..r1-1 (r0 <= r1) or split r0-1..r1 (r0 > r1) on the index list ``buf``."""
    if r0 <= r1:
        for r in range(r0, r1):
            for j in range(start[r], start[r + 1]):
                buf[offsets[j]] = kept[r]
    else:
        for r in range(r0 - 1, r1 - 1, -1):
            for j in range(start[r], start[r + 1]):
                buf[offsets[j]] = binned_id[r]


class RecordInstance:
    """Shared runtime state: ``records_applied`` of ``pm.record_count`` records; LOD k is
    ``pm.lod_record_counts[k]`` records. Subclasses implement :meth:`_move`."""

    def __init__(self, pm: Any) -> None:
        self.pm = pm
        self.records_applied = 0

    @property
    def vertex_count(self) -> int:
        """Vertices in use: the binned vertex of every applied record is the last one, gone."""
        return self.pm.vertex_count - self.records_applied

    @property
    def lod(self) -> int | None:
        """The LOD this instance shows, or None between the records of one seam step."""
        lrc = self.pm.lod_record_counts
        k = int(np.searchsorted(lrc, self.records_applied))
        return k if k < self.pm.lod_count and lrc[k] == self.records_applied else None

    def _move(self, target: int) -> None:
        raise NotImplementedError

    def collapse(self) -> bool:
        """Apply the next record; False at the coarsest state."""
        if self.records_applied >= self.pm.record_count:
            return False
        self._move(self.records_applied + 1)
        return True

    def split(self) -> bool:
        """Undo the last record; False at full detail."""
        if self.records_applied == 0:
            return False
        self._move(self.records_applied - 1)
        return True

    def set_lod(self, k: int) -> None:
        """Jump to LOD ``k`` (collapsing or splitting as many records as needed)."""
        self._move(int(self.pm.lod_record_counts[self.pm._check_lod(k)]))


class LevelledInstance(RecordInstance):
    """A record instance over multilevel lists; ``_level_list(level, collapsed)`` gives a level's stored list.

    ``records_done`` (records applied or undone) and ``level_switches`` (lists copied) measure the LOD-change
    cost. The mesh provides ``_lrs`` (record range of each level), ``level_of_records(n)`` and the record
    arrays ``_offsets``, ``_start``, ``_kept``, ``_binned``.
    """

    def __init__(self, pm: Any) -> None:
        super().__init__(pm)
        self.level = 0
        # one buffer for the longest level list, allocated once, as an engine would: a level switch copies
        # into it (its records only shorten or edit a level's list, never lengthen it)
        longest = max(len(self._level_list(lvl, False)) for lvl in range(len(pm._lrs) - 1))
        self._store = np.empty(longest, np.int64)
        self._buf = self._load(0, False)
        self.records_done = 0
        self.level_switches = 0

    def _level_list(self, level: int, collapsed: bool) -> np.ndarray:
        raise NotImplementedError

    def _load(self, level: int, collapsed: bool) -> np.ndarray:
        """A level's stored list copied into the instance's buffer; the view of it the instance edits."""
        src = self._level_list(level, collapsed)
        buf = self._store[: len(src)]
        buf[:] = src
        return buf

    def _move(self, target: int) -> None:
        pm = self.pm
        target = int(target)
        lvl = pm.level_of_records(target)
        r = self.records_applied
        if lvl != self.level:
            r0, r1 = int(pm._lrs[lvl]), int(pm._lrs[lvl + 1])
            collapsed = (r1 - target) < (target - r0)
            self._buf = self._load(lvl, collapsed)
            r = r1 if collapsed else r0
            self.level = lvl
            self.level_switches += 1
        apply_records(self._buf, pm._offsets, pm._start, pm._kept, pm._binned, r, target)
        self.records_done += abs(target - r)
        self.records_applied = target
