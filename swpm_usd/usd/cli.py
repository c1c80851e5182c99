"""``validate-usd``: run SwpmMeshAPI and usd-core's built-in validators on a USD stage.

``swpm-pipeline validate STAGE.usd`` dispatches here (:func:`validate_stage`). Exit code 0 without errors,
1 with errors; ``--json`` prints the report of :func:`swpm_usd.usd.validate.report`.
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from ..format.cli import JsonUsageCommand


@click.command("validate-usd", cls=JsonUsageCommand)
@click.argument("stage", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print a JSON report instead of one line per finding.")
@click.option("--no-builtin", is_flag=True, help="Run only the swpm validator, not usd-core's built-in ones.")
def validate_usd(stage: Path, as_json: bool, no_builtin: bool) -> None:
    """Validate STAGE (.usd/.usda/.usdc/.usdz): our invariants plus usd-core's built-in validators."""
    from .validate import report, validate_stage

    findings = validate_stage(stage, builtin=not no_builtin)
    rep = report(findings)
    if as_json:
        click.echo(json.dumps({"stage": str(stage), **rep}, indent=2))
    else:
        for f in findings:
            click.echo(f"{f.severity.upper():7} {f.code} {f.prim}: {f.message}")
        # (the verdict first, as an .swpm file's line gives it: "spot.usdc: 0 error(s), 0 warning(s)" left a
        # first reader to count)
        verdict = "INVALID" if rep["errors"] else "valid"
        click.echo(f"{stage}: {verdict}, {rep['errors']} error(s), {rep['warnings']} warning(s)")
    if rep["errors"]:
        raise SystemExit(1)


main = validate_usd

if __name__ == "__main__":  # pragma: no cover
    validate_usd()
