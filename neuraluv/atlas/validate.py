"""Atlas step 5: exact validation of a packed atlas (flips, overlaps, bounds, padding)."""
from __future__ import annotations

import math

import numpy as np

from neuraluv.jacobian import signed_areas_2d
from neuraluv.meshfix import face_areas, normalize_unit_box
from neuraluv.metrics import distortion_metrics
from neuraluv.topology import faces_sharing

__all__ = ["uv_islands", "triangles_union", "self_overlap", "validate_atlas", "face_texel_density"]


def uv_islands(FUV):
    """Label faces by UV island (faces sharing a ``vt`` index are connected).

    Returns
    -------
    n : int
    labels : (m,) int array
    """
    FUV = np.asarray(FUV, np.int64)
    return faces_sharing(FUV.reshape(-1), np.repeat(np.arange(len(FUV)), 3), len(FUV))


def validate_atlas(V, F, UV, FUV=None, *, padding=0.0, resolution=None, check_padding=True, tiles=False,
                   stacked=False):
    """Check a packed atlas exactly: flips, overlaps, bounds, padding.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional (default ``F``)
    padding : float
        Required gap between islands in texels at ``resolution``.
    resolution : int, optional
    check_padding : bool
    tiles : bool
        UDIM layout: every face must lie inside one unit tile ``[i, i+1] × [j, j+1]``
        (``i, j ≥ 0``) instead of inside ``[0,1]²``.
    stacked : bool
        Islands stacked on purpose (``build_atlas(stack=True)``): two islands covering
        exactly the same region (symmetric difference below 1e-9 of their area) are
        counted in ``stacked_islands`` and are neither an overlap nor a padding
        violation. Partial overlaps still are.

    Returns
    -------
    dict
        ``flips`` (faces with det J ≤ 0 via :func:`neuraluv.metrics.distortion_metrics`; faces
        without finite UVs count too), ``non_finite_faces`` (corners with NaN/inf UVs),
        ``islands``, ``overlapping_pairs`` (island pairs whose polygons share
        area), ``overlap_area``, ``self_overlapping_islands``, ``padding_violations``
        (pairs closer than ``padding/resolution``), ``min_gap_texels``,
        ``uv_in_unit_square``, ``covered_faces``, ``valid`` and ``density_spread``
        (``max/min − 1`` over islands of ``sqrt(UV area / 3D area)``: 0 when every
        island has the same texel density; not part of ``valid``).

    Notes
    -----
    Islands are unions of their UV triangles (shapely/GEOS, exact polygon
    arithmetic in floating point); candidate pairs come from an STRtree query.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2], [0, 1, 2]])
    >>> UV = np.array([[.1, .1], [.4, .1], [.1, .4], [.2, .2], [.5, .2], [.2, .5]])
    >>> r = validate_atlas(V, F, UV, np.array([[0, 1, 2], [3, 4, 5]]))
    >>> r["flips"], r["overlapping_pairs"], r["valid"]
    (0, 1, False)
    """
    import shapely

    V = normalize_unit_box(V)[0]
    F = np.asarray(F, np.int64)
    FUV = F if FUV is None else np.asarray(FUV, np.int64)
    UV = np.asarray(UV, float)
    m = len(F)
    has_uv = (FUV >= 0).all(1) & (FUV < len(UV)).all(1) if m else np.zeros(0, bool)
    covered = int(has_uv.sum())
    ok_face = has_uv.copy()
    ok_face[has_uv] = np.isfinite(UV[FUV[has_uv]]).all(axis=(1, 2))
    non_finite = int((has_uv & ~ok_face).sum())
    used = UV[np.unique(FUV[ok_face])] if ok_face.any() else UV[:0]
    in_box = bool(non_finite == 0 and len(used) and used.min() >= 0.0 and used.max() <= 1.0)
    if tiles and non_finite == 0 and len(used) and used.min() >= 0.0:
        corners = UV[FUV[ok_face]]
        tile = np.floor(corners.mean(1))[:, None, :]
        in_box = bool(((corners >= tile) & (corners <= tile + 1)).all())
    if covered < m or non_finite:  # faces without (finite) UVs count as flipped: det J is undefined
        met = distortion_metrics(V, F[ok_face], UV, FUV[ok_face]) if ok_face.any() else {"flips": 0, "min_det": None}
        flips = int(met["flips"]) + (m - int(ok_face.sum()))
    else:
        met = distortion_metrics(V, F, UV, FUV) if m else {"flips": 0}
        flips = int(met["flips"])
    n, lab_ok = uv_islands(FUV[ok_face]) if ok_face.any() else (0, np.zeros(0, np.int64))
    lab = lab_ok
    FUV = FUV[ok_face]
    polys, self_ov = [], 0
    order = np.argsort(lab, kind="stable")
    bounds = np.searchsorted(lab[order], np.arange(n + 1))
    density = _island_density(V, F[ok_face], UV, FUV, lab, n)
    for i in range(n):
        fi = order[bounds[i]:bounds[i + 1]]
        P, total = triangles_union(UV, FUV[fi])
        if total > 0 and (total - P.area) / total > 1e-7:
            self_ov += 1
        polys.append(P)
    polys = np.array(polys, dtype=object)
    tree = shapely.STRtree(polys)
    pad = float(padding) / float(resolution) if (resolution and check_padding) else 0.0
    ov_pairs, ov_area, pad_viol = 0, 0.0, 0
    a, b = tree.query(polys, predicate="intersects")
    keep = a < b
    on_top = set()  # (i, j) pairs stacked on purpose
    for i, j in zip(a[keep], b[keep]):
        ar = polys[i].intersection(polys[j]).area
        if ar > 0:
            if stacked and polys[i].symmetric_difference(polys[j]).area <= 1e-9 * max(polys[i].area, 1e-300):
                on_top.add((i, j))
                continue
            ov_pairs += 1
            ov_area += ar
    min_gap = float("inf")
    if n > 1:
        probe = max(pad, 1e-9)
        a, b = tree.query(polys, predicate="dwithin", distance=probe * 4)
        keep = a < b
        for i, j in zip(a[keep], b[keep]):
            if (i, j) in on_top:
                continue
            d = polys[i].distance(polys[j])
            min_gap = min(min_gap, d)
            if pad > 0 and d < pad * (1 - 1e-6):
                pad_viol += 1
    gap_tex = (min_gap * resolution) if (resolution and math.isfinite(min_gap)) else (None if n > 1 and not math.isfinite(min_gap) else min_gap)
    if resolution and not math.isfinite(min_gap):
        gap_tex = f">{4 * max(pad, 1e-9) * resolution:.3g}" if n > 1 else "inf"
    valid = (covered == m and non_finite == 0 and flips == 0 and ov_pairs == 0 and self_ov == 0 and in_box
             and pad_viol == 0)
    return {
        "faces": m, "covered_faces": covered, "non_finite_faces": non_finite, "flips": flips, "min_det": met.get("min_det"),
        "islands": int(n), "overlapping_pairs": ov_pairs, "overlap_area": ov_area,
        "self_overlapping_islands": self_ov, "padding_violations": pad_viol, "padding_texels": padding,
        "resolution": resolution, "min_gap_texels": gap_tex, "uv_in_unit_square": in_box, "valid": bool(valid),
        "density_spread": _spread(density),
        "stacked_islands": len({int(j) for _, j in on_top}),
    }


