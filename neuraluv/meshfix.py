"""Mesh repair and normalisation (``meshfix``; not to be confused with UV repair).

The paper (Sec. 4) normalises meshes to the unit box and removes degenerate
faces and unreferenced vertices before decomposing them into chart candidates.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["RepairReport", "repair_mesh", "weld_ids", "WELD_TOL", "normalize_unit_box", "face_areas", "is_triangle_soup", "SOUP_COMPONENTS"]


def face_areas(V, F):
    """Triangle areas.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array

    Returns
    -------
    A : (m,) float array

    Examples
    --------
    >>> face_areas([[0., 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    array([0.5])
    """
    V = np.asarray(V, float)
    F = np.asarray(F)
    e1 = V[F[:, 1]] - V[F[:, 0]]
    e2 = V[F[:, 2]] - V[F[:, 0]]
    return 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)


#: Vertices closer than this times the bounding-box diagonal are one vertex when welding.
WELD_TOL = 1e-10


def weld_ids(V, tol=WELD_TOL):
    """The welded vertex of each vertex: positions within ``tol`` times the diagonal share one id.

    Parameters
    ----------
    V : (n,3) float array
    tol : float

    Returns
    -------
    ids : (n,) int array, ids in ``0..k-1``.

    Examples
    --------
    >>> weld_ids([[0., 0, 0], [1, 0, 0], [0, 0, 0]]).tolist()
    [0, 1, 0]
    """
    import igl  # lazily: this module (the unit box, face areas) is imported by light ones

    V = np.asarray(V, float)
    if not len(V):
        return np.zeros(0, np.int64)
    diag = float(np.linalg.norm(V.max(0) - V.min(0))) or 1.0
    return np.asarray(igl.remove_duplicate_vertices(V, tol * diag)[2], np.int64).reshape(-1)


@dataclass
class RepairReport:
    """What :func:`repair_mesh` changed (counts)."""

    degenerate_faces: int = 0
    duplicate_faces: int = 0
    merged_vertices: int = 0
    unreferenced_vertices: int = 0

    def as_dict(self):
        return asdict(self)

    @property
    def changed(self):
        return any(v for v in asdict(self).values())


def repair_mesh(V, F, *, weld=False, weld_tol=WELD_TOL, area_tol=1e-14):
    """Remove degenerate and duplicate faces, optionally weld, drop unreferenced vertices.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    weld : bool
        Merge vertices closer than ``weld_tol`` times the bounding-box diagonal.
        Off by default: a supplied chart encodes its seams as coincident but
        distinct vertices, and welding would close them.
    weld_tol : float
        Relative welding distance.
    area_tol : float
        Faces with area below ``area_tol * diag**2`` (or repeated corners) are degenerate.

    Returns
    -------
    V : (n',3) float array
    F : (m',3) int array
    report : RepairReport
    vmap : (n',) int array
        Index of each output vertex in the input ``V``.

    Examples
    --------
    >>> V = [[0., 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5]]
    >>> F = [[0, 1, 2], [0, 1, 1], [0, 1, 2]]
    >>> V2, F2, rep, vmap = repair_mesh(V, F)
    >>> F2.tolist(), rep.degenerate_faces, rep.duplicate_faces, rep.unreferenced_vertices
    ([[0, 1, 2]], 1, 1, 1)
    """
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    rep = RepairReport()
    vmap = np.arange(len(V))
    diag = float(np.linalg.norm(V.max(0) - V.min(0))) if len(V) else 1.0
    diag = diag if diag > 0 else 1.0
    if weld and len(V):
        import igl  # lazily: this module (the unit box, face areas) is imported by light ones

        SV, SVI, SVJ = igl.remove_duplicate_vertices(V, weld_tol * diag)
        rep.merged_vertices = len(V) - len(SV)
        F = SVJ[F]
        V = SV
        vmap = SVI
    # degenerate: repeated corner or (near) zero area
    rep_corner = (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2])
    area = face_areas(V, F) if len(F) else np.zeros(0)
    degenerate = rep_corner | ~(area > area_tol * diag**2)
    rep.degenerate_faces = int(degenerate.sum())
    F = F[~degenerate]
    # duplicate faces (same vertex set, either orientation): keep the first
    if len(F):
        key = np.sort(F, axis=1)
        _, first = np.unique(key, axis=0, return_index=True)
        keep = np.zeros(len(F), bool)
        keep[np.sort(first)] = True
        rep.duplicate_faces = int((~keep).sum())
        F = F[keep]
    used = np.unique(F) if len(F) else np.zeros(0, np.int64)
    rep.unreferenced_vertices = int(len(V) - len(used))
    remap = -np.ones(len(V), np.int64)
    remap[used] = np.arange(len(used))
    return V[used], remap[F], rep, vmap[used]


def normalize_unit_box(V):
    """Translate and uniformly scale ``V`` into the unit box ``[-0.5, 0.5]^3``.

    Parameters
    ----------
    V : (n,3) float array

    Returns
    -------
    Vn : (n,3) float array
        ``(V - center) / scale``, largest extent 1.
    center : (3,) float array
    scale : float

    Notes
    -----
    Coordinates are first divided by their largest magnitude, so inputs near
    the float64 range (1e300) do not overflow in the extent computation.

    Examples
    --------
    >>> Vn, c, s = normalize_unit_box([[0., 0, 0], [2, 1, 0]])
    >>> Vn.tolist(), s
    ([[-0.5, -0.25, 0.0], [0.5, 0.25, 0.0]], 2.0)
    >>> normalize_unit_box([[0., 0, 0], [1e300, 0, 0]])[0][:, 0].tolist()
    [-0.5, 0.5]
    """
    V = np.asarray(V, float)
    m = float(np.abs(V).max()) if V.size else 0.0
    m = m if (m > 0 and np.isfinite(m)) else 1.0
    Vs = V / m
    lo, hi = Vs.min(0), Vs.max(0)
    center = 0.5 * (lo + hi)
    scale = float((hi - lo).max())
    if not scale > 0:
        scale = 1.0
    return (Vs - center) / scale, center * m, scale * m


#: More components than this (and more than one per 20 faces) make an input a triangle soup.
SOUP_COMPONENTS = 8


def is_triangle_soup(n_components, n_faces):
    """True for an input that falls apart into many pieces (an STL file, an unwelded export).

    Such an input is welded before unwrapping; an input with few components keeps
    its coincident vertices as seams (Bob's charts touch along theirs).

    Examples
    --------
    >>> is_triangle_soup(3, 10688), is_triangle_soup(512, 512)
    (False, True)
    """
    return n_components > max(SOUP_COMPONENTS, n_faces // 20)
