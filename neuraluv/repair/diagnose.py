"""Diagnose a supplied UV layout, per face and per island, and say what repair will do.

:func:`layout_facts` reads the layout once (which faces have usable UVs, the
islands, every face's det J, each island's texel density and orientation);
:func:`diagnose_layout` turns those facts into a list of named problems with
their location (3D centroid, UV box) and the repair action, and the warnings
that repair leaves alone (padding between untouched islands, texel-density
spread). ``neuraluv check --uv IN`` prints it.

Definitions (one place for all of them):

* a face is **missing** when a corner has no ``vt`` index, **non-finite** when a
  corner's ``vt`` is NaN or infinite;
* **islands** are the faces with usable UVs joined through shared ``vt`` rows;
* **flipped**: ``det J < 0``; **degenerate**: ``det J = 0`` (both fail
  :func:`~neuraluv.atlas.validate.validate_atlas`);
* an island is **mirrored** when its flipped faces cover more UV area than its
  positive ones (the whole island was reflected, not folded);
* **overlaps** are pairs of positively oriented triangles whose interiors share
  area (:func:`~neuraluv.repair.overlap.overlapping_pairs`), within an island
  (a self-overlap) or between islands;
* **texel density** of an island is ``sqrt(Σ A_uv / Σ A_3d)`` over its positive faces.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from neuraluv.jacobian import signed_areas_2d
from neuraluv.meshfix import face_areas, normalize_unit_box
from neuraluv.metrics import face_dets
from neuraluv.topology import faces_sharing

__all__ = ["LayoutFacts", "layout_facts", "face_clusters", "UVDiagnosis", "diagnose_layout", "find_overlaps"]


@dataclass
class LayoutFacts:
    """What :func:`layout_facts` reads off a layout (arrays over faces unless noted).

    Attributes
    ----------
    Vn : (n,3) float array, the mesh normalised to the unit box (distortion is measured on it).
    F : (m,3) int array; UV : (p,2) float array; FUV : (m,3) int array (-1 where a corner has no ``vt``).
    missing, non_finite : (m,) bool arrays.
    label : (m,) int array, island of each usable face (-1 for missing / non-finite faces).
    n_islands : int
    det : (m,) float array, det J (NaN for unusable faces); positive faces are valid.
    signed_uv : (m,) float array, signed UV areas; area3d : (m,) float array.
    density : (n_islands,) float array, texel density (NaN when the island has no positive face).
    mirrored : (n_islands,) bool array.
    degenerate3d : (m,) bool array, faces with no 3D area (distortion is undefined; their UVs are left alone).
    """

    Vn: np.ndarray
    F: np.ndarray
    UV: np.ndarray
    FUV: np.ndarray
    missing: np.ndarray
    non_finite: np.ndarray
    label: np.ndarray
    n_islands: int
    det: np.ndarray
    signed_uv: np.ndarray
    area3d: np.ndarray
    density: np.ndarray
    mirrored: np.ndarray
    degenerate3d: np.ndarray

    def island_faces(self, i):
        """Face indices of island ``i``."""
        return np.flatnonzero(self.label == i)

    @property
    def usable(self):
        return self.label >= 0

    @property
    def bad(self):
        """Usable faces that fail validation (flipped or degenerate in UV; faces with no 3D area excluded)."""
        return self.usable & ~(self.det > 0) & ~self.degenerate3d

    @property
    def median_density(self):
        d = self.density[np.isfinite(self.density)]
        return float(np.median(d)) if len(d) else None


def layout_facts(V, F, UV, FUV):
    """Read a layout once: usable faces, islands, det J, densities, mirrored islands.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array
        ``vt`` index of every corner; -1 (or out of range) where a face has none.

    Returns
    -------
    LayoutFacts

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]); F = np.array([[0, 1, 2], [1, 3, 2]])
    >>> UV = np.array([[0.1, 0.1], [0.4, 0.1], [0.1, 0.4], [0.4, 0.4]])
    >>> f = layout_facts(V, F, UV, F)
    >>> f.n_islands, f.bad.tolist(), bool(f.mirrored[0])
    (1, [False, False], False)
    >>> layout_facts(V, F, UV * [-1, 1], F).mirrored.tolist()
    [True]
    """
    Vn = normalize_unit_box(np.asarray(V, float))[0]
    F = np.asarray(F, np.int64)
    UV = np.asarray(UV, float).reshape(-1, 2)
    FUV = np.asarray(FUV, np.int64)
    m = len(F)
    in_range = (FUV >= 0) & (FUV < len(UV))
    missing = ~in_range.all(1)
    FUV = np.where(in_range, FUV, -1)
    fin = np.zeros(m, bool)
    fin[~missing] = np.isfinite(UV[FUV[~missing]]).all(axis=(1, 2))
    non_finite = ~missing & ~fin
    usable = ~missing & fin
    label = -np.ones(m, np.int64)
    n = 0
    if usable.any():
        n, lab = faces_sharing(FUV[usable].reshape(-1), np.repeat(np.arange(int(usable.sum())), 3), int(usable.sum()))
        label[usable] = lab
    det = np.full(m, np.nan)
    signed = np.full(m, np.nan)
    if usable.any():
        det[usable] = face_dets(Vn, F[usable], UV, FUV[usable])
        signed[usable] = signed_areas_2d(UV, FUV[usable])
    a3 = face_areas(Vn, F)
    deg3 = ~(a3 > 1e-14)
    pos = usable & (det > 0) & ~deg3
    lab_u = label[usable]
    s_u = np.nan_to_num(signed[usable])
    area_pos = np.bincount(lab_u, weights=np.where(s_u > 0, s_u, 0.0), minlength=n)
    area_neg = np.bincount(lab_u, weights=np.where(s_u < 0, -s_u, 0.0), minlength=n)
    mirrored = area_neg > area_pos
    a3_pos = np.bincount(label[pos], weights=a3[pos], minlength=n)
    auv_pos = np.bincount(label[pos], weights=signed[pos], minlength=n)
    # a mirrored island's density is measured on its (flipped) faces' unsigned area
    neg = usable & (det < 0)
    a3_neg = np.bincount(label[neg], weights=a3[neg], minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        density = np.where(mirrored, np.sqrt(area_neg / a3_neg), np.sqrt(auv_pos / a3_pos))
    density = np.where(np.isfinite(density) & (density > 0), density, np.nan)
    return LayoutFacts(Vn=Vn, F=F, UV=UV, FUV=FUV, missing=missing, non_finite=non_finite, label=label, n_islands=int(n),
                       det=det, signed_uv=signed, area3d=a3, density=density, mirrored=mirrored, degenerate3d=deg3)


def face_clusters(FUV, faces):
    """Group ``faces`` into clusters joined through shared ``vt`` rows: ``[array, ...]``, largest first."""
    faces = np.asarray(faces, np.int64)
    if not len(faces):
        return []
    n, lab = faces_sharing(np.asarray(FUV)[faces].reshape(-1), np.repeat(np.arange(len(faces)), 3), len(faces))
    out = [faces[lab == k] for k in range(n)]
    return sorted(out, key=len, reverse=True)


def find_overlaps(facts, faces=None):
    """Overlapping pairs of UV triangles oriented like their island (positive; reversed in a mirrored island).

    Parameters
    ----------
    facts : LayoutFacts
    faces : int array, optional
        Restrict the test to pairs with at least one face in this set (default: all).

    Returns
    -------
    i, j : (k,) int arrays, face indices (``i < j`` when ``faces`` is None).
    area : (k,) float array, their shared UV area.
    """
    from neuraluv.repair.overlap import candidate_pairs, overlapping_pairs, pair_areas

    lab = np.where(facts.usable, facts.label, 0)
    mirrored = facts.mirrored[lab] if facts.n_islands else np.zeros(len(lab), bool)
    # faces oriented like their island (a mirrored island's reversed faces are its regular ones)
    pos = np.flatnonzero(facts.usable & np.where(mirrored, facts.det < 0, facts.det > 0))
    tri = facts.UV[facts.FUV[pos]]
    if faces is None:
        a, b = candidate_pairs(tri)
    else:
        sel = np.isin(pos, faces)
        sub = np.flatnonzero(sel)
        a, b = candidate_pairs(tri[sub], tri)
        a = sub[a]
        keep = a != b
        a, b = a[keep], b[keep]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        both = np.unique(np.stack([lo, hi], 1), axis=0) if len(lo) else np.zeros((0, 2), np.int64)
        a, b = both[:, 0], both[:, 1]
    hit = overlapping_pairs(tri[a], tri[b])
    a, b = a[hit], b[hit]
    area = pair_areas(tri[a], tri[b])
    keep = area > 0
    return pos[a[keep]], pos[b[keep]], area[keep]


@dataclass
class UVDiagnosis:
    """A layout's problems and what repair will do about each (:func:`diagnose_layout`).

    Attributes
    ----------
    faces : int
    islands : list of dict, one per island: faces, texel density (and relative to the median),
        UV box, flipped / degenerate faces, mirrored, self-overlapping pairs, outside the unit square.
    problems : list of dict: ``kind``, ``island`` (or ``islands``), ``faces`` (count), ``face_ids``
        (the first 1,000), ``where`` (3D centroid of the faces, in the input's coordinates, and UV box),
        ``action`` (what ``neuraluv repair`` does).
    warnings : list of dict, the same fields; conditions repair leaves as they are.
    validation : dict, :func:`~neuraluv.atlas.validate.validate_atlas` of the layout as given.
    """

    faces: int
    islands: list
    problems: list
    warnings: list
    validation: dict
    resolution: int = 1024
    padding: float = 2.0
    info: dict = field(default_factory=dict)

    @property
    def ok(self):
        """True when there is nothing for repair to do."""
        return not self.problems

    def as_dict(self):
        from neuraluv import __version__
        from neuraluv.io import jsonable

        return jsonable({"neuraluv": __version__, "faces": self.faces, "ok": self.ok, "problems": self.problems,
                         "warnings": self.warnings, "islands": self.islands, "validation": self.validation,
                         "resolution": self.resolution, "padding_texels": self.padding, **self.info})

    def format(self, name="layout"):
        """The report as text: one line per problem, then the warnings."""
        n_isl = len(self.islands)
        dens = [i["texel_density"] for i in self.islands if i["texel_density"] is not None]
        lines = [f"{name}: {self.faces:,} faces, {n_isl} UV islands"
                 + (f", texel density {min(dens):.3g}–{max(dens):.3g} UV per unit length (normalised mesh)" if dens else "")]
        if self.ok:
            lines.append("  nothing to repair: no flipped, degenerate, mirrored, overlapping, missing or non-finite "
                         "UVs, all inside [0,1]²")
        for p in self.problems:
            lines.append(f"  problem: {_describe(p)}\n           → {p['action']}")
        for w in self.warnings:
            lines.append(f"  warning: {_describe(w)}\n           → {w['action']}")
        return "\n".join(lines)


def _describe(p):
    where = p.get("where", {})
    loc = ""
    if where.get("centroid") is not None:
        c = where["centroid"]
        loc = f" near 3D ({c[0]:.3g}, {c[1]:.3g}, {c[2]:.3g})"
    if where.get("uv_box") is not None:
        (a, b), (c, d) = where["uv_box"]
        loc += f", UV [{a:.3f}, {b:.3f}]–[{c:.3f}, {d:.3f}]"
    who = f"island {p['island']}" if "island" in p else (f"islands {', '.join(map(str, p['islands']))}" if "islands" in p else "")
    return f"{p['message']}" + (f" ({who})" if who else "") + loc


def _where(V, F, UV, FUV, faces):
    faces = np.asarray(faces, np.int64)
    if not len(faces):
        return {}
    c = np.asarray(V, float)[F[faces]].reshape(-1, 3).mean(0)
    rows = FUV[faces].reshape(-1)
    rows = rows[rows >= 0]
    pts = UV[rows] if len(rows) else np.zeros((0, 2))
    pts = pts[np.isfinite(pts).all(1)]
    box = [pts.min(0).tolist(), pts.max(0).tolist()] if len(pts) else None
    return {"centroid": c.tolist(), "uv_box": box}


def _problem(kind, message, action, faces, V, F, UV, FUV, **extra):
    faces = np.asarray(faces, np.int64)
    return {"kind": kind, "message": message, **extra, "faces": int(len(faces)), "face_ids": faces[:1000].tolist(),
            "where": _where(V, F, UV, FUV, faces), "action": action}


def diagnose_layout(V, F, UV, FUV=None, *, resolution=1024, padding=2.0, facts=None):
    """Every problem of a supplied UV layout, where it is, and what repair will do.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional
        Per-corner ``vt`` indices (default ``F``); -1 where a face has none.
    resolution : int
        Texture resolution at which padding is measured.
    padding : float
        Required gap between islands, in texels (a warning when violated).
    facts : LayoutFacts, optional
        Already computed.

    Returns
    -------
    UVDiagnosis

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> from neuraluv.tutte import tutte
    >>> V, F = disk(3); UV = tutte(V, F) * 0.4 + 0.5
    >>> diagnose_layout(V, F, UV).ok
    True
    >>> UV[0] += [0.3, 0.0]                          # push the centre vertex across its ring
    >>> d = diagnose_layout(V, F, UV)
    >>> [p["kind"] for p in d.problems]              # the fold also lays triangles over their neighbours
    ['folded_faces', 'self_overlap']
    """
    from neuraluv.atlas.validate import validate_atlas

    F = np.asarray(F, np.int64)
    FUV = F if FUV is None else np.asarray(FUV, np.int64)
    f = facts if facts is not None else layout_facts(V, F, UV, FUV)
    V = np.asarray(V, float)
    UVf = f.UV
    FU = f.FUV
    problems, warnings = [], []
    args = (V, F, UVf, FU)
    if f.missing.any():
        problems.append(_problem("missing_uv", f"{int(f.missing.sum()):,} faces without texture coordinates",
                                 "give them new charts (solved, at the layout's median texel density, placed in free space)",
                                 np.flatnonzero(f.missing), *args))
    if f.non_finite.any():
        problems.append(_problem("non_finite_uv", f"{int(f.non_finite.sum()):,} faces with NaN or infinite texture coordinates",
                                 "give them new charts (solved, at the layout's median texel density, placed in free space)",
                                 np.flatnonzero(f.non_finite), *args))
    ii, jj, area = find_overlaps(f) if f.usable.any() else (np.zeros(0, int),) * 2 + (np.zeros(0),)
    li, lj = f.label[ii], f.label[jj]
    same = li == lj
    islands = []
    med = f.median_density
    for i in range(f.n_islands):
        fi = f.island_faces(i)
        d = f.det[fi]
        rows = np.unique(FU[fi])
        pts = UVf[rows]
        lo, hi = pts.min(0), pts.max(0)
        d3 = f.degenerate3d[fi]
        flipped = fi[(d < 0) & ~d3]
        degen = fi[~(d < 0) & ~(d > 0) & ~d3]
        self_pairs = int((same & (li == i)).sum())
        outside = bool(lo.min() < 0.0 or hi.max() > 1.0)
        dens = f.density[i]
        isl = {"island": i, "faces": int(len(fi)), "uv_rows": int(len(rows)), "uv_box": [lo.tolist(), hi.tolist()],
               "texel_density": None if not np.isfinite(dens) else float(dens),
               "density_vs_median": None if (not np.isfinite(dens) or not med) else float(dens / med),
               "mirrored": bool(f.mirrored[i]), "flipped": int(len(flipped)), "degenerate": int(len(degen)),
               "self_overlap_pairs": self_pairs, "outside_unit_square": outside}
        islands.append(isl)
        if f.mirrored[i]:
            problems.append(_problem("mirrored_island", f"mirrored island: {int((d < 0).sum()):,} of {len(fi):,} faces reversed",
                                     "reflect the island back (not re-solved), then untangle any faces still folded",
                                     fi, *args, island=i))
            flipped = fi[(d > 0) & ~d3]  # after reflecting back, the positive faces are the folded ones
        if len(flipped) or len(degen):
            bad = np.concatenate([flipped, degen])
            cl = face_clusters(FU, bad)
            what = []
            if len(flipped):
                what.append(f"{len(flipped):,} flipped")
            if len(degen):
                what.append(f"{len(degen):,} degenerate")
            problems.append(_problem("folded_faces", f"{' and '.join(what)} faces in {len(cl)} cluster"
                                     + ("s" if len(cl) != 1 else "") + f" (largest {len(cl[0]):,} faces)",
                                     "untangle each cluster locally, growing rings until it is valid; every other UV of "
                                     "the island stays bit-identical", bad, *args, island=i,
                                     clusters=[len(c) for c in cl]))
        if self_pairs:
            sel = same & (li == i)
            problems.append(_problem("self_overlap", f"island overlaps itself: {self_pairs:,} triangle pairs, "
                                     f"area {area[sel].sum():.3g}",
                                     "untangle around the overlapping faces; re-solve the island only if that fails",
                                     np.unique(np.concatenate([ii[sel], jj[sel]])), *args, island=i))
        if outside:
            problems.append(_problem("outside_unit_square", "island extends outside [0,1]²",
                                     "move it (translate, rotate; no mirroring, same texel density) into free space",
                                     fi, *args, island=i))
    if len(li) and (~same).any():
        pairs = {}
        for a, b, ar in zip(li[~same], lj[~same], area[~same]):
            key = (int(min(a, b)), int(max(a, b)))
            pairs[key] = pairs.get(key, 0.0) + float(ar)
        for (a, b), ar in sorted(pairs.items()):
            sel = (~same) & (((li == a) & (lj == b)) | ((li == b) & (lj == a)))
            problems.append(_problem("island_overlap", f"islands {a} and {b} overlap (area {ar:.3g})",
                                     "move one of them (the smaller, or the one repair already changed) into free space",
                                     np.unique(np.concatenate([ii[sel], jj[sel]])), *args, islands=[a, b], area=ar))
    val = validate_atlas(f.Vn, F, UVf, FU, padding=padding, resolution=resolution)
    if val["padding_violations"]:
        warnings.append({"kind": "padding", "message": f"{val['padding_violations']} island pairs closer than "
                         f"{padding:g} texels at {resolution} px (closest {val['min_gap_texels']})",
                         "action": "left as is for islands repair does not move; moved and new islands keep the padding"})
    if f.degenerate3d.any():
        warnings.append({"kind": "zero_area_faces", "message": f"{int(f.degenerate3d.sum()):,} faces have no 3D area "
                         "(distortion is undefined there)", "action": "their UVs are left as they are"})
    dens = [x for x in f.density if np.isfinite(x)]
    if len(dens) > 1 and max(dens) > 2 * min(dens):
        warnings.append({"kind": "texel_density", "message": f"texel density varies {max(dens) / min(dens):.1f}× "
                         "between islands", "action": "left as is (repair keeps each island's density)"})
    return UVDiagnosis(faces=int(len(F)), islands=islands, problems=problems, warnings=warnings, validation=val,
                       resolution=int(resolution), padding=float(padding))
