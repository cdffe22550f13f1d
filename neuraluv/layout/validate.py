"""Exact validation of a UV layout: flips, overlaps, bounds, padding, texel density.

One validation for every purpose: the atlas validates what it packed, ``check
--uv`` and repair validate what they were given and what they wrote, the
benchmarks validate every layout they compare. Callers that already hold the
:class:`~neuraluv.layout.facts.LayoutFacts` pass them, so nothing is read twice.
"""
from __future__ import annotations

import math

import numpy as np

from neuraluv.layout.facts import defect_area, density_spread, layout_facts
from neuraluv.layout.overlap import gaps, triangles_union
from neuraluv.layout.purpose import check_purpose, layout_intent

__all__ = ["validate_layout", "validate_facts"]


def validate_layout(V, F, UV, FUV=None, **kw):
    """Check a UV layout exactly: flips, overlaps, bounds, padding (:func:`validate_facts` of its facts).

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional (default ``F``); -1 where a corner has no ``vt``.
    **kw : the options below (keywords only)
    padding : float
        Required gap between islands in texels at ``resolution``.
    resolution : int, optional
    check_padding : bool
    tiles : bool
        UDIM layout: every face must lie inside one unit tile ``[i, i+1] × [j, j+1]``
        (``i, j ≥ 0``) instead of inside ``[0,1]²``.
    purpose : {"bake", "lightmap", "texture"}
        ``bake`` / ``lightmap`` (default): the rules below. ``texture``: an artist's layout
        (:mod:`~neuraluv.layout.purpose`): valid when every face has finite UVs and no face is
        folded or UV-degenerate inside its shell; mirrored, stacked, tiled and palette shells
        are allowed, and the dict holds ``flips`` (folded + degenerate + unusable faces),
        ``folded_faces``, ``degenerate_faces``, ``shells``, ``mirrored_shell_faces``,
        ``palette_faces``, ``covered_faces``, ``non_finite_faces``, ``min_det`` (oriented like
        each face's shell) and ``valid``.
    min_defect : float
        Texels (of area) at ``resolution``: an island's overlap with itself, or two islands' overlap,
        smaller than this in all is not counted (``overlaps_below_tolerance`` lists them); 0 (default): exact.
        (:func:`validate_facts` takes the tolerance the facts were read with.)
    stacked : bool
        Islands stacked on purpose (``build_atlas(stack=True)``): two islands covering
        exactly the same region (symmetric difference below 1e-9 of their area) are
        counted in ``stacked_islands`` and are neither an overlap nor a padding
        violation. Partial overlaps still are.

    Returns
    -------
    dict
        ``flips`` (usable faces with det J ≤ 0 or collapsed in UV,
        :func:`~neuraluv.layout.facts.uv_degenerate`: written as float32 a det J of 1e-17 is 0; plus faces
        without finite UVs: their det J is undefined), ``zero_area_faces`` (no 3D area: no distortion, not
        counted as flips), ``non_finite_faces``, ``covered_faces``, ``min_det``,
        ``islands``, ``mirrored_islands``, ``overlapping_pairs`` (island pairs whose
        oriented triangles share area), ``overlap_area``, ``self_overlapping_islands``,
        ``padding_violations`` (pairs closer than ``padding/resolution``),
        ``min_gap_texels``, ``uv_in_unit_square``, ``stacked_islands``, ``valid`` and
        ``density_spread`` (:func:`~neuraluv.layout.facts.density_spread`; not part of ``valid``).

    Notes
    -----
    Overlaps are exact triangle-pair tests (:func:`~neuraluv.layout.overlap.find_overlaps`);
    gaps are distances between the islands' polygon unions (shapely/GEOS).

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2], [0, 1, 2]])
    >>> UV = np.array([[.1, .1], [.4, .1], [.1, .4], [.2, .2], [.5, .2], [.2, .5]])
    >>> r = validate_layout(V, F, UV, np.array([[0, 1, 2], [3, 4, 5]]))
    >>> r["flips"], r["overlapping_pairs"], r["valid"]
    (0, 1, False)
    """
    tol = defect_area(kw.pop("min_defect", 0.0), kw.get("resolution"))
    return validate_facts(layout_facts(V, F, UV, FUV, min_overlap=tol), **kw)


