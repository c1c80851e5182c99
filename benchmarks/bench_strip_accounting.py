"""Where a sliding-window strip pool's indices go: the pool split into the distinct triangles the windows draw
(the floor), triangles stored more than once, restart indices, each strip's first two indices, and degenerate
triangles (swaps and ``q q`` joins), in units of lambda (over three indices a LOD-0 triangle). Every strip
index is one of: a restart, one of its strip's first two, one that draws a triangle (one a list triangle of
the pool, which decodes exactly: floor + repeats) or one that draws a degenerate triangle.

    python benchmarks/bench_strip_accounting.py [MESH ...] [--options cluster-swap] [--levels]

``--levels`` prints the split level by level (the pool cut at each level's first window; a linked level's
range starts inside the previous level's tail). Repeats by where their earlier copy lies: the previous level
(a level stored in full repeats the previous level's last LOD) or older (a static middle or a linked patch's
untouched run stored again). ``slidingwindow.md``, "Where the strip indices go" (2026-12-05).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
MESHES = HERE.parent.parent / "shared" / "meshes"
OPTIONS = {"defaults": {}, "cluster-swap": {"cluster": True, "optimize_connectivity": True}}


def _canonical(t: np.ndarray) -> np.ndarray:
    r = np.argmin(t, axis=1)[:, None]
    return np.take_along_axis(t, (r + np.arange(3)) % 3, axis=1)


def account(lst, strip) -> tuple[dict, list[dict]]:
    """The split of ``strip``'s pool (``lst``: the same build's list pool), in lambda, and per level."""
    tris = np.asarray(lst.index_pool, np.int64).reshape(-1, 3)
    rec = np.asarray(lst.window_records, np.int64)
    srec = np.asarray(strip.window_records, np.int64)
    sp = np.asarray(strip.index_pool, np.int64)
    rv = strip.restart_index
    T, T0, S = tris.shape[0], int(rec[0, 1]), sp.shape[0]
    _, first, inv = np.unique(_canonical(tris), axis=0, return_index=True, return_inverse=True)
    inv = inv.reshape(-1)
    repeat = np.ones(T, bool)
    repeat[first] = False
    order = np.argsort(inv, kind="stable")
    prev = np.full(T, -1)
    same = inv[order][1:] == inv[order][:-1]
    prev[order[1:][same]] = order[:-1][same]
    lvl = np.asarray(lst.lod_level)
    levels = np.unique(lvl)
    lfirst = np.array([np.flatnonzero(lvl == L)[0] for L in levels])
    lstart = rec[lfirst, 0] // 3
    lend = np.array([(rec[lvl == L, 0] // 3 + rec[lvl == L, 1]).max() for L in levels])
    sstart = srec[lfirst, 0]
    # each strip index: a restart, one of its strip's first two, a triangle or a degenerate one
    isr = sp == rv
    seg = np.cumsum(isr)
    pos = np.arange(S) - np.r_[0, np.flatnonzero(isr) + 1][seg]
    a, b = np.r_[-1, -1, sp[:-2]], np.r_[-1, sp[:-1]]
    draws = ~isr & (pos >= 2)
    degenerate = draws & ((a == b) | (b == sp) | (a == sp))
    head = ~isr & (pos < 2)
    rows = []
    tb, sb = np.r_[lstart[1:], T], np.r_[sstart[1:], S]
    for k in range(levels.shape[0]):
        t0, t1, s0, s1 = lstart[k], tb[k], sstart[k], sb[k]
        rep = repeat[t0:t1]
        plev = np.searchsorted(lstart, prev[t0:t1], side="right") - 1
        rows.append(
            {
                "level": int(levels[k]),
                "lods": int((lvl == levels[k]).sum()),
                "linked": bool(k > 0 and lstart[k] < lend[k - 1]),
                "floor": int((~rep).sum()),
                "repeat_prev": int((rep & (plev == k - 1)).sum()),
                "repeat_older": int((rep & (plev != k - 1)).sum()),
                "restarts": int(isr[s0:s1].sum()),
                "heads": int(head[s0:s1].sum()),
                "degenerate": int(degenerate[s0:s1].sum()),
                "indices": int(s1 - s0),
            }
        )
    u = 3.0 * T0
    tot = {key: sum(r[key] for r in rows) / u for key in rows[0] if key not in ("level", "lods", "linked")}
    tot["lambda"] = S / u
    tot["lods_per_T0"] = rec.shape[0] / T0
    tot["levels"] = levels.shape[0]
    tot["linked"] = sum(r["linked"] for r in rows)
    tot["strips_per_lod"] = float(isr.sum() + 1) / rec.shape[0]
    tot["level0_lods"] = rows[0]["lods"] / rec.shape[0]
    return tot, rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("meshes", nargs="*", help="mesh files (default: every .obj of ../shared/meshes)")
    ap.add_argument("--options", default="cluster-swap", help="comma separated: " + ", ".join(OPTIONS))
    ap.add_argument("--levels", action="store_true", help="the split of every level too")
    args = ap.parse_args(argv)

    import swpm_usd

    paths = [Path(p) for p in args.meshes] or sorted(MESHES.glob("*.obj"))
    print(
        "| mesh | option | lambda | floor | repeats (previous level, older) | restarts | strip heads |"
        " degenerate | strips a LOD | LODs in level 0 | levels (linked) |"
    )
    print("|" + "---|" * 11)
    for path in paths:
        mesh = swpm_usd.load_mesh(path)
        for opt in args.options.split(","):
            lst = swpm_usd.build(mesh, encoding="sliding-window", **OPTIONS[opt])
            strip = swpm_usd.build(mesh, encoding="sliding-window", primitive="strip", **OPTIONS[opt])
            t, rows = account(lst, strip)
            rep = t["repeat_prev"] + t["repeat_older"]
            cells = [path.stem, opt] + [f"{t[k]:.3f}" for k in ("lambda", "floor")]
            cells += [f"{rep:.3f} ({t['repeat_prev']:.3f}, {t['repeat_older']:.3f})"]
            cells += [f"{t[k]:.3f}" for k in ("restarts", "heads", "degenerate")]
            cells += [f"{t['strips_per_lod']:.2f}", f"{100 * t['level0_lods']:.0f} %"]
            cells += [f"{t['levels']} ({t['linked']})"]
            print("| " + " | ".join(cells) + " |", flush=True)
            if args.levels:
                for r in rows:
                    print("   ", r)
    return 0


if __name__ == "__main__":
    sys.exit(main())
