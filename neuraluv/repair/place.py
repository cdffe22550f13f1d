"""Moving islands into free space: the smallest move that removes an overlap.

An island that overlaps another, lies outside the unit square or is new is
placed where it fits in the free space of the layout — translated, turned by a
quarter turn if it has to be (never mirrored), scaled down uniformly only if
it fits nowhere at its own size — as close to where it was as possible. Every
other island stays where it is.

The search is a raster one (Lévy et al.'s Tetris-style packers and xatlas do
the same): the fixed islands, grown by the padding, are drawn conservatively
into an occupancy grid; the moving island's mask is correlated with it by FFT,
which gives every grid offset at which the two masks do not touch; offsets are
tried nearest first, and each is verified exactly with shapely (polygon
intersection and distance) before it is accepted, so the raster never decides
validity.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Placement", "island_polygon", "place_island", "quarter_turn"]

_HALF_DIAG = 0.7072  # a cell meets a shape iff its centre is within half a diagonal (cells are unit squares)


def island_polygon(UV, T):
    """The union of an island's UV triangles (shapely), ``T (k,3)`` rows of ``UV``."""
    from neuraluv.atlas.validate import triangles_union

    return triangles_union(UV, T)[0]


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


@dataclass
class Placement:
    """Where :func:`place_island` put an island.

    Attributes
    ----------
    uv : (k,2) float array, the island's new UV rows (None when it fits nowhere).
    turns : int, quarter turns applied (counter-clockwise).
    scale : float, uniform scale applied (1 unless it had to shrink).
    shift : (2,) float array, translation of the island's bounding-box corner.
    distance : float, how far its bounding-box corner moved (UV units).
    tried : int, candidate offsets verified exactly.
    """

    uv: np.ndarray | None
    turns: int = 0
    scale: float = 1.0
    shift: np.ndarray | None = None
    distance: float = 0.0
    tried: int = 0


def _cells(geom, grid, dist):
    """Boolean ``(grid, grid)`` mask of cells whose centre is within ``dist`` (cell units) of ``geom`` (cell units)."""
    import shapely

    out = np.zeros((grid, grid), bool)
    if geom is None or geom.is_empty:
        return out
    x0, y0, x1, y1 = geom.bounds
    i0, j0 = max(int(np.floor(x0 - dist - 1)), 0), max(int(np.floor(y0 - dist - 1)), 0)
    i1, j1 = min(int(np.ceil(x1 + dist + 1)), grid), min(int(np.ceil(y1 + dist + 1)), grid)
    if i1 <= i0 or j1 <= j0:
        return out
    g = geom.buffer(dist, quad_segs=4) if dist > 0 else geom
    shapely.prepare(g)
    xs, ys = np.meshgrid(np.arange(i0, i1) + 0.5, np.arange(j0, j1) + 0.5, indexing="ij")
    out[i0:i1, j0:j1] = shapely.intersects_xy(g, xs, ys)
    return out


def occupancy(polys, grid, pad):
    """Cells (``grid × grid`` over the unit square) within ``pad`` (UV units) of any of ``polys``, conservatively."""
    from shapely import affinity

    occ = np.zeros((grid, grid), bool)
    for P in polys:
        if P is None or P.is_empty:
            continue
        occ |= _cells(affinity.scale(P, grid, grid, origin=(0, 0)), grid, pad * grid + _HALF_DIAG)
    return occ


def place_island(uv, T, fixed, *, resolution=1024, padding=2.0, grid=None, scales=(1.0,), turns=(0, 1, 2, 3),
                 occ=None, max_tries=24):
    """Translate (and if needed turn, then shrink) one island into free space, nearest to where it was.

    Parameters
    ----------
    uv : (k,2) float array
        The island's UV rows as they are now.
    T : (t,3) int array
        Its triangles, indices into ``uv``.
    fixed : list of shapely geometries
        Every island that stays (already placed ones included).
    resolution : int
        Texture resolution of the padding.
    padding : float
        Gap to keep from every fixed island, in texels.
    grid : int, optional
        Raster size (default ``resolution`` clamped to 256–4096).
    scales : sequence of float
        Uniform scales to try, in order (1 first: shrink only if needed).
    turns : sequence of int
        Quarter turns to try, in order.
    occ : (grid, grid) bool array, optional
        Occupancy of ``fixed`` (see :func:`occupancy`), reused across islands.
    max_tries : int
        Exact verifications per orientation and scale.

    Returns
    -------
    Placement
        ``uv`` None when the island fits nowhere.

    Examples
    --------
    >>> from shapely.geometry import box
    >>> T = np.array([[0, 1, 2], [1, 3, 2]]); uv = np.array([[0.1, 0.1], [0.3, 0.1], [0.1, 0.3], [0.3, 0.3]])
    >>> p = place_island(uv, T, [box(0.0, 0.0, 0.5, 0.5)], resolution=64, padding=1)
    >>> bool(p.uv.min() >= 0.5 or p.uv[:, 1].min() >= 0.5 or p.uv[:, 0].min() >= 0.5), p.turns, p.scale
    (True, 0, 1.0)
    """
    import shapely
    from scipy.signal import fftconvolve

    uv = np.asarray(uv, float)
    grid = int(grid or min(max(int(resolution), 256), 4096))
    pad = float(padding) / float(resolution)
    if occ is None:
        occ = occupancy(fixed, grid, pad)
    occ_f = occ.astype(np.float32)
    fixed_u = shapely.union_all([P for P in fixed if P is not None and not P.is_empty]) if fixed else None
    if fixed_u is not None:
        shapely.prepare(fixed_u)
    origin = uv.min(0)
    tries = 0
    for s in scales:
        for k in turns:
            c = 0.5 * (uv.min(0) + uv.max(0))
            q = quarter_turn(uv - c, k) * s if s != 1.0 else quarter_turn(uv - c, k)
            q = q - q.min(0)  # bounding-box corner at the origin
            ext = q.max(0)
            if ext.max() > 1.0 - 2 * pad:
                continue
            P0 = island_polygon(q, T)
            from shapely import affinity

            M = _cells(affinity.scale(P0, grid, grid, origin=(0, 0)), grid, _HALF_DIAG)
            h, w = int(np.ceil(ext[0] * grid)) + 2, int(np.ceil(ext[1] * grid)) + 2
            M = M[:h, :w]
            if M.shape[0] >= grid or M.shape[1] >= grid:
                continue
            hits = fftconvolve(occ_f, M[::-1, ::-1].astype(np.float32), mode="valid")
            free = np.argwhere(hits < 0.5)
            if not len(free):
                continue
            target = origin * grid
            d = np.hypot(free[:, 0] - target[0], free[:, 1] - target[1])
            for idx in np.argsort(d, kind="stable")[:max_tries]:
                tries += 1
                shift = free[idx] / grid
                cand = q + shift
                if cand.min() < 0 or cand.max() > 1:
                    continue
                Pc = island_polygon(cand, T)
                if fixed_u is not None and (Pc.intersects(fixed_u) and Pc.intersection(fixed_u).area > 0
                                            or Pc.distance(fixed_u) < pad * (1 - 1e-9)):
                    continue
                return Placement(uv=cand, turns=int(k), scale=float(s), shift=shift - origin,
                                 distance=float(np.hypot(*(shift - origin))), tried=tries)
    return Placement(uv=None, tried=tries)