def validate_facts(f, *, padding=0.0, resolution=None, check_padding=True, tiles=False, stacked=False,
                   purpose="bake"):
    """:func:`validate_layout` of a layout whose :class:`~neuraluv.layout.facts.LayoutFacts` ``f`` the caller holds."""
    if check_purpose(purpose) == "texture":
        return _validate_texture(f)
    m, n = len(f.F), f.n_islands
    usable = f.usable
    covered = int((~f.missing).sum())
    non_finite = int(f.non_finite.sum())
    small = f.small_folds(f.bad)  # folds no texture at the tolerance shows (none at the default 0)
    flips = int((f.bad & ~small).sum()) + (m - int(usable.sum()))
    good = usable & ~f.degenerate3d
    min_det = float(f.det[good].min()) if good.any() else None
    used = f.UV[np.unique(f.FUV[usable])] if usable.any() else f.UV[:0]
    in_box = bool(non_finite == 0 and len(used) and used.min() >= 0.0 and used.max() <= 1.0)
    if tiles and non_finite == 0 and len(used) and used.min() >= 0.0:
        corners = f.UV[f.FUV[usable]]
        tile = np.floor(corners.mean(1))[:, None, :]
        in_box = bool(((corners >= tile) & (corners <= tile + 1)).all())
    ii, jj, area = f.overlaps()
    li, lj = f.label[ii], f.label[jj]
    self_ov = len(np.unique(li[li == lj]))
    cross = {}
    for a, b, ar in zip(li[li != lj], lj[li != lj], area[li != lj]):
        key = (int(min(a, b)), int(max(a, b)))
        cross[key] = cross.get(key, 0.0) + float(ar)
    polys = [triangles_union(f.UV, f.FUV[f.island_faces(i)])[0] for i in range(n)] if n > 1 else []
    on_top = set()
    if stacked:
        for i, j in cross:
            if polys[i].symmetric_difference(polys[j]).area <= 1e-9 * max(polys[i].area, 1e-300):
                on_top.add((i, j))
    ov_pairs = len(cross) - len(on_top)
    ov_area = float(sum(ar for k, ar in cross.items() if k not in on_top))
    pad = float(padding) / float(resolution) if (resolution and check_padding) else 0.0
    probe = 4 * max(pad, 1e-9)
    _, _, d = gaps(polys, probe, skip=on_top)
    min_gap = float(d.min()) if len(d) else float("inf")
    pad_viol = int((d < pad * (1 - 1e-6)).sum()) if pad > 0 else 0
    if resolution and math.isfinite(min_gap):
        gap_tex = min_gap * resolution
    elif resolution:
        gap_tex = f">{probe * resolution:.3g}" if n > 1 else "inf"
    else:
        gap_tex = min_gap if (n <= 1 or math.isfinite(min_gap)) else None
    valid = (covered == m and non_finite == 0 and flips == 0 and ov_pairs == 0 and self_ov == 0 and in_box
             and pad_viol == 0)
    return {
        "faces": m, "covered_faces": covered, "non_finite_faces": non_finite, "flips": flips, "min_det": min_det,
        "zero_area_faces": int(f.degenerate3d.sum()), "islands": int(n), "mirrored_islands": int(f.mirrored.sum()),
        "overlapping_pairs": ov_pairs, "overlap_area": ov_area, "self_overlapping_islands": int(self_ov),
        "padding_violations": pad_viol, "padding_texels": padding, "resolution": resolution,
        "min_gap_texels": gap_tex, "uv_in_unit_square": in_box, "valid": bool(valid),
        "density_spread": density_spread(f.density), "stacked_islands": len({j for _, j in on_top}),
        "overlaps_below_tolerance": f.ignored_overlaps(), "folded_faces_below_tolerance": int(small.sum()),
        "purpose": "bake",
    }


def _validate_texture(f):
    """The texture purpose's verdict (:func:`~neuraluv.layout.purpose.layout_intent`): every face has finite UVs,
    no fold, no UV-degenerate face inside a shell; mirrored, stacked, tiled and palette shells are allowed."""
    it = layout_intent(f)
    m = len(f.F)
    covered = int((~f.missing).sum())
    non_finite = int(f.non_finite.sum())
    folds = int(it.fold.sum())
    degen = int(it.degenerate.sum())
    flips = folds + degen + (m - int(f.usable.sum()))
    good = f.usable & ~f.degenerate3d & ~it.palette & (it.shell >= 0)
    sign = np.where(it.shell >= 0, it.shell_sign[np.maximum(it.shell, 0)], 1) if len(it.shell_sign) else np.ones(m)
    oriented = f.det * sign
    min_det = float(oriented[good].min()) if good.any() else None
    return {
        "faces": m, "covered_faces": covered, "non_finite_faces": non_finite, "flips": flips, "folded_faces": folds,
        "degenerate_faces": degen, "min_det": min_det, "zero_area_faces": int(f.degenerate3d.sum()),
        "islands": int(f.n_islands), "shells": int(len(it.shell_sign)), "mirrored_shell_faces": int(it.mirrored_shell.sum()),
        "palette_faces": int(it.palette.sum()), "valid": bool(covered == m and non_finite == 0 and folds == 0 and degen == 0),
        "purpose": "texture",
    }
