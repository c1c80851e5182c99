"""Typed errors raised by swpm-usd. Every error names the file (when there is one) and what is wrong."""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path


def first_few(items: Sequence[str], count: int = 3) -> str:
    """The first ``count`` of ``items`` joined by commas, ``", ..."`` after them when there are more: how a
    message names what it is about without listing thousands."""
    return ", ".join(items[:count]) + (", ..." if len(items) > count else "")


def tf_message(e: BaseException) -> str:
    """The messages of a usd-core error (a ``Tf.ErrorException``, or its text in any exception), without
    the C++ function / file / line noise: what a message of this package quotes of usd-core."""
    chunks = re.split(r"\s*Error in '[^']*' at line \d+ in file \S+ : ", str(e))
    found = [" ".join(c.split()).strip("'") for c in chunks if c.strip()]
    return "; ".join(found) if found else (str(e).strip() or type(e).__name__)


class SwpmError(Exception):
    """Base class of every error swpm-usd raises on purpose. ``code`` is its stable code
    (:data:`swpm_usd.codes.CODES`: what a script groups failures by), set by each subclass or raise site;
    ``severity`` that code's."""

    code = "INTERNAL_ERROR"

    @property
    def severity(self) -> str:
        from .codes import CODES

        return CODES[self.code].severity


class MeshLoadError(SwpmError):
    """A mesh file could not be turned into a valid triangle mesh.

    ``path`` is the file, ``problem`` a short human-readable statement of what is wrong. ``code`` says which
    kind (:mod:`swpm_usd.codes`; ``INPUT_MALFORMED`` unless the raise site says otherwise), ``format`` the
    file's (by its suffix), ``line`` (from 1) and ``offset`` (a byte, from 0) where the problem names them.
    """

    code = "INPUT_MALFORMED"

    def __init__(
        self,
        path: str | Path | None,
        problem: str,
        *,
        code: str | None = None,
        line: int | None = None,
        offset: int | None = None,
    ) -> None:
        from .codes import format_of, located

        self.path = None if path is None else str(path)
        self.problem = problem
        if code is not None:
            self.code = code
        self.file, self.format = self.path, format_of(path)
        # (each loader says where in its message, "line 3", "byte offset 8", of a file that does not parse:
        # the other kinds name no place in the file, and may name a path, "a link loop (to /x/line 5/a.obj)")
        found = located(problem, path) if self.code == "INPUT_MALFORMED" else (None, None)
        self.line = line if line is not None else found[0]
        self.offset = offset if offset is not None else found[1]
        where = self.path if self.path is not None else "<mesh>"
        super().__init__(f"{where}: {problem}")


class BuildError(SwpmError):
    """An encoding could not be built from a mesh (bad parameters or an unsupported mesh). ``code``:
    ``PARAMETER_INVALID`` unless the raise site gives another (``MESH_INVALID``, ``BUILD_FAILED``)."""

    code = "PARAMETER_INVALID"

    def __init__(self, *args: object, code: str | None = None) -> None:
        super().__init__(*args)
        if code is not None:
            self.code = code


class OutputLockedError(SwpmError):
    """Another pipeline run holds the output folder ``path`` (its lock file); ``pid`` is that run's process
    id when it could be read."""

    code = "OUTPUT_LOCKED"

    def __init__(self, path: str | Path, pid: int | None = None) -> None:
        self.path = self.file = str(path)
        self.pid = pid
        who = f" (pid {pid})" if pid is not None else ""
        super().__init__(
            f"{self.path}: another swpm-pipeline run{who} is writing in this output folder; "
            "wait for it to end, or choose another output.dir"
        )


class MissingExtraError(SwpmError, ImportError):
    """An optional dependency the command needs is not installed: ``extra`` names the package's extra that
    installs it (``pip install 'swpm-usd[dask]'``). Not the config's fault, nor the input's: the same command
    runs once it is installed."""

    code = "EXTRA_MISSING"

    def __init__(self, what: str, extra: str, exc: ImportError | None = None) -> None:
        self.extra = extra
        missing = f" ({exc})" if exc is not None else ""
        super().__init__(
            f"{what} needs the {extra} extra, not installed{missing}: pip install 'swpm-usd[{extra}]'"
        )
