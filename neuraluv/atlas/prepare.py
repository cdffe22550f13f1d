"""Atlas step 1: repair a raw mesh (weld, drop degenerate/duplicate faces, orient, split non-manifold)."""
from __future__ import annotations

import igl
import numpy as np

from neuraluv.io import check_mesh_arrays
from neuraluv.meshfix import repair_mesh, weld_ids
from neuraluv.topology import topology_scan  # noqa: F401  (doctest)

__all__ = ["prepare_mesh", "orient_faces", "input_layout", "surface_view"]


def orient_faces(F):
    """One winding per connected patch, the majority winding of its faces kept.

    Parameters
    ----------
    F : (m,3) int array (welded)

    Returns
    -------
    F2 : (m,3) int array, ``F`` with some faces' corners 1 and 2 swapped.
    flipped : (m,) bool array, the faces swapped.

    Examples
    --------
    >>> F2, flipped = orient_faces(np.array([[0, 1, 2], [0, 2, 3], [0, 4, 3]]))
    >>> flipped.tolist()
    [False, False, True]
    """
    F = np.asarray(F, np.int64)
    if not len(F):
        return F.copy(), np.zeros(0, bool)
    FF, C = igl.bfs_orient(F)
    FF = np.asarray(FF, np.int64)
    C = np.asarray(C, np.int64).reshape(-1)
    flipped = ~np.all(FF == F, axis=1)
    for c in np.unique(C[flipped]):  # keep the input's majority winding in each patch
        inc = C == c
        if flipped[inc].sum() * 2 > inc.sum():
            FF[inc] = FF[inc][:, [0, 2, 1]]
    return FF, ~np.all(FF == F, axis=1)


def prepare_mesh(V, F, *, min_height=1e-6):
    """Repair a raw mesh for atlas construction.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    min_height : float
        Faces whose smallest height is below ``min_height`` times the bounding-box
        diagonal are removed like degenerate faces (counted in
        ``info["sliver_faces"]``): float32 outputs (GLB) cannot keep them flip-free.

    Returns
    -------
    V : (n',3) float array
    F : (m',3) int array
        Welded, degenerate/duplicate-free, each component consistently
        oriented (majority of the input winding kept), manifold.
    vmap : (n',) int array
        Input vertex of each output vertex (``V_out = V_in[vmap]``).
    info : dict
        ``repair`` (RepairReport counts), ``reoriented_faces``, ``split_vertices``,
        ``sliver_faces``.

    Examples
    --------
    >>> from neuraluv.datasets.generated import flip_windings, unweld
    >>> from neuraluv.datasets import sphere
    >>> V, F = sphere(1)
    >>> V2, F2 = unweld(V, flip_windings(F, 0.3))
    >>> V3, F3, vmap, info = prepare_mesh(V2, F2)
    >>> len(V3) == len(V), topology_scan(V3, F3).oriented
    (True, True)
    """
    V, F = check_mesh_arrays(V, F)
    V1, F1, rep, vmap = repair_mesh(V, F, weld=True)
    info = {"repair": rep.as_dict(), "reoriented_faces": 0, "split_vertices": 0, "removed_after_split": 0}
    if len(F1) == 0:
        return V1, F1, vmap, info
    FF, flipped = orient_faces(F1)
    info["reoriented_faces"] = int(flipped.sum())
    SV, SF, SVI = igl.split_nonmanifold(V1, FF)
    SF = np.asarray(SF, np.int64)
    SVI = np.asarray(SVI, np.int64).reshape(-1)
    info["split_vertices"] = int(len(SV) - len(V1))
    V2, F2, rep2, vm2 = repair_mesh(np.asarray(SV, float), SF)
    info["removed_after_split"] = int(rep2.degenerate_faces + rep2.duplicate_faces)
    vmap = vmap[SVI[vm2]]
    # needles thinner than min_height·diag: below what float32 (GLB, GPU UVs) resolves
    info["sliver_faces"] = 0
    if min_height and len(F2):
        P = V2[F2]
        edge = np.linalg.norm(P[:, [1, 2, 0]] - P, axis=2).max(1)
        area2 = np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
        diag = float(np.linalg.norm(V2.max(0) - V2.min(0))) or 1.0
        thin = ~(area2 >= min_height * diag * edge)
        if thin.any() and not thin.all():
            info["sliver_faces"] = int(thin.sum())
            V2, F2, _, vm3 = repair_mesh(V2, F2[~thin])
            vmap = vmap[vm3]
    return V2, F2, vmap, info


