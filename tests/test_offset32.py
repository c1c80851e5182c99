"""The OFFSET32 feature (spec/format.md 1): ``idx`` types only the arrays an engine uploads, ``off`` every
other integer array (windows, records, level tables, RCNT). A pool longer than 65,535 indices of fewer than
65,536 vertices is written with u16 ``INDX`` and u32 tables (bunny's sliding window); 65,536 vertices make
the file INDEX32 (both u32) without OFFSET32; a small file has neither. Offsets the validator reports step
by O in the tables (spec/errors.md), and files of a writer before 0.9.0 (one width for all) still read and
are saved in the new layout."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from conftest import shared_mesh

import swpm_usd
from swpm_usd.format import layout as L
from swpm_usd.format import vectors as vec
from swpm_usd.format.reader import load_bytes, validate_bytes
from swpm_usd.format.writer import encode_bytes


def _features(data: bytes) -> int:
    return struct.unpack_from("<I", data, 20)[0]


def _assert_same_buffers(back, pm) -> None:  # noqa: ANN001
    """Every buffer of the loaded mesh holds the built one's values, in the type of its array."""
    built, loaded = pm.buffers(), back.buffers()
    assert sorted(built) == sorted(loaded)
    for name, a in built.items():
        assert np.array_equal(np.asarray(loaded[name], np.int64), np.asarray(a, np.int64)), name


@pytest.fixture(scope="module")
def bunny_sw():
    return swpm_usd.build(shared_mesh("stanford-bunny.obj"), encoding="sliding-window")


