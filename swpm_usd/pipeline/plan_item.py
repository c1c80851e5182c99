"""One asset's plan (:class:`PlanItem`): what :func:`.runner.plan` decided of it, and how its triangle count
is known (:data:`TRIANGLE_COUNTS`, shown in a plan line by :func:`_triangles_shown`).

Separate from the runner because the runner's parts (:mod:`.rules`, :mod:`.reasons`, :mod:`.inputs`,
:mod:`.manifest`) each take plan items: they name this type here, not the orchestration that makes them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .assets import Asset


@dataclass
class PlanItem:
    asset: Asset
    input_digest: str
    triangles: int | None  # known from the manifest, else None (the worker counts)
    rule: int | None = None
    treatment: dict[str, Any] = field(default_factory=dict)
    why: str = ""
    digest: str = ""
    up_to_date: bool = False
    rule_pending: bool = False  # the worker matches the rule once it has counted the triangles
    inputs: list[Path] = field(default_factory=list)  # the files the asset is built from (discover's)
    #: an up-to-date asset's outputs as its manifest record lists them, with the stat fields of those
    #: hashed to be checked recorded anew (:func:`.outputs._checked_output`) and those of a kind the config no
    #: longer asks for left out when deleted or changed since, a USD layer's units added to a record
    #: written before they were (:func:`.worker.recorded_layer_units`); None when no record changed
    checked_outputs: dict[str, dict] | None = None
    #: the asset's manifest record; None when the manifest has none, or one that is not a record the run
    #: writes (a hand edit: :func:`.records.record_problem`), which is then ignored, with a warning
    previous: dict | None = None
    #: each input file's manifest entry (:func:`.assets.hash_inputs`): the recorded ones, when the input
    #: digest was taken from the record (:func:`.inputs._inputs_unchanged`), else those of the files just
    #: hashed
    input_stats: list[dict] = field(default_factory=list)
    #: ``inputs`` is a list a rerun may take from the record while its files are unchanged
    #: (:func:`.assets.discover`'s ``settled``): the record says so by :data:`.inputs.INPUTS_LISTED`
    inputs_listed: bool = False
    #: how ``triangles`` is known (:data:`TRIANGLE_COUNTS`): a dry run takes the count a file tells before
    #: its geometry is read where the rules need one (:func:`.io.early_triangle_count`)
    triangles_how: str = "exact"
    #: why the asset is built again (:func:`.reasons.build_reasons`: ``{"code", "detail"}`` each, in the
    #: order of :data:`.reasons.REASONS`); empty when it is up to date (``--force`` aside: the runner's)
    because: list[dict[str, str]] = field(default_factory=list)


#: how a plan's triangle count is known: the cleaned mesh's (recorded, or the file loaded), the count the
#: file declares before cleaning (a dry run: a glTF's JSON, a binary STL's header, a USD stage's
#: faceVertexCounts), at least that (a dry run: an OBJ's face lines), none needed (no rule on triangles and
#: no record), or none (the file does not load: its build fails)
TRIANGLE_COUNTS = ("exact", "declared before cleaning", "lower bound", "not needed", "unknown")


def _triangles_shown(item: PlanItem) -> str:
    """A plan line's triangle count, with how it is known when it is not the cleaned mesh's."""
    tri, how = item.triangles, item.triangles_how
    if how == "declared before cleaning":
        return f"triangles={tri} (declared, before cleaning)"
    if how == "lower bound":
        return f"triangles>={tri} (at least: a lower bound)"
    if how == "not needed":
        return "triangles=? (not needed: no rule on triangles)"
    if how == "unknown":
        return "triangles=? (unknown: the file did not load)"
    return f"triangles={'?' if tri is None else tri}"