def input_layout(V_in, F_in, source, F, UV, FUV):
    """Carry a layout made on :func:`prepare_mesh`'s mesh back to every triangle of the input.

    A triangle the repair kept gets its face's UVs corner by corner (matched through the welded
    vertices, whatever its winding); a duplicate (a double-sided twin, either winding) gets the same
    UVs as the face it repeats; a triangle the repair removed (no area, repeated corners, a sliver
    thinner than the float32 limit) gets all three corners at one UV point of a neighbour — no area in
    the texture, as it has (next to) none on the surface.

    Parameters
    ----------
    V_in : (n,3) float array, F_in : (m,3) int array
        The input mesh.
    source : (n',) int array
        The input vertex of each vertex of the prepared mesh (``vmap`` of :func:`prepare_mesh`).
    F : (m',3) int array, UV : (p,2) float array, FUV : (m',3) int array
        The layout of the prepared mesh.

    Returns
    -------
    FUV_in : (m,3) int array, rows of ``UV`` for every corner of ``F_in``.
    info : dict, ``kept_faces``, ``twin_faces`` (duplicates given their twin's UVs), ``collapsed_faces``
        (removed by the repair, mapped to a point) and ``reversed`` ((m,) bool: the triangle is wound
        against the face its UVs were made for, e.g. a back face or a face the repair re-oriented).

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> F_in = np.array([[0, 1, 2], [0, 2, 1], [0, 0, 1]])   # a face, its back face, a degenerate one
    >>> UV = np.array([[0., 0], [1, 0], [0, 1]])
    >>> FUV_in, info = input_layout(V, F_in, np.arange(3), F_in[:1], UV, F_in[:1])
    >>> FUV_in.tolist(), info["twin_faces"], info["collapsed_faces"]
    ([[0, 1, 2], [0, 2, 1], [0, 0, 0]], 1, 1)
    """
    F_in = np.asarray(F_in, np.int64)
    wid = weld_ids(V_in)
    W_in = wid[F_in]
    W = wid[np.asarray(source, np.int64)][np.asarray(F, np.int64)]
    key_in, key = np.sort(W_in, 1), np.sort(W, 1)
    allk, inv = np.unique(np.vstack([key, key_in]), axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    face_of = -np.ones(len(allk), np.int64)
    face_of[inv[:len(F)][::-1]] = np.arange(len(F))[::-1]
    match = face_of[inv[len(F):]]
    distinct = (W_in[:, 0] != W_in[:, 1]) & (W_in[:, 1] != W_in[:, 2]) & (W_in[:, 0] != W_in[:, 2])
    match[~distinct] = -1
    FUV_in = np.zeros_like(F_in)
    ok = match >= 0
    Wm, FUVm = W[match[ok]], np.asarray(FUV, np.int64)[match[ok]]
    perm = np.zeros((int(ok.sum()), 3), np.int64)
    for c in range(3):
        perm[:, c] = np.argmax(Wm == W_in[ok, c:c + 1], axis=1)
        FUV_in[ok, c] = FUVm[np.arange(len(perm)), perm[:, c]]
    reversed_ = np.zeros(len(F_in), bool)  # wound against the face the layout was made for
    reversed_[ok] = perm[:, 1] != (perm[:, 0] + 1) % 3
    # removed faces: one UV point, the row of a corner's welded vertex in the layout (else row 0)
    row_of = -np.ones(int(wid.max()) + 1, np.int64)
    row_of[W.reshape(-1)[::-1]] = np.asarray(FUV, np.int64).reshape(-1)[::-1]
    lost = np.flatnonzero(~ok)
    r = np.full(len(lost), int(np.asarray(FUV).reshape(-1)[0]) if len(FUV) else 0)
    for c in (2, 1, 0):
        rc = row_of[W_in[lost, c]]
        r = np.where(rc >= 0, rc, r)
    FUV_in[lost] = r[:, None]
    used = match[ok]
    n_kept = len(np.unique(used))
    return FUV_in, {"kept_faces": int(n_kept), "twin_faces": int(len(used) - n_kept),
                    "collapsed_faces": int(len(lost)), "reversed": reversed_}


def surface_view(V, F, UV, FUV, reversed_=None):
    """A written layout as a map of the surface, for validation: twins dropped, windings made consistent.

    Corners at one place on the surface with one UV are one UV row (a glTF file splits a vertex for a
    normal or an old UV seam; the map is not cut there). A triangle that repeats another (same welded
    corners, the same UV at each) adds nothing to the map: a double-sided face's back side. A face wound
    against its neighbours has its corners 1 and 2 swapped (in ``F`` and ``FUV`` alike; the map is
    unchanged). This is how the atlas's read-back judges a file that keeps the input's faces as they were.

    Parameters
    ----------
    V : (n,3), F : (m,3), UV : (p,2), FUV : (m,3)
    reversed_ : (m,) bool array, optional
        The faces wound against the map (``input_layout``'s ``reversed``); by default, the faces
        :func:`orient_faces` turns (ambiguous where the mesh is not manifold).

    Returns
    -------
    F2 : (m2,3) int array, m2 <= m.
    UV2 : (p2,2) float array; FUV2 : (m2,3) int array into it.
    info : dict, ``twin_faces``, ``reoriented_faces``.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> F2, UV2, FUV2, info = surface_view(V, [[0, 1, 2], [0, 2, 1]], V[:, :2], [[0, 1, 2], [0, 2, 1]])
    >>> F2.tolist(), info
    ([[0, 1, 2]], {'twin_faces': 1, 'reoriented_faces': 0})
    """
    F, FUV = np.asarray(F, np.int64).copy(), np.asarray(FUV, np.int64).copy()
    W = weld_ids(V)[F]
    if reversed_ is not None:
        rv = np.asarray(reversed_, bool)
        F[rv], FUV[rv], W[rv] = F[rv][:, [0, 2, 1]], FUV[rv][:, [0, 2, 1]], W[rv][:, [0, 2, 1]]
    corner = np.c_[W.reshape(-1).astype(float), np.asarray(UV, float)[FUV.reshape(-1)]]
    rows, inv = np.unique(corner, axis=0, return_inverse=True)
    UV = rows[:, 1:]
    FUV = inv.reshape(-1, 3).astype(np.int64)
    order = np.argsort(W, axis=1, kind="stable")
    Ws = np.take_along_axis(W, order, 1)
    Us = UV[np.take_along_axis(FUV, order, 1)].reshape(len(F), 6)
    key = np.hstack([Ws.astype(float), Us])
    _, first = np.unique(key, axis=0, return_index=True)
    keep = np.zeros(len(F), bool)
    keep[first] = True
    F2, FUV2 = F[keep], FUV[keep]
    W2 = W[keep]
    distinct = (W2[:, 0] != W2[:, 1]) & (W2[:, 1] != W2[:, 2]) & (W2[:, 0] != W2[:, 2])
    flipped = np.zeros(len(F2), bool)
    if reversed_ is None and distinct.any():
        _, fl = orient_faces(W2[distinct])
        flipped[np.flatnonzero(distinct)[fl]] = True
    F2[flipped] = F2[flipped][:, [0, 2, 1]]
    FUV2[flipped] = FUV2[flipped][:, [0, 2, 1]]
    turned = int(flipped.sum()) if reversed_ is None else int(np.asarray(reversed_, bool)[keep].sum())
    return F2, UV, FUV2, {"twin_faces": int((~keep).sum()), "reoriented_faces": turned}
