"""Atlas step 3: route each disk-like candidate — exact unfold, the neural solver, or a marked fallback.

* A candidate without interior vertices (a strip or fan of triangles: its dual
  graph is a tree, so it has zero curvature everywhere) is **unfolded
  exactly** (:func:`unfold_tree`): an isometry, E_SD = 4, no solver needed. So is a
  flat candidate whose solver start is already an isometry (:data:`ISOMETRIC_START`).
* Every other candidate goes to the **neural solver**; all of them are solved
  together in batches (:func:`neuraluv.solver.solve_charts`), each with its
  own network, seeds and retries. Each network is attached to the chart's Tutte
  map moved on by at most :data:`START_SLIM` SLIM iterations while it stays
  injective (the solver's ``start_slim``; not in the paper, whose start is the
  Tutte map): atlas candidates are near-developable and their Tutte circles far
  from them.
* A neural map without flips whose boundary crosses itself (the solver's stop
  test sees distortion, not the boundary) is **solved on** from where it stopped
  for :data:`CONTINUE_STEPS` more validated steps before anything else.
* A candidate whose neural map is invalid (flips, or a boundary that crosses
  itself) is bisected and routed again, then becomes a **marked fallback** (PCA → Tutte + SLIM → split into
  halves → per-face), with its reason.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from neuraluv.atlas.candidates import chart_mesh, split_into_disks
from neuraluv.jacobian import local_frames
from neuraluv.layout.overlap import boundary_is_simple, self_overlap
from neuraluv.metrics import ESD_ISOMETRY, distortion_metrics, is_valid
from neuraluv.relax import slim_relax_while
from neuraluv.solver.config import get_config
from neuraluv.topology import bisect_faces, boundary_loop, submesh
from neuraluv.tutte import tutte

#: Route codes of ``AtlasResult.face_route``.
ROUTES = {"fallback": 0, "neural": 1, "exact": 2}

#: SLIM iterations at most of a fallback's Tutte map (:func:`tutte_slim_uv`).
TUTTE_SLIM_ITERATIONS = 20

#: SLIM iterations at most that move each neural chart's Tutte start towards its flattening while it stays injective
#: (the solver's ``start_slim``, :func:`route_charts`). On the 64 neural charts of cow's atlas: 8,015 -> 5,738 steps
#: and solves 13.2 -> 11.1 s (+1.1 s to prepare), face-weighted E_SD 4.01280 -> 4.01285; on chair_model's 87 new
#: charts 9,655 -> 5,375 steps, 10.6 -> 4.9 s (+1.0 s), E_SD 4.0001 both (one process, 2 threads, alone).
START_SLIM = 10

#: A neural candidate whose prepared start (the Tutte map moved on by SLIM, :data:`START_SLIM`) is already an
#: isometry to this relative tolerance of E_SD = 4 — a flat chart — is routed exact with it (method
#: ``"isometric-start"``): no network step can improve on it, and the solver would call it stalled.
ISOMETRIC_START = 1e-6

#: Largest E_SD of a fallback's Tutte + SLIM island before the chart is bisected instead
#: (:func:`fallback_islands`; an isometry has 4, the neural charts of our benchmarks 4–6).
FALLBACK_MAX_ESD = 8.0

#: Validated steps a flip-free neural map whose boundary crosses itself is solved on from
#: where it stopped, once, before its chart is split (:func:`route_charts`). On the atlases of
#: cow, spot and fertility this resolved 2 of the 3 such charts in under 1 s in all.
CONTINUE_STEPS = 200

#: Rounds between two checks of a solve-on's best map: it ends once the boundary no longer crosses itself.
CONTINUE_CHECK = 10

#: The start of a split chart's piece that is injective on the chart's neural map (:func:`_on_parent`).
PARENT_START = "split chart's map"

__all__ = ["AtlasChart", "CONTINUE_STEPS", "ISOMETRIC_START", "ROUTES", "START_SLIM", "pca_uv", "per_face_uv",
           "unfold_tree", "tutte_slim_uv", "fallback_islands", "route_charts", "route_chart"]


def pca_uv(V, F):
    """Project a chart on its two principal axes, oriented like its faces.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array

    Returns
    -------
    UV : (n,2) float array (at 3D scale)

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> distortion_metrics(V, np.array([[0, 1, 2]]), pca_uv(V, np.array([[0, 1, 2]])))["flips"]
    0
    """
    V = np.asarray(V, float)
    X = V - V.mean(0)
    _, _, vt = np.linalg.svd(X, full_matrices=False)
    a, b = vt[0], vt[1] if len(vt) > 1 else np.array([0.0, 1.0, 0.0])
    nrm = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]).sum(0)
    if np.dot(np.cross(a, b), nrm) < 0:
        b = -b
    return np.column_stack([X @ a, X @ b])


def per_face_uv(V, F):
    """Each triangle laid out isometrically on its own (flip-free; a face without 3D area: a point).

    Returns
    -------
    list of (3,2) float arrays, one per face (corners in face order).
    """
    dCi, _ = local_frames(V, F)
    ok = np.isfinite(dCi).all(axis=(1, 2))
    ok[ok] = np.linalg.det(dCi[ok]) != 0
    C = np.zeros_like(dCi)
    C[ok] = np.linalg.inv(dCi[ok])  # columns: c_j - c_i, c_k - c_i
    return [np.array([[0.0, 0.0], C[t][:, 0], C[t][:, 1]]) for t in range(len(F))]


@dataclass
class AtlasChart:
    """One chart candidate and where it was routed.

    Attributes
    ----------
    faces : (k,) int array, faces of the repaired mesh.
    route : ``"neural"``, ``"exact"`` or ``"fallback"``.
    method : ``"neural"``, ``"exact-unfold"``, ``"isometric-start"``, ``"slim-start"`` (a fallback: the network
        found nothing better than its start), ``"pca"``, ``"tutte-slim"``, ``"split"``, ``"per-face"``.
    reason : why a fallback was used (empty otherwise).
    source : how the candidate arose (component, xatlas seams, split).
    islands : list of ``(fidx, vidx, Fl, uv)``: faces, vertices, local faces and
        UVs (3D scale) of each packed island (one for neural charts).
    metrics : chart metrics (:func:`distortion_metrics`) at 3D scale over all islands.
    time : seconds spent routing the chart.
    solver : summary of the last neural attempt (``ChartResult.summary()``) or None.
    """

    faces: np.ndarray
    route: str
    method: str
    reason: str
    source: str
    islands: list
    metrics: dict = field(default_factory=dict)
    time: float = 0.0
    solver: dict | None = None

    def summary(self, i):
        return {
            "chart": i, "faces": int(len(self.faces)), "islands": len(self.islands), "route": self.route,
            "method": self.method, "reason": self.reason, "source": self.source, "metrics": self.metrics,
            "time": self.time, "solver": self.solver,
        }


def tutte_slim_uv(V, F, fidx, iterations=TUTTE_SLIM_ITERATIONS):
    """A chart's Tutte map relaxed by SLIM for as long as it stays injective, or None.

    The uniform Tutte map of the chart's filled disk (:func:`chart_mesh`) on a circle
    is injective (Tutte's theorem; checked, since floating point can crush faces);
    SLIM iterations (:func:`~neuraluv.relax.slim_relax_while`, flip-free by its line
    search) then lower the distortion one at a time, and the last iterate whose
    boundary does not cross itself is kept.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    fidx : (k,) int array, the chart's faces
    iterations : int
        SLIM iterations at most.

    Returns
    -------
    (vi, Fl, uv) : the chart's local vertices (global indices), faces and UVs (3D
        scale), as :func:`chart_mesh` numbers them; None when even the Tutte map is not
        injective (e.g. the chart is not a disk).

    Notes
    -----
    SLIM minimises the symmetric Dirichlet energy (paper Eq. 1) and never crosses a
    flip, but like the neural solver it can let the free boundary run over itself;
    the boundary check after each iteration (:func:`boundary_is_simple`, on the filled
    disk) stops it before that.

    Examples
    --------
    >>> from neuraluv.datasets import saddle
    >>> V, F = saddle(6)
    >>> vi, Fl, uv = tutte_slim_uv(V, F, np.arange(len(F)))
    >>> m = distortion_metrics(V[vi], Fl, uv); m["flips"], bool(m["esd"] < 4.2)
    (0, True)
    """
    vi, Fl, Vx, Fx = chart_mesh(V, F, fidx)
    Vc, Fc = np.vstack([np.asarray(V, float)[vi], Vx]), np.vstack([Fl, Fx]).astype(np.int64)

    def injective(uv):  # no flip and a simple outer boundary: injective on the filled disk
        return is_valid(Vc, Fc, uv) and boundary_is_simple(uv, Fc)

    try:
        uv = tutte(Vc, Fc)
        if not injective(uv):
            return None
        uv = slim_relax_while(Vc, Fc, uv, injective, iterations)[0]
    except Exception:  # noqa: BLE001 - a degenerate chart (no boundary, singular system): no such island
        return None
    uv = uv[:len(vi)]  # the fillers' vertices come last: dropped
    return (vi, Fl, uv) if self_overlap(uv, Fl) == 0.0 else None


def fallback_islands(V, F, fidx, why, depth=0, max_esd=FALLBACK_MAX_ESD):
    """A marked fallback: PCA → Tutte + SLIM → split into halves (the same chain on each) → per-face islands.

    A chart whose PCA projection folds or overlaps stays one island when its
    :func:`tutte_slim_uv` map is injective with E_SD ≤ ``max_esd``; otherwise it is
    bisected and each half goes through the chain again (a fallback's many small
    islands are what generated meshes suffer from most).

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    fidx : (k,) int array, the chart's faces
    why : str, the reason recorded (returned unchanged)
    depth : int, bisections so far (single faces after 6)
    max_esd : float
        Largest symmetric Dirichlet energy (area-weighted mean) of a Tutte + SLIM island.

    Returns
    -------
    method : ``"pca"``, ``"tutte-slim"``, ``"split"`` (halves, each PCA, Tutte + SLIM or split
        again) or ``"per-face"``
    islands : list of ``(fidx, vidx, Fl, uv)`` (see :class:`AtlasChart`)
    why : the reason passed in
    """
    vi, Fl = submesh(F, fidx)
    uv = pca_uv(V[vi], Fl)
    m = distortion_metrics(V[vi], Fl, uv)
    if m["valid"] and self_overlap(uv, Fl) == 0.0:
        return "pca", [(fidx, vi, Fl, uv)], why
    if len(fidx) > 1:
        found = tutte_slim_uv(V, F, fidx)
        if found is not None and distortion_metrics(np.asarray(V, float)[found[0]], *found[1:])["esd"] <= max_esd:
            return "tutte-slim", [(fidx, *found)], why
    if depth < 6 and len(fidx) > 1:
        out = []
        for p in bisect_faces(V, F, fidx):
            out += fallback_islands(V, F, p, why, depth + 1, max_esd)[1]
        return "split", out, why
    out = []
    for f, uvf in zip(fidx, per_face_uv(V, F[fidx])):
        out.append((np.array([f]), F[f].copy(), np.array([[0, 1, 2]]), uvf))
    return "per-face", out, why


def unfold_tree(V, F):
    """Isometric unfold of a chart without interior vertices (a strip or fan of triangles).

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
        A disk-like chart whose every vertex is on the boundary.

    Returns
    -------
    UV : (n,2) float array or None
        Each triangle keeps its 3D edge lengths (det J = 1, E_SD = 4 exactly) and
        its orientation; None when the chart has an interior vertex.

    Notes
    -----
    With no interior vertex, a disk's faces and interior edges form a tree
    (Euler: ``E_int = m − 1``), so laying the first triangle down and each
    neighbour across its shared edge places every vertex exactly once. The
    result is locally injective; whether its boundary crosses itself is checked
    separately (:func:`boundary_is_simple`).

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 1]])
    >>> F = np.array([[0, 1, 2], [0, 2, 3]])
    >>> UV = unfold_tree(V, F)
    >>> m = distortion_metrics(V, F, UV); round(m["esd"], 12), m["flips"]
    (4.0, 0)
    """
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    bnd = boundary_loop(F) if len(F) > 1 else F[0]
    if len(np.unique(F)) != len(bnd):
        return None
    edge_faces = {}
    for f, (a, b, c) in enumerate(F):
        for u, v in ((a, b), (b, c), (c, a)):
            edge_faces.setdefault((min(u, v), max(u, v)), []).append(f)
    UV = np.full((len(V), 2), np.nan)
    a, b, c = F[0]
    lab, lac = np.linalg.norm(V[b] - V[a]), np.linalg.norm(V[c] - V[a])
    e1, e2 = V[b] - V[a], V[c] - V[a]
    x = float(e2 @ e1) / max(lab, 1e-300)
    UV[a], UV[b], UV[c] = (0.0, 0.0), (lab, 0.0), (x, np.sqrt(max(lac * lac - x * x, 0.0)))
    placed = np.zeros(len(F), bool)
    placed[0] = True
    queue = [0]
    while queue:
        f = queue.pop()
        tri = F[f]
        for k in range(3):
            u, v = tri[k], tri[(k + 1) % 3]
            for g in edge_faces[(min(u, v), max(u, v))]:
                if placed[g]:
                    continue
                placed[g] = True
                queue.append(g)
                w = [t for t in F[g] if t != u and t != v][0]
                if np.isnan(UV[w, 0]):
                    UV[w] = _apex(V, F[g], w, UV)
    if not (placed.all() and np.isfinite(UV).all()):
        return None
    return UV if distortion_metrics(V, F, UV)["valid"] else None


def _apex(V, face, w, UV):
    """Place vertex ``w`` of ``face`` from its two placed neighbours, keeping the face counter-clockwise."""
    i = int(np.flatnonzero(face == w)[0])
    p, q = face[(i + 1) % 3], face[(i + 2) % 3]          # face order (w, p, q): counter-clockwise
    P, Q = UV[p], UV[q]
    d = Q - P
    L = float(np.hypot(*d))
    rp, rq = np.linalg.norm(V[w] - V[p]), np.linalg.norm(V[w] - V[q])
    t = (rp * rp - rq * rq + L * L) / (2 * L * L)
    h = np.sqrt(max(rp * rp - (t * L) ** 2, 0.0)) / L
    # (w, p, q) counter-clockwise ⇔ (p, q, w) counter-clockwise ⇔ w lies left of the directed edge p → q
    return P + t * d + h * np.array([-d[1], d[0]])


def _finish(chart, V, t0):
    """Chart metrics over its islands (exploded, so islands are independent) and the routing time."""
    Vx = np.vstack([V[isl[1]] for isl in chart.islands])
    off = np.cumsum([0] + [len(isl[1]) for isl in chart.islands])
    Fx = np.vstack([isl[2] + o for isl, o in zip(chart.islands, off[:-1])])
    Ux = np.vstack([isl[3] for isl in chart.islands])
    chart.metrics = distortion_metrics(Vx, Fx, Ux)
    chart.time = time.perf_counter() - t0
    return chart


def route_charts(V, F, candidates, config="fast", *, seed=0, device="cpu", deadline=None, progress=False, splits=2,
                 start_slim=START_SLIM):
    """Route disk-like candidates: exact unfold, neural (batched), or a marked fallback.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    candidates : list of (fidx, source)
        Face sets of disk-like charts (e.g. :func:`~neuraluv.atlas.candidates.chart_candidates` of the
        same ``V, F``, whose chart meshes are reused).
    config : str or SolverConfig
        The neural solver's preset (its retries apply per chart).
    seed : int
    device : str
    deadline : float, optional
        ``time.perf_counter()`` value: solves still running then stop with their best valid map;
        charts not started become marked fallbacks ("time budget").
    progress : bool
    splits : int
        A candidate whose neural map is invalid or overlaps itself is bisected into
        disk-like halves that are routed again, up to this many times, before it
        becomes a marked fallback.
    start_slim : int or None
        The solver's ``start_slim`` for these charts (None: the config's own, 0 for every preset).

    Returns
    -------
    list of AtlasChart
        In the order of the candidates, a split candidate replaced by its pieces
        (every face is in exactly one chart).

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> from neuraluv.solver.config import get_config
    >>> V, F = spherical_cap(n_rings=4)
    >>> c = route_charts(V, F, [(np.arange(len(F)), "component"), (np.array([0]), "split")], get_config("test"))
    >>> [(x.route, x.method, x.metrics["flips"]) for x in c]
    [('neural', 'neural', 0), ('exact', 'exact-unfold', 0)]
    """
    from neuraluv.solver.chart import prepare_charts, solve_charts

    cfg = get_config(config)
    if start_slim is not None:
        cfg = replace(cfg, start_slim=int(start_slim))
    t0 = time.perf_counter()
    done, todo = [], [(np.asarray(f, np.int64), s, None) for f, s in candidates]
    known = [getattr(c, "mesh", None) for c in candidates]  # the chart meshes the candidates' disk tests built
    for level in range(splits + 1):
        out, retry = _route_round(V, F, todo, cfg, seed, device, deadline, progress and level == 0, t0,
                                  prepare_charts, solve_charts, last=level == splits,
                                  known=known if level == 0 else None)
        done += [c for c in out if c is not None]
        todo = []
        for fidx, src, why, parent in retry:
            if len(fidx) < 2:
                method, islands, reason = fallback_islands(V, F, fidx, why)
                done.append(_finish(AtlasChart(fidx, "fallback", method, reason, src, islands), V, t0))
                continue
            todo += [(p, f"{src}; split after: {why}", parent) for p, _ in split_into_disks(V, F, fidx)]
        if not todo:
            break
    order = {tuple(np.asarray(f, np.int64)[:1]): i for i, (f, _) in enumerate(candidates) if len(f)}
    done.sort(key=lambda c: order.get(tuple(c.faces[:1]), len(candidates)))
    return done


def _route_round(V, F, todo, cfg, seed, device, deadline, progress, t0, prepare_charts, solve_charts, last, known=None):
    """One routing round; returns (charts, [(fidx, source, why, parent) to split and retry]).

    ``todo`` holds ``(fidx, source, parent)``: ``parent`` is None, or the flip-free neural map of the chart a
    piece was split from, which the piece's solve starts from where it is injective (:func:`_on_parent`)."""
    out = [None] * len(todo)
    retry, retried = [], set()
    idx, preps, why = [], [], {}
    known = known or [None] * len(todo)
    meshes = [m if m is not None else chart_mesh(V, F, fidx)   # bow-ties split, holes filled (fillers dropped later)
              for (fidx, _, _), m in zip(todo, known)]
    need = []
    for k, (fidx, src, parent) in enumerate(todo):
        vi, Fl, Vx, Fx = meshes[k]
        uv = unfold_tree(V[vi], Fl) if len(Fx) == 0 else None
        if uv is not None and boundary_is_simple(uv, Fl):
            out[k] = _finish(AtlasChart(fidx, "exact", "exact-unfold", "", src, [(fidx, vi, Fl, uv)]), V, t0)
            continue
        if uv is not None:
            why[k] = "exact unfold overlaps itself; "
        need.append(k)
    # features and starts of every chart at once, over the solver's batch workers
    prepared = prepare_charts([(np.vstack([V[meshes[k][0]], meshes[k][2]]), np.vstack([meshes[k][1], meshes[k][3]]))
                               for k in need], cfg, labels=[f"chart {k}" for k in need], check=False, errors="return",
                              starts=[_on_parent(V, todo[k][0], meshes[k], todo[k][2]) for k in need],
                              start_name=PARENT_START)
    for k, prep in zip(need, prepared):
        fidx, src, _ = todo[k]
        vi, Fl, _, _ = meshes[k]
        if isinstance(prep, Exception):  # degenerate input for the eigensolver etc.: a marked fallback, never a crash
            msg = str(prep).splitlines()[0] if str(prep) else ""
            why[k] = why.get(k, "") + f"neural solver error: {type(prep).__name__}: {msg}"
        elif _isometric(prep):
            uv = prep.u_start[:len(vi)] * prep.scale   # the fillers' vertices come last: dropped
            out[k] = _finish(AtlasChart(fidx, "exact", "isometric-start", "", src, [(fidx, vi, Fl, uv)]), V, t0)
        else:
            preps.append(prep)
            idx.append(k)
    results, simple = [], []
    if idx and (deadline is None or time.perf_counter() < deadline):
        results = solve_charts(None, cfg, preps=preps, seed=seed, device=device, deadline=deadline, progress=progress)
        results, simple = _solve_on(results, preps, [meshes[k] for k in idx], cfg, seed, device, deadline,
                                    solve_charts)
    else:
        for k in idx:
            why[k] = why.get(k, "") + "time budget exhausted before the neural solve"
    for k, prep, res, ok in zip(idx, preps, results, simple):
        fidx, src, _ = todo[k]
        vi, Fl, Vx, Fx = meshes[k]
        solver = res.summary()
        solver.pop("metrics", None)
        if len(Fx):
            solver["filled_holes"] = int(len(Vx))
        uv = None if res.uv is None else res.uv[:len(vi)]  # the fillers' vertices come last: dropped
        # no flip and a simple outer boundary: injective on the filled disk, hence on the chart
        if ok:
            out[k] = _finish(AtlasChart(fidx, "neural", "neural", "", src, [(fidx, vi, Fl, uv)], solver=solver), V, t0)
            continue
        if _kept_start(res, prep):
            # the network found nothing better than its start, an injective map near the optimum, kept whole
            # (splitting it would only add seams): a SLIM-moved start a marked fallback, a split chart's own map neural
            how = ("neural", "neural", "") if prep.start == PARENT_START else ("fallback", "slim-start",
                                                                              f"neural: {res.reason}")
            out[k] = _finish(AtlasChart(fidx, *how, src, [(fidx, vi, Fl, uv)], solver=solver), V, t0)
            continue
        if res.status == "neural":
            why[k] = why.get(k, "") + f"neural map overlaps itself in UV ({100 * self_overlap(uv, Fl):.3g}% of its area)"
        else:
            why[k] = why.get(k, "") + f"neural: {res.reason}"
        timed_out = deadline is not None and time.perf_counter() > deadline
        if not last and not timed_out:
            retry.append((fidx, src, why[k], (fidx, Fl, uv) if res.status == "neural" else None))
            retried.add(k)
            continue
        method, islands, reason = fallback_islands(V, F, fidx, why[k])
        out[k] = _finish(AtlasChart(fidx, "fallback", method, reason, src, islands, solver=solver), V, t0)
    for k in range(len(todo)):
        if out[k] is None and k not in retried:
            fidx, src, _ = todo[k]
            method, islands, reason = fallback_islands(V, F, fidx, why.get(k, "not solved"))
            out[k] = _finish(AtlasChart(fidx, "fallback", method, reason, src, islands), V, t0)
    return out, retry


