"""swpm-usd: view-independent progressive meshes (vanilla, skip-strip, mixed, sliding window) for LOD."""

from __future__ import annotations

__version__ = "0.7.0"

# first: in the swpm-pipeline command, a Ctrl-C during the imports below exits 130 with one line
from . import _startup  # noqa: F401, I001 - (its import sets the handler: see swpm_usd._startup)

from .usd import plugin as _usd_plugin  # noqa: F401, I001 - registers SwpmMeshAPI before any stage use

from .build import build
from .encode import ProgressiveMesh, from_buffers
from .errors import BuildError, MeshLoadError, SwpmError
from .format import load, save, validate
from .mesh import Mesh


def load_mesh(path, **kwargs):  # noqa: ANN001, ANN201 - thin re-export, see swpm_usd.io.load_mesh
    """Load a mesh file (see :func:`swpm_usd.io.load_mesh`)."""
    from .io import load_mesh as _load

    return _load(path, **kwargs)


__all__ = [
    "BuildError",
    "Mesh",
    "MeshLoadError",
    "ProgressiveMesh",
    "SwpmError",
    "__version__",
    "build",
    "from_buffers",
    "load",
    "load_mesh",
    "save",
    "validate",
]