def _island_density(V, F, UV, FUV, lab, n):
    """Per island ``sqrt(UV area / 3D area)`` (NaN for islands of no 3D area)."""
    a3 = np.bincount(lab, face_areas(V, F), minlength=n)
    a2 = np.bincount(lab, np.abs(signed_areas_2d(UV, FUV)), minlength=n)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(a3 > 0, np.sqrt(a2 / np.where(a3 > 0, a3, 1)), np.nan)


def face_texel_density(V, F, UV, FUV=None):
    """Texel density of each face's island, relative to the median island: 1 everywhere for one density.

    The density of an island is ``sqrt(UV area / 3D area)`` (UV units per unit length;
    times the resolution: texels per unit length); :func:`validate_atlas` reports its
    spread across islands as ``density_spread``.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional (default ``F``)

    Returns
    -------
    (m,) float array

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2], [0, 1, 2]])
    >>> UV = np.array([[0, 0], [.2, 0], [0, .2], [.5, .5], [.9, .5], [.5, .9]])
    >>> face_texel_density(V, F, UV, np.array([[0, 1, 2], [3, 4, 5]])).round(3).tolist()
    [0.667, 1.333]
    """
    F = np.asarray(F, np.int64)
    FUV = F if FUV is None else np.asarray(FUV, np.int64)
    n, lab = uv_islands(FUV)
    d = _island_density(np.asarray(V, float), F, np.asarray(UV, float), FUV, lab, n)
    return d[lab] / np.nanmedian(d)


def _spread(density):
    """Texel-density spread across islands: ``max / min − 1`` of ``sqrt(UV area / 3D area)`` (0 = one density)."""
    d = density[np.isfinite(density) & (density > 0)]
    return float(d.max() / d.min() - 1.0) if len(d) else None


def self_overlap(UV, F, rtol=1e-7):
    """Relative area by which a chart's UV triangles overlap each other.

    ``(Σ|A_t| − |∪ t|) / Σ|A_t|`` computed exactly with shapely polygon unions;
    0 for a globally injective chart.

    Examples
    --------
    >>> UV = np.array([[0., 0], [1, 0], [0, 1], [1, 1]])
    >>> self_overlap(UV, np.array([[0, 1, 2], [1, 3, 2]])), self_overlap(UV, np.array([[0, 1, 2], [0, 1, 3]])) > 0
    (0.0, True)
    """
    P, total = triangles_union(UV, F)
    if total <= 0:
        return 0.0
    d = (total - P.area) / total
    return float(d) if d > rtol else 0.0


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

    Examples
    --------
    >>> U, t = triangles_union(np.array([[0., 0], [1, 0], [0, 1], [1, 1]]), np.array([[0, 1, 2], [1, 3, 2]]))
    >>> round(U.area, 12), t
    (1.0, 1.0)
    """
    import shapely

    tri = np.asarray(UV, float)[np.asarray(F)]
    total = float(np.abs(signed_areas_2d(UV, F)).sum())
    ring = np.concatenate([tri, tri[:, :1]], axis=1)
    polys = shapely.polygons(ring)
    return shapely.union_all(polys), total
