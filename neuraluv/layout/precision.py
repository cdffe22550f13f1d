"""UVs as the files carry them: float32 values, without a flipped triangle."""
from __future__ import annotations

import numpy as np

from neuraluv.jacobian import signed_areas_2d

__all__ = ["float32_uvs"]


def float32_uvs(UV, F, rounds=24):
    """UVs rounded to float32 values (OBJ and GLB carry the same layout) without flipping a triangle.

    A triangle thinner than float32's resolution at its place in the texture (a
    needle the solver kept positive in float64) can round to zero or negative area.
    Each such triangle's corner opposite its longest edge is pushed away from that
    edge, 2^r float32 steps in round ``r``, until every triangle that was positive
    before rounding is positive after it (or ``rounds`` run out: the validation then
    reports the flip).

    Parameters
    ----------
    UV : (n,2) float array
    F : (m,3) int array

    Returns
    -------
    (n,2) float64 array of float32-representable values

    Examples
    --------
    >>> UV = np.array([[0.5, 0.5], [0.50001, 0.5], [0.500005, 0.5 + 1e-9]])
    >>> F = np.array([[0, 1, 2]])
    >>> bool(signed_areas_2d(UV.astype(np.float32).astype(float), F)[0] > 0)  # plain rounding: flat
    False
    >>> U = float32_uvs(UV, F); bool(signed_areas_2d(U, F)[0] > 0), bool((U == U.astype(np.float32)).all())
    (True, True)
    """
    UV = np.asarray(UV, float)
    F = np.asarray(F, np.int64)
    U = UV.astype(np.float32).astype(np.float64)
    if not len(F):
        return U
    keep = signed_areas_2d(UV, F) > 0
    for r in range(int(rounds)):
        bad = np.flatnonzero(keep & (signed_areas_2d(U, F) <= 0))
        if not len(bad):
            break
        for f in bad:
            P = U[F[f]]
            i = int(np.argmax(np.linalg.norm(P[[2, 0, 1]] - P[[1, 2, 0]], axis=1)))  # corner opposite the longest edge
            p, q = P[(i + 1) % 3], P[(i + 2) % 3]
            d = q - p
            n = np.array([-d[1], d[0]]) / max(np.linalg.norm(d), 1e-300)  # left of p->q: the positive side
            step = float(np.spacing(np.float32(np.abs(P[i]).max() or 1.0))) * 2.0 ** r
            U[F[f, i]] = (P[i] + n * step).astype(np.float32)
    return U

