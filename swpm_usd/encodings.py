"""The encodings' names and parameters, without their code: what a config, its JSON Schema and the command
line's help check and list (:mod:`swpm_usd.pipeline.config`, :mod:`swpm_usd.pipeline.schema`,
:mod:`swpm_usd.format.cli`). Importing it loads neither numba nor an encoder, so a pipeline run with nothing
to build, a config check or ``--help`` does not pay for them (about 0.4 s a command). The encoders import
their defaults from here; :data:`swpm_usd.encode.BUILDERS` pairs each encoding's builder with
:data:`ENCODING_PARAMS`' entry.
"""

from __future__ import annotations

import numbers
from typing import Any

#: parameters of the shared collapse sequence, accepted by every encoding built on it
SIMPLIFY_PARAMS: dict[str, Any] = {"boundary_weight": 8.0, "seam_weight": 2.0}

#: ``optimize_connectivity``: an edge swap may move the surface by at most this fraction of the bounding-box
#: diagonal. LOD 0 then lies within that distance of the input (Hausdorff, 30,000 samples: 0.00042 - 0.00049
#: on the ten shared meshes; the former 10-degree guard alone gave 0.0003 - 0.0044, suzanne the worst),
#: about meshoptimizer's error at 50 % of bunny's triangles (0.00044), so the swaps cost the LODs about no
#: error. Bunny: lambda with the swaps 5.37 -> 4.20, with clustering 3.74; at 1e-3 (LOD 0 at 0.0009):
#: 4.01 and 3.60, with the Hausdorff ratio at 50 % 1.63 -> 2.07.
SWAP_MAX_DEVIATION = 5e-4

#: ``order_passes`` at most: the search evaluates a move over a few blocks past it, not over the whole level,
#: so late passes can undo and redo the same moves instead of settling (spot with 10**9 passes did not end
#: in 5 minutes); four passes gain 0.1 % over two (ACMR ratio mean over the ten meshes, 40 fractions)
MAX_ORDER_PASSES = 8
#: ``order_reach`` at most (a move is evaluated over blocks up to this far apart, and all of a pass's
#: candidates grow with it)
MAX_ORDER_REACH = 8

#: the sliding-window encoding's own parameters and their defaults (the collapse quadric weights come on top)
SLIDING_WINDOW_PARAMS: dict[str, Any] = {
    "builder": "topology",
    "mu": 0.1,
    "tolerance": 0.1,
    "optimize_connectivity": False,
    "swap_max_deviation": SWAP_MAX_DEVIATION,
    "cluster": False,
    "inner_vertices": 1,
    "cache_size": 16,
    "absorb_middle": True,
    "absorb_rounds": 1,
    "target_slack": None,
    "error_bound": None,
    "order_passes": None,
    "order_reach": 2,
    "coarsest_copy": True,
    "primitive": "list",
    "strip_window": 4,
}

#: skip-strip ``primitive`` values
PRIMITIVES = ("strip", "list")
#: the skip-strip encoding's own parameters and defaults (``ENCODING_PARAMS`` adds the simplifier's)
SKIPSTRIP_PARAMS: dict[str, Any] = {
    "primitive": "strip",
    "restart": True,
    "degenerate_threshold": 0.25,
    "cache_size": 16,
    "strip_window": 4,
}
#: ``strip_window`` at most (the stripifier scans its window for every triangle it emits)
MAX_STRIP_WINDOW = 64

#: the mixed encoding's own parameters and defaults (``ENCODING_PARAMS`` adds the simplifier's)
MIXED_PARAMS: dict[str, Any] = {"level_threshold": 0.25, "cache_size": 16}

#: what each parameter does, one short line, for ``encode --help`` and ``build --help`` (they listed names and
#: defaults alone); a name means the same in every encoding that takes it (the README and each encoder's
#: docstring say more)
PARAM_HELP: dict[str, str] = {
    "boundary_weight": "quadric weight of open-boundary edges",
    "seam_weight": "quadric weight of attribute seams (uv, normals)",
    "builder": "topology (TD-VIPM) or forsyth (larger pool)",
    "mu": "share of costliest vertices kept: less error",
    "tolerance": "forsyth: error slack before a new level",
    "optimize_connectivity": "edge swaps first: a smaller pool",
    "swap_max_deviation": "a swap's largest move, of the box diagonal",
    "cluster": "levels share storage: smaller pool, more error",
    "inner_vertices": "inner vertices a patch removes: >1, fewer LODs",
    "cache_size": "FIFO vertex-cache size the orderings target",
    "absorb_middle": "triangles of no patch join one (warmer cache)",
    "absorb_rounds": "rings of them a patch takes; 0 for all",
    "target_slack": "share of the mu cut a centre's move may cost more",
    "error_bound": "centres' error at most this x the quadric order's",
    "order_passes": "passes of the patch-order search (warmer cache)",
    "order_reach": "places the order search may move a patch",
    "coarsest_copy": "coarsest LOD stored once more, cache-ordered",
    "primitive": "strip (restart-joined strips) or list",
    "strip_window": "stripifier's look-ahead past the cache order",
    "restart": "join strips by restart index, else degenerates",
    "degenerate_threshold": "degenerate share that starts a new level",
    "level_threshold": "binned share that starts a new level",
}

