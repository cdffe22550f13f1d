"""Diagnose a supplied UV layout, per island, and say what repair will do (``neuraluv check --uv``).

:func:`diagnose_layout` reads the layout's facts once
(:func:`~neuraluv.layout.facts.layout_facts`: usable faces, islands, det J, mirrored
islands, texel densities; the definitions are there) and turns them into a list of
named problems with their location (3D centroid, UV box) and the repair action,
and the warnings that repair leaves alone (padding between untouched islands,
texel-density spread, faces without 3D area). Overlaps are the exact triangle-pair
tests of :mod:`neuraluv.layout.overlap`; the validation is
:func:`~neuraluv.layout.validate.validate_facts` of the same facts.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from neuraluv import __version__
from neuraluv.io import jsonable
from neuraluv.layout.facts import defect_area, face_clusters, layout_facts
from neuraluv.layout.overlap import overlap_pairs
from neuraluv.layout.purpose import check_purpose, layout_intent
from neuraluv.layout.validate import validate_facts
from neuraluv.topology import graph_components, unique_rows

__all__ = ["UVDiagnosis", "diagnose_layout"]


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
    features : list of dict, the same fields; what the purpose calls intentional (under ``texture``:
        mirrored shells, islands sharing texels, tiles and UDIMs outside ``[0,1]²``, palette collapses).
    purpose : str, the purpose the layout was judged by (:mod:`~neuraluv.layout.purpose`).
    validation : dict, :func:`~neuraluv.layout.validate.validate_facts` of the layout as given.
    """

    faces: int
    islands: list
    problems: list
    warnings: list
    validation: dict
    resolution: int = 1024
    padding: float = 2.0
    info: dict = field(default_factory=dict)
    purpose: str = "bake"
    features: list = field(default_factory=list)

    @property
    def ok(self):
        """True when there is nothing for repair to do."""
        return not self.problems

    def as_dict(self):
        return jsonable({"neuraluv": __version__, "purpose": self.purpose, "faces": self.faces, "ok": self.ok,
                         "problems": self.problems, "features": self.features, "warnings": self.warnings, "islands": self.islands, "validation": self.validation,
                         "resolution": self.resolution, "padding_texels": self.padding, **self.info})

    def format(self, name="layout", limit=5):
        """The report as text: the problems, then the warnings, then a summary line.

        Parameters
        ----------
        name : str
        limit : int or None
            Lines per kind of problem or warning; the rest are counted in one line
            (None: every one).
        """
        n_isl = len(self.islands)
        dens = [i["texel_density"] for i in self.islands if i["texel_density"] is not None]
        lines = [f"{name}: {self.faces:,} faces, {n_isl} UV islands, judged as a {self.purpose} layout"
                 + (f", texel density {min(dens):.3g}–{max(dens):.3g} UV per unit length (normalised mesh)" if dens else "")]
        if self.ok and self.purpose == "texture":
            lines.append("  nothing to repair: no folded or degenerate faces inside a shell, no missing or non-finite UVs")
        elif self.ok:
            lines.append("  nothing to repair: no flipped, degenerate, mirrored, overlapping, missing or non-finite "
                         "UVs, all inside [0,1]²")
        for label, items in (("problem", self.problems), ("feature", self.features), ("warning", self.warnings)):
            for kind, group in _by_kind(items).items():
                shown = group if limit is None else group[:limit]
                one = len({p["action"] for p in group}) == 1  # one action for the kind: said once, after its lines
                for p in shown:
                    lines.append(f"  {label}: {_describe(p)}" + ("" if one else f"\n           → {p['action']}"))
                if one:
                    lines.append(f"           → {group[0]['action']}")
                if len(group) > len(shown):
                    lines.append(f"  … and {len(group) - len(shown):,} more {label}s of this kind ({kind}; "
                                 f"--all or --json lists every one)")
        counts = "; ".join(f"{k} {len(g):,}" for k, g in _by_kind(self.problems).items())
        lines.append(f"summary: {len(self.problems):,} problem{'s' * (len(self.problems) != 1)}"
                     + (f" ({counts})" if counts else "")
                     + (f", {len(self.features):,} intentional feature{'s' * (len(self.features) != 1)} (kept)"
                        if self.features else "")
                     + f", {len(self.warnings):,} warning{'s' * (len(self.warnings) != 1)}"
                     + ("; nothing to repair" if self.ok else "; `neuraluv repair` fixes the problems"))
        return "\n".join(lines)


def _by_kind(items):
    """Items grouped by their ``kind``, in order of first appearance."""
    out = {}
    for p in items:
        out.setdefault(p.get("kind", "other"), []).append(p)
    return out


