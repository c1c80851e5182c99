"""How many patch centres a sliding-window level can have: our search against an exact solver's bound.

The pool of the topology builder shrinks with the number of patch centres per level (an independent set of
the level's vertices, SWPM appendix: lambda ~ (2 - f) / f for a centre fraction f), so the lambda target
(<= 5.4 on bunny) needs f >= 0.3125 on every level. For the first levels of a default build this prints
the minimum-degree greedy's set, the builder's iterated local search (``sw_centres.grow_independent_set``)
at the builder's effort and at 10 iterations per vertex, and HiGHS's branch and bound on the same graph
(``scipy.optimize.milp``; one clique constraint per triangle): its best set and its upper bound after
``--time-limit`` seconds (HiGHS overruns it: bunny's first level took 17 minutes for a 150 s limit, the
second and third 19 s and 150 s). Fractions are of the level's positions.

    python benchmarks/bench_centres.py [MESH] [--mu 0.1] [--levels 3] [--time-limit 120]
        [--out benchmarks/results/centres.json]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp
from scipy.sparse import csr_matrix

import swpm_usd
from swpm_usd.encode import slidingwindow as sw
from swpm_usd.encode import sw_centres as swc
from swpm_usd.encode import sw_levels

HERE = Path(__file__).resolve().parent
MESHES = HERE.parent.parent / "shared" / "meshes"


def _record_levels(mesh, mu: float) -> tuple[list[dict], float]:
    """Build once, keeping every level's graph, eligible positions and greedy centres."""
    levels: list[dict] = []
    graphs: list[np.ndarray] = []
    select, graph = swc.select_patches, sw_levels.position_graph

    def graph_hook(tp, P):
        graphs.append(np.array(tp))
        return graph(tp, P)

    def select_hook(adj_start, adj, eligible, tiebreak, inner_max):
        out = select(adj_start, adj, eligible, tiebreak, inner_max)
        level = {"adj_start": adj_start, "adj": adj, "eligible": eligible.copy(), "greedy": out[1]}
        level["tp"] = graphs[-1]
        levels.append(level)
        return out

    swc.select_patches, sw_levels.position_graph = select_hook, graph_hook
    try:
        pm = swpm_usd.build(mesh, encoding="sliding-window", mu=mu)
    finally:
        swc.select_patches, sw_levels.position_graph = select, graph
    return levels, pm.index_pool.shape[0] / (3.0 * mesh.triangle_count)


def _exact(level: dict, time_limit: float) -> tuple[int, float]:
    """HiGHS on max sum(x) with x_a + x_b (+ x_c) <= 1 over the eligible corners of every triangle."""
    el = level["eligible"]
    idx = np.flatnonzero(el)
    col = np.full(el.shape[0], -1, np.int64)
    col[idx] = np.arange(idx.shape[0])
    tp = level["tp"]
    keep = el[tp].sum(1) >= 2
    c = col[tp[keep]]
    rows = np.repeat(np.arange(c.shape[0]), 3)
    cols = c.reshape(-1)
    ok = cols >= 0
    A = csr_matrix((np.ones(int(ok.sum())), (rows[ok], cols[ok])), shape=(c.shape[0], idx.shape[0]))
    res = milp(
        -np.ones(idx.shape[0]),
        constraints=LinearConstraint(A, -np.inf, 1),
        integrality=np.ones(idx.shape[0]),
        bounds=Bounds(0, 1),
        options={"time_limit": time_limit, "mip_rel_gap": 1e-3},
    )
    best = int(round(-res.fun)) if res.x is not None else 0
    bound = -float(getattr(res, "mip_dual_bound", np.nan))
    return best, bound


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh", nargs="?", default=str(MESHES / "stanford-bunny.obj"))
    ap.add_argument("--mu", type=float, default=0.1)
    ap.add_argument("--levels", type=int, default=3)
    ap.add_argument("--time-limit", type=float, default=120.0)
    ap.add_argument("--out", default=str(HERE / "results" / "centres.json"))
    args = ap.parse_args(argv)
    mesh = swpm_usd.load_mesh(args.mesh)
    levels, lam = _record_levels(mesh, args.mu)
    rows = []
    for i, lv in enumerate(levels[: args.levels]):
        positions = int(np.count_nonzero(np.diff(lv["adj_start"])))
        build = sw._more_centres(lv["adj_start"], lv["adj"], lv["eligible"], lv["greedy"]).shape[0]
        long = swc.grow_independent_set(
            lv["adj_start"], lv["adj"], lv["eligible"], lv["greedy"], 10 * int(lv["eligible"].sum()), 1
        ).shape[0]
        t = time.perf_counter()
        best, bound = _exact(lv, args.time_limit)
        rows.append(
            {
                "level": i,
                "positions": positions,
                "eligible": int(lv["eligible"].sum()),
                "greedy": int(lv["greedy"].shape[0]),
                "search": int(build),
                "search_x10": int(long),
                "exact_best": best,
                "exact_bound": bound,
                "exact_seconds": time.perf_counter() - t,
            }
        )
    name = Path(args.mesh).stem
    print(f"{name}, mu={args.mu}: lambda {lam:.3f} (centre fraction f needed for lambda 5.4: 0.3125)")
    print("| level | positions | greedy f | search f | search x10 f | exact best f | exact bound f | s |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        n = r["positions"]
        print(
            f"| {r['level']} | {n} | {r['greedy'] / n:.4f} | {r['search'] / n:.4f}"
            f" | {r['search_x10'] / n:.4f} | {r['exact_best'] / n:.4f} | {r['exact_bound'] / n:.4f}"
            f" | {r['exact_seconds']:.0f} |"
        )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"mesh": name, "mu": args.mu, "lambda": lam, "levels": rows}, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
