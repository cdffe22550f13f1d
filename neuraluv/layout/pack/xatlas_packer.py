"""xatlas's packer, reading back only where it put each island (quarter turns only, never a mirror).

xatlas's own output coordinates are float32 snapped to its texel grid (which
can flip tiny triangles), and its 90° "rotation" is a transpose — a mirror
image — so it is switched off: only the placement xatlas chooses is read back
(:func:`~neuraluv.layout.rigid.rigid_fit`) and applied to the float64 UVs.
"""
from __future__ import annotations

import numpy as np
import xatlas
from scipy.spatial import ConvexHull, QhullError

from neuraluv.jacobian import signed_areas_2d
from neuraluv.layout.pack import FLOAT32_SLACK
from neuraluv.layout.pack.result import PackResult, fullest, min_gap, uv_area
from neuraluv.layout.pack.shelf import shelf_pack
from neuraluv.layout.rigid import QUARTER_TURNS, rigid_fit

__all__ = ["xatlas_pack", "xatlas_shape_pack"]


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
        area = sum(uv_area(u, f) for u, f in zip(packed, faces))
    return PackResult(uvs=packed, scale=s_all, offsets=boxes[:, 0].copy(), utilisation=area, padding_texels=float(padding),
                      packer="xatlas")


def _xatlas_place(start, allf, tpu, pad, resolution, brute_force):
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


def xatlas_shape_pack(uvs, faces, *, padding=4.0, resolution=1024, brute_force="auto", tolerance=0.005,
                      texel_density=None, supersample=1, trials=4):
    """Pack charts by their shapes with xatlas's placement, at the largest common scale that fits.

    xatlas's packer places each chart's rasterised shape (not its bounding box);
    we search the texel density (texels per UV unit, the same for every chart) by
    bisection for the largest one that still fits one ``resolution``² page, then read
    back only where xatlas put each chart and apply that translation to the float64
    UVs at the common scale. The gaps are then measured exactly
    (:func:`~neuraluv.layout.pack.result.min_gap`); xatlas
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
        return fullest(lambda q=q: xatlas_shape_pack([u @ QUARTER_TURNS[k] for u, k in zip(uvs, q)], faces, **kw)
                        for q in turns[:int(trials)])
    if brute_force == "auto":
        kw = dict(padding=padding, resolution=resolution, tolerance=tolerance, texel_density=texel_density,
                  supersample=supersample, trials=1)
        return fullest(lambda b=b: xatlas_shape_pack(uvs, faces, brute_force=b, **kw)
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
    raise ValueError("xatlas_shape_pack could not reach the padding; use the shelf packer")


class _Misplaced(ValueError):
    """xatlas did not place some charts as rigid, unmirrored copies (``charts``: their indices)."""

    def __init__(self, charts):
        super().__init__(f"xatlas did not place {len(charts)} chart(s) rigidly")
        self.charts = set(charts)


def _tight_once(uvs, faces, *, pad, resolution, brute_force, tolerance, texel_density, k, hull):
    """One :func:`xatlas_shape_pack` attempt with the given hull proxies; raises ``_Misplaced``."""
    sent, sent_f = _proxies(uvs, faces, hull)
    off = np.cumsum([0] + [len(u) for u in sent])
    start = shelf_pack(sent, None, padding=2.0, resolution=4096)
    s0 = start.scale
    pts = np.vstack(start.uvs).astype(np.float32)
    allf = np.vstack([f + o for f, o in zip(sent_f, off[:-1])]).astype(np.uint32)
    area = sum(uv_area(u, f) for u, f in zip(uvs, faces))
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
        gap = min_gap(packed, faces, pages)
        if gap * resolution >= pad * (1 - 1e-6):
            if texel_density is None:  # xatlas keeps a margin of its own: grow the layout up to the padding line
                lo_c = np.min([u.min(0) for u in packed], axis=0)
                hi_c = np.max([u.max(0) for u in packed], axis=0)
                edge = (pad + FLOAT32_SLACK) / resolution  # kept for the float32 write
                grow = float(np.min((1 - 2 * edge) / np.maximum(hi_c - lo_c, 1e-300)))
                if grow > 1:
                    packed = [(u - lo_c) * grow + edge for u in packed]
                    tex *= grow
                    gap = min_gap(packed, faces, pages)
            util = sum(uv_area(u, f) for u, f in zip(packed, faces)) / max(1, int(pages.max()) + 1)
            return PackResult(uvs=packed, scale=tex / resolution, offsets=np.array([u.min(0) for u in packed]),
                              utilisation=util, padding_texels=float(gap * resolution) if np.isfinite(gap) else float("inf"),
                              pages=pages, packer="xatlas-shapes")
    raise ValueError("xatlas_shape_pack could not reach the padding; use the shelf packer")


def _proxies(uvs, faces, hull=()):
    """What xatlas is given per chart.

    The chart itself; for a sliver (xatlas does not place charts of no rasterised
    area) its bounding box thickened to 5% of its length; and for a chart with
    near-degenerate triangles (xatlas drops them and may then place the pieces of the
    chart apart) or listed in ``hull``, its convex hull.
    """
    sent, sent_f = [], []
    quad = np.array([[0, 1, 2], [0, 2, 3]])
    for i, (u, f) in enumerate(zip(uvs, faces)):
        lo, hi = u.min(0), u.max(0)
        ext = hi - lo
        box = float(ext[0] * ext[1])
        area = uv_area(u, f)
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

    The chart's rotation is the least-squares proper fit (:func:`~neuraluv.layout.rigid.rigid_fit`)
    of xatlas's output to the input. A chart that xatlas did not place as one rigid copy
    to within a texel — a reflection (a mirrored island), pieces placed apart, or vertices
    left out — raises ``_Misplaced`` listing every such chart.
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
        R, _, _ = rigid_fit(P, Q)  # the best rotation: a mirrored or scattered placement does not fit it
        pc, qc = P - P.mean(0), Q - Q.mean(0)
        if np.abs(pc @ R * tex - qc).max() > 1.0:  # not one rigid, unmirrored copy (to a texel)
            bad.append(i)
            continue
        packed.append(((u - P.mean(0)) @ R * tex + Q.mean(0) + pad) / resolution)
        pages[i] = page[sel[0]]
    if bad:
        raise _Misplaced(bad)
    return packed, pages
