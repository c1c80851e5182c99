"""Stable codes of the problems swpm-usd reports about inputs, builds, outputs and runs.

A studio running thousands of assets groups failures by a code, not by parsing English: every error this
package raises on purpose (:class:`~swpm_usd.errors.SwpmError` and its subclasses) carries ``code``, one of
:data:`CODES`, beside its message, which keeps its words. ``build --json``, ``encode --json`` and
``run --json`` print it (with its ``severity``, and the ``line`` or byte ``offset`` where the loader knows
it) beside ``error``, and so do the pipeline's failure records (``manifest.json``, ``report.html``).

This module is the single source of truth: the second table of ``spec/errors.md`` is generated from
:data:`CODES` (``python -m swpm_usd.format.errors > spec/errors.md``) and a test fails when they differ.
Codes never change meaning; new ones may be added. A ``.swpm`` file's own problems have the ``SWPM_*`` codes
of :mod:`swpm_usd.format.errors` (``validate``); loading such a file raises ``INPUT_MALFORMED``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ERROR = "error"


@dataclass(frozen=True)
class Code:
    """One code: ``meaning`` in a line, ``raised`` by which errors (and where the CLI shows it)."""

    code: str
    severity: str
    meaning: str
    raised: str


_CODES = [
    Code(
        "INPUT_NOT_FOUND",
        ERROR,
        "A file given (a mesh, a pipeline config) does not exist: no file, a link to nothing or in a loop.",
        "MeshLoadError (exit 1), ConfigError of a missing config (exit 2), SwpmFormatError (load of a "
        "missing .swpm)",
    ),
    Code(
        "INPUT_UNREADABLE",
        ERROR,
        "The file exists but cannot be read: a folder or device, no permission, an I/O error.",
        "MeshLoadError, ConfigError, SwpmFormatError (load)",
    ),
    Code(
        "INPUT_UNSUPPORTED",
        ERROR,
        "A file of a type this package does not read (its suffix), or a glTF that requires an extension the "
        "loader does not read (extensionsRequired, a compression it cannot decode).",
        "MeshLoadError",
    ),
    Code(
        "INPUT_MALFORMED",
        ERROR,
        "The file does not read as its format says (`format`: obj, ply, stl, off, gltf, glb, usd, swpm): "
        "bad syntax, a value out of range, truncated; `line` or `offset` where the loader knows it.",
        "MeshLoadError, SwpmFormatError (its report: the SWPM codes), UsdReadError",
    ),
    Code(
        "INPUT_INCOMPLETE",
        ERROR,
        "A file the input needs is missing or does not read: a USD sublayer, reference or payload that "
        "does not resolve, a .gltf's buffer file missing or shorter than declared.",
        "MeshLoadError",
    ),
    Code(
        "INPUT_EMPTY",
        ERROR,
        "The input holds no triangle to build from: an empty file, no mesh, only points, lines or holes, "
        "every triangle degenerate.",
        "MeshLoadError",
    ),
    Code(
        "INPUT_TOO_LARGE",
        ERROR,
        "The input holds more triangles than its budget (--max-triangles, limits.max_triangles, "
        "max_triangles=), or more points than 32-bit indices address.",
        "MeshLoadError",
    ),
    Code(
        "MESH_INVALID",
        ERROR,
        "A Mesh made directly (not loaded, not Mesh.from_arrays) that the kernels cannot take: an index out "
        "of range, a NaN point, a triangle naming one vertex twice.",
        "BuildError",
    ),
    Code(
        "PARAMETER_INVALID",
        ERROR,
        "An encoding or a parameter the builder refuses: unknown, of the wrong type, out of its bounds, or a "
        "combination the encoder cannot build (order_passes with builder=forsyth); a USD prim_path that "
        "names no prim.",
        "BuildError, MeshLoadError (prim_path)",
    ),
    Code(
        "BUILD_FAILED",
        ERROR,
        "The encoder's own check failed on what it built (a sliding-window cluster that does not fit, "
        "buffers that do not agree, a .swpm that does not validate): a bug to report, with the input.",
        "BuildError; a run's asset",
    ),
    Code(
        "BUDGET_EXCEEDED",
        ERROR,
        "The build does not meet the pipeline config's budgets (global, instance or total bytes) or "
        "streaming limits (max_lods, min_coarsest_triangles, coarsest_lod_bytes).",
        "a run's asset",
    ),
    Code(
        "TIME_LIMIT_EXCEEDED",
        ERROR,
        "The asset was still building after limits.seconds: its worker was stopped.",
        "a run's asset",
    ),
    Code(
        "WORKER_LOST",
        ERROR,
        "The worker process building the asset died: killed by a signal (the out-of-memory killer's "
        "SIGKILL), a crash in native code, an exit.",
        "a run's asset",
    ),
    Code(
        "OUTPUT_UNWRITABLE",
        ERROR,
        "An output cannot be written: its folder cannot be made or written, a full disk, no permission; a "
        "layer open in this process that could not be reloaded once written.",
        "OSError of an output, LayerReloadError",
    ),
    Code(
        "OUTPUT_UNSUPPORTED",
        ERROR,
        "The progressive mesh cannot be stored as asked: an attribute or parameter the .swpm format or the "
        "USD schema has no place for, a source stage that cannot be encoded in place.",
        "SwpmEncodeError, UsdWriteError, ArrayTypeError, UsdOverrideError",
    ),
    Code(
        "OUTPUT_LOCKED",
        ERROR,
        "Another swpm-pipeline run holds the output folder (its lock file).",
        "OutputLockedError (run, exit 1)",
    ),
    Code(
        "CONFIG_INVALID",
        ERROR,
        "The pipeline config is not valid (YAML, the schema, the rules): every problem is listed as "
        "FILE:LINE:COL: $.path: message.",
        "ConfigError (run, exit 2)",
    ),
    Code(
        "USAGE_ERROR",
        ERROR,
        "The command line is wrong: an unknown option, a bad value, a missing argument.",
        "click's usage error (exit 2, `usage_error: true`)",
    ),
    Code(
        "INTERRUPTED",
        ERROR,
        "The command was stopped by Ctrl-C (SIGINT).",
        "KeyboardInterrupt (exit 130)",
    ),
    Code(
        "INTERNAL_ERROR",
        ERROR,
        "An exception this package does not raise on purpose: a bug to report; a run's record keeps its "
        "traceback.",
        "any other exception",
    ),
    Code(
        "INPUT_CHANGED",
        ERROR,
        "An input file (or a glTF buffer, a stage's layer it reads) changed while it was read: an exporter "
        "still writing it; in a run also a glTF or USD file changed since the plan hashed it (the files it "
        "names may be others), or one whose triangle count no longer fits the rule chosen for it. Not built; "
        "the asset's previous build is kept and the next run builds it.",
        "InputChangedError (a run's asset; encode, exit 1)",
    ),
    Code(
        "EXTRA_MISSING",
        ERROR,
        "An optional dependency the command needs is not installed: `run --executor dask` without the dask "
        "extra (`pip install 'swpm-usd[dask]'`); the same command runs once it is.",
        "MissingExtraError (run, exit 1)",
    ),
]
CODES: dict[str, Code] = {c.code: c for c in _CODES}

#: a format's name (a JSON error's ``format``) by file suffix
_FORMATS = {
    ".obj": "obj",
    ".ply": "ply",
    ".stl": "stl",
    ".off": "off",
    ".gltf": "gltf",
    ".glb": "glb",
    ".usd": "usd",
    ".usda": "usd",
    ".usdc": "usd",
    ".usdz": "usd",
    ".swpm": "swpm",
}
#: formats whose loaders' messages name a line of the file (a .glb's, of its JSON chunk, are not the file's)
_TEXT_FORMATS = ("obj", "ply", "stl", "off", "gltf")
#: formats whose loaders' messages name a byte offset of the file (usd-core's, and the .swpm reader's, do not)
_OFFSET_FORMATS = (*_TEXT_FORMATS, "glb")
#: where the loaders put a location: the problem's start, after ": ", "at " or "(" (not inside a path or a
#: name: "buffer 0: its file 'line 7.bin'", "@./byte offset 3.usda@", "(to /tmp/line 5/a.obj)")
_LINE = re.compile(r"(?:^|: |\bat |\()line (\d+)\b(?! of the chunk)")
_OFFSET = re.compile(r"(?:^|: |\bat |\()byte offset (\d+)\b")
#: what a message quotes (the file's content, a name, a path): a Python repr in '...' or "...", a USD
#: asset path in @...@; its words are not the loader's
_QUOTED = re.compile(r"""(?<!\w)'(?:[^'\\\n]|\\.)*'|(?<!\w)"(?:[^"\\\n]|\\.)*"|@[^@\n]*@""")


