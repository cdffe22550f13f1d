"""Steps 1-3 of :func:`~neuraluv.repair.repair.repair_layout` under a bake's rules (``bake``, ``lightmap``).

A layout to bake into gives every surface texels of its own. Before the per-island steps, islands that cannot
hold texels as they are lose their rows: an island with no UV area (a palette collapse) joins the faces without
UVs (:func:`collapsed_faces`: new charts, step 4), and surfaces stacked or mirrored on one island's rows get rows
of their own (:func:`own_rows_per_surface`). Then each island, stopping at the first step that fixes it
(:func:`repair_islands`): a mirrored island reflected back; folds and self-overlaps repaired locally
(:func:`~neuraluv.repair.local.repair_cluster`); else the island untangled whole; else re-solved as a chart.
"""
from __future__ import annotations

import time

import numpy as np

from neuraluv.layout.facts import face_clusters, layout_facts, uv_degenerate
from neuraluv.layout.purpose import layout_intent
from neuraluv.meshfix import weld_ids
from neuraluv.repair.local import IslandGraph, repair_cluster, resolve_as_chart, untangle_faces, with_stretched_neighbours
from neuraluv.repair.region import face_dets_of, mended, self_overlap_faces
from neuraluv.repair.shells import own_copies
from neuraluv.repair.untangle import budget_spent
from neuraluv.topology import vertex_components

__all__ = ["LEFT_UNDONE", "collapsed_faces", "own_rows_per_surface", "repair_islands"]


#: An island's action when the time budget ran out before its repair (the summary counts them).
LEFT_UNDONE = {"step": "left undone", "reason": "the time budget was spent before this island's repair"}


def repair_islands(Vn, F, UVw, FUVw, facts, actions, movers_pref, med, cfg, *, seed, device, deadline, neural,
                   keep_small=True):
    """Steps 1-3 under a bake's rules: mirrored islands reflected back, folds and self-overlaps repaired locally
    (else the whole island untangled, else re-solved). Returns ``UV, FUV``; ``actions`` and ``movers_pref`` are
    filled in. ``keep_small``: folds below the tolerance are left as they are (False when the layout is packed
    afresh next: an island scaled up takes its small folds above the tolerance)."""
    # an island's rows are its own: until it is changed, its det J and self-overlaps are the facts'
    ii, jj, _ = facts.overlaps()
    same = facts.label[ii] == facts.label[jj]
    over_faces = np.concatenate([ii[same], jj[same]])
    over_label = facts.label[over_faces]
    small = facts.small_folds(facts.bad) if keep_small else np.zeros(len(F), bool)
    for i in range(facts.n_islands):
        fi = facts.island_faces(i)
        dens = facts.density[i] if np.isfinite(facts.density[i]) else med
        if facts.mirrored[i]:  # 1. mirrored: reflect back about the island's centre
            rows = np.unique(FUVw[fi])
            cx = 0.5 * (UVw[rows, 0].min() + UVw[rows, 0].max())
            UVw[rows, 0] = 2.0 * cx - UVw[rows, 0]
            actions[i].append({"step": "reflected", "rows": int(len(rows))})
            movers_pref.add(i)
            det = face_dets_of(Vn, F, UVw, FUVw, fi)
            over = self_overlap_faces(UVw, FUVw, fi, det)
            broken = ~(det > 0) | uv_degenerate(UVw, FUVw[fi], det)  # mended's test, on the dets just read
        else:
            over = np.unique(over_faces[over_label == i])
            broken = facts.bad[fi]
        # 2./3. folds and self-overlaps, locally (folds below the tolerance are left as they are)
        bad = fi[broken & ~facts.degenerate3d[fi] & ~small[fi]]
        targets = np.unique(np.concatenate([bad, over]))
        if not len(targets):
            continue
        if budget_spent(deadline):  # what is left is reported, not searched for (--time-budget)
            actions[i].append(LEFT_UNDONE)
            continue
        targets = with_stretched_neighbours(Vn, F, UVw, FUVw, fi, targets)
        graph = IslandGraph(FUVw, fi, len(UVw))
        escalate = False
        for cl in face_clusters(FUVw, targets):
            if mended(Vn, F, UVw, FUVw, cl).all() and not len(self_overlap_faces(UVw, FUVw, fi,
                                                                                  face_dets_of(Vn, F, UVw, FUVw, fi), cl)):
                continue  # fixed by an earlier cluster's region
            out, info = repair_cluster(Vn, F, UVw, FUVw, graph, cl, dens, config=cfg, seed=seed, device=device,
                                       deadline=deadline, neural=neural)
            if out is None:
                escalate = info.get("step") != "budget"
                if not escalate:
                    actions[i].append(LEFT_UNDONE)
                break
            UVw = out
            actions[i].append({k: info[k] for k in ("step", "rings", "extra_rings", "region_faces", "free_rows") if k in info}
                              | {"cluster_faces": int(len(cl)), "time": info["time"]})
            movers_pref.add(i)
        if escalate and budget_spent(deadline):
            actions[i].append(LEFT_UNDONE)
        elif escalate:
            UVw, FUVw, act = _whole_island(Vn, F, UVw, FUVw, fi, dens, cfg, neural=neural, seed=seed, device=device,
                                           deadline=deadline)
            actions[i].append(act)
            movers_pref.add(i)
    return UVw, FUVw


