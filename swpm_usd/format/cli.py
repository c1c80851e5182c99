"""``swpm-pipeline`` commands of the binary format: ``encode``, ``inspect``, ``validate``, ``conformance``.

They are plain :class:`click.Command` objects; ``swpm_usd/cli.py`` adds them to its group. Exit codes:
0 ok, 1 invalid input (a mesh or .swpm file that cannot be used), 2 usage error (click's own).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import re
import sys
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from ..errors import SwpmError

if TYPE_CHECKING:
    from .errors import Report
    from .ranges import FileRanges


def _parse_params(params: tuple[str, ...]) -> dict:
    parsed = {}
    given: dict[str, str] = {}
    for item in params:
        if "=" not in item or not item.split("=", 1)[0].strip():  # (``=5``: " not a parameter of vanilla")
            raise click.UsageError(f"--param expects NAME=VALUE, got {item!r}")
        name, value = item.split("=", 1)
        if name in given:  # (the last one was taken, silently: which did the user mean?)
            raise click.BadParameter(
                f"{name} given twice ({given[name]!r}, then {value!r}); give it once", param_hint="--param"
            )
        given[name] = value
        try:
            parsed[name] = json.loads(value)
        except json.JSONDecodeError:
            parsed[name] = value
    return parsed


def _encoding_and_params(encoding: str, params: tuple[str, ...]) -> dict:
    """``--encoding`` and ``--param`` checked alike for every command (usage errors, exit 2): a known
    encoding, NAME=VALUE items, names its builder takes, and values by the check a pipeline config's
    ``params`` get, in its words (:func:`..pipeline.schema.param_problem`: the type and bounds its schema
    gives each, a number finite, an integer no float), then :func:`..build.check_params`. Checked before the
    mesh is read: ``-p mu=2`` read the mesh and built its collapse sequence (minutes on a large mesh) before
    the encoder refused it, exit 1. So is a combination the encoder refuses, ``order_passes=2`` with
    ``builder=forsyth`` (:func:`..encodings.combination_problem`; it failed at the build, exit 1). Returns the
    parsed parameters."""
    from ..encodings import ENCODING_PARAMS, combination_problem

    if encoding not in ENCODING_PARAMS:
        from ..param_hints import did_you_mean

        meant = did_you_mean(encoding, list(ENCODING_PARAMS))  # (`-e slidingwindow`)
        meant = f" ({meant})" if meant else ""
        raise click.BadParameter(
            f"{encoding!r}; choose one of {', '.join(sorted(ENCODING_PARAMS))}{meant}",
            param_hint="--encoding",
        )
    parsed = _parse_params(params)
    unknown = sorted(set(parsed) - set(ENCODING_PARAMS[encoding]))
    if unknown:
        from ..param_hints import unknown_param_hint

        # (``-p mu=0.2`` without ``-e sliding-window`` said vanilla takes boundary_weight and seam_weight
        # alone, and no more: name the encoding that takes it, or the name meant)
        hints = "; ".join(f"{n}: {hint}" for n in unknown if (hint := unknown_param_hint(encoding, n)))
        raise click.BadParameter(
            f"{', '.join(unknown)} not a parameter of {encoding}{f' ({hints})' if hints else ''}; "
            f"it takes {', '.join(sorted(ENCODING_PARAMS[encoding]))}",
            param_hint="--param",
        )
    from ..build import check_params
    from ..pipeline.schema import param_problem

    for name, value in parsed.items():
        problem = param_problem(encoding, name, value)
        if problem:
            if isinstance(value, str) and "is not of type" in problem:
                # (the README writes Python's cluster=True; -p reads JSON: 'True' and '.2' stayed text)
                problem += f" (-p reads its value as JSON: {_as_json_value(name, value)})"
            raise click.BadParameter(f"{name}: {problem}", param_hint="--param")
    try:
        check_params(encoding, ENCODING_PARAMS[encoding], parsed)
    except SwpmError as exc:
        raise click.BadParameter(str(exc), param_hint="--param") from None
    problem = combination_problem(encoding, parsed)
    if problem:
        raise click.BadParameter(problem, param_hint="--param")
    return parsed


def _as_json_value(name: str, value: str) -> str:
    """How to write ``value``, text that did not read as JSON, so that it does: ``cluster=true`` for
    Python's ``True``, ``mu=0.2`` for ``.2``; else what JSON's values look like."""
    spelled = {"true": "true", "false": "false", "none": "null", "null": "null"}.get(value.strip().lower())
    if spelled is None:
        try:
            number = float(value)
        except ValueError:
            number = None
        if number is not None and math.isfinite(number):
            spelled = json.dumps(int(number) if number.is_integer() and "." not in value else number)
    if spelled is None:
        return "true, false, null, a number (0.2) or text"
    return f"write {name}={spelled}"


#: ``click.Context.meta`` key: what a command given ``--json`` prints, with ``"error"``, when it is stopped by
#: Ctrl-C (:func:`json_on_interrupt`; printed by the command group, ``swpm_usd.cli``)
_JSON_ON_INTERRUPT = "swpm_usd.json_on_interrupt"


def json_on_interrupt(as_json: bool, **fields: object) -> None:
    """A command with ``--json``: stopped by Ctrl-C, it prints ``{**fields, "error": "interrupted"}`` on
    stdout (as it prints its other errors), so a script reading its output gets JSON however it ends."""
    if as_json:
        click.get_current_context().meta[_JSON_ON_INTERRUPT] = fields


#: one line per encoding for ``--help`` (an encoding of ``ENCODING_PARAMS`` without one is listed bare)
_ENCODING_SUMMARY = {
    "vanilla": "each instance edits its own index buffer (collapse records)",
    "skip-strip": "multilevel skip strips or lists, cache-ordered per level",
    "mixed": "per level a shared static and a per-instance dynamic list",
    "sliding-window": "one static index pool; a LOD change is a table look-up",
}


def pm_summary(pm) -> dict:
    """The keys ``build --json`` and ``encode --json`` share: what was built."""
    return {
        "encoding": pm.encoding,
        "params": pm.params,
        "lod_count": pm.lod_count,
        "vertices": pm.vertex_count,
        "global_bytes": pm.global_bytes,
        "instance_bytes": pm.instance_bytes,
    }


def _param_value(value: object) -> str:
    """A default as it is given to ``-p``: strings bare, the rest as JSON (true, null, 0.25)."""
    return value if isinstance(value, str) else json.dumps(value)


def encodings_help(parameters: bool = True) -> str:
    """The encodings of :data:`swpm_usd.encodings.ENCODING_PARAMS` as help text: each one's name and summary,
    then the parameters every encoding takes (with the same default) and, with ``parameters``, each
    encoding's own, with their defaults, and what each does (:data:`..encodings.PARAM_HELP`). Paragraphs
    start with click's ``\\b``, so the columns are kept."""
    from ..encodings import ENCODING_PARAMS, PARAM_HELP

    defaults = list(ENCODING_PARAMS.values())
    shared = {k: v for k, v in defaults[0].items() if all(k in d and d[k] == v for d in defaults)}
    width = max(len(name) for name in ENCODING_PARAMS) + 2

    def assignments(values: dict) -> str:
        return " ".join(f"{k}={_param_value(v)}" for k, v in values.items())

    lines = ["\b", "Encodings (--encoding):"]
    for name, params in ENCODING_PARAMS.items():
        lines.append(f"  {name:<{width}}{_ENCODING_SUMMARY.get(name, '')}".rstrip())
        own = {k: v for k, v in params.items() if k not in shared}
        if parameters and own:
            lines += [f"  {'':<{width}}{line}" for line in textwrap.wrap(assignments(own), 76 - width)]
    if shared:
        lines += ["", "\b", "Parameters of every encoding (-p NAME=VALUE, defaults shown):"]
        lines += [f"  {line}" for line in textwrap.wrap(assignments(shared), 74)]
    if parameters and any(v is None for d in defaults for v in d.values()):
        lines += ["", "A default of null: the encoder picks the value from the other parameters."]
    if parameters:  # (names and defaults alone taught no one what mu or cluster does)
        named = [k for k in dict.fromkeys(k for d in defaults for k in d) if k in PARAM_HELP]
        pad = max((len(k) for k in named), default=0) + 2
        lines += ["", "\b", "What each parameter does:"]
        lines += [f"  {k:<{pad}}{PARAM_HELP[k]}" for k in named]
    return "\n".join(lines)


