"""Which UV triangles overlap which, how far apart islands are, whether a boundary crosses itself.

The one overlap engine of the package. Two triangles overlap when their
interiors share area. For convex polygons that is decided exactly by the
separating axis theorem: they are disjoint (or only touch along an edge or at a
corner) if and only if the projections on one of the six edge normals do not
overlap with positive length. Candidates come from an STRtree of the triangles'
bounding boxes (shapely/GEOS); the test itself is NumPy, so a 100k-face layout
takes about a second. Shared areas, island outlines (unions) and the gaps
between islands are exact polygon arithmetic (shapely).
"""
from __future__ import annotations

import numpy as np
import shapely

from neuraluv.jacobian import signed_areas_2d
from neuraluv.topology import boundary_loop

__all__ = ["candidate_pairs", "overlapping_pairs", "pair_areas", "overlap_pairs", "find_overlaps", "self_overlap",
           "triangles_union", "outline_rings", "gaps", "boundary_is_simple"]

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

    Examples
    --------
    >>> t = np.array([[[0., 0], [1, 0], [0, 1]], [[.5, .5], [2, .5], [.5, 2]], [[5., 5], [6, 5], [5, 6]]])
    >>> [a.tolist() for a in candidate_pairs(t)]
    [[0], [1]]
    """
    def boxes(t):
        lo, hi = t.min(1), t.max(1)
        return shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1])

    empty = np.zeros(0, np.int64), np.zeros(0, np.int64)
    A = boxes(tri_a) if len(tri_a) else None
    if tri_b is None:
        if A is None or len(A) < 2:
            return empty
        i, j = shapely.STRtree(A).query(A)
        keep = i < j
        return i[keep].astype(np.int64), j[keep].astype(np.int64)
    if A is None or not len(tri_b):
        return empty
    ia, ib = shapely.STRtree(boxes(tri_b)).query(A)  # (index of the query geometry in A, index in the tree B)
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


def _polygons(T):
    return shapely.polygons(np.concatenate([T, T[:, :1]], axis=1))


def pair_areas(P, Q):
    """Exact shared area of triangle pairs (shapely), ``(k,)`` float array.

    Examples
    --------
    >>> t = np.array([[[0., 0], [1, 0], [0, 1]]])
    >>> pair_areas(t, t).tolist()
    [0.5]
    """
    if not len(P):
        return np.zeros(0)
    return shapely.area(shapely.intersection(_polygons(np.asarray(P, float)), _polygons(np.asarray(Q, float))))


def points_in_triangles(points, tris):
    """Which triangles contain which points (strictly inside): pairs ``(point, triangle)``.

    Parameters
    ----------
    points : (k,2) float array
    tris : (t,3,2) float array

    Returns
    -------
    p, t : (q,) int arrays

    Examples
    --------
    >>> T = np.array([[[0., 0], [1, 0], [0, 1]], [[2., 2], [3, 2], [2, 3]]])
    >>> [a.tolist() for a in points_in_triangles(np.array([[0.2, 0.2], [5., 5], [2.1, 2.1]]), T)]
    [[0, 2], [0, 1]]
    """
    points = np.asarray(points, float).reshape(-1, 2)
    tris = np.asarray(tris, float).reshape(-1, 3, 2)
    if not len(points) or not len(tris):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    lo, hi = tris.min(1), tris.max(1)
    p, t = shapely.STRtree(shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1])).query(shapely.points(points))
    a, b, c, q = tris[t, 0], tris[t, 1], tris[t, 2], points[p]

    def cross(u, v, w):
        return (v[:, 0] - u[:, 0]) * (w[:, 1] - u[:, 1]) - (v[:, 1] - u[:, 1]) * (w[:, 0] - u[:, 0])

    s = np.sign(cross(a, b, c))
    inside = (s != 0) & (np.sign(cross(a, b, q)) == s) & (np.sign(cross(b, c, q)) == s) & (np.sign(cross(c, a, q)) == s)
    return p[inside].astype(np.int64), t[inside].astype(np.int64)


def overlap_pairs(UV, FUV, faces, subset=None, *, areas=False):
    """Pairs of ``faces`` whose UV triangles overlap (exactly; touching does not count).

    Parameters
    ----------
    UV : (p,2) float array
    FUV : (m,3) int array
    faces : (k,) int array
        The faces tested against each other.
    subset : (s,) int array, optional
        Only pairs with at least one face in ``subset``.
    areas : bool
        Also return the shared areas, and keep only pairs whose shared area is positive.

    Returns
    -------
    i, j : (q,) int arrays, face indices (``i < j``, each pair once); and ``area (q,)`` with ``areas``.

    Examples
    --------
    >>> UV = np.array([[0., 0], [1, 0], [0, 1], [.2, .2], [1.2, .2], [.2, 1.2], [3, 3], [4, 3], [3, 4]])
    >>> FUV = np.array([[0, 1, 2], [3, 4, 5], [6, 7, 8]])
    >>> [a.tolist() for a in overlap_pairs(UV, FUV, [0, 1, 2])], overlap_pairs(UV, FUV, [0, 1, 2], [2])[0].tolist()
    ([[0], [1]], [])
    """
    faces = np.asarray(faces, np.int64)
    tri = np.asarray(UV, float)[np.asarray(FUV, np.int64)[faces]]
    if subset is None:
        a, b = candidate_pairs(tri)
    else:
        sub = np.flatnonzero(np.isin(faces, subset))
        # only the faces whose boxes meet the subset's box are searched (a small region of a large island)
        lo, hi = tri.min(1), tri.max(1)
        near = np.flatnonzero((hi >= lo[sub].min(0)).all(1) & (lo <= hi[sub].max(0)).all(1)) if len(sub) \
            else np.zeros(0, np.int64)
        a, b = candidate_pairs(tri[sub], tri[near])
        a, b = sub[a], near[b]
        keep = a != b
        lo, hi = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
        both = np.unique(np.stack([lo, hi], 1), axis=0) if len(lo) else np.zeros((0, 2), np.int64)
        a, b = both[:, 0], both[:, 1]
    hit = overlapping_pairs(tri[a], tri[b])
    a, b = a[hit], b[hit]
    if not areas:
        return faces[a], faces[b]
    area = pair_areas(tri[a], tri[b])
    keep = area > 0
    return faces[a[keep]], faces[b[keep]], area[keep]


def find_overlaps(facts, faces=None):
    """Overlapping pairs of UV triangles oriented like their island (``LayoutFacts.oriented``).

    Parameters
    ----------
    facts : :class:`~neuraluv.layout.facts.LayoutFacts`
    faces : int array, optional
        Only pairs with at least one face in this set (default: all).

    Returns
    -------
    i, j : (k,) int arrays, face indices (``i < j``).
    area : (k,) float array, their shared UV area.
    """
    pos = np.flatnonzero(facts.oriented)
    return overlap_pairs(facts.UV, facts.FUV, pos, faces, areas=True)


def self_overlap(UV, F):
    """Share of a chart's UV area covered twice: ``Σ_pairs |t_i ∩ t_j| / Σ_t |A_t|`` (0 when injective).

    Examples
    --------
    >>> UV = np.array([[0., 0], [1, 0], [0, 1], [1, 1]])
    >>> self_overlap(UV, np.array([[0, 1, 2], [1, 3, 2]])), self_overlap(UV, np.array([[0, 1, 2], [0, 1, 3]])) > 0
    (0.0, True)
    """
    F = np.asarray(F, np.int64)
    total = float(np.abs(signed_areas_2d(np.asarray(UV, float), F)).sum()) if len(F) else 0.0
    if total <= 0:
        return 0.0
    *_, area = overlap_pairs(UV, F, np.arange(len(F)), areas=True)
    return float(area.sum() / total)


def triangles_union(UV, F):
    """The union of UV triangles as one shapely geometry, and their summed unsigned area.

    Parameters
    ----------
    UV : (p,2) float array
    F : (m,3) int array
        Triangles as indices into ``UV``.

    Returns
    -------
    union : shapely geometry (exact polygon union, GEOS)
    total : float, ``Σ_t |A_t|`` (equals ``union.area`` when no two triangles overlap)

    Notes
    -----
    When every triangle is counter-clockwise and the boundary edges (those whose reverse no
    triangle uses) chain into one counter-clockwise loop and clockwise ones that make a valid
    polygon :math:`P`, the union is :math:`P`, built from the loops without the overlay
    (about 20 times faster): the triangles' indicators sum to the winding number of their
    boundary chain (shared edges cancel), which is :math:`1_P`, so they cover :math:`P` once
    and nothing else. Otherwise the union is GEOS's. The same point set either way; the rings
    may start at another vertex, or run the other way, than GEOS's.

    Examples
    --------
    >>> U, t = triangles_union(np.array([[0., 0], [1, 0], [0, 1], [1, 1]]), np.array([[0, 1, 2], [1, 3, 2]]))
    >>> round(U.area, 12), t
    (1.0, 1.0)
    """
    UV, F = np.asarray(UV, float), np.asarray(F, np.int64)
    areas = signed_areas_2d(UV, F)
    total = float(np.abs(areas).sum())
    union = _boundary_polygon(UV, F) if len(F) and (areas > 0).all() else None
    return (shapely.union_all(_polygons(UV[F])) if union is None else union), total


def _boundary_polygon(UV, F):
    """The polygon bounded by the boundary edges of counter-clockwise triangles, or None when they do not chain
    into one counter-clockwise loop and clockwise ones making a valid polygon (see :func:`triangles_union`)."""
    e = F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)  # directed edges
    key = e[:, 0] * len(UV) + e[:, 1]
    if len(np.unique(key)) < len(key):  # an edge used twice the same way: the faces are not oriented alike
        return None
    b = e[~np.isin(key, e[:, 1] * len(UV) + e[:, 0])]
    nxt = np.full(len(UV), -1)
    nxt[b[:, 0]] = b[:, 1]
    if len(b) < 3 or np.count_nonzero(nxt >= 0) < len(b):  # two boundary edges leave one vertex
        return None
    seen, shells, holes = np.zeros(len(UV), bool), [], []
    for s in b[:, 0]:
        if seen[s]:
            continue
        ring, v = [s], nxt[s]
        seen[s] = True
        while v != s:
            if v < 0 or seen[v]:
                return None
            seen[v] = True
            ring.append(v)
            v = nxt[v]
        r = UV[ring]
        (shells if shapely.LinearRing(r).is_ccw else holes).append(r)
    if len(shells) != 1:
        return None
    poly = shapely.Polygon(shells[0], holes)
    return poly if poly.is_valid else None


def outline_rings(shape, holes=False):
    """The rings of a shapely (multi)polygon: ``[(exterior (k,2), [interiors]), ...]`` (interiors only with ``holes``).

    Examples
    --------
    >>> from shapely.geometry import box
    >>> [(e.shape, len(h)) for e, h in outline_rings(box(0, 0, 1, 1))]
    [((5, 2), 0)]
    """
    parts = getattr(shape, "geoms", [shape])
    return [(np.asarray(p.exterior.coords), [np.asarray(r.coords) for r in p.interiors] if holes else [])
            for p in parts if p.geom_type == "Polygon" and not p.is_empty]


def gaps(polys, within, pages=None, skip=()):
    """Pairs of islands closer than ``within`` and their distances (exact polygon distances).

    Parameters
    ----------
    polys : sequence of shapely geometries, one per island
    within : float
        Largest distance of interest.
    pages : (k,) int array, optional
        Islands on different pages (UDIM tiles) are never near.
    skip : set of (i, j)
        Pairs to leave out (e.g. islands stacked on purpose).

    Returns
    -------
    i, j : (q,) int arrays (``i < j``); d : (q,) float array

    Examples
    --------
    >>> from shapely.geometry import box
    >>> [x.tolist() for x in gaps([box(0, 0, 1, 1), box(1.5, 0, 2, 1), box(9, 9, 10, 10)], 1.0)]
    [[0], [1], [0.5]]
    """
    P = np.array(list(polys), dtype=object)
    if len(P) < 2:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    a, b = shapely.STRtree(P).query(P, predicate="dwithin", distance=float(within))
    keep = a < b
    if pages is not None:
        pages = np.asarray(pages)
        keep &= pages[a] == pages[b]
    a, b = a[keep], b[keep]
    if skip:
        ok = np.array([(int(i), int(j)) not in skip for i, j in zip(a, b)], bool)
        a, b = a[ok], b[ok]
    d = shapely.distance(P[a], P[b]) if len(a) else np.zeros(0)
    return a.astype(np.int64), b.astype(np.int64), np.asarray(d, float)


def boundary_is_simple(UV, F):
    """True when the chart's boundary loop does not cross itself in UV (with no flip: globally injective).

    Examples
    --------
    >>> F = np.array([[0, 1, 2], [0, 2, 3]])
    >>> boundary_is_simple(np.array([[0., 0], [1, 0], [1, 1], [0, 1]]), F)
    True
    """
    bnd = boundary_loop(F)
    if len(bnd) < 3:
        return False
    return bool(shapely.LinearRing(np.asarray(UV, float)[bnd]).is_simple)
