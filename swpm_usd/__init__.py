"""swpm-usd: view-independent progressive meshes (vanilla, skip-strip, mixed, sliding window) for LOD."""

from __future__ import annotations

__version__ = "0.9.7"

# first: in the swpm-pipeline command, a Ctrl-C during the imports below exits 130 with one line
from . import _startup  # noqa: F401, I001 - (its import sets the handler: see swpm_usd._startup)

from .usd import plugin as _usd_plugin  # noqa: F401, I001 - registers SwpmMeshAPI before any stage use

from ._lazy import lazy_attributes

# (build is light, importing the encoders when called; it is not lazy: the submodule of the same name,
# once imported, would be found where the function is expected)
from .build import build
from .errors import BuildError, MeshLoadError, SwpmError
from .mesh import Mesh

#: names re-exported from modules that load numba and the encoders, imported on first use
#: (:mod:`swpm_usd._lazy`): ``swpm-pipeline --help``, a config check or a run with nothing to build needs none
__getattr__, __dir__ = lazy_attributes(
    __name__,
    {
        "ProgressiveMesh": "encode",
        "from_buffers": "encode",
        "load": "format",
        "save": "format",
        "validate": "format",
        # the subpackages the package's import used to load, found as attributes after ``import swpm_usd``
        **{sub: sub for sub in ("encode", "format", "metrics", "simplify", "vcache")},
    },
)


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