#: the keys of :func:`problem_fields` a run's failure record holds (``file`` aside: the asset names it)
PROBLEM_KEYS = ("code", "severity", "format", "line", "offset")


def format_of(path: str | Path | None) -> str | None:
    """The format a file's suffix names (``obj``, ``gltf``, ``usd``, ...), or None."""
    return None if path is None else _FORMATS.get(Path(path).suffix.lower())


def located(problem: str, path: str | Path | None) -> tuple[int | None, int | None]:
    """(line, byte offset) a loader's ``problem`` names, each None when it names none: the loaders say
    where as ``line N`` (from 1, in the text formats) and ``byte offset N`` (from 0), never inside what
    they quote."""
    own = _QUOTED.sub("''", problem)
    kind = format_of(path)
    line = _LINE.search(own) if kind in _TEXT_FORMATS else None
    offset = _OFFSET.search(own) if kind in _OFFSET_FORMATS else None
    return (int(line.group(1)) if line else None, int(offset.group(1)) if offset else None)


def problem_fields(exc: BaseException) -> dict[str, Any]:
    """The keys a JSON error or a run's failure record gives beside its ``error`` text: ``code`` and
    ``severity``, then ``file``, ``format``, ``line`` and ``offset`` where the error knows them."""
    from .errors import SwpmError

    # (another library's exception may have attributes of these names, a SyntaxError its offset: not ours)
    ours = isinstance(exc, SwpmError) and exc.code in CODES
    code = exc.code if ours else "INTERRUPTED" if isinstance(exc, KeyboardInterrupt) else "INTERNAL_ERROR"
    fields: dict[str, Any] = {"code": code, "severity": CODES[code].severity}
    for key in ("file", "format", "line", "offset") if ours else ():
        value = getattr(exc, key, None)
        if value is not None:
            fields[key] = value
    return fields


