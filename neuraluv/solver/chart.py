"""The neural chart solver (paper Algorithm 1).

Features → SIREN → UVs → per-face Jacobians → stable E_SD + barrier, minimised
with Adam and a cosine learning rate. Every Adam step is checked: if it flips a
triangle (more flipped faces than before the step) — or, in the shipped
presets, halves the smallest det J below ε or raises the loss by more than
``loss_rise`` — the model and optimiser state are restored and the step is
retried with a smaller learning rate. A seed/retry schedule and a marked
fallback close the loop, so the solver never returns a silently flipped map.

:func:`prepare_chart` (lines 1–3 of Algorithm 1: normalise, features, frames,
the valid start) is shared by the solver and the NTK probes.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
import torch

from neuraluv.errors import TopologyError
from neuraluv.jacobian import local_frames
from neuraluv.meshfix import normalize_unit_box
from neuraluv.metrics import distortion_metrics
from neuraluv.solver.config import get_config
from neuraluv.solver.device import resolve_device
from neuraluv.solver.energy import alpha_schedule, jacobians_torch, objective
from neuraluv.solver.result import ChartResult
from neuraluv.solver.siren import Siren
from neuraluv.spectral import chart_features, lbo_eigenfunctions
from neuraluv.topology import is_disk_like
from neuraluv.tutte import tutte

__all__ = ["PreparedChart", "prepare_chart", "build_network", "ChartResult", "solve_chart", "Snapshot"]


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
    start : ``"tutte"`` or ``"tutte+slimN"`` (un-crushed, see ``start_relax``).
    start_metrics : :func:`~neuraluv.metrics.distortion_metrics` of ``u_start`` on ``Vn``.
    dC_inv : (m,2,2) float array, A : (m,) float array: local frames and areas of ``Vn``.
    target : (n,2) float array or None, the map the warm-up fits in absolute mode.
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


def prepare_chart(V, F, config="fast", *, check=True, n_eig=None, label="chart"):
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
        Number of LBO eigenpairs to keep in ``eig`` (default: the config's ``k``,
        at least 2); the NTK probes need more than the network's input.
    label : str
        Name used in error messages.

    Returns
    -------
    PreparedChart

    Notes
    -----
    The start is the uniform Tutte map on a circle of the chart's area. When
    ``start_relax > 0`` and its smallest det J is below ``relax_below``, it is
    un-crushed by flip-free SLIM iterations until every det J ≥ ``eps``
    (:func:`neuraluv.relax.slim_relax_until`; not in the paper, see
    :class:`~neuraluv.solver.config.SolverConfig`).

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> p = prepare_chart(*spherical_cap(n_rings=4), "test")
    >>> p.X.shape, p.start, p.start_metrics["flips"]
    ((61, 11), 'tutte', 0)
    """
    cfg = get_config(config)
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    if check:
        ok, why = is_disk_like(V, F)
        if not ok:
            raise TopologyError(f"{label} is not disk-like: {why}")
    Vn, _, s = normalize_unit_box(V)
    dC_inv, A = local_frames(Vn, F)
    bad = ~(np.isfinite(dC_inv).all(axis=(1, 2)) & (A > 0))
    if bad.any():
        raise TopologyError(f"{label} has {int(bad.sum())} degenerate (zero-area) faces: remove them first "
                            "(neuraluv.meshfix.repair_mesh; `neuraluv unwrap` and `atlas` do this)")
    n_eig = max(cfg.k, 2) if n_eig is None else max(int(n_eig), cfg.k, 2)
    need_eig = cfg.k > 0 or cfg.init == "spectral" or n_eig > max(cfg.k, 2)
    eig = lbo_eigenfunctions(Vn, F, n_eig) if need_eig else (np.zeros(0), np.zeros((len(V), 0)))
    X = chart_features(Vn, F, cfg.k, eig=(eig[0][: cfg.k], eig[1][:, : cfg.k]))
    u0 = tutte(Vn, F)
    m0 = distortion_metrics(Vn, F, u0)
    start = "tutte"
    if cfg.start_relax > 0 and m0["valid"] and m0["min_det"] < cfg.relax_below:
        from neuraluv.relax import slim_relax_until

        relaxed, n_relax = slim_relax_until(Vn, F, u0, cfg.eps, cfg.start_relax)
        if n_relax > 0:
            mr = distortion_metrics(Vn, F, relaxed)
            if mr["valid"]:
                u0, start, m0 = relaxed, f"tutte+slim{n_relax}", mr
    return PreparedChart(V=V, F=F, Vn=Vn, scale=float(s), X=X, eig=eig, u_start=u0, start=start, start_metrics=m0,
                         dC_inv=dC_inv, A=A, target=_init_target(cfg, u0, eig))


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


