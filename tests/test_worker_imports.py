"""A run's workers import what the runner imports, not the modules of the folder the run is started in.

Python 3.11's fork server ignores the import path it is given and starts as ``python -c``, which puts the
current folder first: a ``trimesh.py`` (or ``numba.py``) lying in an asset library was imported by every
worker of a run started there (helper-196's audit). :func:`swpm_usd.pipeline.pool._server_import_path`.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

SHARED_MESHES = Path(__file__).resolve().parents[2] / "shared" / "meshes"

# a module named as one the fork server preloads for an OBJ: it leaves a mark, then refuses to be trimesh
SHADOW = """\
from pathlib import Path
Path(__file__).with_name("shadow-imported").write_text("yes")
raise ImportError("the library folder's trimesh.py, not trimesh")
"""

CONFIG = """\
version: 1
assets:
  - glob: "meshes/*.obj"
output:
  dir: out
defaults:
  encoding: vanilla
"""


def test_a_run_started_in_a_folder_does_not_import_that_folders_modules(tmp_path):
    script = Path(sys.executable).with_name("swpm-pipeline")  # the console script (its own folder first)
    assert script.exists(), script
    (tmp_path / "meshes").mkdir()
    for name in ("a.obj", "b.obj"):
        shutil.copy(SHARED_MESHES / "suzanne.obj", tmp_path / "meshes" / name)
    (tmp_path / "pipeline.yaml").write_text(CONFIG)
    (tmp_path / "trimesh.py").write_text(SHADOW)
    proc = subprocess.run(
        [str(script), "run", "pipeline.yaml", "--jobs", "2", "--json"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"},
    )
    assert not (tmp_path / "shadow-imported").exists(), proc.stderr[-2000:]
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads(proc.stdout)
    assert result["built"] == 2 and result["failed"] == 0