#: a command's ``--json`` error object on a usage error: its parameters (parsed before the error) that name
#: what it was given, under the keys its other errors use (``build``: ``input``; ``encode``: ``input`` and
#: ``output``; ``run``: ``input``, its config)
_JSON_USAGE_FIELDS = {"input_path": "input", "config": "input", "output": "output"}


def _wants_json(command: click.Command, args: list[str]) -> bool:
    """Whether ``--json`` is among ``command``'s options in ``args``, as its parser reads them: not after a
    ``--`` (all is arguments there), nor as the value of an option that takes one (``-o --json`` names the
    output ``--json``, as click reads it)."""
    takes: dict[str, int] = {}  # (an option's name -> how many values follow it)
    for param in command.params:
        if isinstance(param, click.Option) and not param.is_flag and not param.count:
            takes.update(dict.fromkeys(param.opts + param.secondary_opts, param.nargs))
    i = 0
    while i < len(args):
        arg = args[i]
        if arg == "--":
            return False
        if arg == "--json":
            return True
        i += 1 + takes.get(arg, 0)  # (``--output=x`` and ``-ox``, the value attached, are one word)
    return False


def _echo_json_usage(exc: click.UsageError, params: dict) -> None:
    """Print a usage error as the command's JSON error object on stdout (click prints its usage and the
    message on stderr, and exits 2, as it does without ``--json``)."""
    from ..codes import fields_of

    fields = {key: params[name] for name, key in _JSON_USAGE_FIELDS.items() if params.get(name) is not None}
    error = {"error": exc.format_message(), "usage_error": True, **fields_of("USAGE_ERROR")}
    click.echo(json.dumps({**fields, **error}, indent=2))


class JsonUsageCommand(click.Command):
    """A command with ``--json``: a usage error (a bad option or argument, ``click.UsageError`` or
    ``click.BadParameter``, raised as its arguments are parsed or by its body) given ``--json`` also prints
    ``{..., "error": message, "usage_error": true}`` on stdout, the shape of its other JSON errors, so a
    script reading its output gets JSON however it ends; still exit 2, click's text on stderr."""

    def make_context(
        self, info_name: str | None, args: list[str], parent: click.Context | None = None, **extra: object
    ) -> click.Context:
        wants_json = _wants_json(self, args)  # (before the parser, which consumes the list)
        given = list(args)
        try:
            return super().make_context(info_name, args, parent=parent, **extra)
        except click.UsageError as exc:
            if wants_json:
                params = exc.ctx.params if exc.ctx is not None else {}
                _echo_json_usage(exc, {**self._given(info_name, given, parent), **params})
            raise

    def _given(self, info_name: str | None, args: list[str], parent: click.Context | None) -> dict:
        """The values ``args`` gives the command's parameters, as written (before their types check them):
        a usage error in one (``--rows 0``, an input that is a folder) still names the input and output
        given, as the README says (click parses into its context only the values it took before the
        error). Empty when the arguments do not parse."""
        try:
            ctx = click.Context(self, info_name=info_name, parent=parent)
            values, _, _ = self.make_parser(ctx).parse_args(args=args)
        except click.UsageError:
            return {}
        return {name: value for name, value in values.items() if isinstance(value, str)}

    def invoke(self, ctx: click.Context) -> object:
        try:
            return super().invoke(ctx)
        except click.UsageError as exc:
            if ctx.params.get("as_json"):
                _echo_json_usage(exc, ctx.params)
            raise


