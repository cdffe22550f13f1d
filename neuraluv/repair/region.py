"""What a repair region is measured by: its overlaps, its distortion and its faces' det J.

The steps of :mod:`~neuraluv.repair.local`, :mod:`~neuraluv.repair.shells` and :mod:`~neuraluv.repair.bake`
accept a repaired region only when its faces are valid and it overlaps no other face of its island
(:func:`region_overlaps`; intended overlaps and twins aside), and grow it only while growing lowers its
distortion (:func:`region_esd`, the paper's symmetric Dirichlet energy, area-weighted).
"""
from __future__ import annotations

import numpy as np

from neuraluv.layout.facts import uv_degenerate, within_rings
from neuraluv.layout.overlap import overlap_pairs
from neuraluv.metrics import corner_jacobians, face_dets, face_metrics

__all__ = ["region_overlaps", "region_esd", "island_esds", "FAR_QUANTILE", "face_dets_of", "self_overlap_faces",
           "PairsWith", "intended_overlaps"]


def region_overlaps(UV, FUV, region, island, allowed=None, group=None):
    """Number of overlapping triangle pairs with a face in ``region`` among the ``island``'s faces (exact).

    ``allowed``: a set of face pairs ``(i, j)``, ``i < j`` (or any container answering ``in`` for them,
    :class:`PairsWith`), that overlapped before on purpose (a texture
    layout's shell may lie over itself); they are not counted. Nor are twins (two faces on the same three rows:
    copies stacked on purpose, which no move of their rows can part). With ``group`` ((m,) int array), only
    pairs of one group count (the shells of an island stacked on each other overlap on purpose).
    """
    a, b = overlap_pairs(UV, FUV, island, region)
    skip = (np.sort(FUV[a], 1) == np.sort(FUV[b], 1)).all(1)  # twins
    if group is not None:
        skip |= group[a] != group[b]
    a, b = a[~skip], b[~skip]
    if not allowed:
        return len(a)
    return sum((int(i), int(j)) not in allowed for i, j in zip(np.minimum(a, b), np.maximum(a, b)))


def region_esd(Vn, F, UV, FUV, faces, scale):
    """Area-weighted E_SD of ``faces`` with the layout scaled by ``1/scale`` (``inf`` when a face is not valid)."""
    return float(island_esds(Vn, F, UV, FUV, [faces], [scale])[0])


def island_esds(Vn, F, UV, FUV, groups, scales):
    """:func:`region_esd` of several face groups, each at its own scale, from one Jacobian evaluation.

    Parameters
    ----------
    Vn : (n,3) float array
    F, FUV : (m,3) int arrays
    UV : (p,2) float array
    groups : list of (k_i,) int arrays, face indices
    scales : (len(groups),) float array, each group's texel density

    Returns
    -------
    (len(groups),) float array: the area-weighted E_SD of each group's faces with the layout scaled by
    ``1/scale`` (``inf`` where a face of the group has det J ≤ 0 or is not finite)

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2], [0, 1, 2]])
    >>> UV = np.array([[0, 0], [2, 0], [0, 2], [0, 0], [0, 1], [1, 0]])
    >>> island_esds(V, F, UV, np.array([[0, 1, 2], [3, 4, 5]]), [np.array([0]), np.array([1])], [2.0, 1.0]).tolist()
    [4.0, inf]
    """
    sizes = [len(g) for g in groups]
    if not sum(sizes):
        return np.full(len(groups), np.nan)
    faces = np.concatenate([np.asarray(g, np.int64) for g in groups])
    label = np.repeat(np.arange(len(groups)), sizes)
    J, A = corner_jacobians(Vn, F[faces], UV, FUV[faces])
    fm = face_metrics(J / np.asarray(scales, float)[label][:, None, None])
    bad = np.bincount(label, weights=~(fm["det"] > 0) | ~np.isfinite(fm["sd"]), minlength=len(groups)) > 0
    with np.errstate(invalid="ignore"):
        esd = np.bincount(label, weights=np.where(np.isfinite(fm["sd"]), fm["sd"], 0.0) * A, minlength=len(groups)) \
            / np.bincount(label, weights=A, minlength=len(groups))
    return np.where(bad, np.inf, esd)


