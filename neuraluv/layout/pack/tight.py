"""The default packer: the fullest of several raster packings, islands cut when that packs fuller."""
from __future__ import annotations

import numpy as np

from neuraluv.layout import facts
from neuraluv.layout.pack import (ORDER_JITTER, ORDER_MAX_ISLANDS, ORDER_PATIENCE, PACK_TRIALS, RASTER_MAX_ISLANDS,
                                  RASTER_TRIALS, SPLIT_GAIN)
from neuraluv.layout.pack.cuts import granular_islands
from neuraluv.layout.pack.raster import island_outlines, raster_pack
from neuraluv.layout.pack.result import uv_area
from neuraluv.layout.pack.xatlas_packer import xatlas_shape_pack
from neuraluv.layout.rigid import rotate_to_min_box
from neuraluv.topology import submesh

__all__ = ["tight_pack"]

def tight_pack(uvs, faces, *, padding=4.0, resolution=1024, texel_density=None, trials=PACK_TRIALS, rotate=True,
               method="auto", split=None, xyz=None):
    """Pack islands by their shapes at the largest common scale that fits the texture, with exact padding.

    The fullest of ``trials`` packings is kept: :func:`~neuraluv.layout.pack.raster.raster_pack`
    with the settings of :data:`RASTER_TRIALS`, then with the first setting and the placement
    order perturbed (seeded, :data:`ORDER_JITTER`; up to :data:`ORDER_MAX_ISLANDS` islands; they
    stop after :data:`ORDER_PATIENCE` in a row that packed no fuller);
    every trial after the first searches up from the best scale so far and costs one
    placement per rule when it cannot reach it; up to :data:`RASTER_MAX_ISLANDS` islands; or xatlas's
    shape placement with (at most two) quarter-turn trials
    (:func:`~neuraluv.layout.pack.xatlas_packer.xatlas_shape_pack`) for more islands or with
    ``method="xatlas"``.

    With ``split`` (a share, e.g. :data:`~neuraluv.layout.pack.cuts.SPLIT_SHARE`), when an
    island holds more than that share of the total UV area the islands are also packed cut
    by :func:`~neuraluv.layout.pack.cuts.granular_islands` (a few large islands leave gaps no
    placement can fill), and that packing is kept when it is fuller by at least
    :data:`SPLIT_GAIN` on no more pages (its trials search only from the whole packing's
    fill up: a cut packing that cannot reach it is dropped after one placement per rule);
    its ``pieces`` then say which part of which island each packed island is.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays
        Islands at a common scale.
    faces : list of (m_i,3) int arrays
    padding : float
        Minimum gap, in texels at ``resolution``.
    resolution : int
    texel_density : float, optional
        Texels per UV unit instead of the largest scale that fits; several pages when needed.
    trials : int
        Packings tried; the fullest (fewest pages first) is kept.
    rotate : bool
        Turn islands to nest them (proper rotations only); False keeps each as given.
    method : ``"auto"``, ``"raster"`` or ``"xatlas"``
    split : float, optional
        Largest share of the total UV area one packed island may hold before a cut
        packing is tried (None: islands are packed whole).
    xyz : list of (n_i,3) float arrays, optional
        The islands' 3D vertices: each cut part is then scaled to its own texel density
        (:func:`~neuraluv.layout.facts.texel_density`; the islands are assumed at one density
        already), so the density spread across packed islands stays that of whole islands.

    Returns
    -------
    PackResult (``packer="tight"``, with ``pages`` and ``trials``; ``pieces`` when the cut packing was kept)

    Examples
    --------
    >>> sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]]); q = np.array([[0, 1, 2], [0, 2, 3]])
    >>> res = tight_pack([sq, 2 * sq, sq], [q, q, q], padding=4, resolution=128)
    >>> res.padding_texels >= 4, round(res.utilisation, 2) > 0.5, res.packer
    (True, True, 'tight')
    """
    if method not in ("auto", "raster", "xatlas"):
        raise ValueError(f"unknown method {method!r}: use 'auto', 'raster' or 'xatlas'")
    kw = dict(padding=padding, resolution=resolution, texel_density=texel_density, trials=trials, rotate=rotate,
              method=method)
    whole = _best_of_trials(uvs, faces, **kw)
    if split:
        pieces = granular_islands(uvs, faces, split)
        if len(pieces) > len(uvs):
            parts = [(i, idx, *submesh(faces[i], idx)) for i, idx in pieces]
            puvs = [np.asarray(uvs[i], float)[vi] for i, _, vi, _ in parts]
            if xyz is not None:
                d = facts.island_densities([np.asarray(xyz[i], float)[vi] for i, _, vi, _ in parts],
                                           [f for *_, f in parts], puvs)
                puvs = [u / di if np.isfinite(di) and di > 0 else u for u, di in zip(puvs, d)]
            pfaces = [f for *_, f in parts]
            # the cut packing must reach at least the whole packing's fill before growing to the padding line
            low = None
            if texel_density is None:
                low = whole.raster_scale * np.sqrt(sum(map(uv_area, uvs, faces)) / sum(map(uv_area, puvs, pfaces)))
            cut = _best_of_trials([rotate_to_min_box(u) for u in puvs] if rotate else puvs, pfaces, floor=low, **kw)
            if cut is not None and cut.n_pages <= whole.n_pages and cut.utilisation >= whole.utilisation + SPLIT_GAIN:
                cut.pieces = [(i, idx, vi) for i, idx, vi, _ in parts]
                whole = cut
    whole.packer = "tight"
    return whole


