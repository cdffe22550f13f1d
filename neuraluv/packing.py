"""Packing chart UVs into the unit square.

The paper packs its charts "with an area-scaled shelf packer" (Sec. 4): every
chart keeps its own 3D scale (so texel density is uniform across charts), charts
are placed left to right on shelves sorted by height, and the whole layout is
scaled uniformly into ``[0,1]²``. Charts are only translated and uniformly
scaled, never mirrored, so orientation (det J > 0) is preserved.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neuraluv.jacobian import signed_areas_2d

__all__ = ["PackResult", "shelf_pack", "rotate_to_min_box", "xatlas_pack"]


@dataclass
class PackResult:
    """Output of :func:`shelf_pack`.

    Attributes
    ----------
    uvs : list of (n_i,2) float arrays, each chart's UVs in ``[0,1]²``.
    scale : float, the common factor from 3D units to the unit square.
    offsets : (c,2) float array, where each chart's bounding-box corner went.
    utilisation : float, summed chart UV area / area of the unit square.
    padding_texels : float, the smallest gap between two boxes in texels at
        ``resolution`` (inf for a single chart; None without a resolution).
    """

    uvs: list
    scale: float
    offsets: np.ndarray
    utilisation: float
    padding_texels: float | None = None


def _layout(sizes, gap, width):
    order = np.argsort(-sizes[:, 1], kind="stable")
    pos = np.zeros_like(sizes)
    x = y = shelf_h = 0.0
    used_w = 0.0
    for i in order:
        w, h = sizes[i]
        if x > 0 and x + w > width:
            y += shelf_h + gap
            x = shelf_h = 0.0
        pos[i] = (x, y)
        x += w + gap
        used_w = max(used_w, x - gap)
        shelf_h = max(shelf_h, h)
    return pos, used_w, y + shelf_h


def _poly_area(uv, F):
    return 0.0 if F is None else float(np.abs(signed_areas_2d(uv, F)).sum())


def shelf_pack(uvs, faces=None, *, padding=2.0, resolution=1024, margin=None):
    """Pack charts (at a common scale) into the unit square with a shelf packer.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays
        Each chart's UVs in 3D units (e.g. :class:`~neuraluv.solver.ChartResult.uv`).
    faces : list of (m_i,3) int arrays, optional
        Chart faces, used only to report utilisation.
    padding : float
        Gap between charts, and between charts and the border, in texels.
    resolution : int or None
        Texture resolution the padding refers to. ``None`` packs with no gap.
    margin : float, optional
        Border margin in unit-square units; defaults to the padding.

    Returns
    -------
    PackResult

    Examples
    --------
    >>> sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]])
    >>> res = shelf_pack([sq, 2 * sq], padding=4, resolution=64)
    >>> all(((u >= 0) & (u <= 1)).all() for u in res.uvs), res.padding_texels >= 4
    (True, True)
    """
    uvs = [np.asarray(u, float) for u in uvs]
    lo = np.array([u.min(0) for u in uvs])
    sizes = np.array([u.max(0) - u.min(0) for u in uvs])
    sizes = np.maximum(sizes, 1e-12 * max(sizes.max(), 1e-300))
    width = max(np.sqrt((sizes[:, 0] * sizes[:, 1]).sum()) * 1.15, sizes[:, 0].max())
    pad_uv = 0.0 if resolution is None else float(padding) / float(resolution)
    mg = pad_uv if margin is None else float(margin)
    if 2 * mg >= 0.5:
        raise ValueError("padding/margin too large for the resolution")
    gap = 0.0
    for _ in range(20):
        pos, W, H = _layout(sizes, gap, width)
        scale = (1.0 - 2 * mg) / max(W, H)
        need = pad_uv / scale
        if gap >= need * (1 - 1e-9):
            break
        gap = need * 1.01
    out = [((u - l) + p) * scale + mg for u, l, p in zip(uvs, lo, pos)]
    area = sum(_poly_area(u, f) for u, f in zip(out, faces)) if faces is not None else float("nan")
    ptex = None
    if resolution is not None:
        ptex = float("inf") if len(uvs) == 1 else float(gap * scale * resolution)
    return PackResult(uvs=out, scale=float(scale), offsets=pos * scale + mg, utilisation=area, padding_texels=ptex)


def rotate_to_min_box(uv):
    """Rotate a chart (no mirroring) so its axis-aligned bounding box is smallest.

    The optimal box is aligned with an edge of the convex hull (Freeman &
    Shapira 1975), so only the hull edge directions are tried.

    Parameters
    ----------
    uv : (n,2) float array

    Returns
    -------
    uv : (n,2) float array, rotated about the origin (det of the map is +1).

    Examples
    --------
    >>> c, s = np.cos(0.3), np.sin(0.3)
    >>> sq = np.array([[0., 0], [2, 0], [2, 1], [0, 1]]) @ np.array([[c, s], [-s, c]])
    >>> r = rotate_to_min_box(sq)
    >>> round(float(np.prod(r.max(0) - r.min(0))), 6)
    2.0
    """
    uv = np.asarray(uv, float)
    if len(uv) < 3:
        return uv.copy()
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = uv[ConvexHull(uv).vertices]
    except (QhullError, ValueError):
        return uv.copy()
    e = np.roll(hull, -1, axis=0) - hull
    ang = np.unique(np.round(np.mod(np.arctan2(e[:, 1], e[:, 0]), np.pi / 2), 12))
    best, best_a = None, 0.0
    for a in ang:
        c, s = np.cos(-a), np.sin(-a)
        h = hull @ np.array([[c, s], [-s, c]])
        area = float(np.prod(h.max(0) - h.min(0)))
        if best is None or area < best * (1 - 1e-12):
            best, best_a = area, a
    c, s = np.cos(-best_a), np.sin(-best_a)
    out = uv @ np.array([[c, s], [-s, c]])
    ext = out.max(0) - out.min(0)
    if ext[1] > ext[0]:  # lie flat: shelves prefer wide, low charts
        out = out @ np.array([[0.0, -1.0], [1.0, 0.0]])
    return out


def xatlas_pack(uvs, faces, *, padding=2.0, resolution=1024):
    """Pack charts with xatlas's packer (rotations by quarter turns, no mirroring).

    xatlas packs each chart's bounding rectangle (two triangles); only the
    placement it chooses (where, and whether turned a quarter) is read back and
    applied to the float64 chart UVs, because xatlas's own output coordinates
    are float32 and snapped to its texel grid, which can flip tiny triangles.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays
        Charts at a common scale (3D units), e.g. after :func:`rotate_to_min_box`.
    faces : list of (m_i,3) int arrays
        Chart faces, used for the utilisation.
    padding : float
        Padding in texels at ``resolution``.
    resolution : int

    Returns
    -------
    PackResult

    Raises
    ------
    ImportError
        Without the ``xatlas`` package.
    ValueError
        When xatlas needs more than one atlas page.
    """
    import xatlas

    uvs = [np.asarray(u, float) for u in uvs]
    lo = np.array([u.min(0) for u in uvs])
    size = np.array([u.max(0) - u.min(0) for u in uvs])
    size = np.maximum(size, 1e-9 * size.max())
    # xatlas rasterises charts: give needle-thin charts at least ~2 texels of box
    tex = float(resolution) * np.sqrt(0.5 / max(float((size[:, 0] * size[:, 1]).sum()), 1e-300))
    size = np.maximum(size, 2.0 / tex)
    # rectangles laid out disjointly (xatlas also uses positions to find charts)
    start = shelf_pack([np.array([[0, 0], [w, 0], [w, h], [0, h]]) for w, h in size], padding=2.0,
                       resolution=max(int(resolution), 64))
    quad = np.array([[0, 1, 2], [0, 2, 3]])
    allu = np.vstack(start.uvs).astype(np.float32)
    allf = np.vstack([quad + 4 * i for i in range(len(uvs))]).astype(np.uint32)
    at = xatlas.Atlas()
    at.add_uv_mesh(allu, allf)
    po = xatlas.PackOptions()
    po.padding = int(np.ceil(padding))
    po.resolution = int(resolution)
    po.bilinear = True
    po.rotate_charts = True
    po.rotate_charts_to_axis = False
    at.generate(xatlas.ChartOptions(), po)
    if at.atlas_count != 1:
        raise ValueError(f"xatlas needed {at.atlas_count} atlas pages at resolution {resolution}; use the shelf packer")
    vmap, ind, out = at[0]
    vmap = np.asarray(vmap, np.int64)
    out = np.asarray(out, float) * [at.width, at.height] / max(at.width, at.height)
    boxes = np.zeros((len(uvs), 2, 2))
    boxes[:, 0] = np.inf
    boxes[:, 1] = -np.inf
    chart = vmap // 4
    np.minimum.at(boxes[:, 0], chart, out)
    np.maximum.at(boxes[:, 1], chart, out)
    ob = boxes[:, 1] - boxes[:, 0]
    turned = (ob[:, 0] >= ob[:, 1]) != (size[:, 0] >= size[:, 1])
    sz = np.where(turned[:, None], size[:, ::-1], size)
    s_all = float(np.median(ob.max(1) / sz.max(1)))
    packed, area = [], 0.0
    R = np.array([[0.0, 1.0], [-1.0, 0.0]])  # a quarter turn (det +1)
    for i, u in enumerate(uvs):
        p = u - lo[i] - 0.5 * size[i]
        if turned[i]:
            p = p @ R
        s = min(s_all, float(np.min(ob[i] / np.maximum(sz[i], 1e-300))))
        packed.append(p * s + boxes[i].mean(0))
    if faces is not None:
        area = sum(_poly_area(u, f) for u, f in zip(packed, faces))
    return PackResult(uvs=packed, scale=s_all, offsets=boxes[:, 0].copy(), utilisation=area, padding_texels=float(padding))
