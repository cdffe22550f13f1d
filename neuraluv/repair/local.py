"""Local repair of folds: the smallest neighbourhood that works, everything else bit-identical.

For one cluster of folded faces (flipped or degenerate, joined through shared
``vt`` rows) of one island, :func:`repair_cluster` escalates and stops at the
first step that gives a valid region (every face ``det J > 0``, no triangle of
the region overlapping another of the island):

1. **untangle + polish** in a region grown ring by ring: the cluster's inner rows; then the rows the
   damage moved, read as the rows near the cluster whose every face is folded or more distorted than
   most faces further out; then 0, 1, 2, 3, 4, 6, 8, … rings of texture vertices around the cluster.
   The rows in the region move, its outer ring stays pinned; :func:`~neuraluv.repair.untangle.untangle`
   (Garanzha et al. 2021) removes the folds, :func:`~neuraluv.repair.untangle.polish` lowers the paper's
   stable objective with flip-free steps. The first region that works (unless it is the damaged rows, which
   already hold them) is then grown one ring at a time while the next ring holds damaged rows, is more
   distorted than the faces further out and growing lowers the distortion by more than 1% (rows the damage
   moved without folding them are freed too); when the polish stops on its iteration cap, the neural solver
   continues from it (step 2's solver);
2. **the neural solver on the region with its ring pinned**, from a Tutte map of the region inside its
   pinned ring (when that start is valid): the paper's SIREN reparameterization with LBO features, residual
   on the start, every step validity-checked; the pinned rows are held by a zero mask on the network's
   output (:class:`~neuraluv.solver.batch.ChartBatch`);
3. **the whole island, untangled** with a free boundary (every row moves);
4. otherwise the caller re-solves the whole island as a chart (the last resort).
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from neuraluv.layout.facts import face_clusters, no_3d_area, texel_density, uv_degenerate
from neuraluv.meshfix import normalize_unit_box
from neuraluv.metrics import corner_jacobians, face_dets, face_metrics
from neuraluv.repair.region import FAR_QUANTILE, _face_sd, _far_esd, region_esd, region_overlaps
from neuraluv.repair.untangle import budget_spent, polish, untangle
from neuraluv.solver.config import get_config
from neuraluv.topology import undirected_edges, unique_rows

__all__ = ["RING_SCHEDULE", "IslandGraph", "repair_cluster", "neural_region", "untangle_faces",
           "with_stretched_neighbours", "resolve_as_chart"]

#: Ring counts tried around a fold, in order.
RING_SCHEDULE = (0, 1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64)


class IslandGraph:
    """Face–row incidence of one island (or shell), for growing regions ring by ring.

    ``locked`` rows (a bool mask over all rows) are never freed: rows the island shares with faces
    outside it (another shell stacked on it) stay where they are.
    """

    def __init__(self, FUV, faces, n_rows, locked=None):
        self.faces = np.asarray(faces, np.int64)
        T = np.asarray(FUV, np.int64)[self.faces]
        self.M = sp.csr_matrix((np.ones(T.size), (np.repeat(np.arange(len(T)), 3), T.reshape(-1))),
                               shape=(len(T), n_rows))
        self.MT = self.M.T.tocsr()
        self.locked = np.zeros(n_rows, bool) if locked is None else np.asarray(locked, bool)

    def grow(self, rows_mask):
        """Rows of every island face touching ``rows_mask`` (locked rows excepted)."""
        f = (self.M @ rows_mask.astype(float)) > 0
        return ((self.MT @ f.astype(float)) > 0) & ~self.locked

    def faces_touching(self, rows_mask):
        """Island faces (global indices) with a corner in ``rows_mask``."""
        return self.faces[(self.M @ rows_mask.astype(float)) > 0]


def _hurt_rows(Vn, F, UV, FUV, graph, cluster, seed_rows, scale, band_tol, sign):
    """Rows near a fold cluster whose every face is damaged: folded, or more distorted than most faces further out.

    A fold's damage moves some rows; the faces around a moved row are folded or distorted, while a row it
    did not move has faces beyond the damage too. Freeing exactly these rows leaves every face the damage
    did not touch bit-identical. "Distorted" is the test the region growth uses (:func:`repair_cluster`):
    a face within two rings of the cluster whose E_SD is more than ``band_tol`` (relative) above the
    :data:`FAR_QUANTILE` quantile of the faces three to five rings out. ``sign`` ((m,) ±1): the orientation
    each face is valid in (a face valid reversed is measured mirrored).

    Returns
    -------
    (p,) bool array over the rows (locked rows never set)
    """
    near_rows = graph.grow(graph.grow(seed_rows))
    near = graph.faces_touching(near_rows)
    out = graph.grow(graph.grow(graph.grow(near_rows)))
    far = np.setdiff1d(graph.faces_touching(out), near)
    hurt = np.zeros(len(F), bool)
    hurt[cluster] = True
    if len(far):
        det, sd_all = _face_sd(Vn, F, UV, FUV, np.r_[near, far], scale, sign)
        det, sd, sd_far = det[:len(near)], sd_all[:len(near)], sd_all[len(near):]
        sd_far = sd_far[np.isfinite(sd_far)]
        if len(sd_far):
            with np.errstate(invalid="ignore"):
                bad = ~(det > 0) | ~np.isfinite(sd) | (sd > (1.0 + band_tol) * np.quantile(sd_far, FAR_QUANTILE))
            hurt[near[bad]] = True
    rows = np.zeros(len(UV), bool)
    rows[np.unique(FUV[graph.faces[hurt[graph.faces]]])] = True
    beyond = (graph.MT @ (~hurt[graph.faces]).astype(float)) > 0  # rows with a face that is not damaged
    return rows & ~beyond & ~graph.locked


def _tutte_inside(UV, FUV, faces, free):
    """Uniform Tutte map of the region's free rows with every other row of the region pinned (None if singular)."""
    T = FUV[faces]
    rows = np.unique(T)
    loc = np.searchsorted(rows, T)
    e = unique_rows(undirected_edges(loc)[1])
    n = len(rows)
    W = sp.coo_matrix((np.ones(2 * len(e)), (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])), shape=(n, n)).tocsr()
    L = sp.diags(np.asarray(W.sum(1)).ravel()) - W
    is_free = np.isin(rows, free)
    fi, pi = np.flatnonzero(is_free), np.flatnonzero(~is_free)
    if not len(pi):
        return None
    A = L[fi][:, fi].tocsc()
    b = -(L[fi][:, pi] @ UV[rows[pi]])
    try:
        x = np.column_stack([spsolve(A, b[:, 0]), spsolve(A, b[:, 1])])
    except Exception:  # noqa: BLE001 - singular: a free part not connected to the ring
        return None
    if not np.isfinite(x).all():
        return None
    out = UV.copy()
    out[rows[fi]] = x
    return out


