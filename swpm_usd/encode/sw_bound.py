"""The error bound on a topology-driven level's patch centres (``error_bound``; SWPM 3's error control with
an absolute reference): the plain quadric collapse sequence's error (the vanilla order, Garland-Heckbert
quadrics) at a triangle count, which the level's centres may exceed only by a factor.

* :class:`SequenceReference` - the sequence's running maximum error at a triangle count.
* :func:`bar_costly` - a level's centres whose ranking cost passes the bound made ineligible.
"""

from __future__ import annotations

import numpy as np

from ..simplify import kernels as K
from .vanilla import collapse_records


class SequenceReference:
    """The plain quadric collapse sequence of a fresh simplifier state ``st`` (collapsed here: pass one of
    its own; ``triangles``: the mesh's, in its vertex ids): its running maximum error (a distance, ``sqrt``
    of the quadric cost, as :meth:`swpm_usd.simplify.CollapseSequence.lod_errors` without the fan
    deviation) once a given number of triangles is left (:meth:`error_at`)."""

    def __init__(self, st: K.CollapseState, triangles: np.ndarray) -> None:
        binned, kept, step, step_error, _, _ = K.run_sequence(st, 3, False)
        S = step_error.shape[0]
        # the triangles each vertex collapse removes, as the vanilla encoding replays them
        _, removed, _, _ = collapse_records(triangles, binned, kept, st.vertex_pos.shape[0])
        tri_after = triangles.shape[0] - np.r_[0, np.cumsum(removed)]
        steps_done = np.r_[0, np.cumsum(np.bincount(step, minlength=S))]  # vertex collapses after s steps
        #: triangles left after ``s`` steps and the running maximum error then (``s = 0 .. S``)
        self.alive = tri_after[steps_done]
        self.error = np.r_[0.0, np.maximum.accumulate(step_error)] if S else np.zeros(1)

    def error_at(self, triangles: float) -> float:
        """The running maximum error after the fewest steps that leave at most ``triangles`` (after the
        last step if the sequence never gets there)."""
        s = int(np.searchsorted(-self.alive, -float(triangles), side="left"))
        return float(self.error[min(s, self.error.shape[0] - 1)])


def bar_costly(
    eligible: np.ndarray, positions: np.ndarray, ks: np.ndarray, rank_cs: np.ndarray, bound2: float
) -> int:
    """Make ``positions`` with a valid collapse (``ks >= 0``) whose ranking cost ``rank_cs`` (squared
    distance: the quadric cost or the fan's deviation, the larger) passes ``bound2`` ineligible as patch
    centres, in place; returns how many were eligible before."""
    bar = positions[(ks >= 0) & (rank_cs > bound2)]
    barred = int(np.count_nonzero(eligible[bar]))
    eligible[bar] = False
    return barred
