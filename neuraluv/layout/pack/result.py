"""What every packer returns (:class:`PackResult`), and the measurements packers share."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neuraluv.jacobian import signed_areas_2d
from neuraluv.layout.overlap import gaps, triangles_union

__all__ = ["PackResult", "uv_area", "min_gap", "fullest"]


@dataclass
class PackResult:
    """A packing of islands into the unit square (or into UDIM tiles).

    Attributes
    ----------
    uvs : list of (n_i,2) float arrays, each packed island's UVs in ``[0,1]²`` (of its page).
    scale : float, the common factor from the islands' units to the unit square.
    offsets : (c,2) float array, each packed island's bounding-box corner.
    utilisation : float, summed island UV area per page (NaN when no faces were given).
    padding_texels : float or None, the smallest gap between two islands (or to the border) in
        texels at the packer's resolution (inf for a single island; None without a resolution).
    pages : (c,) int array or None, the page (UDIM tile) of each packed island.
    packer : str, the packer that produced it (set by the caller when it fell back to another).
    pieces : list of ``(island, faces, vertices)`` or None, when islands were packed cut into parts
        (:func:`~neuraluv.layout.pack.cuts.granular_islands`): per packed part its island, its faces
        (into the island's ``F``) and vertices (the rows of the island's UVs that ``uvs[j]`` holds).
    raster_scale : float or None, the scale :func:`~neuraluv.layout.pack.raster.raster_pack` placed at
        (before the layout was grown to the padding line).
    trials : int, packings tried (the fullest was kept).
    """

    uvs: list
    scale: float
    offsets: np.ndarray
    utilisation: float
    padding_texels: float | None = None
    pages: np.ndarray | None = None
    packer: str = ""
    pieces: list | None = None
    raster_scale: float | None = None
    trials: int = 1

    @property
    def n_pages(self):
        """Pages (UDIM tiles) used: 1 without ``pages``."""
        return 1 if self.pages is None or not len(self.pages) else int(self.pages.max()) + 1


def uv_area(uv, F):
    """Unsigned UV area of an island's triangles (0 without faces).

    Examples
    --------
    >>> uv_area(np.array([[0., 0], [2, 0], [0, 1]]), np.array([[0, 2, 1]]))
    1.0
    """
    return 0.0 if F is None else float(np.abs(signed_areas_2d(np.asarray(uv, float), F)).sum())


def min_gap(uvs, faces, pages=None, within=0.05, *, polys=None):
    """Smallest distance between two islands on the same page, and from an island to the page border.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays, in ``[0,1]²``
    faces : list of (m_i,3) int arrays
    pages : (c,) int array, optional
    within : float
        Island pairs farther apart than this are not measured.
    polys : list of shapely geometries, optional
        The islands' :func:`~neuraluv.layout.overlap.triangles_union`, when the caller has them.

    Returns
    -------
    float (UV units)

    Examples
    --------
    >>> t = np.array([[0, 1, 2]]); a = np.array([[.1, .1], [.3, .1], [.1, .3]])
    >>> round(min_gap([a, a + [.24, 0]], [t, t]), 12)   # 0.04 apart, 0.1 from the border
    0.04
    """
    if polys is None:
        polys = [triangles_union(u, f)[0] for u, f in zip(uvs, faces)]
    gap = min(min(float(u.min()), float(1 - u.max())) for u in uvs) if uvs else float("inf")
    _, _, d = gaps(polys, within, pages)
    return min(gap, float(d.min())) if len(d) else gap


def fullest(makers):
    """The fullest :class:`PackResult` (fewest pages first) that the callables ``makers`` produce.

    Re-raises the last ``ValueError`` when none of them packs.
    """
    best, err = None, None
    for make in makers:
        try:
            r = make()
        except ValueError as exc:
            err = exc
            continue
        if best is None or (-r.n_pages, r.utilisation) > (-best.n_pages, best.utilisation):
            best = r
    if best is None:
        raise err
    return best
