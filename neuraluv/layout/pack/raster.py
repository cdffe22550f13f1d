"""Greedy raster packing: islands' shapes placed largest first at the largest common scale that fits."""
from __future__ import annotations

import numpy as np
import shapely

from neuraluv.layout.overlap import outline_rings, triangles_union
from neuraluv.layout.pack import FLOAT32_SLACK, RASTERS_KEPT, START_FILL
from neuraluv.layout.pack.result import PackResult, min_gap, uv_area
from neuraluv.layout.raster import Page, dilate, rasterise

__all__ = ["raster_pack", "island_outlines", "largest_fit"]


def largest_fit(attempt, start, hi, tolerance, *, down=True):
    """The packing at the largest scale up to ``hi`` that ``attempt`` fits, to a relative ``tolerance``.

    Gallops from ``start`` (steps of 4, 8, 16 … times the tolerance) up until a scale
    does not fit, or down (with ``down``) until one does, then bisects the bracket.
    Greedy placement is not monotone in the scale, so this finds *a* largest fitting
    scale of the bracket, as a bisection does, in fewer placements when ``start`` is
    close to the answer.

    Parameters
    ----------
    attempt : callable
        ``attempt(scale)`` -> the packing's data with the scale first, or None when it does not fit.
    start, hi : float
    tolerance : float
    down : bool
        Search below ``start`` when it does not fit (False: return None).

    Returns
    -------
    ``attempt``'s data at the largest fitting scale found, or None

    Raises
    ------
    ValueError
        When nothing fits down to ``hi / 1000``.

    Examples
    --------
    >>> s = largest_fit(lambda s: (s,) if s <= 3.0 else None, 1.0, 10.0, 0.01)[0]
    >>> bool(3.0 / 1.01 <= s <= 3.0)
    True
    """
    step = 4 * tolerance
    found = attempt(start)
    if found is None:
        if not down:
            return None
        top = lo = start
        while found is None:
            top, lo = lo, lo / (1 + step)
            step *= 2
            if lo < hi * 1e-3:
                raise ValueError("raster_pack could not fit the islands on one page")
            found = attempt(lo)
    else:
        lo, top = start, hi
        while lo * (1 + step) < hi:
            trial = attempt(lo * (1 + step))
            if trial is None:
                top = lo * (1 + step)
                break
            lo, found = lo * (1 + step), trial
            step *= 2
    while top / lo > 1 + tolerance:
        mid = np.sqrt(lo * top)
        trial = attempt(mid)
        if trial is not None:
            lo, found = mid, trial
        else:
            top = mid
    return found


def island_outlines(uvs, faces):
    """Each island's union polygon and outline rings, computed once per packing.

    A packing moves every island by a similarity (turn, scale, shift), so the
    islands' placed polygons are these unions moved the same way: the exact gap
    check needs no union of the placed triangles.

    Returns
    -------
    rings : list of list of ``(exterior (k,2), [])``
        One list per island, holes left out so they count as filled (as :func:`rasterise` takes them).
    unions : list of shapely geometries
        :func:`~neuraluv.layout.overlap.triangles_union` of each island.

    Examples
    --------
    >>> sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]]); q = np.array([[0, 1, 2], [0, 2, 3]])
    >>> rings, unions = island_outlines([sq], [q])
    >>> [len(r) for r in rings], unions[0].area
    ([1], 1.0)
    """
    rings, unions = [], []
    for u, f in zip(uvs, faces):
        union = triangles_union(u, f)[0]
        r = outline_rings(union)
        rings.append(r or [(np.asarray(u, float)[np.asarray(f)].reshape(-1, 2), [])])
        unions.append(union)
    return rings, unions


