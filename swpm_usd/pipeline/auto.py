"""``encoding: auto``: build each candidate encoding, keep those within the budgets, pick the best.

:func:`summarize` gives the figures the manifest and the report show of a built mesh (lambda, ACMR and
error per LOD sample, memory); :func:`choose_auto` ranks the candidates by ``select`` (:data:`AUTO_SELECT`:
the ACMR at half the triangles, or :func:`misses_at_error`, the vertex-cache misses each draws at equal
error). Separate from :mod:`.worker`, which calls it for an asset whose rule says ``auto``: the choice is
its own piece of measuring, read on its own.
"""

from __future__ import annotations

from typing import Any

import numpy as np

AUTO_CANDIDATES = ("vanilla", "skip-strip", "mixed", "sliding-window")
#: ``encoding: auto``'s ``select`` parameter: what the candidates within the budgets are ranked by.
#: ``acmr``: the ACMR at half the triangles (issue 7's rule, the default). ``misses-at-error``: the
#: vertex-cache misses each draws at equal error, as a renderer picking LODs by error (``lod_for_error``)
#: would draw them: an encoding whose LODs carry more error draws more triangles for the same screen-space
#: error
AUTO_SELECT = ("acmr", "misses-at-error")
#: ``misses-at-error``: the triangle fractions whose errors are the references (see :func:`misses_at_error`)
AUTO_ERROR_FRACTIONS = (0.5, 0.25, 0.1)


def lod_change_cost(pm) -> float:
    """Mean index writes per record when an instance changes LOD (0 for a table look-up)."""
    b = pm.buffers()
    if "collapse_change_count" in b and b["collapse_change_count"].size:
        return float(np.mean(b["collapse_change_count"]))
    return 0.0


def summarize(pm, cache_size: int = 16) -> dict[str, Any]:
    """Figures the manifest and the report show: lambda, ACMR and error per LOD sample, memory."""
    from ..encode.base import stored_index_count
    from ..metrics import acmr

    t0 = max(1, pm.triangle_count_at(0))
    dataset = stored_index_count(pm.buffers())
    curve = []
    for f in np.linspace(1.0, 0.0, 21):
        k = pm.lod_for_triangles(int(round(f * t0)))
        if curve and curve[-1]["lod"] == k:
            continue
        kind, stream = pm.draw_stream(k)
        curve.append(
            {
                "lod": int(k),
                "triangles": pm.triangle_count_at(k),
                "vertices": pm.vertex_count_at(k),
                "error": pm.error_at(k),
                "acmr": acmr(stream, cache_size=cache_size, kind=kind, restart_index=pm.restart_index),
            }
        )
    half = curve[min(range(len(curve)), key=lambda i: abs(curve[i]["triangles"] - t0 / 2))]
    return {
        "lod_count": pm.lod_count,
        "triangles": int(t0),
        "vertices": pm.vertex_count,
        "lambda": dataset / (3 * t0),
        "acmr": half["acmr"],
        "error_at_half": half["error"],
        "global_bytes": int(pm.global_bytes),
        "instance_bytes": int(pm.instance_bytes),
        "lod_change_cost": lod_change_cost(pm),
        "curve": curve,
    }


def misses_at_error(pms: dict[str, Any], fractions=AUTO_ERROR_FRACTIONS, cache_size: int = 16) -> dict:
    """Per encoding, the FIFO misses its draw stream costs at equal error, at each of ``fractions``.

    For each fraction ``f``, the reference error is the smallest that any of ``pms`` (built from one mesh)
    stores for its LOD at ``f`` of LOD 0's triangles (``error_at(lod_for_triangles(...))``), among those whose
    LODs get down to that count (one that stops simplifying above it would offer its coarsest LOD's error);
    a fraction none of them reaches is skipped. Each encoding then draws its coarsest LOD within that error
    (``lod_for_error``), as a renderer selecting by error would, and its misses (cache of ``cache_size``,
    degenerate triangles and strip joins included) are counted. Returns
    ``{encoding: {"misses": [...], "triangles": [...], "reference_errors": [...]}}``, one entry per fraction
    used."""
    from ..metrics import cache_misses

    t0 = max(1, min(pm.triangle_count_at(0) for pm in pms.values()))
    refs = []
    for f in fractions:
        target = int(round(f * t0))
        errs = []
        for pm in pms.values():
            k = pm.lod_for_triangles(target)
            if pm.triangle_count_at(k) <= target:
                errs.append(pm.error_at(k))
        if errs:
            refs.append(min(errs))
    out = {}
    for enc, pm in pms.items():
        misses, tris = [], []
        for e in refs:
            k = pm.lod_for_error(e)
            kind, stream = pm.draw_stream(k)
            misses.append(int(cache_misses(stream, cache_size, kind, pm.restart_index)[0]))
            tris.append(pm.triangle_count_at(k))
        out[enc] = {"misses": misses, "triangles": tris, "reference_errors": [float(e) for e in refs]}
    return out


