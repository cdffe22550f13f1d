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

#: Packers of :func:`neuraluv.atlas.build_atlas` (the first is the default).
PACKERS = ("tight", "shelf", "xatlas")

__all__ = ["PACKERS", "PackResult", "shelf_pack", "rotate_to_min_box", "xatlas_pack", "raster_pack", "tight_pack", "xatlas_shape_pack", "island_density", "upright",
           "granular_islands", "halve_island", "float32_uvs"]


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
    pages : (c,) int array or None, the texture page (UDIM tile) of each chart.
    packer : str, the packer that produced it (``"shelf"`` when ``"tight"`` fell back).
    pieces : list of (int, (k,) int array, (n,) int array) or None, when :func:`tight_pack` packed
        charts cut by :func:`granular_islands`: per packed piece its chart, faces (into the
        chart's ``F``) and vertices (the rows of the chart's UVs that ``uvs[j]`` holds).
    raster_scale : float or None, :func:`raster_pack`'s placement scale (before growing).
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


def island_density(uv, V, F):
    """Texel-density factor of one island: ``sqrt(UV area / 3D area)`` (UV units per unit length).

    Parameters
    ----------
    uv : (n,2) float array
    V : (n,3) float array, the island's 3D vertices (same order as ``uv``)
    F : (m,3) int array

    Returns
    -------
    float

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> round(island_density(2 * V[:, :2], V, F), 12)
    2.0
    """
    from neuraluv.meshfix import face_areas

    a3 = float(face_areas(np.asarray(V, float), F).sum())
    a2 = _poly_area(np.asarray(uv, float), F)
    return float(np.sqrt(a2 / a3)) if a3 > 0 and a2 > 0 else float("nan")


def float32_uvs(UV, F, rounds=24):
    """UVs rounded to float32 values (OBJ and GLB carry the same layout) without flipping a triangle.

    A triangle thinner than float32's resolution at its place in the texture (a
    needle the solver kept positive in float64) can round to zero or negative area.
    Each such triangle's corner opposite its longest edge is pushed away from that
    edge, 2^r float32 steps in round ``r``, until every triangle that was positive
    before rounding is positive after it (or ``rounds`` run out: the validation then
    reports the flip).

    Parameters
    ----------
    UV : (n,2) float array
    F : (m,3) int array

    Returns
    -------
    (n,2) float64 array of float32-representable values

    Examples
    --------
    >>> UV = np.array([[0.5, 0.5], [0.50001, 0.5], [0.500005, 0.5 + 1e-9]])
    >>> F = np.array([[0, 1, 2]])
    >>> bool(signed_areas_2d(UV.astype(np.float32).astype(float), F)[0] > 0)  # plain rounding: flat
    False
    >>> U = float32_uvs(UV, F); bool(signed_areas_2d(U, F)[0] > 0), bool((U == U.astype(np.float32)).all())
    (True, True)
    """
    UV = np.asarray(UV, float)
    F = np.asarray(F, np.int64)
    U = UV.astype(np.float32).astype(np.float64)
    if not len(F):
        return U
    keep = signed_areas_2d(UV, F) > 0
    for r in range(int(rounds)):
        bad = np.flatnonzero(keep & (signed_areas_2d(U, F) <= 0))
        if not len(bad):
            break
        for f in bad:
            P = U[F[f]]
            i = int(np.argmax(np.linalg.norm(P[[2, 0, 1]] - P[[1, 2, 0]], axis=1)))  # corner opposite the longest edge
            p, q = P[(i + 1) % 3], P[(i + 2) % 3]
            d = q - p
            n = np.array([-d[1], d[0]]) / max(np.linalg.norm(d), 1e-300)  # left of p->q: the positive side
            step = float(np.spacing(np.float32(np.abs(P[i]).max() or 1.0))) * 2.0 ** r
            U[F[f, i]] = (P[i] + n * step).astype(np.float32)
    return U


#: :func:`granular_islands` halves islands holding more than this share of the total UV area.
SPLIT_SHARE = 1 / 10


def halve_island(uv, F):
    """Cut an island in two across its main axis, keeping every face's UVs.

    Faces go to either side of the median of their centroids' projection on the
    principal axis of the UV centroids (a straight cut across the island's length);
    each side is then split into its edge-connected pieces. The pieces keep the
    island's UVs, so they are as flip-free and overlap-free as the island was: only
    seams are added.

    Parameters
    ----------
    uv : (n,2) float array
    F : (m,3) int array

    Returns
    -------
    list of (k_i,) int arrays
        Face indices into ``F`` of each piece (together every face once).

    Examples
    --------
    >>> uv = np.array([[0., 0], [1, 0], [2, 0], [3, 0], [0, 1], [1, 1], [2, 1], [3, 1]])
    >>> F = np.array([[0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6]])
    >>> [p.tolist() for p in halve_island(uv, F)]
    [[0, 1, 3], [2, 4, 5]]
    """
    from neuraluv.topology import face_components

    F = np.asarray(F, np.int64)
    if len(F) < 2:
        return [np.arange(len(F))]
    c = np.asarray(uv, float)[F].mean(1)
    c = c - c.mean(0)
    axis = np.linalg.svd(c, full_matrices=False)[2][0]
    t = c @ axis
    side = t > np.median(t)
    if side.all() or not side.any():
        return [np.arange(len(F))]
    pieces = []
    for s in (side, ~side):
        idx = np.flatnonzero(s)
        n, lab = face_components(F[idx])
        pieces += [idx[lab == j] for j in range(n)]
    return sorted(pieces, key=lambda p: int(p[0]))