class EncodingsHelpCommand(JsonUsageCommand):
    """A command whose ``--help`` ends with the encodings and their parameters (:func:`encodings_help`),
    read from the registry when the help is shown (so ``--version`` and the commands import nothing more)."""

    def format_epilog(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        super().format_epilog(ctx, formatter)
        formatter.write_paragraph()
        with formatter.indentation():
            formatter.write_text(encodings_help(parameters=True))


class EncodingsHelpGroup(click.Group):
    """The command group: its ``--help`` ends with the encodings and the parameters every encoding takes."""

    def format_epilog(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        super().format_epilog(ctx, formatter)
        formatter.write_paragraph()
        with formatter.indentation():
            formatter.write_text(
                encodings_help(parameters=False)
                + "\n\nEach encoding's own parameters: swpm-pipeline encode --help. In a pipeline config,"
                + " encoding: auto picks one of them per asset."
            )


def _output_folder_problem(output: Path) -> str | None:
    """Why ``output`` cannot be written in its folder, or None: checked before the build, which it followed
    (minutes on a large mesh, then ``cannot write x.obj/y.swpm: File exists``). A folder missing is made (the
    nearest one that exists must be a writable folder; a link on the way that leads nowhere is refused: the
    folder's making failed on it after the build, ``File exists``)."""
    import os

    from ..fileio import link_loop

    loop = link_loop(output.parent)
    if loop is not None:  # (it was called a dangling link: a user looked for a folder that was never missing)
        return f"cannot write {output}: {loop[0]} is a link loop (to {loop[1]})"
    folder = output.parent
    while not folder.exists() and folder != folder.parent:
        if folder.is_symlink():  # (exists() follows the link: it leads nowhere)
            return f"cannot write {output}: {folder} is a dangling link (to {os.readlink(folder)})"
        folder = folder.parent
    if not folder.is_dir():
        return f"cannot write {output}: {folder} is not a folder"
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"cannot write {output}: the folder {folder} is not writable"
    return None


class FilePath(click.Path):
    """A file argument (``click.Path(dir_okay=False)``) that is not empty: ``""`` (a shell variable unset,
    ``"$MESH"``) was taken as the current folder, each command saying it its own way (``.: unsupported file
    type``, ``: cannot read file``, ``.:1:1: $: cannot read the file ([Errno 21] Is a directory: '.')``). A
    usage error (exit 2), said alike by every command."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__(dir_okay=False, **kwargs)  # type: ignore[arg-type]

    def convert(self, value: object, param: click.Parameter | None, ctx: click.Context | None) -> object:
        if isinstance(value, str) and value == "":
            self.fail("the path is empty (an unset shell variable?)", param, ctx)
        return super().convert(value, param, ctx)


#: ``--max-triangles N`` of the commands that load a mesh (:func:`swpm_usd.io.load_mesh`'s ``max_triangles``)
max_triangles_option = click.option(
    "--max-triangles",
    "max_triangles",
    type=click.IntRange(min=0),
    default=None,
    metavar="N",
    help="Refuse (exit 1) an input of more than N triangles, checked before it is read where its format "
    "tells the count (glTF instances, USD faceVertexCounts, binary STL header, OBJ face lines).",
)


@contextlib.contextmanager
def ctrl_c_through_compiled_code() -> Iterator[None]:
    """Ctrl-C in the block raises KeyboardInterrupt, also where compiled code turned it into another error
    (numba: ``SystemError: CPUDispatcher(...) returned a result with an exception set``, a traceback and exit
    1 from a build stopped in a kernel). Only where Ctrl-C raises KeyboardInterrupt (Python's own handler,
    the main thread): a caller's own handler is kept."""
    import signal
    import threading

    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    ):
        yield
        return
    noted: list[int] = []

    def note(signum: int, frame: object) -> None:
        noted.append(signum)
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGINT, note)
    try:
        yield
    except Exception as exc:
        if noted:
            raise KeyboardInterrupt from exc
        raise
    finally:
        signal.signal(signal.SIGINT, old)


class _OutputError(OSError):
    """An OSError of ``encode``'s output (its folder, its write): ``OUTPUT_UNWRITABLE``."""


def _input_error(exc: OSError, input_path: str) -> SwpmError:
    """``exc``, raised reading ``input_path`` (or a file it names), as the MeshLoadError naming it."""
    import errno

    from ..errors import MeshLoadError
    from ..fileio import missing_file_problem

    path = input_path if exc.filename is None else exc.filename
    if exc.errno == errno.ENOENT:  # (in the loader's words for the same code: "file not found", or a loop)
        return MeshLoadError(path, missing_file_problem(path), code="INPUT_NOT_FOUND")
    return MeshLoadError(path, f"cannot read the file ({exc.strerror or exc})", code="INPUT_UNREADABLE")


def mesh_input(input_path: str, max_triangles: int | None) -> object:
    """What a command builds from ``input_path``: the path itself (loaded by ``build``), or the mesh loaded
    under the budget ``max_triangles``."""
    if max_triangles is None:
        return input_path
    from ..io import load_mesh

    return load_mesh(input_path, max_triangles=max_triangles)


