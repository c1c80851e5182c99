"""Build time of a whole LOD chain against meshoptimizer (the aim: within 10x of its time).

meshoptimizer's chain: ``simplify`` from the full mesh to 50, 25, 10, 5 and 2 % of the indices (five
discrete LODs); ours: one ``swpm_usd.build`` per encoding (every LOD at once). Medians of 5 / 3 runs after a
warm-up, in one process.

    python benchmarks/bench_chain.py [MESH ...]
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


def _median_time(fn, repeats: int) -> float:
    fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "meshes", nargs="*", default=[str(SHARED / "stanford-bunny.obj"), str(SHARED / "cow.obj")]
    )
    ap.add_argument("--out", default=str(HERE / "results" / "chain.json"))
    args = ap.parse_args()
    rows = []
    for path in args.meshes:
        mesh = load_mesh(path)
        idx = mesh.triangles.astype(np.uint32).reshape(-1)
        pts = np.ascontiguousarray(mesh.points, np.float32)

        def chain(idx=idx, pts=pts):
            for f in (0.5, 0.25, 0.1, 0.05, 0.02):
                dst = np.zeros_like(idx)
                target = int(idx.size * f) // 3 * 3
                meshoptimizer.simplify(
                    dst,
                    idx,
                    pts,
                    index_count=idx.size,
                    vertex_count=len(pts),
                    target_index_count=target,
                    target_error=1e3,
                )

        mo = _median_time(chain, 5)
        for enc in BUILDERS:
            ours = _median_time(lambda enc=enc, mesh=mesh: swpm_usd.build(mesh, enc), 3)
            rows.append(
                {
                    "mesh": Path(path).name,
                    "encoding": enc,
                    "ours_s": ours,
                    "meshopt_s": mo,
                    "ratio": ours / mo,
                }
            )
    print(f"{'mesh':<20} {'encoding':<15} {'ours s':>8} {'meshopt s':>10} {'ratio':>6}  (aim <= 10x)")
    for r in rows:
        print(
            f"{r['mesh']:<20} {r['encoding']:<15} {r['ours_s']:>8.3f} "
            f"{r['meshopt_s']:>10.3f} {r['ratio']:>6.1f}"
        )
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
