"""The neural chart solver (paper Algorithm 1): one chart or many.

Features → SIREN → UVs → per-face Jacobians → stable E_SD + barrier, minimised
with Adam and a cosine learning rate (or L-BFGS, the ``fast`` preset). Every
step is checked: if it flips a triangle (more flipped faces than before the
step) — or, in the shipped presets, halves the smallest det J below ε or
raises the loss by more than ``loss_rise`` — it is refused and retried with
half the step. A seed/retry schedule and a marked fallback close the loop, so
the solver never returns a silently flipped map.

:func:`prepare_chart` (lines 1–3 of Algorithm 1: normalise, features, frames,
the valid start) is shared by the solver and the NTK probes;
:func:`solve_charts` solves many charts together (their networks are evaluated
in one batched pass, :mod:`neuraluv.solver.engine`); :func:`solve_chart` is
the one-chart case.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch
from tqdm.auto import tqdm

from neuraluv.errors import TopologyError
from neuraluv.jacobian import jacobians, local_frames
from neuraluv.layout.overlap import boundary_is_simple
from neuraluv.meshfix import normalize_unit_box
from neuraluv.metrics import distortion_metrics, metrics_from_jacobians
from neuraluv.relax import slim_relax_until, slim_relax_while
from neuraluv.solver.config import get_config
from neuraluv.solver.device import resolve_device
from neuraluv.solver.batch import make_batch
from neuraluv.solver.engine import optimise
from neuraluv.solver.pool import batch_pool, batch_workers, map_batches, split_even
from neuraluv.solver.result import ChartResult, Stop
from neuraluv.solver.siren import Siren
from neuraluv.solver.vertex import chart_module
from neuraluv.spectral import chart_features, lbo_eigenfunctions
from neuraluv.topology import is_disk_like
from neuraluv.tutte import tutte

__all__ = ["PreparedChart", "prepare_chart", "build_network", "ChartResult", "Stop", "solve_chart", "solve_charts",
           "batch_plan"]


@dataclass
class PreparedChart:
    """Everything Algorithm 1 computes before the first optimisation step.

    Attributes
    ----------
    V : (n,3) float array, the chart as given.
    F : (m,3) int array.
    Vn : (n,3) float array, normalised to the unit box.
    scale : float, ``V``-units per ``Vn``-unit (UVs are solved on ``Vn`` and
        multiplied by ``scale``).
    X : (n, 3+k) float32 array, the SIREN input ``[p̃ ‖ ψ̃_1..k]``.
    eig : (evals (k',), phi (n,k')), the LBO eigenpairs of ``Vn`` (k' ≥ k).
    u_start : (n,2) float array, the valid start on ``Vn`` (the residual base).
    start : ``"tutte"``, ``"tutte+slimN"`` (N SLIM iterations: un-crushed, see ``start_relax``, and
        moved on while injective, see ``start_slim``), or the ``start_name`` of a start given to
        :func:`prepare_chart`.
    start_metrics : :func:`~neuraluv.metrics.distortion_metrics` of ``u_start`` on ``Vn``.
    dC_inv : (m,2,2) float array, A : (m,) float array: local frames and areas of ``Vn``.
    target : (n,2) float array or None, the map the warm-up fits in absolute mode.
    free : (n,) bool array or None, vertices the network may move (the others stay at
        ``u_start`` exactly; residual mode only). None: all move.
    """

    V: np.ndarray
    F: np.ndarray
    Vn: np.ndarray
    scale: float
    X: np.ndarray
    eig: tuple
    u_start: np.ndarray
    start: str
    start_metrics: dict
    dC_inv: np.ndarray
    A: np.ndarray
    target: np.ndarray | None
    free: np.ndarray | None = None


def _init_target(cfg, u_start, eig):
    """The map the warm-up fits in absolute mode (None: no warm-up)."""
    if cfg.init == "tutte":
        return u_start
    if cfg.init == "spectral":
        phi = eig[1][:, :2]
        if phi.shape[1] < 2 or not np.any(phi):
            return u_start
        phi = phi - phi.mean(0)
        r = np.sqrt((u_start**2).sum(1).mean() / max((phi**2).sum(1).mean(), 1e-300))
        return phi * r
    if cfg.init == "random":
        return None
    raise ValueError(f"init must be 'tutte', 'spectral' or 'random', got {cfg.init!r}")


def prepare_chart(V, F, config="fast", *, check=True, n_eig=None, k=None, start_uv=None, start_name="given", free=None,
                  label="chart"):
    """Lines 1–3 of Algorithm 1: normalise, features, local frames, a valid start.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
        A disk-like chart.
    config : str or SolverConfig
    check : bool
        Run the disk-like test first (raises :class:`~neuraluv.errors.TopologyError`).
    n_eig : int, optional
        Number of LBO eigenpairs to keep in ``eig`` (default: the spectral rank,
        at least 2); the NTK probes need more than the network's input.
    k : int, optional
        Spectral rank of the features (default and at most the config's ``k``).
        ``X`` keeps ``3 + config.k`` columns: the missing eigenfunctions are
        zero columns, so the network has the config's shape whatever ``k``.
    start_uv : (n,2) float array, optional
        A valid start in the units of ``Vn`` (UVs at ``V``'s scale divided by
        ``scale``), used as it is instead of the Tutte map (no SLIM un-crushing).
    start_name : str
        ``start`` of the result when ``start_uv`` is given.
    free : (n,) bool array, optional
        Vertices the network may move; the others stay at the start exactly
        (residual mode). None: all move.
    label : str
        Name used in error messages.

    Returns
    -------
    PreparedChart

    Raises
    ------
    TopologyError
        The chart is not disk-like (with ``check``) or has a zero-area face.

    Notes
    -----
    The local frames give ``J_t = ΔU_t ΔC_t⁻¹`` (paper Eq. 4); they are
    computed once and serve the Tutte map's orientation, the start's metrics
    and the SLIM un-crushing. The start is the uniform Tutte map on a circle of
    the chart's area. When ``start_relax > 0`` and its smallest det J is below
    ``relax_below``, it is un-crushed by flip-free SLIM iterations until every
    det J ≥ ``eps`` (:func:`neuraluv.relax.slim_relax_until`; not in the paper,
    see :class:`~neuraluv.solver.config.SolverConfig`). With ``start_slim > 0`` (the atlas's
    routing; not in the paper) up to that many more SLIM iterations follow, kept while the map
    stays injective (no flip, a simple outer boundary).

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> V, F = spherical_cap(n_rings=4)
    >>> p = prepare_chart(V, F, "test")
    >>> p.X.shape, p.start, p.start_metrics["flips"]
    ((61, 11), 'tutte', 0)

    A given start, two eigenfunctions (zero columns pad the features), vertex 0 pinned:

    >>> q = prepare_chart(V, F, "test", k=2, start_uv=p.u_start, start_name="mine", free=np.arange(len(V)) > 0)
    >>> q.X.shape, q.start, bool((q.X[:, 5:] == 0).all()), int((~q.free).sum())
    ((61, 11), 'mine', True, 1)
    """
    cfg = get_config(config)
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    if check:
        ok, why = is_disk_like(V, F)
        if not ok:
            raise TopologyError(f"{label} is not disk-like: {why}")
    Vn, _, s = normalize_unit_box(V)
    frames = local_frames(Vn, F)
    dC_inv, A = frames
    bad = ~(np.isfinite(dC_inv).all(axis=(1, 2)) & (A > 0))
    if bad.any():
        raise TopologyError(f"{label} has {int(bad.sum())} degenerate (zero-area) faces: remove them first "
                            "(neuraluv.meshfix.repair_mesh; `neuraluv unwrap` and `atlas` do this)")
    k = cfg.k if k is None else min(int(k), cfg.k)
    if cfg.param == "vertex":  # free per-vertex UVs read no features: skip the eigen-solve (zero columns)
        k = 0
    n_eig = max(k, 2) if n_eig is None else max(int(n_eig), k, 2)
    need_eig = k > 0 or cfg.init == "spectral" or n_eig > max(k, 2)
    eig = lbo_eigenfunctions(Vn, F, n_eig) if need_eig else (np.zeros(0), np.zeros((len(V), 0)))
    X = chart_features(Vn, F, k, eig=(eig[0][:k], eig[1][:, :k]))
    if X.shape[1] < 3 + cfg.k:  # a lower rank: zero columns keep the config's network shape
        X = np.concatenate([X, np.zeros((len(X), 3 + cfg.k - X.shape[1]), X.dtype)], 1)
    if start_uv is None:
        u0, start, m0 = _tutte_start(cfg, Vn, F, frames)
    else:
        u0, start = np.asarray(start_uv, float), start_name
        m0 = _metrics(u0, F, frames)
    return PreparedChart(V=V, F=F, Vn=Vn, scale=float(s), X=X, eig=eig, u_start=u0, start=start, start_metrics=m0,
                         dC_inv=dC_inv, A=A, target=_init_target(cfg, u0, eig),
                         free=None if free is None else np.asarray(free, bool))


#: Vertices in all below which :func:`prepare_charts` (``workers="auto"``) prepares the charts here, one after the
#: other: about 0.18 ms a vertex (cow's 64 charts, 3,822 vertices: 0.70 s), against some 40 ms to fork two workers.
PREPARE_AT_ONCE = 2000


def prepare_charts(charts, config="fast", *, labels=None, check=True, errors="raise", workers="auto", pool="auto",
                   starts=None, start_name="given"):
    """:func:`prepare_chart` of many charts, split over the batch workers (forked processes on Linux, CPU).

    Parameters
    ----------
    charts : list of (V (n,3), F (m,3))
    config : str or SolverConfig
    labels : list of str, optional
    check : bool
        Run the disk-like test first (raises :class:`TopologyError`).
    errors : ``"raise"`` or ``"return"``
        ``"return"``: a chart whose preparation raises gets the exception in its place.
    starts : list of ((n,2) float array or None), optional
        Per chart, a valid start at ``V``'s scale (:func:`prepare_chart`'s ``start_uv`` times its
        ``scale``), named ``start_name``; None: the chart's own start.
    workers, pool :
        As in :func:`solve_charts` (:func:`~neuraluv.solver.pool.batch_workers`,
        :func:`~neuraluv.solver.pool.batch_pool`); the charts are split into groups of about
        equal cost, ``n^1.5`` for ``n`` vertices. ``"auto"`` prepares fewer than :data:`PREPARE_AT_ONCE`
        vertices in all here.

    Returns
    -------
    list of PreparedChart (or Exception)
        In the order of ``charts``; the same as one :func:`prepare_chart` after the other.

    Examples
    --------
    >>> from neuraluv.datasets import disk, spherical_cap
    >>> a, b = prepare_charts([spherical_cap(3), disk(4)], "test")
    >>> a.X.shape[0] == len(spherical_cap(3)[0]) and b.start
    'tutte'
    """
    cfg = get_config(config)
    labels = labels or [f"chart {i}" for i in range(len(charts))]
    if errors not in ("raise", "return"):
        raise ValueError(f"errors must be 'raise' or 'return', not {errors!r}")

    def one(i):
        try:
            given = None if starts is None or starts[i] is None else starts[i] / normalize_unit_box(charts[i][0])[2]
            return prepare_chart(*charts[i], cfg, check=check, label=labels[i], start_uv=given, start_name=start_name)
        except Exception as exc:
            if errors == "raise":
                raise
            return exc

    how = batch_pool(pool, "cpu")
    n_workers = batch_workers(workers, "cpu", how)
    if workers == "auto" and sum(len(V) for V, _ in charts) < PREPARE_AT_ONCE:
        n_workers = 1
    cost = [float(len(V)) ** 1.5 for V, _ in charts]
    groups = split_even(cost, n_workers)
    out = [None] * len(charts)
    for idx, res in map_batches(lambda idx, a: [one(i) for i in idx], groups, 0, n_workers,
                                [sum(cost[i] for i in g) for g in groups], how):
        for i, r in zip(idx, res):
            out[i] = r
    return out


def _metrics(u, F, frames):
    """``distortion_metrics(Vn, F, u)`` from the chart's local frames ``(dC_inv, A)`` (computed once)."""
    return metrics_from_jacobians(jacobians(u, F, frames[0]), frames[1])


def _tutte_start(cfg, Vn, F, frames):
    """Algorithm 1, line 3: the Tutte map of ``Vn``, un-crushed by SLIM when ``cfg.start_relax`` applies, then
    moved on by SLIM while injective when ``cfg.start_slim`` asks.

    Returns ``(u (n,2), name, metrics)`` (see :func:`prepare_chart`).
    """
    u0 = tutte(Vn, F, frames=frames)
    m0 = _metrics(u0, F, frames)
    n_slim = 0
    if cfg.start_relax > 0 and m0["valid"] and m0["min_det"] < cfg.relax_below:
        relaxed, n_relax = slim_relax_until(Vn, F, u0, cfg.eps, cfg.start_relax, frames=frames)
        if n_relax > 0:
            mr = _metrics(relaxed, F, frames)
            if mr["valid"]:
                u0, m0, n_slim = relaxed, mr, n_relax
    if cfg.start_slim > 0 and m0["valid"] and boundary_is_simple(u0, F):
        def injective(uv):  # no flip and a simple outer boundary: injective on a disk
            return _metrics(uv, F, frames)["valid"] and boundary_is_simple(uv, F)

        moved, k = slim_relax_while(Vn, F, u0, injective, cfg.start_slim)
        if k > 0:
            u0, m0, n_slim = moved, _metrics(moved, F, frames), n_slim + k
    return u0, (f"tutte+slim{n_slim}" if n_slim else "tutte"), m0


def build_network(prep, config="fast", *, seed=0, device="cpu"):
    """The chart network of Algorithm 1, line 4 (before the warm-up).

    Parameters
    ----------
    prep : PreparedChart
    config : str or SolverConfig
    seed : int
        Seed of the network's own random generator (the global RNGs are not touched).
    device : str or torch.device

    Returns
    -------
    Siren
        Residual on ``prep.u_start`` (zero head: it reproduces the start
        exactly) when ``config.residual`` and ``init == "tutte"``; absolute otherwise.
    """
    cfg = get_config(config)
    device = resolve_device(device)
    gen = torch.Generator().manual_seed(int(seed) % (2**63))
    residual = cfg.residual and cfg.init == "tutte"
    base = torch.as_tensor(prep.u_start, dtype=torch.float64) if residual else None
    net = Siren(prep.X.shape[1], cfg.width, cfg.n_layers, cfg.omega0, base=base, generator=gen)
    return net.to(device)


def batch_plan(sizes, max_rows, max_batch):
    """Group charts into batches by vertex count, so that padding stays small and a batch fits ``max_rows``.

    Parameters
    ----------
    sizes : (N,) sequence of int
        Vertex count of every chart (``len(prep.X)``).
    max_rows : int
        At most this many padded vertex rows per batch (charts × the batch's largest chart).
    max_batch : int
        At most this many charts per batch.

    Returns
    -------
    list of list of int
        Chart indices per batch, smallest charts first (the batches of :func:`solve_charts`).

    Notes
    -----
    Charts in a batch have at most 2.5× (plus 32) the vertices of its smallest
    chart: padding costs network time, but every batch costs a fixed
    per-step overhead too, which dominates for charts of a few dozen vertices.

    Examples
    --------
    >>> batch_plan([40, 500, 30, 45, 600], max_rows=1000, max_batch=512)
    [[2, 0, 3], [1], [4]]
    >>> batch_plan([40, 500, 30, 45, 600], max_rows=1000, max_batch=2)
    [[2, 0], [3], [1], [4]]
    """
    sizes = [int(n) for n in sizes]
    order = sorted(range(len(sizes)), key=lambda i: sizes[i])
    groups, cur = [], []
    for i in order:
        n = sizes[i]
        if cur and (n * (len(cur) + 1) > max_rows or len(cur) >= max_batch or n > 2.5 * sizes[cur[0]] + 32):
            groups.append(cur)
            cur = []
        cur.append(i)
    if cur:
        groups.append(cur)
    return groups


def _result(cfg, prep, attempts, log, t_start, device):
    """The ChartResult of one chart from its attempts: neural, or a marked fallback with its reason."""
    V, F, s = prep.V, prep.F, prep.scale
    best = min(attempts, key=lambda t: (not t[0]["valid"], t[0]["flips"], t[0]["esd"]))
    m, uv, trace, stop, used_seed, theta = best
    neural_uv = uv
    start, sm = prep.start, prep.start_metrics
    status, reason = "neural", ""
    if m["valid"] and not trace["iter"] and stop is Stop.TIME:
        status = "fallback"
        reason = f"time budget exhausted before this chart's solve; the valid start ({start}) is returned"
    elif m["valid"] and not trace["iter"]:
        status = "fallback"
        reason = (f"solver stalled at its start ({start}, min det J {sm['min_det']:.2g}): every step, "
                  f"even {cfg.max_backtracks} halvings down, was rejected (a flip, a collapsing "
                  "determinant or a rising loss); the valid start is returned (a start below relax_below is "
                  "un-crushed first when start_relax > 0)")
    elif m["valid"] and np.array_equal(uv, prep.u_start * s):
        status = "fallback"
        reason = (f"no accepted step improved on the start ({start}, min det J {sm['min_det']:.2g}, "
                  f"{len(trace['iter'])} iterations); the valid start is returned (a start below relax_below is "
                  "un-crushed first when start_relax > 0)")
    elif not m["valid"]:
        status = "fallback"
        if sm["valid"]:
            uv = prep.u_start * s
            reason = (f"neural solve invalid after {len(attempts)} attempts (best: {m['flips']} flipped faces); "
                      f"the valid start ({start}) used")
            m = distortion_metrics(V, F, uv)
        else:
            reason = (
                f"no flip-free map found after {len(attempts)} attempts (best has {m['flips']} flipped faces; "
                f"Tutte start has {sm['flips']}): the chart may be degenerate"
            )
    residual = cfg.residual and cfg.init == "tutte"
    base = torch.as_tensor(prep.u_start, dtype=torch.float64, device=device) if residual else None
    return ChartResult(
        uv=uv, metrics=m, status=status, reason=reason, trace=trace, time=time.perf_counter() - t_start,
        seed=used_seed, attempts=len(attempts), stop=stop.label, config=cfg.as_dict(),
        network=chart_module(theta, prep.X.shape[1], cfg, base), start=start,
        attempt_metrics=[a[0] for a in attempts], neural_uv=neural_uv, attempt_log=log, theta=theta,
    )


def solve_charts(charts, config="fast", *, seed=0, device="auto", progress=False, callback=None, labels=None,
                 check=True, deadline=None, max_rows=60000, max_batch=512, preps=None, theta0=None, workers="auto",
                 pool="auto", until=None):
    """Flatten many disk-like charts, their networks optimised together in batches.

    Parameters
    ----------
    charts : list of (V (n,3), F (m,3))
        Disk-like charts (None when ``preps`` is given).
    config : str or SolverConfig
    seed : int
        First seed of every chart's retry schedule (``seed, seed+1, ...``).
    device : str
        ``"auto"`` (CUDA when available), ``"cpu"`` or ``"cuda"``.
    progress : bool
        A tqdm bar over the first chart's steps (one chart) or over charts (several).
    callback : callable, optional
        ``callback(event, step, model)`` — only for a single chart (see :func:`solve_chart`).
    labels : list of str, optional
        Names used in error messages.
    check : bool
        Run the disk-like test first (raises :class:`TopologyError`).
    deadline : float, optional
        ``time.perf_counter()`` value at which every running optimisation stops
        (its best map so far is used, stop reason ``Stop.TIME``, ``"time"``).
    max_rows, max_batch : int
        A batch holds at most ``max_batch`` charts and ``max_rows`` padded vertex rows.
    preps : list of PreparedChart, optional
        Already prepared charts (skips :func:`prepare_chart`).
    theta0 : list of ((P,) tensor or None), optional
        Per chart, the parameters its first attempt starts from (a ``ChartResult.theta`` of
        an earlier solve of the same prepared chart: the solve goes on from there); retries
        start afresh.
    until : (int, callable), optional
        ``(every, done)``: :func:`~neuraluv.solver.engine.optimise`'s, with ``done(charts, uvs)`` given
        indices into ``charts`` and their flip-free best maps at ``V``'s scale.
    workers : int or "auto"
        Batches optimised at once (:func:`~neuraluv.solver.pool.batch_workers`); ``"auto"`` on the CPU:
        as many as torch may use threads (``torch.get_num_threads()``, which ``--threads`` and
        :func:`~neuraluv.solver.device.auto_threads` set), each forked child on one thread, or
        :data:`~neuraluv.solver.pool.BATCH_WORKERS` threads. Each batch's result does not depend on
        the others, nor on their order.
    pool : ``"auto"``, ``"process"`` or ``"thread"``
        Where ``workers`` batches run at once: forked processes (``"auto"`` on Linux, CPU) or threads
        (:func:`~neuraluv.solver.pool.batch_pool`).

    Returns
    -------
    list of ChartResult
        In the order of ``charts``; ``time`` is each chart's share of its batch's wall time.

    Notes
    -----
    A round of a batch (:func:`~neuraluv.solver.engine.optimise`) is a few hundred
    small tensor operations: for the charts of an atlas it is bound by the cost of
    each operation, not by arithmetic, and a second torch thread speeds one batch
    up little. Two batches, each on one thread, keep both cores busy. In two
    threads of one process they wait on each other: every torch call gives up the
    interpreter lock and takes it back (on cow's atlas 63–88 thousand voluntary
    context switches per run); forked processes do not (about 250). ``neuraluv
    atlas cow.off``, 2 cores, alternating, 3 rounds: threads 12.7 / 13.9 / 14.4 s
    (routing 7.4 / 8.9 / 9.1 s), processes 9.6 / 10.8 / 10.7 s (routing 5.4 / 6.1 /
    5.5 s), the same output bytes (issue 28).
    """
    t_start = time.perf_counter()
    cfg = get_config(config)
    dev = resolve_device(device)
    n_charts = len(preps) if preps is not None else len(charts)
    labels = labels or [f"chart {i}" for i in range(n_charts)]
    if preps is None:
        preps = prepare_charts(charts, cfg, labels=labels, check=check, workers=workers, pool=pool)
    if callback is not None and len(preps) != 1:
        raise ValueError("callback is supported for a single chart only")
    t_prep = time.perf_counter() - t_start
    residual = cfg.residual and cfg.init == "tutte"
    attempts = [[] for _ in preps]
    logs = [[] for _ in preps]
    bar = None
    if progress:
        if len(preps) == 1:
            bar = tqdm(total=cfg.iterations, desc=labels[0], leave=False, dynamic_ncols=True)
        else:
            bar = tqdm(total=len(preps), desc="charts", leave=False, dynamic_ncols=True)
    todo = list(range(len(preps)))
    chart_time = np.zeros(len(preps))
    how = batch_pool(pool, dev)
    n_workers = batch_workers(workers, dev, how)

    def run(idx, a):
        tb = time.perf_counter()
        batch = make_batch([preps[i] for i in idx], residual=residual, device=dev)
        done = None if until is None else (  # batch rows -> charts, UVs at V's scale
            until[0], lambda r, u: until[1]([idx[j] for j in r], [x * preps[idx[j]].scale for j, x in zip(r, u)]))
        res = optimise(batch, cfg, [seed + a] * len(idx), lr_scale=[0.5**a] * len(idx), callback=callback,
                       progress=bar if len(preps) == 1 else None, deadline=deadline, until=done,
                       theta0=[theta0[i] for i in idx] if (theta0 is not None and a == 0) else None)
        return res, time.perf_counter() - tb

    for a in range(cfg.retries + 1):
        if not todo:
            break
        groups = [[todo[j] for j in g] for g in batch_plan([len(preps[i].X) for i in todo], max_rows, max_batch)]
        rows = [len(g) * max(len(preps[i].X) for i in g) for g in groups]   # padded rows: the costliest run first
        for idx, (res, dt) in map_batches(run, groups, a, n_workers, rows, how, deadline):
            for k, i in enumerate(idx):
                p = preps[i]
                uv = res.best_uv[k, : len(p.X)] * p.scale
                m = distortion_metrics(p.V, p.F, uv)
                tr = res.traces[k]
                attempts[i].append((m, uv, tr, res.stop[k], seed + a, res.theta[k]))
                logs[i].append({"seed": seed + a, "lr": cfg.lr * 0.5**a, "stop": res.stop[k].label, "iterations": len(tr["iter"]),
                                "rejected": tr["rejected"][-1] if tr["rejected"] else 0, "valid": m["valid"],
                                "flips": m["flips"]})
            w = np.array([len(preps[i].X) for i in idx], float)
            chart_time[idx] += dt * w / w.sum()
            if bar is not None and len(preps) > 1:
                bar.update(sum(1 for i in idx if attempts[i][-1][0]["valid"] or a == cfg.retries))
        todo = [i for i in todo if not attempts[i][-1][0]["valid"]]
        if deadline is not None and time.perf_counter() > deadline:
            break
    if bar is not None:
        bar.close()
    share = t_prep / max(len(preps), 1)
    out = []
    for i, p in enumerate(preps):
        r = _result(cfg, p, attempts[i], logs[i], time.perf_counter(), dev)
        r.time = float(chart_time[i] + share)
        out.append(r)
    return out


def solve_chart(V, F, config="fast", *, seed=0, device="auto", progress=False, callback=None, label="chart", check=True,
                deadline=None):
    """Flatten one disk-like chart with the neural solver.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
        A disk-like chart (one component, one boundary loop).
    config : str or SolverConfig
        A preset name (``"paper"``, ``"fast"``, ``"literal"``, ``"test"``) or a config.
    seed : int
        First seed of the retry schedule (``seed, seed+1, ...``).
    device : str
        ``"auto"`` (CUDA when available), ``"cpu"`` or ``"cuda"``.
    progress : bool
        Show a tqdm progress bar.
    callback : callable, optional
        ``callback(event, step, model)`` with event ``"warmup_end"``, ``"step"``
        or ``"end"`` (used by the NTK trajectory probe and the film strips);
        ``model`` is a :class:`~neuraluv.solver.siren.Siren` holding the current weights.
    check : bool
        Run the disk-like test first (raises :class:`TopologyError`).
    deadline : float, optional
        ``time.perf_counter()`` value at which the optimisation stops with its best map so far.

    Returns
    -------
    ChartResult
        ``status == "neural"`` with a valid map, or ``"fallback"`` with the
        reason and the best map found (the Tutte map when it is valid).

    Notes
    -----
    Algorithm 1: normalise, build features, precompute frames, Tutte map,
    warm-up, then for each iteration a step on
    ``Σ_t A_t ‖J_t‖²(1 + q(det J_t)) + α(s) Σ_t [ε − det J_t]₊²`` that is kept
    only if it does not flip a triangle (nor trip the ``det_drop`` /
    ``loss_rise`` guards); otherwise it is retried with half the step. A Tutte
    start with min det J below ``relax_below`` is first un-crushed by SLIM
    (``start_relax``).

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> V, F = spherical_cap(n_rings=5)
    >>> res = solve_chart(V, F, "test", device="cpu")
    >>> res.status, res.metrics["flips"]
    ('neural', 0)
    """
    t0 = time.perf_counter()
    res = solve_charts([(V, F)], config, seed=seed, device=device, progress=progress, callback=callback, labels=[label],
                       check=check, deadline=deadline)[0]
    res.time = time.perf_counter() - t0
    return res
