"""Open an untrusted binary USD file (crate, ``.usdc``) in a probe process before this one opens it.

usd-core does not survive every corrupt crate file: a byte flipped in a value or in a section's header makes
``Usd.Stage.Open`` or a value's read crash the process (SIGSEGV), or ask for a giant allocation (the system
kills the process, or another one). :func:`check` has the file opened first by a probe process (``python -c``
:data:`.probe_program._PROBE`: the stage opened, every prim's and property's metadata and values read, every
spec of every layer it uses), under a memory and a time limit. Only when the probe reads it cleanly does the
caller open the file itself; a probe that dies by a signal or overruns its time, or in which usd-core cannot
open the file or read a value (or a crate layer its stage uses), is a :class:`Problem` (one line naming the
file) the caller turns into its typed error (``validate``: ``SWPM_USD_CRASH``, ``SWPM_USD_OPEN``,
``SWPM_USD_READ`` or ``SWPM_USD_PROBE``; the loader: :class:`~swpm_usd.errors.MeshLoadError`).

A stage is probed when opening it opens a crate file (:func:`needs_probe`): its root is one (:func:`is_crate`:
a ``.usdc``, a ``.usdz``, a ``.usd`` whose first bytes are ``PXR-USDC``; usd-core's text parser fails
cleanly), or a text root whose sublayers, references, payloads, clips or other asset paths, through text
layers as deep as they go, resolve to one (those text layers are parsed in this process; a caller that opens
the stage in a :func:`checked` block finds them parsed, held for its open: each parsed once). A layer that is
not a regular file (a FIFO, whose open waits for a writer; a folder; a device), the root or one a layer names,
is an "open" problem at once, decided by ``os.stat`` and never opened: here for the root and the layers text
layers name, in the probe (which opens the stage's layers one by one before the stage; one only a variant
names is named, not opened: the stage opens it only when the variant is selected; a text one is read, a
crate one read in a process of its own, the layers it names named in turn) for those a crate layer
names; the probe's alarm is left for what cannot be named before the open. Each answer is kept for this
process while the file and every file it depends on (the layers the probe opened or was opening when it
crashed or ran out of time: it names each to the server before it opens it; the files its text layers or the
stage's composition errors name: one missing, should it appear) keep their path, size, mtime and inode; one
file given in two spellings (a link, ``d/..``) is one file, probed once. One
probe server serves every file of this process: started once (Python and usd-core's import, about 0.3 s), it
forks a fresh process for each file (about 12 ms for a small one: the server has built usd-core's schema
registry once, on a stage of its own in memory, which each fork inherits), several at once for
:func:`check_many`, so a file that crashes or corrupts a probe leaves the next one a clean process. The server
ends when the process that started it does (its input's end, or its parent process gone: checked every 0.25
s), killing its probes (each also dies with the server: ``PR_SET_PDEATHSIG``). A probe that fails itself (an
error of its own, no answer, no process started) is tried once more in a fresh server, then is a "probe"
problem: the file is never opened in this process unprobed.

This module is the client: which files a stage opens (decided here, without usd-core for a crate file), the
answers kept, and the server started and talked to; the server's own program, run in its process, is
:mod:`.probe_program`, and what each answer means, as a :class:`Problem`'s message, :mod:`.probe_problems`.
"""

from __future__ import annotations

import atexit
import contextlib
import json
import os
import select
import shutil
import stat
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

from .probe_problems import Problem as Problem  # (re-exported)
from .probe_problems import _not_regular, _overran, _problem
from .probe_program import _CLEAN, _LAYER_FAILED, _NOT_REGULAR, _OPEN_FAILED, _READ_FAILED
from .probe_program import _PROBE as _PROBE  # (re-exported: :func:`_start_server` reads it here)

#: the first bytes of a crate (binary USD) file
CRATE_MAGIC = b"PXR-USDC"
#: seconds a probe may take (a crate file usd-core hangs on); ``SWPM_USD_PROBE_SECONDS`` overrides it
PROBE_SECONDS = 300.0
#: address space a probe may use: this much plus :data:`PROBE_MEMORY_PER_BYTE` times the file's size (a
#: corrupt array or section size asks usd-core for terabytes; under the limit that is an error, not a kill
#: by the system's out-of-memory killer, which may pick another process)
PROBE_MEMORY_BASE = 4 << 30
PROBE_MEMORY_PER_BYTE = 64