def test_a_bunny_pool_is_u16_with_u32_tables(bunny_sw) -> None:
    pm = bunny_sw
    pool = np.asarray(pm.index_pool)
    assert pm.vertex_count <= 0xFFFF and pool.shape[0] > 0xFFFF  # the pool's length alone needs u32
    data = encode_bytes(pm)
    feats = _features(data)
    assert feats & L.FEATURE_OFFSET32 and not feats & L.FEATURE_INDEX32
    _, _, indx_len = vec.chunk(data, L.INDX)
    assert indx_len == 2 * pool.shape[0]
    _, _, wrec_len = vec.chunk(data, L.WREC)
    assert wrec_len == 3 * 4 * pm.lod_count
    rep = validate_bytes(data)
    assert rep.valid and not rep.problems, rep.format()
    assert (rep.summary["index_width"], rep.summary["offset_width"], rep.summary["index_values_width"]) == (
        2,
        4,
        2,
    )
    back = load_bytes(data)
    assert back.index_pool.dtype == np.uint16 and back.window_records.dtype == np.uint32
    _assert_same_buffers(back, pm)
    for k in (0, pm.lod_count // 2, pm.lod_count - 1):
        assert np.array_equal(back.triangles_at(k), pm.triangles_at(k)), k
    # the file of a writer before 0.9.0 (one width: u32 through the pool's offsets) reads the same and is
    # saved again in the new layout, byte for byte the build's
    old = encode_bytes(pm, legacy=True)
    assert _features(old) & L.FEATURE_INDEX32 and not _features(old) & L.FEATURE_OFFSET32
    assert vec.chunk(old, L.INDX)[2] == 4 * pool.shape[0]
    assert (
        len(old) - len(data) >= 2 * pool.shape[0]
    )  # (every other chunk the same size, give or take padding)
    loaded = load_bytes(old)
    _assert_same_buffers(loaded, pm)
    assert encode_bytes(loaded) == data


def _list_window(V: int):
    from swpm_usd.encode.sw_mesh import SlidingWindowProgressiveMesh

    return SlidingWindowProgressiveMesh(
        np.zeros((V, 3), np.float32),
        {},
        np.array([V]),
        np.array([1]),
        np.zeros(1, np.float32),
        index_pool=np.array([0, 1, V - 1], np.uint32),
        window_records=np.array([[0, 1, V]], np.uint32),
        params={"primitive": "list"},
    )


def test_65536_vertices_make_index32_without_offset32() -> None:
    """V > 65,535 makes ``idx`` u32 (INDEX32), and ``off`` is u32 with it: OFFSET32 is not set (spec 1: MUST
    NOT), even where a table value (the window's vertex_count 65,537) needs u32."""
    pm = _list_window(0x10001)
    data = encode_bytes(pm)
    assert _features(data) & L.FEATURE_INDEX32 and not _features(data) & L.FEATURE_OFFSET32
    rep = validate_bytes(data)
    assert rep.valid and not rep.problems, rep.format()
    assert (rep.summary["index_width"], rep.summary["offset_width"]) == (4, 4)
    back = load_bytes(data)
    assert back.index_pool.dtype == back.window_records.dtype == np.uint32
    _assert_same_buffers(back, pm)
    # forcing OFFSET32 on it changes nothing: INDEX32 already widens the tables
    assert encode_bytes(pm, offset_width=4) == data


def test_a_table_value_past_65535_alone_sets_offset32() -> None:
    """65,535 vertices (every id below 0xFFFF) whose window says 65,535 vertices: u16 throughout; a pool
    starting at 65,536 (an offset past u16) sets OFFSET32 and leaves ``INDX`` u16."""
    pm = _list_window(0xFFFF)
    assert _features(encode_bytes(pm)) & (L.FEATURE_INDEX32 | L.FEATURE_OFFSET32) == 0
    pm.index_pool = np.r_[np.zeros(0x10000 * 3, np.uint32), pm.index_pool].astype(np.uint32)
    pm.window_records = np.array([[0x10000 * 3, 1, 0xFFFF]], np.uint32)
    data = encode_bytes(pm)
    assert _features(data) & L.FEATURE_OFFSET32 and not _features(data) & L.FEATURE_INDEX32
    assert validate_bytes(data).valid
    back = load_bytes(data)
    assert back.index_pool.dtype == np.uint16 and back.window_records.dtype == np.uint32
    assert back.triangles_at(0).tolist() == [[0, 1, 0xFFFE]]


@pytest.mark.parametrize("encoding", ["vanilla", "sliding-window", "skip-strip", "mixed"])
def test_a_small_build_has_neither_bit_and_round_trips(encoding: str) -> None:
    pm = swpm_usd.build(shared_mesh("suzanne.obj"), encoding=encoding)
    data = encode_bytes(pm)
    assert _features(data) & (L.FEATURE_INDEX32 | L.FEATURE_OFFSET32) == 0
    rep = validate_bytes(data)
    assert rep.valid and not rep.problems, rep.format()
    back = load_bytes(data)
    _assert_same_buffers(back, pm)
    # (the mesh's arrays keep the file's type, ``buffers()`` gives them as u32; prev_change_count is derived)
    stored = [n for n in back.buffers() if n != "collapse_prev_change_count"]
    assert all(getattr(back, n).dtype == np.uint16 for n in stored)
    # forced OFFSET32 (a writer SHOULD NOT, the file is valid): the tables u32, the lists u16, same values
    forced = encode_bytes(pm, offset_width=4)
    assert _features(forced) & L.FEATURE_OFFSET32 and not _features(forced) & L.FEATURE_INDEX32
    rep = validate_bytes(forced)
    assert rep.valid and not rep.problems, rep.format()
    wide = load_bytes(forced)
    _assert_same_buffers(wide, pm)
    for name in stored:
        assert getattr(wide, name).dtype == (np.uint16 if name in L.INDEX_ARRAYS else np.uint32), name
    assert encode_bytes(wide) == data  # saved again: the writer's rule, no OFFSET32


def test_a_reader_that_does_not_know_offset32_rejects_it(monkeypatch) -> None:  # noqa: ANN001
    """Bit 6 is a required feature: a reader without it (``KNOWN_FEATURES`` as before 0.9.0) must reject the
    file (SWPM_HEADER_UNKNOWN_FEATURE at the features field), not misread its u32 tables as u16."""
    data = encode_bytes(vec.fan_sliding(), offset_width=4)
    assert validate_bytes(data).valid
    monkeypatch.setattr(L, "KNOWN_FEATURES", L.KNOWN_FEATURES & ~L.FEATURE_OFFSET32)
    rep = validate_bytes(data)
    assert not rep.valid and (rep.problems[0].code, rep.problems[0].offset) == (
        "SWPM_HEADER_UNKNOWN_FEATURE",
        20,
    )


def test_both_bits_are_an_error_read_as_u32() -> None:
    """OFFSET32 with INDEX32: SWPM_HEADER_OFFSET32_WITH_INDEX32, the checks go on with idx = off = u32."""
    data = encode_bytes(vec.fan_vanilla(), index_width=4)
    both = vec.patch(data, 20, "<I", _features(data) | L.FEATURE_OFFSET32)
    assert [(p.code, p.offset) for p in validate_bytes(both).problems] == [
        ("SWPM_HEADER_OFFSET32_WITH_INDEX32", 20)
    ]
    # the header's other checks go on (a wrong file CRC is still found); the encoding's then do not run
    bad = vec.patch(both, L.FILE_CRC_OFFSET, "<I", 0x12345678, crc=False)
    codes = [p.code for p in validate_bytes(bad).problems]
    assert codes == ["SWPM_HEADER_OFFSET32_WITH_INDEX32", "SWPM_CHECKSUM_MISMATCH"]


def test_resaving_a_u32_file_of_an_older_writer_settles_its_restart() -> None:
    """A strip pool in a u32 file joined by 0xFFFFFFFF (as a writer before 0.9.0 wrote any pool whose offsets
    passed 65,535), loaded and saved: u16, joined by 0xFFFF, drawing the same triangles."""
    old = encode_bytes(vec.fan_sliding_strips(0xFFFFFFFF), legacy=True)
    assert _features(old) & L.FEATURE_INDEX32
    loaded = load_bytes(old)
    assert loaded.restart_index == 0xFFFFFFFF
    new = encode_bytes(loaded)
    assert _features(new) & (L.FEATURE_INDEX32 | L.FEATURE_OFFSET32) == 0
    assert new == encode_bytes(vec.fan_sliding_strips())
    back = load_bytes(new)
    assert back.restart_index == back.params["restart_index"] == 0xFFFF
    for k in range(back.lod_count):
        assert np.array_equal(back.triangles_at(k), loaded.triangles_at(k)), k


# -- the validator's offsets in an OFFSET32 file: tables step O = 4 bytes, lists W = 2 (spec/errors.md) ------
def _table(data: bytes, t: bytes) -> int:
    return vec.chunk(data, t)[1] + 8  # the record table follows the 8-byte record header


DEFECTS = {
    # name: (mesh with the defect, code, where the problem is expected in the OFFSET32 file)
    "prev-change-count": (
        vec.fan_vanilla(buffers={"collapse_prev_change_count": [1]}),
        "SWPM_RECORD_BAD_COUNTS",
        lambda d: _table(d, L.VREC) + 3 * 4,
    ),
    "change-offset-past-list": (
        vec.fan_vanilla(buffers={"collapse_change_offsets": [2, 99]}),
        "SWPM_INDEX_OUT_OF_RANGE",
        lambda d: _table(d, L.VREC) + 4 * 4 + 1 * 4,
    ),
    "skip-binned": (
        vec.fan_skip(buffers={"collapse_binned": [3]}),
        "SWPM_RECORD_BAD_BINNED",
        lambda d: _table(d, L.SREC) + 4,
    ),
    "window-triangles": (
        vec.fan_sliding(buffers={"window_records": [[0, 4, 5], [12, 3, 4]]}),
        "SWPM_WINDOW_COUNT_MISMATCH",
        lambda d: vec.chunk(d, L.WREC)[1] + 12 + 4,
    ),
    "strip-index-count": (
        vec.fan_sliding_strips(buffers={"window_index_counts": [7, 4]}),
        "SWPM_WINDOW_STRIP_TRIANGLES",
        lambda d: vec.chunk(d, L.WREC)[1] + 3 * 4,
    ),
    "mixed-dynamic-removed": (
        vec.fan_mixed(
            buffers={"collapse_dynamic_tris_removed": [3], "collapse_static_tris_removed": [0]},
            triangle_counts=np.array([4, 1]),
        ),
        "SWPM_RECORD_BAD_COUNTS",
        lambda d: _table(d, L.MREC) + 2 * 4,
    ),
    "mixed-dynamic-start": (
        vec.fan_mixed(buffers={"level_dynamic_start": [0, 9]}),
        "SWPM_MIXED_BAD_LEVELS",
        # MLVL: header 8, level_first_lod off[1] (4 bytes), level_static_start off[2] (8), then this array
        lambda d: vec.chunk(d, L.MLVL)[1] + 8 + 4 + 8,
    ),
    "index-above-vertex-count": (
        vec.fan_vanilla(buffers={"indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 9]}),
        "SWPM_INDEX_OUT_OF_RANGE",
        lambda d: vec.chunk(d, L.INDX)[1] + 11 * 2,  # INDX is idx: W = 2
    ),
}


@pytest.mark.parametrize("name", list(DEFECTS))
def test_offsets_in_tables_step_by_the_table_width(name: str) -> None:
    pm, code, where = DEFECTS[name]
    data = encode_bytes(pm, offset_width=4)
    assert _features(data) & L.FEATURE_OFFSET32
    found = [(p.code, p.offset) for p in validate_bytes(data).problems if p.code == code]
    assert found and found[0] == (code, where(data)), (name, found)
    # the same defect in the u16 file: the same codes, found where u16 puts them
    narrow = [p.code for p in validate_bytes(encode_bytes(pm)).problems]
    assert narrow == [p.code for p in validate_bytes(data).problems], name


def test_table_lengths_count_in_the_table_width() -> None:
    """RCNT a multiple of O (6 bytes in an OFFSET32 file: bad), WREC 3 O L."""
    data = encode_bytes(vec.fan_vanilla(), offset_width=4)
    bad = vec.relayout(data, {L.RCNT: bytes(6)})
    eo = vec.chunk(bad, L.RCNT)[0]
    assert [(p.code, p.offset) for p in validate_bytes(bad).problems] == [("SWPM_CHUNK_BAD_LENGTH", eo + 16)]


# -- spec/format.md 7 types every decoded array idx or off, as the reader views it ---------------------------
def _spec_array_types() -> dict[str, str]:
    """name -> type of the encodings' decoded arrays in spec/format.md 7 (``collapse_<column>`` as given)."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "spec" / "format.md").read_text()
    section = text[text.index("| Encoding | Name | Type | Shape | From |") :].split("\n\n")[0]
    out = {}
    for line in section.splitlines()[2:]:
        cells = [c.strip() for c in line.strip("|").split("|")]
        for name in re.findall(r"`([^`]+)`", cells[1]):
            out[name] = cells[2]
    return out


def test_the_spec_types_each_decoded_array_idx_or_off_as_the_reader_does() -> None:
    """Every encoding array of spec/format.md 7 is typed ``idx`` (the uploaded lists,
    :data:`.layout.INDEX_ARRAYS`) or ``off`` (every other), and the reader views it so in an OFFSET32 file
    of each encoding (W = 2, O = 4): its element size is W for ``idx``, O for ``off``."""
    from swpm_usd.format.reader import _check

    types = _spec_array_types()
    assert set(types.values()) == {"idx", "off"}, types
    assert {n for n, t in types.items() if t == "idx"} == set(L.INDEX_ARRAYS)
    seen = set()
    for pm in (vec.fan_vanilla(), vec.fan_sliding_strips(), vec.fan_skip_strip(), vec.fan_mixed()):
        data = encode_bytes(pm, offset_width=4)
        rep, p = _check(np.frombuffer(data, np.uint8), None)
        assert rep.valid and p is not None, rep.format()
        for name, a in p.buffers.items():
            spec = types.get(name) or types["collapse_<column>" if name.startswith("collapse_") else name]
            assert a.dtype.itemsize == (2 if spec == "idx" else 4), (pm.encoding, name)
            seen.add(name)
    assert {n for n in types if "<" not in n} <= seen


def test_the_vector_schema_requires_the_table_width() -> None:
    """spec/format.md 7: a valid vector's summary holds ``offset_width`` (O: 2 or 4) beside ``index_width``;
    the expected-result schema (spec/manifest.schema.json) must require it and allow only 2 or 4, as it does
    ``index_width`` (it accepted a summary without it, or with 3)."""
    import json
    from pathlib import Path

    import jsonschema

    spec = Path(__file__).resolve().parents[1] / "spec"
    schema = json.loads((spec / "manifest.schema.json").read_text())
    expected = {**schema["$defs"]["expected"], "$defs": schema["$defs"]}
    exp = json.loads((spec / "vectors" / "valid" / "sliding-window-offset32.json").read_text())
    jsonschema.validate(exp, expected)
    assert exp["summary"]["offset_width"] == 4
    for bad in (3, None):
        summary = {k: v for k, v in exp["summary"].items() if k != "offset_width"}
        if bad is not None:
            summary["offset_width"] = bad
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate({**exp, "summary": summary}, expected)


@pytest.mark.parametrize("offset_width", [2, 4])
@pytest.mark.parametrize(("maker", "t"), [(vec.fan_skip_strip, L.SKIP), (vec.fan_mixed, L.MLVL)])
def test_a_level_chunk_shorter_than_its_header_needs_8_bytes(maker, t: bytes, offset_width: int) -> None:  # noqa: ANN001
    """A SKIP or MLVL of fewer than 8 bytes (its two u32 counts) is SWPM_CHUNK_BAD_LENGTH at its entry's
    length field, its message needing 8 bytes whatever W and O (SKIP's said it needed 6 of 6 bytes)."""
    data = encode_bytes(maker(), offset_width=offset_width)
    eo, off, _ = vec.chunk(data, t)
    bad = vec.relayout(data, {t: data[off : off + 6]})
    problems = validate_bytes(bad).problems
    assert [(p.code, p.offset) for p in problems] == [("SWPM_CHUNK_BAD_LENGTH", vec.chunk(bad, t)[0] + 16)]
    assert problems[0].message.endswith("is 6 bytes, its contents need 8"), problems[0].message


@pytest.mark.parametrize(
    "kwargs", [{"offset_width": 3}, {"offset_width": 8}, {"index_width": 3}, {"index_width": 8}]
)
def test_a_width_other_than_2_or_4_is_refused(kwargs: dict) -> None:
    """``index_width`` and ``offset_width`` are 2 or 4 bytes (or None): another value is a ValueError, not a
    file (``offset_width=3`` wrote u32 tables without the OFFSET32 bit, a file its own reader rejects;
    ``index_width=8`` wrote u16)."""
    with pytest.raises(ValueError, match="width"):
        encode_bytes(vec.fan_vanilla(), **kwargs)
    for ok in (None, 2, 4):
        assert validate_bytes(encode_bytes(vec.fan_vanilla(), **{next(iter(kwargs)): ok})).valid