def granular_islands(uvs, faces, max_share=SPLIT_SHARE):
    """Halve (:func:`halve_island`) every island holding more than ``max_share`` of the total UV area, until
    none does: a few large islands leave gaps no packer can fill; smaller pieces nest.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays
        Islands at a common scale.
    faces : list of (m_i,3) int arrays
    max_share : float

    Returns
    -------
    list of (int, (k,) int array)
        ``(island, face indices)`` per piece, in island order; an island left whole is one piece.

    Examples
    --------
    >>> sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]]); q = np.array([[0, 1, 2], [0, 2, 3]])
    >>> [(i, f.tolist()) for i, f in granular_islands([sq, 0.1 * sq], [q, q], max_share=0.6)]
    [(0, [1]), (0, [0]), (1, [0, 1])]
    """
    areas = [_poly_area(np.asarray(u, float), np.asarray(f)) for u, f in zip(uvs, faces)]
    limit = max_share * sum(areas)
    out = []
    for i, (u, f) in enumerate(zip(uvs, faces)):
        todo, f = [np.arange(len(f))], np.asarray(f)
        while todo:
            idx = todo.pop()
            if len(idx) > 1 and _poly_area(u, f[idx]) > limit:
                parts = halve_island(u, f[idx])
                if len(parts) > 1:
                    todo += [idx[p] for p in parts]
                    continue
            out.append((i, idx))
    return out


def _outlines(uv, f):
    """A chart's outline rings (closed (k,2) arrays; holes are left out, so they count as filled)."""
    import shapely

    shape = shapely.union_all(shapely.polygons(np.asarray(uv, float)[np.asarray(f)]))
    parts = getattr(shape, "geoms", [shape])
    rings = [np.asarray(p.exterior.coords) for p in parts if p.geom_type == "Polygon" and not p.is_empty]
    return rings or [np.asarray(uv, float)[np.asarray(f)].reshape(-1, 2)]


def _raster(rings, cells):
    """Rasterise outline rings at ``cells`` grid cells per UV unit: (mask (h,w) bool, UV-cell origin (2,))."""
    from PIL import Image, ImageDraw

    lo = np.floor(np.vstack(rings).min(0) * cells) - 1.0
    qs = [r * cells - lo for r in rings]
    w, h = (np.ceil(np.vstack(qs).max(0)) + 2).astype(int)
    img = Image.new("1", (int(w), int(h)), 0)
    draw = ImageDraw.Draw(img)
    for q in qs:  # fill and outline: every cell the outline crosses is (about) marked
        draw.polygon(q.ravel().tolist(), fill=1, outline=1)
    return np.array(img, bool), lo


def _disk(r):
    y, x = np.mgrid[-r:r + 1, -r:r + 1]
    return x * x + y * y <= r * r


def _raster_place(masks, grid, dil, border, rule, pages_max):
    """Greedy placement of rasterised charts (largest first) on ``grid``² pages.

    ``masks[i]`` lists chart ``i``'s candidate masks (one per rotation). A chart goes
    where its mask, dilated by ``dil`` cells, covers no cell of a placed chart and stays
    ``border`` cells inside the page; of the free spots the first in reading order
    (``rule="corner"``) or the one that keeps the layout's box smallest (``"box"``) is
    taken. Returns ``[(page, rotation, row, col)]`` or None when a chart found no spot
    within ``pages_max`` pages.
    """
    from scipy import fft, ndimage

    se = _disk(dil)
    size = grid + 2 * dil
    shape = (fft.next_fast_len(size, real=True),) * 2
    occ, spec, ext, out = [], [], [], []
    for cands in masks:
        best = None
        for page in range(pages_max):
            if page == len(occ):
                occ.append(np.zeros((size, size), np.float32))
                spec.append(None)
                ext.append((0, 0))
            W, H = ext[page]
            for k, m in enumerate(cands):
                h, w = m.shape
                if h > grid - 2 * border or w > grid - 2 * border:
                    continue
                D = ndimage.binary_dilation(np.pad(m, dil), se).astype(np.float32)
                if spec[page] is None:  # an empty page: every spot is free
                    hit = np.zeros((grid - h + 1, grid - w + 1), np.float32)
                else:  # hit[y, x] = sum_ij occ[y+i, x+j] D[i, j]: no wrap-around inside the valid range
                    hit = fft.irfft2(spec[page] * np.conj(fft.rfft2(D, shape)), shape)[:grid - h + 1, :grid - w + 1]
                free = hit[border:grid - border - h + 1, border:grid - border - w + 1] < 0.5
                if rule == "corner":  # the first free spot in reading order
                    j = int(np.argmax(free.ravel()))
                    if not free.ravel()[j]:
                        continue
                    y, x = divmod(j, free.shape[1])
                    key = np.array([(y + border) * grid + x + border], np.int64)
                    ys, xs = np.array([y + border]), np.array([x + border])
                else:
                    ys, xs = np.nonzero(free)
                    if not len(ys):
                        continue
                    ys, xs = ys + border, xs + border
                    side = np.maximum(np.maximum(W, xs + w), np.maximum(H, ys + h))
                    key = (side.astype(np.int64) * 2 * grid + ys + xs) * grid + ys
                j = int(np.argmin(key))
                if best is None or key[j] < best[0]:
                    best = (key[j], page, k, int(ys[j]), int(xs[j]))
            if best is not None:
                break
        if best is None:
            return None
        _, page, k, y, x = best
        m = cands[k]
        occ[page][dil + y:dil + y + m.shape[0], dil + x:dil + x + m.shape[1]] += m
        spec[page] = fft.rfft2(occ[page], shape)
        ext[page] = (max(ext[page][0], x + m.shape[1]), max(ext[page][1], y + m.shape[0]))
        out.append((page, k, y, x))
    return out


