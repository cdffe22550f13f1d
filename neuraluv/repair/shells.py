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
from neuraluv.layout.purpose import layout_intent, twin_layers
from neuraluv.repair.local import IslandGraph, repair_cluster, resolve_as_chart, untangle_faces
from neuraluv.repair.region import PairsWith, face_dets_of, intended_overlaps, mended, region_overlaps
from neuraluv.repair.seams import repair_across_shells
from neuraluv.repair.twins import layer_sign, twin_layers_hold, twins_follow
from neuraluv.repair.untangle import budget_spent

#: A fold on a seam (rows shared with another shell) tries its own shell within this many rings first; larger regions
#: of it come after the twin layers and across shells. Damaged Duck, Suzanne, cylinders, capsule, fuze, spot, milk
#: truck (local folds, noise, seeds 10-13): 30 of the 33 own-shell seam repairs that worked did so within 2 rings;
#: the 63 that failed took 62 s of the sweep's 105 s of local repairs, trying up to 12 rings.
SEAM_OWN_RINGS = 2

#: A fold whose regions of up to this many rings all fail waits until the other folds of its shell were repaired,
#: then escalates from its smallest region again: the damage of another fold may lie across those regions (a
#: subdivided Suzanne unwrapped without seams, 1% vertex noise: one fold's region grew to 32 rings, 3,844 faces).
WAIT_RINGS = 8

#: Folds whose neighbourhoods overlap in UV (or touch) are first repaired together within this many rings.
JOIN_RINGS = 2

__all__ = ["repair_shells", "repair_twin_layers", "own_copies"]