def neural_region(Vn, F, UV, FUV, faces, free, scale, config="fast", *, seed=0, device="cpu", deadline=None):
    """The neural solver on a region, its non-free rows pinned, from the (valid) map ``UV``.

    Parameters
    ----------
    Vn : (n,3) float array
    F, FUV : (m,3) int arrays
    UV : (p,2) float array
        A map whose region faces are all valid: the residual base.
    faces : (r,) int array
        The region's faces; its rows that are not in ``free`` are pinned.
    free : (k,) int array
    scale : float
        Texel density (UV per 3D length) at which J is measured.
    config : str or SolverConfig
    seed : int
    device : str
    deadline : float, optional

    Returns
    -------
    UV : (p,2) float array
        A copy with the free rows from the solver's best valid map (unchanged if it found none).
    result : :class:`~neuraluv.solver.result.ChartResult`

    Notes
    -----
    The region's chart mesh has one vertex per ``vt`` row (at the 3D position of
    its first corner); the SIREN's inputs are its normalised positions and LBO
    eigenfunctions (paper Sec. 3), the residual base is ``UV / scale`` in the
    chart's normalised units, and the network's output is multiplied by 0 on the
    pinned rows, so they stay bit-identical.
    """
    from neuraluv.solver.chart import prepare_chart, solve_charts

    cfg = get_config(config)
    T = FUV[faces]
    rows = np.unique(T)
    Fc = np.searchsorted(rows, T)
    Vc = np.zeros((len(rows), 3))
    Vc[Fc.reshape(-1)[::-1]] = Vn[F[faces].reshape(-1)[::-1]]
    sv = normalize_unit_box(Vc)[2]  # the chart's units: the start is UV / scale in them
    # tiny regions: at most n - 2 eigenfunctions (prepare_chart pads the features to the preset's width)
    prep = prepare_chart(Vc, Fc, cfg, check=False, k=max(len(rows) - 2, 0),
                         start_uv=UV[rows] / (scale * sv), start_name="repair", free=np.isin(rows, free),
                         label="repair region")
    res = solve_charts(None, cfg, seed=seed, device=device, preps=[prep], deadline=deadline)[0]
    out = UV.copy()
    if res.metrics["valid"] and res.status == "neural":
        new = res.uv * scale  # res.uv is in the chart's units (u · sv)
        fr = np.isin(rows, free)
        out[rows[fr]] = new[fr]
    return out, res


