"""What every baseline adapter shares: failure kinds, orientation, loop-UV welding."""
from __future__ import annotations

import numpy as np

from neuraluv.jacobian import jacobians, local_frames
from neuraluv.topology import is_disk_like, vertex_components

__all__ = ["InitFail", "Unavailable", "require_disk", "orient_charts", "weld_corners"]


class InitFail(RuntimeError):
    """The method cannot start on this input (reported as ``"init fail"``)."""


class Unavailable(RuntimeError):
    """An optional dependency or binary is missing (reported as ``"unavailable"``)."""




def orient_charts(V, F, UV):
    """Reflect every chart of ``UV`` whose total signed area is negative.

    A chart is a connected component of ``(V, F)`` (for cut meshes: an atlas
    island). A chart mirrored as a whole is an equally good parameterization
    (xatlas returns some islands mirrored), so it is reflected in place about
    its bounding-box centre line; flips are then the faces that disagree with
    their chart's majority.

    Returns
    -------
    UV : (n,2) float array
    mirrored : int
        Number of charts reflected.
    """

    dC_inv, A = local_frames(V, F)
    sdet = A * np.linalg.det(jacobians(UV, F, dC_inv))
    ncomp, lab = vertex_components(len(V), F)
    flab = lab[F[:, 0]]
    per = np.bincount(flab, weights=sdet, minlength=ncomp)
    bad = np.flatnonzero(per < 0)
    if len(bad) == 0:
        return UV, 0
    UV = UV.copy()
    for c in bad:
        vi = np.flatnonzero(lab == c)
        y = UV[vi, 1]
        UV[vi, 1] = y.min() + y.max() - y
    return UV, int(len(bad))


def weld_corners(F, corner_uv):
    """A cut mesh from per-corner UVs: one vertex per distinct (vertex, uv) pair.

    Parameters
    ----------
    F : (m,3) int array
    corner_uv : (3m,2) float array
        UV of corner ``j`` of face ``t`` at row ``3t+j`` (Blender loop UVs).

    Returns
    -------
    vidx : (n',) int array
        Input vertex of each cut-mesh vertex (cut-mesh positions are ``V[vidx]``).
    F_cut : (m,3) int array
        Same faces, indexing the cut mesh.
    UV : (n',2) float array

    Examples
    --------
    >>> F = np.array([[0, 1, 2], [0, 2, 3]])
    >>> uv = np.array([[0, 0], [1, 0], [1, 1], [0, 0], [1, 1], [0, 1.]])
    >>> vidx, Fc, UV = weld_corners(F, uv)
    >>> vidx.tolist(), Fc.tolist()
    ([0, 1, 2, 3], [[0, 1, 2], [0, 2, 3]])
    """
    F = np.asarray(F, np.int64)
    corner_uv = np.asarray(corner_uv, float)
    key = np.column_stack([F.reshape(-1), corner_uv])
    uniq, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return F.reshape(-1)[first], inv.reshape(-1).reshape(F.shape), corner_uv[first]


def require_disk(V, F, method):
    """Raise :class:`InitFail` unless ``(V, F)`` is one disk (libigl methods)."""
    ok, why = is_disk_like(V, F)
    if not ok:
        raise InitFail(f"{method} needs one disk-like chart: {why}")