def _loaded_and_digest(input_path: str, max_triangles: int | None) -> tuple[object, str | None]:
    """``encode``'s input, loaded, and the digest (``sha256:...``) of the bytes it was loaded from (None for
    a path that is no regular file: its load says why). It was hashed by a second read after the build: a
    file replaced meanwhile got the new file's digest, on an output built from the old one. An OBJ is read
    once, its bytes hashed and parsed (:func:`..io.load_mesh`'s ``data``: its checks as for a path). The other
    loaders read by path (usd-core, trimesh's binary readers, a glTF's buffers beside it), so the file is
    hashed once loaded, through one descriptor, and refused (``INPUT_CHANGED``) unless that is the file
    the load began on, unchanged since (its size, mtime, ctime and inode: a ctime cannot be set back)."""
    import os

    from ..io import load_mesh

    path = Path(input_path)
    if not path.is_file():
        return mesh_input(input_path, max_triangles), None
    if path.suffix.lower() == ".obj":
        with open(path, "rb") as f:
            data = f.read()
        if data:  # (an empty one: its load says so)
            mesh = load_mesh(path, max_triangles=max_triangles, data=data)
            return mesh, "sha256:" + hashlib.sha256(data).hexdigest()
    from ..pipeline.worker import InputChangedError, stat_fields, update_with_stat

    before = os.stat(path)
    mesh = load_mesh(path, max_triangles=max_triangles)
    h = hashlib.sha256()
    read = update_with_stat(h, path)
    if read is None or (before.st_size, stat_fields(before)) != (read.st_size, stat_fields(read)):
        raise InputChangedError(f"{input_path}: changed while it was read: not built from it", input_path)
    return mesh, "sha256:" + h.hexdigest()


@click.command("encode", cls=EncodingsHelpCommand)
@click.argument("input_path", metavar="INPUT", type=FilePath())
@click.option(
    "-o",
    "--output",
    "output",
    required=True,
    type=FilePath(),
    help="The .swpm file to write (atomically; a missing folder is made); never the input. A link there "
    "is replaced by the file, its target left as it was, as run replaces its outputs (and sed -i a file).",
)
@click.option(
    "--encoding",
    "-e",
    default="vanilla",
    show_default=True,
    help="Encoding to build (listed below).",
)
@click.option(
    "--param",
    "-p",
    "params",
    multiple=True,
    metavar="NAME=VALUE",
    help="Encoding parameter (repeatable, listed below), value parsed as JSON when it can be.",
)
@max_triangles_option
@click.option(
    "--legacy-layout",
    is_flag=True,
    help="Write a file a reader before 0.9.0 accepts: one integer width for every array, never the "
    "OFFSET32 feature bit (tables u32 beside u16 index lists), which such a reader refuses "
    "(SWPM_HEADER_UNKNOWN_FEATURE). Use it when the runtime that loads the file holds an older reader. "
    "The cost: a file whose tables need u32 (a sliding-window pool longer than 65,535 indices) is u32 "
    "throughout, INDEX32, its index lists too (bunny's sliding window: 5.71 MB, not 3.48 MB). "
    "The printed line names the widths written (index u32, tables u32, legacy layout); --json gives "
    "index_width and offset_width.",
)
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def encode_cmd(
    input_path: str,
    output: str,
    encoding: str,
    params: tuple[str, ...],
    max_triangles: int | None,
    legacy_layout: bool,
    as_json: bool,
) -> None:
    """Build INPUT with an encoding and write it as an SWPM v1 file.

    \b
    Examples:
      swpm-pipeline encode samples/spot.obj -o spot.swpm --json
      swpm-pipeline encode spot.obj -o spot.swpm -e skip-strip -p primitive=list
      swpm-pipeline encode cow.obj -o cow.swpm -e sliding-window --legacy-layout
    """
    from ..build import build
    from ..slow_notice import notice_if_slow
    from .layout import HEADER_SIZE, header_widths
    from .writer import save

    parsed = _encoding_and_params(encoding, params)
    if Path(output).exists() and Path(input_path).exists() and Path(output).samefile(input_path):
        raise click.BadParameter(f"{output} is the input: it would be overwritten", param_hint="--output")
    if Path(output).suffix.lower() != ".swpm":
        raise click.BadParameter(
            f"{output}: the output must be a .swpm file (a USD layer: swpm_usd.usd.write, or a pipeline "
            "config's output.usd: true)",
            param_hint="--output",
        )
    json_on_interrupt(as_json, input=input_path, output=output)
    start = time.perf_counter()
    try:
        problem = _output_folder_problem(Path(output))
        if problem:  # (before the build: exit 1, as the write that would fail after it)
            raise _OutputError(problem)
        try:
            # (a cold numba cache: the first build compiles for a minute or more, silent until then)
            with ctrl_c_through_compiled_code(), notice_if_slow():
                mesh, digest = _loaded_and_digest(input_path, max_triangles)
                pm = build(mesh, encoding, **parsed)
            seconds = time.perf_counter() - start
        except OSError as exc:
            # the input's (read raw for its digest: gone or unreadable since its stat), never the output's:
            # it was labelled OUTPUT_UNWRITABLE
            raise _input_error(exc, input_path) from exc
        try:
            save(pm, output, source_digest=digest, legacy_layout=legacy_layout)
            size = Path(output).stat().st_size
            with open(output, "rb") as f:  # (the widths the file's header declares, as a reader takes them)
                index_width, offset_width = header_widths(f.read(HEADER_SIZE))
        except OSError as exc:
            raise _OutputError(f"cannot write {output}: {exc.strerror or exc}") from exc
    except (SwpmError, OSError, ValueError) as exc:
        from ..codes import fields_of, problem_fields

        click.echo(f"error: {exc}", err=True)
        if as_json:
            # (the output's OSErrors are _OutputErrors; the input's are MeshLoadErrors)
            fields = fields_of("OUTPUT_UNWRITABLE", file=output) if isinstance(exc, _OutputError) else None
            fields = fields or problem_fields(exc)
            error = {"input": input_path, "output": output, "error": str(exc), **fields}
            click.echo(json.dumps(error, indent=2))
        sys.exit(1)
    if as_json:
        out = {
            "input": input_path,
            "output": output,
            **pm_summary(pm),
            "triangles": pm.triangle_count_at(0),
            "coarsest_triangles": pm.triangle_count_at(pm.lod_count - 1),
            "bytes": size,
            "index_width": index_width,
            "offset_width": offset_width,
            "legacy_layout": legacy_layout,
            "source_digest": digest,
            "build_seconds": seconds,
        }
        click.echo(json.dumps(out, indent=2, default=float))
        return
    # (the widths as inspect's first line says them; "legacy layout" when asked for: no OFFSET32)
    layout = f"index u{8 * index_width}, tables u{8 * offset_width}" + (
        ", legacy layout" if legacy_layout else ""
    )
    click.echo(
        f"{output}: {pm.encoding}, {pm.lod_count} LODs, {pm.vertex_count} vertices, {size} bytes, {layout}"
    )


