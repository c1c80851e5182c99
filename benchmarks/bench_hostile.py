"""Build time on hostile meshes: a fan of many triangles standing on one edge, a cone of many sections, a
non-manifold hub and a flat strip.

The fan: suzanne (967 triangles) with ``n`` extra triangles on one of its edges, their tips scattered
around it, the way a broken export or a malicious file can pile faces onto one edge. The cone: a closed cone
of ``n`` sections (``2 n`` triangles), whose apex and cap centre are hubs of ``n`` triangles each, as CAD
exports tessellate cones, cylinders and discs. The hub: ``n`` triangles that all hold one vertex, their
other corners random among ``n`` points, as a file whose indices were zeroed in part would make it (before
the hub's edges were counted, ``pos_edge_kinds``, and its ring visited lazily: vanilla 99 s at 3,000
triangles, cubic; before the vertex-cache order kept a heavy vertex's triangles in a tree, ``vcache._HEAVY``:
Forsyth's builder 142 s at 30,000, its levels' ordering 46 of its 49 s at 20,000). The strip: ``n`` quads
in a row in the plane z = 0 (a ribbon, a road, a hair card), where every collapse along the strip costs
exactly 0 (before the quadric order's heap stopped popping the newest of equal keys first, it chained
collapses onto a few fans of thousands of triangles that then moved along the strip: vanilla 35 s and mixed
43 s at 20,000 quads; 277 s at 40,000 before vanilla's replay dropped dead corners). Every encoding (and
the sliding window's Forsyth builder and its several-inner-vertex mode with edge swaps) is built once per
size, warm, in one process. The ratio column is the time over the previous size's (2 for linear at doubling
sizes, 4 for quadratic, 8 for cubic). Targets:
no build over 30 s at a fan of 2,000 triangles (that fan used to take 489 s with Forsyth's builder and 207 s
with the topology-driven one), at a cone of 10,000 sections (before the hub guards,
``swpm_usd.simplify.kernels.HUB_SIZE``: the topology-driven builder 62 s, Forsyth's 120 s or more, and the
quadric order of vanilla 372 s already at 8,000 sections), at a hub of 30,000 triangles or at a strip of
20,000 quads.

    python benchmarks/bench_hostile.py [--sizes 500,1000,2000] [--cone-sizes 2500,5000,10000]
        [--hub-sizes 7500,15000,30000] [--strip-sizes 5000,10000,20000]
        [--out benchmarks/results/hostile.json]
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


def cone_mesh(n: int):
    """A closed cone of ``n`` sections: its apex and its cap's centre each in ``n`` triangles."""
    import trimesh

    from swpm_usd.mesh import Mesh

    cone = trimesh.creation.cone(radius=1.0, height=2.0, sections=n)
    return Mesh.from_arrays(np.asarray(cone.vertices), np.asarray(cone.faces))


def hub_mesh(n: int):
    """``n`` triangles that all hold vertex 0, their other corners random among ``n`` normal random points."""
    from swpm_usd.mesh import Mesh

    rng = np.random.default_rng(0)
    pts = rng.normal(size=(n + 1, 3))
    return Mesh.from_arrays(pts, np.c_[np.zeros(n, np.int64), rng.integers(1, n + 1, (n, 2))])


def strip_mesh(n: int):
    """A flat strip of ``n`` unit quads in a row (``2 n`` triangles) in the plane z = 0: every vertex on the
    boundary, every boundary edge collinear, so every collapse along the strip costs exactly 0."""
    from swpm_usd.mesh import Mesh

    x = np.arange(n + 1, dtype=np.float64)
    pts = np.concatenate(
        [np.c_[x, np.zeros(n + 1), np.zeros(n + 1)], np.c_[x, np.ones(n + 1), np.zeros(n + 1)]]
    )
    i = np.arange(n)
    top = n + 1 + i
    tris = np.concatenate([np.c_[i, i + 1, top + 1], np.c_[i, top + 1, top]])
    return Mesh.from_arrays(pts, tris)


# mesh maker, size the target is at
SHAPES = {
    "fan": (fan_mesh, 2000),
    "cone": (cone_mesh, 10000),
    "hub": (hub_mesh, 30000),
    "strip": (strip_mesh, 20000),
}


def main() -> None:
    import swpm_usd

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="500,1000,2000")
    ap.add_argument("--cone-sizes", default="2500,5000,10000")
    ap.add_argument("--hub-sizes", default="7500,15000,30000")
    ap.add_argument("--strip-sizes", default="5000,10000,20000")
    ap.add_argument("--out", default=str(HERE / "results" / "hostile.json"))
    args = ap.parse_args()
    sizes = {
        "fan": [int(s) for s in args.sizes.split(",")],
        "cone": [int(s) for s in args.cone_sizes.split(",")],
        "hub": [int(s) for s in args.hub_sizes.split(",")],
        "strip": [int(s) for s in args.strip_sizes.split(",")],
    }
    swpm_usd.build(fan_mesh(50), encoding="sliding-window")  # numba's compile (or cache load) off the clock
    rows = []
    print(
        f"{'setting':58s} {'shape':>5s} {'size':>6s} {'seconds':>8s} {'ratio':>6s} {'LODs':>6s}"
        f" {'coarsest':>8s}"
    )
    for shape, (make, _) in SHAPES.items():
        for enc, kw in SETTINGS:
            label = enc + (" " + json.dumps(kw) if kw else "")
            prev = None
            for n in sizes[shape]:
                mesh = make(n)
                t0 = time.perf_counter()
                pm = swpm_usd.build(mesh, encoding=enc, **kw)
                dt = time.perf_counter() - t0
                ratio = dt / prev if prev else float("nan")
                prev = dt
                coarsest = int(pm.triangles_at(pm.lod_count - 1).shape[0])
                rows.append(
                    {
                        "setting": label,
                        "shape": shape,
                        "size": n,
                        "seconds": dt,
                        "lods": pm.lod_count,
                        "coarsest": coarsest,
                    }
                )
                print(
                    f"{label:58s} {shape:>5s} {n:6d} {dt:8.2f} {ratio:6.2f} {pm.lod_count:6d} {coarsest:8d}",
                    flush=True,
                )
    for shape, (_, at) in SHAPES.items():
        worst = max(
            (r for r in rows if r["shape"] == shape and r["size"] == at),
            key=lambda r: r["seconds"],
            default=None,
        )
        if worst is not None:
            ok = worst["seconds"] <= TARGET_S
            print(
                f"slowest {shape} at {at:,}: {worst['setting']} {worst['seconds']:.1f} s"
                f" (at most {TARGET_S:.0f} s: {ok})"
            )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"target_seconds": TARGET_S, "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
