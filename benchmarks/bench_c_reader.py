"""Benchmark of the C99 reader's ``swpm_open_ex`` (runtime/c/swpm_reader.h) against the Python validator.

    python benchmarks/bench_c_reader.py [MESH] [--encodings vanilla,sliding-window,skip-strip,mixed]
                                        [--repeat 50]

Builds MESH (default cow) in each encoding, writes it with ``swpm_usd.format.encode_bytes``, compiles a
timing program with the system ``cc -O2`` and prints, per encoding, the file's size and the minimum over
``--repeat`` runs of ``swpm_open_ex`` (the whole validation, CRC-32s and replays included, with a scratch of
the file's length) and of ``swpm_usd.format.validate_bytes`` on the same bytes (after one warm-up run each),
and their ratio. Minimums, as the machine may be shared: what a run costs when nothing else interferes.
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
    long n, i, repeat = atol(argv[2]);
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
        r = swpm_open_ex(data, (size_t)n, &f, scratch, (size_t)n);
        clock_gettime(CLOCK_MONOTONIC, &b);
        if (r.code) { fprintf(stderr, "%s at %llu\n", r.code, (unsigned long long)r.offset); return 1; }
        t = (b.tv_sec - a.tv_sec) * 1e3 + (b.tv_nsec - a.tv_nsec) / 1e6;
        if (i && t < best) best = t; /* run 0 is the warm-up */
    }
    printf("%.4f\n", best);
    return 0;
}
"""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("mesh", nargs="?", default=str(COW))
    ap.add_argument("--encodings", default="vanilla,sliding-window,skip-strip,mixed")
    ap.add_argument("--repeat", type=int, default=50)
    args = ap.parse_args(argv)
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
        print(f"{'encoding':16} {'bytes':>9} {'C open ms':>10} {'Python ms':>10} {'ratio':>7}")
        for enc in args.encodings.split(","):
            data = encode_bytes(swpm_usd.build(args.mesh, enc))
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
