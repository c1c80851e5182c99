"""What :func:`.runner.run` returns (:class:`RunResult`): the records, counts, warnings, plan and orphans of
a run, which the CLI prints and ``--json`` holds.

Separate from the runner: the result's shape, not how a run fills it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .reasons import counted


@dataclass
class RunResult:
    records: dict[str, dict]
    built: int
    skipped: int
    failed: int
    warnings: list[str]
    seconds: float
    manifest_path: Path
    plan: list[dict] = field(default_factory=list)  # --dry-run / --explain: each asset's plan
    #: this run's failures: asset id -> the failed attempt's record (``error``, ``traceback``, ...), with
    #: ``kept_previous`` True when the asset's previous build was kept (see :func:`.outputs._keep_previous`)
    failures: dict[str, dict] = field(default_factory=dict)
    #: the outputs of assets no longer in the config: deleted (``prune``), or left in output.dir and named
    #: here, as output.dir-relative paths (a dry run names what ``prune`` would delete)
    pruned: list[str] = field(default_factory=list)
    unlisted: list[str] = field(default_factory=list)
    #: the ids of the assets this run built (``built`` counts them), in the order they finished
    built_ids: list[str] = field(default_factory=list)
    #: why each asset this run built or tried (a dry run: would build) was to be built: asset id -> its
    #: reasons (:func:`.reasons.build_reasons`, ``forced`` first with ``--force``)
    because: dict[str, list[dict[str, str]]] = field(default_factory=dict)
    #: the assets of the config that ``only`` left out (not built, not counted in ``skipped``, not planned)
    not_selected: int = 0
    #: each output of ``pruned`` or ``unlisted`` (in their order), named: ``{"path", "asset", "because":
    #: {"code", "detail"}}`` (:data:`.outputs.ORPHAN_REASONS`: its asset removed, or rebuilt under other
    #: names, ...; ``asset`` None for scene.usda or report.html)
    orphans: list[dict] = field(default_factory=list)

    def orphans_counted(self) -> list[tuple[int, str, str]]:
        """How many of :attr:`orphans` have each reason and detail: (count, code, detail), in the order
        first found (:func:`.outputs.orphan_phrase` says each)."""
        counts: dict[tuple[str, str], int] = {}
        for o in self.orphans:
            key = (o["because"]["code"], o["because"]["detail"])
            counts[key] = counts.get(key, 0) + 1
        return [(n, code, detail) for (code, detail), n in counts.items()]

    @property
    def built_because(self) -> dict[str, int]:
        """How many of the assets built had each reason (code -> count, in the order of
        :data:`.reasons.REASONS`; an asset with two reasons counts in both)."""
        return counted([self.because.get(aid, []) for aid in self.built_ids])
