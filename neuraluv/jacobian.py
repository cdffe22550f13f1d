"""Local tangent frames and the per-face Jacobian ``J = ΔU ΔC⁻¹``.

Each 3D triangle is laid out isometrically in its own 2D frame; the affine map
from that frame to the UV triangle has the 2x2 Jacobian used everywhere in the
package (energy, barrier, step rejection and every reported metric).
"""
from __future__ import annotations

import numpy as np

__all__ = ["local_frames", "jacobians", "signed_areas_2d"]


def local_frames(V, F):
    """Per-face isometric 2D coordinates, their inverse edge matrix and areas.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array

    Returns
    -------
    dC_inv : (m,2,2) float array
        ``[c_j - c_i | c_k - c_i]^{-1}`` for each face ``(i, j, k)``.
    area : (m,) float array
        3D triangle areas ``A_t``.

    Notes
    -----
    With ``e1 = x_j - x_i`` and ``e2 = x_k - x_i`` the frame is ``x̂ = e1/|e1|``,
    ``ŷ = n̂ × x̂``, so ``c_i = 0``, ``c_j = (|e1|, 0)``, ``c_k = (e2·x̂, e2·ŷ)``.
    ``det ΔC = 2 A_t > 0``: the frame follows the face's winding, so
    ``det J > 0`` means the UV triangle keeps the 3D orientation.

    Examples
    --------
    >>> dCi, A = local_frames([[0., 0, 0], [2, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> (dCi[0].round(3) + 0.0).tolist(), A.tolist()
    ([[0.5, 0.0], [0.0, 1.0]], [1.0])
    """
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    e1 = V[F[:, 1]] - V[F[:, 0]]
    e2 = V[F[:, 2]] - V[F[:, 0]]
    n = np.cross(e1, e2)
    nn = np.linalg.norm(n, axis=1)
    l1 = np.linalg.norm(e1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        xh = e1 / l1[:, None]
        yh = np.cross(n / nn[:, None], xh)
    a = l1
    b = np.einsum("ij,ij->i", e2, xh)
    d = np.einsum("ij,ij->i", e2, yh)
    # inverse of [[a, b], [0, d]]
    with np.errstate(divide="ignore", invalid="ignore"):
        dC_inv = np.zeros((len(F), 2, 2))
        dC_inv[:, 0, 0] = 1.0 / a
        dC_inv[:, 0, 1] = -b / (a * d)
        dC_inv[:, 1, 1] = 1.0 / d
    return dC_inv, 0.5 * nn


def jacobians(UV, F, dC_inv):
    """Per-face Jacobians of a UV map (numpy).

    Parameters
    ----------
    UV : (n,2) float array
    F : (m,3) int array
    dC_inv : (m,2,2) float array
        From :func:`local_frames`.

    Returns
    -------
    J : (m,2,2) float array
        ``J_t = [u_j - u_i | u_k - u_i] ΔC_t⁻¹``.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> dCi, _ = local_frames(V, F)
    >>> jacobians(2 * V[:, :2], F, dCi)[0].tolist()
    [[2.0, 0.0], [0.0, 2.0]]
    """
    UV = np.asarray(UV, float)
    F = np.asarray(F, np.int64)
    dU = np.stack([UV[F[:, 1]] - UV[F[:, 0]], UV[F[:, 2]] - UV[F[:, 0]]], axis=-1)
    with np.errstate(invalid="ignore", over="ignore"):  # degenerate faces: inf frames -> non-finite J
        return dU @ dC_inv


def signed_areas_2d(UV, F):
    """Signed areas of the UV triangles (positive: counter-clockwise).

    Parameters
    ----------
    UV : (n,2) float array
    F : (m,3) int array

    Returns
    -------
    area : (m,) float array

    Examples
    --------
    >>> signed_areas_2d(np.array([[0., 0], [1, 0], [0, 1]]), np.array([[0, 1, 2], [0, 2, 1]])).tolist()
    [0.5, -0.5]
    """
    UV = np.asarray(UV, float)
    F = np.asarray(F)
    a = UV[F[:, 1]] - UV[F[:, 0]]
    b = UV[F[:, 2]] - UV[F[:, 0]]
    return 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