#: every encoding's parameters and their defaults, in the order ``BUILDERS`` lists them
ENCODING_PARAMS: dict[str, dict[str, Any]] = {
    "sliding-window": {**SIMPLIFY_PARAMS, **SLIDING_WINDOW_PARAMS},
    "vanilla": dict(SIMPLIFY_PARAMS),
    "skip-strip": {**SIMPLIFY_PARAMS, **SKIPSTRIP_PARAMS},
    "mixed": {**SIMPLIFY_PARAMS, **MIXED_PARAMS},
}


def combination_problem(encoding: str, params: dict[str, Any]) -> str | None:
    """What the ``encoding``'s builder refuses of ``params`` together, each value valid alone, or None: the
    one rule, which the builder (``swpm_usd.encode.slidingwindow``) raises and the command line's ``-p`` and a
    config's ``params`` check with the values' bounds, a usage error before any mesh is read (``-p
    builder=forsyth -p order_passes=1`` read the mesh and failed at the build, exit 1; a config passed
    ``--dry-run`` and failed every asset). A value of the wrong type is left to the check of its own."""
    if encoding == "skip-strip":
        return _strip_only_problem(SKIPSTRIP_PARAMS, params)
    if encoding != "sliding-window":
        return None
    p = {**SLIDING_WINDOW_PARAMS, **params}
    builder, cluster, passes = p["builder"], p["cluster"], p["order_passes"]
    if not isinstance(builder, str) or not isinstance(cluster, bool):
        return None
    if cluster and builder != "topology":
        return "cluster=True needs builder='topology'"
    if isinstance(passes, int) and not isinstance(passes, bool) and passes > 0:
        if builder != "topology" or cluster:
            return "order_passes > 0 needs builder='topology' without cluster"
    # (Forsyth's builder has no patch centres to bar: it ignored the bound, recorded in the file's params)
    bound = p.get("error_bound")
    if isinstance(bound, numbers.Real) and not isinstance(bound, bool) and builder != "topology":
        return "error_bound needs builder='topology'"
    # the parameters set to other than their default, which a build that ignores them refuses (it ignored
    # them, silently, and ``swpm_usd.build`` recorded them in the file's params)
    given = {
        name
        for name, value in params.items()
        if name in SLIDING_WINDOW_PARAMS and not _is_default(value, SLIDING_WINDOW_PARAMS[name])
    }
    if builder == "forsyth":  # (an unknown builder is its own check's)
        for name in TOPOLOGY_ONLY_PARAMS:
            if name in given:
                return f"{name} needs builder='topology'"
    elif builder == "topology" and "tolerance" in given:
        return "tolerance needs builder='forsyth'"
    if "swap_max_deviation" in given and _off(p["optimize_connectivity"]):
        return "swap_max_deviation needs optimize_connectivity=True"
    if "absorb_rounds" in given and _off(p["absorb_middle"]):
        return "absorb_rounds needs absorb_middle=True"
    if "order_reach" in given and (cluster or (isinstance(passes, int) and passes == 0)):
        return "order_reach needs order_passes > 0 (builder='topology' without cluster)"
    return _strip_only_problem(SLIDING_WINDOW_PARAMS, params)


def _strip_only_problem(defaults: dict[str, Any], params: dict[str, Any]) -> str | None:
    """``restart`` or ``strip_window`` set to other than its default with ``primitive="list"``, which builds
    no strip (each was ignored, silently, and recorded in the file's params), or None."""
    if {**defaults, **params}["primitive"] != "list":
        return None
    for name in ("restart", "strip_window"):
        if name in params and name in defaults and not _is_default(params[name], defaults[name]):
            return f"{name} needs primitive='strip'"
    return None


#: the sliding-window parameters only the topology builder reads (its patches and their order), which
#: ``builder="forsyth"`` refuses set to anything but their default; ``cluster``, ``order_passes`` and
#: ``error_bound`` have rules of their own above
TOPOLOGY_ONLY_PARAMS = (
    "mu",
    "inner_vertices",
    "absorb_middle",
    "absorb_rounds",
    "target_slack",
    "order_reach",
)


def _is_default(value: Any, default: Any) -> bool:
    """``value`` equal to ``default``, or of another kind than the parameter's (numpy's too): a value of the
    wrong type is its own check's, not a combination's (a config's ``tolerance: '0.2'`` also said 'tolerance
    needs builder='forsyth''); ``1`` is not ``True``, nor ``True`` 1, and each is the other's wrong type."""
    flag = _is_flag(value)
    if isinstance(default, bool):
        return not flag or bool(value) == default
    if default is None or isinstance(default, numbers.Real):
        if flag or not isinstance(value, numbers.Real):
            return True
        return default is not None and bool(value == default)
    return not isinstance(value, type(default)) or value == default


def _is_flag(value: Any) -> bool:
    """``value`` a bool, Python's or numpy's (no number; numpy 2 names its type 'bool', not 'bool_')."""
    return isinstance(value, bool) or getattr(getattr(value, "dtype", None), "kind", "") == "b"


def _off(value: Any) -> bool:
    """``value`` False, Python's or numpy's (``swpm_usd.build`` takes either): ``is False`` missed numpy's."""
    return _is_flag(value) and not bool(value)
