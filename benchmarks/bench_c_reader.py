"""Benchmark of the C99 reader's ``swpm_open_ex`` (runtime/c/swpm_reader.h) against the Python validator.

    python benchmarks/bench_c_reader.py [MESH] [--encodings vanilla,sliding-window,skip-strip,mixed]
                                        [--repeat 50]

Builds MESH (default cow) in each encoding, writes it with ``swpm_usd.format.encode_bytes``, compiles a
timing program with the system ``cc -O2`` and prints, per encoding, the file's size and the minimum over
``--repeat`` runs of ``swpm_open_ex`` (the whole validation, CRC-32s and replays included, with a scratch of
the file's length) and of ``swpm_usd.format.validate_bytes`` on the same bytes (after one warm-up run each),
and their ratio. Minimums, as the machine may be shared: what a run costs when nothing else interferes.

    python benchmarks/bench_c_reader.py --streaming [MESH...] [--repeat 20]

Streaming (spec/format.md 4.1), per mesh (default: every shared mesh) and encoding (sliding-window lists and
strips, vanilla, skip-strip, mixed): the file's bytes, the prefix the coarsest LOD needs, the LOD of about
10 % of LOD 0's triangles (``lod_for_triangles``) and LOD 0 (the whole file: VERT is last), each in bytes and
% of the file, and the time to open the coarsest LOD's prefix: ``swpm_open_prefix`` (``cc -O2``, scratch of
the file's length) and ``swpm_usd.format.open_prefix``, minimum of ``--repeat`` runs after a warm-up. Beside
the prefix, what a range reader (spec 4.2, ``swpm_usd.format.read_lod``: the header, then ``SMAP``'s ranges
for the LOD's band) fetches to draw the coarsest LOD and the 10 % LOD, in bytes and % of the file.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
RUNTIME = HERE.parent / "runtime" / "c"
COW = HERE.parent.parent / "shared" / "meshes" / "cow.obj"

TIMER = r"""
#define _POSIX_C_SOURCE 199309L /* clock_gettime under -std=c99 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#define SWPM_READER_IMPLEMENTATION
#include "swpm_reader.h"
int main(int argc, char **argv) {
    FILE *fp = fopen(argv[1], "rb");
    long n, i, repeat = atol(argv[2]), prefix = argc > 3 ? atol(argv[3]) : -1; /* -1: the whole file */
    uint8_t *data;
    void *scratch;
    double best = 1e30;
    swpm_file f;
    if (!fp) return 2;
    fseek(fp, 0, SEEK_END);
    n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    data = malloc((size_t)n);
    scratch = malloc((size_t)n);
    if (!data || !scratch || fread(data, 1, (size_t)n, fp) != (size_t)n) return 2;
    fclose(fp);
    for (i = 0; i <= repeat; i++) {
        struct timespec a, b;
        swpm_result r;
        double t;
        clock_gettime(CLOCK_MONOTONIC, &a);
        r = prefix < 0 ? swpm_open_ex(data, (size_t)n, &f, scratch, (size_t)n)
                       : swpm_open_prefix(data, (size_t)prefix, &f, scratch, (size_t)n);
        clock_gettime(CLOCK_MONOTONIC, &b);
        if (r.code) { fprintf(stderr, "%s at %llu\n", r.code, (unsigned long long)r.offset); return 1; }
        t = (b.tv_sec - a.tv_sec) * 1e3 + (b.tv_nsec - a.tv_nsec) / 1e6;
        if (i && t < best) best = t; /* run 0 is the warm-up */
    }
    printf("%.4f\n", best);
    return 0;
}
"""


STREAM_VARIANTS = {
    "sw-list": ("sliding-window", {}),
    "sw-strip": ("sliding-window", {"primitive": "strip", "cluster": True, "optimize_connectivity": True}),
    "vanilla": ("vanilla", {}),
    "skip-strip": ("skip-strip", {}),
    "mixed": ("mixed", {}),
}


def _pct(n: int, size: int) -> str:
    return f"{n:9d} {100 * n / size:5.1f}%"


def streaming(exe: Path, tmp: Path, meshes: list[str], repeat: int) -> None:
    """The --streaming table (see the module's docstring)."""
    import swpm_usd
    from swpm_usd.format import encode_bytes, open_prefix, read_lod

    print(
        f"{'mesh':16} {'encoding':10} {'bytes':>9} {'coarsest':>17} {'10 % LOD':>23} {'LOD 0':>9} "
        f"{'C open ms':>9} {'Py open ms':>10} {'ranges coarsest':>17} {'ranges 10 %':>17}"
    )
    for mesh in meshes:
        for name, (enc, kw) in STREAM_VARIANTS.items():
            pm = swpm_usd.build(mesh, enc, **kw)
            data = encode_bytes(pm)
            path = tmp / f"{name}.swpm"
            path.write_bytes(data)
            whole = open_prefix(data)
            L = whole.lod_count
            k10 = pm.lod_for_triangles(int(0.1 * int(pm.triangle_counts[0])))
            coarse, ten, zero = (whole.needed_bytes(k) for k in (L - 1, k10, 0))
            out = subprocess.run(
                [str(exe), str(path), str(repeat), str(coarse)], capture_output=True, text=True
            )
            if out.returncode:
                raise SystemExit(f"{mesh} {name}: {out.stderr.strip()}")
            part = data[:coarse]
            assert open_prefix(part).finest_drawable == L - 1
            py = []
            for _ in range(repeat + 1):
                t = time.perf_counter()
                open_prefix(part)
                py.append(time.perf_counter() - t)
            size = len(data)
            fetched = []
            for k in (L - 1, k10):  # a range reader's bytes: the union of what it fetched (header, SMAP's)
                fr = read_lod(lambda o, n, d=data: d[o : o + n], k, head=64)
                fetched.append(fr.held_bytes)
            print(
                f"{Path(mesh).stem:16} {name:10} {size:9d} {_pct(coarse, size):>17} "
                f"{f'(LOD {k10}) ' + _pct(ten, size):>23} {zero:9d} {float(out.stdout):9.3f} "
                f"{min(py[1:]) * 1e3:10.3f} {_pct(fetched[0], size):>17} {_pct(fetched[1], size):>17}",
                flush=True,
            )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("mesh", nargs="*", default=[])
    ap.add_argument("--encodings", default="vanilla,sliding-window,skip-strip,mixed")
    ap.add_argument("--repeat", type=int, default=50)
    ap.add_argument("--streaming", action="store_true", help="the prefix table (spec/format.md 4.1)")
    args = ap.parse_args(argv)
    if not args.streaming and len(args.mesh) > 1:
        ap.error("one MESH without --streaming")
    import swpm_usd
    from swpm_usd.format import encode_bytes, validate_bytes

    cc = shutil.which("cc")
    if cc is None:
        print("no C compiler (cc)", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        src, exe = Path(tmp) / "timer.c", Path(tmp) / "timer"
        src.write_text(TIMER)
        subprocess.run([cc, "-std=c99", "-O2", "-I", str(RUNTIME), "-o", str(exe), str(src)], check=True)
        if args.streaming:
            streaming(exe, Path(tmp), args.mesh or sorted(map(str, COW.parent.glob("*.obj"))), args.repeat)
            return 0
        mesh = args.mesh[0] if args.mesh else str(COW)
        print(f"{'encoding':16} {'bytes':>9} {'C open ms':>10} {'Python ms':>10} {'ratio':>7}")
        for enc in args.encodings.split(","):
            data = encode_bytes(swpm_usd.build(mesh, enc))
            path = Path(tmp) / f"{enc}.swpm"
            path.write_bytes(data)
            out = subprocess.run([str(exe), str(path), str(args.repeat)], capture_output=True, text=True)
            if out.returncode:
                print(f"{enc}: {out.stderr.strip()}", file=sys.stderr)
                return 1
            c_ms = float(out.stdout)
            assert not [p for p in validate_bytes(data).problems if p.severity == "error"]
            py = []
            for _ in range(args.repeat + 1):
                t = time.perf_counter()
                validate_bytes(data)
                py.append(time.perf_counter() - t)
            py_ms = min(py[1:]) * 1000
            print(f"{enc:16} {len(data):9d} {c_ms:10.3f} {py_ms:10.3f} {py_ms / c_ms:7.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
