"""Repair under the ``texture`` purpose: each shell's folds fixed in its own orientation, intent kept.

:func:`repair_shells` is steps 1-3 of :func:`~neuraluv.repair.repair.repair_layout` for a
texture layout (:mod:`~neuraluv.layout.purpose`): mirrored, stacked, tiled and palette shells
are intent, so only the folds and UV-degenerate faces inside each shell are repaired, by the
same local escalation as a bake layout's folds (:func:`~neuraluv.repair.local.repair_cluster`).
"""
from __future__ import annotations

import numpy as np

from neuraluv.layout.facts import face_clusters
from neuraluv.layout.overlap import overlap_pairs
from neuraluv.layout.purpose import layout_intent
from neuraluv.repair.local import (
    IslandGraph,
    face_dets_of,
    region_overlaps,
    repair_cluster,
    resolve_as_chart,
    untangle_faces,
    with_stretched_neighbours,
)
from neuraluv.repair.untangle import budget_spent

__all__ = ["repair_shells", "intended_overlaps"]


def repair_shells(Vn, F, UVw, FUVw, facts, actions, med, cfg, *, seed, device, deadline, neural):
    """Steps 1-3 under the ``texture`` purpose: each shell's folds and UV-degenerate faces repaired locally, in
    the shell's own orientation, with the rows it shares with other shells of its island locked.

    A reversed shell is repaired on the layout negated in ``u`` (exact), then negated back, so every row
    the repair does not free is bit-identical. Pairs of the shell's faces that overlapped on purpose may
    stay; a repaired region makes no other overlap. A fold whose rows are all shared with another shell (a
    fold on the seam of a stacked copy) gets copies of those rows for its own shell (same values; the other
    shell keeps the originals) and is repaired on them. A cluster no local region repairs is untangled
    with the whole shell free (locked rows kept); then, for a shell that shares no row with another, the
    shell is re-solved as a chart and fitted back where it was (with ``neural``); a cluster that still fails
    is left as it is and reported.
    Returns ``UV, FUV``.
    """
    it = layout_intent(facts)
    bad = it.fold | it.degenerate
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
        flip = it.shell_sign[k] < 0
        work = UVw * np.array([-1.0, 1.0]) if flip else UVw
        dens = facts.density[i] if np.isfinite(facts.density[i]) else med
        targets = shell[bad[shell]]
        graph = IslandGraph(FUVw, shell, len(work), locked=locked)
        allowed = intended_overlaps(work, FUVw, shell, bad, IslandGraph(FUVw, shell, len(work)))
        targets = with_stretched_neighbours(Vn, F, work, FUVw, shell, targets)
        for cl in face_clusters(FUVw, targets):
            if (face_dets_of(Vn, F, work, FUVw, cl) > 0).all() and region_overlaps(work, FUVw, cl, shell, allowed) == 0:
                continue  # fixed by an earlier cluster's region
            kw = dict(config=cfg, seed=seed, device=device, deadline=deadline, neural=neural, allowed=allowed)
            out, info = repair_cluster(Vn, F, work, FUVw, graph, cl, dens, **kw)
            split = np.intersect1d(np.unique(FUVw[cl]), np.flatnonzero(locked))
            if out is None and len(split):  # the shell's own copies of the rows it shares around the fold
                new = len(work) + np.arange(len(split))
                work = np.vstack([work, work[split]])
                sub = FUVw[shell]
                hit = np.isin(sub, split)
                sub[hit] = new[np.searchsorted(split, sub[hit])]
                FUVw = FUVw.copy()
                FUVw[shell] = sub
                locked = np.r_[locked, np.zeros(len(split), bool)]
                graph = IslandGraph(FUVw, shell, len(work), locked=locked)
                out, info = repair_cluster(Vn, F, work, FUVw, graph, cl, dens, **kw)
                if out is not None:
                    info = {**info, "split_rows": int(len(split))}
            if out is None and budget_spent(deadline):
                actions[i].append({"step": "left undone", "cluster_faces": int(len(cl)), "shell": int(k),
                                   "reason": "the time budget was spent"})
                continue
            if out is None:
                rows = np.setdiff1d(np.unique(FUVw[shell]), np.flatnonzero(locked))
                out, info = untangle_faces(Vn, F, work, FUVw, shell, rows, dens, allowed, deadline=deadline)
            if out is None and neural and not budget_spent(deadline) and not locked[np.unique(FUVw[shell])].any():
                # the last resort of a shell of its own: re-solved as a chart, fitted back where it was (every
                # UV of the shell moves a little; the texture is re-baked)
                out_uv, out_fuv, info = resolve_as_chart(Vn, F, work, FUVw, shell, dens, cfg, seed=seed,
                                                         device=device, deadline=deadline)
                if (face_dets_of(Vn, F, out_uv, out_fuv, cl) > 0).all():
                    work, FUVw = out_uv, out_fuv
                    actions[i].append({"step": info["step"], "cluster_faces": int(len(cl)), "time": info["time"],
                                       "shell": int(k), "pieces": info["pieces"]})
                    break  # the whole shell is new: its other clusters went with it
            if out is None:
                actions[i].append({"step": "left folded", "cluster_faces": int(len(cl)),
                                   "reason": "no local region and no untangle of the whole shell was valid"})
                continue
            work = out
            actions[i].append({kk: info[kk] for kk in ("step", "rings", "extra_rings", "region_faces", "free_rows",
                                                      "split_rows") if kk in info}
                              | {"cluster_faces": int(len(cl)), "time": info["time"], "shell": int(k),
                                 **({"mirrored_shell": True} if flip else {})})
        UVw = work * np.array([-1.0, 1.0]) if flip else work
    return UVw, FUVw


def intended_overlaps(UV, FUV, shell, bad, graph, rings=3):
    """Pairs of the shell's faces that overlap on purpose: a repaired region may keep them.

    Two overlapping faces of which neither is broken overlap on purpose (a shell laid over itself); so do a
    broken face and a face more than ``rings`` rings away from it (the fold lies where the shell is stacked
    on another part of itself). A broken face over its near neighbours is the fold itself.
    """
    a, b = overlap_pairs(UV, FUV, shell)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keep = ~bad[lo] & ~bad[hi]
    for n in np.flatnonzero(~keep):
        i, j = (lo[n], hi[n]) if bad[lo[n]] else (hi[n], lo[n])
        near = np.zeros(graph.M.shape[1], bool)
        near[FUV[i]] = True
        for _ in range(rings):
            near = graph.grow(near)
        keep[n] = not near[FUV[j]].any()
    return set(zip(lo[keep].tolist(), hi[keep].tolist()))