def _mesh_hint(file: str, problems: list) -> None:
    """A mesh file given to ``inspect`` or ``validate`` as an SWPM file (its magic wrong, its name a mesh
    type's), or a USD stage under another name (its first bytes a crate's or a text layer's): one line on
    stderr saying what to run instead (the report alone, ``magic is 7620302e33343837``, left a user to find
    out why a mesh is an invalid file)."""
    from ..io import SUPPORTED_SUFFIXES

    suffix = Path(file).suffix.lower()
    # (a mesh file under 64 bytes is "header truncated", not "bad magic": it got no hint)
    not_swpm = ("SWPM_HEADER_BAD_MAGIC", "SWPM_HEADER_TRUNCATED")
    if suffix in SUPPORTED_SUFFIXES and any(q.code in not_swpm for q in problems):
        # (inspect reads .swpm files only; a stage this package wrote is checked by validate)
        swpm_name = Path(file).with_suffix(".swpm").name
        if suffix.startswith(".usd"):
            # validate first: a stage given to inspect is most often a run's layer, already encoded (encode
            # alone, first, rebuilt its LOD 0 as if it were a plain mesh)
            click.echo(
                f"hint: {file} is a USD stage ({suffix}), not an SWPM file: swpm-pipeline validate {file} "
                "checks a stage's SwpmMeshAPI prims (swpm_usd.load reads one, swpm_usd.save writes it as "
                f"an .swpm file); a stage of plain meshes: swpm-pipeline encode {file} -o {swpm_name} builds "
                f"one, swpm-pipeline build {file} shows its LODs",
                err=True,
            )
            return
        click.echo(
            f"hint: {file} is a mesh file ({suffix}), not an SWPM file: swpm-pipeline encode {file} -o "
            f"{swpm_name} writes one, swpm-pipeline build {file} shows its LODs",
            err=True,
        )
    elif any(q.code in not_swpm for q in problems):
        # (a stage under another name, a .usdc renamed .swpm: its magic alone said nothing)
        kind = _usd_kind(file)
        if kind:
            usd_name = Path(file).with_suffix(kind).name
            click.echo(
                f"hint: {file} is a USD stage ({kind[1:]}), not an SWPM file: under a {kind} name (as "
                f"{usd_name}) swpm-pipeline validate checks its SwpmMeshAPI prims and swpm_usd.load reads it",
                err=True,
            )


def _usd_kind(file: str) -> str | None:
    """``".usdc"`` for a USD crate file, ``".usda"`` for a text layer, by their first bytes; else None."""
    try:
        with open(file, "rb") as f:
            head = f.read(8)
    except OSError:
        return None
    return ".usdc" if head == b"PXR-USDC" else ".usda" if head.startswith(b"#usda ") else None


@click.command("inspect", cls=JsonUsageCommand, short_help="Show an .swpm file's header, chunks and LODs.")
@click.argument("file", type=FilePath())
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@click.option(
    "--rows",
    type=click.IntRange(min=1),
    default=10,
    show_default=True,
    help="LOD rows to show (spread evenly, the first and the last always).",
)
def inspect_cmd(file: str, as_json: bool, rows: int) -> None:
    """Show FILE's (an .swpm file's) header, chunks, counts, parameters and a per-LOD table, and the
    problems validate finds. Exit 0 valid, 1 invalid or unreadable.

    The first line names the integer widths: index, the lists an engine uploads (u16 below 65,536
    vertices); tables, the offsets and records (u32 beside u16 index lists is the OFFSET32 bit, which a
    reader before 0.9.0 refuses: encode --legacy-layout writes one it reads). --json: index_width and
    offset_width, in bytes."""
    from .reader import _check, _map

    try:
        buf = _map(file)
    except OSError as exc:
        click.echo(f"error: {file}: cannot read file: {exc.strerror or exc}", err=True)
        if as_json:  # the report validate gives: one SWPM_IO_ERROR
            from .reader import validate

            rep = validate(file)
            out = {
                "path": file,
                "valid": False,
                **rep.summary,
                "problems": [q.to_dict() for q in rep.problems],
            }
            click.echo(json.dumps({**out, "lods": []}, indent=2, default=str))
        sys.exit(1)
    rep, p = _check(buf, file)
    out = {"path": file, "valid": rep.valid, **rep.summary, "problems": [q.to_dict() for q in rep.problems]}
    if p is not None and p.meta is not None:
        out["meta"] = p.meta
    table = []
    if p is not None and p.lods is not None:
        n = p.lods.shape[0]
        picks = sorted({int(round(x)) for x in [i * (n - 1) / max(rows - 1, 1) for i in range(max(rows, 2))]})
        for k in picks:
            r = p.lods[k]
            table.append(
                {
                    "lod": k,
                    "vertices": int(r["vertex_count"]),
                    "triangles": int(r["triangle_count"]),
                    "error": float(r["error"]),
                }
            )
    out["lods"] = table
    _mesh_hint(file, rep.problems)
    if as_json:
        click.echo(json.dumps(out, indent=2, default=str))
    else:
        # what the header gave, and nothing of what it did not (it read "INVALID SWPM ? ?, index u?")
        head = " ".join(
            [f"{file}: {'valid' if rep.valid else 'INVALID'} SWPM"]
            + [str(out[k]) for k in ("version", "encoding") if out.get(k) is not None]
        )
        width = f", index u{8 * out['index_width']}" if "index_width" in out else ""
        values_w = out.get("index_values_width", out.get("index_width"))
        if values_w is not None and values_w < out.get("index_width", values_w):
            # (the file's idx widened by offsets or counts, a writer before 0.9.0, or by choice: what an
            # engine can upload its index lists as)
            width += f" (index values fit u{8 * values_w})"
        elif values_w is not None and values_w > out.get("index_width", values_w):
            # (an older writer's u16 file of 65,536 vertices: vertex 65,535 is u16's restart index, spec 1)
            width += f" (vertex ids reach 0xFFFF: drawn as u{8 * values_w})"
        if "offset_width" in out:  # off, the tables' type: u32 with INDEX32 or OFFSET32 (spec 1)
            width += f", tables u{8 * out['offset_width']}"
        click.echo(head + width)
        for key in (
            "file_size",
            "lod_count",
            "vertex_count",
            "triangle_count",
            "index_count",
            "lambda",
            "attributes",
        ):
            if key in out:
                click.echo(f"  {key}: {out[key]}")
        if "meta" in out:
            click.echo(f"  params: {json.dumps(out['meta'].get('params', {}), sort_keys=True)}")
        for c in out.get("chunks", []):
            click.echo(
                f"  chunk {c['type']} {'critical ' if c['critical'] else 'ancillary'} "
                f"@{c['offset']:>10} {c['length']:>10} B"
            )
        if table:
            click.echo(f"  {'LOD':>7} {'vertices':>9} {'triangles':>10} {'error':>11}")
            for r in table:
                click.echo(f"  {r['lod']:>7} {r['vertices']:>9} {r['triangles']:>10} {r['error']:>11.4g}")
        for q in rep.problems:
            click.echo(f"  {q.severity} {q.code} @{q.offset}: {q.message}")
    sys.exit(0 if rep.valid else 1)