class Snapshot:
    """Parameters and optimiser state saved into preallocated buffers, restorable in place.

    ``save`` copies into the same buffers every time (no allocation after the
    first call); ``restore`` copies them back. Optimiser state that did not
    exist at ``save`` time (Adam before its first step) is removed on restore.

    Examples
    --------
    >>> net = torch.nn.Linear(2, 1); opt = torch.optim.Adam(net.parameters())
    >>> snap = Snapshot(net, opt); snap.save()
    >>> w = net.weight.detach().clone()
    >>> net(torch.ones(1, 2)).sum().backward(); opt.step()
    >>> snap.restore(); bool(torch.equal(net.weight, w)), len(opt.state)
    (True, 0)
    """

    def __init__(self, model, opt):
        self.model, self.opt = model, opt
        self.params = list(model.parameters())
        self.p_buf = [p.detach().clone() for p in self.params]
        self.s_buf = None
        self.had_state = False

    def save(self):
        with torch.no_grad():
            torch._foreach_copy_(self.p_buf, [p.detach() for p in self.params])
        st = self.opt.state
        self.had_state = bool(st) and all(p in st for p in self.params)
        if self.had_state:
            if self.s_buf is None:
                self.s_buf = [{k: v.detach().clone() for k, v in st[p].items() if torch.is_tensor(v)} for p in self.params]
            else:
                for p, buf in zip(self.params, self.s_buf):
                    for k, b in buf.items():
                        b.copy_(st[p][k])

    def restore(self):
        with torch.no_grad():
            torch._foreach_copy_([p.detach() for p in self.params], self.p_buf)
        if not self.had_state:
            for p in self.params:
                self.opt.state.pop(p, None)
            return
        for p, buf in zip(self.params, self.s_buf):
            cur = self.opt.state[p]
            for k, b in buf.items():
                cur[k].copy_(b)


def _cosine_lr(it, n, lr, lr_min):
    return lr_min + 0.5 * (lr - lr_min) * (1.0 + math.cos(math.pi * min(it, n) / max(n, 1)))