def _try_neural(Vn, F, UV, FUV, region, free, scale, config, seed, device, deadline):
    """:func:`neural_region`, or ``(UV, None)`` when the region cannot be prepared (a degenerate region mesh)."""
    try:
        return neural_region(Vn, F, UV, FUV, region, free, scale, config, seed=seed, device=device, deadline=deadline)
    except (ValueError, ArithmeticError, RuntimeError, np.linalg.LinAlgError):
        return UV, None


def repair_cluster(Vn, F, UV, FUV, graph, cluster, scale, *, config="fast", seed=0, device="cpu", deadline=None,
                   max_fraction=0.5, max_rings=None, min_rings=None, neural=True, max_extra_rings=8, grow_gain=0.01,
                   band_tol=0.1, allowed=None, sign=None, group=None):
    """Repair one fold cluster in the smallest region that works (see the module docstring).

    Parameters
    ----------
    Vn : (n,3) float array
    F, FUV : (m,3) int arrays
    UV : (p,2) float array
        The layout (not modified).
    graph : IslandGraph
        The island the cluster belongs to.
    cluster : (c,) int array
        Folded faces (and faces that must become valid).
    scale : float
        The island's texel density: the fallback when the region and the two
        rings around it have no valid face. Each attempt measures the density
        of that neighbourhood (:func:`~neuraluv.layout.facts.texel_density`)
        and untangles, polishes and compares at it.
    config, seed, device, deadline
        For the neural step.
    max_fraction : float
        Stop growing rings when the region holds more than this fraction of the island.
    max_rings, min_rings : int, optional
        Nor try more than ``max_rings`` rings around the cluster; with ``min_rings``, only regions of at least
        that many rings (the smaller ones were tried before).
    neural : bool
        Allow the neural steps.
    max_extra_rings, grow_gain, band_tol : int, float, float
        After the first region that works, grow it one ring at a time (at most
        ``max_extra_rings``) while the next ring holds a damaged row (:func:`_hurt_rows`, whose test
        ``band_tol`` also sets), its faces are more than ``band_tol`` (relative) more distorted than most
        faces two to four rings out (their :data:`FAR_QUANTILE` quantile), and growing lowers the energy
        over the grown region and one ring beyond by more than ``grow_gain``: rows the damage moved
        without folding are freed too, but a layout that was merely not optimal is not "improved" beyond
        its neighbourhood's quality.
    allowed : set of (int, int), optional
        Face pairs of the island that overlap on purpose (:func:`region_overlaps`): a repaired
        region may keep them, but makes no other overlap.
    sign, group : (m,) arrays, optional
        For a region across shells of both orientations (two mirrored halves joined at a seam): -1 where a
        face is valid reversed (:meth:`~neuraluv.repair.untangle.RegionEnergy.build`), and each face's shell
        (only overlaps within a shell count). No neural step and no growth past the first valid region then.

    Returns
    -------
    UV : (p,2) float array or None
        The repaired copy (None: escalate to the whole island).
    info : dict
        ``step``, ``rings`` (the first region that worked: -1 the rows inside the cluster, -2 the damaged rows,
        else the rings around the cluster), ``extra_rings`` (grown after it), ``region_faces``, ``free_rows``,
        ``time``, and the sub-steps' details.
    """
    t0 = time.perf_counter()
    n_rows = len(UV)
    island = graph.faces
    if sign is not None:  # the distortion measures take every reversed face for a fold: nothing to grow by
        neural, max_extra_rings = False, 0
    sgn = np.ones(len(F)) if sign is None else np.asarray(sign, float)
    seed_rows = np.zeros(n_rows, bool)
    seed_rows[np.unique(FUV[cluster])] = True
    seed_rows &= ~graph.locked
    if not seed_rows.any():
        return None, {"step": "escalate", "reason": "every row of the cluster is shared with another shell",
                      "tried": [], "time": time.perf_counter() - t0}

    def local_scale(rows):
        """Texel density of the region and two rings around it: a layout's density may vary over an island
        (a conformal map shrinks protrusions), and the pinned ring fixes the room the region has."""
        near = graph.faces_touching(graph.grow(graph.grow(rows)))
        d = texel_density(Vn, F[near], UV, FUV[near])
        return d if np.isfinite(d) else scale

    def valid(U, faces):
        """Every face of ``faces`` oriented as it should be and not collapsed (check's test, not det J > 0 alone)."""
        d = face_dets(Vn, F[faces], U, FUV[faces]) * sgn[faces]
        return bool(((d > 0) & ~uv_degenerate(U, FUV[faces], d)).all())

    def attempt(rows):
        """Untangle + polish with ``rows`` free: ``(map or None, details)``."""
        free = np.flatnonzero(rows)
        region = graph.faces_touching(rows)
        region = region[~no_3d_area(Vn, F[region])]  # no 3D area: no distortion to untangle
        sc = local_scale(rows)
        rest = np.setdiff1d(cluster, region)  # cluster faces with no free row: they stay as they are
        if len(rest) and not valid(UV, rest):
            return None, {"region": region, "free": free, "untangle": {"ok": False}, "overlaps": -1, "scale": sc,
                          "why": "cluster faces outside the region are still folded"}
        out, uinfo = untangle(Vn, F, UV, FUV, region, free, scale=sc, deadline=deadline, sign=sign)
        ov = region_overlaps(out, FUV, region, island, allowed, group) if uinfo["ok"] else -1
        det = {"region": region, "free": free, "untangle": uinfo, "overlaps": ov, "scale": sc}
        if not (uinfo["ok"] and valid(out, region)):  # a face on pinned rows that coincide stays collapsed
            det["untangle"] = {**uinfo, "ok": False}
            return None, det
        out2, pinfo = polish(Vn, F, out, FUV, region, free, scale=sc, deadline=deadline, sign=sign)
        ov2 = region_overlaps(out2, FUV, region, island, allowed, group)
        det["polish"] = pinfo
        ok2 = ov2 == 0 and valid(out2, region)
        if ov == 0:
            return (out2 if ok2 else out), det  # the polish moved a triangle over another: keep the untangled map
        # untangled but overlapping (a stretched rim laid over the island): the polish pulls it back, or fails
        det["overlaps"] = ov2
        return (out2 if ok2 else None), det

    # first the cluster's inner rows only (every face around them is in the cluster): a fold's damage is often
    # just those, and freeing them leaves the cluster's rim rows, and every face beyond, bit-identical
    in_cluster = np.zeros(len(F), bool)
    in_cluster[cluster] = True
    outside = (graph.MT @ (~in_cluster[graph.faces]).astype(float)) > 0  # rows of a face outside the cluster
    inner = seed_rows & ~outside
    hurt = inner | _hurt_rows(Vn, F, UV, FUV, graph, cluster, seed_rows, local_scale(seed_rows), band_tol, sgn)
    schedule = ([-1] if inner.any() and (inner != seed_rows).any() else []) \
        + ([-2] if (hurt != inner).any() and (hurt != seed_rows).any() else []) \
        + [r for r in RING_SCHEDULE if max_rings is None or r <= max_rings]
    if min_rings is not None:
        schedule = [r for r in schedule if r >= min_rings]
    rows = seed_rows.copy()
    done_r = 0
    last = None
    tried = []
    found = None
    for r in schedule:
        if budget_spent(deadline):  # the time budget: no larger region is tried (the caller reports it)
            return None, {"step": "budget", "reason": "the time budget was spent", "tried": tried,
                          "time": time.perf_counter() - t0}
        if r < 0:
            rows = (inner if r == -1 else hurt).copy()
        else:
            if done_r < 0:
                rows, done_r = seed_rows.copy(), 0
            for _ in range(r - done_r):
                rows = graph.grow(rows)
        done_r = r
        region = graph.faces_touching(rows)
        whole = len(region) == len(island) and not (graph.grow(rows) & ~rows).any()
        if len(region) > max_fraction * len(island) and last is not None:
            if r == -2:
                continue  # the damaged rows reach far: the rings around the cluster are tried next
            break
        try:
            out, det = attempt(rows)
        except ValueError as exc:  # degenerate 3D faces in the region
            return None, {"step": "failed", "reason": str(exc), "time": time.perf_counter() - t0}
        last = (r, det["region"], det["free"], det["scale"])
        tried.append({"rings": r, "region_faces": int(len(det["region"])), "untangled": det["untangle"]["ok"],
                      "overlaps": det["overlaps"]})
        if out is not None:
            found = (r, rows, out, det, whole)
            break
        if whole:
            break
    if found is not None:
        # grow further while it pays: rows moved by the damage but not folded are still pinned at their damaged
        # places; one more ring frees them. Keep a larger region only if it lowers the energy (over the larger
        # region and one ring beyond, the same faces for both) by more than ``grow_gain``.
        r, rows, out, det, whole = found
        extra = 0
        # the damaged rows themselves (r = -2) already hold every row the damage moved around the fold
        while r != -2 and not whole and extra < max_extra_rings and not budget_spent(deadline):
            bigger = graph.grow(rows)
            region_b = graph.faces_touching(bigger)
            if len(region_b) > max_fraction * len(island) or (bigger == rows).all():
                break
            if not (bigger & hurt & ~rows).any():
                break  # no row the damage moved is left pinned in the next ring: growing would only "improve"
            # grow only while the damage goes on: the faces of the next ring (area-weighted mean) are more distorted
            # than most faces further out (the FAR_QUANTILE quantile over rings 2-4: a quantile, as the damage may
            # reach there too, and an upper one, as an artist's layout has distorted parts of its own) by more than
            # ``band_tol``; otherwise growing would only "improve" the user's layout, not repair it
            region, sc = det["region"], det["scale"]
            near = graph.faces_touching(bigger)
            ring = np.setdiff1d(near, region)
            far = np.setdiff1d(graph.faces_touching(graph.grow(graph.grow(graph.grow(bigger)))), near)
            if len(ring) and len(far) and region_esd(Vn, F, out, FUV, ring, sc) <= (1.0 + band_tol) * _far_esd(
                    Vn, F, out, FUV, far, sc):
                break
            out_b, det_b = attempt(bigger)
            if out_b is None:
                break
            S = graph.faces_touching(graph.grow(bigger))
            e_old, e_new = region_esd(Vn, F, out, FUV, S, sc), region_esd(Vn, F, out_b, FUV, S, sc)
            if not e_new < (1.0 - grow_gain) * e_old:
                break
            rows, out, det, extra = bigger, out_b, det_b, extra + 1
            whole = len(region_b) == len(island) and not (graph.grow(rows) & ~rows).any()
        region, free, sc = det["region"], det["free"], det["scale"]
        step = "untangle+polish"
        if neural and not det["polish"]["converged"] and not whole:
            out3, res = _try_neural(Vn, F, out, FUV, region, free, sc, config, seed, device, deadline)
            if (res is not None and res.status == "neural" and region_overlaps(out3, FUV, region, island, allowed) == 0
                    and region_esd(Vn, F, out3, FUV, region, sc) < region_esd(Vn, F, out, FUV, region, sc)):
                out, step = out3, "untangle+polish+neural"
        return out, {"step": step, "rings": r, "extra_rings": extra, "region_faces": int(len(region)),
                     "free_rows": int(len(free)), "whole_island": bool(whole), "untangle": det["untangle"],
                     "polish": det["polish"], "tried": tried, "time": time.perf_counter() - t0}
    if neural and last is not None:
        r, region, free, sc = last
        start = _tutte_inside(UV, FUV, region, free)
        if start is not None and valid(start, region) and region_overlaps(start, FUV, region, island, allowed) == 0:
            out, res = _try_neural(Vn, F, start, FUV, region, free, sc, config, seed, device, deadline)
            out = out if (res is not None and res.status == "neural" and valid(out, region)) else start
            if region_overlaps(out, FUV, region, island, allowed) == 0:
                return out, {"step": "neural (ring pinned)", "rings": r, "region_faces": int(len(region)),
                             "free_rows": int(len(free)), "tried": tried, "time": time.perf_counter() - t0}
    return None, {"step": "escalate", "tried": tried, "time": time.perf_counter() - t0}


