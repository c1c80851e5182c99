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