def _misses_scores(per_encoding: dict) -> dict[str, float]:
    """Per encoding, the geometric mean over the reference errors of its misses over the fewest any encoding
    draws there (1.0: the fewest at every one), so each error weighs alike."""
    encs = list(per_encoding)
    m = np.array([per_encoding[e]["misses"] for e in encs], dtype=np.float64).reshape(len(encs), -1)
    if m.shape[1] == 0:
        return dict.fromkeys(encs, 1.0)
    ratio = np.maximum(m, 1.0) / np.maximum(m.min(axis=0), 1.0)
    return {e: float(np.exp(np.log(ratio[i]).mean())) for i, e in enumerate(encs)}


def choose_auto(
    mesh,
    instances: int,
    budgets: dict,
    storable: frozenset[str] | None = None,
    select: str = "acmr",
) -> tuple[Any, str, dict]:
    """Build every candidate, measure, and pick (Forsyth's table with measured numbers).

    Within the memory budgets (global + instances x instance bytes), the lowest ACMR at half the triangles
    wins (``select="acmr"``), or the fewest vertex-cache misses at equal error (``select="misses-at-error"``:
    :func:`misses_at_error`, each encoding's misses over the fewest at every reference error, geometric
    mean); values within 5 % are a tie, broken by total memory, then by LOD-change cost.
    If nothing fits the budgets, the smallest total memory wins and the reason says so.
    """
    if select not in AUTO_SELECT:
        raise ValueError(f"auto: select must be one of {', '.join(AUTO_SELECT)}, got {select!r}")
    from ..build import build
    from ..encode import BUILDERS

    measured = {}
    built = {}
    for enc in AUTO_CANDIDATES:
        if enc not in BUILDERS or (storable is not None and enc not in storable):
            continue
        pm = build(mesh, enc)
        s = summarize(pm)
        s["total_bytes"] = s["global_bytes"] + instances * s["instance_bytes"]
        measured[enc] = {k: v for k, v in s.items() if k != "curve"}
        built[enc] = pm

    def fits(m: dict) -> bool:
        return (
            m["total_bytes"] <= budgets.get("total_bytes", float("inf"))
            and m["global_bytes"] <= budgets.get("global_bytes", float("inf"))
            and m["instance_bytes"] <= budgets.get("instance_bytes", float("inf"))
        )

    if select == "misses-at-error" and built:
        # the reference errors come from every candidate, within the budgets or not: they only pick the
        # error levels at which the candidates are compared
        per_encoding = misses_at_error(built)
        scores = _misses_scores(per_encoding)
        for enc, m in per_encoding.items():
            measured[enc]["misses_at_error"] = m["misses"]
            measured[enc]["misses_at_error_score"] = scores[enc]
            measured[enc]["triangles_at_error"] = m["triangles"]
            measured[enc]["reference_errors"] = m["reference_errors"]
    key = "acmr" if select == "acmr" else "misses_at_error_score"
    ok = [e for e in measured if fits(measured[e])]
    if ok:
        best = min(measured[e][key] for e in ok)
        tied = [e for e in ok if measured[e][key] <= 1.05 * best]
        pick = min(tied, key=lambda e: (measured[e]["total_bytes"], measured[e]["lod_change_cost"]))
        if select == "acmr":
            what = f"ACMR {measured[pick]['acmr']:.3f} (best within budget {best:.3f})"
        else:
            what = (
                f"{measured[pick]['misses_at_error_score']:.2f}x the fewest cache misses at equal error "
                f"(best within budget {best:.2f}x; geometric mean over the errors stored at "
                f"{', '.join(f'{f:g}' for f in AUTO_ERROR_FRACTIONS)} of the triangles)"
            )
        why = (
            f"auto: {pick} has {what} and "
            f"{measured[pick]['total_bytes']} bytes for {instances} instance(s); candidates within budget: "
            f"{', '.join(sorted(ok))}"
        )
    else:
        pick = min(measured, key=lambda e: measured[e]["total_bytes"])
        why = (
            f"auto: no encoding fits the budgets; {pick} needs the least memory "
            f"({measured[pick]['total_bytes']} bytes for {instances} instance(s))"
        )
    return built[pick], why, measured
