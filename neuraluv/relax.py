"""Flip-free relaxation of a valid map with libigl's SLIM.

SLIM (Rabinovich et al. 2017) minimises the symmetric Dirichlet energy by
reweighted local/global steps with a line search that never crosses a flip,
so from a flip-free start (a Tutte map) every iterate is flip-free. It is the
SLIM baseline, and optionally the solver's start (``SolverConfig.start_relax``)
when a Tutte map is too crushed for first-order optimisation to leave it.
"""
from __future__ import annotations

import igl
import numpy as np

from neuraluv.jacobian import jacobians, local_frames
from neuraluv.metrics import face_metrics

__all__ = ["slim_relax", "slim_relax_until", "slim_relax_while"]


def _slim_data(V, F, UV0):
    return igl.slim_precompute(np.asfortranarray(V, dtype=np.float64), np.asfortranarray(F, dtype=np.int32),
                               np.asfortranarray(UV0, dtype=np.float64), igl.SYMMETRIC_DIRICHLET,
                               np.zeros(0, np.int32), np.zeros((0, 2), order="F"), 0.0)


def slim_relax(V, F, UV0, iterations=20):
    """Run ``iterations`` SLIM iterations on the symmetric Dirichlet energy.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV0 : (n,2) float array
        A flip-free start (orientation-preserving w.r.t. ``F``).
    iterations : int

    Returns
    -------
    UV : (n,2) float array, at the scale of ``V`` (no vertex pinned)

    Notes
    -----
    Minimises ``Σ_t A_t (‖J_t‖²_F + ‖J_t⁻¹‖²_F)`` (paper Eq. 1).

    Examples
    --------
    >>> from neuraluv.datasets import saddle
    >>> from neuraluv.tutte import tutte
    >>> from neuraluv.metrics import distortion_metrics
    >>> V, F = saddle(5)
    >>> UV0 = tutte(V, F)
    >>> m0, m1 = distortion_metrics(V, F, UV0), distortion_metrics(V, F, slim_relax(V, F, UV0, 5))
    >>> m1["flips"], bool(m1["esd"] < m0["esd"])
    (0, True)
    """
    uv = igl.slim_solve(_slim_data(V, F, UV0), int(iterations))
    return np.ascontiguousarray(np.asarray(uv)[:, :2])


def slim_relax_until(V, F, UV0, min_det, max_iterations=100, *, frames=None):
    """SLIM iterations, one at a time, until the smallest det J reaches ``min_det``.

    Used to un-crush a convex-boundary start just enough for first-order
    optimisation to move, without solving the problem for it.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV0 : (n,2) float array
        A flip-free start.
    min_det : float
        Stop as soon as every face has ``det J >= min_det``.
    max_iterations : int
        Upper bound on SLIM iterations.
    frames : (dC_inv (m,2,2), A (m,)), optional
        :func:`~neuraluv.jacobian.local_frames` of ``(V, F)``, when the caller
        has them (computed once otherwise, not once per iteration).

    Returns
    -------
    UV : (n,2) float array
    iterations : int
        SLIM iterations run (0 when ``UV0`` already satisfies ``min_det``).

    Examples
    --------
    >>> from neuraluv.datasets import glove
    >>> from neuraluv.tutte import tutte
    >>> from neuraluv.metrics import face_dets
    >>> V, F = glove()
    >>> UV0 = tutte(V, F)
    >>> round(float(face_dets(V, F, UV0).min()), 4)  # the glove's fingers are squeezed
    0.0048
    >>> slim_relax_until(V, F, UV0, 1e-3)[1]  # already above the target: untouched
    0
    >>> UV, its = slim_relax_until(V, F, UV0, 0.05)
    >>> its, bool(face_dets(V, F, UV).min() >= 0.05)
    (1, True)
    """
    F = np.asarray(F, np.int64)
    dC_inv = (local_frames(V, F) if frames is None else frames)[0]

    def smallest_det(UV):
        return face_metrics(jacobians(UV, F, dC_inv))["det"].min()

    UV = np.ascontiguousarray(np.asarray(UV0, float)[:, :2])
    if smallest_det(UV) >= min_det:
        return UV, 0
    data, it = _slim_data(V, F, UV), 0
    for it in range(1, int(max_iterations) + 1):
        UV = np.ascontiguousarray(np.asarray(igl.slim_solve(data, 1))[:, :2])
        if smallest_det(UV) >= min_det:
            break
    return UV, it


def slim_relax_while(V, F, UV0, accept, max_iterations=20):
    """SLIM iterations, one at a time, kept while ``accept(UV)`` holds.

    SLIM never crosses a flip but can let a free boundary run over itself; with
    ``accept`` checking that (e.g. :func:`~neuraluv.layout.overlap.boundary_is_simple`),
    the last accepted iterate is returned.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV0 : (n,2) float array
        A flip-free start (returned when the first iterate is not accepted).
    accept : callable ``(UV) -> bool``
    max_iterations : int

    Returns
    -------
    UV : (n,2) float array
    iterations : int
        Iterations accepted.

    Examples
    --------
    >>> from neuraluv.datasets import saddle
    >>> from neuraluv.tutte import tutte
    >>> from neuraluv.metrics import distortion_metrics
    >>> V, F = saddle(5)
    >>> UV0 = tutte(V, F)
    >>> UV, its = slim_relax_while(V, F, UV0, lambda uv: distortion_metrics(V, F, uv)["esd"] > 4.05)
    >>> bool(distortion_metrics(V, F, UV)["esd"] > 4.05), its < 20
    (True, True)
    """
    UV = np.ascontiguousarray(np.asarray(UV0, float)[:, :2])
    data, done = _slim_data(V, F, UV), 0
    for _ in range(int(max_iterations)):
        nxt = np.ascontiguousarray(np.asarray(igl.slim_solve(data, 1))[:, :2])
        if not accept(nxt):
            break
        UV, done = nxt, done + 1
    return UV, done
