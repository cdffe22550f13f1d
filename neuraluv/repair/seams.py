"""Folds on a seam: rows that two shells of one island share (mirrored halves joined along the mirror line).

A fold there turns faces of one half over, so that they read as the other half's; under the ``texture`` purpose
(:func:`~neuraluv.repair.shells.repair_shells`) it is repaired with the rows of both shells free, each face in
its own shell's orientation (:func:`repair_across_shells`), and, where the damage made the seam itself unclear,
with each face near the fold on the side of the shortest seam on the surface (:func:`seam_signs`: a minimum cut).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from neuraluv.repair.local import IslandGraph, repair_cluster
from neuraluv.repair.region import face_dets_of, intended_overlaps
from neuraluv.repair.untangle import budget_spent
from neuraluv.topology import undirected_edges

__all__ = ["repair_across_shells", "seam_signs", "ACROSS_FRACTION", "ACROSS_RINGS", "SEAM_RINGS"]

#: A fold on a seam between shells is repaired across them in regions of at most this share of the island (a
#: seam's fold is local; larger regions of two stacked shells seldom come out without overlaps, and cost seconds).
ACROSS_FRACTION = 0.1
#: ... and of at most this many rings around the fold: on the damaged Duck, Suzanne and three mirrored Blender
#: Suzannes (local folds and vertex noise, seeds 10-13: 55 repairs across shells) the 12 that worked did so within
#: one ring of the fold, while the 43 that failed took 12.5 s trying up to 8 rings (7.1 s up to 2).
ACROSS_RINGS = 2

#: Rings around a fold on a seam in which :func:`seam_signs` places the seam anew.
SEAM_RINGS = 2


def repair_across_shells(Vn, F, UV, FUV, facts, it, island, cluster, bad, scale, *, allowed_cache=None, **kw):
    """Repair a fold on rows that shells of one island share (a seam), with the rows of every shell free.

    Each face is untangled and polished in its own shell's orientation (``sign``,
    :meth:`~neuraluv.repair.untangle.RegionEnergy.build`), only overlaps within a shell count, and rows of
    faces in no shell (a palette collapse, faces without 3D area) stay where they are.

    Parameters
    ----------
    Vn : (n,3) float array
    F, FUV : (m,3) int arrays
    UV : (p,2) float array, the layout as it is (not a shell's orientation)
    facts, it : :class:`~neuraluv.layout.facts.LayoutFacts`, :class:`~neuraluv.layout.purpose.LayoutIntent`
    island : int
    cluster : int array, the fold's faces
    bad : (m,) bool array, the problem faces (for the overlaps that were there on purpose)
    scale : float, the island's texel density
    allowed_cache : dict, optional
        ``island -> face pairs that overlap on purpose`` (:func:`intended_overlaps` over the island's shells),
        filled on first use: a repair moves only broken faces, so the pairs read once hold for its other folds
        (``bad``, the island's problem faces, is the same for all of them).
    **kw : for :func:`~neuraluv.repair.local.repair_cluster`

    Returns
    -------
    UV or None, info (as :func:`~neuraluv.repair.local.repair_cluster`; ``step`` says "(across shells)")
    """
    faces = facts.island_faces(island)
    inside = faces[it.shell[faces] >= 0]
    sign = np.zeros(len(F))
    sign[inside] = it.shell_sign[it.shell[inside]]
    locked = np.zeros(len(UV), bool)
    locked[np.unique(FUV[np.setdiff1d(faces, inside)])] = True
    graph = IslandGraph(FUV, inside, len(UV), locked=locked)
    allowed = None if allowed_cache is None else allowed_cache.get(int(island))
    if allowed is None:
        allowed = intended_overlaps(UV, FUV, inside, bad, graph)
        if allowed_cache is not None:
            allowed_cache[int(island)] = allowed
    out, info = repair_cluster(Vn, F, UV, FUV, graph, cluster, scale, **{**kw, "allowed": allowed},
                               sign=sign, group=it.shell, max_fraction=ACROSS_FRACTION, max_rings=ACROSS_RINGS)
    moved = np.zeros(0, np.int64)
    if out is None and not budget_spent(kw.get("deadline")):
        # the fold may have turned faces of one half over so that they read as the other half's: again with
        # each face near the fold on the side of the shortest seam
        sign2, group2, moved = seam_signs(Vn, F, UV, FUV, graph, cluster, sign, it.shell)
        if len(moved):
            if not bad[moved].all():  # faces the cut turned over are broken too: their overlaps are not intended
                bad2 = bad.copy()
                bad2[moved] = True
                mv = set(moved.tolist())  # the island's pairs as read once, those of the faces it turned over anew
                allowed = {p for p in allowed if p[0] not in mv and p[1] not in mv} | intended_overlaps(
                    UV, FUV, inside, bad2, graph, subset=moved)
            out, info = repair_cluster(Vn, F, UV, FUV, graph, np.union1d(cluster, moved), scale,
                                       **{**kw, "allowed": allowed}, sign=sign2, group=group2,
                                       max_fraction=ACROSS_FRACTION, max_rings=ACROSS_RINGS)
    if out is not None:
        info = {**info, "step": info["step"] + " (across shells)"} | ({"seam_faces": int(len(moved))} if len(moved)
                                                                       else {})
    return out, info


def seam_signs(Vn, F, UV, FUV, graph, cluster, sign, shell, rings=SEAM_RINGS):
    """Which side of a seam between mirrored shells each face near a fold belongs to, read from the surface.

    A fold on the seam of two mirrored halves turns faces of one half over, so that the layout reads them as
    faces of the other half (their orientation is all the damaged layout tells). The seam itself is a line
    on the surface the damage does not move: near the fold each face is given the side (``sign``) of the
    labelling with the shortest seam (3D length of the edges between the two sides), all faces further away
    keeping theirs — a minimum cut, with a tie-break towards each face's present orientation.

    Parameters
    ----------
    Vn : (n,3) float array
    F, FUV : (m,3) int arrays
    UV : (p,2) float array
    graph : IslandGraph
        The faces of the island's shells (``graph.faces``).
    cluster : int array
        The fold's faces.
    sign : (m,) float array
        +1 / -1: the orientation of each face's shell (0: in no shell).
    shell : (m,) int array
        Each face's shell.
    rings : int
        The faces within this many rings of the cluster get a new side; the rest hold theirs.

    Returns
    -------
    sign, shell : (m,) arrays, copies with the near faces' sides and shells (a face that changes side joins a
        neighbouring shell of its new side)
    moved : int array, the faces whose side changed

    Examples
    --------
    Two mirrored halves of a strip meet at its narrowest, x = 0, laid on the same texels (``u = |x|``); a fold
    drags a row of the first face right of the seam over it, so the layout reads that face as one of the left
    half. The shortest seam gives it back to the right half:

    >>> V = np.array([[x, y * (1 + abs(x) / 10), 0.0] for x in range(-4, 5) for y in (0, 1)])  # narrowest at 0
    >>> F = np.array([f for c in range(8) for f in ([2 * c, 2 * c + 2, 2 * c + 1], [2 * c + 1, 2 * c + 2, 2 * c + 3])])
    >>> UV = np.abs(V[:, :2]); UV[10] = [-0.5, 0.0]                  # the fold: face 8 turned over
    >>> sign = np.r_[-np.ones(9), np.ones(7)]; shell = np.r_[np.zeros(9, int), np.ones(7, int)]   # as read
    >>> s, sh, moved = seam_signs(V, F, UV, F, IslandGraph(F, np.arange(16), len(UV)), np.array([8]), sign, shell)
    >>> s[6:11].tolist(), sh[6:11].tolist(), moved.tolist()
    ([-1.0, -1.0, 1.0, 1.0, 1.0], [0, 0, 1, 1, 1], [8])
    """
    from scipy.sparse.csgraph import breadth_first_order, maximum_flow

    sign, shell = np.asarray(sign, float).copy(), np.asarray(shell).copy()
    faces = graph.faces
    if len(np.unique(sign[faces])) < 2:
        return sign, shell, np.zeros(0, np.int64)  # one orientation all around: no seam to place
    rows = np.zeros(graph.M.shape[1], bool)
    rows[np.unique(FUV[cluster])] = True
    for _ in range(rings):
        rows = graph.grow(rows) | rows
    near = graph.faces_touching(rows)
    # faces sharing a texture edge, and that edge's length on the surface
    _, E = undirected_edges(FUV[faces])
    P = np.asarray(Vn, float)[F[faces]]
    L = np.linalg.norm(np.concatenate([P[:, 1] - P[:, 0], P[:, 2] - P[:, 1], P[:, 0] - P[:, 2]]), axis=1)
    who = np.tile(faces, 3)
    _, key = np.unique(E, axis=0, return_inverse=True)
    order = np.argsort(key, kind="stable")
    k, w_, L_ = key[order], who[order], L[order]
    pair = k[1:] == k[:-1]  # consecutive faces on one edge (a stacked edge gives a chain of pairs)
    a, b, le = w_[:-1][pair], w_[1:][pair], L_[:-1][pair]
    idx = np.full(len(F), -1)
    idx[near] = np.arange(len(near))
    n = len(near)
    src, snk = n, n + 1
    unit = 1000.0 / max(float(np.median(le)) if len(le) else 1.0, 1e-300)
    cap = np.clip(np.rint(le * unit), 1, 2**20).astype(np.int64)  # integer capacities; no int32 overflow in sums
    us, vs, cs = [], [], []
    ia, ib = idx[a], idx[b]
    both = (ia >= 0) & (ib >= 0)
    us += [ia[both], ib[both]]
    vs += [ib[both], ia[both]]
    cs += [cap[both], cap[both]]
    for x, y in ((ia, b), (ib, a)):  # a near face beside a face holding its side: tied to that side
        m = (x >= 0) & (idx[y] < 0) & (sign[y] != 0)
        us.append(np.where(sign[y[m]] > 0, src, x[m]))
        vs.append(np.where(sign[y[m]] > 0, x[m], snk))
        cs.append(cap[m])
    det = face_dets_of(Vn, F, UV, FUV, near)  # the tie-break: each near face's orientation as it is
    us.append(np.where(det > 0, src, np.arange(n)))
    vs.append(np.where(det > 0, np.arange(n), snk))
    cs.append(np.ones(n, np.int64))
    G = sp.csr_matrix((np.concatenate(cs).astype(np.int32), (np.concatenate(us), np.concatenate(vs))),
                      shape=(n + 2, n + 2))
    G.sum_duplicates()
    flow = maximum_flow(G, src, snk).flow
    residual = (G - flow).tocsr()
    residual.data[residual.data < 0] = 0
    residual.eliminate_zeros()
    seen = np.zeros(n + 2, bool)  # the source's side of the minimum cut (what it still reaches): +1
    seen[breadth_first_order(residual, src, return_predecessors=False)] = True
    new = np.where(seen[:n], 1.0, -1.0)
    moved = near[(new != sign[near]) & (sign[near] != 0)]
    sign[near] = np.where(sign[near] != 0, new, 0.0)
    # a face that changed side joins a shell of its new side beside it (repeated: a patch joins from its rim)
    left = set(moved.tolist())
    for _ in range(len(moved)):
        if not left:
            break
        for f in list(left):
            nb = np.r_[b[a == f], a[b == f]]
            nb = nb[(sign[nb] == sign[f]) & ~np.isin(nb, list(left))]
            if len(nb):
                shell[f] = shell[nb[0]]
                left.discard(f)
    return sign, shell, moved
