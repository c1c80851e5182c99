"""The local executor: a pool of worker processes running one task each, and the fork server they start from.

:func:`_local_pool` runs each task (a dict, :func:`.tasks._task`) on a worker process of its own
(:func:`.worker.serve`), one at a time, and yields each record as it finishes: a worker that dies fails its
asset alone, one past ``limits.seconds`` is stopped, and Ctrl-C or an error stops them all. The workers fork
from a server that has imported the package once (:func:`_forkserver_preload`) and warmed the tasks'
encodings (:func:`_warm_encodings`, :mod:`._warm`); :func:`.runner.execute` starts it. Separate from the
runner: process management, pipes and signals, which the planning and the records never touch.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Generator, Iterator
from pathlib import Path
from typing import Any

from .interrupts import _interrupts_deferred, _interrupts_ignored, _interrupts_noted, _interrupts_raise
from .worker import READY, ignore_interrupts, serve

#: how long a worker process may take to start (fork from the server, or spawn) before its task's
#: ``limits.seconds`` counts: its start-up is the pool's, not the asset's (a hung start still ends)
_START_S = 60.0


def _forkserver_pid() -> int | None:
    """The pid of this process's fork server, or None when none is running (or known)."""
    from multiprocessing import forkserver

    return getattr(getattr(forkserver, "_forkserver", None), "_forkserver_pid", None)


def _warm_encodings(tasks: list[dict]) -> list[str]:
    """The encodings the fork server warms (:mod:`._warm`) for ``tasks``: each task's, every candidate of
    ``auto``, and for a task whose rule waits for its triangle count (``config_data``) those of every rule
    and of the defaults (each once, in the order first named); none for a broken input retried
    (``failed_loading``: a rerun of 500 assets whose only tasks were its 10 broken ones warmed all four)."""
    from .worker import AUTO_CANDIDATES

    found: dict[str, None] = {}
    for t in tasks:
        if t.get("failed_loading"):
            continue  # (a broken input retried: it fails before any build, most likely)
        data = t.get("config_data")
        if data is None:
            names = [t.get("encoding")]
        else:
            names = [r.get("encoding") for r in data.get("rules", [])]
            names.append((data.get("defaults") or {}).get("encoding", "sliding-window"))
        for name in names:
            for enc in AUTO_CANDIDATES if name == "auto" else (name,):
                if isinstance(enc, str):
                    found.setdefault(enc)
    return list(found)


#: what the fork server preloads for an OBJ, PLY, STL, OFF or glTF (:func:`_forkserver_preload`)
_TRIMESH_PRELOAD = ("trimesh", "swpm_usd.io.trimesh_loader")


def _forkserver_preload(tasks: list[dict]) -> list[str]:
    """The modules the fork server imports before it forks a worker: the warm-up of the tasks' encodings
    (:func:`_warm_encodings`), and usd-core's writer and loader when a task writes a USD layer or reads a
    USD file (each worker forked from a server without them imported pxr itself: ~0.5 s a worker loaded)."""
    from ..io import _TRIMESH_SUFFIXES, _USD_SUFFIXES

    live = [t for t in tasks if not t.get("failed_loading")]  # (a broken input retried: it fails first)
    usd = any(t.get("write_usd") or Path(t["path"]).suffix.lower() in _USD_SUFFIXES for t in live)
    # trimesh (scipy) for an OBJ, PLY, STL, OFF or glTF: imported once here, not by each worker
    meshes = any(Path(t["path"]).suffix.lower() in _TRIMESH_SUFFIXES for t in live)
    return [
        "swpm_usd.pipeline._warm",
        *(["swpm_usd.usd.writer", "swpm_usd.io.usd_loader"] if usd else []),
        *(_TRIMESH_PRELOAD if meshes else []),
    ]


def _server_import_path() -> str:
    """``PYTHONPATH`` for the fork server, with ``PYTHONSAFEPATH=1`` beside it: the runner's first import
    folder (its script's, or the current folder under ``python -m`` / ``-c``), then the inherited entries.

    Python 3.11's fork server ignores the ``sys_path`` it is given and runs as ``python -c``, which puts the
    current folder first on its path: a run started in an asset library imported that folder's ``trimesh.py``
    or ``numba.py`` (or a checkout's ``swpm_usd`` over the installed one) into every worker. The server now
    imports what the runner imports: its own first folder is left out (``PYTHONSAFEPATH``), the runner's is
    put first."""
    first = sys.path[0] if sys.path else ""
    folders = [os.path.abspath(first or os.curdir)]
    inherited = os.environ.get("PYTHONPATH")
    return os.pathsep.join([*folders, *([inherited] if inherited else [])])


