"""Atomic file writes: a reader (or a crash) sees the old file or the complete new one, never a part."""

from __future__ import annotations

import errno
import os
import secrets
import shutil
import stat
import tempfile
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from pathlib import Path
from typing import Any, TypeVar

_T = TypeVar("_T")


def _umask() -> int:
    """The process umask, read without changing it where Linux shows it (``os.umask`` sets it to read it,
    which another thread could see), else by setting and restoring it."""
    try:
        with open("/proc/self/status", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def mode_for(path: str | os.PathLike[str]) -> int:
    """The permission bits a file written to ``path`` (a temporary file renamed over it) gets: those of the
    regular file now at ``path`` (a replaced output keeps its mode: 0o640, 0o444 stay so), else the mode a
    plain ``open()`` gives a new file, 0o666 less the umask. The read, write and execute bits only (no
    set-id or sticky bit is carried over to new content)."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        st = None
    if st is not None and stat.S_ISREG(st.st_mode):
        return stat.S_IMODE(st.st_mode) & 0o777
    return 0o666 & ~_umask()


def link_loop(path: str | os.PathLike[str]) -> tuple[Path, str] | None:
    """The link on the way to ``path`` (``path`` itself or one of its folders) that leads round in a loop
    (``a -> b -> a``: following it fails with ELOOP), nearest the root, and what it names; None when there is
    none. A path that names no file for this reason was called "not found" or "a dangling link", which sends
    a user looking for a file that was never missing."""
    path = Path(path)
    for p in reversed([path, *path.parents]):
        if not p.is_symlink():  # (False too where lstat fails: below a loop, p is never reached)
            continue
        try:
            os.stat(p)
        except OSError as exc:
            if exc.errno == errno.ELOOP and _comes_back(p):
                try:
                    return p, os.readlink(p)
                except OSError:
                    return p, "?"
    return None


def _comes_back(link: Path) -> bool:
    """Whether following ``link`` link by link comes back to one already followed (a loop), where ELOOP is
    also the system's word for a chain of more links than it follows (40 on Linux) ending at a file."""
    seen: set[str] = set()
    here = os.path.abspath(link)
    while os.path.islink(here):
        if here in seen or len(seen) > 100_000:
            return True
        seen.add(here)
        try:
            here = os.path.normpath(os.path.join(os.path.dirname(here), os.readlink(here)))
        except OSError:
            return False
    return False


def missing_file_problem(path: str | os.PathLike[str]) -> str:
    """Why ``path``, which names no file, does not: ``a link loop (to b.obj)`` for a link that leads round in
    a loop, ``its folder d is a link loop (to e)`` for one on the way to it (:func:`link_loop`), else ``file
    not found``."""
    loop = link_loop(path)
    if loop is None:
        try:
            os.stat(path)
        except OSError as exc:
            if exc.errno == errno.ELOOP:  # (a chain of links longer than the system follows, not a loop)
                return "too many links to follow on the way to it (a chain longer than the system follows)"
        return "file not found"
    link, target = loop
    if link == Path(path):
        return f"a link loop (to {target}): following it comes back round, to no file"
    return f"its folder {link} is a link loop (to {target}): following it comes back round, to no file"


def set_plain_mode(fd: int, like: str | os.PathLike[str] | None = None) -> None:
    """Give the open file ``fd`` the mode a plain ``open()`` gives a new file, 0o666 less the umask
    (``mkstemp``'s is always 0o600), or with ``like`` (the path ``fd`` is to be renamed over) :func:`mode_for`
    it: the mode of the file it replaces. A filesystem without modes (vfat, some network mounts) keeps its
    own."""
    try:
        os.fchmod(fd, 0o666 & ~_umask() if like is None else mode_for(like))
    except (OSError, AttributeError):
        pass


def set_mode_for(tmp: str | os.PathLike[str], target: str | os.PathLike[str]) -> None:
    """Give the file ``tmp``, about to be renamed over ``target``, :func:`mode_for` ``target`` (for a file
    another library created, e.g. a USD layer saved by usd-core)."""
    try:
        os.chmod(tmp, mode_for(target))
    except (OSError, NotImplementedError):
        pass


def temporary_beside(path: Path, prefix: str, suffix: str) -> tuple[int, str]:
    """``tempfile.mkstemp`` in ``path``'s folder: (descriptor, name). An error creating it (a disk quota
    met, a folder that refuses files) names ``path``, the file it is for, not the temporary one, which is
    not there."""
    try:
        return tempfile.mkstemp(prefix=prefix, suffix=suffix, dir=path.parent)
    except OSError as exc:
        if exc.errno is None or (exc.filename is not None and Path(exc.filename).parent != path.parent):
            raise
        raise OSError(exc.errno, exc.strerror, os.fspath(path)) from exc


def stage_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to a new temporary file beside ``path`` (``.<name>.XXXXXXXX.tmp``), fsync it and
    return its path, for the caller to rename over ``path`` (or delete).

    The file gets the mode of the file now at ``path``, which it is to replace, or for a new file the mode a
    plain ``open()`` gives one, 0o666 less the umask (:func:`mode_for`; ``mkstemp``'s is always 0o600: other
    users, a render farm's accounts or a web server could not read the outputs)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = temporary_beside(path, f".{path.name}.", ".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            set_plain_mode(f.fileno(), like=path)
            os.fsync(f.fileno())
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        if exc.filename is None and exc.errno is not None:
            # a write's or fsync's error names no file (a full disk said "No space left on device" alone):
            # named after the file it was to replace, which the caller's message can show
            raise OSError(exc.errno, exc.strerror, os.fspath(path)) from exc
        raise
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return Path(tmp)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to a temporary file beside ``path``, fsync it, then rename it into place
    (:func:`stage_bytes`)."""
    tmp = stage_bytes(path, data)
    try:
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return Path(path)


def keep_aside(path: str | os.PathLike[str]) -> Path | None:
    """Keep the file now at ``path`` under a new temporary name beside it (``.<name>.XXXXXXXX.prev.tmp``),
    so it can be renamed back after ``path`` is replaced: a hard link (no data copied), or a copy where the
    filesystem has no hard links. None when there is no file at ``path``."""
    path = Path(path)
    for _ in range(100):
        aside = path.with_name(f".{path.name}.{secrets.token_hex(4)}.prev.tmp")
        try:
            os.link(path, aside, follow_symlinks=False)
            return aside
        except FileExistsError:
            continue
        except FileNotFoundError:
            return None
        except (OSError, NotImplementedError):  # EPERM, EOPNOTSUPP, EMLINK: no (more) hard links here
            break
    else:  # pragma: no cover - a hundred random names taken
        raise FileExistsError(f"no free temporary name beside {path}")
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".prev.tmp", dir=path.parent)
    os.close(fd)
    aside = Path(name)
    try:
        shutil.copyfile(path, aside)
        shutil.copystat(path, aside)
    except FileNotFoundError:
        aside.unlink(missing_ok=True)
        return None
    except BaseException:
        aside.unlink(missing_ok=True)
        raise
    return aside


@contextmanager
def new_layer_replacing(
    target: str | os.PathLike[str],
    tmp: str | os.PathLike[str],
    args: dict[str, str] | None = None,
    errors: Callable[[], AbstractContextManager[Any]] = nullcontext,
) -> Iterator[Any]:
    """A new, empty USD layer (``Sdf.Layer.CreateNew``) at the temporary path ``tmp`` beside ``target`` (a
    real layer: relative asset paths authored in it resolve as they will from ``target``), for the ``with``
    block to fill. After the block it is saved, given ``target``'s mode (:func:`set_mode_for`: a replaced
    layer keeps its mode), renamed over ``target``, and a layer of ``target``'s name open in this process
    reloaded (it would keep its old content). Any failure, the block's, the save's or the rename's, deletes
    ``tmp`` and is raised: ``target`` is left as it was, on disk and in memory. ``errors`` (a context manager
    factory: an error translation) is entered around the layer's creation and around its save and rename,
    not around the block. A save usd-core refuses (``Save()`` False) is an :class:`OSError`.

    The one way ``write_usdlod``, ``write_overrides`` and the pipeline's ``scene.usda`` write a layer they
    author (``Sdf.Layer.CreateNew`` writes an empty layer at once: at the target, a failure would leave it
    empty)."""
    from pxr import Sdf

    from .usd.writer import reload_if_open

    target, tmp = Path(target), Path(tmp)
    with errors():
        target.parent.mkdir(parents=True, exist_ok=True)
        layer = Sdf.Layer.CreateNew(str(tmp), args=args or {})
    try:
        yield layer
        with errors():
            if not layer.Save():
                raise OSError(f"usd-core did not save the layer {target}")
            set_mode_for(tmp, target)
            os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    # (a reload that fails raises with this frame in its traceback: a caller that keeps the error would keep
    # the layer authored at ``tmp``, renamed since, alive; a caller binding it ``as`` drops its name too)
    del layer
    reload_if_open(target)


def fill_layer_replacing(
    target: str | os.PathLike[str],
    tmp: str | os.PathLike[str],
    fill: Callable[[Any], _T],
    args: dict[str, str] | None = None,
    errors: Callable[[], AbstractContextManager[Any]] = nullcontext,
) -> _T:
    """:func:`new_layer_replacing`, the new layer filled by ``fill`` (its result returned) and bound in no
    frame of the caller's: a ``LayerReloadError`` (the file written, the layer of its name open here not
    reloaded) that a caller keeps does not keep the layer authored at ``tmp`` alive (the error's traceback
    holds each frame it went through, with the names bound in it)."""
    with new_layer_replacing(target, tmp, args, errors) as layer:
        result = fill(layer)
        del layer  # (before the save, the rename and the reload)
    return result