#: a file's stamp: (size, mtime_ns, inode), None for a file that is not there
_Stamp = tuple[int, int, int] | None
#: (real path, size, mtime_ns, inode) of a file checked -> (the problem found, None: none; the real path and
#: stamp of every other file its answer depends on: the layers the probe opened, the layers and crate files
#: a text root names; the path the problem's message names the file by). The answer holds while each of
#: those files is as it was
_answers: dict[tuple[str, int, int, int], tuple[Problem | None, tuple[tuple[str, _Stamp], ...], str]] = {}
#: the key of a file a probe found clean -> (that answer, of :data:`_answers`; the files of the layers its
#: stage uses) (:func:`used_layers`): the list holds while that answer is the file's (one given since, its
#: sublayer changed to name no crate file and found clean in text, has no list: the old one was stale)
_used: dict[tuple[str, int, int, int], tuple[tuple, list[str]]] = {}
#: a probe's path -> the files of the layers its stage uses, as the probe server answered (a clean answer),
#: taken into :data:`_used` by :func:`check_many`
_probed_used: dict[str, list[str]] = {}


def _regular(path: str) -> bool:
    """Whether ``path`` is a regular file, or not there (the caller's open reports that). A FIFO, a device
    or a folder is never read in this process (reading a FIFO waits until something writes to it)."""
    try:
        return stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return True


class _NotRegular(Exception):
    """A layer a text root names is not a regular file: ``layer`` (its real path), its ``mode``, and the real
    paths of the files read or named up to it (``named``)."""

    def __init__(self, layer: str, mode: int, named: list[str]) -> None:
        super().__init__(layer)
        self.layer, self.mode, self.named = layer, mode, named


#: the text layers :func:`_named_files` parses are kept open (usd-core's layer registry) in this list while a
#: :func:`checked` block of this thread runs: the block's own open of the stage finds them parsed
_holding = threading.local()


def is_crate(path: str | os.PathLike[str]) -> bool:
    """Whether usd-core reads ``path`` with its crate (binary) reader, as it chooses by the name: a ``.usdc``
    always, a ``.usdz`` package (its layers may be crate files) too, a ``.usda`` never (the text parser,
    whatever the bytes), and a ``.usd`` (or another name) when its first bytes are :data:`CRATE_MAGIC` (a
    ``.usda`` is not read here: a rerun of a pipeline whose stage is up to date reads none of its inputs)."""
    suffix = Path(path).suffix.lower()
    if suffix in (".usdc", ".usdz"):
        return True
    if suffix == ".usda":
        return False
    if not _regular(os.fspath(path)):
        return True  # (not read here: a FIFO's read waits for a writer; check reports it at once)
    return _crate_magic(os.fspath(path))


def _crate_magic(path: str) -> bool:
    """Whether the file at ``path`` (a regular file) starts with :data:`CRATE_MAGIC`."""
    try:
        with open(path, "rb") as f:
            return f.read(len(CRATE_MAGIC)) == CRATE_MAGIC
    except OSError:
        return False


#: how many text layers :func:`_named_files` reads below a root at most (a deeper stack is probed)
_TEXT_LAYERS_READ = 256


