"""The facts of a UV layout over a mesh, read once: faces, islands, det J, orientation, texel density.

Every client of a layout — the atlas's validation, ``check --uv``, repair and the
benchmarks — asks the same questions of it; they are answered here, once, and
carried in a :class:`LayoutFacts`:

* a face is **missing** when a corner has no ``vt`` index, **non-finite** when a
  corner's ``vt`` is NaN or infinite; the others are **usable**;
* **islands** are the usable faces joined through shared ``vt`` rows (:func:`uv_islands`);
* **det J** of every usable face (:func:`~neuraluv.metrics.face_dets`) on the mesh
  normalised to the unit box; a face with no 3D area (``degenerate3d``) has no
  distortion and is neither valid nor invalid;
* an island is **mirrored** when its faces with reversed orientation cover more
  UV area than the others (the island was reflected as a whole, not folded), unless
  one orientation covers more than :data:`SURFACE_FACTOR` times the other's 3D area:
  then that one (:func:`holds_more`; a vertex flung across a small island makes one
  stretched, reversed face that covers more UV area than the faces it folds over);
* the **texel density** of an island (:func:`texel_density`) is
  ``sqrt(Σ |A_uv| / Σ A_3d)`` over its faces oriented like the island.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from neuraluv.jacobian import signed_areas_2d
from neuraluv.layout.overlap import find_overlaps
from neuraluv.meshfix import face_areas, normalize_unit_box
from neuraluv.metrics import face_dets
from neuraluv.topology import faces_sharing

__all__ = ["LayoutFacts", "layout_facts", "uv_islands", "coincident_rows", "face_clusters", "within_rings",
           "texel_density", "island_densities",
           "face_texel_density",
           "density_spread", "DEGENERATE_3D_AREA", "DEGENERATE_3D_HEIGHT", "no_3d_area", "DEGENERATE_UV",
           "uv_degenerate", "defect_area", "SURFACE_FACTOR", "holds_more"]

#: Faces of the unit-box mesh with less 3D area than this have no distortion (their UVs are left alone).
DEGENERATE_3D_AREA = 1e-14

#: Faces of the unit-box mesh thinner than this (twice the area over the longest edge) have no 3D area either:
#: corners on one line as float32 positions store them (a glTF's, Blender's subdivided n-gons) are ~1e-7 off it,
#: and their UVs, written as float32 too, have no orientation to keep.
DEGENERATE_3D_HEIGHT = 1e-6

#: Relative UV area below which a face is UV-degenerate (area / longest UV edge², scale-free).
DEGENERATE_UV = 1e-12


#: One part of a layout (an orientation of an island, a sheet) holding more than this multiple of another's 3D area
#: holds more of the surface whatever their UV areas say (:func:`holds_more`).
SURFACE_FACTOR = 2.0


def holds_more(uv_a, uv_b, a3_a, a3_b, factor=SURFACE_FACTOR):
    """Whether part ``a`` of a layout holds more of it than part ``b``: the larger UV area, unless one part has
    more than ``factor`` times the other's 3D area (then the larger 3D area).

    UV area alone is what damage can fake: a vertex flung across a small island makes one stretched face
    that covers more UV area than the faces it folds over; its 3D area is what it was.

    Parameters
    ----------
    uv_a, uv_b, a3_a, a3_b : float or (k,) float arrays
        UV areas and 3D areas of the two parts.
    factor : float

    Returns
    -------
    bool or (k,) bool array

    Examples
    --------
    >>> holds_more(2.0, 1.0, 1.0, 1.5).tolist(), holds_more(2.0, 1.0, 1.0, 3.0).tolist()
    (True, False)
    """
    uv_a, uv_b, a3_a, a3_b = (np.asarray(x, float) for x in (uv_a, uv_b, a3_a, a3_b))
    return np.where(a3_a > factor * a3_b, True, np.where(a3_b > factor * a3_a, False, uv_a > uv_b))


def uv_islands(FUV):
    """Label faces by UV island: faces sharing a ``vt`` index are connected.

    Parameters
    ----------
    FUV : (m,3) int array

    Returns
    -------
    n : int
    labels : (m,) int array

    Examples
    --------
    >>> uv_islands(np.array([[0, 1, 2], [2, 1, 3], [4, 5, 6]]))[1].tolist()
    [0, 0, 1]
    """
    FUV = np.asarray(FUV, np.int64)
    return faces_sharing(FUV.reshape(-1), np.repeat(np.arange(len(FUV)), 3), len(FUV))


def coincident_rows(V, F, UV, FUV, label=None):
    """The row each ``vt`` row is one point of the map with: rows with bit-identical UVs used at corners with
    bit-identical 3D positions (a glTF vertex split for its normals, an exporter's repeated ``vt``).

    Such rows are no seam: the surface and its map are continuous across them, and a tool that moves one
    must move the others with it, or it opens a slit (or lays one side over the other). Each group maps
    to its smallest row. Islands stay as :func:`uv_islands` reads them: with ``label`` (an island per
    face), only rows of one island are joined.

    Parameters
    ----------
    V : (n,3) float array
    F, FUV : (m,3) int arrays (``FUV`` -1 where a corner has no ``vt``)
    UV : (p,2) float array (rows that are not finite are joined with none)
    label : (m,) int array, optional
        A group per face (faces with a negative label take no part).

    Returns
    -------
    canon : (p,) int array, ``canon[r] <= r``; ``canon[r] == r`` for a row coincident with no smaller one.

    Examples
    --------
    Two triangles split along their shared edge (rows 4, 5 repeat rows 1, 2 at the same places):

    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [1, 0, 0], [0, 1, 0]])
    >>> F = np.array([[0, 1, 2], [4, 3, 5]])
    >>> coincident_rows(V, F, V[:, :2], F).tolist()
    [0, 1, 2, 3, 1, 2]
    >>> coincident_rows(V, F, V[:, :2], F, label=np.array([0, 1])).tolist()  # two islands: kept apart
    [0, 1, 2, 3, 4, 5]
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    FUV = np.asarray(FUV, np.int64)
    UV = np.asarray(UV, float).reshape(-1, 2)
    p = len(UV)
    fin = np.isfinite(UV).all(1)
    if len(np.unique(UV[fin], axis=0)) == fin.sum():  # no two rows alike: nothing to join
        return np.arange(p)
    r = FUV.reshape(-1)
    ok = (r >= 0) & (r < p)
    ok[ok] = fin[r[ok]]
    lab = np.zeros(len(r)) if label is None else np.repeat(np.asarray(label, float), FUV.shape[1])
    ok &= lab >= 0
    rows = r[ok]
    key = np.c_[UV[rows], np.asarray(V, float)[np.asarray(F, np.int64).reshape(-1)[ok]], lab[ok]]
    _, k = np.unique(key, axis=0, return_inverse=True)
    k = k.reshape(-1)
    A = coo_matrix((np.ones(len(rows)), (rows, p + k)), shape=(p + k.max(initial=-1) + 1,) * 2)
    _, comp = connected_components(A, directed=False)
    comp = comp[:p]
    first = np.full(comp.max(initial=-1) + 1, p, np.int64)
    np.minimum.at(first, comp, np.arange(p))
    return first[comp]