def fields_of(code: str, **where: Any) -> dict[str, Any]:
    """:func:`problem_fields` of a problem that is no exception (a run's budget check, a worker lost)."""
    return {
        "code": code,
        "severity": CODES[code].severity,
        **{k: v for k, v in where.items() if v is not None},
    }


def render_markdown() -> str:
    """The section of ``spec/errors.md`` listing :data:`CODES` (generated; do not edit by hand)."""
    lines = [
        "## Input, build, output and run problems",
        "",
        "<!-- Generated from swpm_usd/codes.py; do not edit -->",
        "",
        "Every error swpm-usd raises on purpose carries one of these codes (`code`, an attribute of the",
        "exception) beside its message. `build --json`, `encode --json` and `run --json` print it with its",
        "`severity` beside `error`, with the file it concerns (`file`), its `format` and the `line` (from",
        "1) or byte `offset` (from 0) where the loader knows them; a run's failure records (`manifest.json`,",
        "`report.html`, `run --json`'s `failures`) hold them too, `file` aside. A `.swpm` file's own",
        "problems have the SWPM codes above (`validate`).",
        "",
        "| Code | Severity | Meaning | Raised by |",
        "|---|---|---|---|",
    ]
    for c in _CODES:
        lines.append(f"| `{c.code}` | {c.severity} | {c.meaning} | {c.raised} |")
    return "\n".join(lines) + "\n"
