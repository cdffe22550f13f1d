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
projection island the projection, not the sheets, says which reversed faces are folds.
"""
from __future__ import annotations

import numpy as np

__all__ = ["projection_axes", "projection_signs", "projection_folds", "PROJECTION_FIT", "PROJECTION_SHARE", "EDGE_ON"]

#: A corner sits on the projection when its UV is within this share of the island's UV extent of it.
PROJECTION_FIT = 1e-4
#: Share of an island's corners that must sit on its projection for the island to be one.
PROJECTION_SHARE = 0.9
#: Faces whose normal is within this cosine of edge-on to the projection's axis lie along its silhouette,
#: where it folds the surface over: one that sits on the projection is intent (a sliver may come out reversed
#: by rounding alone); one moved off it is left to the sheets' reading (0.2: within 11.5° of edge-on). Judged
#: by the projection down to 0.05, every face ``data_scripts/purpose_fold_recall.py`` reverses on the Duck is
#: found, but the local repair then failed on 2 of its 6 vertex-noise cases: it could not keep the
#: projection's own fold line.
EDGE_ON = 0.2
#: Islands with fewer faces are not judged as projections (a few faces fit any affine map).
MIN_FACES = 8


def projection_axes(P, U, *, fit=PROJECTION_FIT, share=PROJECTION_SHARE):
    """The planar projection ``U ≈ [P, 1] @ A`` a set of corners was made by, and which corners sit on it; or
    None.

    Parameters
    ----------
    P : (k,3) float array, corners' 3D positions (each corner its own: copies on shared rows do not fit)
    U : (k,2) float array, their UVs

    Returns
    -------
    ((4,2) float array, (k,) bool array) or None
        ``A`` and the corners within ``fit`` (relative to the UVs' extent) of it, when they are at least
        ``share`` of them.

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
    keep = np.ones(len(P), bool)
    for _ in range(4):  # refit on the corners that agree (a fold's moved rows are outliers)
        A = np.linalg.lstsq(X[keep], U[keep], rcond=None)[0]
        r = np.linalg.norm(X @ A - U, axis=1) / ext
        keep = r <= max(fit, float(np.median(r)))
    return (A, r <= fit) if np.mean(r <= fit) >= share else None


def projection_signs(facts, faces):
    """The orientation the planar projection of an island (``faces``) gives each of its faces, whether the face
    sits on it, and whether it is edge-on to it: ``(m,)`` int, bool and bool arrays over all faces (+1 or -1;
    0 where a face is exactly edge-on, has no 3D area or is not in ``faces``; on: all three corners where the
    projection puts them; edge-on: within :data:`EDGE_ON`); None when the island is no projection.

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
    faces = faces[~facts.degenerate3d[faces] & facts.usable[faces]]
    if len(faces) < MIN_FACES:
        return None
    Vn, F = facts.Vn, facts.F
    got = projection_axes(Vn[F[faces]].reshape(-1, 3), facts.UV[facts.FUV[faces]].reshape(-1, 2))
    if got is None:
        return None
    A, corner_on = got
    axis = np.cross(A[:3, 0], A[:3, 1])
    n = np.cross(Vn[F[faces, 1]] - Vn[F[faces, 0]], Vn[F[faces, 2]] - Vn[F[faces, 0]])
    dot = n @ axis
    cos = np.abs(dot) / np.maximum(np.linalg.norm(n, axis=1) * np.linalg.norm(axis), 1e-300)
    out, on, edge = np.zeros(len(facts.F), np.int64), np.zeros(len(facts.F), bool), np.zeros(len(facts.F), bool)
    out[faces] = np.sign(dot).astype(np.int64)
    on[faces] = corner_on.reshape(-1, 3).all(1)
    edge[faces] = cos <= EDGE_ON
    return out, on, edge


def projection_folds(facts, cls, shell, shell_sign, shell_island, fold):
    """In each island made by a planar projection, the faces against its orientation are folds and the faces
    along it are not, nor the edge-on faces that sit on it (rounding reversed them; changed in place): each
    face whose reading changes goes to the shell of the orientation the projection gives it that the faces
    around it lie in (:func:`_nearest_shell`; else the island's largest; where the island has no shell of
    that orientation, the sheets' reading stays). Faces moved off it within :data:`EDGE_ON` of edge-on keep
    the sheets' reading.

    Parameters
    ----------
    facts : LayoutFacts
    cls : (m,) int array, 1 / -1 / 0 (positive, reversed, UV-degenerate)
    shell : (m,) int array, each face's shell (changed)
    shell_sign, shell_island : (k,) int arrays, per shell
    fold : (m,) bool array (changed)

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
        ks = np.flatnonzero(shell_island == i)
        largest = {}
        for s in (-1, 1):
            k = ks[shell_sign[ks] == s]
            if len(k):
                largest[s] = int(k[np.argmax(size[k])])
        faces = faces[cls[faces] != 0]
        near_edge = edge[faces]
        against = (sgn[faces] != 0) & (cls[faces] != sgn[faces]) & ~near_edge
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