def raster_pack(uvs, faces, *, padding=4.0, resolution=1024, texel_density=None, angles=8, grid=256,
                tolerance=0.01, weights=None, floor=None):
    """Pack charts by their rasterised shapes, largest first, at the largest common scale that fits.

    Each chart is rasterised on a ``grid``² page (cells of ``resolution / grid`` texels),
    dilated by the padding, and placed greedily by an overlap test computed as one
    correlation of the page's occupancy with the chart's mask, trying ``angles``
    rotations of it (proper rotations only). Two placement rules are tried — the
    first free spot in reading order (bottom-left fill) and the spot that keeps the
    layout's box smallest — and the common scale is searched by bisection for each;
    the fuller layout is kept, then grown to the padding line. The gaps are measured
    exactly on the float64 UVs; when rasterisation left one short of ``padding``,
    the dilation grows by a cell and the packing is redone.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays
        Charts at a common scale.
    faces : list of (m_i,3) int arrays
    padding : float
        Minimum gap between charts, and to the border, in texels at ``resolution``.
    resolution : int
    texel_density : float, optional
        Texels per UV unit instead of the search; charts that do not fit go on further
        pages (``PackResult.pages``).
    angles : int
        Rotations tried per chart (multiples of ``360° / angles``); 1 keeps each chart
        as given (e.g. upright islands).
    grid : int
        Cells per page side of the raster (finer packs tighter, slower).
    tolerance : float
        Relative precision of the scale search.
    weights : (c,) float array, optional
        Factors on the charts' areas for the placement order (largest first): a
        perturbed order packs differently (:func:`tight_pack`'s later trials).
    floor : float, optional
        Only search scales (``PackResult.raster_scale``) from this one up: a packing that
        does not fit there raises ``ValueError`` after one placement per rule, so a trial
        that cannot beat an earlier one costs little.

    Returns
    -------
    PackResult (with ``pages``; ``raster_scale``: the scale the charts were placed at,
    before the layout was grown to the padding line)

    Raises
    ------
    ValueError
        When an island is larger than a page at the given ``texel_density``.

    Notes
    -----
    Greedy raster placement of irregular shapes (bottom-left fill, e.g. Hopper &
    Turton 2001); the overlap of a chart with the page at every offset is
    :math:`(O \star D)(y,x)=\sum_{i,j} O(y+i,x+j)\,D(i,j)`, a correlation, zero where
    the dilated chart ``D`` fits. xatlas's packer places charts one by one at random or
    scanned spots scored by the atlas size; with few large, irregular islands the
    reading-order fill nests them closer.

    Examples
    --------
    >>> sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]]); q = np.array([[0, 1, 2], [0, 2, 3]])
    >>> res = raster_pack([sq, 2 * sq, sq], [q, q, q], padding=4, resolution=128, grid=64)
    >>> res.padding_texels >= 4, round(res.utilisation, 2) > 0.5
    (True, True)
    """
    uvs = [np.asarray(u, float) for u in uvs]
    faces = [np.asarray(f, np.int64) for f in faces]
    grid = int(min(grid, resolution))
    cell = float(resolution) / grid  # texels per cell
    border = int(np.ceil(padding / cell))
    area = np.array([_poly_area(u, f) for u, f in zip(uvs, faces)])
    order = np.argsort(-area * (1.0 if weights is None else np.asarray(weights, float)), kind="stable")
    turns = [np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
             for a in 2 * np.pi * np.arange(max(int(angles), 1)) / max(int(angles), 1)]

    rings = [_outlines(u, f) for u, f in zip(uvs, faces)]

    def attempt(cells, rule, dil, pages_max):
        masks, origin = [], []
        for i in order:
            ms = [_raster([r @ R for r in rings[i]], cells) for R in turns]
            masks.append([m for m, _ in ms])
            origin.append([o for _, o in ms])
        where = _raster_place(masks, grid, dil, border, rule, pages_max)
        return None if where is None else (cells, rule, where, origin)

    def layout(found):
        cells, _, where, origin = found
        packed, pages = [None] * len(uvs), np.zeros(len(uvs), np.int64)
        for (page, k, y, x), i, org in zip(where, order, origin):
            packed[i] = ((uvs[i] @ turns[k]) * cells - org[k] + [x, y]) * (cell / resolution)
            pages[i] = page
        return packed, pages

    dil = int(np.ceil(padding / cell)) + 1
    for _ in range(3):
        if texel_density is not None:
            cells = float(texel_density) / cell
            big = max(float((u.max(0) - u.min(0)).max()) for u in uvs) * float(texel_density)
            if big > resolution - 2 * padding:
                raise ValueError(f"an island spans {big:.0f} texels at this texel density, more than a "
                                 f"{resolution}-texel tile holds: lower the density or raise the resolution")
            found = attempt(cells, "corner", dil, len(uvs))
            if found is None:
                raise ValueError("raster_pack could not place an island at this texel density")
            tries = [found]
        else:
            hi = grid / np.sqrt(max(area.sum(), 1e-300))
            tries = []
            for rule in ("corner", "box"):
                if floor is not None:  # only a packing at least this dense is wanted
                    lo = float(floor) * resolution / cell
                    found = attempt(lo, rule, dil, 1)
                    if found is None:
                        continue
                else:
                    lo = hi / 2 if not tries else tries[-1][0]  # the second rule starts where the first ended
                    found = attempt(lo, rule, dil, 1)
                while found is None:
                    lo /= 1.5
                    if lo < hi * 1e-3:
                        raise ValueError("raster_pack could not fit the charts on one page")
                    found = attempt(lo, rule, dil, 1)
                top = hi
                while top / lo > 1 + tolerance:
                    mid = np.sqrt(lo * top)
                    trial = attempt(mid, rule, dil, 1)
                    if trial is not None:
                        lo, found = mid, trial
                    else:
                        top = mid
                tries.append(found)
            if not tries:
                raise ValueError("raster_pack: the charts do not fit at the floor scale")
        best = None
        for found in tries:
            packed, pages = layout(found)
            gap = _min_gap(packed, faces, pages)
            if gap * resolution < padding * (1 - 1e-6):
                continue
            if texel_density is None:  # grow up to the padding line (gaps only widen)
                lo_c = np.min([u.min(0) for u in packed], axis=0)
                hi_c = np.max([u.max(0) for u in packed], axis=0)
                edge = (padding + 0.01) / resolution  # a hundredth of a texel kept for the float32 write
                grow = float(np.min((1 - 2 * edge) / np.maximum(hi_c - lo_c, 1e-300)))
                packed = [(u - lo_c) * grow + edge for u in packed]
                gap = _min_gap(packed, faces, pages)
                scale = found[0] * cell / resolution * grow
            else:
                scale = float(texel_density) / resolution
            util = float(sum(_poly_area(u, f) for u, f in zip(packed, faces))) / (int(pages.max()) + 1)
            res = PackResult(uvs=packed, scale=float(scale), offsets=np.array([u.min(0) for u in packed]),
                             utilisation=util, pages=pages,
                             padding_texels=float(gap * resolution) if np.isfinite(gap) else float("inf"),
                             raster_scale=float(found[0] * cell / resolution))
            if best is None or res.utilisation > best.utilisation:
                best = res
        if best is not None:
            return best
        dil += 1
    raise ValueError("raster_pack could not reach the padding; use the shelf packer")