def _describe(p):
    where = p.get("where", {})
    loc = ""
    if where.get("centroid") is not None:
        c = where["centroid"]
        loc = f" near 3D ({c[0]:.3g}, {c[1]:.3g}, {c[2]:.3g})"
    if where.get("uv_box") is not None:
        (a, b), (c, d) = where["uv_box"]
        loc += f", UV [{a:.3f}, {b:.3f}]–[{c:.3f}, {d:.3f}]"
    isl = p.get("islands", [])
    many = f"islands {', '.join(map(str, isl[:8]))}" + (f", … ({len(isl):,} in all)" if len(isl) > 8 else "")
    who = f"island {p['island']}" if "island" in p else (many if "islands" in p else "")
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


def diagnose_layout(V, F, UV, FUV=None, *, resolution=1024, padding=2.0, facts=None, purpose="bake", min_defect=0.0):
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
    facts : :class:`~neuraluv.layout.facts.LayoutFacts`, optional
        Already computed (of the same layout; its ``min_overlap`` is the tolerance then).
    min_defect : float
        Texels (of area) at ``resolution``: an island's overlap with itself, or two islands' overlap, smaller
        than this in all cannot show in the texture and is a warning (left alone), not a problem; 0: exact.
    purpose : {"bake", "lightmap", "texture"}
        What the layout is for (:mod:`~neuraluv.layout.purpose`): ``bake`` / ``lightmap`` judge by
        a bake's rules (unique, unmirrored, in ``[0,1]²``); ``texture`` reports mirrored, stacked,
        tiled and palette shells as intentional features and only folds, UV-degenerate faces
        inside a shell and missing / non-finite UVs as problems. ``ok`` is the
        :func:`~neuraluv.layout.validate.validate_facts` verdict of the same purpose (padding aside).

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
    purpose = check_purpose(purpose)
    F = np.asarray(F, np.int64)
    FUV = F if FUV is None else np.asarray(FUV, np.int64)
    f = facts if facts is not None else layout_facts(V, F, UV, FUV, min_overlap=defect_area(min_defect, resolution))
    V = np.asarray(V, float)
    UVf = f.UV
    FU = f.FUV
    problems, warnings = [], []
    args = (V, F, UVf, FU)
    if purpose == "texture":
        return _diagnose_texture(f, V, F, resolution, padding)
    problems = _lost_faces(f, args)
    ii, jj, area = f.overlaps()
    li, lj = f.label[ii], f.label[jj]
    same = li == lj
    islands = []
    med = f.median_density
    small = f.small_folds(f.bad)  # folds no texture shows at the tolerance: warnings below, not problems
    for i in range(f.n_islands):
        fi = f.island_faces(i)
        d = f.det[fi]
        rows = np.unique(FU[fi])
        pts = UVf[rows]
        lo, hi = pts.min(0), pts.max(0)
        d3 = f.degenerate3d[fi]
        flipped = fi[(d < 0) & ~d3 & ~small[fi]]
        degen = fi[f.bad[fi] & ~(d < 0) & ~d3]  # det J 0, or positive by rounding alone (uv_degenerate)
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
    val = validate_facts(f, padding=padding, resolution=resolution)
    if val["padding_violations"]:
        warnings.append({"kind": "padding", "message": f"{val['padding_violations']} island pairs closer than "
                         f"{padding:g} texels at {resolution} px (closest {val['min_gap_texels']})",
                         "action": "left as is for islands repair does not move; moved and new islands keep the padding"})
    _small_fold_warnings(warnings, f, small, args, resolution)
    for ov in f.ignored_overlaps():
        texels = ov["area"] * float(resolution) ** 2
        what = (f"island {ov['islands'][0]} overlaps itself" if len(ov["islands"]) == 1 else
                f"islands {ov['islands'][0]} and {ov['islands'][1]} overlap")
        warnings.append({"kind": "subtexel_overlap", "message": f"{what} by {texels:.2g} texels at {resolution} px "
                         f"(UV area {ov['area']:.2g}), below the {f.min_overlap * float(resolution) ** 2:g}-texel "
                         "tolerance", "action": "left as is: no texture at this resolution shows it", "overlap_islands": ov["islands"],
                         "area": ov["area"]})
    if f.degenerate3d.any():
        warnings.append({"kind": "zero_area_faces", "message": f"{int(f.degenerate3d.sum()):,} faces have no 3D area "
                         "(distortion is undefined there)", "action": "their UVs are left as they are"})
    dens = [x for x in f.density if np.isfinite(x)]
    if len(dens) > 1 and max(dens) > 2 * min(dens):
        warnings.append({"kind": "texel_density", "message": f"texel density varies {max(dens) / min(dens):.1f}× "
                         "between islands", "action": "left as is (repair keeps each island's density)"})
    return UVDiagnosis(faces=int(len(F)), islands=islands, problems=problems, warnings=warnings, validation=val,
                       resolution=int(resolution), padding=float(padding), purpose=purpose)


