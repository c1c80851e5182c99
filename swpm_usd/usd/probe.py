"""Open an untrusted binary USD file (crate, ``.usdc``) in a probe process before this one opens it.

usd-core does not survive every corrupt crate file: a byte flipped in a value or in a section's header makes
``Usd.Stage.Open`` or a value's read crash the process (SIGSEGV), or ask for a giant allocation (the system
kills the process, or another one). :func:`check` has the file opened first by a probe process (``python
-c`` :data:`_PROBE`: the stage opened, every prim's and property's metadata and values read, every spec of
every layer it uses), under a memory and a time limit. Only when the probe reads it cleanly does the caller
open the file itself; a probe that dies by a signal or overruns its time, or in which usd-core cannot open
the file or read a value, is a :class:`Problem` (one line naming the file) the caller turns into its typed
error (``validate``: ``SWPM_USD_CRASH``, ``SWPM_USD_OPEN`` or ``SWPM_USD_READ``; the loader:
:class:`~swpm_usd.errors.MeshLoadError`).

Only files usd-core reads as crate are probed (:func:`is_crate`: a ``.usdc``, a ``.usdz``, a ``.usd`` whose
first bytes are ``PXR-USDC``; its text parser fails cleanly), and each once per process (the answer is kept
by path, size, mtime and inode). One probe server serves every file of this process: started once (Python
and usd-core's import, about 0.3 s), it forks a fresh process for each file (about 12 ms for a small one: the
server has built usd-core's schema registry once, on a stage of its own in memory, which each fork inherits),
so a file that crashes or corrupts a probe leaves the next one a clean process.
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import threading
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import NamedTuple

#: the first bytes of a crate (binary USD) file
CRATE_MAGIC = b"PXR-USDC"
#: seconds a probe may take (a crate file usd-core hangs on); ``SWPM_USD_PROBE_SECONDS`` overrides it
PROBE_SECONDS = 300.0
#: address space a probe may use: this much plus :data:`PROBE_MEMORY_PER_BYTE` times the file's size (a
#: corrupt array or section size asks usd-core for terabytes; under the limit that is an error, not a kill
#: by the system's out-of-memory killer, which may pick another process)
PROBE_MEMORY_BASE = 4 << 30
PROBE_MEMORY_PER_BYTE = 64
#: a probe's answers: usd-core opened and read the file, raised an error opening it, or reading a value in
#: it (its first message beside)
_CLEAN, _OPEN_FAILED, _READ_FAILED = 0, 3, 4

#: the probe server's program: argv[1] the schema plugin's folder (registered as this process registers it:
#: its fallbacks are values read too; through PXR_PLUGINPATH_NAME, usd-core 26.11 raises "There already is
#: a type named 'SwpmMeshAPI'" at the first stage's open). It reads requests, one JSON line each (the file,
#: its seconds and its address-space limit in bytes), forks a process that probes the file under those
#: limits, and answers each with a JSON line: [code, message], the code the probe's (``_CLEAN``,
#: ``_OPEN_FAILED``, ``_READ_FAILED``) or minus the signal it died by (SIGALRM: out of time). It ends when
#: its input does
_PROBE = r"""
import json, os, resource, signal, sys
signal.signal(signal.SIGINT, signal.SIG_IGN)
from pxr import Plug, Sdf, Tf, Usd
try:
    Plug.Registry().RegisterPlugins(sys.argv[1])
except Exception:
    pass
def warm():
    # usd-core's first stage in a process builds its schema registry (reads every plugin's schemas: ~25 ms,
    # most of a small file's probe): done once here, on a stage of our own in memory, each fork inherits it
    from pxr import UsdGeom
    Sdf.FileFormat.FindByExtension("usdc")
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.Mesh.Define(stage, "/m").CreatePointsAttr()
    for prim in stage.Traverse():
        prim.GetAllMetadata()
        for attr in prim.GetAttributes():
            attr.GetAllMetadata()
            attr.Get()
try:
    warm()
except Exception:
    pass
