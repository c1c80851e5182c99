"""What a probe found, as the one-line :class:`Problem` a caller turns into its typed error.

:func:`_problem` reads a probe's answer (its code, :mod:`.probe_program`'s, or minus the signal it died
by) as a "crash", "timeout", "open" or "read" problem naming the file; :func:`_not_regular` is the "open"
problem of a layer that is not a regular file, reported without opening it. Separate from :mod:`.probe`,
which starts the probes and keeps their answers: these are the messages alone, no process and no state.
"""

from __future__ import annotations

import signal
import stat
from typing import NamedTuple

from .probe_program import _CLEAN, _LAYER_FAILED, _NOT_REGULAR, _OPEN_FAILED


class Problem(NamedTuple):
    """What a probe found: ``kind`` "crash" (usd-core died by a signal), "timeout", "open" (it raised an
    error opening the file), "read" (opening it, but reading a value in it: corrupt data, which read in
    this process could ask for a giant allocation) or "probe" (the probe itself failed twice, not usd-core:
    the file was not opened, here or there), and ``message``, one line naming the file."""

    kind: str
    message: str


def _file_kind(mode: int) -> str:
    """What a file that is not a regular file is, by its ``st_mode``."""
    kinds = (
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    return next((what for test, what in kinds if test(mode)), "not a regular file")


def _not_regular(path: str, layer: str | None, mode: int) -> Problem:
    """The "open" :class:`Problem` of ``path`` when it (``layer`` None) or a layer its stage opens is not a
    regular file: reported at once, the file never opened (here or in a probe, where a FIFO's open would
    wait for a writer until :data:`.probe.PROBE_SECONDS`)."""
    what = "it is" if layer is None else f"a layer its stage opens, {layer}, is"
    return Problem("open", f"{path}: {what} not a regular file ({_file_kind(mode)}); it was not opened")


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def _problem(path: str, code: int, text: str, seconds: float) -> Problem | None:
    if code == _CLEAN:
        return None
    if code == -signal.SIGALRM:
        return _overran(path, seconds)
    if code < 0:
        said = f"; usd-core said: {text}" if text else ""
        return Problem(
            "crash",
            f"{path}: usd-core crashed opening or reading it (a probe process died by "
            f"{_signal_name(-code)}{said}): the file is corrupt; it was not opened in this process",
        )
    if code == _NOT_REGULAR:
        mode, _, layer = text.partition("|")
        return _not_regular(path, layer, int(mode))
    from ..errors import tf_message

    reason = tf_message(RuntimeError(text)) if text.strip() else "usd-core returned no stage"
    if code == _OPEN_FAILED:
        return Problem("open", f"{path}: usd-core cannot open it as a USD layer: {reason}")
    if code == _LAYER_FAILED:
        return Problem("open", f"{path}: usd-core cannot open a crate layer its stage uses, {reason}")
    return Problem("read", f"{path}: usd-core cannot read it: {reason}")


def _overran(path: str, seconds: float) -> Problem:
    return Problem(
        "timeout",
        f"{path}: usd-core did not finish opening and reading it within {seconds:g} s (a probe process was "
        "stopped): the file is corrupt, or larger than SWPM_USD_PROBE_SECONDS allows",
    )
