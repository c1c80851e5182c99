"""USD I/O benchmark: write the bunny asset layer, read its buffers, open a 1,000-instance scene.

Targets (issue): write <= 100 ms, read buffers <= 10 ms, open + read every instance's window table <= 1 s.
Run ``python benchmarks/bench_usd.py [--repeat N]``; prints a table and writes
``benchmarks/results/bench_usd.json``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from pxr import Sdf, Usd, UsdGeom

import swpm_usd
from swpm_usd import usd

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT.parent / "shared" / "meshes"
if not MESHES.exists():
    MESHES = Path("/work/shared/meshes")


def _median(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def _scene(asset: Path, folder: Path, n: int) -> Path:
    layer = Sdf.Layer.CreateNew(str(folder / "scene.usdc"))
    stage = Usd.Stage.Open(layer)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    UsdGeom.SetStageUpAxis(stage, "Y")
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    with Sdf.ChangeBlock():
        for i in range(n):
            spec = Sdf.CreatePrimInLayer(layer, f"/World/i{i:04d}")
            spec.specifier = Sdf.SpecifierDef
            spec.typeName = "Xform"
            spec.referenceList.Prepend(Sdf.Reference(asset.name))
            spec.instanceable = True
    layer.Save()
    return folder / "scene.usdc"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--instances", type=int, default=1000)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        bunny = swpm_usd.build(MESHES / "stanford-bunny.obj", "vanilla")
        bunny.triangles_at(0)  # JIT warm-up outside the timing
        path = usd.write(bunny, tmp / "bunny.usdc")
        write_s = _median(lambda: usd.write(bunny, tmp / "bunny.usdc"), args.repeat)
        rows.append(
            ("write bunny asset layer (.usdc)", write_s, 0.100, f"{path.stat().st_size / 1e6:.2f} MB")
        )

        stage = Usd.Stage.Open(str(path))
        prim = stage.GetPrimAtPath("/Stanford_bunny/mesh") or usd.find_encoded(stage)[0]
        read_s = _median(lambda: usd.read_buffers(prim), args.repeat)
        rows.append(
            ("read bunny buffers (open stage)", read_s, 0.010, f"{len(usd.read_buffers(prim))} buffers")
        )

        def open_and_read() -> None:
            s = Usd.Stage.Open(str(path))
            usd.read_buffers(s.GetDefaultPrim())

        rows.append(("open layer + read bunny buffers", _median(open_and_read, args.repeat), None, ""))
        rows.append(("read bunny ProgressiveMesh", _median(lambda: usd.read(prim), args.repeat), None, ""))

        from swpm_usd.encode.slidingwindow import build_sliding_window

        sw = build_sliding_window(swpm_usd.load_mesh(MESHES / "spot.obj"))
        sw_asset = usd.write(sw, tmp / "spot_sw.usdc")
        scene = _scene(sw_asset, tmp, args.instances)
        expected = sw.buffers()["window_records"]

        def open_scene() -> int:
            s = Usd.Stage.Open(str(scene))
            n = 0
            pred = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
            for p in Usd.PrimRange(s.GetPseudoRoot(), pred):
                if p.GetName() == "mesh":
                    w = np.asarray(p.GetAttribute("swpm:windowRecords").Get()).reshape(-1, 3)
                    n += int(w.shape[0] == expected.shape[0])
            assert n == args.instances
            return n

        open_scene()
        rows.append(
            (
                f"open {args.instances}-instance scene + read every window table",
                _median(open_scene, 3),
                1.0,
                "",
            )
        )
    print(f"{'measurement':62} {'median':>10} {'target':>8}  note")
    for name, t, target, note in rows:
        tgt = f"{target * 1e3:.0f} ms" if target else "-"
        ok = "" if target is None else (" OK" if t <= target else " OVER")
        print(f"{name:62} {t * 1e3:8.1f} ms {tgt:>8}{ok}  {note}")
    out = ROOT / "benchmarks" / "results" / "bench_usd.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(
        json.dumps(
            {
                "python": platform.python_version(),
                "usd": Usd.GetVersion(),
                "repeat": args.repeat,
                "results": [
                    {"name": n, "median_s": t, "target_s": tgt, "note": note} for n, t, tgt, note in rows
                ],
            },
            indent=2,
        )
    )
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