def _named_files(path: str) -> tuple[bool, list[str]]:
    """Whether the stage of ``path``, a text (non-crate) root layer, opens a crate file (its sublayers,
    references, payloads, value clips or another asset path it names, through text layers as deep as they
    go, resolve to one), and the real paths of the files read or named on the way (their stamps key the
    answer). Text layers are read here (usd-core's text parser fails cleanly); a crate file never is, nor a
    layer that is not a regular file (:class:`_NotRegular` is raised at the first one named). Each text layer
    is opened by the path the stage's own open gives it (the root as given, the others anchored on the layer
    naming them), so that, held (:func:`checked`), the stage's open finds it parsed."""
    from pxr import Ar, Sdf, UsdUtils

    resolver = Ar.GetResolver()
    held = getattr(_holding, "layers", None)
    seen: set[str] = {os.path.realpath(path)}
    todo = [os.path.abspath(path)]
    crate = False
    read = 0  # (text layers read: the textures and other files named are no layers, counted apart)
    while todo:
        layer = todo.pop()
        if read >= _TEXT_LAYERS_READ:
            return True, sorted(seen)  # (a stack this large: probed rather than read here)
        read += 1
        try:
            # (parsed once: the extraction finds it in usd-core's layer registry while it is held here)
            opened = Sdf.Layer.FindOrOpen(layer)
            named = [p for group in UsdUtils.ExtractExternalReferences(layer) for p in group]
        except Exception:  # noqa: BLE001 - a text layer that does not parse: the stage's open reports it
            continue
        if held is not None and opened is not None:
            held.append(opened)
        for asset in named:
            try:
                found = str(resolver.Resolve(resolver.CreateIdentifier(asset, Ar.ResolvedPath(layer))))
            except Exception:  # noqa: BLE001 - an asset path the resolver refuses: nothing opened
                found = ""
            if not found:  # (not there now: keyed as missing, should it appear)
                found = os.path.join(os.path.dirname(layer), asset.split("[", 1)[0])
            spelled = found.split("[", 1)[0] if found.endswith("]") else found
            real = os.path.realpath(spelled)
            if real in seen:
                continue
            seen.add(real)
            suffix = Path(real).suffix.lower()
            if suffix not in (".usda", ".usd", ".usdc", ".usdz"):
                continue  # (a texture or another asset: no layer usd-core opens as crate)
            try:
                mode = os.stat(real).st_mode
            except OSError:
                continue  # (not there: keyed as missing, should it appear)
            if not stat.S_ISREG(mode):
                raise _NotRegular(real, mode, sorted(seen))
            if is_crate(real):
                crate = True
            else:
                todo.append(spelled)
    return crate, sorted(seen)


def needs_probe(path: str | os.PathLike[str]) -> bool:
    """Whether opening ``path``'s stage opens a crate file: ``path`` is one (:func:`is_crate`), or a text
    layer whose layer stack, references, payloads or clips (through other text layers) resolve to one."""
    p = os.fspath(path)
    if is_crate(p) or not _regular(p):
        return True
    try:
        return _named_files(p)[0]
    except _NotRegular:
        return True  # (a layer that is not a regular file: check reports it, opening nothing)


def _seconds() -> float:
    try:
        return max(1.0, float(os.environ.get("SWPM_USD_PROBE_SECONDS", PROBE_SECONDS)))
    except ValueError:
        return PROBE_SECONDS


def _stamp(path: str) -> _Stamp:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_size, st.st_mtime_ns, st.st_ino)


def _key(path: str) -> tuple[str, int, int, int] | None:
    stamp = _stamp(path)
    return None if stamp is None else (os.path.realpath(path), *stamp)


def _answer(key: tuple[str, int, int, int], path: str) -> Problem | None:
    """The answer kept for the file of ``key``, its message naming the file as ``path`` spells it (another
    spelling of the same file, a link to it, may have been probed: the callers strip their own)."""
    problem, _, spelled = _answers[key]
    if problem is None or spelled == path or not problem.message.startswith(f"{spelled}: "):
        return problem
    return problem._replace(message=f"{path}: {problem.message[len(spelled) + 2 :]}")


def _known(key: tuple[str, int, int, int]) -> bool:
    """Whether this process has an answer for the file of ``key`` that still holds (the files it depends on
    unchanged)."""
    known = _answers.get(key)
    return known is not None and all(_stamp(p) == stamp for p, stamp in known[1])


def check(path: str | os.PathLike[str]) -> Problem | None:
    """None when opening ``path``'s stage opens no crate file (:func:`needs_probe`) or a probe process
    opened and read it cleanly (the caller may then open it in its own process), else the :class:`Problem`:
    usd-core crashed on it (the signal), did not finish within :data:`PROBE_SECONDS`, or raised an error
    opening it or reading a value (its message), or the probe failed twice. Asked again while the file and
    every file its answer depends on (the layers the probe opened, those its text layers or its composition
    errors name) are as they were (path, size, mtime, inode), the first answer is given without a probe."""
    return check_many([path])[0]


