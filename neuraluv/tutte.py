"""Tutte's embedding: a flip-free starting map for any disk.

Tutte (1963) and Floater (1997): fixing the boundary of a disk triangulation to
a convex polygon and placing every interior vertex at a convex combination of
its neighbours (positive weights) gives an injective map. The solver starts
from this map (Algorithm 1, line 3).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg

from neuraluv.errors import TopologyError
from neuraluv.jacobian import jacobians, local_frames
from neuraluv.spectral import cotangent_laplacian
from neuraluv.topology import boundary_loop

__all__ = ["circle_boundary", "tutte"]


def circle_boundary(V, bnd, radius=1.0):
    """Place the loop ``bnd`` on a circle, spaced by 3D arc length.

    Parameters
    ----------
    V : (n,3) float array
    bnd : (b,) int array
        Ordered boundary loop.
    radius : float

    Returns
    -------
    bc : (b,2) float array

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    >>> circle_boundary(V, np.arange(4)).round(6).tolist()
    [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [-0.0, -1.0]]
    """
    V = np.asarray(V, float)
    seg = np.linalg.norm(V[np.roll(bnd, -1)] - V[bnd], axis=1)
    total = seg.sum()
    if not total > 0:
        seg = np.ones(len(bnd))
        total = float(len(bnd))
    t = np.concatenate([[0.0], np.cumsum(seg)[:-1]]) / total * 2 * np.pi
    return radius * np.column_stack([np.cos(t), np.sin(t)])


def tutte(V, F, *, weights="uniform", bnd=None, frames=None):
    """Tutte embedding with the boundary on a circle of the chart's 3D area.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
        A disk-like chart.
    weights : {"uniform", "cotangent"}
        ``"uniform"`` (positive weights, flip-free by Tutte's theorem) or
        ``"cotangent"`` (the harmonic map; can fold on obtuse meshes — kept for
        teaching).
    bnd : (b,) int array, optional
        Boundary loop to pin; the longest loop by default.
    frames : (dC_inv (m,2,2), A (m,)), optional
        :func:`~neuraluv.jacobian.local_frames` of ``(V, F)``, when the caller
        has them (the areas and the orientation test use them).

    Returns
    -------
    UV : (n,2) float array
        Counter-clockwise oriented (det J > 0 relative to ``F``), circle radius
        ``sqrt(A/π)`` so the UV disk has the chart's 3D area.

    Notes
    -----
    Solves ``L_int u_int = -L_ib u_b`` with ``L = A - D`` (adjacency minus degree)
    for uniform weights.

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> from neuraluv.metrics import distortion_metrics
    >>> V, F = spherical_cap(n_rings=6)
    >>> distortion_metrics(V, F, tutte(V, F))["flips"]
    0
    """
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    n = len(V)
    if bnd is None:
        bnd = boundary_loop(F)
    if len(bnd) < 3:
        raise TopologyError("Tutte map needs a boundary loop of at least 3 vertices (is the chart closed?)")
    dC_inv, A = local_frames(V, F) if frames is None else frames
    area = A.sum()
    bc = circle_boundary(V, bnd, radius=np.sqrt(area / np.pi))
    if weights == "uniform":
        E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
        E = np.unique(np.sort(E, axis=1), axis=0)
        W = sp.coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n))
        W = (W + W.T).tocsr()
        W.data[:] = 1.0
        L = (W - sp.diags(np.asarray(W.sum(axis=1)).ravel())).tocsr()
    elif weights == "cotangent":
        L = cotangent_laplacian(V, F).tocsr()
    else:
        raise ValueError(f"weights must be 'uniform' or 'cotangent', got {weights!r}")
    interior = np.setdiff1d(np.arange(n), bnd)
    UV = np.zeros((n, 2))
    UV[bnd] = bc
    if len(interior):
        Lii = L[interior][:, interior].tocsc()
        rhs = -(L[interior][:, bnd] @ bc)
        UV[interior] = scipy.sparse.linalg.spsolve(Lii, rhs).reshape(-1, 2)
    # orientation: make the map orientation-preserving w.r.t. F's winding
    if np.sum(A * np.linalg.det(jacobians(UV, F, dC_inv))) < 0:
        UV[:, 1] *= -1
    return UV
