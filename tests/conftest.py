"""Shared fixtures: the real test meshes of ../shared/meshes, loaded once per session."""

from __future__ import annotations

import signal
import struct
import zlib
from functools import cache
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED_MESHES = ROOT.parent / "shared" / "meshes"


@cache
def shared_mesh(name: str):
    from swpm_usd.io import load_mesh

    path = SHARED_MESHES / name
    if not path.exists():
        pytest.fail(f"shared mesh {path} is missing: CI must run with ../shared beside the project")
    return load_mesh(path)


@cache
def shared_sequence(name: str):
    from swpm_usd.simplify import collapse_sequence

    return collapse_sequence(shared_mesh(name))


def edge_stats(triangles: np.ndarray, vertex_pos: np.ndarray) -> dict[str, int]:
    """Counts of welded (position) edges by number of incident triangles, and orientation problems."""
    t = vertex_pos[triangles]
    a = t.reshape(-1)
    b = t[:, [1, 2, 0]].reshape(-1)
    directed = np.stack([a, b], 1)
    und = np.sort(directed, 1)
    _, inv, counts = np.unique(und, axis=0, return_inverse=True, return_counts=True)
    # a consistently oriented manifold edge is used once in each direction
    uniq_dir = np.unique(directed, axis=0).shape[0]
    return {
        "edges": int(counts.shape[0]),
        "boundary": int((counts == 1).sum()),
        "manifold": int((counts == 2).sum()),
        "nonmanifold": int((counts > 2).sum()),
        "repeated_directed": int(directed.shape[0] - uniq_dir),
    }


def pytest_configure(config: pytest.Config) -> None:
    """Python's Ctrl-C handler in a test process started with SIGINT ignored: a suite run as a background job
    (``pytest ... &`` in a script, as some CI runners start it) inherits the ignored signal, and so does each
    process a test starts. The tests of Ctrl-C are of a command run from a terminal: theirs failed so (exit 1,
    not 130; a subprocess that ignores the test's Ctrl-C), the product rightly keeping a caller's ignore."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(autouse=True)
def _ctrl_c_handler_restored():
    """Every test leaves the process's Ctrl-C handler as it found it. A command run in-process ignores Ctrl-C
    as it exits on one (``swpm_usd.cli._exiting_on_interrupt``); left so, every subprocess a later test starts
    would inherit the ignored signal, and a test interrupting one would find it ignores Ctrl-C."""
    handler = signal.getsignal(signal.SIGINT)
    yield
    signal.signal(signal.SIGINT, handler)


def refix_crcs(data: bytes) -> bytes:
    """Recompute chunk and file CRCs where the table is readable (never trusts a count blindly): a mutated
    file that reaches the checks behind the CRCs (the format fuzz, the C reader's differential fuzz)."""
    if len(data) < 64:
        return data
    count, to = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    if count > 64 or to + 32 * count > len(data):
        return data
    b = bytearray(data)
    for i in range(count):
        eo = to + 32 * i
        t, _, off, ln = struct.unpack_from("<4sIQQ", b, eo)
        if off + ln <= len(b):
            struct.pack_into("<I", b, eo + 24, zlib.crc32(bytes(b[off : off + ln]), zlib.crc32(t)))
    struct.pack_into("<I", b, 48, 0)
    struct.pack_into("<I", b, 48, zlib.crc32(bytes(b[: to + 32 * count])))
    return bytes(b)
