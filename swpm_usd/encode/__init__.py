"""Encoders: one module per VIPM encoding, each a pure function from a mesh / collapse sequence to buffers.

``BUILDERS`` maps an encoding name to ``(function(mesh, **params) -> ProgressiveMesh, default params)``;
:func:`swpm_usd.build` dispatches through it, so a new encoding registers itself here.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..mesh import Mesh
from ..simplify import collapse_sequence
from .base import ENCODINGS, ProgressiveMesh, from_buffers
from .vanilla import VanillaInstance, VanillaProgressiveMesh, build_vanilla

#: parameters of the shared collapse sequence, accepted by every encoding built on it
SIMPLIFY_PARAMS: dict[str, Any] = {"boundary_weight": 8.0, "seam_weight": 2.0}


def _build_vanilla(mesh: Mesh, **params: Any) -> ProgressiveMesh:
    seq = collapse_sequence(mesh, **params)
    pm = build_vanilla(seq)
    pm.params.update(params)
    return pm


from .mixed import MIXED_PARAMS, build_mixed_mesh  # noqa: E402 (skip-strip / mixed entries)
from .skipstrip import SKIPSTRIP_PARAMS, build_skipstrip_mesh  # noqa: E402
from .slidingwindow import SLIDING_WINDOW_PARAMS  # noqa: E402
from .slidingwindow import build_sliding_window as _build_sliding_window  # noqa: E402

BUILDERS: dict[str, tuple[Callable[..., ProgressiveMesh], dict[str, Any]]] = {
    "sliding-window": (_build_sliding_window, {**SIMPLIFY_PARAMS, **SLIDING_WINDOW_PARAMS}),
    "vanilla": (_build_vanilla, dict(SIMPLIFY_PARAMS)),
    "skip-strip": (build_skipstrip_mesh, {**SIMPLIFY_PARAMS, **SKIPSTRIP_PARAMS}),
    "mixed": (build_mixed_mesh, {**SIMPLIFY_PARAMS, **MIXED_PARAMS}),
}

__all__ = [
    "BUILDERS",
    "ENCODINGS",
    "SIMPLIFY_PARAMS",
    "ProgressiveMesh",
    "VanillaInstance",
    "VanillaProgressiveMesh",
    "build_vanilla",
    "from_buffers",
]
