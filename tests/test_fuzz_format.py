"""Fuzzing the SWPM reader: mutated valid vectors are read or rejected with a coded report, never a crash.

Mutations are byte replacements, truncations and insertions; half of the cases recompute every CRC afterwards
so that the mutation reaches the content checks instead of stopping at a checksum.
"""

from __future__ import annotations

from pathlib import Path

from conftest import refix_crcs
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from swpm_usd.format import SwpmFormatError, load_bytes, validate_bytes
from swpm_usd.format.errors import CATALOGUE

VECTORS = Path(__file__).resolve().parents[1] / "spec" / "vectors" / "valid"
FILES = sorted(p.read_bytes() for p in VECTORS.glob("*.swpm"))
MAX = 3000  # (5,000 took 60 s of a loaded suite)
SETTINGS = settings(
    max_examples=MAX, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck), database=None
)


@st.composite
def mutated(draw: st.DrawFn) -> bytes:
    data = bytearray(draw(st.sampled_from(FILES)))
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["byte", "byte", "byte", "word", "truncate", "insert"]))
        if not data:
            break
        pos = draw(st.integers(0, len(data) - 1))
        if kind == "byte":
            data[pos] = draw(st.integers(0, 255))
        elif kind == "word":
            val = draw(st.sampled_from([0, 1, 0xFFFF, 0xFFFFFFFF, 0x7FFFFFFF, 65536, 3]))
            data[pos : pos + 4] = val.to_bytes(4, "little")
        elif kind == "truncate":
            del data[pos:]
        else:
            data[pos:pos] = draw(st.binary(min_size=1, max_size=16))
    out = bytes(data)
    return refix_crcs(out) if draw(st.booleans()) else out


def _check(data: bytes) -> None:
    rep = validate_bytes(data)
    assert all(p.code in CATALOGUE for p in rep.problems)
    try:
        pm = load_bytes(data)
    except SwpmFormatError as exc:
        assert exc.report.errors, "rejected without an error"
        assert all(p.code in CATALOGUE for p in exc.report.problems)
        return
    assert rep.valid
    for k in range(pm.lod_count):
        pm.draw_stream(k)


@SETTINGS
@given(mutated())
def test_mutated_vectors_never_crash(data: bytes) -> None:
    _check(data)


@settings(SETTINGS, max_examples=1500)
@given(st.binary(max_size=700))
def test_random_bytes_never_crash(data: bytes) -> None:
    prefix = b"SWPM\r\n\x1a\n\x01\x00"
    _check(prefix + data if data[:1] != b"\0" else data)
