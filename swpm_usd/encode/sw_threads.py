"""The sliding-window builder's second thread: work of the main thread shared with a helper thread.

The topology-driven builder (:mod:`.slidingwindow`) runs on up to three threads where the machine has a
second core: the main thread builds the levels one after another, a *worker* finishes each fully stored
level (:func:`.sw_layout.finish_level`), and a *helper* takes part of the main thread's own work. This
module holds the helper's share: a call run beside the main thread (:func:`beside`), a level's work cut into
blocks that both threads take in turn (:func:`share`: the best collapses, :func:`level_costs_shared`, and the
fan-deviation searches, :func:`sampled_deviation`); the replay of the LOD errors level by level
(:class:`Replay`, on the worker after each level's finishing: on the helper its tasks queued ahead of the
shares, and the main thread did nearly every share itself); and whether the threads should start at all
(:func:`core_free`: only while the other processes leave a core free). Every result is the one the main
thread alone computes, bit for bit: the kernels read the state and write separate outputs, and they release
the GIL.
"""

from __future__ import annotations

import itertools
import os
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import numpy as np

from ..simplify.sequence import replay_steps
from . import sw_deviation as swd
from . import sw_levels

#: levels of at least this many sampled positions search them on two threads (the main one and a helper),
#: in ``_SHARE_BLOCKS`` blocks of at least ``_DEVIATION_BLOCK`` rows (:func:`sampled_deviation`; the same
#: costs, bit for bit)
_DEVIATION_PARALLEL = 256


_DEVIATION_BLOCK = 64


#: levels of at least this many positions find their best collapses on two threads, in blocks of at least
#: ``_COSTS_BLOCK`` (:func:`level_costs_shared`)
_COSTS_PARALLEL = 1024


_COSTS_BLOCK = 256


#: blocks of a level's work shared by the two threads (:func:`share`): more blocks balance the threads
#: better (the main thread does again at most the block the helper is in), fewer take the GIL less often
_SHARE_BLOCKS = 16


#: a level of fewer triangles builds its position graph on the main thread, and a mesh of fewer starts no
#: thread at all: a hand-off costs about what such a level's work does (medians of 15-25 alternating builds,
#: 0 -> 1,024: cow -1 %, spot -3 to -5 %, teapot -1.5 %, bob -1.4 %, fandisk -2.6 %, dragon-20k +2.5 %,
#: within the noise; the process's CPU time lower on all; 3,000: +10-14 %, cow's second level then waits on
#: the main thread)
_LEVEL_HAND_OFF = 1024


#: a threaded build's level of fewer triangles is finished (:func:`.sw_layout.finish_level`) on the main
#: thread, not handed to the worker. A level's finishing (its patch order search and cache order) is about
#: a third of its work in one hand-off, where the position graph is a small share: 1,024 -> 256 (2026-12-05;
#: two processes, four alternating rounds of ten builds, medians) took the main thread's CPU time per build
#: beetle 38.4 -> 31.7 ms, teapot 87.2 -> 79.6, spot 91.9 -> 84.6, cow 90.2 -> 84.4, bob 147.5 -> 144.5, the
#: process's within -4 to +2 % (``slidingwindow.md``)
_FINISH_HAND_OFF = 256


#: a build that could start its threads does so only while the other processes leave a core free: the
#: cores they kept busy since this process last looked (:func:`core_free`) at most ``cores - 1``. With the
#: cores busy the threads cost more than they save: the main thread waits for a core beside its own worker
#: and helper, and for the GIL each time it lets it go to one of them that the OS then preempts (cow's main
#: thread 20-31 ms of a 255-320 ms build in ``np.flatnonzero`` alone at a load of 2.5, 0.4-1.3 ms inline;
#: threaded over inline wall time 0.98-1.16 on eight meshes at a load of 2.3-2.6, where with a core free the
#: threads take cow 142 -> 102 ms and bunny 2.02 -> 1.39 s; ``slidingwindow.md``). False: the threads
#: whatever the load (the tests of the threaded path set it so)
ADAPT_TO_LOAD = True
#: a look's window: looks this close after the previous one keep its answer (``/proc/stat`` counts in
#: hundredths of a second, so a shorter window is mostly rounding); a previous look older than
#: ``_LOOK_MAX_AGE`` seconds says nothing of now (the build then starts its threads, as on a first look)
_LOOK_MIN_WINDOW = 0.2
_LOOK_MAX_AGE = 30.0
_look_lock = threading.Lock()
_last_look: list = []  # [(pid, monotonic s, system busy s, this process's CPU s, answer)]


def _new_look_lock() -> None:
    global _look_lock
    _look_lock = threading.Lock()


# (a fork while another thread holds the lock left the child's copy held for ever: its first build hung)
if hasattr(os, "register_at_fork"):  # (not on Windows, which does not fork)
    os.register_at_fork(after_in_child=_new_look_lock)


