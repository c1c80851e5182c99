"""``swpm-pipeline``: the command line. Small commands that compose; ``--json`` for machines.

Exit codes: 0 ok, 1 invalid input (a mesh or file that cannot be used) or a missing optional dependency
(``run --executor dask`` without the dask extra), 2 usage error, 130 interrupted (Ctrl-C: one line on
stderr, no traceback).
"""

from __future__ import annotations

import json
import sys
import time

import click
import numpy as np

from . import __version__
from .errors import SwpmError
from .format.cli import (
    _JSON_ON_INTERRUPT,
    EncodingsHelpCommand,
    EncodingsHelpGroup,
    FilePath,
    JsonUsageCommand,
    ctrl_c_through_compiled_code,
    json_on_interrupt,
    max_triangles_option,
    mesh_input,
    pm_summary,
)

#: the most ``run --jobs`` takes: each job is a worker process (a 4-core machine runs 4 well; a typo such as
#: ``--jobs 100000`` was taken and started a worker per asset, up to the asset count, at once)
MAX_JOBS = 256


def _lod_rows(pm, max_rows: int) -> list[dict]:
    """One row per selected LOD: evenly spread triangle fractions, always the first and the last."""
    from .metrics import acmr

    t0 = max(1, pm.triangle_count_at(0))
    fractions = np.linspace(1.0, 0.0, max(2, max_rows))
    lods = sorted({pm.lod_for_triangles(int(round(f * t0))) for f in fractions} | {0, pm.lod_count - 1})
    rows = []
    cache = int(pm.params.get("cache_size", 16))
    for k in lods:
        kind, stream = pm.draw_stream(k)
        rows.append(
            {
                "lod": int(k),
                "triangles": pm.triangle_count_at(k),
                "vertices": pm.vertex_count_at(k),
                "error": pm.error_at(k),
                "acmr": acmr(stream, cache_size=cache, kind=kind, restart_index=pm.restart_index),
            }
        )
    return rows


#: the exit code of a command stopped by Ctrl-C (128 + SIGINT, as a shell reports it)
EXIT_INTERRUPTED = 130


class _Main(EncodingsHelpGroup):
    """The command group: a Ctrl-C in any command exits 130 with one line (click's own: "Aborted!", 1), and
    ``{"error": "interrupted"}`` on stdout for one given ``--json`` (:func:`json_on_interrupt`)."""

    def invoke(self, ctx: click.Context) -> object:
        from ._startup import restore_interrupts

        restore_interrupts()  # (the package's import exited on Ctrl-C at once: see swpm_usd._startup)
        from .warnlines import package_warnings_as_lines

        package_warnings_as_lines()  # (a loader's warning: one line, not our source file and code line)
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            _exiting_on_interrupt()
            click.echo("swpm-pipeline: interrupted", err=True)
            fields = ctx.meta.get(_JSON_ON_INTERRUPT)
            if fields is not None:
                from .codes import fields_of

                click.echo(
                    json.dumps({**fields, "error": "interrupted", **fields_of("INTERRUPTED")}, indent=2)
                )
            ctx.exit(EXIT_INTERRUPTED)