@contextlib.contextmanager
def _environ(name: str, value: str) -> Iterator[None]:
    """``os.environ[name]`` set to ``value`` within (then as it was)."""
    before = os.environ.get(name)
    os.environ[name] = value
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = before


class _Worker:
    """A worker process of the local pool (:func:`.worker.serve`), the task it builds (None: idle) and when
    that task must be done by (``time.monotonic``)."""

    def __init__(self, ctx: Any) -> None:
        self.conn, theirs = ctx.Pipe()
        self.process = ctx.Process(target=serve, args=(theirs,), name="swpm-pipeline-worker", daemon=True)
        self.process.start()
        theirs.close()
        self.task: dict | None = None
        self.started = 0.0
        self.deadline = float("inf")
        self.limit_s: float | None = None
        self.is_ready = False  # (until it sends worker.READY: its start-up is not its task's time)

    def give(self, task: dict, limit_s: float | None) -> bool:
        """Send ``task``; False when the pipe is broken (the process died before: it never had the task).
        A worker still starting has :data:`_START_S` more to its deadline; :meth:`ready` moves it."""
        self.task = task
        self.started = time.monotonic()
        self.limit_s = limit_s
        if limit_s is None:
            self.deadline = float("inf")
        else:
            self.deadline = self.started + limit_s + (0.0 if self.is_ready else _START_S)
        try:
            self.conn.send(task)
        except OSError:  # (BrokenPipeError, ECONNRESET)
            return False
        return True

    def ready(self, when: float) -> None:
        """The worker has started (at ``when``, its ``time.monotonic``): its task's time counts from then."""
        self.is_ready = True
        if self.task is not None:
            self.started = min(time.monotonic(), max(self.started, when))
            if self.limit_s is not None:
                self.deadline = self.started + self.limit_s

    def stop(self) -> None:
        """Kill the process and wait for it (its temporary files are the caller's)."""
        if self.process.is_alive():
            self.process.kill()
        self.process.join(timeout=30)
        self.conn.close()


def _lost(w: _Worker, error: str, code: str = "WORKER_LOST") -> dict:
    """The failure record of the asset worker ``w`` was building when it died or was stopped (``code``:
    ``WORKER_LOST``, or ``TIME_LIMIT_EXCEEDED`` when the run stopped it)."""
    from ..codes import fields_of

    task = w.task or {}
    return {
        "id": task.get("id"),
        "digest": task.get("digest"),
        "status": "failed",
        "error": error,
        **fields_of(code),
        "seconds": time.monotonic() - w.started,
        "worker_lost": True,  # (the runner cleans up after it, then drops this key)
    }


def _death(exitcode: int | None) -> str:
    """Why a worker process ended, in words."""
    if exitcode is not None and exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        why = f"killed by {name}"
        if -exitcode == signal.SIGKILL:
            why += " (the system may have run out of memory: its out-of-memory killer sends SIGKILL)"
        elif -exitcode in (signal.SIGSEGV, signal.SIGBUS, signal.SIGABRT, signal.SIGILL):
            why += " (a crash in native code: usd-core, numba or a library)"
        return why
    return f"exited with code {exitcode}"