def untangle_faces(Vn, F, UV, FUV, faces, rows, density, allowed=None, deadline=None):
    """Untangle ``faces`` with ``rows`` free (then polish); ``(UV, info)`` or ``(None, info)`` when not valid."""
    t0 = time.perf_counter()
    if not len(rows):
        return None, {"ok": False}
    try:
        out, info = untangle(Vn, F, UV, FUV, faces, rows, scale=density, deadline=deadline)
    except ValueError:
        return None, {"ok": False}
    if not info["ok"]:
        return None, info
    ov = region_overlaps(out, FUV, faces, faces, allowed)
    out2, _ = polish(Vn, F, out, FUV, faces, rows, scale=density, deadline=deadline)
    if region_overlaps(out2, FUV, faces, faces, allowed):
        if ov:  # overlapping before the polish and after it
            return None, {**info, "overlaps": ov}
        out2 = out
    return out2, {"step": "untangle whole shell", "free_rows": int(len(rows)), "time": time.perf_counter() - t0}


def with_stretched_neighbours(Vn, F, UV, FUV, island, targets, *, factor=4.0, rings=2):
    """``targets`` plus the severely stretched faces joined to them: a fold's damage beyond its flipped faces.

    A face is severely stretched when its conformal distortion σ_max/σ_min (scale-free, so a conformal map's
    shrunken parts do not count) is above ``factor`` and above ``factor`` times the island's median. Only
    such faces connected (through shared ``vt`` rows, via other such faces) to a target are added; a
    stretched face elsewhere is the layout's own and stays untouched. Where such faces would join several
    folds into one cluster, only those within ``rings`` rings (of ``vt`` rows) of a target are added: a band
    the layout stretches on purpose (the rows around a pole of a latitude-longitude map) does not make every
    fold along it one cluster.
    """
    ok = np.setdiff1d(island, targets)
    if not len(ok):
        return targets
    conf = face_metrics(corner_jacobians(Vn, F[ok], UV, FUV[ok])[0])["conformal"]
    fin = conf[np.isfinite(conf)]
    stretched = ok[conf > factor * max(1.0, float(np.median(fin)))] if len(fin) else ok[:0]
    if not len(stretched):
        return targets
    own = np.zeros(len(F), np.int64)
    for n, c in enumerate(face_clusters(FUV, targets)):
        own[c] = n
    keep, near = [], None
    for c in face_clusters(FUV, np.concatenate([targets, stretched])):
        t = c[np.isin(c, targets)]
        if len(np.unique(own[t])) > 1:  # several folds joined through stretched faces: only those near one
            if near is None:
                graph = IslandGraph(FUV, island, len(UV))
                near = np.zeros(len(UV), bool)
                near[np.unique(FUV[targets])] = True
                for _ in range(rings):
                    near = graph.grow(near)
            c = np.union1d(t, c[near[FUV[c]].all(1)])
        keep.append(c[:0] if not len(t) else c)
    return np.unique(np.concatenate(keep))