def _xatlas_place(start, allf, tpu, pad, resolution, brute_force):
    import xatlas

    at = xatlas.Atlas()
    at.add_uv_mesh(start, allf)
    po = xatlas.PackOptions()
    po.padding = int(pad)
    po.resolution = int(resolution)
    po.bilinear = False
    po.rotate_charts = False  # xatlas "rotates" by transposing: a mirror image
    po.rotate_charts_to_axis = False
    po.bruteForce = bool(brute_force)
    po.texels_per_unit = float(tpu)
    at.generate(xatlas.ChartOptions(), po)
    return at


#: The first raster packings :func:`tight_pack` tries: (grid cells per side, rotations per chart).
#: Later trials repeat the first setting with the placement order perturbed (:data:`ORDER_JITTER`).
RASTER_TRIALS = ((512, 4), (256, 8))

#: Spread (log-normal sigma) of the factors on the charts' areas that perturb the placement order of
#: :func:`tight_pack`'s later trials: greedy placement is chaotic, and with few large islands the
#: best of several orders packs several points fuller than largest-first alone.
ORDER_JITTER = 0.5

#: Default trials of :func:`tight_pack` (the tight packer of ``build_atlas`` and the CLI).
PACK_TRIALS = 12

#: Perturbed-order trials run only up to this many islands: with many islands one order packs
#: about as full as another (Cow, 83 islands: 12 trials no fuller than 2, packing time doubled).
ORDER_MAX_ISLANDS = 48

