"""First build on a fresh machine: numba compiles the kernels before the first build of every encoding.

    python benchmarks/bench_compile.py [MESH] [--repeats 3] [--out benchmarks/results/compile.json]

Each repeat runs one fresh Python process with an empty ``NUMBA_CACHE_DIR`` (a temporary folder) that
builds MESH (default: cow) with every encoding in turn: sliding-window (the topology builder), Forsyth's
builder, vanilla, skip-strip, mixed. A step's cold time includes the compile of the kernels no earlier
step compiled; the warm time is the same build again in the same process. ``--alone`` gives every encoding
a fresh process and cache of its own (its whole compile). Prints the medians and writes JSON.

Each cold process also lists the kernels numba compiled for more than one signature (``.signatures``:
int32 against int64 scalars, a literal ``0`` or ``True``, an argument omitted or passed, C against A
layout): every extra one is a whole compile on a fresh machine. ``--check`` exits 1 when one of
``ONE_SIGNATURE`` has more than one (a cold cache is what types a caller's callees: a warm one loads the
caller whole, so this is a benchmark, not a unit test).
``--kernels N`` also lists the N kernels whose compile took longest in the (last) cold process: seconds of
its own compile (its callees' compiles taken out: numba's ``numba:compile`` events nest) and with them, and
its signatures (wall time: run it on a quiet machine).
No target: what a user waits for on first use, and a yardstick for changes to the kernels.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEFAULT = HERE.parent.parent / "shared" / "meshes" / "cow.obj"
#: kernels whose callers agree on one signature (on 0.7.3, two to five each in a cold run of the tests)
ONE_SIGNATURE = (
    "swpm_usd.metrics._nearest2",
    "swpm_usd.simplify.best.best_collapse",
    "swpm_usd.simplify.best.best_collapse_sized",
    "swpm_usd.simplify.stars._neighbours_rows_sorted",
    "swpm_usd.simplify.run.run_sequence",
    "swpm_usd.vcache._tree_set",
    "swpm_usd.encode.sw_forsyth._refresh",
    "swpm_usd.encode.sw_cluster._cheapest_prefix",
    "swpm_usd.encode.sw_refine.refine_patch_order",
    "swpm_usd.encode.sw_deviation.deviation_rows",
    "swpm_usd.simplify.stars.triangle_positions",
    "swpm_usd.vcache._rotate_rows",
    "swpm_usd.vcache._order_blocks",  # (sw_layout._finish passed it the literals 0 and True: ~5 s CPU)
)
STEPS = {
    "sliding-window": ("sliding-window", {}),
    "sliding-window forsyth": ("sliding-window", {"builder": "forsyth"}),
    "vanilla": ("vanilla", {}),
    "skip-strip": ("skip-strip", {}),
    "mixed": ("mixed", {}),
}

CHILD = """
import json, resource, sys, time
steps = json.loads(sys.argv[2])
kernels, stack = {}, []
if len(sys.argv) > 3:  # per kernel: [own s, with callees s, signatures]
    from numba.core import event

    class Compiles(event.Listener):
        def on_start(self, ev):
            stack.append([time.perf_counter(), 0.0])

        def on_end(self, ev):
            t0, inner = stack.pop()
            dt = time.perf_counter() - t0
            if stack:
                stack[-1][1] += dt
            f = ev.data["dispatcher"].py_func
            row = kernels.setdefault(f"{f.__module__}.{f.__qualname__}", [0.0, 0.0, []])
            row[0] += dt - inner
            row[1] += dt
            row[2].append(str(ev.data["args"]))

    event.register("numba:compile", Compiles())
t = time.perf_counter()
import swpm_usd
mesh = swpm_usd.load_mesh(sys.argv[1])
out = {"import_load_s": time.perf_counter() - t}
for name, (encoding, params) in steps.items():
    t = time.perf_counter()
    swpm_usd.build(mesh, encoding=encoding, **params)
    t1 = time.perf_counter()
    swpm_usd.build(mesh, encoding=encoding, **params)
    out[name] = {"cold_s": t1 - t, "warm_s": time.perf_counter() - t1}
