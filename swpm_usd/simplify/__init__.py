"""Half-edge collapse simplification (quadric error order) shared by every encoding."""

from .. import numba_cache  # noqa: F401 (first: it stamps the kernels defined from here on)
from .sequence import CollapseSequence, MeshTopology, collapse_sequence, make_state, mesh_topology

__all__ = ["CollapseSequence", "MeshTopology", "collapse_sequence", "make_state", "mesh_topology"]