def repair_shells(Vn, F, UVw, FUVw, facts, actions, med, cfg, *, seed, device, deadline, neural, only=None):
    """Steps 1-3 under the ``texture`` purpose: each shell's folds and UV-degenerate faces repaired locally, in
    the shell's own orientation, with the rows it shares with other shells of its island locked.
    A fold on rows that two stacked halves share (twin faces) is repaired in its half's layer
    (:func:`repair_twin_layers`): the twins follow, mirrored.

    The steps for one fold, most local first: with the folds of the shell still to come whose neighbourhoods
    overlap its own in UV (or touch it), its own damaged rows (no ring around), then a region of the shell for
    all of them (at most :data:`JOIN_RINGS` rings); a region of its shell (for a fold on rows shared with another
    shell, at most :data:`SEAM_OWN_RINGS` rings; while other folds are to come, at most :data:`WAIT_RINGS`: a
    fold no such region repairs, or whose region reaches a fold that waits, waits until the others had their
    turn, then escalates from its smallest region); a region of its twin halves' layer; a region across the
    shells that share its rows (:func:`~neuraluv.repair.seams.repair_across_shells`); the larger regions of its
    shell; a region of the shell on copies of those rows; the twin halves' whole layer (untangled, else
    re-solved); the whole shell untangled; the shell re-solved.

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
        queue = face_clusters(FUVw, targets)
        waited = set()  # positions in the queue of folds that wait for the shell's other folds
        q = 0
        while q < len(queue):
            cl, q = queue[q], q + 1
            if mended(Vn, F, work, FUVw, cl).all() and region_overlaps(work, FUVw, cl, shell, allowed) == 0:
                continue  # fixed by an earlier cluster's region
            if np.isin(cl, twin_done).all() and twin_layers_hold(Vn, F, work * sgn, FUVw, facts.island_faces(i), cl):
                continue  # the twins of a fold repaired in its layers (the other half's shell)
            kw = dict(config=cfg, seed=seed, device=device, deadline=deadline, neural=neural, allowed=allowed)
            own = np.zeros(len(work), bool)
            own[np.unique(FUVw[cl[bad[cl]]])] = True
            g = IslandGraph(FUVw, shell, len(work), locked=locked & ~(held & own)) if (held & own).any() else graph
            seam = bool(locked[np.unique(FUVw[cl])].any())  # rows shared with another shell (a seam, twin halves)
            wait = not seam and q - 1 not in waited and q < len(queue)  # other folds of the shell still to come
            out = None
            joined = _joined(Vn, F, work, FUVw, g, cl, queue[q:], allowed) if wait else []
            if joined:  # folds whose neighbourhoods overlap (or touch): its own rows first, then repaired as one
                out, info = repair_cluster(Vn, F, work, FUVw, g, cl, dens, max_rings=0, **kw)
                both = np.unique(np.concatenate([cl, *joined]))
                if out is None:
                    out, info = repair_cluster(Vn, F, work, FUVw, g, both, dens, max_rings=JOIN_RINGS, **kw)
                    if out is not None:
                        info = {**info, "joined_faces": int(len(both) - len(cl))}
            if out is None:
                out, info = repair_cluster(Vn, F, work, FUVw, g, cl, dens, min_rings=1 if joined else None,
                                           max_rings=SEAM_OWN_RINGS if seam else WAIT_RINGS if wait else None, **kw)
            if wait and not budget_spent(deadline) and (out is None or _reaches(out, work, FUVw, queue, waited, q)):
                # no small region works: another fold's damage may lie across them (an unwrap without seams packs
                # far-apart surface close in UV); this fold is tried again, from its smallest region, after the
                # others. So is one whose region reaches a waiting fold (it would repair it too, in a larger region)
                waited.add(len(queue))
                queue.append(cl)
                continue
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
            every = None  # the pairs the shell may keep overlapping (set by the step that allows them)
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
            if out is None and every is not None and len(split) and not budget_spent(deadline):
                # the shell's own copies of the rows it shares, keeping the overlaps the shell had (a fold on a seam
                # whose shared rows quantization laid on one line: before the whole shell is re-solved)
                out, info = repair_cluster(Vn, F, work, FUVw, graph, cl, dens, **{**kw, "allowed": every})
                if out is not None:
                    info = {**info, "split_rows": int(len(split)), "kept_overlaps": True}
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
                                                      "split_rows", "seam_faces", "kept_overlaps", "joined_faces")
                               if kk in info}
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


def _joined(Vn, F, UV, FUV, graph, cl, pending, allowed):
    """The folds of ``pending`` (still folded) joined to the fold ``cl``: a face within one ring of one overlaps (or
    is) a face within one ring of the other, and the pair does not overlap on purpose (``allowed``).

    One pass for all of them (sparse products over the island's face-row incidence, one overlap test): a layout
    folded as made (a sphere projection) has hundreds of folds.
    """
    if not pending:
        return []
    faces = np.concatenate(pending)
    lab = np.repeat(np.arange(len(pending)), [len(c) for c in pending])
    folded = np.bincount(lab, weights=(face_dets_of(Vn, F, UV, FUV, faces) <= 0).astype(float), minlength=len(pending))
    rows = FUV[faces].reshape(-1)
    C = sp.csr_matrix((np.ones(len(rows)), (rows, np.repeat(lab, 3))), shape=(graph.M.shape[1], len(pending)))
    grown = graph.MT @ ((graph.M @ C) > 0).astype(float)                # rows of the faces touching each fold
    grown = sp.diags((~graph.locked).astype(float)) @ grown             # locked rows are never freed (IslandGraph.grow)
    near = ((graph.M @ (grown > 0).astype(float)) > 0).tocsr()          # island faces (local) x folds: within one ring
    pos = np.full(len(F), -1)
    pos[graph.faces] = np.arange(len(graph.faces))
    rows_cl = np.zeros(graph.M.shape[1], bool)
    rows_cl[np.unique(FUV[cl])] = True
    mine = graph.faces_touching(graph.grow(rows_cl))
    hit = np.asarray(near[pos[mine]].sum(0)).reshape(-1) > 0            # a face near both
    others = graph.faces[np.asarray(near.sum(1)).reshape(-1) > 0]
    a, b = overlap_pairs(UV, FUV, np.union1d(mine, others), mine)
    keep = [(int(min(x, y)), int(max(x, y))) not in (allowed or ()) for x, y in zip(a, b)]
    partner = np.where(np.isin(a, mine), b, a)[np.asarray(keep, bool)] if len(a) else np.zeros(0, np.int64)
    if len(partner):
        hit |= np.asarray(near[pos[partner]].sum(0)).reshape(-1) > 0
    return [c for c, h, f in zip(pending, hit, folded) if h and f > 0]


def _reaches(out, work, FUV, queue, waited, q):
    """Whether the repaired map ``out`` moved a row of a fold still waiting in ``queue`` (positions ``waited`` from
    ``q`` on)."""
    wait = [queue[j] for j in waited if j >= q]
    if not wait:
        return False
    rows = np.unique(FUV[np.concatenate(wait)])
    rows = rows[rows < min(len(out), len(work))]
    return bool((out[rows] != work[rows]).any())


def _resolved(Vn, F, UV, FUV, shell, shared, cl, dens, cfg, kw):
    """The last resort for a shell: re-solved as a chart (:func:`~neuraluv.repair.local.resolve_as_chart`), on its
    own copies of the rows ``shared`` with other shells; ``(UV, FUV, action)``, or ``(None, None, None)`` where a
    face of the fold ``cl`` is still not valid."""
    W, FU = own_copies(UV, FUV, shell, shared) if len(shared) else (UV, FUV)
    out_uv, out_fuv, info = resolve_as_chart(Vn, F, W, FU, shell, dens, cfg, seed=kw["seed"], device=kw["device"],
                                             deadline=kw["deadline"])
    if not mended(Vn, F, out_uv, out_fuv, cl).all():
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


def repair_twin_layers(Vn, F, UV, FUV, island, cluster, scale, *, whole=True, allowed_cache=None, **kw):
    """Repair a fold of twin halves in their layers (:func:`~neuraluv.layout.purpose.twin_layers`), each in its own
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
        The face pairs of each layer that overlap on purpose (:func:`~neuraluv.repair.region.intended_overlaps`,
        with every face reversed against the layer broken), filled on first use and read by the island's later folds.
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
        reversed_ = ~mended(Vn, F, work, FUV, fl)
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
        if res is None:  # as repair_shells' last local step: the layer's faces that lay over another part of it
            a, b = overlap_pairs(work, FUV, fl)  # before may overlap (which of those were meant, a fold cannot tell)
            if len(a):
                laid = np.zeros(len(F), bool)
                laid[a] = laid[b] = True
                res, info = repair_cluster(Vn, F, work, FUV, graph, targets, scale,
                                           **{**kw, "allowed": PairsWith(allowed, laid)})
                if res is not None:
                    info = {**info, "kept_overlaps": True}
        if res is None:  # the whole layer free (its locked rows kept)
            rows = np.setdiff1d(np.unique(FUV[fl]), np.flatnonzero(locked))
            res, info = untangle_faces(Vn, F, work, FUV, fl, rows, scale, allowed, deadline=kw.get("deadline"))
        if res is None and not locked.any() and kw.get("neural", True) and not budget_spent(kw.get("deadline")):
            # the last resort of a layer whose rows only its twins share: re-solved as a chart, fitted back where
            # it was; each twin takes its face's new rows, so the copies stay stacked
            res_uv, res_fuv, info = resolve_as_chart(Vn, F, work, FUV, fl, scale, kw["config"], seed=kw["seed"],
                                                     device=kw["device"], deadline=kw.get("deadline"))
            if mended(Vn, F, res_uv, res_fuv, fl).all():
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