def _small_fold_warnings(warnings, f, small, args, resolution):
    """One warning per fold below the tolerance (:meth:`~neuraluv.layout.facts.LayoutFacts.small_folds`)."""
    if not small.any():
        return
    for cl in face_clusters(f.FUV, np.flatnonzero(small)):
        area = float(np.abs(f.signed_uv[cl]).sum())
        w = _problem("subtexel_fold", f"{len(cl):,} folded faces covering {area * float(resolution) ** 2:.2g} "
                     f"texels at {resolution} px, below the {f.min_overlap * float(resolution) ** 2:g}-texel "
                     "tolerance", "left as is: no texture at this resolution shows it", cl, *args,
                     island=int(f.label[cl[0]]))
        warnings.append(w)


def _lost_faces(f, args):
    """The problems of faces without usable UVs (every purpose)."""
    out = []
    if f.missing.any():
        out.append(_problem("missing_uv", f"{int(f.missing.sum()):,} faces without texture coordinates",
                            "give them new charts (solved, at the layout's median texel density, placed in free space)",
                            np.flatnonzero(f.missing), *args))
    if f.non_finite.any():
        out.append(_problem("non_finite_uv", f"{int(f.non_finite.sum()):,} faces with NaN or infinite texture coordinates",
                            "give them new charts (solved, at the layout's median texel density, placed in free space)",
                            np.flatnonzero(f.non_finite), *args))
    return out


def _tiles(lo, hi):
    """The unit tiles ``(i, j)`` an island's UV box covers."""
    a, b = np.floor(lo).astype(int), np.ceil(hi).astype(int) - 1
    b = np.maximum(a, b)
    return [(int(i), int(j)) for i in range(a[0], b[0] + 1) for j in range(a[1], b[1] + 1)]


