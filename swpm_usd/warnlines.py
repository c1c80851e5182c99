"""The package's own warnings as one line, ``warning: <message>``, on a command's stderr and a run's workers'.

Python's default format printed a loader's warning as ``/…/swpm_usd/io/__init__.py:92: UserWarning: cow.usda:
attributes ['uv'] are missing on some of its 2 meshes; dropped`` followed by the package's own code line
(``return load_usd(p, ...)``), which told a user nothing; the message itself names the file and what happened,
as the run's ``warning: ...`` lines do. Warnings of other packages keep Python's format (their origin is
theirs to show). Installed by the command (:mod:`.cli`) and a pool's worker (:func:`.pipeline.worker.serve`)
only: a program that imports the package keeps its own format.
"""

from __future__ import annotations

import os
import warnings
from typing import Any

_PACKAGE = os.path.dirname(os.path.abspath(__file__)) + os.sep


def package_warnings_as_lines() -> None:
    """Format this package's ``UserWarning`` as ``warning: <message>`` in this process (once)."""
    default = warnings.formatwarning
    if getattr(default, "_swpm_lines", False):
        return

    def formatwarning(
        message: Warning | str, category: type[Warning], filename: str, lineno: int, line: str | None = None
    ) -> str:
        if category is UserWarning and os.path.abspath(filename).startswith(_PACKAGE):
            return f"warning: {message}\n"
        return default(message, category, filename, lineno, line)

    formatwarning_any: Any = formatwarning
    formatwarning_any._swpm_lines = True
    warnings.formatwarning = formatwarning