def _attempt(cfg, prep, seed, device, progress, callback, label):
    """One optimisation run (one seed): warm-up, then validity-checked Adam steps."""
    Xt = torch.as_tensor(prep.X, device=device)
    F_t = torch.as_tensor(prep.F, device=device)
    dCi = torch.as_tensor(prep.dC_inv, dtype=torch.float64, device=device)
    A = torch.as_tensor(prep.A, dtype=torch.float64, device=device)
    model = build_network(prep, cfg, seed=seed, device=device)
    residual = model.residual
    trace = {k: [] for k in ("iter", "loss", "esd", "min_det", "flips", "rejected", "lr", "time")}
    t0 = time.perf_counter()

    # --- warm-up: fit the network to the initial map (stationary in residual mode)
    target = None if residual else prep.target
    if target is not None and cfg.warmup_iters > 0:
        tgt = torch.as_tensor(target, dtype=torch.float64, device=device)
        opt_w = torch.optim.Adam(model.parameters(), lr=cfg.warmup_lr)
        for _ in range(cfg.warmup_iters):
            opt_w.zero_grad(set_to_none=True)
            fit = torch.mean((model(Xt) - tgt) ** 2)
            if fit.item() < 1e-14:
                break
            fit.backward()
            opt_w.step()
    if callback is not None:
        callback("warmup_end", 0, model)

    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr, betas=tuple(cfg.betas))
    snap = Snapshot(model, opt) if cfg.reject else None
    n = cfg.iterations

    def evaluate(s):
        u = model(Xt)
        return u, objective(jacobians_torch(u, F_t, dCi), A, alpha_schedule(s, n, cfg.alpha_start, cfg.alpha_end),
                            cfg.eps_J, cfg.eps)

    u, cur = evaluate(0)
    flips_cur = int((cur.det <= 0).sum().item())
    mind_cur = float(cur.det.min().item())
    best = (flips_cur, float(cur.esd), u.detach().clone())
    rejected_total = 0
    scale = 1.0
    stop = "budget"
    best_hist = []
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n, desc=label, leave=False, dynamic_ncols=True)
    for it in range(n):
        opt.zero_grad(set_to_none=True)
        cur.loss.backward()
        if snap is not None:
            snap.save()
        lr_it = _cosine_lr(it, n, cfg.lr, cfg.lr_min)
        step_scale = scale
        accepted = False
        # the loss-rise guard compares both losses at the same barrier weight α(it)
        alpha_it = alpha_schedule(it, n, cfg.alpha_start, cfg.alpha_end)
        loss_limit = float(cur.loss.item()) * (1.0 + cfg.loss_rise) if cfg.loss_rise > 0 else math.inf
        for _ in range(cfg.max_backtracks + 1):
            for g in opt.param_groups:
                g["lr"] = lr_it * step_scale
            opt.step()
            u_new, new = evaluate(it + 1)
            flips_new = int((new.det <= 0).sum().item())
            mind_new = float(new.det.min().item())
            ok = bool(torch.isfinite(new.loss).item())
            if ok and flips_cur == 0 and cfg.det_drop > 0:
                ok = mind_new >= min(cfg.eps, cfg.det_drop * mind_cur)
            if ok and cfg.loss_rise > 0:
                ok = float(new.at(alpha_it).item()) <= loss_limit
            if not cfg.reject or (ok and flips_new <= flips_cur):
                accepted = True
                break
            snap.restore()
            rejected_total += 1
            step_scale *= cfg.backtrack
        if not accepted:
            stop = "stalled"
            break
        scale = min(1.0, step_scale * cfg.step_recover)
        u, cur, flips_cur, mind_cur = u_new, new, flips_new, mind_new
        esd = float(cur.esd)
        if (flips_cur, esd) < best[:2]:
            best = (flips_cur, esd, u.detach().clone())
        trace["iter"].append(it + 1)
        trace["loss"].append(float(cur.loss.item()))
        trace["esd"].append(esd)
        trace["min_det"].append(mind_cur)
        trace["flips"].append(flips_cur)
        trace["rejected"].append(rejected_total)
        trace["lr"].append(lr_it * step_scale)
        trace["time"].append(time.perf_counter() - t0)
        if callback is not None:
            callback("step", it + 1, model)
        if bar is not None:
            bar.update(1)
            if it % 25 == 0:
                bar.set_postfix(esd=f"{esd:.4g}", min_det=f"{mind_cur:.3g}", rej=rejected_total)
        best_hist.append(best[1])
        if cfg.early_stop and it + 1 >= max(cfg.patience, n // 2) and best[0] == 0:
            old = best_hist[-cfg.patience]
            if (old - best[1]) <= cfg.tol * abs(best[1]):
                stop = "early_stop"
                break
    if bar is not None:
        bar.close()
    if callback is not None:
        callback("end", len(trace["iter"]), model)
    return best[2].detach().cpu().numpy(), trace, stop, model


def solve_chart(V, F, config="fast", *, seed=0, device="auto", progress=False, callback=None, label="chart", check=True):
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
        or ``"end"`` (used by the NTK trajectory probe).
    check : bool
        Run the disk-like test first (raises :class:`TopologyError`).

    Returns
    -------
    ChartResult
        ``status == "neural"`` with a valid map, or ``"fallback"`` with the
        reason and the best map found (the Tutte map when it is valid).

    Notes
    -----
    Algorithm 1: normalise, build features, precompute frames, Tutte map,
    warm-up, then for each iteration an Adam step on
    ``Σ_t A_t ‖J_t‖²(1 + q(det J_t)) + α(s) Σ_t [ε − det J_t]₊²`` that is kept
    only if it does not flip a triangle (nor trip the ``det_drop`` /
    ``loss_rise`` guards); otherwise the state is restored and the step
    retried with half the learning rate. A Tutte start with min det J below
    ``relax_below`` is first un-crushed by SLIM (``start_relax``).

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> V, F = spherical_cap(n_rings=5)
    >>> res = solve_chart(V, F, "test", device="cpu")
    >>> res.status, res.metrics["flips"]
    ('neural', 0)
    """
    t_start = time.perf_counter()
    cfg = get_config(config)
    dev = resolve_device(device)
    prep = prepare_chart(V, F, cfg, check=check, label=label)
    V, F, s = prep.V, prep.F, prep.scale
    attempts, log = [], []
    for a in range(cfg.retries + 1):
        c = replace(cfg, lr=cfg.lr * (0.5**a))
        uv_n, trace, stop, model = _attempt(c, prep, seed + a, dev, progress, callback, f"{label} seed {seed + a}")
        uv = uv_n * s
        m = distortion_metrics(V, F, uv)
        attempts.append((m, uv, trace, stop, seed + a, model))
        log.append({"seed": seed + a, "lr": c.lr, "stop": stop, "iterations": len(trace["iter"]),
                    "rejected": trace["rejected"][-1] if trace["rejected"] else 0, "valid": m["valid"], "flips": m["flips"]})
        if m["valid"]:
            break
    best = min(attempts, key=lambda t: (not t[0]["valid"], t[0]["flips"], t[0]["esd"]))
    m, uv, trace, stop, used_seed, model = best
    neural_uv = uv
    start, sm = prep.start, prep.start_metrics
    status, reason = "neural", ""
    if m["valid"] and not trace["iter"]:
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
    return ChartResult(
        uv=uv,
        metrics=m,
        status=status,
        reason=reason,
        trace=trace,
        time=time.perf_counter() - t_start,
        seed=used_seed,
        attempts=len(attempts),
        stop=stop,
        config=cfg.as_dict(),
        network=model,
        start=start,
        attempt_metrics=[a[0] for a in attempts],
        neural_uv=neural_uv,
        attempt_log=log,
    )
