"""USD schema and I/O for progressive meshes: the SwpmMeshAPI schema, writer, reader, overrides, validation.

Importing ``swpm_usd`` registers the schema plugin (:mod:`swpm_usd.usd.plugin`); everything else is loaded
lazily so ``import swpm_usd`` stays cheap. Public API:

- :func:`write` (asset layer per mesh), :func:`write_overrides` (non-destructive layer over a stage),
  :func:`write_usdlod` (UsdLod layer over an asset written with discrete LODs), :func:`select_lods`;
- :func:`read` (prim -> ProgressiveMesh), :func:`read_file` (path -> ProgressiveMesh), :func:`read_buffers`,
  :func:`find_encoded`;
- :func:`validate_stage` -> list of :class:`Finding`, :func:`stage_report` (the same as the SWPM reader's
  :class:`~swpm_usd.format.Report`, what :func:`swpm_usd.validate` gives for a stage),
  :func:`register_validators`.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from . import plugin as plugin

#: the suffixes of a USD stage: ``swpm-pipeline validate`` and :func:`swpm_usd.validate` check such a path as
#: a stage (:func:`validate_stage`), any other as an SWPM file
USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")

_EXPORTS = {
    "write": "writer",
    "write_usdlod": "writer",
    "select_lods": "writer",
    "read": "reader",
    "read_file": "reader",
    "read_buffers": "reader",
    "find_encoded": "reader",
    "write_overrides": "overrides",
    "validate_stage": "validate",
    "stage_report": "validate",
    "validate_prim": "validate",
    "register_validators": "validate",
    "Finding": "validate",
}

__all__ = sorted(_EXPORTS) + ["plugin"]


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