def within_rings(F, faces, i, j, rings):
    """Whether face ``j`` lies within ``rings`` rings of face ``i``, the rings grown through ``faces``.

    Face ``j`` is within 0 rings of ``i`` when the two share a corner, and within ``r + 1`` rings when it shares
    a corner with a face within ``r`` rings (the rows of ``i`` grown ring by ring reach ``j``'s). With ``F`` the
    ``vt`` rows, the rings are those of the texture layout.

    Parameters
    ----------
    F : (m,3) int array
    faces : (k,) int array, the faces the rings grow through (``i`` and ``j`` among them)
    i, j : (q,) int arrays, pairs of faces
    rings : int

    Returns
    -------
    (q,) bool array

    Examples
    --------
    A strip of triangles, each sharing an edge with the next (and a corner with the one after):

    >>> F = np.array([[k, k + 1, k + 2] for k in range(6)])
    >>> [within_rings(F, np.arange(6), np.zeros(5, int), np.arange(1, 6), r).tolist() for r in (0, 1)]
    [[True, True, False, False, False], [True, True, True, True, False]]
    """
    faces = np.asarray(faces, np.int64)
    i, j = np.asarray(i, np.int64), np.asarray(j, np.int64)
    if not len(i):
        return np.zeros(0, bool)
    import scipy.sparse as sp

    T = np.asarray(F)[faces]
    M = sp.csr_matrix((np.ones(T.size), (np.repeat(np.arange(len(T)), 3), T.reshape(-1))),
                      shape=(len(T), int(T.max()) + 1))
    G = (M @ M.T).tocsr()  # faces sharing a corner, each face its own neighbour
    G.data[:] = 1.0
    pos = np.full(int(max(faces.max(), i.max(), j.max())) + 1, -1)
    pos[faces] = np.arange(len(faces))
    ui, inv = np.unique(i, return_inverse=True)
    R = G[pos[ui]]
    for _ in range(rings):
        R = (R @ G).tocsr()
        R.data[:] = 1.0
    return np.asarray(R[inv.reshape(-1), pos[j]]).reshape(-1) != 0


