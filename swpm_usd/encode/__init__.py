"""Encoders: one module per VIPM encoding, each a pure function from a mesh / collapse sequence to buffers.

``BUILDERS`` maps an encoding name to ``(function(mesh, **params) -> ProgressiveMesh, default params)``;
:func:`swpm_usd.build` dispatches through it, so a new encoding registers itself here (its builder) and in
:data:`swpm_usd.encodings.ENCODING_PARAMS` (its parameters, which configs and the command line check without
importing the encoders).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .. import numba_cache  # noqa: F401 (first: it stamps the kernels defined from here on)
from ..encodings import ENCODING_PARAMS, SIMPLIFY_PARAMS
from ..mesh import Mesh
from ..simplify import collapse_sequence
from .base import ENCODINGS, ProgressiveMesh, from_buffers
from .vanilla import VanillaInstance, VanillaProgressiveMesh, build_vanilla


def _build_vanilla(mesh: Mesh, **params: Any) -> ProgressiveMesh:
    seq = collapse_sequence(mesh, **params)
    pm = build_vanilla(seq)
    pm.params.update(params)
    return pm


from .mixed import build_mixed_mesh  # noqa: E402 (skip-strip / mixed entries)
from .skipstrip import build_skipstrip_mesh  # noqa: E402
from .slidingwindow import build_sliding_window as _build_sliding_window  # noqa: E402

_BUILDER_FUNCTIONS: dict[str, Callable[..., ProgressiveMesh]] = {
    "sliding-window": _build_sliding_window,
    "vanilla": _build_vanilla,
    "skip-strip": build_skipstrip_mesh,
    "mixed": build_mixed_mesh,
}
#: the defaults are :data:`swpm_usd.encodings.ENCODING_PARAMS`' (the same dicts), which names and checks
#: parameters without loading the encoders
BUILDERS: dict[str, tuple[Callable[..., ProgressiveMesh], dict[str, Any]]] = {
    name: (_BUILDER_FUNCTIONS[name], defaults) for name, defaults in ENCODING_PARAMS.items()
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
