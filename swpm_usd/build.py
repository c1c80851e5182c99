"""``swpm_usd.build``: one entry point for every encoding."""

from __future__ import annotations

import math
import numbers
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import BuildError
from .mesh import Mesh

if TYPE_CHECKING:  # (the encoders are imported by build() alone: see swpm_usd.encodings)
    from .encode.base import ProgressiveMesh

#: a FIFO larger than this models no GPU, and the cache simulations allocate arrays of this many entries
#: (``cache_size=10**9`` asked for 7.5 GiB)
MAX_CACHE_SIZE = 1024
#: the quadric weights of boundary and seam edges; larger ones overflow the collapse errors to inf
MAX_QUADRIC_WEIGHT = 1e6


def check_params(encoding: str, defaults: dict[str, Any], params: dict[str, Any]) -> None:
    """A :class:`BuildError` naming the parameter unless each value has its default's type (an integer,
    a finite number, a bool or a string; a ``None`` default is the encoder's to check) and the shared
    bounds: ``cache_size <= MAX_CACHE_SIZE``, quadric weights in ``[0, MAX_QUADRIC_WEIGHT]``."""
    for name, value in params.items():
        default = defaults[name]
        is_bool = isinstance(value, (bool, np.bool_))
        if isinstance(default, bool):
            ok, kind = is_bool, "true or false"
        elif isinstance(default, numbers.Integral):
            ok, kind = isinstance(value, numbers.Integral) and not is_bool, "an integer"
        elif isinstance(default, numbers.Real):
            ok = isinstance(value, numbers.Real) and not is_bool and math.isfinite(value)
            kind = "a finite number"
        elif isinstance(default, str):
            ok, kind = isinstance(value, str), "a string"
        else:
            continue
        if not ok:
            raise BuildError(f"{encoding} parameter {name} must be {kind}, got {value!r}")
    if "cache_size" in params:
        check_cache_size(params["cache_size"])
    for name in ("boundary_weight", "seam_weight"):
        if name in params and not 0.0 <= params[name] <= MAX_QUADRIC_WEIGHT:
            raise BuildError(f"{name} must be in [0, {MAX_QUADRIC_WEIGHT:g}], got {params[name]}")


def check_cache_size(cache_size: Any) -> None:
    """A :class:`BuildError` unless ``cache_size`` is in ``[1, MAX_CACHE_SIZE]``: :func:`build`'s check, and
    an encoder's called directly (``build_sliding_window(mesh, cache_size=10**9)``)."""
    if cache_size < 1:  # (the cache simulations' ValueError, a traceback in `build`)
        raise BuildError(f"cache_size must be at least 1, got {cache_size}")
    if cache_size > MAX_CACHE_SIZE:
        raise BuildError(f"cache_size must be at most {MAX_CACHE_SIZE}, got {cache_size}")


#: parameters recorded in ``pm.params`` (and so in a file's metadata) only when set: options added after
#: files without them were written (``error_bound``, 0.9.3), so a build that leaves them off writes the
#: same bytes as before they existed
RECORDED_WHEN_SET = frozenset({"error_bound"})


def build(mesh_or_path: Mesh | str | Path, encoding: str = "vanilla", **params: Any) -> ProgressiveMesh:
    """Build a :class:`ProgressiveMesh` of ``encoding`` from a mesh or a mesh file.

    ``params`` are the encoding's parameters (see ``swpm_usd.encode.BUILDERS[encoding][1]`` for the names
    and defaults); an unknown name raises :class:`BuildError`. The resolved parameters are in ``pm.params``.
    """
    from .encode import BUILDERS

    if encoding not in BUILDERS:
        from .param_hints import did_you_mean

        meant = did_you_mean(encoding, list(BUILDERS))
        raise BuildError(
            f"unknown encoding {encoding!r}; choose one of {sorted(BUILDERS)}{f' ({meant})' if meant else ''}"
        )
    fn, defaults = BUILDERS[encoding]
    unknown = sorted(set(params) - set(defaults))
    if unknown:
        from .param_hints import unknown_param_hint

        # (``mu=0.2`` under the default vanilla, a config's ``params={...}`` given whole: say what was meant)
        hints = []
        for name in unknown:
            if name == "params" and isinstance(params[name], dict):
                hints.append(f"{name}: give each parameter as a keyword, build(path, encoding, **params)")
            elif hint := unknown_param_hint(encoding, name):
                hints.append(f"{name}: {hint}")
        said = f" ({'; '.join(hints)})" if hints else ""
        raise BuildError(
            f"parameter(s) {', '.join(unknown)} do not belong to encoding {encoding!r}{said}; "
            f"it accepts {', '.join(sorted(defaults))}"
        )
    check_params(encoding, defaults, params)
    if isinstance(mesh_or_path, Mesh):
        mesh = mesh_or_path
    else:
        from .io import load_mesh

        mesh = load_mesh(mesh_or_path)
    resolved = {**defaults, **params}
    pm = fn(mesh, **resolved)
    # a None default leaves the choice to the encoder: the value it recorded stays (order_passes); an option
    # added later that is off is not recorded, so a build without it is byte for byte the file it was before
    # the option existed (nothing for a pipeline to rebuild)
    pm.params.update(
        {
            k: v
            for k, v in resolved.items()
            if (v is not None or k not in pm.params) and not (v is None and k in RECORDED_WHEN_SET)
        }
    )
    return pm
