"""Where a warm build's CPU time goes, per thread, per function and per numba kernel.

After one build (the kernels compiled), every numba dispatcher and every Python function of the package's
modules is wrapped with a timer (``time.thread_time`` and ``time.perf_counter``, exclusive of the wrapped
calls made inside it on the same thread), and so is ``concurrent.futures.Future.result`` (where a thread
waits for another). A kernel's time includes the kernels it calls inside numba (those are not wrapped).
The wrappers cost a few microseconds a call: the table's total is a little above an unwrapped build's.

    python benchmarks/profile_build.py MESH.obj [--encoding sliding-window] [--builds 3] [--top 45]
        [--threads | --inline] [--calls collapse_patches,_finish]

``--threads``: the worker and helper threads whatever the load (``sw_threads.ADAPT_TO_LOAD`` off), as on a
machine with a core free; ``--inline``: none. ``--calls``: each call's self CPU time of those functions (in
the last build), to see how a kernel's time falls with its level's size. The rows are per thread root (the
first wrapped function a pool thread ran: ``finish_level`` is the worker, ``Replay._level`` its replay,
``deviation_rows`` / ``level_costs`` / ``_adjacency`` the helper's shares), then every thread together.
"""

from __future__ import annotations

import argparse
import collections
import concurrent.futures
import functools
import sys
import threading
import time
import types

import numba.core.registry
import numpy as np

import swpm_usd
from swpm_usd.io import load_mesh

_local = threading.local()
_stats: dict = collections.defaultdict(lambda: [0, 0.0, 0.0, 0.0])  # (thread, name) -> calls, cpu, wall, self
_lock = threading.Lock()
_calls: dict = collections.defaultdict(list)  # name -> [cpu ms of each call] (``--calls``)


def _wrap(name: str, fn):
    @functools.wraps(fn)
    def timed(*args, **kwargs):
        stack = getattr(_local, "stack", None)
        if stack is None:
            stack = _local.stack = []
        if not stack and threading.current_thread() is not threading.main_thread():
            _local.role = name  # a pool thread named by the first function it runs
        stack.append(0.0)
        c0, w0 = time.thread_time(), time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            cpu, wall = time.thread_time() - c0, time.perf_counter() - w0
            inner = stack.pop()
            if stack:
                stack[-1] += cpu
            main = threading.current_thread() is threading.main_thread()
            root = "main" if main else (getattr(_local, "role", None) or "other")
            if not stack:
                _local.role = None
            with _lock:
                s = _stats[(root, name)]
                s[0] += 1
                s[1] += cpu
                s[2] += wall
                s[3] += cpu - inner
                _calls[name].append(1e3 * (cpu - inner))

    return timed