def probe(path):
    try:
        stage = Usd.Stage.Open(path)
    except Exception as exc:
        return 3, str(exc)
    if stage is None:
        return 3, ""
    failed = []
    def attempt(fn, *args):
        try:
            return fn(*args)
        except Tf.ErrorException as exc:
            failed.append(str(exc))
        except UnicodeDecodeError as exc:
            failed.append(f"a text value (token or string) is not UTF-8: {exc}")
        except Exception:
            pass
        return None
    def read_prim(prim):
        attempt(prim.GetAllMetadata)
        for prop in attempt(prim.GetProperties) or []:
            attempt(prop.GetAllMetadata)
            if isinstance(prop, Usd.Attribute):
                value = attempt(prop.Get)
                if type(value).__name__ in ("TokenArray", "StringArray"):  # (made Python text as read)
                    attempt(lambda value=value: [str(v) for v in value])
                times = attempt(prop.GetTimeSamples) or []
                for t in times[:1] + times[-1:]:
                    attempt(prop.Get, t)
            else:
                attempt(prop.GetTargets)
    for root in [stage.GetPseudoRoot()] + list(attempt(stage.GetPrototypes) or []):
        for prim in Usd.PrimRange.AllPrims(root):
            read_prim(prim)
    attempt(stage.GetCompositionErrors)
    def read_spec(layer, path):
        spec = attempt(layer.GetObjectAtPath, path)
        if spec is None:
            return
        for key in attempt(spec.ListInfoKeys) or []:
            attempt(spec.GetInfo, key)
        for t in attempt(layer.ListTimeSamplesForPath, path) or []:
            attempt(layer.QueryTimeSample, path, t)
    for layer in attempt(stage.GetUsedLayers) or []:
        attempt(layer.Traverse, Sdf.Path.absoluteRootPath, lambda p, layer=layer: read_spec(layer, p))
    return (4, failed[0]) if failed else (0, "")
for line in sys.stdin:
    path, seconds, memory = json.loads(line)
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(r)
        try:
            resource.setrlimit(resource.RLIMIT_AS, (memory, resource.RLIM_INFINITY))
        except (ValueError, OSError):
            pass
        signal.alarm(max(1, int(seconds)))
        code, message = probe(path)
        with os.fdopen(w, "w") as out:
            out.write(json.dumps([code, message]))
        os._exit(0)
    os.close(w)
    with os.fdopen(r) as got:
        text = got.read()
    _, status = os.waitpid(pid, 0)
    if os.WIFSIGNALED(status):
        answer = [-os.WTERMSIG(status), ""]
    else:
        try:
            answer = json.loads(text)
        except ValueError:
            answer = [5, ""]
    sys.stdout.write(json.dumps(answer) + "\n")
    sys.stdout.flush()
