"""Triangles and vertex-cache misses at meshoptimizer's error: what a renderer that picks LODs by error draws.

``bench_slidingwindow.py`` compares errors at equal triangle counts, as issue 4's target is stated. A renderer
that selects the LOD by screen-space error instead draws the coarsest LOD whose error is below its threshold,
so the cost of a larger error is more triangles. Here, per mesh and fraction ``f`` (50/25/10 %):

* ``e_ref``: the Hausdorff error (``swpm_usd.metrics.surface_error``) of meshoptimizer's ``simplify`` to
  ``f`` of the triangles;
* our LOD: the one of fewest triangles whose measured Hausdorff error is at most ``e_ref``. The search starts
  at meshoptimizer's triangle count and walks a geometric grid of ``--scan`` triangle counts: towards LOD 0
  while the LODs exceed ``e_ref``, towards the coarsest LOD while they are within it; then it bisects
  between the last LOD within the error and the first beyond it (exact where the error grows with the LOD
  between those two). If not even LOD 0 is within the error (float rounding), LOD 0 is reported and the
  row's ``within`` is false;
* ``tri``: its triangles over meshoptimizer's; ``miss``: its FIFO misses as drawn (``draw_stream``, cache of
  16) over those of meshoptimizer's LOD ordered by ``optimize_vertex_cache``: the vertex work at equal
  error.

A ratio of 1.0 draws what meshoptimizer draws for the same error. Writes ``benchmarks/results/
equal_error.json``.

    python benchmarks/bench_equal_error.py [MESH ...] [--encodings sliding-window,vanilla]
        [--options topology,inner3-mu0.4-absorb-all] [--samples 30000] [--scan 32]

``--options`` names sliding-window parameter sets of ``bench_slidingwindow.py`` (``OPTIONS``); the other
encodings are built with their defaults.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import bench_slidingwindow as bsw  # noqa: E402  (OPTIONS and meshoptimizer's simplify, shared)

import swpm_usd  # noqa: E402
from swpm_usd.metrics import cache_misses, surface_error  # noqa: E402

RESULTS = HERE / "results"
FRACTIONS = (0.5, 0.25, 0.1)
CACHE = 16


def _meshopt_misses(tris: np.ndarray, vertex_count: int) -> int:
    import meshoptimizer

    idx = np.ascontiguousarray(tris, dtype=np.uint32).reshape(-1)
    dst = np.empty_like(idx)
    meshoptimizer.optimize_vertex_cache(dst, idx, idx.shape[0], vertex_count)
    return cache_misses(dst, CACHE)[0]


def _drawn_misses(pm, k: int) -> int:
    kind, stream = pm.draw_stream(k)
    return cache_misses(stream, CACHE, kind, pm.restart_index)[0]


def lod_at_error(pm, mesh, e_ref: float, t_start: int, samples: int, scan: int) -> tuple[int, int, bool]:
    """The LOD of fewest triangles with Hausdorff error at most ``e_ref`` (searched as the module docstring
    says), how many errors were measured, and whether that LOD is within ``e_ref`` (False only when not even
    LOD 0 is: it is returned then)."""
    measured: dict[int, float] = {}

    def ok(k: int) -> bool:
        if k not in measured:
            err = surface_error(mesh.points, mesh.triangles, pm.points, pm.triangles_at(k), samples=samples)
            measured[k] = err.hausdorff
        return measured[k] <= e_ref

    T0 = mesh.triangle_count
    last = pm.lod_count - 1
    k0 = pm.lod_for_triangles(max(t_start, 1))
    passing, failing = None, None
    if ok(k0):
        # within the error at meshoptimizer's count already: look for a coarser LOD that still is
        passing = k0
        for t in np.geomspace(max(t_start, 1), max(pm.triangle_count_at(last), 1), scan)[1:]:
            k = pm.lod_for_triangles(int(round(t)))
            if k == passing:
                continue
            if not ok(k):
                failing = k
                break
            passing = k
    else:
        failing = k0
        for t in np.geomspace(max(t_start, 1), T0, scan)[1:]:
            k = pm.lod_for_triangles(int(round(t)))
            if ok(k):
                passing = k
                break
            failing = k
        if passing is None:
            return 0, len(measured), ok(0)
    # bisection on the LOD index between the passing LOD (finer) and the failing one (coarser)
    if failing is not None:
        lo, hi = passing, failing
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if ok(mid):
                lo = mid
            else:
                hi = mid
        passing = lo
    return passing, len(measured), True


def bench(name: str, mesh, encoding: str, option: str, params: dict, samples: int, scan: int) -> dict:
    pm = swpm_usd.build(mesh, encoding=encoding, **params)
    row: dict = {"mesh": name, "encoding": encoding, "option": option, "T": mesh.triangle_count}
    for f in FRACTIONS:
        ms = bsw._meshopt_simplify(mesh.points, mesh.triangles, int(round(f * mesh.triangle_count)))
        e_ref = surface_error(mesh.points, mesh.triangles, mesh.points, ms, samples=samples).hausdorff
        k, evals, within = lod_at_error(pm, mesh, e_ref, ms.shape[0], samples, scan)
        p = int(f * 100)
        row[f"tri{p}"] = pm.triangle_count_at(k) / max(ms.shape[0], 1)
        row[f"miss{p}"] = _drawn_misses(pm, k) / max(_meshopt_misses(ms, mesh.vertex_count), 1)
        row[f"evals{p}"] = evals
        row[f"within{p}"] = within
    return row


def _geomean(values: list[float]) -> float:
    return float(np.exp(np.mean(np.log(values)))) if values else float("nan")


def _table(rows: list[dict]) -> str:
    head = "mesh".ljust(16) + "encoding".ljust(16) + "option".ljust(28)
    head += "".join(f"tri{int(f * 100)}".rjust(8) for f in FRACTIONS)
    head += "".join(f"miss{int(f * 100)}".rjust(8) for f in FRACTIONS)
    lines = [head]
    for r in rows:
        line = r["mesh"][:15].ljust(16) + r["encoding"].ljust(16) + r["option"][:27].ljust(28)
        line += "".join(f"{r[f'tri{int(f * 100)}']:8.2f}" for f in FRACTIONS)
        line += "".join(f"{r[f'miss{int(f * 100)}']:8.2f}" for f in FRACTIONS)
        lines.append(line)
    return "\n".join(lines)


def _summary(rows: list[dict]) -> list[dict]:
    out = []
    for key in dict.fromkeys((r["encoding"], r["option"]) for r in rows):
        sel = [r for r in rows if (r["encoding"], r["option"]) == key]
        tri = [r[f"tri{int(f * 100)}"] for r in sel for f in FRACTIONS]
        miss = [r[f"miss{int(f * 100)}"] for r in sel for f in FRACTIONS]
        out.append(
            {
                "encoding": key[0],
                "option": key[1],
                "points": len(tri),
                "tri_geomean": _geomean(tri),
                "tri_max": max(tri),
                "tri_within_1.25": sum(t <= 1.25 for t in tri),
                "miss_geomean": _geomean(miss),
                "miss_median": statistics.median(miss),
            }
        )
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("meshes", nargs="*", help="mesh paths (default: the ten shared meshes)")
    ap.add_argument("--encodings", default="sliding-window", help="comma-separated (default: sliding-window)")
    ap.add_argument("--options", default="topology", help="sliding-window parameter sets")
    ap.add_argument("--samples", type=int, default=30_000, help="surface samples each way (default 30000)")
    ap.add_argument("--scan", type=int, default=32, help="grid points from f to LOD 0 (default 32)")
    ap.add_argument("--out", default=str(RESULTS / "equal_error.json"))
    args = ap.parse_args(argv)
    paths = [Path(p) for p in args.meshes] or sorted(bsw.MESHES.glob("*.obj"))
    runs = []
    for enc in args.encodings.split(","):
        if enc == "sliding-window":
            for opt in args.options.split(","):
                if opt not in bsw.OPTIONS:
                    ap.error(f"unknown option {opt!r}; choose from {', '.join(bsw.OPTIONS)}")
                runs.append((enc, opt, bsw.OPTIONS[opt]))
        else:
            runs.append((enc, "defaults", {}))
    rows = []
    for path in paths:
        mesh = swpm_usd.load_mesh(path)
        for enc, opt, params in runs:
            rows.append(bench(path.stem, mesh, enc, opt, params, args.samples, args.scan))
            print(_table(rows[-1:]).splitlines()[1], flush=True)
    print()
    print(_table(rows))
    summary = _summary(rows)
    print()
    for s in summary:
        print(
            f"{s['encoding']} {s['option']}: triangles at meshoptimizer's error, "
            f"geomean {s['tri_geomean']:.3f} "
            f"(max {s['tri_max']:.2f}, within 1.25 on {s['tri_within_1.25']} of {s['points']}); "
            f"misses geomean {s['miss_geomean']:.3f}"
        )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    result = {"samples": args.samples, "scan": args.scan, "rows": rows, "summary": summary}
    out.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
