"""Imported once by the pipeline's forkserver: build a tiny mesh with each encoding the run's pending tasks
use (:data:`.worker.WARM_ENCODINGS_ENV`, set by :func:`.runner.execute`; every encoding when it is not
set) so their numba kernels are loaded from their on-disk cache before the workers fork (each worker then
starts with them in memory instead of loading them again). Never raises: a failure only costs the workers
their own warm-up."""

from __future__ import annotations

import os
import select
import sys
import threading
from collections.abc import Iterable

#: the encodings this process warmed (in the fork server: those its workers start with)
WARMED: list[str] = []


def warm(encodings: Iterable[str] | None = None) -> None:
    """Build the tiny mesh with each of ``encodings`` (None: those :data:`.worker.WARM_ENCODINGS_ENV`
    names, or every encoding when it is not set); a name that is no encoding's is passed over."""
    try:
        from ..encode import BUILDERS
        from .worker import WARM_ENCODINGS_ENV

        if encodings is None:
            named = os.environ.get(WARM_ENCODINGS_ENV)
            encodings = list(BUILDERS) if named is None else [e for e in named.split(",") if e]
        chosen = [e for e in BUILDERS if e in set(encodings)]
        if not chosen:
            return  # (nothing to build: numba and the encoders not even imported)
        import numpy as np

        from ..build import build
        from ..format import encode_bytes, validate_bytes
        from ..mesh import Mesh
        from ..metrics import acmr
        from ..pipeline.worker import summarize

        # a closed, bumpy 12x8 torus: big enough for every builder to run its whole path
        u, v = np.meshgrid(np.arange(12) * (2 * np.pi / 12), np.arange(8) * (2 * np.pi / 8), indexing="ij")
        r = 0.3 + 0.05 * np.sin(3 * u)
        pts = np.stack([(1 + r * np.cos(v)) * np.cos(u), (1 + r * np.cos(v)) * np.sin(u), r * np.sin(v)], -1)
        i, j = np.meshgrid(np.arange(12), np.arange(8), indexing="ij")
        a, b = i * 8 + j, ((i + 1) % 12) * 8 + j
        c, d = ((i + 1) % 12) * 8 + (j + 1) % 8, i * 8 + (j + 1) % 8
        tris = np.concatenate(
            [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
        )
        mesh = Mesh(points=pts.reshape(-1, 3), triangles=tris)
        for enc in chosen:
            try:  # (each its own: skip-strip's strip, read as a triangle list, raised and ended the warm-up
                # before mixed was warmed, and before skip-strip's file was encoded)
                pm = build(mesh, enc)
                summarize(pm)
                kind, stream = pm.draw_stream(0)
                acmr(stream, kind=kind, restart_index=pm.restart_index)
                validate_bytes(encode_bytes(pm))
            except Exception:  # noqa: BLE001 - warming is an optimisation only
                continue
            WARMED.append(enc)
    except Exception:  # noqa: BLE001 - warming is an optimisation only
        pass


_SERVER_MODULE = "multiprocessing.forkserver"


def end_with_the_runner() -> None:
    """End the fork server once the runner that started it (its parent) is gone, during its warm-up too. The
    server watches its pipe from the runner only once every module is preloaded, and a runner's fork request
    queued on the server's socket holds that pipe open (the runner's end, in flight): a runner killed with
    SIGKILL (a farm's job killed) while the server compiled the kernels (minutes with a cold cache) left it
    compiling, on a busy farm node, to the end. A thread waits on the parent's pidfd (no polling) and exits
    the process. It is stopped before any fork of the server (``os.register_at_fork``: a worker then starts
    with no other thread, and no fork is told from another by the frames of CPython's forkserver, whose
    layout is its own) and started again in the server once it has forked; a child closes its descriptors."""
    if not _in_the_fork_server():
        return
    from .worker import RUNNER_PID_ENV

    parent = os.getppid()
    if os.environ.get(RUNNER_PID_ENV, str(parent)) != str(parent):  # (its runner gone already: reparented)
        os._exit(1)
    pidfd_open = getattr(os, "pidfd_open", None)
    if pidfd_open is None:
        return
    try:
        runner = pidfd_open(parent)
    except OSError:  # (a kernel without pidfds: the warm-up runs to its end, as before)
        return
    if os.getppid() != parent:  # (gone before its pidfd was open)
        os._exit(1)
    wake_r, wake_w = os.pipe()

    def watch() -> None:
        poller = select.poll()
        poller.register(runner, select.POLLIN)
        poller.register(wake_r, select.POLLIN)
        for ready, _ in poller.poll():
            if ready == runner:
                os._exit(1)
        # (woken: the server forks, and starts a new watch once it has)

    watching: list[threading.Thread] = []
    # (the server's alone: the at-fork hooks stay registered in its children, and a worker that forks in
    # turn must neither watch the descriptors it closed, their numbers reused by its own files, nor close
    # them again in its child)
    in_the_server = [True]

    def start() -> None:
        if not in_the_server:
            return
        thread = threading.Thread(target=watch, name=WATCH_THREAD, daemon=True)
        watching[:] = [thread]
        thread.start()

    def stop() -> None:
        if in_the_server and watching and watching[0].is_alive():
            os.write(wake_w, b"x")
            watching[0].join()
            os.read(wake_r, 1)  # (the wake-up taken: the next watch waits again)

    def close() -> None:  # (in the child: a worker does not watch its server's runner)
        if not in_the_server:
            return
        in_the_server.clear()
        watching.clear()
        for fd in (wake_r, wake_w, runner):
            os.close(fd)

    os.register_at_fork(before=stop, after_in_parent=start, after_in_child=close)
    start()


#: the name of the thread that ends the fork server with its runner (:func:`end_with_the_runner`)
WATCH_THREAD = "swpm-forkserver-runner-watch"


def _in_the_fork_server() -> bool:
    """Whether this code runs in :func:`multiprocessing.forkserver.main` (its preload): a caller's frame is
    that function's (its name and module, whatever calls it in between)."""
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name == "main" and frame.f_globals.get("__name__") == _SERVER_MODULE:
            return True
        frame = frame.f_back
    return False


end_with_the_runner()
warm()