@click.command("validate", cls=JsonUsageCommand)
@click.argument("file", type=FilePath())
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@click.option("--no-builtin", is_flag=True, help="USD stages: run only our validator, not usd-core's.")
@click.option(
    "--prefix",
    type=click.IntRange(min=0),
    default=None,
    help="Check only the first N bytes, as a streaming reader that has received them (spec/format.md 4.1); "
    "an N past the end checks the whole file, with a note on stderr (--json: "
    "summary.prefix.requested_bytes).",
)
@click.option(
    "--ranges",
    "ranges_spec",
    metavar="OFF:LEN,...",
    default=None,
    help="Check only these byte ranges of the file (byte offset:length, comma-separated, e.g. "
    "0:4096,81920:2048), as a reader that fetched them does (spec/format.md 4.2): the LODs they draw, or "
    "SWPM_RANGES_NOT_HELD with the range to fetch next.",
)
@click.option(
    "--lod",
    type=click.IntRange(min=0),
    default=None,
    help="Fetch what LOD K needs as a range reader does (the header, SMAP's ranges for K's band, then what "
    "the reader asks for; spec/format.md 4.2) and check those ranges: the reads made, the LODs they draw.",
)
@click.pass_context
def validate_cmd(
    ctx: click.Context,
    file: str,
    as_json: bool,
    no_builtin: bool,
    prefix: int | None,
    ranges_spec: str | None,
    lod: int | None,
) -> None:
    """Check FILE and list every problem. Exit 0 valid, 1 invalid.

    A .swpm file is checked against the SWPM v1 spec (spec/format.md); a USD stage (.usd .usda .usdc
    .usdz) with the SwpmMeshAPI validators plus usd-core's built-in ones (spec/usd.md). --prefix N checks
    the file's first N bytes as a prefix reader does (spec/format.md 4.1: what they hold now, the LODs they
    draw; SWPM_PREFIX_TOO_SHORT gives the bytes to wait for): the report's summary gains "prefix" (bytes,
    file_size, finest_drawable, drawable_lods, needed_bytes of LOD 0 and the coarsest). --ranges OFF:LEN,...
    checks those byte ranges as a range reader does (spec 4.2: a band of SMAP, HTTP range requests;
    SWPM_RANGES_NOT_HELD gives the range to fetch next, in the summary's range_need [start, end)); --lod K
    fetches what LOD K needs first, as swpm_usd.format.read_lod does. Their summary gains "ranges" (held,
    held_bytes, file_size, complete, drawable_lods, finest_drawable, needed_ranges of LOD 0 and the
    coarsest; with --lod, lod and the reads made). Give one of --prefix, --ranges, --lod.
    """
    from ..usd import USD_SUFFIXES

    options = (("prefix", prefix), ("ranges", ranges_spec), ("lod", lod))
    given = [f"--{n}" for n, v in options if v is not None]
    if len(given) > 1:
        raise click.UsageError(f"give one of --prefix, --ranges, --lod, not {' and '.join(given)}")
    if given and Path(file).suffix.lower() in USD_SUFFIXES:
        raise click.BadParameter("reads an SWPM file's bytes, not a USD stage's", param_hint=given[0])
    if prefix is not None:
        _validate_prefix(file, prefix, as_json)
    if ranges_spec is not None:
        _validate_ranges(file, _parse_ranges(ranges_spec), as_json)
    if lod is not None:
        _validate_lod(file, lod, as_json)
    if Path(file).suffix.lower() in USD_SUFFIXES:
        from ..usd.cli import validate_usd

        if not Path(file).is_file():
            # a FIFO or a device is never opened (a FIFO's open waits for a writer); validate_stage says
            # so at once, in one SWPM_USD_OPEN naming its kind
            from ..fileio import missing_file_problem

            problem = "not a regular file" if Path(file).exists() else missing_file_problem(file)
            click.echo(f"error: {file}: {problem}", err=True)
            if as_json:
                from ..usd.validate import ERROR, Finding, report, validate_stage

                # (a missing file, or a link loop, in the words of the line above: usd-core's were
                # "cannot open it as a USD layer (No such file or directory): Failed to open layer @x@")
                findings = (
                    validate_stage(file, builtin=False)
                    if Path(file).exists()
                    else [Finding("SWPM_USD_OPEN", ERROR, "/", f"{file}: {problem}")]
                )
                click.echo(json.dumps({"stage": file, **report(findings)}, indent=2))
            sys.exit(1)
        ctx.invoke(validate_usd, stage=Path(file), as_json=as_json, no_builtin=no_builtin)
        return
    from .reader import validate

    rep = validate(file)
    _mesh_hint(file, rep.problems)
    click.echo(rep.to_json(indent=2) if as_json else rep.format())
    sys.exit(0 if rep.valid else 1)


