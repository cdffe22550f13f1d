"""Rigid motions of islands: the best fit of one point set to another, quarter turns, orientations.

Islands move only by proper rigid motions (rotations and translations, det +1)
and uniform scales: a reflection would mirror the texture. :func:`rigid_fit` is
the one least-squares fit (Kabsch / Procrustes) used to read back where a packer
put an island, to put a re-solved island back where it was, and to recognise
copies of a part.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

__all__ = ["rigid_fit", "QUARTER_TURNS", "quarter_turn", "rotate_to_min_box", "upright"]

#: The four proper quarter-turn matrices: ``uv @ QUARTER_TURNS[k]`` turns ``uv`` by ``k`` quarter turns anticlockwise.
QUARTER_TURNS = (np.eye(2), np.array([[0.0, 1.0], [-1.0, 0.0]]), -np.eye(2), np.array([[0.0, -1.0], [1.0, 0.0]]))


def rigid_fit(P, Q, *, proper=True, scale=False):
    """The rotation, scale and translation taking points ``P`` closest to ``Q`` (least squares).

    Parameters
    ----------
    P, Q : (k,d) float arrays
        Corresponding points (``d`` = 2 or 3).
    proper : bool
        Only rotations (det +1, Kabsch's correction); False allows a reflection.
    scale : bool
        Also fit a uniform scale (a similarity); otherwise ``s = 1``.

    Returns
    -------
    R : (d,d) float array, s : float, t : (d,) float array
        ``s * P @ R + t ≈ Q``.

    Notes
    -----
    With centred points :math:`\\bar P, \\bar Q` and the SVD :math:`\\bar P^T \\bar Q = U S W^T`,
    :math:`R = U\\,\\mathrm{diag}(1, …, \\det(U W^T))\\,W^T` minimises
    :math:`\\|\\bar P R - \\bar Q\\|_F` over rotations (Kabsch 1976); the best scale is
    :math:`\\mathrm{tr}(S D) / \\|\\bar P\\|_F^2`.

    Examples
    --------
    >>> P = np.array([[0., 0], [2, 0], [0, 1]]); R90 = QUARTER_TURNS[1]
    >>> R, s, t = rigid_fit(P, P @ R90 + [5, 1])
    >>> bool(np.allclose(R, R90)), s, t.round(12).tolist()
    (True, 1.0, [5.0, 1.0])
    >>> round(float(np.linalg.det(rigid_fit(P, P * [-1, 1])[0])), 12)   # a mirror image: the best rotation
    1.0
    """
    P = np.asarray(P, float)
    Q = np.asarray(Q, float)
    pc, qc = P.mean(0), Q.mean(0)
    A, B = P - pc, Q - qc
    U, S, Wt = np.linalg.svd(A.T @ B)
    D = np.ones(len(S))
    if proper and np.linalg.det(U @ Wt) < 0:
        D[-1] = -1.0
    R = (U * D) @ Wt
    s = float((S * D).sum() / max(float((A ** 2).sum()), 1e-300)) if scale else 1.0
    return R, s, qc - s * pc @ R


def quarter_turn(P, k):
    """Rotate points ``P (n,2)`` by ``k`` quarter turns counter-clockwise, exactly (coordinate swaps).

    Examples
    --------
    >>> quarter_turn(np.array([[1.0, 0.0]]), 1).tolist(), quarter_turn(np.array([[0.3, 0.2]]), 2).tolist()
    ([[-0.0, 1.0]], [[-0.3, -0.2]])
    """
    P = np.asarray(P, float)
    for _ in range(k % 4):
        P = np.stack([-P[:, 1], P[:, 0]], 1)
    return P


def rotate_to_min_box(uv):
    """Rotate a chart (no mirroring) so its axis-aligned bounding box is smallest, lying wide.

    The optimal box is aligned with an edge of the convex hull (Freeman &
    Shapira 1975), so only the hull edge directions are tried.

    Parameters
    ----------
    uv : (n,2) float array

    Returns
    -------
    uv : (n,2) float array, rotated about the origin (det of the map is +1).

    Examples
    --------
    >>> c, s = np.cos(0.3), np.sin(0.3)
    >>> sq = np.array([[0., 0], [2, 0], [2, 1], [0, 1]]) @ np.array([[c, s], [-s, c]])
    >>> r = rotate_to_min_box(sq)
    >>> round(float(np.prod(r.max(0) - r.min(0))), 6)
    2.0
    """
    uv = np.asarray(uv, float)
    if len(uv) < 3:
        return uv.copy()

    try:
        hull = uv[ConvexHull(uv).vertices]
    except (QhullError, ValueError):
        return uv.copy()
    e = np.roll(hull, -1, axis=0) - hull
    ang = np.unique(np.round(np.mod(np.arctan2(e[:, 1], e[:, 0]), np.pi / 2), 12))
    best, best_a = None, 0.0
    for a in ang:
        c, s = np.cos(-a), np.sin(-a)
        h = hull @ np.array([[c, s], [-s, c]])
        area = float(np.prod(h.max(0) - h.min(0)))
        if best is None or area < best * (1 - 1e-12):
            best, best_a = area, a
    c, s = np.cos(-best_a), np.sin(-best_a)
    out = uv @ np.array([[c, s], [-s, c]])
    ext = out.max(0) - out.min(0)
    if ext[1] > ext[0]:  # lie flat: shelves prefer wide, low charts
        out = out @ QUARTER_TURNS[3]
    return out


def upright(uv, V=None):
    """Rotate a chart (no mirroring) so its main axis runs along U.

    The main axis is the principal direction of the chart's UV points; of the two
    ways to lay it along U, the one that puts the 3D +Y direction (or, failing that,
    +Z) towards +V is taken when ``V`` is given, so islands of a standing model
    keep their "up".

    Parameters
    ----------
    uv : (n,2) float array
    V : (n,3) float array, optional
        The chart's 3D vertices (same order as ``uv``).

    Returns
    -------
    uv : (n,2) float array, rotated about the origin (det +1).

    Examples
    --------
    >>> r = upright(np.array([[0., 0], [0, 3], [1, 0]]))
    >>> ext = r.max(0) - r.min(0); bool(ext[0] > ext[1])
    True
    """
    uv = np.asarray(uv, float)
    if len(uv) < 2:
        return uv.copy()
    c = uv - uv.mean(0)
    _, vec = np.linalg.eigh(c.T @ c)
    a = vec[:, -1]
    R = np.array([[a[0], -a[1]], [a[1], a[0]]])  # columns: main axis, its left normal (det +1)
    out = uv @ R
    if V is not None:
        V = np.asarray(V, float)
        for axis in (1, 2):
            up = V[:, axis] - V[:, axis].mean()
            corr = float(up @ (out[:, 1] - out[:, 1].mean()))
            if abs(corr) > 1e-9 * (np.abs(up).sum() + 1e-300):
                if corr < 0:
                    out = -out  # a half turn, still no mirror
                break
    return out
