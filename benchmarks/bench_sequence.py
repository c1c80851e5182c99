"""The collapse sequence alone: cold (a fresh process, numba kernels loaded from the on-disk cache) and warm.

    python benchmarks/bench_sequence.py [MESH] [--repeats 5]

Prints a table and writes JSON (benchmarks/results/sequence.json). Target (issue 2): the Stanford bunny's
full sequence in at most 2 s warm and 5 s cold.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEFAULT = HERE.parent.parent / "shared" / "meshes" / "stanford-bunny.obj"

CHILD = """
import sys, time, json
t0 = time.perf_counter()
from swpm_usd.io import load_mesh
from swpm_usd.simplify import collapse_sequence
mesh = load_mesh(sys.argv[1])
t1 = time.perf_counter()
seq = collapse_sequence(mesh)
t2 = time.perf_counter()
seq = collapse_sequence(mesh)
t3 = time.perf_counter()
print(json.dumps({"import_load_s": t1 - t0, "cold_s": t2 - t1, "warm_s": t3 - t2, "steps": seq.step_count}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh", nargs="?", default=str(DEFAULT))
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=str(HERE / "results" / "sequence.json"))
    args = ap.parse_args()
    subprocess.run(
        [sys.executable, "-c", CHILD, args.mesh], check=True, capture_output=True
    )  # fill the cache
    runs = []
    for _ in range(args.repeats):
        out = subprocess.run(
            [sys.executable, "-c", CHILD, args.mesh], check=True, capture_output=True, text=True
        )
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    res = {k: statistics.median(r[k] for r in runs) for k in ("import_load_s", "cold_s", "warm_s")}
    res.update(mesh=args.mesh, steps=runs[0]["steps"], runs=runs)
    print(f"{'mesh':<24} {'steps':>7} {'import+load s':>14} {'cold s':>8} {'warm s':>8}")
    print(
        f"{Path(args.mesh).name:<24} {res['steps']:>7} {res['import_load_s']:>14.2f} "
        f"{res['cold_s']:>8.2f} {res['warm_s']:>8.2f}   (targets: cold <= 5 s, warm <= 2 s)"
    )
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
