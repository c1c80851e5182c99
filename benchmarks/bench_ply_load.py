"""Time ``swpm_usd.load_mesh`` of PLY files in two source trees, alternating (a noisy machine).

    python benchmarks/bench_ply_load.py --trees /work/main /work/hNNN [--runs 5] FILE.ply...

Each run is a fresh process (``PYTHONPATH`` = the tree) that imports trimesh first, then times one
``load_mesh``; it prints, per file and tree, the median seconds and the median rise of the peak resident
memory over the load (Linux's ``VmHWM``, reset before it, less the resident memory then), and a digest of
the loaded mesh (points, triangles, attributes, stats), which must agree across trees.
``--cold`` evicts the file's pages from the page cache before each load (``posix_fadvise``).
``--make DIR`` writes nefertiti's PLYs (binary and ASCII, and ``x16``: twice subdivided) to DIR first.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

CHILD = """
import hashlib, json, sys, time
import numpy as np, trimesh
from swpm_usd.io import load_mesh
def hwm():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
if sys.argv[2:] == ["--cold"]:  # (the file's pages dropped from the page cache: a first read from the disk)
    import os
    fd = os.open(sys.argv[1], os.O_RDONLY)
    os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
    os.close(fd)
open("/proc/self/clear_refs", "w").write("5")
before = hwm()  # (the peak reset: the imports' peak is not the load's)
t = time.perf_counter()
m = load_mesh(sys.argv[1])
dt = time.perf_counter() - t
h = hashlib.blake2b(digest_size=8)
for a in (m.points, m.triangles, *[m.attributes[k] for k in sorted(m.attributes)]):
    h.update(np.ascontiguousarray(a).tobytes())
h.update(repr(sorted(m.stats.items())).encode())
print(json.dumps({"s": dt, "rss_mb": hwm() - before,
                  "digest": h.hexdigest(), "tris": int(m.triangle_count)}))
"""


def make(folder: Path) -> list[Path]:
    import trimesh

    mesh = trimesh.load(Path(__file__).resolve().parents[2] / "shared/meshes/nefertiti.obj", force="mesh")
    big = mesh.subdivide().subdivide()
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for name, m in (("nefertiti", mesh), ("nefertiti-x16", big)):
        for enc in ("binary", "ascii"):
            p = folder / f"{name}-{enc}.ply"
            p.write_bytes(trimesh.exchange.ply.export_ply(m, encoding=enc))
            out.append(p)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("files", nargs="*", type=Path)
    ap.add_argument("--trees", nargs="+", required=True)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--make", type=Path)
    ap.add_argument("--cold", action="store_true", help="each file's pages evicted before each load")
    args = ap.parse_args()
    files = args.files + (make(args.make) if args.make else [])
    for f in files:
        got: dict[str, list[dict]] = {t: [] for t in args.trees}
        for _ in range(args.runs):
            for tree in args.trees:
                env = {**os.environ, "PYTHONPATH": tree, "PYTHONDONTWRITEBYTECODE": "1"}
                out = subprocess.run(
                    [sys.executable, "-c", CHILD, str(f), *(["--cold"] if args.cold else [])],
                    env=env,
                    capture_output=True,
                    text=True,
                    check=True,
                ).stdout
                got[tree].append(json.loads(out.splitlines()[-1]))
        for tree, runs in got.items():
            seconds = statistics.median(r["s"] for r in runs)
            print(
                f"{f.name} ({f.stat().st_size / 1e6:.1f} MB) {tree}: median {seconds:.3f} s, "
                f"peak RSS rise {statistics.median(r['rss_mb'] for r in runs):.0f} MB, "
                f"{runs[0]['tris']} triangles, digest {sorted({r['digest'] for r in runs})}"
            )


if __name__ == "__main__":
    main()