def instrument() -> int:
    """Wrap every dispatcher and function of the package's loaded modules (and their classes' methods)."""
    done: dict[int, object] = {}
    mods = [m for n, m in list(sys.modules.items()) if n.startswith("swpm_usd") and m is not None]

    def wrapped(obj, label):
        if id(obj) not in done:
            done[id(obj)] = _wrap(label, obj)
        return done[id(obj)]

    for mod in mods:
        for attr, obj in list(vars(mod).items()):
            if isinstance(obj, numba.core.registry.CPUDispatcher):
                setattr(mod, attr, wrapped(obj, f"[nb] {obj.py_func.__module__[9:]}.{obj.__name__}"))
            elif isinstance(obj, types.FunctionType) and (obj.__module__ or "").startswith("swpm_usd"):
                setattr(mod, attr, wrapped(obj, f"{obj.__module__[9:]}.{obj.__qualname__}"))
            elif isinstance(obj, type) and (obj.__module__ or "").startswith("swpm_usd"):
                for k, v in list(vars(obj).items()):
                    if isinstance(v, types.FunctionType) and not k.startswith("__"):
                        setattr(obj, k, wrapped(v, f"{obj.__module__[9:]}.{v.__qualname__}"))
    result = concurrent.futures.Future.result
    concurrent.futures.Future.result = _wrap("(wait) Future.result", result)
    return len(done)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("mesh")
    ap.add_argument("--encoding", default="sliding-window")
    ap.add_argument("--builds", type=int, default=3)
    ap.add_argument("--top", type=int, default=45)
    ap.add_argument("--calls", default="", help="comma-separated names: each call's self CPU ms")
    mode = ap.add_mutually_exclusive_group()  # (both together ran inline, saying nothing)
    mode.add_argument("--inline", action="store_true", help="no worker or helper thread")
    mode.add_argument("--threads", action="store_true", help="threads whatever the load")
    args = ap.parse_args()
    mesh = load_mesh(args.mesh)
    swpm_usd.build(mesh, encoding=args.encoding)  # compile
    import swpm_usd.encode.slidingwindow as sw

    n = instrument()
    if args.inline:
        sw.FINISH_IN_THREAD = False
    if args.threads:
        import swpm_usd.encode.sw_threads as swt

        swt.ADAPT_TO_LOAD = False
    walls, cpus = [], []
    for _ in range(args.builds):
        w, c = time.perf_counter(), time.process_time()
        swpm_usd.build(mesh, encoding=args.encoding)
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    b = args.builds
    total = sum(cpus) / b
    print(f"{args.mesh}: {mesh.triangle_count} triangles, {n} functions wrapped, {b} builds")
    print(f"build wall {np.median(walls):.3f} s, process CPU {np.median(cpus):.3f} s (medians)")
    by_thread = collections.defaultdict(float)
    for (th, _), s in _stats.items():
        by_thread[th] += s[3] / b
    print("self CPU per thread root: " + ", ".join(f"{k} {v:.3f}" for k, v in sorted(by_thread.items())))
    for (th, name), (calls, _cpu, wall, _self) in sorted(_stats.items()):
        if th == "main" and name.startswith("(wait)"):
            print(f"main thread waits in {name}: {calls / b:.0f} calls, {wall / b:.4f} s wall")
    rows = sorted(_stats.items(), key=lambda kv: -kv[1][3])
    print(f"{'thread':<28} {'function':<52} {'calls':>7} {'self CPU s':>10} {'share':>6} {'wall s':>8}")
    for (th, name), (calls, _cpu, wall, self_cpu) in rows[: args.top]:
        print(
            f"{th[-28:]:<28} {name[-52:]:<52} {calls / b:>7.0f} {self_cpu / b:>10.4f} "
            f"{self_cpu / b / total:>6.1%} {wall / b:>8.4f}"
        )
    for want in filter(None, args.calls.split(",")):
        for name, ms in _calls.items():
            if name.endswith(want):
                per = len(ms) // b
                print(f"{name}: " + " ".join(f"{x:.2f}" for x in ms[-per:]))
    # every thread together: calls and self CPU time per function
    agg = collections.defaultdict(lambda: [0, 0.0])
    for (_, name), st in _stats.items():
        agg[name][0] += st[0]
        agg[name][1] += st[3]
    print(f"all threads: {'function':<52} {'calls':>7} {'self CPU s':>10} {'share':>6}")
    for name, (calls, self_cpu) in sorted(agg.items(), key=lambda kv: -kv[1][1])[: args.top]:
        share = self_cpu / b / total
        print(f"             {name[-52:]:<52} {calls / b:>7.0f} {self_cpu / b:>10.4f} {share:>6.1%}")
    kern = collections.defaultdict(lambda: [0, 0.0])
    for (_, name), s in _stats.items():
        if name.startswith("[nb]"):
            kern[name][0] += s[0]
            kern[name][1] += s[3]
    ksum = sum(v[1] for v in kern.values()) / b
    print(f"kernels (all threads): {ksum:.3f} s of {total:.3f} s process CPU ({ksum / total:.0%})")


if __name__ == "__main__":
    main()