def check_many(
    paths: Sequence[str | os.PathLike[str]],
    jobs: int | None = None,
    opened: Callable[[int], object] | None = None,
) -> list[Problem | None]:
    """:func:`check` of each of ``paths`` (in order), probing up to ``jobs`` at once (default: the usable
    cores); the answers are those of :func:`check`, one file at a time. A file given twice, in one spelling
    or two (a link to it, ``a/../b``), is probed once (its real path, size, mtime and inode); each file is
    stat'ed once here, and one that is not a regular file is an answer at once (never opened).

    ``opened(i)`` is called for each text root ``paths[i]`` found clean here, naming no crate file (no probe),
    while the text layers parsed to know it are held (as in a :func:`checked` block): a caller that opens it
    then finds them parsed (a text root parsed once, not twice: the pipeline's planner), and they are let go
    as it returns, before the next file's (a batch's layers are not held together)."""
    answers: list[Problem | None] = [None] * len(paths)
    # key -> (the path as first given, its indices, the files its text layers name)
    todo: dict[tuple[str, int, int, int], tuple[str, list[int], list[str]]] = {}
    for i, path in enumerate(paths):
        p = os.fspath(path)
        try:
            st = os.stat(p)
        except OSError:
            continue  # (the caller's own open reports a missing or unreadable file)
        key = (os.path.realpath(p), st.st_size, st.st_mtime_ns, st.st_ino)
        if key in todo:
            todo[key][1].append(i)
            continue
        if _known(key):
            answers[i] = _answer(key, p)
            continue
        if not stat.S_ISREG(st.st_mode):  # (a FIFO's open would wait for a writer: never opened)
            _answers[key] = (_not_regular(p, None, st.st_mode), (), p)
            answers[i] = _answers[key][0]
            continue
        suffix = Path(p).suffix.lower()
        if suffix in (".usdc", ".usdz") or (suffix != ".usda" and _crate_magic(p)):  # (is_crate, stat'ed)
            named: list[str] = []
        else:
            holds = opened is not None and getattr(_holding, "layers", None) is None
            if holds:  # (this root's text layers held while the caller opens it, then let go: one at a time)
                _holding.layers = []
            try:
                try:
                    crate, named = _named_files(p)
                except _NotRegular as odd:
                    files = (n for n in odd.named if n != key[0])
                    _answers[key] = (
                        _not_regular(p, odd.layer, odd.mode),
                        tuple((n, _stamp(n)) for n in files),
                        p,
                    )
                    answers[i] = _answers[key][0]
                    continue
                if not crate:
                    _answers[key] = (None, tuple((n, _stamp(n)) for n in named if n != key[0]), p)
                    if opened is not None:
                        opened(i)
                    continue
            finally:
                if holds:
                    _holding.layers = None
        todo[key] = (p, [i], named)
    if not todo:
        return answers
    found = _probe_all([(p, key[1]) for key, (p, _, _) in todo.items()], jobs)
    for key, (p, where, named) in todo.items():
        # (the files this probe opened or was opening, named to the server before each opened: a probe
        # that crashed or hung is keyed on the layers it reached, not on an earlier answer's)
        problem, layers = found[p]
        files = {n for n in (*named, *layers) if n != key[0]}
        _answers[key] = (problem, tuple((n, _stamp(n)) for n in sorted(files)), p)
        used = _probed_used.pop(p, None)
        if problem is None and used is not None:
            _used[key] = (_answers[key], used)
        for i in where:
            answers[i] = _answer(key, os.fspath(paths[i]))
    return answers


def used_layers(path: str | os.PathLike[str]) -> list[str] | None:
    """The files of the layers ``path``'s stage uses (its own, its sublayers, references, payloads; a
    package's inner layer as the package), sorted, as the probe that found it clean listed them after its
    open: a caller that wants only those (the pipeline's planner, the inputs of a USD asset) need not open the
    stage in its own process, which parsed a large crate file a second time (the probe's, then the worker's
    build, are the two it must have). None when this process has no such clean answer for the file as it is
    now (not probed: a text root naming no crate file; changed since; probed by an older server)."""
    key = _key(os.fspath(path))
    if key is None or key not in _used or not _known(key) or _answers[key][0] is not None:
        return None
    answer, used = _used[key]
    return list(used) if answer is _answers[key] else None


@contextlib.contextmanager
def checked(path: str | os.PathLike[str]) -> Iterator[Problem | None]:
    """:func:`check` of ``path``, the text layers it parsed in this process (to know whether the stage opens
    a crate file) kept open in usd-core's layer registry while the block runs: the block's own
    ``Usd.Stage.Open(path)`` finds them parsed (a text layer parsed once, not twice). They are let go as the
    block ends: a later open reads the files anew."""
    outer = getattr(_holding, "layers", None)
    if outer is None:
        _holding.layers = []
    try:
        yield check(path)
    finally:
        if outer is None:
            _holding.layers = None