#: Above this many islands ``tight_pack(method="auto")`` places the shapes with xatlas (faster there).
RASTER_MAX_ISLANDS = 1000

#: Utilisation (absolute) the cut charts of ``tight_pack(split=...)`` must gain to be kept: cuts add seams.
SPLIT_GAIN = 0.01


def tight_pack(uvs, faces, *, padding=4.0, resolution=1024, texel_density=None, trials=PACK_TRIALS, rotate=True,
               method="auto", split=None, xyz=None):
    """Pack charts by their shapes at the largest common scale that fits the texture, with exact padding.

    The fullest of ``trials`` packings is kept: :func:`raster_pack` with the settings
    of :data:`RASTER_TRIALS`, then with the first setting and the placement order
    perturbed (seeded, :data:`ORDER_JITTER`; up to :data:`ORDER_MAX_ISLANDS` islands; each
    such trial is first placed at the best scale so far and costs one placement per rule
    when it cannot beat it), up to :data:`RASTER_MAX_ISLANDS` islands; or xatlas's shape
    placement with (at most two) quarter-turn trials (:func:`xatlas_shape_pack`) for more
    islands or with ``method="xatlas"``.

    With ``split`` (a share, e.g. :data:`SPLIT_SHARE`), when a chart holds more than
    that share of the total UV area the charts are also packed cut by
    :func:`granular_islands` (a few large islands leave gaps no placement can fill),
    and that packing is kept when it is fuller by at least :data:`SPLIT_GAIN` on no
    more pages; its ``pieces`` then say which part of which chart each packed island is.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays
        Charts at a common scale.
    faces : list of (m_i,3) int arrays
    padding : float
        Minimum gap, in texels at ``resolution``.
    resolution : int
    texel_density : float, optional
        Texels per UV unit instead of the largest scale that fits; several pages when needed.
    trials : int
        Packings tried; the fullest (fewest pages first) is kept.
    rotate : bool
        Turn charts to nest them (proper rotations only); False keeps each as given.
    method : ``"auto"``, ``"raster"`` or ``"xatlas"``
    split : float, optional
        Largest share of the total UV area one packed island may hold before a cut
        packing is tried (None: charts are packed whole).
    xyz : list of (n_i,3) float arrays, optional
        The charts' 3D vertices: each cut part is then scaled to its own texel density
        (:func:`island_density`; the charts are assumed at one density already), so the
        density spread across packed islands stays that of whole charts.

    Returns
    -------
    PackResult (with ``pages``; ``pieces`` when the cut packing was kept)

    Examples
    --------
    >>> sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]]); q = np.array([[0, 1, 2], [0, 2, 3]])
    >>> res = tight_pack([sq, 2 * sq, sq], [q, q, q], padding=4, resolution=128)
    >>> res.padding_texels >= 4, round(res.utilisation, 2) > 0.5
    (True, True)
    """
    if method not in ("auto", "raster", "xatlas"):
        raise ValueError(f"unknown method {method!r}: use 'auto', 'raster' or 'xatlas'")
    kw = dict(padding=padding, resolution=resolution, texel_density=texel_density, trials=trials, rotate=rotate,
              method=method)
    whole = _tight_pack(uvs, faces, **kw)
    if not split:
        return whole
    from neuraluv.topology import submesh

    pieces = granular_islands(uvs, faces, split)
    if len(pieces) == len(uvs):
        return whole
    parts = [(i, idx, *submesh(faces[i], idx)) for i, idx in pieces]
    puvs = [np.asarray(uvs[i], float)[vi] for i, _, vi, _ in parts]
    if xyz is not None:
        d = [island_density(u, np.asarray(xyz[i], float)[vi], f) for u, (i, _, vi, f) in zip(puvs, parts)]
        puvs = [u / di if np.isfinite(di) and di > 0 else u for u, di in zip(puvs, d)]
    cut = _tight_pack([rotate_to_min_box(u) for u in puvs] if rotate else puvs, [f for *_, f in parts], **kw)
    if int(cut.pages.max()) > int(whole.pages.max()) or cut.utilisation < whole.utilisation + SPLIT_GAIN:
        return whole
    cut.pieces = [(i, idx, vi) for i, idx, vi, _ in parts]
    return cut


