"""One line on stderr when a command's build is still running after a while (``build``, ``encode``).

On a machine whose numba cache is cold (a new install, an upgrade, an emptied ``NUMBA_CACHE_DIR``) the first
build compiles the kernels: cow's first ``build --encoding sliding-window`` printed nothing for 83 s on a
loaded 2-core machine, then "built in 81.48 s", and looked hung until then. ``run`` says so before it starts
(:mod:`.pipeline.progress`); the single-mesh commands say it once the build has taken
:data:`AFTER_S` seconds, and nothing on a warm machine's quick build.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

#: seconds a build runs before the notice (a warm build of the shared meshes takes 0.1-3 s)
AFTER_S = 10.0

MESSAGE = (
    "still building: a first build on this machine compiles numba's kernels (a minute or more, once; "
    "later builds load them), and a large mesh takes longer"
)


@contextmanager
def notice_if_slow(after_s: float | None = None, message: str = MESSAGE) -> Iterator[threading.Timer]:
    """Print ``message`` on stderr once if the block is still running after ``after_s`` seconds (default
    :data:`AFTER_S`); the block gets the timer (a daemon thread, cancelled when the block ends)."""
    timer = threading.Timer(AFTER_S if after_s is None else after_s, _say, args=(message,))
    timer.daemon = True
    timer.start()
    try:
        yield timer
    finally:
        timer.cancel()


def _say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)
