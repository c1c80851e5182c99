"""Benchmark of the sliding-window encoding: index-pool size, levels, vertex cache, error and build time.

    python benchmarks/bench_slidingwindow.py [MESH ...] [--options topology,inner3,forsyth] [--samples 30000]
        [--repeat 3] [--big] [--out benchmarks/results/slidingwindow.json]

Rows per mesh and option: lambda (pool indices / LOD-0 indices), floor (the distinct triangles the windows
draw, over LOD 0's: the least lambda any layout of the same collapses could have), levels, LOD count;
FIFO-16 ACMR of the window at 100/50/25/10 % of the triangles next to meshoptimizer's
``optimize_vertex_cache`` of the same
triangle set (ratio = ours / theirs); Hausdorff error (``swpm_usd.metrics.surface_error``, exact point to
triangle, / bbox diagonal) at 50/25/10 % next to meshoptimizer's ``simplify`` at the same triangle count;
build seconds (median of ``--repeat`` after one warm-up build). Options (``--options``, comma separated):
topology; topology-mu0 and topology-mu0.3 (the default builder with ``mu`` 0, the papers' basic TD-VIPM
without error control, and with 0.3: ``mu`` trades pool size for error); inner3; forsyth; forsyth-tol1;
swap and inner3-swap (``optimize_connectivity=True``, SWPM 3.1 edge swaps; the error is still measured
against the unswapped input), inner3-swap-mu0 (the papers' builder without error control),
swap-dev1e-3, cluster-swap-dev1e-3 and inner3-swap-dev1e-3 (``swap_max_deviation=1e-3``: a smaller pool,
LOD 0 farther from the input); cluster and cluster-swap (``cluster=True``, SWPM 3.2 linked patches, without
and with the edge swaps); inner3-cluster-swap (linked patches of up to three inner vertices with the edge
swaps, the papers' Table 1 (d)); inner4-cluster-swap and inner5-cluster-swap (the same with four and five:
inner5-cluster-swap is the option set that keeps lambda <= 3 on all ten shared meshes, max 2.82 on beetle,
with every level but only about a third of the LODs kept; with every collapse a LOD, cluster-swap: mean 4.43,
max 5.12 on beetle, 2026-12-05);
inner3-swap-slack1, cluster-swap-slack1 and topology-mu0.2-slack1
(``target_slack=1.0``: costlier, higher-degree collapse targets for a smaller pool, alone and spent on
``mu=0.2``); topology-mu0.3-absorb-all (``mu=0.3, absorb_rounds=0``: the whole static middle joins
the patches); inner3-mu0.3 (patches of up to three inner vertices spent on ``mu=0.3``: the error of
topology-mu0.3-absorb-all from a smaller pool, fewer LODs, a colder cache); inner2-mu0.35-absorb-all,
inner3-mu0.4-absorb-all and inner5-mu0.5 (several inner vertices and a larger ``mu``: about the defaults'
pool, half their Hausdorff misses or fewer, a colder cache); order0 (``order_passes=0``: the greedy patch
order alone, without the search the defaults run, two passes of reach 2); reach1
(``order_reach=1``: the default until 2026-12-02's second session); order2,
mu0.3-absorb-all-order2 and inner3-mu0.3-order2 (``order_passes=2, order_reach=3``: each level's patch
order searched further for fewer cache misses over its windows, for a longer build); strip and
cluster-swap-strip (the defaults and cluster-swap with ``primitive="strip"``: the pool as triangle strips,
lambda counting its indices, restart indices included; the ACMR on the decoded triangles in strip order,
the order the strip draws them; ten meshes, lambda mean / max / bunny: strip 3.532 / 3.839 / 3.533,
cluster-swap-strip 2.975 / 3.609 / 2.554 with the block search sized by the pool (3.058 / 3.683 / 2.577
before it) and joins across window ends, 2026-12-05; 3.697 / 3.997 / 3.700 and 3.261 / 3.873 / 2.794
before them; 3.786 / 4.091 / 3.785 and 3.352 / 3.958 / 2.885 when every window's end was a restart).
error-bound4 and error-bound2 (``error_bound``: a level's centres ranked at most 4 / 2 times the plain
quadric sequence's error at the level's expected end: at 4 the meshes whose levels take collapses far dearer
than the quadric order's (fandisk, beetle, spot, suzanne) trade pool for error and the others, bunny
included, build the same pools).
``--big`` adds a generated icosphere of 1.3 M triangles (build time only).
Targets (issue): lambda <= 5.4 on bunny (topology, no reductions; <= 3.9 with cluster-swap; <= 2.8 with
inner3-cluster-swap, the papers' (d); inner3-swap alone 2.88), ACMR ratio <= 1.10, error ratio <= 1.5,
bunny build <= 3 s, 1 M triangles <= 60 s.
Aims (the project's, counted in the summary beside the targets): ACMR ratio <= 1.05, error ratio <= 1.25.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
MESHES = HERE.parent.parent / "shared" / "meshes"
OPTIONS = {
    "topology": {},
    "topology-mu0": {"mu": 0.0},
    "topology-mu0.2": {"mu": 0.2},
    "topology-mu0.3-absorb-all": {"mu": 0.3, "absorb_rounds": 0},
    "topology-mu0.3": {"mu": 0.3},
    "inner3": {"inner_vertices": 3},
    "inner3-mu0.3": {"inner_vertices": 3, "mu": 0.3},
    "inner3-mu0.4-absorb-all": {"inner_vertices": 3, "mu": 0.4, "absorb_rounds": 0},
    "inner2-mu0.35-absorb-all": {"inner_vertices": 2, "mu": 0.35, "absorb_rounds": 0},
    "inner5-mu0.5": {"inner_vertices": 5, "mu": 0.5},
    "order0": {"order_passes": 0},
    "reach1": {"order_reach": 1},
    "order2": {"order_passes": 2, "order_reach": 3},
    "mu0.3-absorb-all-order2": {"mu": 0.3, "absorb_rounds": 0, "order_passes": 2, "order_reach": 3},
    "inner3-mu0.3-order2": {"inner_vertices": 3, "mu": 0.3, "order_passes": 2, "order_reach": 3},
    "forsyth": {"builder": "forsyth"},
    "forsyth-tol1": {"builder": "forsyth", "tolerance": 1.0},
    "swap": {"optimize_connectivity": True},
    "inner3-swap": {"inner_vertices": 3, "optimize_connectivity": True},
    "inner3-swap-mu0": {"inner_vertices": 3, "optimize_connectivity": True, "mu": 0.0},
    "inner3-swap-noabsorb": {"inner_vertices": 3, "optimize_connectivity": True, "absorb_middle": False},
    "swap-dev1e-3": {"optimize_connectivity": True, "swap_max_deviation": 1e-3},
    "cluster-swap-dev1e-3": {"cluster": True, "optimize_connectivity": True, "swap_max_deviation": 1e-3},
    "inner3-swap-dev1e-3": {"inner_vertices": 3, "optimize_connectivity": True, "swap_max_deviation": 1e-3},
    "cluster": {"cluster": True},
    "cluster-swap": {"cluster": True, "optimize_connectivity": True},
    "inner3-cluster-swap": {"cluster": True, "inner_vertices": 3, "optimize_connectivity": True},
    "inner4-cluster-swap": {"cluster": True, "inner_vertices": 4, "optimize_connectivity": True},
    "inner5-cluster-swap": {"cluster": True, "inner_vertices": 5, "optimize_connectivity": True},
    "inner3-swap-slack1": {"inner_vertices": 3, "optimize_connectivity": True, "target_slack": 1.0},
    "topology-mu0.2-slack1": {"mu": 0.2, "target_slack": 1.0},
    "cluster-swap-slack1": {"cluster": True, "optimize_connectivity": True, "target_slack": 1.0},
    "strip": {"primitive": "strip"},
    "cluster-swap-strip": {"cluster": True, "optimize_connectivity": True, "primitive": "strip"},
    "error-bound4": {"error_bound": 4.0},
    "error-bound2": {"error_bound": 2.0},
}
FRACTIONS = (1.0, 0.5, 0.25, 0.1)


def _meshopt_acmr(tris: np.ndarray, vertex_count: int, cache_size: int) -> float:
    import meshoptimizer

    from swpm_usd.metrics import acmr

    idx = np.ascontiguousarray(tris, dtype=np.uint32).reshape(-1)
    dst = np.empty_like(idx)
    meshoptimizer.optimize_vertex_cache(dst, idx, idx.shape[0], vertex_count)
    return acmr(dst, cache_size)


def _meshopt_simplify(points: np.ndarray, tris: np.ndarray, target_tris: int) -> np.ndarray:
    import meshoptimizer

    idx = np.ascontiguousarray(tris, dtype=np.uint32).reshape(-1)
    pos = np.ascontiguousarray(points, dtype=np.float32)
    dst = np.empty_like(idx)
    n = meshoptimizer.simplify(
        dst, idx, pos, idx.shape[0], pos.shape[0], 12, 3 * int(target_tris), 1e3, 0, None
    )
    return dst[:n].reshape(-1, 3)


def distinct_floor(pm) -> float:
    """The least lambda any layout of the same collapses could have: the distinct triangles that some window
    draws (each rotation of a triangle counted once), over LOD 0's. A pool must hold each at least once."""
    rec = np.asarray(pm.window_records, np.int64)
    if pm.primitive == "strip":  # the strip indices some window draws (each starts a strip), decoded
        from swpm_usd.encode.strips import decode_strip

        pool = np.asarray(pm.index_pool, np.int64)
        cover = np.zeros(pool.shape[0] + 1, np.int64)
        np.add.at(cover, rec[:, 0], 1)
        np.add.at(cover, rec[:, 0] + np.asarray(pm.window_index_counts, np.int64), -1)
        drawn = decode_strip(np.where(np.cumsum(cover[:-1]) > 0, pool, pm.restart_index), pm.restart_index)
        turn = np.argmin(drawn, axis=1)[:, None]
        canonical = np.take_along_axis(drawn, (turn + np.arange(3)) % 3, axis=1)
        return np.unique(canonical, axis=0).shape[0] / float(rec[0, 1])
    tris = np.asarray(pm.index_pool).reshape(-1, 3)
    first, count = rec[:, 0] // 3, rec[:, 1]
    cover = np.zeros(tris.shape[0] + 1, np.int64)
    np.add.at(cover, first, 1)
    np.add.at(cover, first + count, -1)
    drawn = tris[np.cumsum(cover[:-1]) > 0]
    turn = np.argmin(drawn, axis=1)[:, None]
    canonical = np.take_along_axis(drawn, (turn + np.arange(3)) % 3, axis=1)
    return np.unique(canonical, axis=0).shape[0] / float(rec[0, 1])