def _local_pool(tasks: list[dict], jobs: int, ctx: Any, limit_s: float | None) -> Generator[dict, None, None]:
    """Run ``tasks`` on ``jobs`` worker processes, one task each at a time, yielding each record as it
    finishes. A worker that dies fails its asset alone (with the cause: a signal, an exit code) and another
    takes its place; one still building ``limit_s`` seconds after it started is stopped, and its asset fails.
    Ctrl-C or an error: every worker is stopped at once (mid-asset), and it is raised."""
    from multiprocessing.connection import wait

    pending = list(reversed(tasks))  # (popped from the end: in the given order)
    workers: list[_Worker] = []

    def assign(i: int) -> None:
        """Give worker ``i`` the next task, a new worker in its place if it died idle (killed just after it
        sent its record) or dies as the task is sent (a task never received goes to the new worker; a
        second broken pipe leaves it to the wait, which reports the new worker's end)."""
        task, w = pending.pop(), workers[i]
        if not w.process.is_alive():
            w.stop()
            w = workers[i] = _Worker(ctx)
        if not w.give(task, limit_s):
            w.stop()
            workers[i] = _Worker(ctx)
            workers[i].give(task, limit_s)

    try:
        # a Ctrl-C while the workers start (waiting for the server to warm up) is raised once they have all
        # started: one interrupted half-way would be a process no list holds, left to end on its own
        with _interrupts_deferred():
            for _ in range(min(jobs, len(pending))):
                workers.append(_Worker(ctx))
        with _interrupts_noted():  # (a second Ctrl-C while the first stops the workers is ignored)
            for i in range(len(workers)):
                assign(i)
            while True:
                busy = [w for w in workers if w.task is not None]
                if not busy:
                    return
                first = min(w.deadline for w in busy)
                # (an hour at most: a wait over 2**31 ms, 24.8 days, raises OverflowError; it is waited again)
                timeout = None if first == float("inf") else min(3600.0, max(0.0, first - time.monotonic()))
                ready = set(wait([w.conn for w in busy] + [w.process.sentinel for w in busy], timeout))
                for i, w in enumerate(workers):
                    if w.task is None:
                        continue
                    rec = None
                    # (``ready`` is stale once a record was yielded, the caller maybe busy past a deadline:
                    # a record sent since is polled for before the deadline is looked at)
                    if w.conn in ready or w.conn.poll():
                        try:
                            rec = w.conn.recv()
                        except (EOFError, OSError):  # died as it sent, or before (the pipe closed)
                            w.process.join(timeout=30)
                            rec = _lost(w, f"the worker process building it {_death(w.process.exitcode)}")
                        else:
                            if isinstance(rec, tuple) and rec[:1] == (READY,):
                                w.ready(rec[1])
                                continue
                    elif w.process.sentinel in ready:
                        w.process.join(timeout=30)
                        rec = _lost(w, f"the worker process building it {_death(w.process.exitcode)}")
                    elif time.monotonic() >= w.deadline:
                        rec = _lost(
                            w,
                            f"stopped after {limit_s:g} s (limits.seconds): its build took longer",
                            "TIME_LIMIT_EXCEEDED",
                        )
                        w.stop()
                    if rec is None:
                        continue
                    if rec.get("worker_lost"):
                        w.stop()
                    w.task = None
                    if pending:
                        assign(i)  # (a new worker in place of one lost, or of one that died idle since)
                    yield rec
    finally:  # Ctrl-C, an error, the caller stopped, or done
        with _interrupts_ignored():
            for w in workers:
                if w.task is None and w.process.is_alive():
                    try:
                        w.conn.send(None)  # (idle: ends by itself; a send error: killed below)
                    except OSError:
                        pass
                    w.process.join(timeout=5)
                w.stop()


def _forkserver_ready(ctx: Any) -> None:
    """Wait for the fork server to have warmed up (it loads the numba kernels, or compiles them: minutes with
    a cold cache, after an install or an upgrade) by having it fork a process that exits at once, in a thread:
    the wait is the main thread's, which a Ctrl-C interrupts, stopping the server. The pool's workers are then
    started at once (a Ctrl-C deferred while they start, :func:`.interrupts._interrupts_deferred`, was held
    for the whole warm-up)."""
    if not _interrupts_raise():
        return  # (nothing interrupts the wait: the pool's first worker waits for the server)
    done = threading.Event()

    def probe() -> None:
        try:
            p = ctx.Process(target=ignore_interrupts)
            p.start()
            p.join()
        except BaseException:  # noqa: BLE001 - the server stopped, or cannot start: the pool reports it
            pass
        finally:
            done.set()

    threading.Thread(target=probe, name="swpm-forkserver-probe", daemon=True).start()
    try:
        while not done.wait(0.1):
            pass
    except BaseException:
        with _interrupts_ignored():
            _stop_forkserver()
        raise


def _stop_forkserver() -> None:
    """Kill this process's fork server (warming up) and forget it (the next pool starts another)."""
    from multiprocessing import forkserver

    server = getattr(forkserver, "_forkserver", None)
    pid = getattr(server, "_forkserver_pid", None)
    if pid is None:
        return
    try:
        os.kill(pid, signal.SIGKILL)
    except OSError:
        return
    stop = getattr(server, "_stop", None)  # closes its pipe, waits for it, deletes its socket
    if stop is not None:
        stop()
