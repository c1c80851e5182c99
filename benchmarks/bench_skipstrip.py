"""Benchmark of the skip-strip / mixed-mode encodings against vanilla and meshoptimizer (Forsyth's table).

For bunny, cow and spot and each encoding (vanilla, skip-strip strips with restart index, strips with
degenerate joins, skip lists, mixed-mode lists): ACMR per drawn (non-degenerate) triangle through a FIFO
cache of 16 at 100/50/25/10 % of the triangles, against meshoptimizer's strip-optimised mesh of the same
triangles (``optimize_vertex_cache_strip`` + ``meshopt_stripify`` with a restart index); the worst fraction
of collapse-degenerate triangles drawn at any LOD (strip joins counted apart), the level count, global and
instance bytes, and the index writes per collapse (LOD-change CPU cost). Mixed mode's two draws are measured
separately (cache flushed between draw calls). Writes ``benchmarks/results/skipstrip.json``.

Run: ``python benchmarks/bench_skipstrip.py [mesh ...]``.
"""

from __future__ import annotations

import ctypes
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from swpm_usd.encode.mixed import build_mixed
from swpm_usd.encode.skipstrip import build_skipstrip
from swpm_usd.encode.strips import decode_strip
from swpm_usd.encode.vanilla import build_vanilla
from swpm_usd.io import load_mesh
from swpm_usd.metrics import cache_misses
from swpm_usd.simplify import collapse_sequence

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT.parent / "shared" / "meshes"
RESULTS = ROOT / "benchmarks" / "results"
FRACTIONS = (1.0, 0.5, 0.25, 0.1)
CACHE = 16


def _meshopt_strip_acmr(tris: np.ndarray, vertex_count: int) -> float:
    """ACMR of meshoptimizer's optimize_vertex_cache_strip + stripify (restart 0xFFFFFFFF) on ``tris``."""
    import meshoptimizer as mo

    lib = ctypes.CDLL(mo._loader.lib._name)
    fn = lib.meshopt_stripify
    fn.restype = ctypes.c_size_t
    P = ctypes.POINTER(ctypes.c_uint)
    fn.argtypes = [P, P, ctypes.c_size_t, ctypes.c_size_t, ctypes.c_uint]
    idx = np.ascontiguousarray(tris, dtype=np.uint32).reshape(-1)
    opt = np.empty_like(idx)
    mo.optimize_vertex_cache_strip(opt, idx, idx.size, vertex_count)
    dst = np.empty(idx.size // 3 * 5 + 8, np.uint32)
    n = fn(dst.ctypes.data_as(P), opt.ctypes.data_as(P), idx.size, vertex_count, 0xFFFFFFFF)
    m, t = cache_misses(dst[:n], CACHE, "strip", 0xFFFFFFFF)
    return m / t


def _acmr(pm: Any, k: int) -> float:
    if pm.encoding == "mixed":
        misses = tris = 0
        for _, idx in pm.draw_calls(k):
            m, t = cache_misses(idx, CACHE)
            misses += m
            tris += t
        return misses / tris
    kind, s = pm.draw_stream(k)
    m, t = cache_misses(s, CACHE, "strip" if kind == "strip" else "triangles", pm.restart_index)
    return m / t


def _degenerate_stats(pm: Any) -> tuple[float, float]:
    """(worst collapse-degenerate fraction over all LODs, worst join-degenerate fraction of a level)."""
    if pm.encoding != "skip-strip":
        return 0.0, 0.0
    level_tris = np.array([pm.level_triangle_count(lvl) for lvl in range(pm.level_count)])
    lvl_of = np.searchsorted(pm.level_first_lod, np.arange(pm.lod_count), side="right") - 1
    worst = float(np.max(1 - pm.triangle_counts / level_tris[lvl_of]))
    joins = 0.0
    if pm.primitive == "strip" and pm.restart_index is None:
        for lvl in range(pm.level_count):
            allt = len(decode_strip(pm.level_list(lvl), None, keep_degenerate=True))
            joins = max(joins, (allt - level_tris[lvl]) / max(allt, 1))
    return worst, joins


def _writes_per_collapse(pm: Any) -> float:
    return float(pm.collapse_change_offsets.shape[0] / max(pm.collapse_kept.shape[0], 1))


def run(names: list[str]) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    for name in names:
        mesh = load_mesh(MESHES / f"{name}.obj")
        t0 = time.perf_counter()
        seq = collapse_sequence(mesh)
        t_seq = time.perf_counter() - t0
        builders = {
            "vanilla": lambda s: build_vanilla(s),
            "skip-strip/strip": lambda s: build_skipstrip(s, primitive="strip", restart=True),
            "skip-strip/strip-degen": lambda s: build_skipstrip(s, primitive="strip", restart=False),
            "skip-strip/list": lambda s: build_skipstrip(s, primitive="list"),
            "mixed": lambda s: build_mixed(s),
        }
        ref_cache: dict[int, float] = {}
        for enc, fn in builders.items():
            t0 = time.perf_counter()
            pm = fn(seq)
            t_build = time.perf_counter() - t0
            row: dict[str, Any] = {
                "mesh": name,
                "encoding": enc,
                "T0": int(pm.triangle_counts[0]),
                "V": pm.vertex_count,
                "lods": pm.lod_count,
                "levels": int(getattr(pm, "level_count", 1)),
                "global_bytes": pm.global_bytes,
                "instance_bytes": pm.instance_bytes,
                "vertex_bytes": pm.vertex_bytes(),
                "writes_per_collapse": round(_writes_per_collapse(pm), 3),
                "build_s": round(t_build, 3),
                "sequence_s": round(t_seq, 3),
            }
            deg, joins = _degenerate_stats(pm)
            row["max_degenerate_fraction"] = round(deg, 4)
            row["max_join_degenerate_fraction"] = round(joins, 4)
            for f in FRACTIONS:
                k = pm.lod_for_triangles(int(round(f * pm.triangle_counts[0])))
                if k not in ref_cache:
                    ref_cache[k] = _meshopt_strip_acmr(pm.triangles_at(k), pm.vertex_count)
                a = _acmr(pm, k)
                row[f"acmr_{int(f * 100)}"] = round(a, 4)
                row[f"meshopt_{int(f * 100)}"] = round(ref_cache[k], 4)
                row[f"ratio_{int(f * 100)}"] = round(a / ref_cache[k], 4)
            rows.append(row)
            print(_fmt(row), flush=True)
    return rows


def _fmt(r: dict[str, Any]) -> str:
    pts = " ".join(
        f"{r[f'acmr_{p}']:.3f}/{r[f'meshopt_{p}']:.3f}({r[f'ratio_{p}']:.2f})" for p in (100, 50, 25, 10)
    )
    return (
        f"{r['mesh']:15s} {r['encoding']:23s} {pts}  deg {r['max_degenerate_fraction']:.3f}"
        f" joins {r['max_join_degenerate_fraction']:.3f} levels {r['levels']:3d}"
        f" global {r['global_bytes']:9d} inst {r['instance_bytes']:8d} w/c {r['writes_per_collapse']:.2f}"
    )


def main() -> None:
    names = sys.argv[1:] or ["stanford-bunny", "cow", "spot"]
    print("mesh            encoding                ACMR@16 ours/meshopt-strip(ratio) at 100 / 50 / 25 / 10 %")
    rows = run(names)
    RESULTS.mkdir(parents=True, exist_ok=True)
    out = RESULTS / "skipstrip.json"
    out.write_text(json.dumps({"cache_size": CACHE, "rows": rows}, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