def face_clusters(FUV, faces):
    """Group ``faces`` into clusters joined through shared ``vt`` rows, largest first.

    Examples
    --------
    >>> [c.tolist() for c in face_clusters(np.array([[0, 1, 2], [5, 6, 7], [2, 3, 4]]), [0, 1, 2])]
    [[0, 2], [1]]
    """
    faces = np.asarray(faces, np.int64)
    if not len(faces):
        return []
    n, lab = faces_sharing(np.asarray(FUV)[faces].reshape(-1), np.repeat(np.arange(len(faces)), 3), len(faces))
    return sorted((faces[lab == k] for k in range(n)), key=len, reverse=True)


def _density(signed, a3, label, n, count=None):
    """Per group: mirrored (reversed faces hold more of it, :func:`holds_more`) and ``sqrt(Σ|A_uv| / ΣA_3d)``
    over the faces oriented like the group (and in ``count``); NaN where no face counts."""
    s = np.nan_to_num(np.asarray(signed, float), nan=0.0, posinf=0.0, neginf=0.0)
    pos = np.bincount(label, weights=np.where(s > 0, s, 0.0), minlength=n)
    neg = np.bincount(label, weights=np.where(s < 0, -s, 0.0), minlength=n)
    pos3 = np.bincount(label, weights=np.where(s > 0, a3, 0.0), minlength=n)
    neg3 = np.bincount(label, weights=np.where(s < 0, a3, 0.0), minlength=n)
    mirrored = holds_more(neg, pos, neg3, pos3)
    ok = (a3 > 0) if count is None else (count & (a3 > 0))
    like = ok & np.where(mirrored[label], s < 0, s > 0)
    a2 = np.bincount(label[like], weights=np.abs(s[like]), minlength=n)
    a3s = np.bincount(label[like], weights=a3[like], minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.sqrt(a2 / a3s)
    return np.where(np.isfinite(d) & (d > 0), d, np.nan), mirrored


def texel_density(V, F, UV, FUV=None, labels=None):
    """Texel density: UV length per 3D length, ``sqrt(Σ |A_uv| / Σ A_3d)``, per island or overall.

    Only faces oriented like their island (positive, or reversed in a mirrored
    island) with finite UVs and positive 3D area count, so a fold or a stray face
    does not bias it. Times the texture resolution it is texels per unit length.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional (default ``F``)
    labels : (m,) int array, optional
        Island of each face: one density per label. Without it, one density over all faces.

    Returns
    -------
    float, or (max(labels)+1,) float array; NaN where no face counts.

    Notes
    -----
    A map whose every triangle keeps its 3D area (``det J = 1``) has density 1;
    scaling the UVs by ``s`` scales it by ``s``. Islands packed at one density have one
    checkerboard cell size on the surface.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> float(texel_density(V, F, 0.25 * V[:, :2])), float(texel_density(V, F, -2 * V[:, :2]))
    (0.25, 2.0)
    """
    F = np.asarray(F, np.int64)
    FUV = F if FUV is None else np.asarray(FUV, np.int64)
    signed = signed_areas_2d(np.asarray(UV, float), FUV) if len(F) else np.zeros(0)
    a3 = face_areas(np.asarray(V, float), F) if len(F) else np.zeros(0)
    if labels is None:
        return float(_density(signed, a3, np.zeros(len(F), np.int64), 1)[0][0])
    labels = np.asarray(labels, np.int64)
    return _density(signed, a3, labels, int(labels.max()) + 1 if len(labels) else 0)[0]


def island_densities(xyz, faces, uvs):
    """:func:`texel_density` of separate islands, in one call.

    Parameters
    ----------
    xyz : list of (n_i,3) float arrays, each island's 3D vertices
    faces : list of (m_i,3) int arrays, indices into the island's own vertices
    uvs : list of (n_i,2) float arrays

    Returns
    -------
    (k,) float array (NaN where no face counts)

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> island_densities([V, 2 * V], [F, F], [V[:, :2], V[:, :2]]).tolist()
    [1.0, 0.5]
    """
    if not len(faces):
        return np.zeros(0)
    off = np.cumsum([0] + [len(u) for u in uvs])
    F = np.vstack([np.asarray(f, np.int64) + o for f, o in zip(faces, off[:-1])])
    labels = np.repeat(np.arange(len(faces)), [len(f) for f in faces])
    return texel_density(np.vstack(xyz), F, np.vstack(uvs), labels=labels)


def density_spread(density):
    """Spread of texel densities: ``max / min − 1`` over the finite ones (0 = one density; None if none).

    Examples
    --------
    >>> density_spread(np.array([1.0, 1.1, np.nan]))
    0.10000000000000009
    """
    d = np.asarray(density, float)
    d = d[np.isfinite(d) & (d > 0)]
    return float(d.max() / d.min() - 1.0) if len(d) else None


@dataclass
class LayoutFacts:
    """What :func:`layout_facts` reads off a layout (arrays over faces unless noted).

    Attributes
    ----------
    Vn : (n,3) float array, the mesh normalised to the unit box (distortion is measured on it).
    F : (m,3) int array; UV : (p,2) float array; FUV : (m,3) int array (-1 where a corner has no ``vt``).
    missing, non_finite : (m,) bool arrays.
    label : (m,) int array, island of each usable face (-1 for missing / non-finite faces).
    n_islands : int
    det : (m,) float array, det J (NaN for unusable faces).
    signed_uv : (m,) float array, signed UV areas; area3d : (m,) float array (of ``Vn``).
    density : (n_islands,) float array, :func:`texel_density` of each island (in ``Vn`` units).
    mirrored : (n_islands,) bool array.
    degenerate3d : (m,) bool array, faces with no 3D area (:data:`DEGENERATE_3D_AREA`).
    min_overlap : float, UV area: an island's overlap with itself, or a pair of islands' overlap, smaller
        than this in all is below what a texture shows and is left out of :meth:`overlaps` (counted in
        :meth:`ignored_overlaps`); so is a fold whose reversed faces cover less (:meth:`small_folds`).
        0 (the default): every overlap and fold counts.
    """

    Vn: np.ndarray
    F: np.ndarray
    UV: np.ndarray
    FUV: np.ndarray
    missing: np.ndarray
    non_finite: np.ndarray
    label: np.ndarray
    n_islands: int
    det: np.ndarray
    signed_uv: np.ndarray
    area3d: np.ndarray
    density: np.ndarray
    mirrored: np.ndarray
    degenerate3d: np.ndarray
    min_overlap: float = 0.0
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def usable(self):
        """(m,) bool: faces with three finite UVs."""
        return self.label >= 0

    @property
    def collapsed(self):
        """(m,) bool: usable faces with 3D area collapsed in UV (:func:`uv_degenerate`; read once)."""
        if "collapsed" not in self._cache:
            use = np.flatnonzero(self.usable & ~self.degenerate3d)
            out = np.zeros(len(self.F), bool)
            out[use] = uv_degenerate(self.UV, self.FUV[use], self.det[use], self.signed_uv[use])
            self._cache["collapsed"] = out
        return self._cache["collapsed"]

    @property
    def bad(self):
        """(m,) bool: usable faces flipped or degenerate in UV (det J ≤ 0, or :attr:`collapsed`: det J > 0 by
        rounding alone); no-3D-area faces excluded."""
        return self.usable & ~self.degenerate3d & (~(self.det > 0) | self.collapsed)

    @property
    def oriented(self):
        """(m,) bool: usable faces oriented like their island (positive; reversed in a mirrored island)."""
        mir = self.mirrored[np.maximum(self.label, 0)] if self.n_islands else np.zeros(len(self.F), bool)
        return self.usable & np.where(mir, self.det < 0, self.det > 0)

    @property
    def median_density(self):
        d = self.density[np.isfinite(self.density)]
        return float(np.median(d)) if len(d) else None

    def island_faces(self, i):
        """Face indices of island ``i`` (ascending)."""
        if "order" not in self._cache:
            lab = np.where(self.usable, self.label, self.n_islands)
            order = np.argsort(lab, kind="stable")
            self._cache["order"] = (order, np.searchsorted(lab[order], np.arange(self.n_islands + 1)))
        order, bounds = self._cache["order"]
        return order[bounds[i]:bounds[i + 1]]

    def island_rows(self, i):
        """The ``vt`` rows of island ``i`` (sorted)."""
        return np.unique(self.FUV[self.island_faces(i)])

    def overlaps(self):
        """Overlapping pairs of oriented faces (:func:`~neuraluv.layout.overlap.find_overlaps`), computed once;
        without the overlaps below :attr:`min_overlap` (per island, or per pair of islands, in all)."""
        if "overlaps" not in self._cache:
            ii, jj, area = find_overlaps(self)
            keep = np.ones(len(ii), bool)
            ignored = []
            if self.min_overlap > 0 and len(ii):
                li, lj = self.label[ii], self.label[jj]
                key = np.minimum(li, lj) * (self.n_islands + 1) + np.maximum(li, lj)
                groups, inv = np.unique(key, return_inverse=True)
                total = np.bincount(inv.reshape(-1), weights=area, minlength=len(groups))
                small = total < self.min_overlap
                keep = ~small[inv.reshape(-1)]
                ignored = [{"islands": sorted({int(g // (self.n_islands + 1)), int(g % (self.n_islands + 1))}),
                            "area": float(t)} for g, t in zip(groups[small], total[small])]
            self._cache["overlaps"] = (ii[keep], jj[keep], area[keep])
            self._cache["ignored"] = ignored
        return self._cache["overlaps"]

    def small_folds(self, faces):
        """The faces of ``faces`` ((m,) bool: folded faces) in folds no texture shows: clusters (joined through
        shared ``vt`` rows) whose UV area is below :attr:`min_overlap` in all. Faces without UV area are never
        in one (a UV-degenerate face stays a problem); none when :attr:`min_overlap` is 0.

        Returns
        -------
        (m,) bool array
        """
        out = np.zeros(len(self.F), bool)
        area = np.abs(np.nan_to_num(self.signed_uv))
        idx = np.flatnonzero(np.asarray(faces, bool) & (area > 0))
        if self.min_overlap <= 0 or not len(idx):
            return out
        for cl in face_clusters(self.FUV, idx):
            if area[cl].sum() < self.min_overlap:
                out[cl] = True
        return out

    def ignored_overlaps(self):
        """The overlaps :meth:`overlaps` leaves out (below :attr:`min_overlap`): ``islands`` (one: with itself)
        and ``area`` (UV) of each."""
        self.overlaps()
        return self._cache["ignored"]


def no_3d_area(Vn, F, areas=None):
    """Faces of the unit-box mesh without 3D area: at most :data:`DEGENERATE_3D_AREA`, or thinner than
    :data:`DEGENERATE_3D_HEIGHT` (corners on one line up to float32 rounding).

    Parameters
    ----------
    Vn : (n,3) float array, the mesh in its unit box
    F : (m,3) int array
    areas : (m,) float array, optional
        The faces' areas, when already computed.

    Returns
    -------
    (m,) bool array

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0.5, 1e-8, 0], [0.5, 0.5, 0]])
    >>> no_3d_area(V, np.array([[0, 1, 2], [0, 1, 3], [0, 0, 1]])).tolist()
    [True, False, True]
    """
    F = np.asarray(F, np.int64)
    if not len(F):
        return np.zeros(0, bool)
    a3 = face_areas(Vn, F) if areas is None else np.asarray(areas, float)
    P = np.asarray(Vn, float)[F]
    longest = np.linalg.norm(P - P[:, [1, 2, 0]], axis=2).max(1)
    return ~(a3 > DEGENERATE_3D_AREA) | ~(2.0 * a3 > DEGENERATE_3D_HEIGHT * longest)


def uv_degenerate(UV, FUV, det, signed_uv=None):
    """(k,) bool: faces ``FUV (k,3)`` collapsed in UV: UV area at most :data:`DEGENERATE_UV` of the longest UV
    edge squared (a point or a line, whatever sign rounding gave det J), or det J (``det (k,)``) zero.

    Examples
    --------
    >>> UV = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0 + 1e-15], [0.0, 1.0]])
    >>> uv_degenerate(UV, np.array([[0, 1, 2], [0, 1, 3]]), np.array([1e-16, -1.0])).tolist()
    [True, False]
    """
    FUV = np.asarray(FUV, np.int64)
    P = np.asarray(UV, float)[FUV]
    e2 = (np.diff(P[:, [0, 1, 2, 0]], axis=1) ** 2).sum(2).max(1)
    s = signed_areas_2d(UV, FUV) if signed_uv is None else signed_uv
    return ~(np.abs(s) > DEGENERATE_UV * e2) | ~(np.asarray(det) != 0)


def layout_facts(V, F, UV, FUV=None, *, normalized=False, min_overlap=0.0):
    """Read a layout once: usable faces, islands, det J, orientation, texel densities.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional
        ``vt`` index of every corner (default ``F``); -1 (or out of range) where a face has none.
    normalized : bool
        ``V`` is already normalised to the unit box (it is used as it is).
    min_overlap : float
        UV area below which an overlap is left out (:attr:`LayoutFacts.min_overlap`; :func:`defect_area`
        turns texels at a resolution into it).

    Returns
    -------
    LayoutFacts

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]); F = np.array([[0, 1, 2], [1, 3, 2]])
    >>> UV = np.array([[0.1, 0.1], [0.4, 0.1], [0.1, 0.4], [0.4, 0.4]])
    >>> f = layout_facts(V, F, UV, F)
    >>> f.n_islands, f.bad.tolist(), bool(f.mirrored[0]), round(float(f.density[0]), 6)
    (1, [False, False], False, 0.3)
    >>> layout_facts(V, F, UV * [-1, 1], F).mirrored.tolist()
    [True]
    """
    V = np.asarray(V, float)
    Vn = V if normalized else normalize_unit_box(V)[0]
    F = np.asarray(F, np.int64)
    UV = np.asarray(UV, float).reshape(-1, 2)
    FUV = F if FUV is None else np.asarray(FUV, np.int64)
    m = len(F)
    in_range = (FUV >= 0) & (FUV < len(UV))
    missing = ~in_range.all(1) if m else np.zeros(0, bool)
    FUV = np.where(in_range, FUV, -1)
    fin = np.zeros(m, bool)
    fin[~missing] = np.isfinite(UV[FUV[~missing]]).all(axis=(1, 2))
    non_finite = ~missing & ~fin
    usable = ~missing & fin
    label = -np.ones(m, np.int64)
    det = np.full(m, np.nan)
    signed = np.full(m, np.nan)
    n = 0
    if usable.any():
        n, label[usable] = uv_islands(FUV[usable])
        det[usable] = face_dets(Vn, F[usable], UV, FUV[usable])
        signed[usable] = signed_areas_2d(UV, FUV[usable])
    a3 = face_areas(Vn, F) if m else np.zeros(0)
    deg3 = no_3d_area(Vn, F, a3)
    lab_u = label[usable]
    density, mirrored = _density(signed[usable], a3[usable], lab_u, n, count=~deg3[usable])
    return LayoutFacts(Vn=Vn, F=F, UV=UV, FUV=FUV, missing=missing, non_finite=non_finite, label=label, n_islands=int(n),
                       det=det, signed_uv=signed, area3d=a3, density=density, mirrored=mirrored, degenerate3d=deg3,
                       min_overlap=float(min_overlap))


def defect_area(texels, resolution):
    """The UV area of ``texels`` texels (of area) in a ``resolution``² texture: the size under which a defect
    cannot show in a texture of that resolution.

    Examples
    --------
    >>> defect_area(0.5, 1024) * 1024 ** 2
    0.5
    """
    return float(texels) / float(resolution) ** 2 if texels and resolution else 0.0


def face_texel_density(V, F, UV, FUV=None):
    """Texel density of each face's island, relative to the median island: 1 everywhere for one density.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional (default ``F``)

    Returns
    -------
    (m,) float array

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2], [0, 1, 2]])
    >>> UV = np.array([[0, 0], [.2, 0], [0, .2], [.5, .5], [.9, .5], [.5, .9]])
    >>> face_texel_density(V, F, UV, np.array([[0, 1, 2], [3, 4, 5]])).round(3).tolist()
    [0.667, 1.333]
    """
    F = np.asarray(F, np.int64)
    FUV = F if FUV is None else np.asarray(FUV, np.int64)
    _, lab = uv_islands(FUV)
    d = texel_density(V, F, UV, FUV, labels=lab)
    return d[lab] / np.nanmedian(d)