def _diagnose_texture(f, V, F, resolution, padding):
    """:func:`diagnose_layout` under the ``texture`` purpose (see :mod:`~neuraluv.layout.purpose`)."""
    it = layout_intent(f)
    UVf, FU = f.UV, f.FUV
    args = (V, F, UVf, FU)
    problems = _lost_faces(f, args)
    features, warnings, islands = [], [], []
    bad = it.fold | it.degenerate
    # which oriented faces overlap, without their shared areas (a stacked layout has many pairs; here they
    # only name the islands that share texels)
    ii, jj = overlap_pairs(f.UV, f.FUV, np.flatnonzero(f.oriented))
    li, lj = f.label[ii], f.label[jj]
    tiles_of = {}
    # every island's box and counts in one pass over the faces (a real asset may have thousands of islands)
    n, u = f.n_islands, np.flatnonzero(f.usable)
    lab = f.label[u]
    lo, hi = np.full((n, 2), np.inf), np.full((n, 2), -np.inf)
    corner_lab, corner_uv = np.repeat(lab, FU.shape[1]), UVf[FU[u].reshape(-1)]
    np.minimum.at(lo, corner_lab, corner_uv)
    np.maximum.at(hi, corner_lab, corner_uv)
    count = {k: np.bincount(lab[w[u]], minlength=n) for k, w in
             (("mirrored_faces", it.mirrored_shell), ("folded", it.fold), ("degenerate", it.degenerate),
              ("palette", it.palette), ("bad", bad))}
    count["faces"] = np.bincount(lab, minlength=n)
    has_shell = it.shell[u] >= 0
    shells = np.bincount(unique_rows(np.c_[lab[has_shell], it.shell[u][has_shell]])[:, 0], minlength=n)
    for i in range(n):
        outside = bool(lo[i].min() < 0.0 or hi[i].max() > 1.0)
        dens = f.density[i]
        islands.append({"island": i, "faces": int(count["faces"][i]), "uv_box": [lo[i].tolist(), hi[i].tolist()],
                        "texel_density": None if not np.isfinite(dens) else float(dens), "shells": int(shells[i]),
                        **{k: int(count[k][i]) for k in ("mirrored_faces", "folded", "degenerate", "palette")},
                        "outside_unit_square": outside})
        if outside:
            tiles_of[i] = _tiles(lo[i], hi[i])
        if not (count["bad"][i] or count["mirrored_faces"][i] or count["palette"][i]):
            continue
        fi = f.island_faces(i)
        mir = it.mirrored_shell[fi]
        b = fi[bad[fi]]
        if len(b):
            cl = face_clusters(FU, b)
            nf, nd = int(it.fold[fi].sum()), int(it.degenerate[fi].sum())
            what = " and ".join(x for x in ((f"{nf:,} folded" if nf else ""), (f"{nd:,} UV-degenerate" if nd else "")) if x)
            problems.append(_problem("folded_faces", f"{what} faces inside a shell, in {len(cl)} cluster"
                                     + ("s" if len(cl) != 1 else "") + f" (largest {len(cl[0]):,} faces)",
                                     ("put the rows moved off the island's planar projection back where it puts "
                                      "them (no solve); what stays folded: untangle it" if i in
                                      it.info.get("projections", ()) else "untangle each cluster")
                                     + " locally in its shell, growing rings until it is valid; every other UV stays "
                                     "bit-identical", b, *args, island=i,
                                     clusters=[len(c) for c in cl]))
        whole = bool(mir.sum() == (~f.degenerate3d[fi]).sum())
        if mir.any() and not whole and i in it.info.get("projections", ()):
            features.append(_problem("mirrored", f"island made by a planar projection: {int(mir.sum()):,} of "
                                     f"{len(fi):,} faces reversed in UV (its far side and concave parts, folded over "
                                     "onto the near side's texels)",
                                     "kept (each face lies where the projection puts it)", fi[mir], *args, island=i))
        elif mir.any():
            features.append(_problem("mirrored", ("island mirrored as a whole" if whole else "mirrored shell stacked in "
                                     "the island") + f": {int(mir.sum()):,} of {len(fi):,} faces reversed in UV",
                                     "kept (a mirrored copy or a reversed winding reads the texture mirrored, on purpose)",
                                     fi[mir], *args, island=i))
        pal = fi[it.palette[fi]]
        if len(pal):
            P = UVf[np.unique(FU[pal])]
            how = "one point" if np.ptp(P, axis=0).max() <= 1e-12 * max(1.0, np.abs(P).max()) else "a line"
            features.append(_problem("palette", f"{len(pal):,} faces collapsed to {how} (a palette or flat colour)",
                                     "kept", pal, *args, island=i))
    # islands sharing texels: connected groups of the island-overlap graph (stacked or overlapping on purpose)
    cross = li != lj
    if cross.any():
        _, comp = graph_components(n, li[cross], lj[cross])
        involved = np.unique(np.r_[li[cross], lj[cross]])
        for c in np.unique(comp[involved]):
            members = np.flatnonzero(comp == c)
            sel = cross & np.isin(li, members)
            features.append(_problem("shared_texels", f"{len(members)} islands share texels (stacked or overlapping, "
                                     f"{int(sel.sum()):,} triangle pairs)", "kept (they read the same part of the texture)",
                                     np.unique(np.r_[ii[sel], jj[sel]]), *args, islands=members.tolist()))
    same = (li == lj) & ~bad[ii] & ~bad[jj]
    for i in np.unique(li[same]):
        sel = same & (li == i)
        features.append(_problem("shared_texels", f"island overlaps itself outside its folds ({int(sel.sum()):,} "
                                 "triangle pairs)", "kept",
                                 np.unique(np.r_[ii[sel], jj[sel]]), *args, island=int(i)))
    if tiles_of:
        allt = sorted({t for ts in tiles_of.values() for t in ts})
        udim = all(0 <= a < 10 and b >= 0 for a, b in allt) and all(len(ts) == 1 for ts in tiles_of.values())
        names = ", ".join(str(1001 + a + 10 * b) for a, b in allt[:12]) if udim else \
            ", ".join(f"[{a}, {a + 1}]×[{b}, {b + 1}]" for a, b in allt[:6])
        many = sum(len(ts) > 1 for ts in tiles_of.values())
        faces = np.concatenate([f.island_faces(i) for i in tiles_of])
        features.append(_problem("tiles", f"{len(tiles_of):,} islands outside [0,1]²: "
                                 + (f"unit tiles {names} (UDIM numbering)" if udim else f"tiles {names}" + (" …" if len(allt) > 6 else ""))
                                 + (f"; {many} repeat across tiles" if many else ""),
                                 "kept (a repeating sampler or UDIM tiles read them)", faces, *args,
                                 islands=sorted(tiles_of)))
    if it.small_fold is not None:
        _small_fold_warnings(warnings, f, it.small_fold, args, resolution)
    if f.degenerate3d.any():
        warnings.append({"kind": "zero_area_faces", "message": f"{int(f.degenerate3d.sum()):,} faces have no 3D area "
                         "(distortion is undefined there)", "action": "their UVs are left as they are"})
    val = validate_facts(f, purpose="texture")
    return UVDiagnosis(faces=int(len(F)), islands=islands, problems=problems, warnings=warnings, validation=val,
                       resolution=int(resolution), padding=float(padding), purpose="texture", features=features)
