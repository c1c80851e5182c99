"""Small warts a new user met (helper-245): the generators' commands warned, a sliding window's direct
build took any cache size, and a few command-line messages and exit codes."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    ("module", "args", "checked_in"),
    [
        ("swpm_usd.format.errors", [], "spec/errors.md"),
        ("swpm_usd.format.errors", ["--c"], "runtime/c/swpm_codes.h"),
        ("swpm_usd.pipeline.schema", [], "pipeline/pipeline.schema.json"),
    ],
)
def test_the_generators_commands_run_without_runpys_warning(module, args, checked_in):
    """Their packages imported them before runpy ran them: ``RuntimeWarning: 'swpm_usd.format.errors' found
    in sys.modules after import of package 'swpm_usd.format'``, on every regeneration."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONDONTWRITEBYTECODE": "1"}
    proc = subprocess.run(
        [sys.executable, "-W", "error::RuntimeWarning", "-m", module, *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr[-2000:]
    assert proc.stdout == (ROOT / checked_in).read_text(), f"regenerate: python -m {module} {' '.join(args)}"