def _system_busy() -> float | None:
    """Seconds of CPU time every process has spent since boot on the CPUs this process may run on
    (``/proc/stat``'s line of each CPU of its affinity, idle and iowait left out), or None where there is no
    ``/proc/stat``. Not the first line's total: a process pinned to 2 of a host's 64 CPUs (``taskset``, a
    container's cpuset) compares the others' load with its own 2 cores, and with the total the other CPUs'
    load kept its threads from starting on its idle cores. The total where the affinity cannot be read or
    ``/proc/stat`` does not list each of its CPUs (lxcfs numbers a container's CPUs from 0)."""
    try:
        with open("/proc/stat", "rb") as f:
            lines = f.read().splitlines()
        busy: dict[bytes, int] = {}  # (b"" the first line's total, b"0" cpu0's, ...)
        for line in lines:
            fields = line.split()
            if fields and fields[0].startswith(b"cpu"):
                counts = [int(x) for x in fields[1:9]]
                busy[fields[0][3:]] = sum(counts) - counts[3] - counts[4]
        mine = [str(c).encode() for c in os.sched_getaffinity(0)] if hasattr(os, "sched_getaffinity") else []
        ticks = sum(busy[c] for c in mine) if mine and all(c in busy for c in mine) else busy[b""]
        return ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, KeyError):
        return None


def core_free(cores: int) -> bool:
    """Whether the other processes kept at most ``cores - 1`` cores busy since this process's previous look
    (its own CPU time, every thread of it, taken off the system's), so that the build has a core the others
    leave free (:data:`ADAPT_TO_LOAD`; with exactly one left, the main thread and its worker and helper share
    it, and the threads still break even or pay: threaded / inline 0.86-1.05 with one other busy process on
    two cores, 0.67-0.88 with none, ``benchmarks/bench_threads.py``). True where that cannot be read, on the
    first look and after a fork (the child's CPU time starts again), and when the previous look is older
    than :data:`_LOOK_MAX_AGE`; a look within :data:`_LOOK_MIN_WINDOW` of it keeps its answer."""
    if not ADAPT_TO_LOAD:
        return True
    busy = _system_busy()
    if busy is None:
        return True
    now, own, pid = time.monotonic(), time.process_time(), os.getpid()
    with _look_lock:
        if _last_look and _last_look[0][0] == pid:
            _, then, busy0, own0, answer = _last_look[0]
            window = now - then
            if window < _LOOK_MIN_WINDOW:
                return answer  # (the window keeps growing from the previous look)
            if window <= _LOOK_MAX_AGE:
                others = ((busy - busy0) - (own - own0)) / window
                answer = others <= cores - 1
                _last_look[:] = [(pid, now, busy, own, answer)]
                return answer
        _last_look[:] = [(pid, now, busy, own, True)]
        return True


def beside(helper: ThreadPoolExecutor | None, fn, *args):
    """``fn(*args)`` on the ``helper`` thread while this one goes on: a callable that returns its result, or
    computes it on this thread if the helper has not started it by then (bunny's BVH is 50 ms: once started,
    the helper is nearer its end than this thread would be); at once without a helper."""
    if helper is None:
        value = fn(*args)
        return lambda: value
    future = helper.submit(fn, *args)
    done = []

    def result():
        if not done:
            done.append(fn(*args) if future.cancel() else future.result())
        return done[0]

    return result


def share(helper: ThreadPoolExecutor, count: int, work) -> set:
    """Items ``0 .. count - 1`` done as ``work(j, here)`` by this thread (``here`` True) and the ``helper``
    thread (False), each taking the next item in turn; returns the items the helper finished. This thread
    never waits for the helper: it does again those the helper has taken and not finished when none is
    left (``work`` must give the same result on either thread, into separate outputs)."""
    items = itertools.count()  # next() is atomic: each item goes to one thread
    finished: list = []  # by the helper (list.append is atomic)

    def run() -> None:
        for j in items:
            if j >= count:
                return
            work(j, False)
            finished.append(j)

    future = helper.submit(run)
    mine = set()
    for j in items:
        if j >= count:
            break
        work(j, True)
        mine.add(j)
    future.cancel()
    theirs = set(finished)
    for j in range(count):
        if j not in mine and j not in theirs:
            work(j, True)
    return theirs