def _place(masks, grid, dil, border, rule, pages_max):
    """Greedy placement of rasterised islands (in the given order) on ``grid``² pages.

    ``masks`` yields, island by island, its candidate masks (one per rotation). An island goes
    where its mask, dilated by ``dil`` cells, covers no cell of a placed island and stays
    ``border`` cells inside the page; of the free spots the first in reading order
    (``rule="corner"``) or the one that keeps the layout's box smallest (``"box"``) is
    taken. Returns ``[(page, rotation, row, col)]`` or None when an island found no spot
    within ``pages_max`` pages.

    The pages hold the placed masks dilated (clipped to the page), and a new mask is tested
    undilated: the same test (a disk is symmetric), and the undilated mask inside the border
    never reaches past the page, so a page is the ``grid``² raster itself (a fast FFT size
    for :meth:`~neuraluv.layout.raster.Page.free`, no room for wrapping around it) and the
    spot is :meth:`~neuraluv.layout.raster.Page.spot`'s.
    """
    pages, ext, out = [], [], []
    for cands in masks:
        best = None
        for page in range(pages_max):
            if page == len(pages):
                pages.append(Page((grid, grid)))
                ext.append((0, 0))
            W, H = ext[page]
            for k, m in enumerate(cands):
                h, w = m.shape
                if h > grid - 2 * border or w > grid - 2 * border:
                    continue
                at = pages[page].spot(m, (border, border), (grid - border - h, grid - border - w),
                                      box=None if rule == "corner" else (W, H))
                if at is None:
                    continue
                y, x = at
                if rule == "corner":  # the first free spot in reading order
                    key = y * grid + x
                else:  # the spot that keeps the layout's box smallest
                    key = (max(W, x + w, H, y + h) * 2 * grid + y + x) * grid + y
                if best is None or key < best[0]:
                    best = (key, page, k, y, x)
            if best is not None:
                break
        if best is None:
            return None
        _, page, k, y, x = best
        m = cands[k]
        pages[page].add(dilate(m, dil), y - dil, x - dil)
        ext[page] = (max(ext[page][0], x + m.shape[1]), max(ext[page][1], y + m.shape[0]))
        out.append((page, k, y, x))
    return out


