"""The error bound on a topology-driven level's patch centres (``error_bound``; SWPM 3's error control with
an absolute reference): the plain quadric collapse sequence's error (the vanilla order, Garland-Heckbert
quadrics) at a triangle count, which the level's centres may exceed only by a factor.

* :func:`death_steps` - the step of a collapse sequence after which each triangle is gone.
* :class:`SequenceReference` - the sequence's running maximum error at a triangle count.
* :func:`bar_costly` - a level's centres whose ranking cost passes the bound made ineligible.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..simplify import kernels as K


@nb.njit(cache=True, nogil=True)
def death_steps(tri_pos: np.ndarray, step_b: np.ndarray, step_k: np.ndarray, P: int) -> np.ndarray:
    """Per triangle (positions ``tri_pos``), the step of the collapse sequence (``step_b[s]`` onto
    ``step_k[s]``) after which two of its corners are one position, or ``len(step_b)`` if never. Each
    position is binned once, onto a position alive then, so the chains of targets of two corners only merge:
    the triangle goes when the later corner reaches the first position both chains hold."""
    S = step_b.shape[0]
    binned_at = np.full(P, S, np.int64)
    onto = np.full(P, -1, np.int64)
    for s in range(S):
        binned_at[step_b[s]] = s
        onto[step_b[s]] = step_k[s]
    mark = np.full(P, -1, np.int64)
    arrive = np.zeros(P, np.int64)  # steps after which the marked corner has reached a marked position
    T = tri_pos.shape[0]
    out = np.empty(T, np.int64)
    for t in range(T):
        best = S
        for i in range(2):
            stamp = 2 * t + i
            p = tri_pos[t, i]
            at = np.int64(0)
            while True:
                mark[p] = stamp
                arrive[p] = at
                if onto[p] < 0:
                    break
                at = binned_at[p] + 1
                p = onto[p]
            for j in range(i + 1, 3):
                q = tri_pos[t, j]
                at = np.int64(0)
                while mark[q] != stamp:
                    if onto[q] < 0:
                        at = -1  # (the chains never meet)
                        break
                    at = binned_at[q] + 1
                    q = onto[q]
                if at >= 0:
                    best = min(best, max(max(at, arrive[q]) - 1, 0))
        out[t] = best
    return out


class SequenceReference:
    """The plain quadric collapse sequence of a fresh simplifier state ``st`` (collapsed here: pass one of
    its own; ``tri_pos``: its triangles' positions): its running maximum error (a distance, ``sqrt`` of the
    quadric cost, as :meth:`swpm_usd.simplify.CollapseSequence.lod_errors` without the fan deviation) once
    a given number of triangles is left (:meth:`error_at`)."""

    def __init__(self, st: K.CollapseState, tri_pos: np.ndarray) -> None:
        _, _, _, step_error, step_b, step_k = K.run_sequence(st, 3, False)
        S = step_error.shape[0]
        die = death_steps(
            np.ascontiguousarray(tri_pos, np.int64), step_b.astype(np.int64), step_k.astype(np.int64),
            st.pos_points.shape[0],
        )  # fmt: skip
        gone = np.cumsum(np.bincount(die, minlength=S + 1)[:S])  # gone after s + 1 steps
        #: triangles left after ``s`` steps and the running maximum error then (``s = 0 .. S``)
        self.alive = np.r_[tri_pos.shape[0], tri_pos.shape[0] - gone]
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