"""


class Problem(NamedTuple):
    """What a probe found: ``kind`` "crash" (usd-core died by a signal), "timeout", "open" (it raised an
    error opening the file) or "read" (opening it, but reading a value in it: corrupt data, which read in
    this process could ask for a giant allocation), and ``message``, one line naming the file."""

    kind: str
    message: str


#: (real path, size, mtime_ns, inode) -> the problem found (None: none)
_answers: dict[tuple[str, int, int, int], Problem | None] = {}


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
    try:
        with open(path, "rb") as f:
            return f.read(len(CRATE_MAGIC)) == CRATE_MAGIC
    except OSError:
        return False


def _seconds() -> float:
    try:
        return max(1.0, float(os.environ.get("SWPM_USD_PROBE_SECONDS", PROBE_SECONDS)))
    except ValueError:
        return PROBE_SECONDS


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def check(path: str | os.PathLike[str]) -> Problem | None:
    """None when ``path`` is not a crate file or a probe process opened and read it cleanly (the caller may
    then open it in its own process), else the :class:`Problem`: usd-core crashed on it (the signal), did
    not finish within :data:`PROBE_SECONDS`, or raised an error opening it or reading a value (its message).
    Asked again for the same file (path, size, mtime, inode), the first answer is given without a probe."""
    p = os.fspath(path)
    key = _key(p)
    if key is None:
        return None  # (the caller's own open reports a missing or unreadable file)
    if not is_crate(p):
        return None
    if key not in _answers:
        _answers[key] = _probe(p, key[1])
    return _answers[key]


def _key(path: str) -> tuple[str, int, int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (os.path.realpath(path), st.st_size, st.st_mtime_ns, st.st_ino)


def cleared(path: str | os.PathLike[str]) -> list[tuple[str, int, int, int]]:
    """Whether this process probed ``path`` clean, as it is now: its key (path, size, mtime, inode) in a list,
    else ``[]``. Handed to another process that opens the file (a pipeline's worker: the run's planning
    probed the asset) with :func:`trust`, the file is not probed again there."""
    key = _key(os.fspath(path))
    return [key] if key is not None and key in _answers and _answers[key] is None else []


def trust(keys: Iterable[Sequence[str | int]]) -> None:
    """Take the keys :func:`cleared` gave in another process as probed clean here (a file changed since has
    another key: probed again)."""
    for key in keys:
        path, size, mtime_ns, ino = key
        _answers.setdefault((str(path), int(size), int(mtime_ns), int(ino)), None)


#: the probe process this one asks (started on the first crate file, again after one crashed it)
_server: subprocess.Popen[bytes] | None = None
_server_pid = 0
_lock = threading.Lock()


def _probe(path: str, size: int) -> Problem | None:
    global _server, _server_pid
    seconds = _seconds()
    memory = PROBE_MEMORY_BASE + PROBE_MEMORY_PER_BYTE * size
    request = json.dumps([str(Path(path).absolute()), seconds, memory]).encode() + b"\n"
    with _lock:
        try:
            if _server is None or _server_pid != os.getpid() or _server.poll() is not None:
                from .plugin import PLUGIN_PATH

                _server = subprocess.Popen(
                    [sys.executable, "-c", _PROBE, PLUGIN_PATH],
                    stdin=subprocess.PIPE,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.DEVNULL,
                    # (no worker threads in the process each probe is forked from: a fork keeps only the
                    # thread that forks, and a pool of usd-core's whose threads are gone would hang)
                    env={**os.environ, "PXR_WORK_THREAD_LIMIT": "1"},
                )
                _server_pid = os.getpid()  # (a process forked from this one starts its own)
            server = _server
            assert server.stdin is not None and server.stdout is not None
            server.stdin.write(request)
            server.stdin.flush()
            ready, _, _ = select.select([server.stdout], [], [], seconds + 30)
            line = server.stdout.readline() if ready else None
        except OSError:  # (no process can be started, or it went: the caller opens the file as before)
            line = b""
        except BaseException:  # (Ctrl-C while waiting: the answer not read would be the next file's)
            _stop(_server)
            raise
        if line is None:  # (a probe hangs past its own alarm)
            _stop(_server)
            return _overran(path, seconds)
        if not line:
            _stop(_server)
            return None
    try:
        code, text = json.loads(line)
    except ValueError:
        return None
    if code == _CLEAN:
        return None
    if code == -signal.SIGALRM:
        return _overran(path, seconds)
    if code < 0:
        return Problem(
            "crash",
            f"{path}: usd-core crashed opening or reading it (a probe process died by "
            f"{_signal_name(-code)}): the file is corrupt; it was not opened in this process",
        )
    if code not in (_OPEN_FAILED, _READ_FAILED):
        return None  # (the probe itself failed, not usd-core on the file: the caller opens it as before)
    from ..errors import tf_message

    reason = tf_message(RuntimeError(text)) if text.strip() else "usd-core returned no stage"
    if code == _OPEN_FAILED:
        return Problem("open", f"{path}: usd-core cannot open it as a USD layer: {reason}")
    return Problem("read", f"{path}: usd-core cannot read it: {reason}")


def _stop(server: subprocess.Popen[bytes] | None) -> None:
    """Kill the probe server (hung, or gone) and forget it."""
    global _server
    if server is not None:
        server.kill()
        server.wait()
    _server = None


def _overran(path: str, seconds: float) -> Problem:
    return Problem(
        "timeout",
        f"{path}: usd-core did not finish opening and reading it within {seconds:g} s (a probe process was "
        "stopped): the file is corrupt, or larger than SWPM_USD_PROBE_SECONDS allows",
    )