def _exiting_on_interrupt() -> None:
    """Another Ctrl-C while the process exits is ignored (it would end it with a traceback, killed by SIGINT,
    while the interpreter waits for its threads)."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@click.group(cls=_Main, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="swpm-pipeline")
def main() -> None:
    """Turn meshes into view-independent progressive meshes (vanilla, skip-strip, mixed, sliding-window).

    \b
    Examples:
      swpm-pipeline build samples/spot.obj --encoding vanilla
      swpm-pipeline build samples/spot.obj --encoding vanilla --json
      swpm-pipeline encode spot.obj -o spot.swpm -e skip-strip -p primitive=list
      swpm-pipeline run samples/pipeline.yaml --jobs 4
    """


@main.command("build", cls=EncodingsHelpCommand, short_help="Build a mesh and print its LOD table.")
@click.argument("input_path", metavar="INPUT", type=FilePath())
@click.option(
    "--encoding", "-e", default="vanilla", show_default=True, help="Encoding to build (listed below)."
)
@click.option(
    "--param",
    "-p",
    "params",
    multiple=True,
    metavar="NAME=VALUE",
    help=(  # (-p mu=0.2 alone: vanilla, the default, does not take mu)
        "Encoding parameter (repeatable, listed below), value parsed as JSON when it can be: "
        "-e sliding-window -p mu=0.2"
    ),
)
@click.option(
    "--rows",
    type=click.IntRange(min=1),
    default=12,
    show_default=True,
    help="How many LODs the table shows (the first and the last always).",
)
@max_triangles_option
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def build_cmd(
    input_path: str,
    encoding: str,
    params: tuple[str, ...],
    rows: int,
    max_triangles: int | None,
    as_json: bool,
) -> None:
    """Build INPUT (.obj .ply .stl .off .glb .gltf .usd*) and print its LOD table.

    The table lists LOD, triangles, vertices, error (mesh units) and ACMR (FIFO cache of the encoding's
    cache size, 16 by default) for LODs spread evenly over the triangle counts.
    """
    from .build import build
    from .format.cli import _encoding_and_params
    from .slow_notice import notice_if_slow

    parsed = _encoding_and_params(encoding, params)
    json_on_interrupt(as_json, input=input_path)
    start = time.perf_counter()
    try:
        # (a cold numba cache: the first build compiles for a minute or more, silent until then)
        with ctrl_c_through_compiled_code(), notice_if_slow():
            pm = build(mesh_input(input_path, max_triangles), encoding, **parsed)
    except SwpmError as exc:
        from .codes import problem_fields

        click.echo(f"error: {exc}", err=True)
        if as_json:
            click.echo(json.dumps({"input": input_path, "error": str(exc), **problem_fields(exc)}, indent=2))
        sys.exit(1)
    seconds = time.perf_counter() - start
    table = _lod_rows(pm, rows)
    if as_json:
        out = {"input": input_path, **pm_summary(pm), "build_seconds": seconds, "lods": table}
        click.echo(json.dumps(out, indent=2, default=float))
        return
    click.echo(
        f"{input_path}: {pm.encoding}, {pm.lod_count} LODs, {pm.vertex_count} vertices, "
        f"built in {seconds:.2f} s; global {pm.global_bytes} B, per instance {pm.instance_bytes} B"
    )
    click.echo(f"{'LOD':>7} {'triangles':>10} {'vertices':>9} {'error':>11} {'ACMR':>6}")
    for r in table:
        click.echo(
            f"{r['lod']:>7} {r['triangles']:>10} {r['vertices']:>9} {r['error']:>11.4g} {r['acmr']:>6.3f}"
        )


@main.command("run", cls=JsonUsageCommand)
@click.argument("config", type=FilePath())
@click.option(
    "--jobs",
    "-j",
    type=click.IntRange(min=1, max=MAX_JOBS),
    default=1,
    show_default=True,
    help="Assets built at once (each in a process of its own).",
)
@click.option(
    "--dry-run",
    is_flag=True,
    help="Plan only: print each asset's rule, encoding, and why it is to build (new, inputs changed, ...).",
)
@click.option("--explain", is_flag=True, help="Print the plan (as --dry-run does), then run it.")
@click.option(
    "--executor",
    type=click.Choice(["local", "dask"]),
    default="local",
    show_default=True,
    help="Where assets are built: worker processes of this machine, or a dask cluster (needs dask and "
    "distributed installed; no limits.seconds).",
)
@click.option(
    "--scheduler",
    default=None,
    metavar="ADDR",
    help="Dask scheduler address, with --executor dask (default: a local cluster).",
)
@click.option(
    "--force",
    is_flag=True,
    help="Rebuild assets even when they are up to date (with --only, the selected ones).",
)
@click.option(
    "--only",
    "only",
    multiple=True,
    metavar="PATTERN",
    help="Build only the assets whose id (path relative to the config, a stage's prim as path:/prim/path; "
    "as --dry-run lists them) matches PATTERN (fnmatch: * also crosses / and :, ? one character, [seq]; "
    "an id matches itself); repeatable. Every asset is still planned; the others keep their records. A "
    "pattern that matches no asset is a usage error.",
)
@click.option(
    "--prune",
    is_flag=True,
    help="Delete the outputs of assets no longer in the config, and those of a kind it no longer asks for "
    "or at names output.names moved once their asset is rebuilt (those still as the manifest recorded "
    "them; with --dry-run, name them).",
)
@click.option(
    "--verify",
    is_flag=True,
    help="Hash every input file and recorded output (sha256) to decide whether it changed, instead of "
    "trusting one whose size, mtime, ctime and inode are as recorded; rebuilds an asset whose bytes changed "
    "without those (bit rot).",
)
@click.option(
    "--json",
    "as_json",
    is_flag=True,
    help="Print the run summary as JSON (with --dry-run or --explain, each asset's plan and why it is to "
    "build, under plan; the plan lines go to stderr).",
)
def run_cmd(
    config: str,
    jobs: int,
    dry_run: bool,
    explain: bool,
    executor: str,
    scheduler: str | None,
    force: bool,
    only: tuple[str, ...],
    prune: bool,
    verify: bool,
    as_json: bool,
) -> None:
    """Run the pipeline described by CONFIG (pipeline.yaml).

    Per asset: the first matching rule picks the encoding and its parameters; the asset is built, its
    streaming order validated and its outputs written atomically under output.dir, with manifest.json
    and report.html. Unchanged assets are skipped: an asset is up to date when its inputs, rule and
    parameters are those recorded and its outputs are still as recorded (inputs and outputs compared by
    their size and stat, else hashed; with --verify by their sha256).

    --only PATTERN (repeatable) builds the assets whose id matches one (meshes/hero_*): every asset is still
    planned, and the others are left as they are.

    An asset built before whose rebuild fails keeps its previous build (outputs, manifest record, place
    in the scene) and is reported failed. One run at a time writes in an output.dir: another fails at
    once.

    Exit 0 when every asset built, 1 when any failed (or output.dir is another run's, or --executor dask
    is asked without the dask extra: pip install 'swpm-usd[dask]'), 2 when the
    configuration is invalid (every problem listed as FILE:LINE:COL: $.path: message) or the command line is
    (a bad option, an --only pattern that matches no asset), 130 on Ctrl-C.
    """
    from .codes import PROBLEM_KEYS
    from .pipeline import ConfigError, SelectionError, run
    from .pipeline.outputs import orphan_phrase
    from .pipeline.reasons import counted, counted_shown

    if scheduler is not None and executor != "dask":
        # (it was ignored: the assets were built here while the user waited for the cluster to be used)
        raise click.BadParameter(
            f"{scheduler!r} is a dask scheduler's address: it needs --executor dask", param_hint="--scheduler"
        )
    try:
        res = run(
            config,
            jobs=jobs,
            executor=executor,
            scheduler=scheduler,
            dry_run=dry_run,
            explain=explain,
            force=force,
            prune=prune,
            verify=verify,
            echo=lambda m: click.echo(m, err=as_json),
            only=only,
        )
    except SelectionError as exc:  # (before the run built or wrote anything)
        raise click.BadParameter(str(exc), param_hint="'--only'") from None
    except ConfigError as exc:
        from .codes import problem_fields

        for p in exc.problems:
            click.echo(p, err=True)
        if as_json:
            error = {"error": "invalid configuration", "problems": exc.problems, **problem_fields(exc)}
            # (``input``: the config, as every run --json error names it; ``file``: where the problems are)
            click.echo(json.dumps({"input": config, **error, "file": config}, indent=2))
        sys.exit(2)
    except (SwpmError, OSError) as exc:
        from .codes import fields_of, problem_fields

        # output.dir held by another run (OutputLockedError), or the run's own files (manifest, report,
        # scene) not written: a full disk, no permission (a traceback before). The assets built are kept
        if isinstance(exc, OSError) and exc.filename is not None:
            message = f"{exc.filename}: {exc.strerror or exc}"
        else:
            message = str(exc)
        message = "; ".join([message, *getattr(exc, "__notes__", ())])
        click.echo(f"error: {message}", err=True)
        if as_json:
            if isinstance(exc, OSError):  # (the run's own files: its inputs' are the assets' failures)
                fields = fields_of(
                    "OUTPUT_UNWRITABLE", file=None if exc.filename is None else str(exc.filename)
                )
            else:
                fields = problem_fields(exc)
            click.echo(json.dumps({"input": config, "error": message, **fields}, indent=2))
        sys.exit(1)
    except KeyboardInterrupt:  # the run has stopped its workers and recorded what they finished
        _exiting_on_interrupt()
        if dry_run:  # (it records nothing: "the assets finished are recorded" was untrue of it)
            click.echo("swpm-pipeline run: interrupted; a dry run builds and writes nothing", err=True)
        else:
            click.echo(
                "swpm-pipeline run: interrupted; the assets finished are recorded in the manifest, "
                "and a rerun builds the rest",
                err=True,
            )
        if as_json:
            from .codes import fields_of

            click.echo(
                json.dumps({"input": config, "error": "interrupted", **fields_of("INTERRUPTED")}, indent=2)
            )
        sys.exit(EXIT_INTERRUPTED)
    if as_json:
        summary = {
            "built": res.built,
            "skipped": res.skipped,
            "failed": res.failed,
            "warnings": res.warnings,
            "seconds": res.seconds,
            "manifest": str(res.manifest_path),
            "failures": [
                {
                    "id": rid,
                    "error": rec.get("error"),
                    "kept_previous": rec["kept_previous"],
                    **{k: rec[k] for k in PROBLEM_KEYS if k in rec},
                }
                for rid, rec in sorted(res.failures.items())
            ],
            "pruned": res.pruned,
            "unlisted": res.unlisted,
            # (each of those named: its path, its asset and why it is left, `{"code", "detail"}`: an asset
            # removed, or rebuilt under the names output.names gives it now, ...)
            "orphans": res.orphans,
            "built_assets": sorted(res.built_ids),  # (which ones: `built` counts them)
            # (why: each reason's code -> how many of them had it, as the plan's `because` names them)
            "built_because": res.built_because,
            "not_selected": res.not_selected,  # (the config's assets --only left out: not built, not planned)
        }
        if dry_run:
            # a dry run deletes nothing: what --prune would delete is named as such, and left in output.dir
            # (it was listed as `pruned`, which a script took for deleted)
            summary.update(pruned=[], unlisted=res.pruned or res.unlisted, would_prune=res.pruned)
            # (the plan's totals: how many it would build, and why, as built_because counts a run's)
            would = counted(list(res.because.values()))
            summary.update(would_build=len(res.because), would_build_because=would)
        if dry_run or explain:
            summary["plan"] = res.plan
        click.echo(json.dumps(summary, indent=2, default=float))
    elif dry_run:  # (a plan of thousands of lines: its totals last)
        would = counted(list(res.because.values()))
        why = f" ({counted_shown(would)})" if would else ""
        left = f", {res.not_selected} not selected" if only else ""
        todo = len(res.because)
        click.echo(f"{todo} to build{why}, {res.skipped} up to date{left}; dry run: nothing written")
    else:
        why = f" ({counted_shown(res.built_because)})" if res.built_because else ""
        left = f", {res.not_selected} not selected" if only else ""
        click.echo(
            f"{res.built} built{why}, {res.skipped} up to date, {res.failed} failed{left} in "
            f"{res.seconds:.1f} s; manifest {res.manifest_path}"
        )
        for rid, rec in sorted(res.failures.items()):
            kept = (
                "; its previous build is kept (outputs, manifest record, scene)"
                if rec["kept_previous"]
                else ""
            )
            # the problem code bracketed after FAILED (`grep 'FAILED \[INPUT_MALFORMED\]'`), as --json has it
            code = f" [{rec['code']}]" if rec.get("code") else ""
            click.echo(f"FAILED{code} {rid}: {rec.get('error')}{kept}", err=True)
        # (counted by why each is left: an asset's outputs at its names before output.names flipped are
        # not "of an asset no longer in the config", which they were said to be)
        for n, code, detail in res.orphans_counted():
            if res.pruned:
                click.echo(f"pruned {orphan_phrase(n, code, detail)}")
            else:
                them = "them" if n != 1 else "it"
                click.echo(f"{orphan_phrase(n, code, detail)} left in output.dir (--prune deletes {them})")
    sys.exit(1 if res.failed else 0)


from .format.cli import conformance_cmd, encode_cmd, inspect_cmd, validate_cmd  # noqa: E402

main.add_command(encode_cmd)
main.add_command(inspect_cmd)
main.add_command(validate_cmd)
main.add_command(conformance_cmd)

if __name__ == "__main__":  # pragma: no cover
    main()