def cleared(path: str | os.PathLike[str]) -> list[list]:
    """Whether this process found ``path`` clean, as it is now with every file its answer depends on: its
    key (path, size, mtime, inode, then those files' ``[path, size, mtime, inode]``, ``[path]`` for one not
    there) in a list, else ``[]``. Handed to another process that opens the file (a pipeline's worker: the
    run's planning probed the asset) with :func:`trust`, the file is not probed again there."""
    key = _key(os.fspath(path))
    if key is None or not _known(key) or _answers[key][0] is not None:
        return []
    return [[*key, [[p, *stamp] if stamp is not None else [p] for p, stamp in _answers[key][1]]]]


def trust(keys: Iterable[Sequence]) -> None:
    """Take the keys :func:`cleared` gave in another process as found clean here (a file changed since, or
    one of the files its answer depends on, has another key: probed again). A key of four items (path,
    size, mtime, inode) depends on no other file."""
    for key in keys:
        path, size, mtime_ns, ino = key[:4]
        deps = tuple(
            (str(d[0]), (int(d[1]), int(d[2]), int(d[3])) if len(d) == 4 else None)
            for d in (key[4] if len(key) > 4 else ())
        )
        _answers.setdefault((str(path), int(size), int(mtime_ns), int(ino)), (None, deps, str(path)))


#: the probe process this one asks (started on the first crate file, again after one crashed it)
_server: subprocess.Popen[bytes] | None = None
_server_pid = 0
_crash_folder: tuple[int, str] | None = None  # (the process that made it, the folder)
_lock = threading.Lock()


def _cores() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def _crash_dir() -> str:
    """The probe servers' temporary folder (one a process, removed when it exits)."""
    global _crash_folder
    if _crash_folder is None or _crash_folder[0] != os.getpid():
        folder = tempfile.mkdtemp(prefix="swpm-probe-")
        _crash_folder = (os.getpid(), folder)
        atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return _crash_folder[1]


def _start_server() -> subprocess.Popen[bytes]:
    global _server, _server_pid
    if _server is None or _server_pid != os.getpid() or _server.poll() is not None:
        from .plugin import PLUGIN_PATH

        crash_dir = _crash_dir()
        _server = subprocess.Popen(
            [sys.executable, "-c", _PROBE, PLUGIN_PATH, str(os.getpid())],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            # (no worker threads in the process each probe is forked from: a fork keeps only the
            # thread that forks, and a pool of usd-core's whose threads are gone would hang)
            env={
                **os.environ,
                "PXR_WORK_THREAD_LIMIT": "1",
                # (usd-core writes a crash report of each probe its fatal error handler ends to TMPDIR: a
                # folder of this server's, read into the answer and removed, not one left in /var/tmp)
                "TMPDIR": crash_dir,
                "SWPM_PROBE_CRASH_DIR": crash_dir,
            },
        )
        _server_pid = os.getpid()  # (a process forked from this one starts its own)
        atexit.register(_end_server, _server)
    return _server


def _end_server(server: subprocess.Popen[bytes]) -> None:
    """At exit: end the server this process started (its input closed: it ends on that) and close its pipes,
    not leave it running for Python to warn of ("subprocess ... is still running") with its pipes open."""
    if _server_pid != os.getpid() or server.returncode is not None:
        _close_pipes(server)
        return
    with contextlib.suppress(OSError):
        server.stdin.close()  # type: ignore[union-attr]
    try:
        server.wait(timeout=5)
    except subprocess.TimeoutExpired:
        server.kill()
        server.wait()
    _close_pipes(server)


def _close_pipes(server: subprocess.Popen[bytes]) -> None:
    for pipe in (server.stdin, server.stdout):
        if pipe is not None:
            with contextlib.suppress(OSError):
                pipe.close()