def _validate_prefix(file: str, n: int, as_json: bool) -> None:
    """``validate --prefix N``: the first N bytes of ``file`` read as a prefix (spec 4.1); exits."""
    from .errors import Report
    from .prefix import _checked_prefix

    size = None
    try:
        with open(file, "rb") as f:  # (at most its size: read(N) allocates N bytes first, a huge N fails)
            size = os.fstat(f.fileno()).st_size
            data = f.read(min(n, size))
    except OSError as exc:
        rep = Report(path=file)
        rep.add("SWPM_IO_ERROR", None, reason=exc.strerror or str(exc))
    else:
        rep, fp = _checked_prefix(data, path=file)  # (once: validate_prefix then open_prefix checked twice)
        if fp is not None:
            lods = fp.drawable_lods
            rep.summary["prefix"] = {
                "bytes": fp.size,
                "file_size": fp.file_size,
                "complete": fp.complete,
                "finest_drawable": fp.finest_drawable,
                "drawable_lods": [lods.start, lods.stop - 1] if lods else None,
                "needed_bytes": {
                    "0": fp.needed_bytes(0),
                    str(fp.lod_count - 1): fp.needed_bytes(fp.lod_count - 1),
                },
            }
    past_end = size is not None and n > size
    if past_end and "prefix" in rep.summary:
        rep.summary["prefix"]["requested_bytes"] = n
    _mesh_hint(file, rep.problems)  # (a mesh given: as validate alone says it)
    click.echo(rep.to_json(indent=2) if as_json else rep.format())
    if not as_json and "prefix" in rep.summary:
        p = rep.summary["prefix"]
        what = (
            f"LODs {p['drawable_lods'][0]}..{p['drawable_lods'][1]}" if p["drawable_lods"] else "no LOD yet"
        )
        click.echo(f"  prefix: {p['bytes']} of {p['file_size']} bytes draw {what}")
    if past_end:  # (it was taken as the whole file without a word: a script's N for every file is kept)
        click.echo(
            f"note: --prefix {n} is past the end of {file} ({size} bytes): the whole file was checked",
            err=True,
        )
    sys.exit(0 if rep.valid else 1)


_DECIMAL = re.compile(r"[0-9]+")


def _parse_ranges(spec: str) -> list[tuple[int, int]]:
    """``--ranges``' OFF:LEN,... as (offset, length) pairs; a usage error naming the item that is not one."""
    out = []
    for item in spec.split(","):
        off, sep, ln = item.strip().partition(":")
        if not (sep and _DECIMAL.fullmatch(off) and _DECIMAL.fullmatch(ln)):  # (isdigit() passes "²")
            raise click.BadParameter(
                f"{item!r} is not OFF:LEN (a byte offset and a length, decimal: 0:4096,81920:2048)",
                param_hint="--ranges",
            )
        out.append((int(off), int(ln)))
    return out


def _read_ranges(file: str, spans: list[tuple[int, int]]) -> dict[int, bytes]:
    """The bytes of ``spans`` read from ``file``; a range past its end is a usage error naming it (checked
    before reading: read(LEN) allocates LEN bytes first). OSError passes up."""
    size = Path(file).stat().st_size
    for o, n in spans:
        if o + n > size:
            raise click.BadParameter(
                f"{o}:{n} ends at byte {o + n}, past the end of {file} ({size} bytes)", param_hint="--ranges"
            )
    held: dict[int, bytes] = {}
    with open(file, "rb") as f:
        for o, n in spans:
            if n > len(held.get(o, b"")):  # (two ranges at one offset: the longer holds the other)
                f.seek(o)
                held[o] = f.read(n)
    return held


def _ranges_summary(fr: FileRanges) -> dict[str, Any]:
    """What ``validate --ranges`` / ``--lod`` add to the summary of ranges that opened."""
    lods = [int(k) for k in fr.drawable_lods]
    return {
        "held": [list(r) for r in fr.held],
        "held_bytes": fr.held_bytes,
        "file_size": fr.file_size,
        "complete": fr.complete,
        "drawable_lods": lods,
        "finest_drawable": lods[0] if lods else None,
        "needed_ranges": {
            str(k): [list(r) for r in fr.needed_ranges(k)] for k in sorted({0, fr.lod_count - 1})
        },
    }


def _runs(lods: list[int]) -> str:
    """``[0, 1, 2, 5]`` as ``0..2, 5`` (a band's ranges draw its LODs, not always consecutive ones)."""
    runs: list[list[int]] = []
    for k in lods:
        if runs and k == runs[-1][1] + 1:
            runs[-1][1] = k
        else:
            runs.append([k, k])
    return ", ".join(str(a) if a == b else f"{a}..{b}" for a, b in runs)


