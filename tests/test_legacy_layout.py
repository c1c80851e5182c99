"""Files a reader before 0.9.0 accepts: ``swpm_usd.save(..., legacy_layout=True)`` and ``encode
--legacy-layout`` write one integer width for every array and never the OFFSET32 bit (spec/format.md 1), so
a sliding-window pool longer than 65,535 indices makes the file INDEX32 throughout. (The pipeline's
``output.legacy_layout`` is tested in test_pipeline.py.)"""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import SHARED_MESHES, shared_mesh

import swpm_usd
from swpm_usd.cli import main
from swpm_usd.format import layout as L
from swpm_usd.format.reader import load, validate


def _features(path) -> int:  # noqa: ANN001
    with open(path, "rb") as f:
        return struct.unpack_from("<I", f.read(L.HEADER_SIZE), 20)[0]


@pytest.fixture(scope="module")
def bunny_sw():
    return swpm_usd.build(shared_mesh("stanford-bunny.obj"), encoding="sliding-window")


def test_save_legacy_layout_is_index32_without_offset32_and_loads_equal(bunny_sw, tmp_path) -> None:
    pm = bunny_sw
    default = swpm_usd.save(pm, tmp_path / "bunny.swpm")
    legacy = swpm_usd.save(pm, tmp_path / "bunny-legacy.swpm", legacy_layout=True)
    assert _features(default) & L.FEATURE_OFFSET32 and not _features(default) & L.FEATURE_INDEX32
    assert _features(legacy) & L.FEATURE_INDEX32 and not _features(legacy) & L.FEATURE_OFFSET32
    rep = validate(legacy)
    assert rep.valid and not rep.problems, rep.format()
    assert (rep.summary["index_width"], rep.summary["offset_width"]) == (4, 4)
    # the cost: the pool u32 too (every other chunk the same size, give or take padding)
    pool = np.asarray(pm.index_pool).shape[0]
    assert legacy.stat().st_size - default.stat().st_size >= 2 * pool
    back = load(legacy)
    assert back.index_pool.dtype == np.uint32
    built = pm.buffers()
    assert sorted(back.buffers()) == sorted(built)
    for name, a in built.items():
        assert np.array_equal(np.asarray(back.buffers()[name], np.int64), np.asarray(a, np.int64)), name
    for k in (0, pm.lod_count // 2, pm.lod_count - 1):
        assert np.array_equal(back.triangles_at(k), pm.triangles_at(k)), k


def test_a_small_file_is_the_same_either_way(tmp_path) -> None:
    """Where nothing needs u32 there is nothing to give up: the legacy file is the default one."""
    pm = swpm_usd.build(shared_mesh("beetle.obj"), encoding="sliding-window")
    a = swpm_usd.save(pm, tmp_path / "a.swpm")
    b = swpm_usd.save(pm, tmp_path / "b.swpm", legacy_layout=True)
    assert a.read_bytes() == b.read_bytes()
    assert _features(a) & (L.FEATURE_INDEX32 | L.FEATURE_OFFSET32) == 0


def test_a_reader_before_offset32_reads_the_legacy_file_refuses_the_default(monkeypatch, tmp_path) -> None:
    pm = swpm_usd.build(shared_mesh("cow.obj"), encoding="sliding-window")
    default = swpm_usd.save(pm, tmp_path / "cow.swpm")
    legacy = swpm_usd.save(pm, tmp_path / "cow-legacy.swpm", legacy_layout=True)
    assert _features(default) & L.FEATURE_OFFSET32  # (cow's pool passes 65,535 indices)
    # a reader of 0.8: bit 6 unknown
    monkeypatch.setattr(L, "KNOWN_FEATURES", L.KNOWN_FEATURES & ~L.FEATURE_OFFSET32)
    old_reader = validate(default)
    assert not old_reader.valid
    assert (old_reader.problems[0].code, old_reader.problems[0].offset) == ("SWPM_HEADER_UNKNOWN_FEATURE", 20)
    rep = validate(legacy)
    assert rep.valid and not rep.problems, rep.format()
    assert np.array_equal(load(legacy).triangles_at(0), pm.triangles_at(0))


def test_encode_legacy_layout_json(tmp_path) -> None:
    runner = CliRunner()
    outs = {}
    for name, extra in (("default", []), ("legacy", ["--legacy-layout"])):
        out = tmp_path / f"cow-{name}.swpm"
        args = ["encode", str(SHARED_MESHES / "cow.obj"), "-o", str(out), "-e", "sliding-window", *extra]
        result = runner.invoke(main, [*args, "--json"])
        assert result.exit_code == 0, result.output
        outs[name] = json.loads(result.stdout)
        assert outs[name]["bytes"] == out.stat().st_size
        assert _features(out) & L.FEATURE_OFFSET32 == (L.FEATURE_OFFSET32 if name == "default" else 0)
    assert (outs["default"]["index_width"], outs["default"]["offset_width"]) == (2, 4)
    assert (outs["legacy"]["index_width"], outs["legacy"]["offset_width"]) == (4, 4)
    assert (outs["default"]["legacy_layout"], outs["legacy"]["legacy_layout"]) == (False, True)
    assert outs["legacy"]["bytes"] > outs["default"]["bytes"]
    help_text = runner.invoke(main, ["encode", "--help"]).output
    assert "--legacy-layout" in help_text and "before 0.9.0" in help_text


def test_encode_says_the_layout_it_wrote(tmp_path) -> None:
    runner = CliRunner()
    lines = {}
    for name, extra in (("default", []), ("legacy", ["--legacy-layout"])):
        out = tmp_path / f"cow-{name}.swpm"
        args = ["encode", str(SHARED_MESHES / "cow.obj"), "-o", str(out), "-e", "sliding-window", *extra]
        result = runner.invoke(main, args)
        assert result.exit_code == 0, result.output
        lines[name] = result.stdout.strip()
    assert lines["default"].endswith("bytes, index u16, tables u32"), lines["default"]
    assert lines["legacy"].endswith("bytes, index u32, tables u32, legacy layout"), lines["legacy"]


@pytest.mark.parametrize("value", ["false", "yes", 1, 0, None])
def test_legacy_layout_is_true_or_false(value, tmp_path) -> None:  # noqa: ANN001
    """A value that is not a bool is a TypeError naming it, not a layout picked by its truth: ``"false"``
    (a config value read as text) wrote the legacy file, ``None`` the default, without a word."""
    pm = swpm_usd.build(shared_mesh("suzanne.obj"), encoding="vanilla")
    with pytest.raises(TypeError, match=f"legacy_layout must be True or False, not {value!r}"):
        swpm_usd.save(pm, tmp_path / "s.swpm", legacy_layout=value)
    assert not (tmp_path / "s.swpm").exists()
    with pytest.raises(TypeError, match="legacy must be True or False"):
        swpm_usd.format.encode_bytes(pm, legacy=value)
    for ok in (True, False, np.bool_(True)):
        assert validate(swpm_usd.save(pm, tmp_path / "s.swpm", legacy_layout=ok)).valid
