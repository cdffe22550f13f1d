"""Which UV triangles overlap which: exact pairwise tests, vectorised.

Two triangles overlap when their interiors share area. For convex polygons that
is decided exactly by the separating axis theorem: they are disjoint (or only
touch along an edge or at a corner) if and only if the projections on one of
the six edge normals do not overlap with positive length. Candidates come from
an STRtree of the triangles' bounding boxes (shapely/GEOS); the test itself is
NumPy, so a 100k-face layout takes about a second. The shared area of a pair
is computed with shapely only for pairs that do overlap.
"""
from __future__ import annotations

import numpy as np

__all__ = ["candidate_pairs", "overlapping_pairs", "pair_areas"]

_CHUNK = 200_000


def candidate_pairs(tri_a, tri_b=None):
    """Pairs of triangles whose bounding boxes intersect.

    Parameters
    ----------
    tri_a : (k,3,2) float array
    tri_b : (l,3,2) float array, optional
        When omitted, pairs within ``tri_a`` (``i < j``).

    Returns
    -------
    i, j : int arrays, indices into ``tri_a`` and ``tri_b`` (or ``tri_a``).
    """
    import shapely

    def boxes(t):
        lo, hi = t.min(1), t.max(1)
        return shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1])

    A = boxes(tri_a)
    if tri_b is None:
        if len(A) < 2:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        i, j = shapely.STRtree(A).query(A)
        keep = i < j
        return i[keep].astype(np.int64), j[keep].astype(np.int64)
    if not len(A) or not len(tri_b):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    B = boxes(tri_b)
    ia, ib = shapely.STRtree(B).query(A)  # (index of the query geometry in A, index in the tree B)
    return ia.astype(np.int64), ib.astype(np.int64)


def overlapping_pairs(P, Q, rtol=1e-9):
    """Which pairs of triangles ``P[k]``, ``Q[k]`` share interior area (separating axis test).

    Parameters
    ----------
    P, Q : (k,3,2) float arrays
        Triangles, either orientation.
    rtol : float
        Projections must overlap by more than ``rtol`` times the pair's size for
        the pair to count (touching along an edge or at a corner does not).

    Returns
    -------
    (k,) bool array

    Examples
    --------
    >>> t = np.array([[[0., 0], [1, 0], [0, 1]]])
    >>> overlapping_pairs(t, t + [[0.2, 0.2]]).tolist(), overlapping_pairs(t, t + [[1.0, 0.0]]).tolist()
    ([True], [False])
    >>> edge = np.array([[[1., 0], [0, 1], [1, 1]]])        # shares the hypotenuse only
    >>> overlapping_pairs(t, edge).tolist()
    [False]
    """
    P = np.asarray(P, float)
    Q = np.asarray(Q, float)
    if not len(P):
        return np.zeros(0, bool)
    if len(P) > _CHUNK:  # bounded memory on large layouts
        return np.concatenate([overlapping_pairs(P[i:i + _CHUNK], Q[i:i + _CHUNK], rtol)
                               for i in range(0, len(P), _CHUNK)])
    size = np.maximum(np.ptp(np.concatenate([P, Q], 1), axis=1).max(1), 1e-300)
    ok = np.ones(len(P), bool)
    for T in (P, Q):
        for k in range(3):
            e = T[:, (k + 1) % 3] - T[:, k]
            n = np.stack([-e[:, 1], e[:, 0]], 1)
            nn = np.linalg.norm(n, axis=1)
            use = nn > 0
            n = n / np.where(use, nn, 1.0)[:, None]
            pp = np.einsum("kij,kj->ki", P, n)
            qq = np.einsum("kij,kj->ki", Q, n)
            gap = np.minimum(pp.max(1), qq.max(1)) - np.maximum(pp.min(1), qq.min(1))
            ok &= ~use | (gap > rtol * size)
    return ok


def pair_areas(P, Q):
    """Exact shared area of triangle pairs (shapely), ``(k,)`` float array."""
    import shapely

    def polys(T):
        return shapely.polygons(np.concatenate([T, T[:, :1]], axis=1))

    if not len(P):
        return np.zeros(0)
    return shapely.area(shapely.intersection(polys(np.asarray(P, float)), polys(np.asarray(Q, float))))