def _tight_pack(uvs, faces, *, padding, resolution, texel_density, trials, rotate, method):
    trials = max(int(trials), 1)
    if method == "xatlas" or (method == "auto" and len(uvs) > RASTER_MAX_ISLANDS):  # perturbed orders: raster only
        return xatlas_shape_pack(uvs, faces, padding=padding, resolution=resolution, texel_density=texel_density,
                                 trials=min(trials, len(RASTER_TRIALS)) if rotate else 1)
    best = _fullest(lambda g=grid, a=angles: raster_pack(uvs, faces, padding=padding, resolution=resolution,
                                                         texel_density=texel_density, grid=g, angles=a if rotate else 1)
                    for grid, angles in RASTER_TRIALS[:trials])
    if texel_density is not None or not 2 <= len(uvs) <= ORDER_MAX_ISLANDS:  # a fixed scale (pages), or
        return best                                                             # nothing or too much to reorder
    grid, angles = RASTER_TRIALS[0]
    for k in range(len(RASTER_TRIALS), trials):
        w = np.exp(np.random.default_rng(k).normal(0.0, ORDER_JITTER, len(uvs)))
        try:
            r = raster_pack(uvs, faces, padding=padding, resolution=resolution, grid=grid,
                            angles=angles if rotate else 1, weights=w, floor=best.raster_scale)
        except ValueError:  # not even as dense as the best: a cheap miss
            continue
        if r.utilisation > best.utilisation:
            best = r
    return best


def _fullest(makers):
    """The fullest :class:`PackResult` (fewest pages first) the callables ``makers`` produce; re-raises the
    last ``ValueError`` when none of them packs."""
    best, err = None, None
    for make in makers:
        try:
            r = make()
        except ValueError as exc:
            err = exc
            continue
        if best is None or (-int(r.pages.max()), r.utilisation) > (-int(best.pages.max()), best.utilisation):
            best = r
    if best is None:
        raise err
    return best


def xatlas_shape_pack(uvs, faces, *, padding=4.0, resolution=1024, brute_force="auto", tolerance=0.005,
                      texel_density=None, supersample=1, trials=4):
    """Pack charts by their shapes with xatlas's placement, at the largest common scale that fits.

    xatlas's packer places each chart's rasterised shape (not its bounding box);
    we search the texel density (texels per UV unit, the same for every chart) by
    bisection for the largest one that still fits one ``resolution``² page, then read
    back only where xatlas put each chart and apply that translation to the float64
    UVs at the common scale. The gaps are then measured exactly
    (:func:`~neuraluv.atlas.validate.validate_atlas`-style polygon distances); xatlas
    is asked for half the padding (it dilates both neighbours) and for more when the
    measured gap falls short.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays
        Charts at a common scale (e.g. density-normalised, rotated to their smallest box).
    faces : list of (m_i,3) int arrays
    padding : float
        Minimum gap between charts, and to the border, in texels at ``resolution``.
    resolution : int
    brute_force : bool or ``"auto"``
        xatlas's slower exhaustive placement. Neither placement is always the
        tighter one, so ``"auto"`` packs both ways (brute force only up to 600
        charts, where it stays within seconds) and keeps the higher utilisation.
    tolerance : float
        Relative precision of the density search.
    texel_density : float, optional
        Texels per UV unit: a fixed density instead of the search. The charts may
        then need several pages: ``PackResult.pages`` says which page each chart is on.
    trials : int
        Packings tried with the charts turned by quarter turns (as given, all turned
        90°, then seeded random quarter turns per chart); the fullest is kept. The
        utilisation of one packing varies by several percent with the charts'
        orientations (Cow: 0.45–0.59 over 12 trials), so a few trials pay off.

    Returns
    -------
    PackResult (with ``pages``, one int per chart; 0 for a single page)

    Notes
    -----
    Charts are turned by quarter turns (``trials``), translated and uniformly scaled
    only: xatlas's own 90° "rotation" transposes a chart (a mirror image), so it is
    switched off. The output is deterministic (the trials' turns are seeded).

    Examples
    --------
    >>> sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]]); q = np.array([[0, 1, 2], [0, 2, 3]])
    >>> res = xatlas_shape_pack([sq, 2 * sq, sq], [q, q, q], padding=4, resolution=128)
    >>> res.padding_texels >= 4, round(res.utilisation, 2) > 0.5
    (True, True)
    """
    if trials > 1:  # quarter turns (proper rotations, never mirrors) change how the shapes nest
        kw = dict(padding=padding, resolution=resolution, brute_force=brute_force, tolerance=tolerance,
                  texel_density=texel_density, supersample=supersample, trials=1)
        uvs = [np.asarray(u, float) for u in uvs]
        turns = [np.zeros(len(uvs), int), np.ones(len(uvs), int)] + \
            [np.random.default_rng(t).integers(0, 4, len(uvs)) for t in range(2, int(trials))]
        return _fullest(lambda q=q: xatlas_shape_pack([u @ _QUARTER[k] for u, k in zip(uvs, q)], faces, **kw)
                        for q in turns[:int(trials)])
    if brute_force == "auto":
        kw = dict(padding=padding, resolution=resolution, tolerance=tolerance, texel_density=texel_density,
                  supersample=supersample, trials=1)
        return _fullest(lambda b=b: xatlas_shape_pack(uvs, faces, brute_force=b, **kw)
                        for b in ([False, True] if len(uvs) <= 600 else [False]))
    uvs = [np.asarray(u, float) for u in uvs]
    faces = [np.asarray(f, np.int64) for f in faces]
    hull = set()  # charts xatlas did not place rigidly: sent again as their convex hull
    for _ in range(3):
        try:
            return _tight_once(uvs, faces, pad=float(padding), resolution=resolution, brute_force=brute_force,
                               tolerance=tolerance, texel_density=texel_density, k=int(supersample), hull=hull)
        except _Misplaced as exc:
            if exc.charts <= hull:
                break
            hull |= exc.charts
    raise ValueError("tight_pack could not reach the padding; use the shelf packer")