ru = resource.getrusage(resource.RUSAGE_SELF)
out["cpu_s"] = ru.ru_utime + ru.ru_stime  # (the whole process: steadier than wall time on a loaded machine)
from numba.core.registry import CPUDispatcher
sigs = {}
for mod in list(sys.modules.values()):
    for obj in list(vars(mod).values()) if getattr(mod, "__name__", "").startswith("swpm_usd") else ():
        if isinstance(obj, CPUDispatcher) and len(obj.signatures) > 1:
            sigs[f"{obj.py_func.__module__}.{obj.py_func.__name__}"] = [str(s) for s in obj.signatures]
out["signatures"] = sigs
out["kernels"] = kernels
print(json.dumps(out))
"""


def _run(mesh: str, steps: dict, kernels: bool = False) -> dict:
    with tempfile.TemporaryDirectory(prefix="swpm-numba-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        res = subprocess.run(
            [sys.executable, "-c", CHILD, mesh, json.dumps(steps), *(["kernels"] if kernels else [])],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh", nargs="?", default=str(DEFAULT))
    ap.add_argument("--repeats", type=int, default=3, help="fresh processes per measurement (default 3)")
    ap.add_argument("--alone", action="store_true", help="every encoding in a fresh process of its own")
    ap.add_argument("--out", default=str(HERE / "results" / "compile.json"))
    ap.add_argument("--check", action="store_true", help="exit 1 if a kernel of ONE_SIGNATURE has several")
    ap.add_argument("--kernels", type=int, default=0, metavar="N", help="list the N slowest kernel compiles")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error("--repeats must be at least 1")
    runs: dict[str, list[dict]] = {name: [] for name in STEPS}
    cpu: list[float] = []
    several: dict[str, list[str]] = {}
    kernels = args.kernels > 0
    for _ in range(args.repeats):
        outs = [_run(args.mesh, {name: step}, kernels) for name, step in STEPS.items()] if args.alone else []
        outs = outs or [_run(args.mesh, STEPS, kernels)]
        for out in outs:
            for name in STEPS:
                if name in out:
                    runs[name].append(out[name])
            several.update(out["signatures"])
        cpu.append(sum(out["cpu_s"] for out in outs))
    rows = []
    print(f"{'step':24s} {'cold s (median)':>16s} {'warm s':>8s}  cold runs")
    for name, rs in runs.items():
        cold = [r["cold_s"] for r in rs]
        warm = [r["warm_s"] for r in rs]
        row = {
            "step": name,
            "cold_s": statistics.median(cold),
            "warm_s": statistics.median(warm),
            "cold_runs": cold,
        }
        rows.append(row)
        print(f"{name:24s} {row['cold_s']:16.1f} {row['warm_s']:8.3f}  {' '.join(f'{c:.1f}' for c in cold)}")
    total = sum(r["cold_s"] for r in rows)
    print(f"{'total':24s} {total:16.1f}")
    print(f"process CPU s (median): {statistics.median(cpu):.1f}  runs {' '.join(f'{c:.1f}' for c in cpu)}")
    for name, sigs in sorted(several.items()):
        print(f"{len(sigs)} signatures: {name}")
        for sig in sigs:
            print(f"    {sig}")
    compiled: dict[str, list] = {}
    for out in outs:  # (the last repeat's processes)
        compiled.update(out["kernels"])
    if compiled:
        own = sum(row[0] for row in compiled.values())
        count = sum(len(row[2]) for row in compiled.values())
        print(f"kernels compiled: {len(compiled)}, signatures {count}, compile {own:.1f} s (wall)")
        print(f"{'own s':>7s} {'with callees':>12s} {'sigs':>4s}  kernel")
        for name, row in sorted(compiled.items(), key=lambda kv: -kv[1][0])[: args.kernels]:
            print(f"{row[0]:7.2f} {row[1]:12.2f} {len(row[2]):4d}  {name}")
    out_path = Path(args.out)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    doc = {
        "mesh": args.mesh,
        "alone": args.alone,
        "repeats": args.repeats,
        "rows": rows,
        "total_cold_s": total,
        "cpu_s": cpu,
        "several_signatures": several,
        "kernels": compiled,
    }
    out_path.write_text(json.dumps(doc, indent=2))
    print(f"wrote {out_path}")
    bad = sorted(set(several) & set(ONE_SIGNATURE))
    if args.check and bad:
        print(f"FAIL: several signatures: {' '.join(bad)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
