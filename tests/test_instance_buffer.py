"""Levelled instances (skip-strip, mixed) edit one buffer allocated at creation: a level switch copies the
level's stored list into it, as an engine's preallocated index buffer, and the drawn triangles stay right."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import swpm_usd

COW = Path(__file__).resolve().parents[2] / "shared" / "meshes" / "cow.obj"


def _tri_set(t: np.ndarray) -> list[tuple[int, ...]]:
    t = np.asarray(t, np.int64).reshape(-1, 3)
    r = np.argmin(t, axis=1)  # rotate each triangle to its smallest index (orientation kept)
    t = np.stack([t[np.arange(len(t)), (r + i) % 3] for i in range(3)], axis=1)
    return sorted(map(tuple, t.tolist()))


@pytest.mark.parametrize("encoding", ["skip-strip", "mixed"])
def test_level_switches_reuse_one_buffer(encoding) -> None:
    pm = swpm_usd.build(COW, encoding=encoding)
    assert pm.level_count > 2
    inst = pm.instance()
    store = inst._store
    rng = np.random.default_rng(7)
    for k in rng.integers(0, pm.lod_count, 40):
        inst.set_lod(int(k))
        assert inst._store is store and np.shares_memory(inst._buf, store)
        assert _tri_set(inst.triangles()) == _tri_set(pm.triangles_at(int(k)))
    assert inst.level_switches >= 10