def raster_pack(uvs, faces, *, padding=4.0, resolution=1024, texel_density=None, angles=8, grid=256,
                tolerance=0.01, weights=None, floor=None, outlines=None, rasters=None):
    """Pack islands by their rasterised shapes, largest first, at the largest common scale that fits.

    Each island is rasterised on a ``grid``² page (cells of ``resolution / grid`` texels),
    dilated by the padding, and placed greedily at a free spot
    (:meth:`~neuraluv.layout.raster.Page.spot`: a compiled scan with numba, an FFT
    correlation without; the same spots), trying ``angles`` rotations of it (proper
    rotations only). Two placement rules are tried — the first free spot in reading
    order (bottom-left fill) and the spot that keeps the layout's box smallest — and
    the common scale is searched for each (:func:`largest_fit`: from a typical fill,
    :data:`~neuraluv.layout.pack.START_FILL`, or from ``floor``, galloping, then bisecting); the fuller layout is kept,
    then grown to the padding line. The gaps are measured exactly on the float64 UVs;
    when rasterisation left one short of ``padding``, the dilation grows by a cell
    and the packing is redone.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays
        Islands at a common scale.
    faces : list of (m_i,3) int arrays
    padding : float
        Minimum gap between islands, and to the border, in texels at ``resolution``.
    resolution : int
    texel_density : float, optional
        Texels per UV unit instead of the search; islands that do not fit go on further
        pages (``PackResult.pages``).
    angles : int
        Rotations tried per island (multiples of ``360° / angles``); 1 keeps each island
        as given (e.g. upright islands).
    grid : int
        Cells per page side of the raster (finer packs tighter, slower).
    tolerance : float
        Relative precision of the scale search.
    weights : (c,) float array, optional
        Factors on the islands' areas for the placement order (largest first): a
        perturbed order packs differently (:func:`~neuraluv.layout.pack.tight.tight_pack`'s later trials).
    floor : float, optional
        Only search scales (``PackResult.raster_scale``) from this one up: a packing that
        does not fit there raises ``ValueError`` after one placement per rule, so a trial
        that cannot beat an earlier one costs little.
    outlines : tuple, optional
        :func:`island_outlines` of the islands, when the caller packs them several times.
    rasters : dict, optional
        Filled with the islands' rasterised turns per scale and number of turns (the last
        :data:`~neuraluv.layout.pack.RASTERS_KEPT` met), to pass to the next packing of the
        same islands (later trials search from the same scale).

    Returns
    -------
    PackResult (``packer="raster"``, with ``pages`` and ``raster_scale``)

    Raises
    ------
    ValueError
        When an island is larger than a page at the given ``texel_density``, or nothing fits.

    Notes
    -----
    Greedy raster placement of irregular shapes (bottom-left fill, e.g. Hopper &
    Turton 2001). xatlas's packer places charts one by one at random or scanned spots
    scored by the atlas size; with few large, irregular islands the reading-order fill
    nests them closer.

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
    area = np.array([uv_area(u, f) for u, f in zip(uvs, faces)])
    order = np.argsort(-area * (1.0 if weights is None else np.asarray(weights, float)), kind="stable")
    n_ang = max(int(angles), 1)
    turns = [np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]]) for a in 2 * np.pi * np.arange(n_ang) / n_ang]
    rings, unions = island_outlines(uvs, faces) if outlines is None else outlines

    rasters = {} if rasters is None else rasters  # (cells, turns) -> {island: (masks, origins)}

    def attempt(cells, rule, dil, pages_max):
        if (cells, n_ang) not in rasters and len(rasters) >= RASTERS_KEPT:
            del rasters[next(iter(rasters))]  # the scale met longest ago
        done, origin = rasters.setdefault((cells, n_ang), {}), []

        def masks():  # rasterised as the placement reaches them (a placement that fails early needs few)
            for i in order:
                if i not in done:
                    ms = [rasterise([(e @ R, []) for e, _ in rings[i]], cells) for R in turns]
                    done[i] = ([m for m, _ in ms], [o for _, o in ms])
                origin.append(done[i][1])
                yield done[i][0]

        where = _place(masks(), grid, dil, border, rule, pages_max)
        return None if where is None else (cells, rule, where, origin)

    def layout(found):
        """The placed islands' UVs, pages and union polygons (each island's union moved as its UVs are)."""
        cells, _, where, origin = found
        packed, pages, polys = [None] * len(uvs), np.zeros(len(uvs), np.int64), [None] * len(uvs)
        for (page, k, y, x), i, org in zip(where, order, origin):
            def move(c, R=turns[k], shift=[x, y] - org[k]):
                return ((c @ R) * cells + shift) * (cell / resolution)
            packed[i] = move(uvs[i])
            polys[i] = shapely.transform(unions[i], move)
            pages[i] = page
        return packed, pages, polys

    dil = int(np.ceil(padding / cell)) + 1
    for _ in range(3):
        if texel_density is not None:
            cells = float(texel_density) / cell
            big = max(float((u.max(0) - u.min(0)).max()) for u in uvs) * float(texel_density)
            if big > resolution - 2 * padding:
                raise ValueError(f"an island spans {big:.0f} texels at this texel density, more than a "
                                 f"{resolution}-texel tile holds: lower the density or raise the resolution")
            if big < 1.0:
                raise ValueError(f"the largest island spans {big:.2g} texels at this texel density, less than one "
                                 f"texel (every island would collapse to a point of the texture): raise the density")
            found = attempt(cells, "corner", dil, len(uvs))
            if found is None:
                raise ValueError("raster_pack could not place an island at this texel density")
            tries = [found]
        else:
            hi = grid / np.sqrt(max(area.sum(), 1e-300))  # every cell covered: no packing is denser
            tries = []
            for rule in ("corner", "box"):
                if floor is not None:  # only a packing at least this dense is wanted
                    start, down = float(floor) * resolution / cell, False
                else:  # a typical fill, then the scale the first rule reached
                    start, down = (hi * np.sqrt(START_FILL) if not tries else tries[-1][0]), True
                found = largest_fit(lambda c, r=rule: attempt(c, r, dil, 1), start, hi, tolerance, down=down)
                if found is not None:
                    tries.append(found)
            if not tries:
                raise ValueError("raster_pack: the islands do not fit at the floor scale")
        best = None
        for found in tries:
            packed, pages, polys = layout(found)
            gap = min_gap(packed, faces, pages, polys=polys)
            if gap * resolution < padding * (1 - 1e-6):
                continue
            if texel_density is None:  # grow up to the padding line (gaps only widen)
                lo_c = np.min([u.min(0) for u in packed], axis=0)
                hi_c = np.max([u.max(0) for u in packed], axis=0)
                edge = (padding + FLOAT32_SLACK) / resolution  # kept for the float32 write
                grow = float(np.min((1 - 2 * edge) / np.maximum(hi_c - lo_c, 1e-300)))
                packed = [(u - lo_c) * grow + edge for u in packed]
                polys = [shapely.transform(p, lambda c: (c - lo_c) * grow + edge) for p in polys]
                gap = min_gap(packed, faces, pages, polys=polys)
                scale = found[0] * cell / resolution * grow
            else:
                scale = float(texel_density) / resolution
            util = float(sum(uv_area(u, f) for u, f in zip(packed, faces))) / (int(pages.max()) + 1)
            res = PackResult(uvs=packed, scale=float(scale), offsets=np.array([u.min(0) for u in packed]),
                             utilisation=util, pages=pages,
                             padding_texels=float(gap * resolution) if np.isfinite(gap) else float("inf"),
                             raster_scale=float(found[0] * cell / resolution), packer="raster")
            if best is None or res.utilisation > best.utilisation:
                best = res
        if best is not None:
            return best
        dil += 1
    raise ValueError("raster_pack could not reach the padding; use the shelf packer")
