"""Threaded against inline sliding-window builds, with 0, 1 or 2 other busy processes on the cores.

    python benchmarks/bench_threads.py [MESH ...] [--busy 0,1,2] [--rounds 7]
        [--out benchmarks/results/threads.json]

A sliding-window build of 1,024 triangles and more finishes its levels on a worker thread and shares part
of each level's work with a helper thread, but only while the other processes leave a core free
(:func:`swpm_usd.encode.sw_threads.core_free`). This measures the choice: for each count of busy
processes (each a Python loop that spins for the whole measurement), warm builds of every MESH (default:
seven of the shared meshes; one of fewer than 1,024 triangles starts no thread, so
its ratio is 1) alternate between the threads forced on and forced off (round r starts with
the threads on when r is even), and the table gives the medians of the wall times and the median of the
per-round ratios threaded / inline, beside what ``core_free`` answers with that load. Below 1 the threads
pay. Medians of alternating rounds, because the machine is shared: other work moves a single figure.
No target: a yardstick for ``sw_threads.core_free``'s rule (threads while at most ``cores - 1`` cores are
busy with other processes).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
MESHES = HERE.parent.parent / "shared" / "meshes"
DEFAULT = ("cow", "beetle", "teapot", "bob", "spot", "fandisk", "stanford-bunny")
SPIN = "while True: pass"


def _measure(meshes: dict, rounds: int) -> list[dict]:
    import swpm_usd
    from swpm_usd.encode import slidingwindow as sw

    rows = []
    for name, mesh in meshes.items():
        times: dict[bool, list[float]] = {True: [], False: []}
        for r in range(rounds):
            for threaded in (True, False) if r % 2 == 0 else (False, True):
                sw.FINISH_IN_THREAD = threaded
                t0 = time.perf_counter()
                swpm_usd.build(mesh, encoding="sliding-window")
                times[threaded].append(time.perf_counter() - t0)
        sw.FINISH_IN_THREAD = True
        ratios = [a / b for a, b in zip(times[True], times[False], strict=True)]
        rows.append(
            {
                "mesh": name,
                "threaded_ms": 1e3 * statistics.median(times[True]),
                "inline_ms": 1e3 * statistics.median(times[False]),
                "ratio": statistics.median(ratios),
            }
        )
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("meshes", nargs="*", help="mesh files (default: seven of ../shared/meshes)")
    ap.add_argument("--busy", default="0,1,2", help="counts of busy processes, comma-separated")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--out", default=str(HERE / "results" / "threads.json"))
    args = ap.parse_args(argv)

    import swpm_usd
    from swpm_usd.encode import sw_threads as swt

    paths = [Path(p) for p in args.meshes] or [MESHES / f"{n}.obj" for n in DEFAULT]
    meshes = {p.stem: swpm_usd.load_mesh(p) for p in paths}
    for mesh in meshes.values():  # warm: compiles and caches, not measured
        swpm_usd.build(mesh, encoding="sliding-window")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    results = []
    for busy in (int(b) for b in args.busy.split(",")):
        spinners = [subprocess.Popen([sys.executable, "-c", SPIN]) for _ in range(busy)]
        try:
            time.sleep(1.0)
            swt.ADAPT_TO_LOAD = True
            swt._last_look.clear()
            swt.core_free(cores)  # the first look only starts the window
            time.sleep(1.0)
            answer = swt.core_free(cores)
            swt.ADAPT_TO_LOAD = False  # the build below forces its threads on or off
            rows = _measure(meshes, args.rounds)
        finally:
            for s in spinners:
                s.kill()
                s.wait()
            swt.ADAPT_TO_LOAD = True
        load = os.getloadavg()[0]
        print(f"\n{busy} busy process(es) on {cores} cores: core_free says {answer}, load {load:.2f}")
        print(f"{'mesh':16s} {'threaded ms':>12s} {'inline ms':>10s} {'ratio':>6s}")
        for row in rows:
            ms = f"{row['threaded_ms']:12.1f} {row['inline_ms']:10.1f}"
            print(f"{row['mesh']:16s} {ms} {row['ratio']:6.3f}")
        results.append({"busy": busy, "cores": cores, "core_free": answer, "rows": rows})
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps({"rounds": args.rounds, "results": results}, indent=1))
    os.replace(tmp, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