class _Misplaced(ValueError):
    """xatlas did not place some charts as rigid, unmirrored copies (``charts``: their indices)."""

    def __init__(self, charts):
        super().__init__(f"xatlas did not place {len(charts)} chart(s) rigidly")
        self.charts = set(charts)


_QUARTER = [np.eye(2), np.array([[0.0, 1.0], [-1.0, 0.0]]), -np.eye(2), np.array([[0.0, -1.0], [1.0, 0.0]])]


def _tight_once(uvs, faces, *, pad, resolution, brute_force, tolerance, texel_density, k, hull):
    """One :func:`tight_pack` attempt with the given hull proxies; raises ``_Misplaced``."""
    sent, sent_f = _proxies(uvs, faces, hull)
    off = np.cumsum([0] + [len(u) for u in sent])
    start = shelf_pack(sent, None, padding=2.0, resolution=4096)
    s0 = start.scale
    pts = np.vstack(start.uvs).astype(np.float32)
    allf = np.vstack([f + o for f, o in zip(sent_f, off[:-1])]).astype(np.uint32)
    area = sum(_poly_area(u, f) for u, f in zip(uvs, faces))
    inner = int(np.floor(resolution - 2 * pad)) * k  # the border keeps the padding too
    for xpad in range(int(np.ceil(k * pad / 2)), int(np.ceil(k * pad)) + 3):  # xatlas dilates both neighbours
        if texel_density is not None:
            tex = float(texel_density)
            big = max(float((u.max(0) - u.min(0)).max()) for u in uvs) * tex
            if big > inner / k - 2 * xpad / k:
                raise ValueError(f"an island spans {big:.0f} texels at this texel density, more than a "
                                 f"{resolution}-texel tile holds: lower the density or raise the resolution")
            at = _xatlas_place(pts, allf, k * tex / s0, xpad, inner, brute_force)
        else:
            hi = (resolution - 2 * pad) / np.sqrt(max(area, 1e-300))
            lo, at_lo = hi / 64, None
            while at_lo is None:
                at_lo = _xatlas_place(pts, allf, k * lo / s0, xpad, inner, brute_force)
                if at_lo.atlas_count != 1:
                    lo, at_lo = lo / 4, None
            at = at_lo
            while hi / lo > 1 + tolerance:
                mid = np.sqrt(lo * hi)
                trial = _xatlas_place(pts, allf, k * mid / s0, xpad, inner, brute_force)
                if trial.atlas_count == 1:
                    lo, at = mid, trial
                else:
                    hi = mid
            tex = lo
        packed, pages = _read_placement(at, uvs, sent, off, tex, pad, resolution, k)
        gap = _min_gap(packed, faces, pages)
        if gap * resolution >= pad * (1 - 1e-6):
            if texel_density is None:  # xatlas keeps a margin of its own: grow the layout up to the padding line
                lo_c = np.min([u.min(0) for u in packed], axis=0)
                hi_c = np.max([u.max(0) for u in packed], axis=0)
                edge = (pad + 0.01) / resolution  # a hundredth of a texel kept for the float32 write
                grow = float(np.min((1 - 2 * edge) / np.maximum(hi_c - lo_c, 1e-300)))
                if grow > 1:
                    packed = [(u - lo_c) * grow + edge for u in packed]
                    tex *= grow
                    gap = _min_gap(packed, faces, pages)
            util = sum(_poly_area(u, f) for u, f in zip(packed, faces)) / max(1, int(pages.max()) + 1)
            return PackResult(uvs=packed, scale=tex / resolution, offsets=np.array([u.min(0) for u in packed]),
                              utilisation=util, padding_texels=float(gap * resolution) if np.isfinite(gap) else float("inf"),
                              pages=pages)
    raise ValueError("tight_pack could not reach the padding; use the shelf packer")


def _proxies(uvs, faces, hull=()):
    """What xatlas is given per chart.

    The chart itself; for a sliver (xatlas does not place charts of no rasterised
    area) its bounding box thickened to 5% of its length; and for a chart with
    near-degenerate triangles (xatlas drops them and may then place the pieces of the
    chart apart) or listed in ``hull``, its convex hull.
    """
    from scipy.spatial import ConvexHull, QhullError

    sent, sent_f = [], []
    quad = np.array([[0, 1, 2], [0, 2, 3]])
    for i, (u, f) in enumerate(zip(uvs, faces)):
        lo, hi = u.min(0), u.max(0)
        ext = hi - lo
        box = float(ext[0] * ext[1])
        area = _poly_area(u, f)
        tri = np.abs(signed_areas_2d(u, f))
        if ext.min() < 0.05 * ext.max() or area < 0.05 * box:
            c, h = 0.5 * (lo + hi), np.maximum(ext, 0.05 * ext.max()) / 2
            sent.append(np.array([c - h, [c[0] + h[0], c[1] - h[1]], c + h, [c[0] - h[0], c[1] + h[1]]]))
            sent_f.append(quad)
            continue
        if i in hull or tri.min() < 1e-6 * area:
            try:
                ring = u[ConvexHull(u).vertices]  # counter-clockwise
            except QhullError:
                ring = None
            if ring is not None and len(ring) >= 3:
                n = len(ring)
                sent.append(np.vstack([ring, ring.mean(0)]))
                sent_f.append(np.column_stack([np.arange(n), (np.arange(n) + 1) % n, np.full(n, n)]))
                continue
        sent.append(u)
        sent_f.append(f)
    return sent, sent_f