def collapsed_faces(facts, actions, intent=None):
    """(m,) bool: the faces of islands with no UV area (every face with 3D area degenerate in UV: a palette
    collapse to a point or along a line). A bake gives them texels of their own: new charts, as for faces
    without UVs; untangling or re-solving them as they are searches a map from one point. Each such input
    island's action is recorded in ``actions``. ``intent``: ``layout_intent(facts)`` when the caller has it."""
    out = np.zeros(len(facts.F), bool)
    if not facts.n_islands:
        return out
    flat = (intent or layout_intent(facts)).face_class == 0  # UV-degenerate, as check reads it
    for i in range(facts.n_islands):
        fi = facts.island_faces(i)
        solid = fi[~facts.degenerate3d[fi]]
        if len(solid) and flat[solid].all():
            out[fi] = True
            actions[i].append({"step": "new charts", "faces": int(len(fi)),
                               "why": "no UV area (collapsed to a point or a line): no texels of its own"})
    return out


def own_rows_per_surface(Vn, F, UV, FUV, facts, actions, movers_pref, intent=None):
    """Under a bake's rules each surface has texels of its own. An island can hold several surfaces on shared
    ``vt`` rows: 3D components (positions welded; an array modifier's stacked copies, identical parts laid on one
    texture) and shells of opposite orientation (a mirror modifier's halves, which share the mirror line's rows;
    read by :func:`~neuraluv.layout.purpose.layout_intent`, so a fold stays with the shell it lies in). Where
    those surfaces overlap or mirror each other, no untangle of the island can mend it: every surface but the
    one with the most faces gets copies of the rows it shares, and becomes an island of its own, which step 1
    reflects back if it is mirrored and step 5 moves into free space.

    Returns ``UV, FUV, facts`` (``facts`` itself where nothing was split); ``actions`` and ``movers_pref`` (input
    islands) are filled in. ``intent``: ``layout_intent(facts)`` when the caller has it.
    """
    lab = facts.label
    if not facts.n_islands:
        return UV, FUV, facts
    it = intent or layout_intent(facts)
    reversed_ = (it.shell >= 0) & (it.shell_sign[np.maximum(it.shell, 0)] < 0) if len(it.shell_sign) else \
        np.zeros(len(F), bool)
    W = weld_ids(Vn)
    key = 2 * vertex_components(int(W.max()) + 1, W[F])[1][W[F[:, 0]]] + reversed_
    ii, jj, _ = facts.overlaps()
    hit = set(lab[ii[(lab[ii] == lab[jj]) & (key[ii] != key[jj])]].tolist())
    on = lab >= 0
    both = (np.bincount(lab[on & reversed_], minlength=facts.n_islands) > 0) & \
        (np.bincount(lab[on & ~reversed_], minlength=facts.n_islands) > 0)
    hit |= set(np.flatnonzero(both).tolist())
    split = False
    for i in sorted(hit):
        fi = facts.island_faces(i)
        c = key[fi]
        keep = np.bincount(c).argmax()
        copies = rows = 0
        for k in np.unique(c[c != keep]):
            shared = np.intersect1d(FUV[fi[c == k]], FUV[fi[c != k]])
            if len(shared):
                UV, FUV = own_copies(UV, FUV, fi[c == k], shared)
                copies, rows = copies + 1, rows + len(shared)
        if copies:
            actions[int(i)].append({"step": "own rows per surface", "surfaces": copies + 1, "rows_added": rows})
            movers_pref.add(int(i))
            split = True
    if not split:
        return UV, FUV, facts
    return UV, FUV, layout_facts(Vn, F, UV, FUV, normalized=True, min_overlap=facts.min_overlap)


def _whole_island(Vn, F, UV, FUV, faces, density, cfg, *, neural, seed, device, deadline):
    """Last resorts for one island: untangle it whole (free boundary), else re-solve it as a chart."""
    rows = np.unique(FUV[faces])
    t0 = time.perf_counter()
    out, info = untangle_faces(Vn, F, UV, FUV, faces, rows, density)
    if out is not None:
        return out, FUV, {"step": "untangle whole island", "rows": int(len(rows)), "time": time.perf_counter() - t0}
    return resolve_as_chart(Vn, F, UV, FUV, faces, density, cfg, seed=seed, device=device, deadline=deadline)
