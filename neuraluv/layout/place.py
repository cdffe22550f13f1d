"""Moving an island into the free space of a layout: the smallest move that removes an overlap.

An island that overlaps another, lies outside the unit square or is new is
placed where it fits in the free space of the layout — translated, turned by a
quarter turn if it has to be (never mirrored), scaled down uniformly only if it
fits nowhere at its own size — as close to where it was as possible. Every other
island stays where it is.

The search is a raster one (:mod:`~neuraluv.layout.raster`, as the packers'):
the fixed islands, grown by the padding, are drawn into an occupancy grid; one
correlation with the moving island's mask gives every offset at which the two do
not touch; offsets are tried nearest first, and each is verified exactly (polygon
intersection and distance to the nearby fixed islands) before it is accepted, so
the raster never decides validity.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from neuraluv.layout.overlap import outline_rings, triangles_union
from neuraluv.layout.raster import Page, dilate, rasterise, room
from neuraluv.layout.rigid import quarter_turn

__all__ = ["Placement", "FreeSpace"]


@dataclass
class Placement:
    """Where :meth:`FreeSpace.place` put an island.

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


def _rings(polys):
    """Rings of shapely geometries, larger boxes first (a shape inside another's hole is drawn after it)."""
    polys = [P for P in polys if P is not None and not P.is_empty]
    polys.sort(key=lambda P: -(P.bounds[2] - P.bounds[0]) * (P.bounds[3] - P.bounds[1]))
    return [r for P in polys for r in outline_rings(P, holes=True)]


class FreeSpace:
    """The free space of a layout in ``[0,1]²``, for placing islands one at a time.

    Parameters
    ----------
    fixed : list of shapely geometries
        The islands that stay.
    resolution : int
        Texture resolution of the padding.
    padding : float
        Gap to keep from every fixed island, in texels.
    grid : int, optional
        Raster cells per side (default ``resolution`` clamped to 256–4096).

    Examples
    --------
    >>> from shapely.geometry import box
    >>> T = np.array([[0, 1, 2], [1, 3, 2]]); uv = np.array([[0.1, 0.1], [0.3, 0.1], [0.1, 0.3], [0.3, 0.3]])
    >>> p = FreeSpace([box(0.0, 0.0, 0.5, 0.5)], resolution=64, padding=1).place(uv, T)
    >>> bool(p.uv[:, 0].min() >= 0.5 or p.uv[:, 1].min() >= 0.5), p.turns, p.scale
    (True, 0, 1.0)
    """

    def __init__(self, fixed, *, resolution=1024, padding=2.0, grid=None):
        self.grid = int(grid or min(max(int(resolution), 256), 4096))
        self.pad = float(padding) / float(resolution)
        self.polys = []
        self._tree = None
        self.page = Page((self.grid, self.grid))
        self.add(*fixed)

    def add(self, *polys):
        """Mark islands (shapely geometries) as fixed."""
        polys = [P for P in polys if P is not None and not P.is_empty]
        if not polys:
            return
        self.polys += polys
        self._tree = None
        taken, _ = rasterise(_rings(polys), self.grid, lo=(0.0, 0.0), shape=(self.grid, self.grid))
        self.page.add(dilate(taken, int(np.ceil(self.pad * self.grid)) + 1, grow=False), 0, 0)

    def clear(self, P):
        """True when the island ``P`` shares no area with a fixed island and keeps the padding from each."""
        if not self.polys:
            return True
        if self._tree is None:
            self._tree = shapely.STRtree(np.array(self.polys, dtype=object))
        near = self._tree.query(P, predicate="dwithin", distance=self.pad)
        for k in near:
            Q = self.polys[k]
            if P.distance(Q) < self.pad * (1 - 1e-9) or (P.intersects(Q) and P.intersection(Q).area > 0):
                return False
        return True

    def place(self, uv, T, *, scales=(1.0,), turns=(0, 1, 2, 3), max_tries=24):
        """Translate (and if needed turn, then shrink) one island into free space, nearest to where it was.

        Parameters
        ----------
        uv : (k,2) float array
            The island's UV rows as they are now.
        T : (t,3) int array
            Its triangles, indices into ``uv``.
        scales : sequence of float
            Uniform scales to try, in order (1 first: shrink only if needed).
        turns : sequence of int
            Quarter turns to try, in order.
        max_tries : int
            Exact verifications per orientation and scale.

        Returns
        -------
        Placement
            ``uv`` None when the island fits nowhere. The island is not added: call :meth:`add`.
        """
        uv = np.asarray(uv, float)
        g, pad = self.grid, self.pad
        origin = uv.min(0)
        c = 0.5 * (uv.min(0) + uv.max(0))
        tries = 0
        for s in scales:
            for k in turns:
                q = quarter_turn(uv - c, k) * s if s != 1.0 else quarter_turn(uv - c, k)
                q = q - q.min(0)  # bounding-box corner at the origin
                if q.max() > 1.0 - 2 * pad:
                    continue
                mask, lo = rasterise(outline_rings(triangles_union(q, T)[0]), g)
                if room(mask) > self.page.room():  # a square of it fits nowhere: no correlation needed
                    continue
                free = np.argwhere(self.page.free(mask))  # (row, col) of the mask's cell (0, 0)
                if not len(free):
                    continue
                shifts = (free[:, ::-1] - lo) / g  # UV shift of q for each free offset
                for idx in np.argsort(np.hypot(*(shifts - origin).T), kind="stable")[:max_tries]:
                    tries += 1
                    cand = q + shifts[idx]
                    if cand.min() < 0 or cand.max() > 1 or not self.clear(triangles_union(cand, T)[0]):
                        continue
                    d = shifts[idx] - origin
                    return Placement(uv=cand, turns=int(k), scale=float(s), shift=d, distance=float(np.hypot(*d)),
                                     tried=tries)
        return Placement(uv=None, tried=tries)