def _probe_all(files: list[tuple[str, int]], jobs: int | None) -> dict[str, tuple[Problem | None, list[str]]]:
    """Probe each (path, size) of ``files``, up to ``jobs`` at once: path -> (the problem, the real paths
    of the layer files the probe opened). A probe that fails itself (it raised an error outside its
    guarded reads, gave no answer, or no process could be started) is tried once more in a fresh server,
    then a "probe" :class:`Problem`: the file is not opened in this process."""
    seconds = _seconds()
    jobs = max(1, jobs if jobs is not None else _cores())
    out: dict[str, tuple[Problem | None, list[str]]] = {}
    tries = {path: 0 for path, _ in files}
    sizes = dict(files)
    queue = [path for path, _ in files]
    with _lock:
        while queue:
            failed = _serve(queue, sizes, seconds, jobs, out)
            # (the files not asked yet when the server went: asked the fresh one, no try of their own spent)
            queue = [path for path in queue if path not in out and path not in failed]
            for path, why in failed.items():
                tries[path] += 1
                if tries[path] < 2:
                    queue.append(path)
                else:
                    out[path] = (
                        Problem(
                            "probe",
                            f"{path}: the process probing it failed ({why}); it was not opened in this "
                            "process",
                        ),
                        [],
                    )
            if queue:
                _stop(_server)  # (a fresh server for the second try)
    return out


def _serve(
    queue: list[str],
    sizes: dict[str, int],
    seconds: float,
    jobs: int,
    out: dict[str, tuple[Problem | None, list[str]]],
) -> dict[str, str]:
    """Ask the probe server about each path of ``queue``, ``jobs`` in flight at most, into ``out``; the paths
    whose probe failed itself, each with why."""
    failed: dict[str, str] = {}
    flight: dict[int, tuple[str, float]] = {}  # tag -> (path, when asked)
    tags = iter(range(1 << 62))
    queue = list(queue)
    pending = b""
    try:
        server = _start_server()
        assert server.stdin is not None and server.stdout is not None
        fd = server.stdout.fileno()
        while queue or flight:
            while queue and len(flight) < jobs:
                path = queue.pop(0)
                tag = next(tags)
                memory = PROBE_MEMORY_BASE + PROBE_MEMORY_PER_BYTE * sizes[path]
                request = json.dumps([tag, str(Path(path).absolute()), seconds, memory]).encode() + b"\n"
                server.stdin.write(request)
                server.stdin.flush()
                flight[tag] = (path, time.monotonic())
            oldest = min(asked for _, asked in flight.values())
            wait = oldest + seconds + 30 - time.monotonic()
            ready, _, _ = select.select([fd], [], [], max(0.0, wait))
            if not ready:  # (a probe hangs past its own alarm: every probe in flight is asked again)
                _stop(server)
                for path, asked in flight.values():
                    if asked == oldest:
                        out[path] = (_overran(path, seconds), [])
                    else:
                        queue.append(path)
                flight.clear()
                pending = b""
                server = _start_server()
                assert server.stdin is not None and server.stdout is not None
                fd = server.stdout.fileno()
                continue
            data = os.read(fd, 1 << 16)
            if not data:  # (the server went: the probes in flight gave no answer)
                _stop(server)
                for path, _ in flight.values():
                    failed[path] = "it ended without an answer"
                return failed
            pending += data
            while b"\n" in pending:
                line, pending = pending.split(b"\n", 1)
                try:
                    tag, code, text, layers, used = json.loads(line)
                    path, _ = flight.pop(tag)
                except (ValueError, KeyError, TypeError):
                    _stop(server)
                    for path, _ in flight.values():
                        failed[path] = "an answer that is not one"
                    return failed
                if code >= 0 and code not in (
                    _CLEAN,
                    _OPEN_FAILED,
                    _READ_FAILED,
                    _LAYER_FAILED,
                    _NOT_REGULAR,
                ):
                    failed[path] = text or f"its answer {code}"
                else:
                    problem = _problem(path, code, text, seconds)
                    out[path] = (problem, [str(p) for p in layers])
                    if problem is None:
                        _probed_used[path] = [str(p) for p in used]
    except OSError as exc:  # (no process can be started, or it went)
        _stop(_server)
        for path in [*(p for p, _ in flight.values()), *queue]:
            failed[path] = f"{type(exc).__name__}: {exc}"
    except BaseException:  # (Ctrl-C while waiting: the answers not read would be the next files')
        _stop(_server)
        raise
    return failed


def _stop(server: subprocess.Popen[bytes] | None) -> None:
    """Kill the probe server (hung, or gone) and forget it. One the process this one was forked from started
    (a child whose own server failed to start, or Ctrl-C before it had one) is that process's: only this
    process's copies of its pipes are closed, not the server killed under its parent."""
    global _server
    if server is not None:
        if server is _server and _server_pid != os.getpid():
            _close_pipes(server)
        else:
            server.kill()
            server.wait()
            _close_pipes(server)
    _server = None
