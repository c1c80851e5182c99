"""Imported once by the pipeline's forkserver: build a tiny mesh with every encoding so the numba kernels are
loaded from their on-disk cache before the workers fork (each worker then starts with them in memory
instead of loading them again). Never raises: a failure only costs the workers their own warm-up."""

from __future__ import annotations


def warm() -> None:
    try:
        import numpy as np

        from ..build import build
        from ..encode import BUILDERS
        from ..format import encode_bytes, validate_bytes
        from ..mesh import Mesh
        from ..metrics import acmr
        from ..pipeline.worker import summarize

        # a closed, bumpy 12x8 torus: big enough for every builder to run its whole path
        u, v = np.meshgrid(np.arange(12) * (2 * np.pi / 12), np.arange(8) * (2 * np.pi / 8), indexing="ij")
        r = 0.3 + 0.05 * np.sin(3 * u)
        pts = np.stack([(1 + r * np.cos(v)) * np.cos(u), (1 + r * np.cos(v)) * np.sin(u), r * np.sin(v)], -1)
        i, j = np.meshgrid(np.arange(12), np.arange(8), indexing="ij")
        a, b = i * 8 + j, ((i + 1) % 12) * 8 + j
        c, d = ((i + 1) % 12) * 8 + (j + 1) % 8, i * 8 + (j + 1) % 8
        tris = np.concatenate(
            [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
        )
        mesh = Mesh(points=pts.reshape(-1, 3), triangles=tris)
        for enc in BUILDERS:
            pm = build(mesh, enc)
            summarize(pm)
            acmr(pm.draw_stream(0)[1])
            try:
                validate_bytes(encode_bytes(pm))
            except ValueError:
                pass
    except Exception:  # noqa: BLE001 - warming is an optimisation only
        pass


warm()