def _on_parent(V, fidx, mesh, parent):
    """A piece's UVs on the flip-free neural map of the chart it was split from, where that map is injective on
    the piece (no flipped face, an outer boundary that does not cross itself, on the piece with its holes closed
    by its filler fans, each hub at the mean of its rim); else None.

    A chart whose neural map overlaps itself is bisected; a half that does not hold the overlap is already
    injective on that map, near the optimum the network found, and its solve starts there
    (:data:`PARENT_START`) instead of at its Tutte circle: it needs tens of steps instead of hundreds.

    Parameters
    ----------
    V : (n,3) float array
    fidx : (k,) int array, the piece's faces (a subset of the parent's)
    mesh : the piece's :func:`~neuraluv.atlas.candidates.chart_mesh`
    parent : None or ``(fidx, Fl, uv)`` of the parent chart (its faces, local faces and UVs)

    Returns
    -------
    (p + e, 2) float array or None
        At ``V``'s scale, the piece's vertices then its filler vertices (as :func:`chart_mesh` orders them).
    """
    if parent is None:
        return None
    vi, Fl, Vx, Fx = mesh
    pf, pFl, puv = parent
    pos = np.full(max(pf.max(), fidx.max()) + 1, -1)   # face -> its row in the parent
    pos[pf] = np.arange(len(pf))
    row = pos[fidx]
    if (row < 0).any():
        return None
    n = len(vi)
    uv = np.full((n + len(Vx), 2), np.nan)
    uv[Fl.ravel()] = puv[pFl[row].ravel()]
    if not np.array_equal(uv[Fl.ravel()], puv[pFl[row].ravel()]) or np.isnan(uv[:n]).any():
        return None   # a vertex the parent had split (a bow-tie) is one vertex of the piece: two UVs
    if len(Vx):   # the piece's holes, closed by fans: each fan's hub at the mean of its rim in UV
        hub = Fx.max(1)                        # a filler triangle: its hub (>= n) and two rim vertices
        for j in range(n, n + len(Vx)):
            rim = Fx[hub == j]
            uv[j] = uv[np.unique(rim[rim < n])].mean(0)
    Vd, Fd = np.vstack([V[vi], Vx]), np.vstack([Fl, Fx])
    if not is_valid(Vd, Fd, uv) or not boundary_is_simple(uv, Fd):
        return None
    return uv


