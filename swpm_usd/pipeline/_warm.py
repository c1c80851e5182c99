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
from typing import Any

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
    the process; it is stopped before the server loop's first fork (a worker then starts with no other
    thread; the loop watches the runner's pipe from then, as it did)."""
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
        # (woken: the server loop forks, and watches the runner's pipe from then)

    thread = threading.Thread(target=watch, name="swpm-forkserver-runner-watch", daemon=True)

    def stop() -> None:
        # (only the server loop's fork: an import that forks must not end the watch)
        if thread.is_alive() and _in_the_fork_server(sys._getframe(1), loop=True):
            os.write(wake_w, b"x")
            thread.join()
            for fd in (wake_r, wake_w, runner):
                os.close(fd)

    os.register_at_fork(before=stop)
    thread.start()


def _in_the_fork_server(frame: Any = None, loop: bool = False) -> bool:
    """Whether this code runs in :func:`multiprocessing.forkserver.main` (its preload; ``loop``: called from
    it directly, its loop forking a worker), which ``frame`` or a caller of it is."""
    frame = sys._getframe(1) if frame is None else frame
    while frame is not None:
        if frame.f_code.co_name == "main" and frame.f_globals.get("__name__") == _SERVER_MODULE:
            return True
        if loop:
            return False
        frame = frame.f_back
    return False


end_with_the_runner()
warm()
