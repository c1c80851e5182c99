"""Ctrl-C during a run: deferred, noted or ignored around the steps a KeyboardInterrupt must not cut short.

A run stops its workers, puts back the outputs they kept aside and writes its manifest when it is
interrupted; these context managers decide where the interrupt lands (the worker pool's start, its wait, the
clean-up). Separate from the runner because the pool (:mod:`.pool`) and the run (:mod:`.runner`) both use
them, and the rules (main thread only, Python's own handler only) are the same for both.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator


def _interrupts_raise() -> bool:
    """Does Ctrl-C raise KeyboardInterrupt here (Python's own handler, in the main thread)? A process started
    with it ignored (a background job of a script) or a caller's own handler keep it as it is."""
    return (
        threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGINT) is signal.default_int_handler
    )


@contextlib.contextmanager
def _interrupts_deferred() -> Iterator[None]:
    """A Ctrl-C in the block is raised (KeyboardInterrupt) when it ends, not inside it (main thread only;
    when Ctrl-C raises KeyboardInterrupt: see :func:`_interrupts_raise`)."""
    if not _interrupts_raise():
        yield
        return
    received: list[int] = []
    old = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
    if received:
        raise KeyboardInterrupt


@contextlib.contextmanager
def _interrupts_noted() -> Iterator[list[int]]:
    """Ctrl-C raises KeyboardInterrupt as usual in the block, and is noted in the list it yields (main
    thread only), so one that something caught and turned into another error is still known (when Ctrl-C
    raises KeyboardInterrupt: see :func:`_interrupts_raise`). Only the first raises: another, while the
    first stops the run, would cut its clean-up short (a handler not restored, workers not stopped)."""
    noted: list[int] = []
    if not _interrupts_raise():
        yield noted
        return

    def note(signum: int, frame: object) -> None:
        noted.append(signum)
        if len(noted) == 1:
            raise KeyboardInterrupt

    old = signal.signal(signal.SIGINT, note)
    try:
        yield noted
    finally:
        signal.signal(signal.SIGINT, old)


@contextlib.contextmanager
def _interrupts_ignored() -> Iterator[None]:
    """Ctrl-C ignored in the block (the main thread only: elsewhere signals cannot be set, nor arrive)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
