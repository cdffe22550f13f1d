"""Islands made by a planar projection, and the faces that go against it.

Projection mapping — "project from view", planar mapping, a side projection like the Khronos
*Duck*'s — gives every vertex the UV ``A p + c`` of its 3D position ``p``. Such an island folds
over itself wherever the surface turns away from the projection's axis: its far side lands on the
near side's texels, reversed, and concave parts fold back inside the near side. Those reversals are
the projection's, not damage: each face's orientation is the sign of ``n · (a × b)`` (its normal
against the axis the two rows of ``A`` span). A face whose UV orientation differs from that sign —
on an island whose corners all (but a few) sit where the projection puts them — was moved off it:
a fold.

:func:`projection_axes` finds the projection of an island (a least-squares affine fit of its
corners' UVs to their 3D positions, refitted on the corners that agree); :func:`projection_signs`
gives each face the orientation the projection gives it, and :func:`projection_folds` makes the
faces against it the folds of a shell of that orientation. :func:`~neuraluv.layout.purpose.layout_intent` uses them: in a
projection island the projection, not the sheets, says which reversed faces are folds, and
:mod:`~neuraluv.repair.projected` puts a fold's rows back where the projection puts them.

UVs stored as 8 to 16-bit integers (gltfpack, gltf-transform's ``quantize``) sit on a grid
(:func:`~neuraluv.layout.precision.uv_lattice`), off the projection by up to half a step: the fit
allows for it, and a face the projection makes so thin that rounding to the grid can turn it
over or collapse it is read like an edge-on one (the grid's doing, not damage).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from neuraluv.layout.precision import uv_lattice

__all__ = ["projection_axes", "IslandProjection", "island_projection", "projection_signs", "projection_folds",
           "PROJECTION_FIT", "PROJECTION_SHARE", "EDGE_ON"]

#: A corner sits on the projection when its UV is within this share of the island's UV extent of it.
PROJECTION_FIT = 1e-4
#: Share of an island's corners that must sit on its projection for the island to be one.
PROJECTION_SHARE = 0.9
#: Faces whose normal is within this cosine of edge-on to the projection's axis lie along its silhouette,
#: where it folds the surface over: one that sits on the projection is intent whatever its orientation (a
#: sliver may come out reversed by rounding alone); one moved off it is judged by the projection like any
#: other face (0.2: within 11.5° of edge-on). Before the repair could put a fold's rows back onto the
#: projection (:mod:`neuraluv.repair.projected`), moved faces here were left to the sheets' reading: the
#: local untangle could not keep the near and far sides' orientations on the rows they share.
EDGE_ON = 0.2
#: Islands with fewer faces are not judged as projections (a few faces fit any affine map).
MIN_FACES = 8


def projection_axes(P, U, *, fit=PROJECTION_FIT, share=PROJECTION_SHARE, grid=0.0):
    """The planar projection ``U ≈ [P, 1] @ A`` a set of corners was made by, and which corners sit on it; or
    None.

    Parameters
    ----------
    P : (k,3) float array, corners' 3D positions (each corner its own: copies on shared rows do not fit)
    U : (k,2) float array, their UVs
    grid : float
        How far (in UV units) rounding to the grid the UVs are stored on moves a corner (0: float data), on top of
        ``fit``.

    Returns
    -------
    ((4,2) float array, (k,) bool array) or None
        ``A`` and the corners within ``fit`` (relative to the UVs' extent) plus ``grid`` of it, when they are at
        least ``share`` of them.

    Examples
    --------
    >>> P = np.random.default_rng(0).normal(size=(50, 3))
    >>> A, on = projection_axes(P, P[:, [0, 2]] * 0.1 + 0.5)
    >>> (np.round(A, 6) + 0.0).tolist()
    [[0.1, 0.0], [0.0, 0.0], [0.0, 0.1], [0.5, 0.5]]
    >>> projection_axes(P, np.c_[np.linalg.norm(P, axis=1), P[:, 0]]) is None
    True
    """
    X = np.c_[P, np.ones(len(P))]
    ext = float(np.ptp(U, axis=0).max()) if len(U) else 0.0
    if not np.isfinite(ext) or ext <= 0 or not np.isfinite(X).all() or not np.isfinite(U).all():
        return None
    tol = fit + float(grid) / ext
    keep = np.ones(len(P), bool)
    for _ in range(4):  # refit on the corners that agree (a fold's moved rows are outliers)
        A = np.linalg.lstsq(X[keep], U[keep], rcond=None)[0]
        r = np.linalg.norm(X @ A - U, axis=1) / ext
        keep = r <= max(tol, float(np.median(r)))
    return (A, r <= tol) if np.mean(r <= tol) >= share else None


class IslandProjection(NamedTuple):
    """The planar projection of an island (:func:`island_projection`)."""
    faces: np.ndarray       # (k,) int, the island's faces it was fitted on (usable, with 3D area)
    A: np.ndarray           # (4,2) float, UV = [p, 1] @ A
    corner_on: np.ndarray   # (k,3) bool, corners where it puts them
    grid: float             # how far rounding to the UVs' grid moves a corner (UV units; 0: float data)
    lattice: tuple          # (origin, step) of that grid (:func:`~neuraluv.layout.precision.uv_lattice`), or None


def island_projection(facts, faces):
    """The planar projection an island (``faces``) was made by, fitted on its usable faces with 3D area
    (:func:`projection_axes`, allowing for the grid quantized UVs are stored on); None when the island is no
    projection (or has fewer than :data:`MIN_FACES` such faces).

    Returns
    -------
    IslandProjection or None
    """
    faces = faces[~facts.degenerate3d[faces] & facts.usable[faces]]
    if len(faces) < MIN_FACES:
        return None
    lat = uv_lattice(facts.UV[np.unique(facts.FUV[faces])])
    grid = 0.6 * float(np.hypot(*lat[1])) if lat is not None else 0.0  # half a step on each axis, and a margin
    got = projection_axes(facts.Vn[facts.F[faces]].reshape(-1, 3), facts.UV[facts.FUV[faces]].reshape(-1, 2),
                          grid=grid)
    return None if got is None else IslandProjection(faces, got[0], got[1].reshape(-1, 3), grid, lat)


def projection_signs(facts, faces):
    """The orientation the planar projection of an island (``faces``) gives each of its faces, whether the face
    sits on it, and whether it is edge-on to it: ``(m,)`` int, bool and bool arrays over all faces (+1 or -1;
    0 where a face is exactly edge-on, has no 3D area or is not in ``faces``; on: all three corners where the
    projection puts them; edge-on: within :data:`EDGE_ON`, or, for UVs on a grid, so thin where the projection
    puts it that rounding to the grid can turn it over); None when the island is no projection.

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> from neuraluv.layout.facts import layout_facts
    >>> V, F = spherical_cap(n_rings=5)
    >>> UV = V[:, :2] * 0.4 + 0.5                  # projected along z
    >>> f = layout_facts(V, F, UV, F)
    >>> s, on, edge = projection_signs(f, np.arange(len(F)))
    >>> bool((s == np.sign(f.det)).all()), bool(on.all())
    (True, True)
    """
    got = island_projection(facts, faces)
    if got is None:
        return None
    faces, A, corner_on = got.faces, got.A, got.corner_on
    Vn, F = facts.Vn, facts.F
    axis = np.cross(A[:3, 0], A[:3, 1])
    n = np.cross(Vn[F[faces, 1]] - Vn[F[faces, 0]], Vn[F[faces, 2]] - Vn[F[faces, 0]])
    dot = n @ axis
    cos = np.abs(dot) / np.maximum(np.linalg.norm(n, axis=1) * np.linalg.norm(axis), 1e-300)
    out, on, edge = np.zeros(len(facts.F), np.int64), np.zeros(len(facts.F), bool), np.zeros(len(facts.F), bool)
    out[faces] = np.sign(dot).astype(np.int64)
    on[faces] = corner_on.all(1)
    edge[faces] = cos <= EDGE_ON
    if got.grid > 0:  # quantized UVs: a face the projection makes thinner than the grid's rounding can turn over
        Q = (np.c_[Vn[F[faces]].reshape(-1, 3), np.ones(3 * len(faces))] @ A).reshape(-1, 3, 2)
        e = Q[:, [1, 2, 0]] - Q
        twice = np.abs(e[:, 0, 0] * e[:, 2, 1] - e[:, 0, 1] * e[:, 2, 0])
        edge[faces] |= twice <= got.grid * np.linalg.norm(e, axis=2).sum(1)
    return out, on, edge


def projection_folds(facts, cls, shell, shell_sign, shell_island, fold, sliver=None):
    """In each island made by a planar projection, the faces against its orientation are folds and the faces
    along it are not, nor the edge-on faces that sit on it (rounding reversed them; changed in place): each
    face whose reading changes goes to the shell of the orientation the projection gives it that the faces
    around it lie in (:func:`_nearest_shell`; else the island's largest; where the island has no shell of
    that orientation, the sheets' reading stays). Only edge-on faces that sit on it are intent whatever their
    orientation.

    Parameters
    ----------
    facts : LayoutFacts
    cls : (m,) int array, 1 / -1 / 0 (positive, reversed, UV-degenerate)
    shell : (m,) int array, each face's shell (changed)
    shell_sign, shell_island : (k,) int arrays, per shell
    fold : (m,) bool array (changed)
    sliver : (m,) bool array, optional (changed)
        Set where a UV-degenerate face (``cls`` 0) sits on its island's projection edge-on to it: a silhouette
        sliver the projection made (quantized UVs collapse them), not a problem.

    Returns
    -------
    list of int, the islands read as planar projections
    """
    found = []
    if not len(shell_sign):
        return found
    size = np.bincount(shell[shell >= 0], minlength=len(shell_sign))
    for i in np.unique(facts.label[facts.usable & (cls != 0)]):
        faces = facts.island_faces(i)
        got = projection_signs(facts, faces)
        if got is None:
            continue
        sgn, on, edge = got
        found.append(int(i))
        if sliver is not None:
            flat = faces[cls[faces] == 0]
            sliver[flat] = on[flat] & edge[flat]
        ks = np.flatnonzero(shell_island == i)
        largest = {}
        for s in (-1, 1):
            k = ks[shell_sign[ks] == s]
            if len(k):
                largest[s] = int(k[np.argmax(size[k])])
        faces = faces[cls[faces] != 0]
        near_edge = edge[faces]
        against = (sgn[faces] != 0) & (cls[faces] != sgn[faces]) & ~(on[faces] & near_edge)
        along = (cls[faces] == sgn[faces]) | (on[faces] & near_edge)
        # only the faces whose reading changes move: a new fold goes to a shell of the projection's orientation
        # (the one it lies in, if so), a fold the projection explains to one of its own orientation
        wrong_host = np.zeros(len(faces), bool)
        has = shell[faces] >= 0
        wrong_host[has] = shell_sign[shell[faces][has]] != sgn[faces][has]
        for f_set, want, folded in ((faces[against & (~fold[faces] | wrong_host)], sgn, True),
                                    (faces[along & fold[faces]], cls, False)):
            for s, host in largest.items():
                m = f_set[want[f_set] == s]
                fold[m] = folded
                shell[m] = _nearest_shell(facts.FUV, m, faces, shell, shell_sign, fold, s, host)
    return found


def _nearest_shell(FUV, m, faces, shell, shell_sign, fold, sign, default):
    """For each face of ``m``, the shell of orientation ``sign`` most of the unfolded faces of ``faces`` sharing
    its ``vt`` rows lie in (``default`` where none does): a fold stays in the shell around it."""
    import scipy.sparse as sp

    out = np.full(len(m), default, np.int64)
    if not len(m):
        return out
    ok = faces[~fold[faces] & (shell[faces] >= 0)]
    ok = ok[shell_sign[shell[ok]] == sign]
    if not len(ok):
        return out
    n_rows = int(FUV.max()) + 1

    def incidence(fs):
        return sp.csr_matrix((np.ones(3 * len(fs)), (np.repeat(np.arange(len(fs)), 3), FUV[fs].ravel())),
                             shape=(len(fs), n_rows))

    touch = (incidence(m) @ incidence(ok).T).tocoo()   # fold face x unfolded neighbour, by shared rows
    if touch.nnz:
        hosts, col = np.unique(shell[ok][touch.col], return_inverse=True)   # the island's shells that vote
        votes = sp.csr_matrix((touch.data, (touch.row, col.reshape(-1))), shape=(len(m), len(hosts))).toarray()
        has = votes.max(1) > 0
        out[has] = hosts[votes[has].argmax(1)]
    return out
