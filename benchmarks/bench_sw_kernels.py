"""CPU time of the sliding-window build's deviation ranking, patch collapses and LOD-error replay, alone.

One inline build of each mesh (the kernels compiled by a build before it) captures the inputs of every call
of :func:`swpm_usd.encode.sw_deviation.deviation_costs` (the ranking pass over every position and the sampled
pass over the costliest share), :func:`swpm_usd.encode.sw_collapse.collapse_patches` and
:func:`swpm_usd.simplify.fan_deviation.replay_deviations`; then each kernel runs again on copies of its
inputs (the copies made outside the timing), ``--rounds`` times, the kernels of a round in turn. Prints per
kernel the median over the rounds of its summed thread CPU time, and a digest of its outputs (two trees
whose digests match computed the same values, bit for bit).

    python benchmarks/bench_sw_kernels.py MESH.obj [MESH.obj ...] [--rounds 7]
"""

from __future__ import annotations

import argparse
import copy
import hashlib
import time

import numpy as np

import swpm_usd
import swpm_usd.encode.slidingwindow as sw
from swpm_usd.encode import sw_collapse, sw_threads
from swpm_usd.encode import sw_deviation as swd
from swpm_usd.io import load_mesh
from swpm_usd.simplify import fan_deviation as fd

_KERNELS = [
    ("deviation (ranking pass)", swd, "deviation_costs", lambda a: a[7].shape[0] == 0),
    ("deviation (sampled pass)", swd, "deviation_costs", lambda a: a[7].shape[0] > 0),
    ("collapse_patches", sw_collapse, "collapse_patches", None),
    ("replay_deviations", fd, "replay_deviations", None),
]


def capture(mesh) -> dict:
    """The arguments of every call of the kernels in one inline build of ``mesh``."""
    calls: dict = {name: [] for name in ("deviation_costs", "collapse_patches", "replay_deviations")}
    saved = []
    for _, mod, name, _ in _KERNELS:
        if (mod, name) in [(m, n) for m, n, _ in saved]:
            continue
        fn = getattr(mod, name)

        def wrapped(*args, _fn=fn, _name=name):
            calls[_name].append(copy.deepcopy(args))
            return _fn(*args)

        saved.append((mod, name, fn))
        setattr(mod, name, wrapped)
    finish, adapt = sw.FINISH_IN_THREAD, sw_threads.ADAPT_TO_LOAD
    sw.FINISH_IN_THREAD = False  # inline: every deviation row in deviation_costs
    try:
        swpm_usd.build(mesh, encoding="sliding-window")
    finally:
        sw.FINISH_IN_THREAD = finish
        sw_threads.ADAPT_TO_LOAD = adapt
        for mod, name, fn in saved:
            setattr(mod, name, fn)
    return calls


def _digest(h, value) -> None:
    if isinstance(value, tuple):
        for v in value:
            _digest(h, v)
    elif isinstance(value, np.ndarray):
        h.update(np.ascontiguousarray(value).tobytes())
    else:
        h.update(repr(value).encode())


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args()
    print("using", swpm_usd.__file__)
    for path in args.meshes:
        mesh = load_mesh(path)
        swpm_usd.build(mesh, encoding="sliding-window")  # compile
        calls = capture(mesh)
        times = {label: [] for label, *_ in _KERNELS}
        digests = {}
        for _ in range(args.rounds):
            for label, mod, name, pick in _KERNELS:
                fn = getattr(mod, name)
                h = hashlib.blake2b(digest_size=8)
                total = 0.0
                for a in calls[name]:
                    if pick is not None and not pick(a):
                        continue
                    a = copy.deepcopy(a)
                    c = time.thread_time()
                    out = fn(*a)
                    total += time.thread_time() - c
                    if name == "collapse_patches":
                        out = (out[0][: out[1]],) + out[1:]  # (gtris's rows past ng: not written)
                    _digest(h, out)
                times[label].append(total)
                digests[label] = h.hexdigest()
        print(f"{path}: {mesh.triangle_count} triangles, {args.rounds} rounds (median thread CPU, ms)")
        for label, *_ in _KERNELS:
            n = sum(1 for a in calls[_[1]] if _[2] is None or _[2](a))
            print(f"  {label:<26} {n:>4} calls {1e3 * np.median(times[label]):>9.2f} ms  {digests[label]}")


if __name__ == "__main__":
    main()