def _read_placement(at, uvs, sent, off, tex, pad, resolution, k=1):
    """Place each chart (at ``tex`` texels per unit) where xatlas put it; returns (uvs, pages).

    The chart's rotation is the least-squares fit (Procrustes) of xatlas's output to
    the input. A chart that xatlas did not place as one rigid copy — a reflection
    (a mirrored island), pieces placed apart, or vertices left out — raises
    ``_Misplaced`` listing every such chart.
    """
    vmap, _, out = at[0]
    vmap = np.asarray(vmap, np.int64)
    page, _ = at.get_mesh_vertex_assignment(0)
    page = np.asarray(page, np.int64)
    q = np.asarray(out, float) * [at.width, at.height] / k  # texels at the target resolution
    owner = np.repeat(np.arange(len(uvs)), np.diff(off))[vmap]
    order = np.argsort(owner, kind="stable")
    bounds = np.searchsorted(owner[order], np.arange(len(uvs) + 1))
    packed, pages, bad = [], np.zeros(len(uvs), np.int64), []
    for i, u in enumerate(uvs):
        sel = order[bounds[i]:bounds[i + 1]]
        sel = sel[page[sel] < at.atlas_count]  # xatlas marks vertices it did not place with 0xFFFFFFFF
        if len(sel) < 2 or len(np.unique(page[sel])) > 1:
            bad.append(i)
            continue
        P = sent[i][vmap[sel] - off[i]]
        Q = q[sel]
        pc, qc = P - P.mean(0), Q - Q.mean(0)
        U, _, Vt = np.linalg.svd(pc.T @ qc)
        R = U @ Vt
        if np.linalg.det(R) < 0 or np.abs(pc @ R * tex - qc).max() > 1.0:  # mirrored, or not one rigid copy
            bad.append(i)
            continue
        packed.append(((u - P.mean(0)) @ R * tex + Q.mean(0) + pad) / resolution)
        pages[i] = page[sel[0]]
    if bad:
        raise _Misplaced(bad)
    return packed, pages


def _min_gap(uvs, faces, pages):
    """Smallest distance between two charts on the same page, and from a chart to the page border."""
    import shapely

    polys = [shapely.union_all(shapely.polygons(u[f])) for u, f in zip(uvs, faces)]
    gap = float("inf")
    for u in uvs:
        gap = min(gap, float(u.min()), float(1 - u.max()))
    for p in np.unique(pages):
        idx = np.flatnonzero(pages == p)
        if len(idx) < 2:
            continue
        P = np.array([polys[i] for i in idx], dtype=object)
        tree = shapely.STRtree(P)
        a, b = tree.query(P, predicate="dwithin", distance=0.05)
        for i, j in zip(a, b):
            if i < j:
                gap = min(gap, P[i].distance(P[j]))
    return gap


def upright(uv, V=None):
    """Rotate a chart (no mirroring) so its main axis runs along U.

    The main axis is the principal direction of the chart's UV points; of the two
    ways to lay it along U, the one that puts the 3D +Y direction (or, failing that,
    +Z) towards +V is taken when ``V`` is given, so islands of a standing model
    keep their "up".

    Parameters
    ----------
    uv : (n,2) float array
    V : (n,3) float array, optional
        The chart's 3D vertices (same order as ``uv``).

    Returns
    -------
    uv : (n,2) float array, rotated about the origin (det +1).

    Examples
    --------
    >>> r = upright(np.array([[0., 0], [0, 3], [1, 0]]))
    >>> ext = r.max(0) - r.min(0); bool(ext[0] > ext[1])
    True
    """
    uv = np.asarray(uv, float)
    if len(uv) < 2:
        return uv.copy()
    c = uv - uv.mean(0)
    w, vec = np.linalg.eigh(c.T @ c)
    a = vec[:, -1]
    R = np.array([[a[0], -a[1]], [a[1], a[0]]])  # columns: main axis, its left normal (det +1)
    out = uv @ R
    if V is not None:
        V = np.asarray(V, float)
        for axis in (1, 2):
            up = V[:, axis] - V[:, axis].mean()
            corr = float(up @ (out[:, 1] - out[:, 1].mean()))
            if abs(corr) > 1e-9 * (np.abs(up).sum() + 1e-300):
                if corr < 0:
                    out = -out  # a half turn, still no mirror
                break
    return out
