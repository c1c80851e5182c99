"""Skip strips: the stripifier's window (``strip_window``) against the vertex cache, on the shared meshes.

For each mesh and setting (``primitive="list"``, then strips at each ``--windows`` value), one collapse
sequence and one skip-strip build; per LOD at 100/50/25/10 % of the triangles, the FIFO misses (cache of 16)
of the stream as drawn (``draw_stream``: degenerate triangles and restart indices included) over those of
meshoptimizer's ``optimize_vertex_cache`` of the same triangles (``run.py``'s ``meshopt_acmr``); and the
levels' uncollapsed lists (``level_indices``) over LOD 0's index buffer (3 indices a triangle), the memory the
setting costs. The table gives per setting the mean and largest ratio over all points, how many are within
1.05 (the project's aim) and the mean size. Writes ``benchmarks/results/strip_window.json``.

    python benchmarks/bench_strip_window.py [MESH ...] [--windows 3,4,5,8,16]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from run import meshopt_acmr  # noqa: E402  (meshoptimizer's optimize_vertex_cache, as run.py compares)

from swpm_usd.encode.skipstrip import build_skipstrip  # noqa: E402
from swpm_usd.io import load_mesh  # noqa: E402
from swpm_usd.metrics import acmr  # noqa: E402
from swpm_usd.simplify import collapse_sequence  # noqa: E402

SHARED = HERE.parent.parent / "shared" / "meshes"
FRACTIONS = (1.0, 0.5, 0.25, 0.1)
CACHE = 16
AIM = 1.05


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshes", nargs="*", default=sorted(str(p) for p in SHARED.glob("*.obj")))
    ap.add_argument("--windows", default="3,4,5,8,16", help="strip_window values (default 3,4,5,8,16)")
    ap.add_argument("--out", default=str(HERE / "results" / "strip_window.json"))
    args = ap.parse_args()
    settings = [("list", {"primitive": "list"})] + [
        (f"strip_window={w}", {"strip_window": int(w)}) for w in args.windows.split(",") if w
    ]
    rows = []
    for path in args.meshes:
        mesh = load_mesh(path)
        seq = collapse_sequence(mesh)
        for name, params in settings:
            pm = build_skipstrip(seq, **params)
            t0 = pm.triangle_count_at(0)
            ratios = []
            for f in FRACTIONS:
                k = pm.lod_for_triangles(int(round(f * t0)))
                kind, stream = pm.draw_stream(k)
                ours = acmr(stream, CACHE, kind, pm.restart_index)
                ratios.append(ours / meshopt_acmr(pm.triangles_at(k), pm.vertex_count, CACHE))
            size = pm.buffers()["level_indices"].size / (3 * t0)
            rows.append({"mesh": Path(path).name, "setting": name, "ratios": ratios, "level_indices": size})
            cells = " ".join(f"{r:.3f}" for r in ratios)
            print(f"{Path(path).name:<20} {name:<16} {cells}  {size:.3f}")
    print(f"\n{'setting':<16} {'mean':>6} {'max':>6} {'<=' + str(AIM):>7} {'points':>6} {'indices':>8}")
    summary = {}
    for name, _ in settings:
        r = np.concatenate([row["ratios"] for row in rows if row["setting"] == name])
        size = float(np.mean([row["level_indices"] for row in rows if row["setting"] == name]))
        summary[name] = {
            "mean": float(r.mean()),
            "max": float(r.max()),
            "within_aim": int(np.sum(r <= AIM)),
            "points": int(r.size),
            "level_indices_mean": size,
        }
        s = summary[name]
        cells = f"{s['mean']:>6.3f} {s['max']:>6.3f} {s['within_aim']:>7} {s['points']:>6} {size:>8.3f}"
        print(f"{name:<16} {cells}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"cache_size": CACHE, "rows": rows, "summary": summary}, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
