"""What a layout is for decides what is a problem: ``texture`` (an artist's layout) or ``bake`` / ``lightmap``.

A lightmap, or any layout that is baked into, needs every surface point on its
own texel: unique, unmirrored, inside ``[0,1]²``, padded. A **texture** layout
does not: artists mirror symmetric halves onto the same texels, stack identical
parts, repeat tiles outside the unit square or use UDIM tiles, and collapse
flat-coloured regions to one texel (a palette). Under ``texture`` those are
*intentional features*; the problems are what no purpose wants:

* **folds**: faces reversed among faces of the other orientation of the same
  shell, squashed or stretched unlike the shell around them;
* **UV-degenerate faces** (zero UV area) inside an otherwise regular shell;
* **missing** or **non-finite** texture coordinates.

:func:`layout_intent` reads this off a layout's :class:`~neuraluv.layout.facts.LayoutFacts`,
once, and ``check --uv``, repair and the read-back validation all ask it, so
they cannot disagree on the same file.

Definitions (on the unit-box mesh):

* a face is **UV-degenerate** when its UV area is at most ``1e-12`` of its
  longest UV edge squared (collapsed to a point or a line), else it is
  **positive** or **reversed** by the sign of det J; faces without 3D area
  take no part;
* a **sheet** is a maximal set of faces of one island joined through shared
  ``vt`` edges, all of one class (positive, reversed, degenerate);
* in each island the largest sheet of the island's orientation (by UV area;
  reversed in a mirrored island) is its main **shell**. Another sheet is a shell
  of its own when it shares no ``vt`` edge with a sheet of the other orientation
  (a piece joined at single vertices), when it is larger than every such
  neighbour (they are the folds; larger by UV area, unless the 3D areas differ by more
  than :data:`~neuraluv.layout.facts.SURFACE_FACTOR`), or when it is a **stacked copy** of the other
  orientation: at least :data:`STACKED_SHARE` of its UV area lies on faces of the
  other orientation at exactly the same three UV positions (a mirror modifier's
  copy), or it is a region (an interior ``vt`` row) mapped as regularly as the
  main shell (median conformal distortion and area scale within
  :data:`REGULAR_FACTOR`) that holds :data:`COPY_SHARE` of the main shell's UV
  area (and lies more on distant parts of the other orientation than on the
  faces within :data:`NEAR_RINGS` rings of it: a region pushed over its own
  neighbours is a fold) or meets the other orientation along a seam on the
  border of that orientation's image. Every other sheet is a **fold**: two
  triangles on either side of one edge in 3D lie on the same side of it in UV,
  so a sheet joined along edges to the other orientation folds over it. In an
  island with a stacked copy, two faces of one sheet on one ``vt`` edge that
  overlap are folds too (a fold next to the seam joins the other layer's
  sheet); and in an island of copies on the same ``vt`` rows at different
  places in 3D (a mirror modifier's halves, an array's copies), each copy is one
  **layer** (:func:`twin_layers`), and a face against its layer's orientation is
  a fold of its layer's shell (a fold on shared rows flips a face and its twin
  at once, and each joins the other copy's sheet); in an island made by a planar
  projection (:mod:`~neuraluv.layout.projection`) the projection says it: a face
  against the orientation it gives is a fold, its far side, concave parts and
  silhouette slivers are not;
* a sheet of two or more faces whose UV points lie thinner than
  :data:`LINE_ASPECT` of their length is a **palette collapse** along a line; a
  sheet of UV-degenerate faces is one when its island has no other faces or it
  has an interior ``vt`` row (one all of whose faces are in the sheet: a region
  was collapsed, not one face); otherwise its faces are **degenerate faces**
  inside a shell (a problem).

Limits, measured (``data_scripts/purpose_fold_recall.py``): on 114 layouts damaged by
``neuraluv_paper.damage`` (local folds and vertex noise on eight real assets), 0.7% (20 of
2,826) of the faces the damage reversed are taken for intent: 0–2.5% on seven of the eight
(Blender's mirrored Suzanne among them: 37.5% before the twin layers; Duck, a side projection:
38.1% before the projection was read, 21.9% while its silhouette was left to the sheets, 0.0%
now) and 18.2% (2 of 11) on tube.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from neuraluv.layout import PURPOSES
from neuraluv.layout.facts import DEGENERATE_UV, holds_more, within_rings
from neuraluv.layout.overlap import overlap_pairs, points_in_triangles
from neuraluv.layout.projection import projection_folds
from neuraluv.topology import faces_sharing, undirected_edges

__all__ = ["PURPOSES", "STACKED_SHARE", "DEGENERATE_UV", "LayoutIntent", "layout_intent", "twin_layers",
           "default_purpose", "check_purpose"]

#: A sheet of the other orientation joined to its island along ``vt`` edges is a stacked copy (intentional),
#: not a fold, when at least this share of its UV area lies on faces of the other orientation with exactly
#: the same three UV positions (a mirror modifier's copy on the same texels).
STACKED_SHARE = 0.9

#: A stacked copy that is not exact must be this regular: its median conformal distortion and area scale
#: within this factor of its island's main shell (:func:`_stacked_copies`).
REGULAR_FACTOR = 2.0

#: An inexact stacked copy without a border seam must hold at least this share of its main shell's UV area.
COPY_SHARE = 0.1

#: Rings around a stacked copy candidate within which the faces it lies on are its own neighbours (a fold pushed
#: over them), not the part it copies (:func:`_stacked_copies`).
NEAR_RINGS = 3

#: Copies on the same ``vt`` rows whose 3D centroids lie further apart than this (unit-box units) are copies at
#: different places (a mirror modifier's halves, an array's), not a double-sided face and its back.
TWIN_APART = 1e-9

#: A sheet whose UV points are thinner than this share of their length is collapsed along a line (a palette).
LINE_ASPECT = 1e-3


def check_purpose(purpose):
    """The purpose's canonical name, or ``ValueError`` naming the choices.

    Examples
    --------
    >>> check_purpose("Lightmap")
    'lightmap'
    """
    p = str(purpose).lower()
    if p not in PURPOSES:
        raise ValueError(f"unknown purpose {purpose!r}: choose one of {', '.join(PURPOSES)}")
    return p


def default_purpose(materials=0, textures=0):
    """The purpose a layout gets when none is asked for, and why (one line).

    Always ``texture``: a layout that arrives with materials or textures is
    certainly read by a texture, and a bare one (an OBJ exported without its
    material file) may well be; ``texture`` calls only what no purpose wants a
    problem, so it changes the least. A layout to bake into is asked for with
    ``bake`` / ``lightmap``.

    Examples
    --------
    >>> default_purpose(materials=1)
    ('texture', 'the file references 1 material')
    >>> default_purpose()[0]
    'texture'
    """
    if materials or textures:
        what = f"{textures} texture{'s' * (textures != 1)}" if textures else \
            f"{materials} material{'s' * (materials != 1)}"
        return "texture", f"the file references {what}"
    return "texture", "no material or texture referenced, but texture changes the least"


@dataclass
class LayoutIntent:
    """What :func:`layout_intent` reads off a layout under the ``texture`` purpose (arrays over faces).

    Attributes
    ----------
    sheet : (m,) int array, sheet of each face (-1: unusable or without 3D area).
    face_class : (m,) int8 array, 1 positive, -1 reversed, 0 UV-degenerate (0 also for faces that take no part).
    shell : (m,) int array, the shell a face belongs to (a fold or degenerate face: the shell it lies in;
        -1: unusable, no 3D area, or a palette collapse).
    shell_sign : (k,) int array, orientation of each shell (1 or -1).
    shell_island : (k,) int array, island of each shell.
    fold : (m,) bool array, faces of folds (problems).
    small_fold : (m,) bool array, faces of folds smaller than the facts' tolerance
        (:meth:`~neuraluv.layout.facts.LayoutFacts.small_folds`: noted, left alone).
    degenerate : (m,) bool array, UV-degenerate faces inside a shell (problems).
    palette : (m,) bool array, faces of palette collapses (intentional).
    mirrored_shell : (m,) bool array, faces of shells reversed in UV (intentional under ``texture``).
    """

    sheet: np.ndarray
    face_class: np.ndarray
    shell: np.ndarray
    shell_sign: np.ndarray
    shell_island: np.ndarray
    fold: np.ndarray
    degenerate: np.ndarray
    palette: np.ndarray
    mirrored_shell: np.ndarray
    info: dict = field(default_factory=dict)
    small_fold: np.ndarray = None

    def shell_faces(self, k):
        """Face indices of shell ``k`` (its folds and degenerate faces included)."""
        return np.flatnonzero(self.shell == k)


def _face_classes(facts):
    """Per face: 1 positive, -1 reversed, 0 UV-degenerate; and which faces take part (usable, with 3D area)."""
    part = facts.usable & ~facts.degenerate3d
    cls = np.zeros(len(facts.F), np.int8)
    if not part.any():
        return cls, part
    idx = np.flatnonzero(part)
    cls[idx] = np.where(facts.collapsed[idx], 0, np.sign(facts.det[idx])).astype(np.int8)
    return cls, part


def _sheets(facts, cls, part):
    """Label faces by sheet: joined through a shared ``vt`` edge with the same class (-1 where not taking part)."""
    idx = np.flatnonzero(part)
    sheet = -np.ones(len(facts.F), np.int64)
    if not len(idx):
        return 0, sheet
    _, e = undirected_edges(facts.FUV[idx])
    c = np.tile(cls[idx].astype(np.int64), 3)
    n, lab = faces_sharing(np.column_stack([e, c]), np.tile(np.arange(len(idx)), 3), len(idx))
    sheet[idx] = lab
    return n, sheet


def _interior_sheets(facts, sheet, n_sheets):
    """(n_sheets,) bool: sheets with a ``vt`` row all of whose faces are in the sheet (an interior row).

    Usable faces that take part in no sheet (no 3D area) count as sheets of their own, so a row they
    touch is interior to nothing.
    """
    use = np.flatnonzero(facts.usable)
    sid = np.where(sheet[use] >= 0, sheet[use], n_sheets + use)
    pairs = np.unique(np.column_stack([facts.FUV[use].reshape(-1), np.repeat(sid, 3)]), axis=0)
    rows, count = np.unique(pairs[:, 0], return_counts=True)
    alone = pairs[np.isin(pairs[:, 0], rows[count == 1]), 1]
    out = np.zeros(n_sheets, bool)
    out[alone[alone < n_sheets]] = True
    return out


def layout_intent(facts, *, stacked_share=STACKED_SHARE):
    """Shells, folds, degenerate faces, palette collapses and mirrored shells of a layout under the ``texture``
    purpose (see the module docstring). A bake's rules need no such reading: every face against its island's
    orientation is broken there (:func:`~neuraluv.layout.validate.validate_facts`).

    Parameters
    ----------
    facts : :class:`~neuraluv.layout.facts.LayoutFacts`
    stacked_share : float
        Share of a sheet's UV area that must lie exactly on faces of the other orientation for the sheet to
        be a stacked copy rather than a fold.

    Returns
    -------
    LayoutIntent (cached on ``facts``)

    Examples
    --------
    A strip whose left half is mapped onto the right half's texels, reversed (a mirror modifier's
    copy on the same texels; the halves share the middle column's ``vt`` rows), then a fold made by
    pushing one vertex of an unmirrored strip over its neighbours:

    >>> from neuraluv.layout.facts import layout_facts
    >>> x, y = np.meshgrid(np.arange(-4.0, 5.0), np.arange(3.0))
    >>> V = np.c_[x.ravel(), y.ravel(), 0 * x.ravel()]
    >>> q = np.array([[i + 9 * j, i + 1 + 9 * j, i + 10 + 9 * j, i + 9 + 9 * j] for j in range(2) for i in range(8)])
    >>> F = np.r_[q[:, [0, 1, 2]], q[:, [0, 2, 3]]]
    >>> it = layout_intent(layout_facts(V, F, np.c_[np.abs(V[:, 0]), V[:, 1]] / 4, F))
    >>> int(it.fold.sum()), int(it.mirrored_shell.sum()), len(it.shell_sign)
    (0, 16, 2)
    >>> bad = V[:, :2] / 8 + 0.5; bad[14] += [0.3, 0.0]
    >>> it = layout_intent(layout_facts(V, F, bad, F))
    >>> int(it.fold.sum()), int(it.mirrored_shell.sum())
    (2, 0)
    """
    key = ("intent", float(stacked_share))
    if key in facts._cache:
        return facts._cache[key]
    m = len(facts.F)
    cls, part = _face_classes(facts)
    n_sheets, sheet = _sheets(facts, cls, part)
    fold = np.zeros(m, bool)
    degenerate = np.zeros(m, bool)
    palette = np.zeros(m, bool)
    mirrored_shell = np.zeros(m, bool)
    shell = -np.ones(m, np.int64)
    idx = np.flatnonzero(part)
    s_lab = sheet[idx]
    s_island = np.zeros(n_sheets, np.int64)
    s_island[s_lab] = facts.label[idx]
    s_cls = np.zeros(n_sheets, np.int64)
    s_cls[s_lab] = cls[idx]
    s_area = np.bincount(s_lab, weights=np.abs(np.nan_to_num(facts.signed_uv[idx])), minlength=n_sheets)
    s_faces = np.bincount(s_lab, minlength=n_sheets)  # faces per sheet (a line needs two)
    # a sheet touching a face of the other orientation along a vt edge overlaps it there (two triangles on
    # opposite sides of one edge in 3D lie on the same side of it in UV): a fold, unless it is a stacked copy
    na, nb = _edge_neighbours(facts.FUV, idx, s_lab, cls[idx], n_sheets)
    s_edge = np.zeros(n_sheets, bool)
    s_edge[na] = True
    # the largest sheet of the other orientation each sheet shares an edge with: a sheet larger than every
    # such neighbour is a part of its own (they are the folds), whatever its orientation
    # (by UV area, unless the 3D areas differ by more than SURFACE_FACTOR: a flung vertex's stretched face is
    # no part of its own)
    s_area3 = np.bincount(s_lab, weights=facts.area3d[idx], minlength=n_sheets)
    dominant = s_area > 0
    dominant[na[~holds_more(s_area[na], s_area[nb], s_area3[na], s_area3[nb])]] = False
    twin_area = np.bincount(s_lab, weights=np.where(_twins(facts.UV, facts.FUV, idx, cls[idx], facts.label[idx]),
                                                    np.abs(np.nan_to_num(facts.signed_uv[idx])), 0.0),
                            minlength=n_sheets)
    has_interior = _interior_sheets(facts, sheet, n_sheets)
    faces_of = _group(idx, s_lab, n_sheets)
    line = np.array([s_faces[k] > 1 and _on_a_line(facts.UV[facts.FUV[faces_of[k]]]) for k in range(n_sheets)], bool)
    maybe = np.flatnonzero((s_cls != 0) & s_edge & ~dominant & ~line & (twin_area < stacked_share * s_area))
    main_of = {}
    for k in range(n_sheets):
        i = int(s_island[k])
        if s_cls[k] == (-1 if facts.mirrored[i] else 1) and (i not in main_of or s_area[k] > s_area[main_of[i]]):
            main_of[i] = k
    copies = _stacked_copies(facts, maybe, faces_of, s_island, s_cls, s_area, main_of, has_interior) \
        if len(maybe) else set()
    role = np.zeros(n_sheets, np.int64)  # 1 shell, 2 fold, 3 degenerate problem, 4 palette
    host = -np.ones(n_sheets, np.int64)
    by_island = {}
    for k in range(n_sheets):
        by_island.setdefault(int(s_island[k]), []).append(k)
    for i, ks in by_island.items():
        ks = np.asarray(ks)
        if i not in main_of:  # no face of the island's orientation: all degenerate
            role[ks] = 4  # the whole island collapsed: a palette
            continue
        main = main_of[i]
        for k in ks:
            if k == main:
                role[k] = 1
            elif s_cls[k] == 0:
                role[k] = 4 if has_interior[k] else 3
            elif line[k]:
                role[k] = 4  # a region collapsed along a line
            elif not s_edge[k] or dominant[k] or twin_area[k] >= stacked_share * s_area[k]:
                role[k] = 1  # joined at vertices only, larger than the folds around it, or an exactly stacked copy
            else:
                role[k] = 2 if k not in copies else 1
        # every fold or degenerate sheet lies in the shell it shares the most vt edges with (else the main one)
        shells_i = ks[role[ks] == 1]
        for k in ks[(role[ks] == 2) | (role[ks] == 3)]:
            host[k] = _host(facts.FUV, faces_of, k, shells_i, main)
    # in an island with a stacked copy joined along a seam, a fold next to the seam joins the other layer's
    # sheet (and twins that share their vt rows fold together, staying twins): it shows as two faces of one
    # sheet on one vt edge lying over each other, which no unfolded sheet has
    twin_isl = np.unique(s_island[(role == 1) & s_edge & ~np.isin(np.arange(n_sheets), list(main_of.values()))])
    if len(twin_isl):
        cand = idx[np.isin(facts.label[idx], twin_isl) & (cls[idx] != 0)]
        for c in (-1, 1):
            fc = cand[cls[cand] == c]
            a, b = overlap_pairs(facts.UV, facts.FUV, fc)
            # two faces of one class on one vt edge lie on opposite sides of it unless one is folded over (two on
            # all three rows are twins, copies stacked on purpose: an array modifier's copies share their rows)
            near = ((facts.FUV[a][:, :, None] == facts.FUV[b][:, None, :]).any(2).sum(1) == 2) & (sheet[a] == sheet[b])
            pleat = np.unique(np.r_[a[near], b[near]])
            fold[pleat] = True
    shell_of_sheet = -np.ones(n_sheets, np.int64)
    shells = np.flatnonzero(role == 1)
    shell_of_sheet[shells] = np.arange(len(shells))
    for k in np.flatnonzero((role == 2) | (role == 3)):
        shell_of_sheet[k] = shell_of_sheet[host[k]]
    shell[idx] = shell_of_sheet[s_lab]
    fold[idx] |= role[s_lab] == 2
    # copies on the same rows at different places in 3D (a mirror modifier's halves, an array's copies): a fold on
    # rows they share flips a face and its twin at once, and each joins the other copy's sheet; by the surface
    # each copy is one layer, and a face against its layer's orientation is a fold, of its layer's shell
    _layer_folds(facts, cls, idx, shell, fold)
    # an island made by a planar projection: the projection says which reversed faces are folds
    sliver = np.zeros(len(facts.F), bool)  # a projection's silhouette slivers collapsed by rounding: its own
    projected = projection_folds(facts, cls, shell, s_cls[shells], s_island[shells], fold, sliver)
    small_fold = facts.small_folds(fold)  # folds no texture at the resolution shows: noted, left alone
    fold &= ~small_fold
    degenerate[idx] = (role[s_lab] == 3) & ~sliver[idx]
    palette[idx] = role[s_lab] == 4
    shell_sign = s_cls[shells]
    mirrored_shell[idx] = (role[s_lab] == 1) & (s_cls[s_lab] == -1) & ~(fold | small_fold)[idx]
    it = LayoutIntent(sheet, cls, shell, shell_sign.astype(np.int64), s_island[shells], fold, degenerate,
                      palette, mirrored_shell, info={"sheets": int(n_sheets), "projections": projected},
                      small_fold=small_fold)
    facts._cache[key] = it
    return it


def twin_layers(F, FUV, faces):
    """The layers of an island whose stacked halves share ``vt`` rows: its faces joined through edges shared in
    3D *and* in UV, never a face to its twin (a face with the same three ``vt`` rows).

    A mirror modifier's halves that share their rows are one island, and a fold on the shared rows folds both
    halves at once: each half's folded faces then lie, by orientation, in the other half's sheet. A half is
    still what the surface joins: its faces meet along 3D edges, and where the halves meet (the mirror plane)
    the face across the edge is the twin.

    Parameters
    ----------
    F, FUV : (m,3) int arrays
    faces : (k,) int array, the island's faces

    Returns
    -------
    layer : (k,) int array, the layer of each face of ``faces``
    twin : (k,) int array, per face the index (into ``faces``) of a twin, -1 where none
    """
    faces = np.asarray(faces, np.int64)
    key = (faces.tobytes(), np.asarray(F)[faces].tobytes(), np.asarray(FUV)[faces].tobytes())
    if key not in _LAYERS:  # read once per island and texture indices: every fold of the island asks again
        if len(_LAYERS) >= 8:
            _LAYERS.pop(next(iter(_LAYERS)))
        _LAYERS[key] = tuple(a.setflags(write=False) or a for a in _twin_layers(F, FUV, faces))
    return _LAYERS[key]


_LAYERS = {}  # twin_layers' last results, by (faces, their F rows, their FUV rows)


def _twin_layers(F, FUV, faces):
    k = len(faces)
    T = np.sort(np.asarray(FUV)[faces], 1)
    _, group = np.unique(T, axis=0, return_inverse=True)
    group = group.reshape(-1)
    twin = -np.ones(k, np.int64)
    order = np.argsort(group, kind="stable")
    pair = group[order[1:]] == group[order[:-1]]
    twin[order[1:][pair]], twin[order[:-1][pair]] = order[:-1][pair], order[1:][pair]
    e3, eu = undirected_edges(np.asarray(F)[faces])[1], undirected_edges(np.asarray(FUV)[faces])[1]
    _, key = np.unique(np.c_[e3, eu], axis=0, return_inverse=True)
    key = key.reshape(-1)
    fid = np.tile(np.arange(k), 3)
    order = np.argsort(key, kind="stable")
    same = key[order[1:]] == key[order[:-1]]
    a, b = fid[order[:-1][same]], fid[order[1:][same]]
    keep = group[a] != group[b]
    A = sp.coo_matrix((np.ones(int(keep.sum())), (a[keep], b[keep])), shape=(k, k))
    return connected_components(A, directed=False)[1], twin


def _layer_folds(facts, cls, idx, shell, fold):
    """Mark (in place) the faces against their twin layer's orientation as folds of their layer's shell (faces
    that are folds already keep theirs).

    Only islands with copies on the same ``vt`` rows at different places in 3D (:func:`twin_layers`; a
    double-sided face and its back coincide in 3D and are no such copy). A layer's orientation is the one
    holding more of it (:func:`~neuraluv.layout.facts.holds_more`); its shell, the one most of its faces of
    that orientation lie in.
    """
    use = idx[cls[idx] != 0]
    if not len(use):
        return
    _, inv = np.unique(np.c_[np.sort(facts.FUV[use], 1), facts.label[use]], axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    c = facts.Vn[facts.F[use]].mean(1)
    lo = np.full((int(inv.max()) + 1, 3), np.inf)
    hi = -lo
    np.minimum.at(lo, inv, c)
    np.maximum.at(hi, inv, c)
    apart = (hi - lo).max(1)[inv] > TWIN_APART
    a2, a3 = np.abs(np.nan_to_num(facts.signed_uv)), facts.area3d
    taking = np.zeros(len(facts.F), bool)
    taking[use] = True
    for i in np.unique(facts.label[use[apart]]):
        faces = facts.island_faces(i)
        faces = faces[taking[faces]]
        layer, _ = twin_layers(facts.F, facts.FUV, faces)
        for lay in np.unique(layer):
            m = faces[layer == lay]
            pos, neg = m[cls[m] > 0], m[cls[m] < 0]
            if not len(pos) or not len(neg):
                continue
            against, along = (pos, neg) if holds_more(a2[neg].sum(), a2[pos].sum(), a3[neg].sum(),
                                                      a3[pos].sum()) else (neg, pos)
            hosts = shell[along][shell[along] >= 0]
            new = against[~fold[against]]  # folds read off the sheets keep the shell they were given
            if len(hosts) and len(new):
                fold[new] = True
                shell[new] = np.bincount(hosts).argmax()


def _on_a_line(P, rel=LINE_ASPECT):
    """Whether the UV points ``P (..., 2)`` lie along a line: thinner than ``rel`` of their length."""
    P = np.asarray(P, float).reshape(-1, 2)
    sv = np.linalg.svd(P - P.mean(0), compute_uv=False)
    return bool(sv[0] > 0 and sv[-1] <= rel * sv[0])


def _stacked_copies(facts, sheets, faces_of, s_island, s_cls, s_area, main_of, has_interior, *,
                    regular=REGULAR_FACTOR, share=COPY_SHARE, rings=NEAR_RINGS):
    """Sheets (of ``sheets``) that are stacked copies by their shape, though not exact twins.

    A copy is a region mapped as regularly as the shell it lies on: it has an interior ``vt`` row, its
    median conformal distortion and median area scale are within a factor ``regular`` of its island's
    main shell, and it is a part of the island of its own — at least ``share`` of the main shell's UV
    area, and lying more on distant parts of the other orientation than on the faces within ``rings``
    rings of it, or meeting the other orientation along a seam on the border of that orientation's image
    (just beyond at least half of the shared edges, away from both faces, lies no face of the other
    orientation). A fold is squashed, or lies on its own neighbours (a region pushed over the faces next
    to it: as regular as a mirrored copy, but a copy lies on the part it copies), or is small and a pleat
    inside the image.
    """
    from neuraluv.metrics import corner_jacobians, face_metrics

    out = set()
    UV, FUV = facts.UV, facts.FUV
    for k in sheets:
        if not has_interior[k]:
            continue
        fk = faces_of[k]
        main = faces_of[main_of[s_island[k]]]
        both = np.r_[fk, main]
        fm = face_metrics(corner_jacobians(facts.Vn, facts.F[both], UV, FUV[both])[0])
        conf, det = fm["conformal"], np.abs(fm["det"])
        ck, cm = np.nanmedian(conf[:len(fk)]), np.nanmedian(conf[len(fk):])
        ak, am = np.nanmedian(det[:len(fk)]), np.nanmedian(det[len(fk):])
        if not (ck <= regular * max(cm, 1.0) and am / regular <= ak <= regular * am):
            continue
        isl = facts.island_faces(s_island[k])
        other = isl[~facts.degenerate3d[isl] & (facts.det[isl] * s_cls[k] < 0)]
        if s_area[k] >= share * s_area[main_of[s_island[k]]]:
            if not _lies_on_its_neighbours(facts, fk, other, isl, rings):
                out.add(int(k))
            continue
        T = FUV[fk]
        E = np.stack([T[:, [0, 1, 2]], T[:, [1, 2, 0]], T[:, [2, 0, 1]]], 1).reshape(-1, 3)
        _, Eo = undirected_edges(FUV[other])
        key = np.sort(E[:, :2], 1)
        n = len(UV) + 1
        E = E[np.isin(key[:, 0] * n + key[:, 1], Eo[:, 0] * n + Eo[:, 1])]
        if not len(E):
            continue
        a, b, c = UV[E[:, 0]], UV[E[:, 1]], UV[E[:, 2]]
        mid = 0.5 * (a + b)
        nrm = np.c_[a[:, 1] - b[:, 1], b[:, 0] - a[:, 0]]
        probe = mid + np.sign(((mid - c) * nrm).sum(1))[:, None] * nrm * 1e-4
        beyond = np.zeros(len(probe), bool)
        beyond[points_in_triangles(probe, UV[FUV[other]])[0]] = True
        if beyond.mean() <= 0.5:
            out.add(int(k))
    return out


def _lies_on_its_neighbours(facts, fk, other, isl, rings):
    """Whether faces ``fk`` overlap faces of ``other`` within ``rings`` rings of them (through the island
    ``isl``'s rows) over more UV area than they overlap the rest of ``other``."""
    a, b, area = overlap_pairs(facts.UV, facts.FUV, np.r_[fk, other], fk, areas=True)
    mine = np.isin(a, fk)
    i, j = np.where(mine, a, b), np.where(mine, b, a)
    keep = np.isin(i, fk) & np.isin(j, other)
    if not keep.any():
        return False
    near = within_rings(facts.FUV, isl, i[keep], j[keep], rings)
    return bool(area[keep][near].sum() > area[keep][~near].sum())


def _group(idx, lab, n):
    """``idx`` split by ``lab`` (0..n-1): a list of n arrays."""
    order = np.argsort(lab, kind="stable")
    bounds = np.searchsorted(lab[order], np.arange(n + 1))
    return [idx[order[bounds[k]:bounds[k + 1]]] for k in range(n)]


def _edge_neighbours(FUV, idx, lab, cls, n):
    """Pairs of sheets of opposite (non-degenerate) classes that share a ``vt`` edge: ``(a, b)`` int arrays."""
    import scipy.sparse as sp

    _, e = undirected_edges(FUV[idx])
    _, inv = np.unique(e, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    s = np.tile(lab, 3)
    c = np.tile(cls, 3)
    n_e = int(inv.max()) + 1 if len(inv) else 0
    pos = sp.csr_matrix((np.ones(int((c == 1).sum())), (inv[c == 1], s[c == 1])), shape=(n_e, n))
    neg = sp.csr_matrix((np.ones(int((c == -1).sum())), (inv[c == -1], s[c == -1])), shape=(n_e, n))
    a, b = (pos.T @ neg).nonzero()
    return np.r_[a, b].astype(np.int64), np.r_[b, a].astype(np.int64)


def _twins(UV, FUV, idx, cls, label):
    """(len(idx),) bool: faces with a face of the opposite orientation in the same island at exactly the same
    three UV positions (a stacked, mirrored copy: a mirror modifier's halves on the same texels)."""
    P = UV[FUV[idx]]  # (k,3,2)
    order = np.lexsort((P[:, :, 1], P[:, :, 0]), axis=1)
    P = np.take_along_axis(P, order[:, :, None], axis=1).reshape(len(idx), 6)
    key = np.column_stack([P.view(np.int64), label])
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    n = inv.max() + 1 if len(inv) else 0
    pos = np.zeros(n, bool)
    neg = np.zeros(n, bool)
    pos[inv[cls == 1]] = True
    neg[inv[cls == -1]] = True
    return np.where(cls == 1, neg[inv], np.where(cls == -1, pos[inv], False))


def _host(FUV, faces_of, k, shells, main):
    """The shell (sheet index) among ``shells`` sharing the most ``vt`` rows with sheet ``k`` (``main`` if none)."""
    rows = np.unique(FUV[faces_of[k]])
    best, best_n = main, 0
    for s in shells:
        n = len(np.intersect1d(rows, FUV[faces_of[s]]))
        if n > best_n:
            best, best_n = int(s), n
    return best