def bench_mesh(name: str, mesh, option: str, params: dict, samples: int, repeat: int, errors: bool) -> dict:
    import swpm_usd
    from swpm_usd.metrics import acmr, surface_error

    cache = 16
    pm = swpm_usd.build(mesh, encoding="sliding-window", **params)  # warm-up (numba cache, first call)
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        pm = swpm_usd.build(mesh, encoding="sliding-window", **params)
        times.append(time.perf_counter() - t)
    T0 = mesh.triangle_count
    row = {
        "mesh": name,
        "option": option,
        "T": T0,
        "lambda": pm.index_pool.shape[0] / (3.0 * T0),
        "floor": distinct_floor(pm),
        "levels": pm.level_count,
        "lods": pm.lod_count,
        "build_s": statistics.median(times),
    }
    for f in FRACTIONS:
        k = pm.lod_for_triangles(int(round(f * T0)))
        tris = pm.triangles_at(k)
        ours = acmr(tris, cache)
        ref = _meshopt_acmr(tris, pm.vertex_count, cache)
        row[f"acmr{int(f * 100)}"] = ours
        row[f"acmr{int(f * 100)}_ratio"] = ours / ref if ref else float("nan")
        if errors and f < 1.0:
            ms = _meshopt_simplify(mesh.points, mesh.triangles, tris.shape[0])
            s_ours = surface_error(mesh.points, mesh.triangles, pm.points, tris, samples=samples)
            s_ref = surface_error(mesh.points, mesh.triangles, mesh.points, ms, samples=samples)
            e_ours, e_ref = s_ours.hausdorff, s_ref.hausdorff
            row[f"err{int(f * 100)}"] = e_ours
            row[f"err{int(f * 100)}_ratio"] = e_ours / e_ref if e_ref else float("nan")
            # the root-mean-square distance too: the Hausdorff maximum is one sample's
            row[f"rms{int(f * 100)}_ratio"] = s_ours.rms / s_ref.rms if s_ref.rms else float("nan")
    return row