#: The quantile of the per-face E_SD of the faces two to four rings beyond a repaired region that the next ring's
#: mean E_SD is compared with (:func:`repair_cluster`): an artist's layout is far from evenly distorted, and a
#: ring is damaged only where it is more distorted than most faces around it, not than the typical one.
FAR_QUANTILE = 0.75


def _face_sd(Vn, F, UV, FUV, faces, scale, sign=None):
    """Per-face ``(det J, E_SD)`` of ``faces`` with the layout scaled by ``1/scale``; a face whose ``sign`` ((m,) ±1)
    is -1 is valid reversed and measured mirrored (the same E_SD, det J > 0)."""
    J = corner_jacobians(Vn, F[faces], UV / scale, FUV[faces])[0]
    if sign is not None:
        J[:, 0, :] *= np.asarray(sign)[faces][:, None]
    fm = face_metrics(J)
    return fm["det"], fm["sd"]


def _far_esd(Vn, F, UV, FUV, faces, scale, q=FAR_QUANTILE):
    """The ``q`` quantile of the per-face E_SD of ``faces`` with the layout scaled by ``1/scale``."""
    sd = _face_sd(Vn, F, UV, FUV, faces, scale)[1]
    return float(np.quantile(sd, q)) if len(sd) else float("inf")


def face_dets_of(Vn, F, UV, FUV, faces):
    """det J of ``faces`` (an empty array for none)."""
    faces = np.asarray(faces, np.int64)
    return face_dets(Vn, F[faces], UV, FUV[faces]) if len(faces) else np.zeros(0)


def mended(Vn, F, UV, FUV, faces):
    """(k,) bool: ``faces`` positive and not collapsed in UV, by the test check and the read-back use
    (:func:`~neuraluv.layout.facts.uv_degenerate`): det J > 0 alone takes rounding for a face."""
    faces = np.asarray(faces, np.int64)
    det = face_dets_of(Vn, F, UV, FUV, faces)
    return (det > 0) & ~uv_degenerate(UV, FUV[faces], det) if len(faces) else np.zeros(0, bool)


def self_overlap_faces(UV, FUV, island, det, subset=None):
    """Positive faces of ``island`` (or of ``subset``) overlapping another positive face of the island."""
    a, b = overlap_pairs(UV, FUV, island[det > 0], subset)
    return np.unique(np.concatenate([a, b]))


class PairsWith:
    """Face pairs a repaired region may keep (:func:`~neuraluv.repair.local.region_overlaps`' ``allowed``): the pairs
    of ``pairs`` and every pair with a face of ``faces`` ((m,) bool).

    Examples
    --------
    >>> ok = PairsWith({(0, 5)}, np.array([False, False, True, False, False, False]))
    >>> [(0, 5) in ok, (2, 4) in ok, (1, 3) in ok]
    [True, True, False]
    """

    def __init__(self, pairs, faces):
        self.pairs, self.faces = set(pairs or ()), np.asarray(faces, bool)

    def __contains__(self, pair):
        return pair in self.pairs or bool(self.faces[pair[0]] or self.faces[pair[1]])

    def __bool__(self):
        return bool(self.pairs) or bool(self.faces.any())


def intended_overlaps(UV, FUV, shell, bad, graph, rings=3, subset=None):
    """Pairs of the shell's faces that overlap on purpose: a repaired region may keep them.

    Two overlapping faces of which neither is broken overlap on purpose (a shell laid over itself); so do a
    broken face and a face more than ``rings`` rings away from it (the fold lies where the shell is stacked
    on another part of itself). A broken face over its near neighbours is the fold itself. ``subset``: only
    the pairs with a face in it.
    """
    a, b = overlap_pairs(UV, FUV, shell, subset)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keep = ~bad[lo] & ~bad[hi]
    n = np.flatnonzero(~keep)
    if len(n):
        i, j = np.where(bad[lo[n]], lo[n], hi[n]), np.where(bad[lo[n]], hi[n], lo[n])  # i broken
        keep[n] = ~within_rings(FUV, graph.faces, i, j, rings)  # (rows grown as IslandGraph.grow does)
    return set(zip(lo[keep].tolist(), hi[keep].tolist()))
