"""The README's Python example runs as written (in a scratch folder, with the repository's samples)."""

from __future__ import annotations

import re
import shutil

from conftest import ROOT


def test_the_readme_python_example_runs(tmp_path, monkeypatch):
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks, "the README has no Python example"
    shutil.copytree(ROOT / "samples", tmp_path / "samples", ignore=shutil.ignore_patterns("out"))
    monkeypatch.chdir(tmp_path)  # (it writes spot.swpm and spot.usdc where it runs)
    scopes = []
    for code in blocks:
        scope: dict = {}
        exec(compile(code, "README.md", "exec"), scope)  # noqa: S102 - the README's own example
        scopes.append(scope)
    # the streaming example drew coarse LODs before the whole file, finer ones as it came, then LOD 0
    drawn = scopes[1]["drawn"]
    assert drawn[0] > 0 and drawn == sorted(drawn, reverse=True) and drawn[-1] == 0
    scope = scopes[0]
    # what the first example leaves behind: the files it wrote, read back as it shows
    pm, pm2, pm3 = scope["pm"], scope["pm2"], scope["pm3"]
    assert (tmp_path / "spot.swpm").is_file() and (tmp_path / "spot.usdc").is_file()
    assert pm2.lod_count == pm3.lod_count == pm.lod_count and pm.encoding == "sliding-window"


def _streaming_example() -> str:
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    return next(b for b in blocks if "open_prefix" in b)


def test_the_readme_streaming_example_stops_on_a_bad_file(tmp_path, monkeypatch):
    """The prefix loop raises the file's SwpmFormatError for a file that is not just still arriving: one cut
    short (its header names bytes that never come), one with a bad magic, one that does not stream. Before,
    it looked up ``prefix_need`` on any error (KeyError) and looped for ever on a file cut inside VERT."""
    import swpm_usd.format
    import swpm_usd.format.prefix as prefix_module
    from swpm_usd.format import SwpmFormatError

    code = compile(_streaming_example(), "README.md", "exec")
    calls = []
    real = prefix_module.open_prefix

    def counted(*args, **kwargs):  # a loop that does not end fails here instead of hanging the suite
        calls.append(1)
        assert len(calls) < 100, "the README's prefix loop does not end"
        return real(*args, **kwargs)

    monkeypatch.setattr(swpm_usd.format, "open_prefix", counted)
    monkeypatch.setattr(prefix_module, "open_prefix", counted)
    monkeypatch.chdir(tmp_path)
    vectors = ROOT / "spec" / "vectors"
    good = (vectors / "valid" / "minimal-vanilla.swpm").read_bytes()
    cases = {
        "cut inside VERT": (good[:-4], "SWPM_FILE_SIZE_MISMATCH"),
        "cut inside the tables": (good[:100], "SWPM_PREFIX_TOO_SHORT"),
        "bad magic": ((vectors / "invalid" / "bad-magic.swpm").read_bytes(), "SWPM_HEADER_BAD_MAGIC"),
        "INDX after VERT": (
            (vectors / "valid" / "smap-empty-index-hull.swpm").read_bytes()[:-4],
            "SWPM_PREFIX_NOT_STREAMABLE",
        ),
    }
    for name, (data, code_expected) in cases.items():
        (tmp_path / "spot.swpm").write_bytes(data)
        calls.clear()
        try:
            exec(code, {})  # noqa: S102 - the README's own example
        except SwpmFormatError as exc:
            assert exc.report.errors[0].code == code_expected, name
        else:
            raise AssertionError(f"{name}: the example read a bad file without an error")
    # and the whole file still opens, draws and finishes
    (tmp_path / "spot.swpm").write_bytes(good)
    scope: dict = {}
    exec(code, scope)  # noqa: S102
    assert scope["drawn"] == [0] and scope["pm"].lod_count >= 1