def _isometric(prep):
    """A prepared chart whose valid start is an isometry (:data:`ISOMETRIC_START`) with a simple outer boundary."""
    m = prep.start_metrics
    return (prep.start != "tutte" and m["valid"] and m["esd"] <= ESD_ISOMETRY * (1.0 + ISOMETRIC_START)
            and boundary_is_simple(prep.u_start, prep.F))


def _kept_start(res, prep):
    """A solver fallback that returned its SLIM-moved start or split chart's map, valid with a simple boundary."""
    return (res.status == "fallback" and (prep.start.startswith("tutte+slim") or prep.start == PARENT_START)
            and res.metrics["valid"]
            and res.uv is not None and np.array_equal(res.uv, prep.u_start * prep.scale)
            and boundary_is_simple(prep.u_start, prep.F))


def _simple(res, mesh):
    """A neural map whose outer boundary does not cross itself (on the chart with its holes filled)."""
    _, Fl, _, Fx = mesh
    return res.status == "neural" and boundary_is_simple(res.uv, np.vstack([Fl, Fx]))


def _solve_on(results, preps, meshes, cfg, seed, device, deadline, solve_charts):
    """Go on with the flip-free neural maps whose boundary crosses itself: :data:`CONTINUE_STEPS` more
    steps from their last parameters at most (no early stop, no retry), ended as soon as the best map's boundary
    is simple (checked every :data:`CONTINUE_CHECK` rounds); a map that comes out simple replaces
    the first one, any other keeps it (and is split by the caller). Returns the results and, per result,
    whether it is a neural map with a simple boundary (judged once)."""
    simple = [_simple(r, m) for r, m in zip(results, meshes)]
    again = [j for j, (r, ok) in enumerate(zip(results, simple)) if r.status == "neural" and not ok]
    if not again or (deadline is not None and time.perf_counter() > deadline):
        return results, simple
    go_on = replace(cfg, iterations=CONTINUE_STEPS, early_stop=False, retries=0)
    filled = [np.vstack([meshes[j][1], meshes[j][3]]) for j in again]
    more = solve_charts(None, go_on, preps=[preps[j] for j in again], seed=seed, device=device, deadline=deadline,
                        theta0=[results[j].theta for j in again],
                        until=(CONTINUE_CHECK, lambda ids, uvs: [boundary_is_simple(u, filled[i])
                                                                 for i, u in zip(ids, uvs)]))
    results = list(results)
    for j, r in zip(again, more):
        if _simple(r, meshes[j]):
            r.time += results[j].time
            results[j], simple[j] = r, True
    return results, simple


def route_chart(V, F, fidx, config="fast", *, seed=0, device="cpu", source="component", deadline=None):
    """Route one disk-like candidate (see :func:`route_charts`).

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> from neuraluv.solver.config import get_config
    >>> V, F = spherical_cap(n_rings=4)
    >>> c = route_chart(V, F, np.arange(len(F)), get_config("fast", iterations=60, retries=0))
    >>> c.route, c.metrics["flips"]
    ('neural', 0)
    """
    return route_charts(V, F, [(fidx, source)], config, seed=seed, device=device, deadline=deadline)[0]
