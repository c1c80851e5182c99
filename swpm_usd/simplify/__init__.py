"""Half-edge collapse simplification (quadric error order) shared by every encoding."""

from .sequence import CollapseSequence, MeshTopology, collapse_sequence, make_state, mesh_topology

__all__ = ["CollapseSequence", "MeshTopology", "collapse_sequence", "make_state", "mesh_topology"]
