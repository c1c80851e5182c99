"""Benchmark every encoding against meshoptimizer, the independent yardstick.

For each mesh (default: every mesh in ../shared/meshes, plus a generated 1,000,000-triangle bumpy torus)
and each registered encoding: build seconds (median of 3 after one warm-up, in a fresh process so peak RSS
is that build's), LOD count, lambda (index dataset over the LOD-0 index count), ACMR at FIFO 16 and 32 and
surface error (Hausdorff and RMS over the bounding-box diagonal, exact point-to-triangle distances) at 100,
50, 25 and 10 % of the triangles. Beside them, measured in the same run on the same triangle counts:
meshoptimizer's ``optimize_vertex_cache`` ACMR on our LOD's own triangles, and the error of its
``simplify`` at the same triangle count; and the LOD's reported error (``error_at``, what ``lod_for_error``
and the USD thresholds select by) over its measured Hausdorff distance.

Then a summary per encoding, the figures a note quotes: lambda (mean over the meshes), ACMR ratios (FIFO 16,
at 100/50/25/10 %) within issue 4's target (1.10) and the project's aim (1.05), Hausdorff ratios (at
50/25/10 %) within the target (1.5) and the aim (1.25), their geometric mean, and reported over measured
error within [2/3, 3/2].

    python benchmarks/run.py [MESH ...] [--encodings vanilla,sliding-window] [--no-large] [--out FILE]

Prints a table and writes JSON (default ``benchmarks/results/run.json``).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SHARED = ROOT.parent / "shared" / "meshes"
FRACTIONS = (1.0, 0.5, 0.25, 0.1)
LARGE = "generated:torus-1M"


def large_torus(n_major: int = 1000, n_minor: int = 500):
    """A closed genus-1 torus with smooth bumps: 2 * n_major * n_minor triangles (1,000,000 by default)."""
    from swpm_usd.mesh import Mesh

    u = np.linspace(0, 2 * np.pi, n_major, endpoint=False)
    v = np.linspace(0, 2 * np.pi, n_minor, endpoint=False)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    r = 0.3 * (1.0 + 0.08 * np.sin(7 * uu) * np.cos(5 * vv) + 0.03 * np.sin(23 * uu + 11 * vv))
    pts = np.stack(
        [(1 + r * np.cos(vv)) * np.cos(uu), (1 + r * np.cos(vv)) * np.sin(uu), r * np.sin(vv)], -1
    ).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")
    a = i * n_minor + j
    b = ((i + 1) % n_major) * n_minor + j
    c = ((i + 1) % n_major) * n_minor + (j + 1) % n_minor
    d = i * n_minor + (j + 1) % n_minor
    tris = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return Mesh(points=pts, triangles=tris, source=LARGE)


def load(spec: str):
    from swpm_usd.io import load_mesh

    return large_torus() if spec == LARGE else load_mesh(spec)


def index_dataset_size(pm) -> int:
    """Index entries stored once for all instances (what lambda divides by the LOD-0 index count)."""
    b = pm.buffers()
    if "index_pool" in b:
        return int(b["index_pool"].shape[0])
    return int(sum(v.shape[0] for name, v in b.items() if name.endswith("indices")))


def meshopt_acmr(tris: np.ndarray, vertex_count: int, cache: int) -> float:
    import meshoptimizer

    from swpm_usd.metrics import acmr

    idx = np.ascontiguousarray(tris, dtype=np.uint32).reshape(-1)
    dst = np.zeros_like(idx)
    meshoptimizer.optimize_vertex_cache(dst, idx, index_count=idx.size, vertex_count=vertex_count)
    return acmr(dst, cache_size=cache)


def meshopt_simplify(mesh, target_triangles: int) -> np.ndarray:
    import meshoptimizer

    idx = mesh.triangles.astype(np.uint32).reshape(-1)
    dst = np.zeros_like(idx)
    n = meshoptimizer.simplify(
        dst,
        idx,
        np.ascontiguousarray(mesh.points, dtype=np.float32),
        index_count=idx.size,
        vertex_count=mesh.vertex_count,
        target_index_count=3 * target_triangles,
        target_error=1e3,
    )
    return dst[:n].reshape(-1, 3).astype(np.int32)


def worker(spec: str, encoding: str, repeats: int, error_samples: int) -> dict:
    """Runs in a fresh process: build timings, peak RSS and quality figures for one mesh and encoding."""
    import swpm_usd
    from swpm_usd.metrics import acmr, surface_error

    mesh = load(spec)
    swpm_usd.build(mesh, encoding)  # warm-up: numba kernels compiled or loaded from cache
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        pm = swpm_usd.build(mesh, encoding)
        times.append(time.perf_counter() - t)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    t0 = pm.triangle_count_at(0)
    out = {
        "mesh": spec,
        "encoding": encoding,
        "triangles": mesh.triangle_count,
        "vertices": mesh.vertex_count,
        "build_s_median": statistics.median(times),
        "build_s_all": times,
        "peak_rss_mb": rss / 2**20,
        "lod_count": pm.lod_count,
        "lambda": index_dataset_size(pm) / (3 * t0),
        "global_bytes": pm.global_bytes,
        "instance_bytes": pm.instance_bytes,
        "points": [],
    }
    for f in FRACTIONS:
        k = pm.lod_for_triangles(int(round(f * t0)))
        tris = pm.triangles_at(k)
        kind, stream = pm.draw_stream(k)
        row = {
            "fraction": f,
            "lod": k,
            "triangles": int(tris.shape[0]),
            "acmr16": acmr(stream, 16, kind=kind, restart_index=pm.restart_index),
            "acmr32": acmr(stream, 32, kind=kind, restart_index=pm.restart_index),
            "meshopt_acmr16": meshopt_acmr(tris, pm.vertex_count, 16),
            "meshopt_acmr32": meshopt_acmr(tris, pm.vertex_count, 32),
        }
        if error_samples and f < 1.0:
            ours = surface_error(mesh.points, mesh.triangles, pm.points, tris, samples=error_samples)
            mo = meshopt_simplify(mesh, tris.shape[0])
            theirs = surface_error(mesh.points, mesh.triangles, mesh.points, mo, samples=error_samples)
            diag = float(np.linalg.norm(mesh.points.max(axis=0) - mesh.points.min(axis=0)))
            row.update(
                reported_error=pm.error_at(k) / diag,
                hausdorff=ours.hausdorff,
                rms=ours.rms,
                meshopt_triangles=int(mo.shape[0]),
                meshopt_hausdorff=theirs.hausdorff,
                meshopt_rms=theirs.rms,
            )
        out["points"].append(row)
    return out


def print_table(results: list[dict]) -> None:
    head = (
        f"{'mesh':<22} {'encoding':<15} {'T':>8} {'build s':>8} {'RSS MB':>7} {'LODs':>7} {'lambda':>6} "
        f"{'%':>4} {'ACMR16':>6} {'/mo':>5} {'ACMR32':>6} {'/mo':>5} {'H 1e-3':>7} {'/mo':>5} {'RMS 1e-3':>8}"
    )
    print(head)
    print("-" * len(head))
    for r in results:
        if "failed" in r:
            print(f"{Path(r['mesh']).name:<22} {r['encoding']:<15} FAILED: {r['failed'][:80]}")
            continue
        for i, p in enumerate(r["points"]):
            lead = (
                f"{Path(r['mesh']).name:<22} {r['encoding']:<15} {r['triangles']:>8} "
                f"{r['build_s_median']:>8.3f} "
                f"{r['peak_rss_mb']:>7.0f} {r['lod_count']:>7} {r['lambda']:>6.2f}"
                if i == 0
                else " " * 78
            )
            h = p.get("hausdorff")
            err = (
                f"{1e3 * h:>7.3f} {h / max(p['meshopt_hausdorff'], 1e-12):>5.2f} {1e3 * p['rms']:>8.3f}"
                if h is not None
                else f"{'':>7} {'':>5} {'':>8}"
            )
            print(
                f"{lead} {int(100 * p['fraction']):>4} {p['acmr16']:>6.3f} "
                f"{p['acmr16'] / p['meshopt_acmr16']:>5.2f} "
                f"{p['acmr32']:>6.3f} {p['acmr32'] / p['meshopt_acmr32']:>5.2f} {err}"
            )


#: issue 4's targets and the project's aims, as ratios to meshoptimizer (see the module docstring)
ACMR_TARGET, ACMR_AIM = 1.10, 1.05
ERROR_TARGET, ERROR_AIM = 1.5, 1.25
#: reported error over measured: "calibrated" inside this band
CALIBRATION = (2 / 3, 3 / 2)


def summarize(results: list[dict]) -> dict[str, dict]:
    """Per encoding: how many points meet each target and aim, over every mesh with quality figures."""
    by_encoding: dict[str, dict] = {}
    for r in results:
        if "failed" in r:
            continue
        fresh: dict[str, list] = {"lambda": [], "acmr": [], "error": [], "calibration": []}
        acc = by_encoding.setdefault(r["encoding"], fresh)
        acc["lambda"].append(r["lambda"])
        for p in r["points"]:
            acc["acmr"].append(p["acmr16"] / p["meshopt_acmr16"])
            if p.get("hausdorff") is not None:
                acc["error"].append(p["hausdorff"] / max(p["meshopt_hausdorff"], 1e-12))
                acc["calibration"].append(p["reported_error"] / max(p["hausdorff"], 1e-12))
    summary = {}
    for enc, acc in by_encoding.items():
        acmr_r, err_r, cal = (np.asarray(acc[k], np.float64) for k in ("acmr", "error", "calibration"))
        summary[enc] = {
            "meshes": len(acc["lambda"]),
            "lambda_mean": float(np.mean(acc["lambda"])),
            "acmr_points": int(acmr_r.size),
            "acmr_within_target": int(np.sum(acmr_r <= ACMR_TARGET)),
            "acmr_within_aim": int(np.sum(acmr_r <= ACMR_AIM)),
            "acmr_ratio_mean": float(acmr_r.mean()) if acmr_r.size else None,
            "acmr_ratio_max": float(acmr_r.max()) if acmr_r.size else None,
            "error_points": int(err_r.size),
            "error_within_target": int(np.sum(err_r <= ERROR_TARGET)),
            "error_within_aim": int(np.sum(err_r <= ERROR_AIM)),
            "error_ratio_geomean": float(np.exp(np.log(err_r).mean())) if err_r.size else None,
            "calibrated": int(np.sum((cal >= CALIBRATION[0]) & (cal <= CALIBRATION[1]))),
            "calibration_geomean": float(np.exp(np.log(np.maximum(cal, 1e-12)).mean())) if cal.size else None,
        }
    return summary


def print_summary(summary: dict[str, dict]) -> None:
    print(
        f"\n{'encoding':<15} {'meshes':>6} {'lambda':>6}  {'ACMR <=1.10':>11} {'<=1.05':>7} {'mean':>5} "
        f"{'max':>5}  {'error <=1.5':>11} {'<=1.25':>7} {'geo':>5}  {'rep/meas ok':>11} {'geo':>5}"
    )
    for enc, s in summary.items():
        n_a, n_e = s["acmr_points"], s["error_points"]
        err = (
            f"{s['error_within_target']:>5}/{n_e:<5} {s['error_within_aim']:>3}/{n_e:<3} "
            f"{s['error_ratio_geomean']:>5.2f}  {s['calibrated']:>5}/{n_e:<5} "
            f"{s['calibration_geomean']:>5.2f}"
            if n_e
            else ""
        )
        print(
            f"{enc:<15} {s['meshes']:>6} {s['lambda_mean']:>6.2f}  {s['acmr_within_target']:>5}/{n_a:<5} "
            f"{s['acmr_within_aim']:>3}/{n_a:<3} {s['acmr_ratio_mean']:>5.3f} "
            f"{s['acmr_ratio_max']:>5.3f}  {err}"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshes", nargs="*", help="mesh files (default: every mesh in ../shared/meshes)")
    ap.add_argument("--encodings", default=None, help="comma-separated (default: every registered encoding)")
    ap.add_argument("--no-large", action="store_true", help="skip the generated 1M-triangle torus")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--samples", type=int, default=200_000, help="surface samples each way for the error")
    ap.add_argument("--out", default=str(HERE / "results" / "run.json"))
    ap.add_argument("--worker", nargs=2, metavar=("MESH", "ENCODING"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker[0], args.worker[1], args.repeats, args.samples)))
        return
    from swpm_usd.encode import BUILDERS

    encodings = args.encodings.split(",") if args.encodings else list(BUILDERS)
    meshes = args.meshes or sorted(str(p) for p in SHARED.glob("*.obj"))
    if not args.no_large:
        meshes.append(LARGE)
    results = []
    for spec in meshes:
        for enc in encodings:
            samples = 0 if spec == LARGE else args.samples
            cmd = [sys.executable, __file__, "--worker", spec, enc, "--repeats", str(args.repeats)]
            cmd += ["--samples", str(samples)]
            proc = subprocess.run(cmd, capture_output=True, text=True, env=dict(os.environ))
            if proc.returncode != 0:
                results.append(
                    {"mesh": spec, "encoding": enc, "failed": proc.stderr.strip().splitlines()[-1:]}
                )
            else:
                results.append(json.loads(proc.stdout.strip().splitlines()[-1]))
            print(f"  done {Path(spec).name} {enc}", file=sys.stderr)
    print_table(results)
    summary = summarize(results)
    print_summary(summary)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(
        json.dumps({"results": results, "fractions": FRACTIONS, "summary": summary}, indent=2)
    )
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
