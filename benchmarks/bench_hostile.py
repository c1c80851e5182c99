"""Build time on a hostile mesh: a fan of many triangles standing on one edge.

Suzanne (967 triangles) with ``n`` extra triangles on one of its edges, their tips scattered around it, the
way a broken export or a malicious file can pile faces onto one edge. Every encoding (and the sliding
window's Forsyth builder and its several-inner-vertex mode with edge swaps) is built once per size, warm,
in one process. The per-collapse work around the edge's ends grows with the fan, so the time grows about
quadratically; the ratio column is the time over the previous size's (4 for quadratic, 8 for cubic).
Target: no build over 30 s at 2,000 triangles (a fan of that size used to take 489 s with Forsyth's
builder and 207 s with the topology-driven one).

    python benchmarks/bench_hostile.py [--sizes 500,1000,2000] [--out benchmarks/results/hostile.json]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SUZANNE = HERE.parent.parent / "shared" / "meshes" / "suzanne.obj"
TARGET_S = 30.0
SETTINGS = [
    ("vanilla", {}),
    ("skip-strip", {}),
    ("mixed", {}),
    ("sliding-window", {}),
    ("sliding-window", {"builder": "forsyth"}),
    ("sliding-window", {"inner_vertices": 3, "optimize_connectivity": True}),
]


def fan_mesh(n: int):
    """Suzanne with ``n`` triangles on its first triangle's first edge (tips: normal random points)."""
    from swpm_usd.io import load_mesh
    from swpm_usd.mesh import Mesh

    base = load_mesh(SUZANNE)
    rng = np.random.default_rng(0)
    pts = np.asarray(base.points, dtype=np.float64)
    tris = np.asarray(base.triangles)
    tips = np.arange(len(pts), len(pts) + n)
    fan = np.stack([np.full(n, tris[0, 0]), np.full(n, tris[0, 1]), tips], axis=1)
    return Mesh.from_arrays(np.concatenate([pts, rng.normal(size=(n, 3))]), np.concatenate([tris, fan]))


def main() -> None:
    import swpm_usd

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="500,1000,2000")
    ap.add_argument("--out", default=str(HERE / "results" / "hostile.json"))
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    swpm_usd.build(fan_mesh(50), encoding="sliding-window")  # numba's compile (or cache load) off the clock
    rows = []
    print(f"{'setting':58s} {'fan':>6s} {'seconds':>8s} {'ratio':>6s} {'LODs':>6s} {'coarsest':>8s}")
    for enc, kw in SETTINGS:
        label = enc + (" " + json.dumps(kw) if kw else "")
        prev = None
        for n in sizes:
            mesh = fan_mesh(n)
            t0 = time.perf_counter()
            pm = swpm_usd.build(mesh, encoding=enc, **kw)
            dt = time.perf_counter() - t0
            ratio = dt / prev if prev else float("nan")
            prev = dt
            coarsest = int(pm.triangles_at(pm.lod_count - 1).shape[0])
            rows.append(
                {"setting": label, "fan": n, "seconds": dt, "lods": pm.lod_count, "coarsest": coarsest}
            )
            print(f"{label:58s} {n:6d} {dt:8.2f} {ratio:6.2f} {pm.lod_count:6d} {coarsest:8d}", flush=True)
    worst = max((r for r in rows if r["fan"] == 2000), key=lambda r: r["seconds"], default=None)
    if worst is not None:
        ok = worst["seconds"] <= TARGET_S
        print(
            f"slowest at 2,000: {worst['setting']} {worst['seconds']:.1f} s (at most {TARGET_S:.0f} s: {ok})"
        )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"target_seconds": TARGET_S, "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
