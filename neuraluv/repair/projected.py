"""Folds in an island made by a planar projection, put back where the projection puts them.

An island made by a planar projection (:mod:`~neuraluv.layout.projection`) says where each of its rows
belongs: ``[p, 1] @ A`` of its corners' 3D positions ``p``. A fold on it (rows moved off it, faces
turned against the orientation it gives them) is mended exactly by moving those rows back: the author's
own map, with no solve and no region to choose. Along the projection's silhouette, where its near and
far sides meet on shared rows, this is the one repair that keeps both sides' orientation; a local
untangle must pick one.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from neuraluv.layout.facts import layout_facts
from neuraluv.layout.projection import PROJECTION_FIT, island_projection
from neuraluv.layout.purpose import layout_intent

__all__ = ["onto_projections"]


def onto_projections(Vn, F, UV, FUV, facts, actions, *, written=None):
    """Move the rows of each projection island's folds that lie off its projection back onto it.

    In each island :func:`~neuraluv.layout.purpose.layout_intent` reads as a planar projection, the rows of
    its folded or UV-degenerate faces (folds too small for a texture to show too) that lie off the
    projection, with the rows off it joined to them through the island's edges (the patch a damage moved),
    go to where the projection puts their corners (a row whose corners the projection puts in different
    places stays). An island's move is kept only if,
    read again, it has fewer problem faces and no new one; else it is undone.

    Parameters
    ----------
    Vn : (n,3) float array, the normalised positions ``facts`` was read on
    F : (m,3) int array
    UV : (p,2) float array (not changed), the layout of ``facts`` or a copy whose rows ``FUV`` joins
    FUV : (m,3) int array, ``facts.FUV`` or the rows each of its rows moves with
        (:func:`~neuraluv.layout.facts.coincident_rows`): the rows moved
    facts : LayoutFacts of the layout as written
    actions : dict, island -> list of action dicts (appended to)
    written : callable, optional
        ``written(UV)``: the LayoutFacts of a working layout on ``FUV`` as it will be written (repair_layout's,
        which joins rows that are one point of the map); default: ``UV`` read on ``FUV`` as it is (then ``FUV``
        must be ``facts.FUV``)

    Returns
    -------
    UV : (p,2) float array, facts : LayoutFacts of it as written (``written(UV)``); ``UV, facts`` themselves when
    nothing moved

    Notes
    -----
    The projection is the affine fit ``U ≈ [P, 1] A`` of
    :func:`~neuraluv.layout.projection.projection_axes`; a row ``r`` moved back takes the mean of
    ``[p_c, 1] A`` over its corners ``c`` (for quantized UVs, rounded to their grid), or, where another row
    of the island that sits on the projection has a corner at the same 3D point (a vertex split for its
    normals), that row's UV bit for bit.

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> V, F = spherical_cap(n_rings=6)
    >>> UV = V[:, :2] * 0.4 + 0.5                           # a projection along z
    >>> bad = UV.copy(); bad[5] = UV[5] + 3 * (UV[0] - UV[5])   # one row pulled across the centre
    >>> f = layout_facts(V, F, bad, F)
    >>> out, f2 = onto_projections(f.Vn, F, bad, F, f, acts := {0: []})
    >>> bool(np.abs(out - UV).max() < 1e-12), acts[0][0]["step"], acts[0][0]["rows"]
    (True, 'back onto its planar projection', 1)
    """
    if written is None:
        def written(U):
            return layout_facts(Vn, F, U, FUV, normalized=True, min_overlap=facts.min_overlap)
    it = layout_intent(facts)
    bad = _problems(it, facts)
    todo = [i for i in it.info.get("projections", ()) if bad[facts.island_faces(i)].any()]
    if not todo:
        return UV, facts
    out = np.asarray(UV, float).copy()
    moved = {}
    for i in todo:
        rows, vals = _rows_back(Vn, F, out, FUV, facts, facts.island_faces(i), bad)
        if len(rows):
            moved[i] = (rows, out[rows].copy())
            out[rows] = vals
    if not moved:
        return UV, facts
    f2 = written(out)
    it2 = layout_intent(f2)
    bad2 = _problems(it2, f2)
    undone = False
    for i, (rows, old) in moved.items():
        fi = facts.island_faces(i)
        if bad2[fi].sum() >= bad[fi].sum() or (bad2[fi] & ~bad[fi]).any():
            out[rows] = old
            undone = True
            continue
        actions[i].append({"step": "back onto its planar projection", "rows": int(len(rows)),
                           "faces_mended": int((bad[fi] & ~bad2[fi]).sum()), "faces_left": int(bad2[fi].sum())})
    if undone:
        if np.array_equal(out, UV):
            return UV, facts
        f2 = written(out)
    return out, f2


def _on_lattice(vals, held, origin, step):
    """``vals`` (k,2) at their nearest grid points, each coordinate the very value a row of ``held`` has at that
    grid point where one has it (the nearest such: the file's own dequantized value, where the fitted grid is
    off it by rounding; a moved row's value near it is farther), else the fitted grid's."""
    out = np.empty_like(vals)
    for a in range(2):
        k = np.rint((vals[:, a] - origin[a]) / step[a])
        have = np.unique(held[:, a])
        x = (have - origin[a]) / step[a]
        hk = np.rint(x)
        order = np.argsort(-np.abs(x - hk))  # per grid point the value nearest it last, so that it is kept
        table = {kk: vv for kk, vv, r in zip(hk[order].tolist(), have[order].tolist(), np.abs(x - hk)[order])
                 if r <= 0.1}
        out[:, a] = [table.get(float(kk), origin[a] + kk * step[a]) for kk in k]
    return out


def _problems(it, facts):
    """Folded and UV-degenerate faces, and here also the folds too small for a texture to show (which the local
    repair leaves alone): putting rows back onto the projection costs nothing and leaves no fold at all."""
    small = it.small_fold if it.small_fold is not None else np.zeros(len(facts.F), bool)
    return (it.fold | small | it.degenerate) & facts.usable


def _rows_back(Vn, F, UV, FUV, facts, faces, bad):
    """The rows of island ``faces`` to move back onto its projection, and their values there."""
    got = island_projection(facts, faces)
    if got is None:
        return np.zeros(0, np.int64), np.zeros((0, 2))
    used, A = got.faces, got.A
    R = FUV[used].ravel()
    P = Vn[F[used]].reshape(-1, 3)
    Q = np.c_[P, np.ones(len(P))] @ A                       # where the projection puts each corner
    ext = float(np.ptp(UV[R], axis=0).max())
    tol = PROJECTION_FIT * ext + got.grid
    n_rows = len(UV)
    off_c = np.linalg.norm(UV[R] - Q, axis=1) > tol
    off = np.zeros(n_rows, bool)
    off[R[off_c]] = True
    # a row the projection puts in two places (corners at different 3D points) has no place to go back to
    lo = np.full((n_rows, 2), np.inf)
    hi = np.full((n_rows, 2), -np.inf)
    np.minimum.at(lo, R, Q)
    np.maximum.at(hi, R, Q)
    off &= ~((hi - lo).max(1) > tol)
    # the patch: rows off the projection joined through the island's edges to a problem face's rows
    E = np.r_[FUV[used][:, [0, 1]], FUV[used][:, [1, 2]], FUV[used][:, [2, 0]]]
    E = E[off[E].all(1)]
    g = sp.coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n_rows, n_rows))
    _, comp = connected_components(g, directed=False)
    seeds = np.unique(FUV[faces[bad[faces]]])
    seeds = seeds[off[seeds]]
    rows = np.flatnonzero(off & np.isin(comp, comp[seeds]))
    if not len(rows):
        return rows, np.zeros((0, 2))
    cnt = np.bincount(R, minlength=n_rows)
    vals = np.zeros((n_rows, 2))
    np.add.at(vals, R, Q)
    vals = vals[rows] / cnt[rows, None]
    # a corner at the 3D point of a row that sits on the projection (a vertex split for its normals) takes
    # that row's UV exactly
    on_c = ~off_c & ~off[R]
    key = {P[c].tobytes(): R[c] for c in np.flatnonzero(on_c)}
    first = {}
    for c in np.flatnonzero(np.isin(R, rows)):
        first.setdefault(int(R[c]), c)
    if got.lattice is not None:  # quantized UVs: on the grid they are stored on, as the file will hold them
        vals = _on_lattice(vals, UV[R], *got.lattice)
    where = {int(r): k for k, r in enumerate(rows)}
    for r, c in first.items():
        twin = key.get(P[c].tobytes())
        if twin is not None:
            vals[where[r]] = UV[twin]
    return rows, vals