def _best_of_trials(uvs, faces, *, padding, resolution, texel_density, trials, rotate, method, floor=None):
    """The fullest of the trials; with ``floor`` (a raster scale) only packings at least that dense count, and
    None is returned when none is. Every trial after the first is searched from the best scale so far up
    (``raster_pack(floor=...)``): one that cannot beat it costs one placement per rule."""
    trials = max(int(trials), 1)
    if method == "xatlas" or (method == "auto" and len(uvs) > RASTER_MAX_ISLANDS):  # perturbed orders: raster only
        n = min(trials, len(RASTER_TRIALS)) if rotate else 1
        best = xatlas_shape_pack(uvs, faces, padding=padding, resolution=resolution, texel_density=texel_density,
                                 trials=n)
        best.trials = n
        return best
    outlines = island_outlines(uvs, faces)  # once for every trial
    kw = dict(padding=padding, resolution=resolution, texel_density=texel_density, outlines=outlines,
              rasters={})  # the rasterised islands too
    fixed = texel_density is not None  # pages at a fixed scale: every setting is packed in full
    best, err, n = None, None, 0
    settings = list(RASTER_TRIALS[:trials])
    if not fixed and 2 <= len(uvs) <= ORDER_MAX_ISLANDS:  # then the first setting with perturbed orders
        settings += [RASTER_TRIALS[0]] * (trials - len(settings))
    stale = 0  # perturbed trials in a row that packed no fuller (ORDER_PATIENCE ends them)
    for k, (grid, angles) in enumerate(settings):
        w = None if k < len(RASTER_TRIALS) else np.exp(np.random.default_rng(k).normal(0.0, ORDER_JITTER, len(uvs)))
        if w is not None and stale >= ORDER_PATIENCE:
            break
        low = floor if best is None else best.raster_scale
        n += 1
        try:
            r = raster_pack(uvs, faces, grid=grid, angles=angles if rotate else 1, weights=w,
                            floor=None if fixed else low, **kw)
        except ValueError as exc:  # not as dense as the best (a cheap miss), or nothing fits
            err = exc
            stale += w is not None
            continue
        if best is None or (-r.n_pages, r.utilisation) > (-best.n_pages, best.utilisation):
            best, stale = r, 0
        else:
            stale += w is not None
    if best is None:
        if floor is not None:
            return None
        raise err
    best.trials = n
    return best