def _echo_ranges(rep: Report, as_json: bool) -> None:
    click.echo(rep.to_json(indent=2) if as_json else rep.format())
    if as_json:
        return
    r = rep.summary.get("ranges")
    if r is not None:
        d = r["drawable_lods"]
        what = f"LOD{'s' if len(d) > 1 else ''} {_runs(d)}" if d else "no LOD"
        click.echo(f"  ranges: {r['held_bytes']} of {r['file_size']} bytes held draw {what}")
        if "reads" in r:
            click.echo(f"  read for LOD {r['lod']}: {','.join(f'{o}:{n}' for o, n in r['reads'])}")
    need = rep.summary.get("range_need")
    if need is not None:
        click.echo(f"  fetch next: {need[0]}:{need[1] - need[0]} (bytes [{need[0]}, {need[1]}))")


def _validate_ranges(file: str, spans: list[tuple[int, int]], as_json: bool) -> None:
    """``validate --ranges OFF:LEN,...``: those byte ranges of ``file`` read as a range reader does (spec
    4.2), checked once; exits."""
    from .errors import Report
    from .ranges import _checked_ranges

    try:
        held = _read_ranges(file, spans)
    except OSError as exc:
        rep = Report(path=file)
        rep.add("SWPM_IO_ERROR", None, reason=exc.strerror or str(exc))
    else:
        try:
            rep, fr = _checked_ranges(held, file)
        except ValueError as exc:  # a range past the header's file_size: the caller's, spec 4.2 step 1
            raise click.BadParameter(str(exc), param_hint="--ranges") from None
        if fr is not None:
            rep.summary["ranges"] = _ranges_summary(fr)
    _mesh_hint(file, rep.problems)
    _echo_ranges(rep, as_json)
    sys.exit(0 if rep.valid else 1)


def _validate_lod(file: str, lod: int, as_json: bool) -> None:
    """``validate --lod K``: what LOD K needs, fetched from ``file`` as :func:`.ranges.read_lod` does, and
    the ranges it opened; exits."""
    from .errors import Report, SwpmFormatError
    from .ranges import read_lod

    reads: list[list[int]] = []
    try:
        size = Path(file).stat().st_size
        with open(file, "rb") as f:

            def read(o: int, n: int) -> bytes:
                n = max(0, min(n, size - o))  # (a file shorter than its header says: what there is)
                reads.append([o, n])
                f.seek(o)
                return f.read(n)

            fr = read_lod(read, lod, path=file)
    except OSError as exc:
        rep = Report(path=file)
        rep.add("SWPM_IO_ERROR", None, reason=exc.strerror or str(exc))
    except SwpmFormatError as exc:
        rep = exc.report
    except IndexError as exc:  # a LOD the file does not have (or that never draws)
        from .reader import validate

        # (a cut or empty file's LOD 0 "did not become drawable" was a usage error, exit 2: its problems
        # are the file's, as validate lists them)
        rep = validate(file)
        if rep.valid:
            raise click.BadParameter(f"no such LOD: {exc}", param_hint="--lod") from None
    except ValueError as exc:  # a range the reader refuses as the caller's (spec 4.2 step 1), said as it is
        raise click.BadParameter(str(exc), param_hint="--lod") from None
    else:
        rep = fr.report
        rep.summary["ranges"] = {"lod": lod, "reads": reads, **_ranges_summary(fr)}
    _mesh_hint(file, rep.problems)
    _echo_ranges(rep, as_json)
    sys.exit(0 if rep.valid else 1)


_DEFAULT_VECTORS = "spec/vectors"
#: the repository's vectors, beside the package in a source checkout (not in the wheel)
_REPO_VECTORS = Path(__file__).resolve().parents[2] / "spec" / "vectors"


@click.command("conformance", cls=JsonUsageCommand, short_help="Run the reader over the conformance vectors.")
@click.argument("vector_dir", required=False, default=_DEFAULT_VECTORS, type=click.Path(file_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def conformance_cmd(vector_dir: str, as_json: bool) -> None:
    """Run the reader over the conformance vectors of VECTOR_DIR (default spec/vectors, else the source
    checkout's) and the prefix reader over their prefix cases (spec/format.md 4.1)."""
    from .vectors import ConformanceManifestError, run_conformance

    if vector_dir == _DEFAULT_VECTORS and not Path(vector_dir).is_dir() and _REPO_VECTORS.is_dir():
        vector_dir = str(_REPO_VECTORS)  # run from elsewhere than the repository root
    if vector_dir == _DEFAULT_VECTORS and not Path(vector_dir).is_dir():
        # (an installed wheel has no spec/: "spec/vectors has no manifest.json" left a user looking for it)
        raise click.UsageError(
            f"no {_DEFAULT_VECTORS} here, and this install is no source checkout: run it from the "
            "repository's root, or give VECTOR_DIR (python -m swpm_usd.format.vectors VECTOR_DIR writes them)"
        )
    if not Path(vector_dir).is_dir():  # (a mistyped folder was said to have "no manifest.json")
        raise click.UsageError(f"{vector_dir}: no such folder")
    if not (Path(vector_dir) / "manifest.json").is_file():
        raise click.UsageError(f"{vector_dir} has no manifest.json")
    try:
        results = run_conformance(vector_dir)
    except ConformanceManifestError as exc:
        click.echo(f"error: {exc}", err=True)
        if as_json:
            click.echo(json.dumps({"error": str(exc)}, indent=2))
        sys.exit(1)
    failed = [r for r in results if not r.passed]
    if as_json:
        click.echo(json.dumps([r.__dict__ for r in results], indent=2))
    else:
        for r in results:
            click.echo(f"{'PASS' if r.passed else 'FAIL'} {r.name}: {r.detail}")
        click.echo(f"{len(results) - len(failed)}/{len(results)} passed")
    sys.exit(1 if failed else 0)


__all__ = [
    "EncodingsHelpCommand",
    "EncodingsHelpGroup",
    "conformance_cmd",
    "encode_cmd",
    "encodings_help",
    "inspect_cmd",
    "pm_summary",
    "validate_cmd",
]
