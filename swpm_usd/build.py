"""``swpm_usd.build``: one entry point for every encoding."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .encode import BUILDERS
from .encode.base import ProgressiveMesh
from .errors import BuildError
from .mesh import Mesh


def build(mesh_or_path: Mesh | str | Path, encoding: str = "vanilla", **params: Any) -> ProgressiveMesh:
    """Build a :class:`ProgressiveMesh` of ``encoding`` from a mesh or a mesh file.

    ``params`` are the encoding's parameters (see ``swpm_usd.encode.BUILDERS[encoding][1]`` for the names
    and defaults); an unknown name raises :class:`BuildError`. The resolved parameters are in ``pm.params``.
    """
    if encoding not in BUILDERS:
        raise BuildError(f"unknown encoding {encoding!r}; choose one of {sorted(BUILDERS)}")
    fn, defaults = BUILDERS[encoding]
    unknown = sorted(set(params) - set(defaults))
    if unknown:
        raise BuildError(
            f"parameter(s) {', '.join(unknown)} do not belong to encoding {encoding!r}; "
            f"it accepts {', '.join(sorted(defaults))}"
        )
    if isinstance(mesh_or_path, Mesh):
        mesh = mesh_or_path
    else:
        from .io import load_mesh

        mesh = load_mesh(mesh_or_path)
    resolved = {**defaults, **params}
    pm = fn(mesh, **resolved)
    pm.params.update(resolved)
    return pm