def resolve_as_chart(Vn, F, UV, FUV, faces, density, cfg, *, seed, device, deadline):
    """Re-solve an island (or shell) as a chart by the atlas router, at ``density``, fitted back to where it was.

    The last resort of a repair: every row of ``faces`` changes. Faces without 3D area are left out (their
    UVs stay, as ``check --uv`` says: no map of a chart is defined on them). When the router returns one
    piece on the same rows they are overwritten in place; otherwise (always where a face's corners share a row: a
    collapse, charted on the mesh's vertices) the pieces get new rows.

    Returns
    -------
    UV, FUV : the layout with the island re-solved
    info : dict, ``step``, ``pieces``, ``routes``, ``time``
    """
    from neuraluv.atlas.candidates import chart_candidates
    from neuraluv.atlas.routing import route_charts
    from neuraluv.layout.rigid import rigid_fit

    t0 = time.perf_counter()
    all_rows = np.unique(FUV[faces])
    faces = faces[~no_3d_area(Vn, F[faces])]
    pieces, routes, by_vertex = [], [], False
    if len(faces):
        by_vertex = bool((FUV[faces] == FUV[faces][:, [1, 2, 0]]).any())
        T = (F if by_vertex else FUV)[faces]
        rows = np.unique(T)
        Fc = np.searchsorted(rows, T)
        Vc = np.zeros((len(rows), 3))
        Vc[Fc.reshape(-1)[::-1]] = Vn[F[faces].reshape(-1)[::-1]]
        for ch in route_charts(Vc, Fc, chart_candidates(Vc, Fc), cfg, seed=seed, device=device, deadline=deadline):
            routes.append({"route": ch.route, "method": ch.method, "reason": ch.reason})
            for fl, vl, Fl, uv in ch.islands:
                new = np.asarray(uv, float) * density
                old = np.full((len(vl), 2), np.nan) if by_vertex else UV[rows[vl]]
                okp = np.isfinite(old).all(1) & np.isfinite(new).all(1)
                if okp.sum() >= 2:
                    R, _, t = rigid_fit(new[okp], old[okp])
                    new = new @ R + t
                pieces.append((faces[fl], new, Fl, rows[vl]))
    UVo, FUVo = UV.copy(), FUV.copy()
    if len(pieces) == 1 and not by_vertex and np.array_equal(np.sort(pieces[0][3]), all_rows):
        fidx, new, Fl, vrows = pieces[0]
        UVo[vrows] = new  # same rows, same faces: overwrite in place
        FUVo[fidx] = vrows[Fl]
    else:
        for fidx, new, Fl, _ in pieces:
            base = len(UVo)
            UVo = np.vstack([UVo, new])
            FUVo[fidx] = Fl + base
    return UVo, FUVo, {"step": "re-solved as a chart", "pieces": len(pieces), "routes": routes,
                       "time": time.perf_counter() - t0}
