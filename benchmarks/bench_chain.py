"""Build time of a whole LOD chain against meshoptimizer (the aim: within 10x of its time).

meshoptimizer's chain: ``simplify`` from the full mesh to 50, 25, 10, 5 and 2 % of the indices (five
discrete LODs); ours: one ``swpm_usd.build`` per encoding (every LOD at once, each ordered for the vertex
cache). A second reference adds ``optimize_vertex_cache`` on LOD 0 and each simplified LOD, what a real
meshoptimizer LOD chain for drawing runs (column ``+vcache``); the aim is stated against the first. After a
warm-up, ours and the references are timed in alternation, ``--rounds`` times (default 5), and a ratio is the
median of the per-round ratios: on a shared machine the load drifts, and timing one side after the other
let the drift into the ratio (meshoptimizer's own median moved 40 % between runs). Each run is also timed in
process CPU time (``time.process_time``: every thread of the process, our worker and helper included), and
``cpu ratio`` is the median per-round ratio of those: under a load the wall times measure the machine (a
threaded build's threads wait for the cores and for each other's GIL: cow's main thread spent 20-30 ms of a
255 ms build in ``np.flatnonzero`` alone at a load of 4, against 0.4 ms inline), the CPU times the code. On a
quiet machine a threaded build's wall time is below its CPU time, so the CPU ratio is the higher of the two.

    python benchmarks/bench_chain.py [MESH ...] [--encodings sliding-window,vanilla] [--rounds 5]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import meshoptimizer
import numpy as np

import swpm_usd
from swpm_usd.encode import BUILDERS
from swpm_usd.io import load_mesh

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared" / "meshes"


def _seconds(fn) -> tuple[float, float]:
    """Wall and process CPU seconds of ``fn()``."""
    t, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t, time.process_time() - c


def _medians(a: list[float], b: list[list[float]]) -> tuple[float, list[float], list[float]]:
    ratios = [statistics.median([x / y for x, y in zip(a, t, strict=True)]) for t in b]
    return statistics.median(a), [statistics.median(t) for t in b], ratios


def _alternating(ours, references, rounds: int) -> tuple[tuple, tuple]:
    """Median of ``ours``' times, and per reference the median time and the median of the per-round
    ratios ours / reference, all timed in alternation: in wall time, then in process CPU time."""
    ours()
    for ref in references:
        ref()
    a, b = [], [[] for _ in references]
    for _ in range(rounds):
        for ref, times in zip(references, b, strict=True):
            times.append(_seconds(ref))
        a.append(_seconds(ours))
    wall = _medians([x[0] for x in a], [[y[0] for y in t] for t in b])
    cpu = _medians([x[1] for x in a], [[y[1] for y in t] for t in b])
    return wall, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "meshes", nargs="*", default=[str(SHARED / "stanford-bunny.obj"), str(SHARED / "cow.obj")]
    )
    ap.add_argument("--encodings", default=",".join(BUILDERS), help="comma-separated (default: all)")
    ap.add_argument("--rounds", type=int, default=5, help="alternating timing rounds (default 5)")
    ap.add_argument("--out", default=str(HERE / "results" / "chain.json"))
    args = ap.parse_args()
    encodings = [e for e in args.encodings.split(",") if e]
    unknown = sorted(set(encodings) - set(BUILDERS))
    if unknown:
        ap.error(f"unknown encodings {unknown}; choose from {sorted(BUILDERS)}")
    rows = []
    for path in args.meshes:
        mesh = load_mesh(path)
        idx = mesh.triangles.astype(np.uint32).reshape(-1)
        pts = np.ascontiguousarray(mesh.points, np.float32)

        def chain(idx=idx, pts=pts, vcache=False):
            if vcache:
                meshoptimizer.optimize_vertex_cache(np.empty_like(idx), idx, idx.size, len(pts))
            for f in (0.5, 0.25, 0.1, 0.05, 0.02):
                dst = np.zeros_like(idx)
                target = int(idx.size * f) // 3 * 3
                n = meshoptimizer.simplify(
                    dst,
                    idx,
                    pts,
                    index_count=idx.size,
                    vertex_count=len(pts),
                    target_index_count=target,
                    target_error=1e3,
                )
                if vcache:
                    meshoptimizer.optimize_vertex_cache(np.empty(n, np.uint32), dst[:n], n, len(pts))

        for enc in encodings:
            (ours, (mo, mo_vc), (ratio, ratio_vc)), (ours_cpu, (mo_cpu, _), (cpu_ratio, _)) = _alternating(
                lambda enc=enc, mesh=mesh: swpm_usd.build(mesh, enc),
                [chain, lambda: chain(vcache=True)],
                args.rounds,
            )
            rows.append(
                {
                    "mesh": Path(path).name,
                    "encoding": enc,
                    "ours_s": ours,
                    "meshopt_s": mo,
                    "ratio": ratio,
                    "meshopt_vcache_s": mo_vc,
                    "ratio_vcache": ratio_vc,
                    "ours_cpu_s": ours_cpu,
                    "meshopt_cpu_s": mo_cpu,
                    "cpu_ratio": cpu_ratio,
                }
            )
    print(
        f"{'mesh':<20} {'encoding':<15} {'ours s':>8} {'meshopt s':>10} {'ratio':>6}  (aim <= 10x)"
        f" {'+vcache s':>10} {'ratio':>6}  {'cpu ratio':>9}"
    )
    for r in rows:
        print(
            f"{r['mesh']:<20} {r['encoding']:<15} {r['ours_s']:>8.3f} "
            f"{r['meshopt_s']:>10.3f} {r['ratio']:>6.1f}{'':14}"
            f"{r['meshopt_vcache_s']:>10.3f} {r['ratio_vcache']:>6.1f}  {r['cpu_ratio']:>9.1f}"
        )
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