def level_costs_shared(helper: ThreadPoolExecutor | None, st, positions: np.ndarray, stars):
    """:func:`.sw_levels.level_costs`, a large level's positions in blocks (:data:`_SHARE_BLOCKS`) on this
    thread and the ``helper`` thread (each position's best collapse reads the state alone: the same costs)."""
    n = positions.shape[0]
    if helper is None or n < _COSTS_PARALLEL:
        return sw_levels.level_costs(st, positions, stars)
    size = max(_COSTS_BLOCK, -(-n // _SHARE_BLOCKS))
    count = -(-n // size)
    parts = [[None] * count, [None] * count]  # by the helper, by this thread

    def work(j: int, here: bool) -> None:
        parts[here][j] = sw_levels.level_costs(st, positions[j * size : (j + 1) * size], stars)

    theirs = share(helper, count, work)
    got = [parts[j not in theirs][j] for j in range(count)]
    return np.concatenate([g[0] for g in got]), np.concatenate([g[1] for g in got])


def sampled_deviation(helper: ThreadPoolExecutor | None, args: tuple) -> np.ndarray:
    """:func:`.sw_deviation.deviation_costs` of ``args``, on this thread and the ``helper`` thread where there
    are enough rows: blocks of rows (:data:`_SHARE_BLOCKS`), each started from no search hint
    (:func:`share`), then :func:`.sw_deviation.deviation_join` (the same output, bit for bit)."""
    n = args[1].shape[0]
    if helper is None or n < _DEVIATION_PARALLEL:
        return swd.deviation_costs(*args)
    size = max(_DEVIATION_BLOCK, -(-n // _SHARE_BLOCKS))
    count = -(-n // size)
    # (out, hint_at, end_hint) of each thread: the helper's rows are copied once it has finished them
    bufs = [(np.empty_like(args[3]), np.empty(n, np.int64), np.zeros(count, np.int64)) for _ in range(2)]

    def work(j: int, here: bool) -> None:
        out, hint_at, end_hint = bufs[here]
        end_hint[j] = swd.deviation_rows(*args, j * size, min(n, (j + 1) * size), 0, out, hint_at)

    theirs = share(helper, count, work)
    out, hint_at, end_hint = bufs[True]
    for j in theirs:
        rows = slice(j * size, (j + 1) * size)
        out[rows] = bufs[False][0][rows]
        hint_at[rows] = bufs[False][1][rows]
        end_hint[j] = bufs[False][2][j]
    swd.deviation_join(*args, size, end_hint, out, hint_at)
    return out


class Replay:
    """Each step's error as the LODs report it (:func:`swpm_usd.simplify.sequence.step_geometric_errors`: a
    fresh state, its :class:`swpm_usd.simplify.fan_deviation.ReplayState`, replays the steps in their final
    order) computed level by level on the ``helper`` executor (the build passes its worker: each level's
    replay queued after its finishing, which settles its steps' order), not after the last level on the main
    thread (cow: 26 of its 185 ms). The parts carry the running maximum: the values of one replay."""

    def __init__(self, helper: ThreadPoolExecutor, new_state, surface_of) -> None:
        self.helper = helper
        self.new_state = new_state
        self.surface_of = surface_of
        self.st = None
        self.run2 = 0.0
        self.parts: list[np.ndarray] = []
        self.tasks: list[Future] = []  # one per level handed on, in level order

    def _level(self, info: np.ndarray) -> None:
        if self.st is None:
            self.st = self.new_state()
        out = replay_steps(self.surface_of(), self.st, info[:, 1], info[:, 2], info[:, 0], self.run2)
        if out.shape[0]:
            self.run2 = max(self.run2, float(np.max(out * out)))
        self.parts.append(out)

    def advance(self, pending: list) -> None:
        """Hand the levels finished so far on to the helper, in order (it runs them in turn)."""
        while len(self.tasks) < len(pending) and pending[len(self.tasks)][0].done():
            info = pending[len(self.tasks)][0].result()[2]
            self.tasks.append(self.helper.submit(self._level, info))

    def result(self, infos: list) -> np.ndarray:
        """The errors of every level's steps (``infos``: each level's, finished): the levels the helper has
        not started are replayed here, in order, once it is done with the one it is on."""
        # cancelled from the last on: the helper runs its tasks in order, so once one cannot be cancelled
        # (started), those before it are done, and no task after it can start any more
        first = len(self.tasks)
        for i in range(len(self.tasks) - 1, -1, -1):
            if not self.tasks[i].cancel():
                break
            first = i
        for task in self.tasks[:first]:
            task.result()
        for i in range(first, len(infos)):
            self._level(infos[i])
        return np.concatenate(self.parts) if self.parts else np.zeros(0)


class Done:
    """A finished future holding ``value`` (a level finished inline): ``done``, ``cancelled``, ``cancel`` and
    ``result`` as :class:`concurrent.futures.Future`'s for a future that has its result, without its lock
    and condition (a ``Future`` made and filled cost about 15 us per level: suzanne's 14 levels, 0.2 ms of
    a 25 ms build)."""

    __slots__ = ("_value",)

    def __init__(self, value: Any) -> None:
        self._value = value

    def done(self) -> bool:
        return True

    def cancelled(self) -> bool:
        return False

    def cancel(self) -> bool:
        return False  # as a finished Future's

    def result(self, timeout: float | None = None) -> Any:
        return self._value


def done_future(value: Any) -> Done:
    """A future already holding ``value`` (a level finished inline): :class:`Done`."""
    return Done(value)