def _fmt(rows: list[dict]) -> str:
    cols = ["mesh", "option", "T", "lambda", "floor", "levels", "lods", "build_s"]
    cols += [f"acmr{int(f * 100)}_ratio" for f in FRACTIONS]
    cols += [f"err{int(f * 100)}_ratio" for f in FRACTIONS if f < 1.0]
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        cells = []
        for c in cols:
            v = r.get(c, "")
            cells.append(f"{v:.3f}" if isinstance(v, float) else str(v))
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def _summary(rows: list[dict]) -> str:
    """Per option, over the meshes: lambda mean, ACMR ratios within 1.10 and error ratios within 1.5 (the
    issue's targets), within 1.05 and 1.25 (the project's aims), and the geometric mean of the Hausdorff and
    RMS ratios."""
    out = [
        "| option | meshes | lambda mean | floor mean | ACMR ratio mean (max) | ACMR <= 1.10 | ACMR <= 1.05 |"
        " Hausdorff ratio geomean | Hausdorff <= 1.5 | Hausdorff <= 1.25 | RMS ratio geomean | RMS <= 1.5 |"
        " RMS <= 1.25 |",
        "|" + "---|" * 13,
    ]
    for opt in dict.fromkeys(r["option"] for r in rows if "acmr100_ratio" in r):
        rs = [r for r in rows if r["option"] == opt and "acmr100_ratio" in r]
        ac = np.array([r[f"acmr{int(f * 100)}_ratio"] for r in rs for f in FRACTIONS])
        cells = [opt, str(len(rs)), f"{np.mean([r['lambda'] for r in rs]):.3f}"]
        cells += [f"{np.mean([r['floor'] for r in rs]):.3f}"]
        cells += [f"{ac.mean():.3f} ({ac.max():.3f})", f"{int((ac <= 1.10).sum())}/{ac.size}"]
        cells += [f"{int((ac <= 1.05).sum())}/{ac.size}"]
        for key in ("err", "rms"):
            e = np.array(
                [r.get(f"{key}{int(f * 100)}_ratio", np.nan) for r in rs for f in FRACTIONS if f < 1]
            )
            e = e[np.isfinite(e) & (e > 0)]
            cells += (
                [
                    f"{np.exp(np.log(e).mean()):.3f}",
                    f"{int((e <= 1.5).sum())}/{e.size}",
                    f"{int((e <= 1.25).sum())}/{e.size}",
                ]
                if e.size
                else ["", "", ""]
            )
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("meshes", nargs="*", help="mesh files (default: every .obj of ../shared/meshes)")
    ap.add_argument("--options", default="topology,inner3,forsyth")
    ap.add_argument("--samples", type=int, default=30_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-errors", action="store_true")
    ap.add_argument("--big", action="store_true", help="add a generated 1.3M-triangle icosphere (time only)")
    ap.add_argument("--out", default=str(HERE / "results" / "slidingwindow.json"))
    args = ap.parse_args(argv)

    import swpm_usd
    from swpm_usd.mesh import Mesh

    paths = [Path(p) for p in args.meshes] or sorted(MESHES.glob("*.obj"))
    rows = []
    for path in paths:
        mesh = swpm_usd.load_mesh(path)
        for opt in args.options.split(","):
            row = bench_mesh(
                path.stem, mesh, opt, OPTIONS[opt], args.samples, args.repeat, not args.no_errors
            )
            rows.append(row)
            print(_fmt([row]).splitlines()[-1], flush=True)
    if args.big:
        import trimesh

        s = trimesh.creation.icosphere(subdivisions=8)
        mesh = Mesh(points=np.asarray(s.vertices, np.float32), triangles=np.asarray(s.faces, np.int32))
        swpm_usd.build(Mesh(points=mesh.points, triangles=mesh.triangles[:2000]), encoding="sliding-window")
        t = time.perf_counter()
        pm = swpm_usd.build(mesh, encoding="sliding-window")
        rows.append(
            {
                "mesh": "icosphere-8",
                "option": "topology",
                "T": mesh.triangle_count,
                "lambda": pm.index_pool.shape[0] / (3.0 * mesh.triangle_count),
                "levels": pm.level_count,
                "lods": pm.lod_count,
                "build_s": time.perf_counter() - t,
            }
        )
        print(_fmt([rows[-1]]).splitlines()[-1], flush=True)
    print()
    print(_fmt(rows))
    print()
    print(_summary(rows))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(rows, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
