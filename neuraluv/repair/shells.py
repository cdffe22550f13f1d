"""Repair under the ``texture`` purpose: each shell's folds fixed in its own orientation, intent kept.

:func:`repair_shells` is steps 1-3 of :func:`~neuraluv.repair.repair.repair_layout` for a
texture layout (:mod:`~neuraluv.layout.purpose`): mirrored, stacked, tiled and palette shells
are intent, so only the folds and UV-degenerate faces inside each shell are repaired, by the
same local escalation as a bake layout's folds (:func:`~neuraluv.repair.local.repair_cluster`).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from neuraluv.layout.facts import face_clusters, layout_facts
from neuraluv.layout.overlap import overlap_pairs
from neuraluv.layout.purpose import layout_intent
from neuraluv.repair.local import IslandGraph, repair_cluster, resolve_as_chart, untangle_faces
from neuraluv.repair.region import face_dets_of, region_overlaps
from neuraluv.repair.twins import layer_sign, twin_layers, twin_layers_hold, twins_follow
from neuraluv.repair.untangle import budget_spent
from neuraluv.topology import undirected_edges

#: A fold on a seam between shells is repaired across them in regions of at most this share of the island (a
#: seam's fold is local; larger regions of two stacked shells seldom come out without overlaps, and cost seconds).
ACROSS_FRACTION = 0.1
#: ... and of at most this many rings around the fold: on the damaged Duck, Suzanne and three mirrored Blender
#: Suzannes (local folds and vertex noise, seeds 10-13: 55 repairs across shells) the 12 that worked did so within
#: one ring of the fold, while the 43 that failed took 12.5 s trying up to 8 rings (7.1 s up to 2).
ACROSS_RINGS = 2

#: A fold on a seam (rows shared with another shell) tries its own shell within this many rings first; larger regions
#: of it come after the twin layers and across shells. Damaged Duck, Suzanne, cylinders, capsule, fuze, spot, milk
#: truck (local folds, noise, seeds 10-13): 30 of the 33 own-shell seam repairs that worked did so within 2 rings;
#: the 63 that failed took 62 s of the sweep's 105 s of local repairs, trying up to 12 rings.
SEAM_OWN_RINGS = 2

#: Rings around a fold on a seam in which :func:`seam_signs` places the seam anew.
SEAM_RINGS = 2

__all__ = ["repair_shells", "repair_across_shells", "seam_signs", "intended_overlaps", "PairsWith",
           "repair_twin_layers", "own_copies"]


def repair_shells(Vn, F, UVw, FUVw, facts, actions, med, cfg, *, seed, device, deadline, neural, only=None):
    """Steps 1-3 under the ``texture`` purpose: each shell's folds and UV-degenerate faces repaired locally, in
    the shell's own orientation, with the rows it shares with other shells of its island locked.
    A fold on rows that two stacked halves share (twin faces) is repaired in its half's layer
    (:func:`repair_twin_layers`): the twins follow, mirrored.

    The steps for one fold, most local first: a region of its shell (for a fold on rows shared with another
    shell, at most :data:`SEAM_OWN_RINGS` rings); a region of its twin halves' layer; a region across the
    shells that share its rows (:func:`repair_across_shells`); the larger regions of its shell; a region of
    the shell on copies of those rows; the twin halves' whole layer (untangled, else re-solved); the whole shell
    untangled; the shell re-solved.

    A reversed shell is repaired on the layout negated in ``u`` (exact), then negated back, so every row
    the repair does not free is bit-identical. Pairs of the shell's faces that overlapped on purpose may
    stay; a repaired region makes no other overlap. A fold whose rows are all shared with another shell (a
    fold on the seam of a stacked copy) gets copies of those rows for its own shell (same values; the other
    shell keeps the originals) and is repaired on them. A cluster no local region repairs is untangled
    with the whole shell free (locked rows kept); then, for a shell that shares no row with another, the
    shell is re-solved as a chart and fitted back where it was (with ``neural``); for a shell that shares rows
    (twin halves, a mirror seam), the same on its own copies of those rows, once every shell had its turn and
    only if the cluster still reads as a fold (a twin's repair often mends it); a cluster that still fails
    is left as it is and reported.
    ``only``: a mask over faces, the problem faces to repair (default: all).
    Returns ``UV, FUV``.
    """
    it = layout_intent(facts)
    bad = it.fold | it.degenerate
    if only is not None:  # (m,) bool: repair only these of the problem faces
        bad = bad & only
    twin_done = np.zeros(0, np.int64)  # faces of folds repaired in twin layers, and their twins
    deferred = []  # folds no step repaired on shells that share rows: the last resort after every shell's turn
    across_allowed = {}  # island -> the face pairs of its shells that overlap on purpose (read once)
    twin_allowed = {}  # (island, layer, rows) -> the same for a layer of twin halves

    def _twin(whole):
        """The fold ``cl`` of shell ``k`` repaired in its twin halves' layers (:func:`repair_twin_layers`)."""
        nonlocal twin_done, FUVw, locked, held, graph
        res, inf = repair_twin_layers(Vn, F, work * sgn, FUVw, facts.island_faces(i), cl, dens, whole=whole,
                                      allowed_cache=twin_allowed, **kw)
        if res is not None:
            res = res * sgn
            twin_done = np.union1d(twin_done, inf["faces"])
            FUVw = inf["FUV"]
            if len(res) > len(work):  # a layer re-solved in pieces: its faces and their twins on new rows
                locked = np.r_[locked, np.zeros(len(res) - len(work), bool)]
                held = np.r_[held, np.zeros(len(res) - len(work), bool)]
                graph = IslandGraph(FUVw, shell, len(res), locked=locked)
        return res, inf

    def _unsplit(step):
        """``step()`` on the shell as it was before the split copies of its shared rows; if it fails (None), the
        split is kept for the steps after it."""
        nonlocal work, FUVw, locked, held, graph
        after_split = (work, FUVw, locked, held, graph)
        work, FUVw, locked, held, graph = before_split
        res, inf = step()
        if res is None:
            work, FUVw, locked, held, graph = after_split
        return res, inf

    for k in np.unique(it.shell[bad]):
        shell = it.shell_faces(k)
        i = int(it.shell_island[k])
        if budget_spent(deadline):  # what is left is reported, not searched for (--time-budget)
            actions[i].append({"step": "left undone", "reason": "the time budget was spent before this shell's "
                               "repair", "shell": int(k)})
            continue
        outside = np.setdiff1d(facts.island_faces(i), shell, assume_unique=True)
        locked = np.zeros(len(UVw), bool)
        locked[np.unique(FUVw[outside])] = True
        # rows only faces without 3D area share with the shell: no map of theirs to keep, but they hold the UVs
        # around them in shape (a pole's fan); a fold's own faces may move theirs
        flat = outside[facts.degenerate3d[outside]]
        held = np.zeros(len(UVw), bool)
        held[np.unique(FUVw[flat])] = True
        held[np.unique(FUVw[np.setdiff1d(outside, flat)])] = False
        flip = it.shell_sign[k] < 0
        sgn = np.array([-1.0, 1.0]) if flip else np.ones(2)  # work * sgn: the layout as it is
        work = UVw * sgn if flip else UVw
        dens = facts.density[i] if np.isfinite(facts.density[i]) else med
        # the folds' own faces: the rows their damage moved beyond them are repair_cluster's damaged rows; adding the
        # shell's stretched faces (as the bake path does) changed the artist's own stretch (Duck.glb: 286 faces, 194)
        targets = shell[bad[shell]]
        graph = IslandGraph(FUVw, shell, len(work), locked=locked)
        allowed = intended_overlaps(work, FUVw, shell, bad, graph)  # (it reads the faces' rows, not the locks)
        for cl in face_clusters(FUVw, targets):
            if (face_dets_of(Vn, F, work, FUVw, cl) > 0).all() and region_overlaps(work, FUVw, cl, shell, allowed) == 0:
                continue  # fixed by an earlier cluster's region
            if np.isin(cl, twin_done).all() and twin_layers_hold(Vn, F, work * sgn, FUVw, facts.island_faces(i), cl):
                continue  # the twins of a fold repaired in its layers (the other half's shell)
            kw = dict(config=cfg, seed=seed, device=device, deadline=deadline, neural=neural, allowed=allowed)
            own = np.zeros(len(work), bool)
            own[np.unique(FUVw[cl[bad[cl]]])] = True
            g = IslandGraph(FUVw, shell, len(work), locked=locked & ~(held & own)) if (held & own).any() else graph
            seam = bool(locked[np.unique(FUVw[cl])].any())  # rows shared with another shell (a seam, twin halves)
            out, info = repair_cluster(Vn, F, work, FUVw, g, cl, dens, max_rings=SEAM_OWN_RINGS if seam else None, **kw)
            twins = out is None and seam  # a fold of twin halves sharing their rows?
            if twins:  # in the halves' layers, locally first (the whole layer is a later resort)
                out, info = _twin(False)
            if out is None and seam and not budget_spent(deadline):
                # a fold on the seam of two shells that share their rows there (mirrored halves joined along the
                # mirror line): repaired with both shells' rows free, each face in its own shell's orientation
                out, info = repair_across_shells(Vn, F, work * sgn, FUVw, facts, it, i, cl, bad, dens,
                                                 allowed_cache=across_allowed, **kw)
                if out is not None:
                    out = out * sgn
            if out is None and seam and not budget_spent(deadline):  # its own shell's larger regions
                out, info = repair_cluster(Vn, F, work, FUVw, g, cl, dens, min_rings=SEAM_OWN_RINGS + 1, **kw)
            split = np.intersect1d(np.unique(FUVw[cl]), np.flatnonzero(locked))
            before_split = (work, FUVw, locked, held, graph)
            if out is None and len(split):  # the shell's own copies of the rows it shares around the fold
                work, FUVw = own_copies(work, FUVw, shell, split)
                locked = np.r_[locked, np.zeros(len(split), bool)]
                held = np.r_[held, np.zeros(len(split), bool)]
                graph = IslandGraph(FUVw, shell, len(work), locked=locked)
                out, info = repair_cluster(Vn, F, work, FUVw, graph, cl, dens, **kw)
                if out is not None:
                    info = {**info, "split_rows": int(len(split))}
            if out is None and only is None and not budget_spent(deadline):
                # the last local step of the first pass (a second pass reads sheets the first one changed, and may
                # not trust them): the faces of the shell that lay over another part of it before may overlap (a fold
                # where the shell lies over itself: which overlaps near it were there on purpose, and where its faces
                # go back to, the damaged layout cannot tell); no other face is laid over the shell, and outside
                # folds overlaps are no problem under this purpose
                a, b = overlap_pairs(before_split[0], before_split[1], shell)
                if len(a):
                    laid = np.zeros(len(F), bool)
                    laid[a] = laid[b] = True
                    every = PairsWith(allowed, laid)
                    out, info = _unsplit(lambda: repair_cluster(Vn, F, work, FUVw, graph, cl, dens,
                                                                **{**kw, "allowed": every}))
                    if out is not None:
                        info = {**info, "kept_overlaps": True}
            if out is None and twins and not budget_spent(deadline):  # the twin halves' whole layer, unsplit
                out, info = _unsplit(lambda: _twin(True))
            if out is None and budget_spent(deadline):
                actions[i].append({"step": "left undone", "cluster_faces": int(len(cl)), "shell": int(k),
                                   "reason": "the time budget was spent"})
                continue
            if out is None:
                rows = np.setdiff1d(np.unique(FUVw[shell]), np.flatnonzero(locked))
                out, info = untangle_faces(Vn, F, work, FUVw, shell, rows, dens, allowed, deadline=deadline)
            shared = locked[np.unique(FUVw[shell])].any()
            if out is None and neural and not budget_spent(deadline) and not shared:
                # the last resort of a shell of its own: re-solved as a chart, fitted back where it was (every
                # UV of the shell moves a little; the texture is re-baked)
                out_uv, out_fuv, info = _resolved(Vn, F, work, FUVw, shell, np.zeros(0, np.int64), cl, dens, cfg, kw)
                if out_uv is not None:
                    work, FUVw = out_uv, out_fuv
                    actions[i].append({**info, "cluster_faces": int(len(cl)), "shell": int(k)})
                    break  # the whole shell is new: its other clusters went with it
            if out is None:
                actions[i].append({"step": "left folded", "cluster_faces": int(len(cl)),
                                   "reason": "no local region and no untangle of the whole shell was valid"})
                if neural and shared:  # the last resort once every shell had its turn (a twin's may repair it)
                    deferred.append((k, i, cl, dens, kw, actions[i][-1]))
                continue
            work = out
            actions[i].append({kk: info[kk] for kk in ("step", "rings", "extra_rings", "region_faces", "free_rows",
                                                      "split_rows", "seam_faces", "kept_overlaps") if kk in info}
                              | {"cluster_faces": int(len(cl)), "time": info["time"], "shell": int(k),
                                 **({"mirrored_shell": True} if flip else {})})
        UVw = work * np.array([-1.0, 1.0]) if flip else work
    now = None
    for k, i, cl, dens, kw, act in deferred:
        # still a fold, read as the result will be read (a twin's repair may have mended it, or made it a sheet of
        # its own), after every shell's repair: its shell re-solved as a chart on its own copies of the rows it
        # shares (twin halves, a mirror seam), so that the other shells keep theirs
        if budget_spent(deadline):
            break
        if now is None:
            now = layout_intent(layout_facts(Vn, F, UVw, FUVw, normalized=True, min_overlap=facts.min_overlap))
        if not (now.fold[cl] | now.degenerate[cl]).any():
            continue
        sgn = np.array([-1.0, 1.0]) if it.shell_sign[k] < 0 else np.ones(2)
        shell = it.shell_faces(k)
        outside = np.setdiff1d(facts.island_faces(i), shell, assume_unique=True)
        shared = np.intersect1d(np.unique(FUVw[shell]), np.unique(FUVw[outside]))
        out_uv, out_fuv, info = _resolved(Vn, F, UVw * sgn, FUVw, shell, shared, cl, dens, cfg, kw)
        if out_uv is not None:
            UVw, FUVw, now = out_uv * sgn, out_fuv, None
            act.clear()
            act.update({**info, "cluster_faces": int(len(cl)), "shell": int(k), "split_rows": int(len(shared))})
    return UVw, FUVw


def _resolved(Vn, F, UV, FUV, shell, shared, cl, dens, cfg, kw):
    """The last resort for a shell: re-solved as a chart (:func:`~neuraluv.repair.local.resolve_as_chart`), on its
    own copies of the rows ``shared`` with other shells; ``(UV, FUV, action)``, or ``(None, None, None)`` where a
    face of the fold ``cl`` is still not valid."""
    W, FU = own_copies(UV, FUV, shell, shared) if len(shared) else (UV, FUV)
    out_uv, out_fuv, info = resolve_as_chart(Vn, F, W, FU, shell, dens, cfg, seed=kw["seed"], device=kw["device"],
                                             deadline=kw["deadline"])
    if not (face_dets_of(Vn, F, out_uv, out_fuv, cl) > 0).all():
        return None, None, None
    return out_uv, out_fuv, {"step": info["step"], "time": info["time"], "pieces": info["pieces"]}


def own_copies(UV, FUV, shell, rows):
    """``(UV, FUV)`` where the faces ``shell`` use new copies (appended, same values) of the sorted ``rows``; the
    other faces keep the originals.

    Examples
    --------
    >>> UV, FUV = np.zeros((4, 2)), np.array([[0, 1, 2], [1, 3, 2]])
    >>> U2, F2 = own_copies(UV, FUV, np.array([1]), np.array([1, 2]))
    >>> len(U2), F2.tolist()
    (6, [[0, 1, 2], [4, 3, 5]])
    """
    new = len(UV) + np.arange(len(rows))
    sub = FUV[shell]
    hit = np.isin(sub, rows)
    sub[hit] = new[np.searchsorted(rows, sub[hit])]
    FUV = FUV.copy()
    FUV[shell] = sub
    return np.vstack([UV, UV[rows]]), FUV


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


class PairsWith:
    """Face pairs a repaired region may keep (:func:`~neuraluv.repair.local.region_overlaps`' ``allowed``): the pairs
    of ``pairs`` and every pair with a face of ``faces`` ((m,) bool).

    Examples
    --------
    >>> ok = PairsWith({(0, 5)}, np.array([False, False, True, False, False, False]))
    >>> [(0, 5) in ok, (2, 4) in ok, (1, 3) in ok]
    [True, True, False]
    """

    def __init__(self, pairs, faces):
        self.pairs, self.faces = set(pairs or ()), np.asarray(faces, bool)

    def __contains__(self, pair):
        return pair in self.pairs or bool(self.faces[pair[0]] or self.faces[pair[1]])

    def __bool__(self):
        return bool(self.pairs) or bool(self.faces.any())


def intended_overlaps(UV, FUV, shell, bad, graph, rings=3, subset=None):
    """Pairs of the shell's faces that overlap on purpose: a repaired region may keep them.

    Two overlapping faces of which neither is broken overlap on purpose (a shell laid over itself); so do a
    broken face and a face more than ``rings`` rings away from it (the fold lies where the shell is stacked
    on another part of itself). A broken face over its near neighbours is the fold itself. ``subset``: only
    the pairs with a face in it.
    """
    a, b = overlap_pairs(UV, FUV, shell, subset)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keep = ~bad[lo] & ~bad[hi]
    n = np.flatnonzero(~keep)
    if len(n):
        i, j = np.where(bad[lo[n]], lo[n], hi[n]), np.where(bad[lo[n]], hi[n], lo[n])  # i broken
        # j is within `rings` rings of i (rows grown `rings` times from i's, as IslandGraph.grow does) exactly when
        # (G^(rings+1))[i, j] != 0, G the faces' adjacency through shared rows (each face its own neighbour)
        pos = np.full(len(bad), -1)
        pos[graph.faces] = np.arange(len(graph.faces))
        G = (graph.M @ graph.MT).tocsr()
        G.data[:] = 1.0
        ui, inv = np.unique(i, return_inverse=True)
        R = G[pos[ui]]
        for _ in range(rings):
            R = (R @ G).tocsr()
            R.data[:] = 1.0
        keep[n] = np.asarray(R[inv.reshape(-1), pos[j]]).reshape(-1) == 0
    return set(zip(lo[keep].tolist(), hi[keep].tolist()))


def repair_twin_layers(Vn, F, UV, FUV, island, cluster, scale, *, whole=True, allowed_cache=None, **kw):
    """Repair a fold of twin halves in their layers (:func:`~neuraluv.repair.twins.twin_layers`), each in its own
    orientation.

    In each layer the cluster's faces (or their twins) lie in, the faces reversed against the layer (the
    orientation holding more of it, :func:`~neuraluv.layout.facts.holds_more`) next to the cluster are
    repaired by :func:`~neuraluv.repair.local.repair_cluster` with the layer's rows free, except rows of
    faces outside the layer that are no twins of its faces: a twin has the same rows, so it follows, mirrored.

    Parameters
    ----------
    Vn : (n,3) float array
    F, FUV : (m,3) int arrays
    UV : (p,2) float array (not modified)
    island, cluster : int arrays, the island's faces and the fold's
    scale : float, the island's texel density
    whole : bool
        When no local region works, untangle the whole layer (its locked rows kept), else re-solve a layer
        whose rows only its twins share as a chart; with False such a fold is left (None) for other steps.
    allowed_cache : dict, optional
        The face pairs of each layer that overlap on purpose (:func:`intended_overlaps`, with every face
        reversed against the layer broken), filled on first use and read by the island's later folds.
    **kw : for :func:`~neuraluv.repair.local.repair_cluster`

    Returns
    -------
    UV : (p',2) float array or None (no layer had a fold, or one was not repaired); more rows than ``UV`` when
        a layer was re-solved in pieces (the last resort of a layer whose rows only its twins share)
    info : dict, ``step`` and the last layer's details; ``faces``: the cluster's faces and their twins; ``FUV``:
        the texture indices, changed where a re-solved layer's pieces (and their twins) took new rows
    """
    island = np.sort(np.asarray(island, np.int64))
    layer, twin = twin_layers(F, FUV, island)
    if not (twin >= 0).any():
        return None, {"step": "escalate", "reason": "no twin faces"}
    at = np.searchsorted(island, cluster)
    near = np.zeros(len(UV), bool)
    near[np.unique(FUV[cluster])] = True
    touch = near[FUV[island]].any(1)
    out, info, done = UV, {"step": "escalate", "reason": "no layer folded"}, 0
    for lay in np.unique(np.r_[layer[at], layer[twin[at][twin[at] >= 0]]]):
        mine = layer == lay
        fl = island[mine]
        sign = np.array([layer_sign(Vn, F, out, FUV, fl), 1.0])
        work = out * sign
        reversed_ = ~(face_dets_of(Vn, F, work, FUV, fl) > 0)
        targets = fl[reversed_ & touch[mine]]
        if not len(targets):
            continue
        others = ~mine & ~((twin >= 0) & mine[np.maximum(twin, 0)])  # faces outside the layer, no twin in it
        locked = np.zeros(len(UV), bool)
        locked[np.unique(FUV[island[others]])] = True
        graph = IslandGraph(FUV, fl, len(work), locked=locked)
        key = (int(island[0]), int(lay), len(work))  # (new rows: a layer re-solved in pieces, read anew)
        allowed = None if allowed_cache is None else allowed_cache.get(key)
        if allowed is None:  # every face reversed against the layer is broken, this fold's or another's
            bad = np.zeros(len(F), bool)
            bad[fl[reversed_]] = True
            allowed = intended_overlaps(work, FUV, fl, bad, graph)
            if allowed_cache is not None:
                allowed_cache[key] = allowed
        res, info = repair_cluster(Vn, F, work, FUV, graph, targets, scale, **{**kw, "allowed": allowed})
        if res is None and not whole:
            return None, info
        if res is None:  # the whole layer free (its locked rows kept)
            rows = np.setdiff1d(np.unique(FUV[fl]), np.flatnonzero(locked))
            res, info = untangle_faces(Vn, F, work, FUV, fl, rows, scale, allowed, deadline=kw.get("deadline"))
        if res is None and not locked.any() and kw.get("neural", True) and not budget_spent(kw.get("deadline")):
            # the last resort of a layer whose rows only its twins share: re-solved as a chart, fitted back where
            # it was; each twin takes its face's new rows, so the copies stay stacked
            res_uv, res_fuv, info = resolve_as_chart(Vn, F, work, FUV, fl, scale, kw["config"], seed=kw["seed"],
                                                     device=kw["device"], deadline=kw.get("deadline"))
            if (face_dets_of(Vn, F, res_uv, res_fuv, fl) > 0).all():
                FUV = twins_follow(FUV, res_fuv, island, mine, twin)
                out, done = res_uv * sign, done + 1
                continue
        if res is None:
            return None, info
        out, done = res * sign, done + 1
    if not done:
        return None, info
    both = np.r_[at, twin[at][twin[at] >= 0]]
    return out, {**info, "step": info["step"] + " (twin layers)", "faces": np.unique(island[both]), "FUV": FUV}
