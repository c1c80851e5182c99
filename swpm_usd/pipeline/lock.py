"""One run at a time in an output folder: an exclusive ``flock`` on its lock file, and who holds it.

A second run in the same output.dir fails at once (:class:`..errors.OutputLockedError`, naming the pid
that holds the lock, as Linux lists it in ``/proc/locks`` or as the holder wrote it in the file) rather
than deleting the first run's temporary files and interleaving manifests. Separate from the runner: the
lock is plain POSIX file locking, and knows nothing of plans, records or workers.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import OutputLockedError

#: the lock file of output.dir: a run holds an exclusive ``flock`` on it while it writes there (see
#: :class:`_OutputLock`); the file stays, the lock goes with the run
LOCK = ".swpm-pipeline.lock"


class _OutputLock:
    """One run at a time in an output folder: an exclusive, non-blocking ``flock`` on its :data:`LOCK` file.

    A second run fails at once with :class:`OutputLockedError` instead of deleting the first one's temporary
    files and interleaving manifests. The kernel drops the lock when the holder's file is closed, so it goes
    with the run however it ends (an error, Ctrl-C, a kill); the file itself stays (deleting it would let a
    third run lock a new file while the second still holds the old one). The holder's pid is written in it for
    the message, by :meth:`claim`, once the run writes in the folder: a run that writes nothing there (a
    rerun with nothing to do) holds the lock as any other, and leaves the file as it was (the pid in it is
    then an ended run's: a run it stops names the holder as the kernel lists it, :func:`_lock_holder`,
    and the pid in the file only where there is no such list, if a process has that pid). Where
    ``flock`` is missing (Windows) or refused (a filesystem without locks), the run goes on unlocked, with
    a warning."""

    def __init__(self, out_dir: Path, echo) -> None:
        self.path = out_dir / LOCK
        self.echo = echo
        self.fd: int | None = None
        self.done = False
        self.writable = False  # (the lock file opened for writing: its pid can be written)
        self.claimed = False  # (this run's pid written in it)

    def acquire(self, folder_checked: bool = False) -> None:
        """Take the lock, or raise :class:`OutputLockedError`. A lock file this process cannot open is
        ignored before the folder is checked (``folder_checked``: a folder the run cannot write in is
        reported as such, exit 2), and after it gives the warning of a filesystem without locks."""
        if self.done:
            return
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not on POSIX
            self.done = True
            return
        cloexec = getattr(os, "O_CLOEXEC", 0)
        writable = True
        try:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | cloexec, 0o666)
            except PermissionError:  # another user's lock file (0o644): flock needs no write access
                fd, writable = os.open(self.path, os.O_RDONLY | cloexec), False
        except OSError as exc:
            if folder_checked:
                self._unlocked(exc)
            return
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = _lock_holder(fd)  # (the holder as the kernel lists it: it may not have written its pid)
            if pid is None:
                try:
                    pid = int(os.read(fd, 32).decode().strip())
                except (OSError, ValueError):
                    pid = None
            os.close(fd)
            raise OutputLockedError(
                self.path.parent, pid if pid is not None and _running(pid) else None
            ) from None
        except OSError as exc:  # ENOLCK, EOPNOTSUPP: a filesystem that does not lock
            os.close(fd)
            self._unlocked(exc)
            return
        self.fd, self.done, self.writable = fd, True, writable

    def claim(self) -> None:
        """Write this process's pid in the lock file held (once; nothing without the lock, or when the file
        is not writable: it keeps an earlier run's pid, which is not running, so not shown). The run calls
        it before it first writes in output.dir."""
        if self.fd is None or not self.writable or self.claimed:
            return
        self.claimed = True
        try:
            os.ftruncate(self.fd, 0)
            os.pwrite(self.fd, f"{os.getpid()}\n".encode(), 0)
        except OSError:  # (a full disk: the pid only names the holder, which /proc/locks names too; the
            pass  # run's own writes meet the full disk next, each as the typed error naming its file)

    def _unlocked(self, exc: OSError) -> None:
        self.done = True
        self.echo(
            f"warning: {self.path.parent}: cannot lock the output folder ({exc.strerror or exc}); "
            "make sure no other run writes there at the same time"
        )

    def release(self) -> None:
        if self.fd is not None:
            os.close(self.fd)  # closing the only descriptor of the open file drops its lock
            self.fd = None


_PROC_LOCKS = "/proc/locks"  # (Linux: the locks held, and by which process)


def _lock_holder(fd: int) -> int | None:
    """The pid of the process holding a ``flock`` on the file open at ``fd``, as Linux lists it in
    ``/proc/locks`` (``1: FLOCK  ADVISORY  WRITE 4117 fe:00:2148341 0 EOF``: pid, device, inode): the run
    that holds the lock, whether or not it has written its pid in the file yet (a run writes it once it
    writes in output.dir: while it plans, or all through a rerun with nothing to do, the file holds an
    ended run's, which a process may have again). The lock of the file's device and inode; where the list
    numbers the device otherwise (an overlayfs or a btrfs subvolume: the device of the filesystem below),
    the one lock of its inode. None where there is no such list (not Linux) or the lock is not in it (its
    holder has just let it go): the pid in the file is then shown, if a process has it."""
    try:
        st = os.fstat(fd)
        with open(_PROC_LOCKS, encoding="ascii", errors="replace") as f:
            lines = f.read().splitlines()
    except OSError:
        return None
    device = f"{os.major(st.st_dev):02x}:{os.minor(st.st_dev):02x}"
    same_inode: dict[str, int] = {}  # device -> pid of the flock held on a file of this inode number
    for line in lines:
        fields = line.split()  # (a waiter's line has "->" after the number: never the holder)
        if len(fields) < 6 or fields[1] != "FLOCK" or not fields[4].lstrip("-").isdigit():
            continue
        dev, _, ino = fields[5].rpartition(":")
        if ino == str(st.st_ino):
            same_inode[dev] = int(fields[4])
    if device in same_inode:
        return same_inode[device]
    return next(iter(same_inode.values())) if len(same_inode) == 1 else None


def _running(pid: int) -> bool:
    """Is there a process ``pid`` (another user's too)?"""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: someone else's
        return True
    return True
