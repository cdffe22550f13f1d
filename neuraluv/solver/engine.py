"""Validity-checked optimisation of chart networks, many charts at once (Algorithm 1, lines 4–13).

Every chart has its own SIREN (the paper's per-chart network). The networks of
a batch of charts are evaluated together: their weights are stacked into one
flat tensor ``theta (B, P)`` (chart ``c``'s parameters in row ``c``), their
inputs padded to a common vertex count, and each layer is one batched matrix
product (``torch.baddbmm``). A chart with ``B = 1`` is the same code.

One *round* evaluates a trial point for every active chart, forward, then
decides per chart — as tensor operations, without a Python loop over charts —
whether to accept it (no new flipped face, no collapse of the smallest det J,
no loss rise / sufficient decrease), and backpropagates only when some chart
accepted. A rejected trial halves that chart's step and is retried from the
same state in the next round, so rejected trials cost a forward pass and
nothing else: the optimiser state is never copied, the accepted and the trial
states are kept side by side and merged with ``torch.where``.

Two optimisers share that loop:

* ``adam`` — the paper's (Adam with a cosine learning rate), written out on
  the stacked parameters; mathematically PyTorch's ``torch.optim.Adam``.
* ``lbfgs`` — limited-memory BFGS with a backtracking (Armijo) line search whose
  trials are the same validity-checked trials; the ``fast`` preset's optimiser.
  The two-loop recursion is vectorised over charts: every round writes one
  history slot for all charts (a zero pair, i.e. a no-op, for charts that did
  not move), so all charts share one ring buffer and no per-chart gather is
  needed.

Size: the loop, its batch layout and both optimisers' per-chart acceptance are one algorithm (Algorithm 1, lines 4-13) whose parts share tensors and invariants; they are kept together so the checks can be read next to the steps they guard.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import torch

from neuraluv.solver.energy import chart_objective
from neuraluv.solver.siren import Siren

__all__ = ["ChartBatch", "make_batch", "param_count", "init_params", "forward", "to_module", "optimise", "EngineResult"]


# --------------------------------------------------------------------------- the batch


@dataclass
class ChartBatch:
    """Prepared charts padded to one vertex count ``n`` (see :func:`make_batch`).

    Attributes
    ----------
    X : (B, n, d) float32 tensor — SIREN inputs (zero rows pad short charts).
    base : (B, n, 2) float64 tensor or None — residual base (the valid start); None in absolute mode.
    target : (B, n, 2) float64 tensor or None — the warm-up target in absolute mode.
    F : (M, 3) long tensor — faces of all charts, indexing the flattened ``(B·n)`` vertex rows.
    face_chart : (M,) long tensor — chart of each face.
    dC_inv : (M, 2, 2) float64 tensor; w : (M,) float64 tensor — area weights, summing to 1 per chart.
    sizes : (B,) int array — vertex count of each chart.
    mask : (B, n, 1) float64 tensor or None — 0 on pinned vertices (their UV stays the base), 1 elsewhere.
    """

    X: torch.Tensor
    base: torch.Tensor | None
    target: torch.Tensor | None
    F: torch.Tensor
    face_chart: torch.Tensor
    dC_inv: torch.Tensor
    w: torch.Tensor
    sizes: np.ndarray
    mask: torch.Tensor | None = None

    @property
    def B(self):
        return self.X.shape[0]

    @property
    def n(self):
        return self.X.shape[1]


def make_batch(preps, *, residual=True, device="cpu"):
    """Stack :class:`~neuraluv.solver.chart.PreparedChart` objects into one :class:`ChartBatch`.

    Parameters
    ----------
    preps : list of PreparedChart
    residual : bool
        Residual mode: the network's output is added to ``prep.u_start``.
    device : torch.device or str

    Returns
    -------
    ChartBatch
    """
    B = len(preps)
    n = max(len(p.X) for p in preps)
    d = preps[0].X.shape[1]
    X = np.zeros((B, n, d), np.float32)
    U = np.zeros((B, n, 2))
    T = np.zeros((B, n, 2))
    Fs, fc, dci, ws = [], [], [], []
    for c, p in enumerate(preps):
        k = len(p.X)
        X[c, :k] = p.X
        U[c, :k] = p.u_start
        if p.target is not None:
            T[c, :k] = p.target
        Fs.append(np.asarray(p.F, np.int64) + c * n)
        fc.append(np.full(len(p.F), c, np.int64))
        dci.append(p.dC_inv)
        ws.append(p.A / p.A.sum())
    dev = torch.device(device)
    has_target = all(p.target is not None for p in preps)
    mask = None
    if residual and any(getattr(p, "free", None) is not None for p in preps):
        mask = np.ones((B, n, 1))
        for c, p in enumerate(preps):
            if getattr(p, "free", None) is not None:
                mask[c, : len(p.X), 0] = np.asarray(p.free, float)
    return ChartBatch(
        X=torch.as_tensor(X, device=dev),
        base=torch.as_tensor(U, device=dev) if residual else None,
        target=torch.as_tensor(T, device=dev) if (has_target and not residual) else None,
        F=torch.as_tensor(np.concatenate(Fs), device=dev),
        face_chart=torch.as_tensor(np.concatenate(fc), device=dev),
        dC_inv=torch.as_tensor(np.concatenate(dci), device=dev),
        w=torch.as_tensor(np.concatenate(ws), device=dev),
        sizes=np.array([len(p.X) for p in preps]),
        mask=None if mask is None else torch.as_tensor(mask, device=dev),
    )


def _subset(batch, keep):
    """The charts ``keep`` (sorted indices) of a batch, re-indexed."""
    keep_t = torch.as_tensor(keep, device=batch.X.device)
    remap = torch.full((batch.B,), -1, dtype=torch.long, device=batch.X.device)
    remap[keep_t] = torch.arange(len(keep), device=batch.X.device)
    fmask = remap[batch.face_chart] >= 0
    F = batch.F[fmask]
    old_c = batch.face_chart[fmask]
    new_c = remap[old_c]
    F = F - (old_c * batch.n)[:, None] + (new_c * batch.n)[:, None]
    return ChartBatch(X=batch.X[keep_t], base=None if batch.base is None else batch.base[keep_t],
                      target=None if batch.target is None else batch.target[keep_t], F=F, face_chart=new_c,
                      dC_inv=batch.dC_inv[fmask], w=batch.w[fmask], sizes=batch.sizes[np.asarray(keep)],
                      mask=None if batch.mask is None else batch.mask[keep_t])


# --------------------------------------------------------------------------- the network on flat parameters


def _shapes(d, width, n_layers):
    """``[(in, out), ...]`` of the SIREN's linear layers (the last is the 2-D head)."""
    dims = [d] + [width] * (n_layers - 1) + [2]
    return list(zip(dims[:-1], dims[1:]))


def param_count(d, width, n_layers):
    """Number of parameters of one chart network.

    Examples
    --------
    >>> param_count(19, 256, 5)  # the paper's network with k = 16
    203010
    """
    return sum(i * o + o for i, o in _shapes(d, width, n_layers))


def _views(theta, d, width, n_layers):
    """``[(W (B,in,out), b (B,1,out)), ...]`` views into ``theta (B, P)``."""
    out, o = [], 0
    B = theta.shape[0]
    for i, k in _shapes(d, width, n_layers):
        W = theta[:, o:o + i * k].view(B, i, k)
        o += i * k
        b = theta[:, o:o + k].view(B, 1, k)
        o += k
        out.append((W, b))
    return out


def leaves(theta, d, width, n_layers):
    """The layers of ``theta (B, P)`` as separate leaf tensors that require grad (sharing its memory).

    Backpropagating into per-layer leaves and concatenating their gradients
    (:func:`flat_grad`) is cheaper than backpropagating into views of one flat
    leaf, which makes autograd scatter every layer's gradient into a full-size buffer.
    """
    return [(W.detach().requires_grad_(True), b.detach().requires_grad_(True)) for W, b in _views(theta, d, width, n_layers)]


def flat_grad(layers):
    """The gradient of :func:`leaves` as one ``(B, P)`` tensor (the layout of ``theta``)."""
    B = layers[0][0].shape[0]
    return torch.cat([t.grad.reshape(B, -1) for L in layers for t in L], 1)


def forward(theta, X, base, *, width, n_layers, omega0, mask=None):
    """UVs of every chart: ``base + head(sin(ω₀(… W₁ x + b₁ …)))`` (float64), ``(B, n, 2)``.

    The same network as :class:`~neuraluv.solver.siren.Siren` (paper Eq. 3),
    evaluated for all charts at once from their stacked weights. ``theta`` is
    the flat ``(B, P)`` tensor or its :func:`leaves`. With ``mask (B, n, 1)``
    the network's output is multiplied by it, so vertices with mask 0 stay
    exactly at ``base`` (pinned; used by local UV repair).
    """
    layers = _views(theta, X.shape[2], width, n_layers) if torch.is_tensor(theta) else theta
    h = X
    for W, b in layers[:-1]:
        h = torch.sin(torch.baddbmm(b, h, W, beta=omega0, alpha=omega0))  # sin(ω₀ (h W + b)), one fused product
    W, b = layers[-1]
    out = torch.baddbmm(b, h, W).to(torch.float64)
    if mask is not None:
        out = out * mask
    return out if base is None else base + out


def init_params(seeds, d, cfg, *, residual=True, device="cpu"):
    """Stacked SIREN initialisations, one per seed (Sitzmann et al.; zero head in residual mode).

    Each row is exactly the initialisation of ``Siren(d, cfg.width, cfg.n_layers,
    cfg.omega0, base=..., generator=torch.Generator().manual_seed(seed))``.
    """
    rows = []
    for s in seeds:
        gen = torch.Generator().manual_seed(int(s) % (2**63))
        net = Siren(d, cfg.width, cfg.n_layers, cfg.omega0, base=torch.zeros(1, 2, dtype=torch.float64) if residual else None,
                    generator=gen)
        lin = [m.linear for m in net.body] + [net.head]
        rows.append(torch.cat([t for L in lin for t in (L.weight.detach().T.reshape(-1), L.bias.detach())]))
    return torch.stack(rows).to(device)


def to_module(theta_row, d, cfg, base=None):
    """A :class:`~neuraluv.solver.siren.Siren` holding one chart's parameters (for callbacks, NTK probes)."""
    net = Siren(d, cfg.width, cfg.n_layers, cfg.omega0, base=base)
    lin = [m.linear for m in net.body] + [net.head]
    with torch.no_grad():
        for L, (W, b) in zip(lin, _views(theta_row[None].detach().cpu(), d, cfg.width, cfg.n_layers)):
            L.weight.copy_(W[0].T)
            L.bias.copy_(b[0, 0])
    return net.to(theta_row.device)


# --------------------------------------------------------------------------- the optimisation loop


@dataclass
class EngineResult:
    """What :func:`optimise` returns, per chart (row ``c`` of every array)."""

    best_uv: np.ndarray          #: (B, n, 2) float64, the best map (fewest flips, then lowest E_SD)
    theta: torch.Tensor          #: (B, P) final parameters
    traces: list                 #: one dict of lists per chart (iter, loss, esd, min_det, flips, rejected, lr, time)
    stop: list                   #: "budget", "early_stop", "stalled" or "time"
    start_esd: np.ndarray        #: (B,) true E_SD of the start (before any step)
    rounds: int                  #: rounds run (forward passes)
    backward: int                #: backward passes
    timing: dict                 #: seconds in forward, objective, backward, optimiser, bookkeeping


def _alpha(it, cfg):
    frac = torch.clamp(it / max(cfg.iterations, 1), 0.0, 1.0)
    return cfg.alpha_start * torch.exp(frac * math.log(cfg.alpha_end / cfg.alpha_start))


def _cosine(it, cfg, lr):
    return cfg.lr_min + 0.5 * (lr - cfg.lr_min) * (1.0 + torch.cos(math.pi * torch.clamp(it / max(cfg.iterations, 1), 0.0, 1.0)))


class _State:
    """Per-chart tensors of a running optimisation (row ``i`` ↔ chart ``rows[i]``), compactable."""

    def __init__(self, **tensors):
        self.__dict__.update(tensors)

    def select(self, keep):
        for k, v in list(self.__dict__.items()):
            if torch.is_tensor(v) and v.dim() > 0:
                setattr(self, k, v[keep])


def optimise(batch, cfg, seeds, *, lr_scale=None, callback=None, progress=None, deadline=None, profile=False):
    """Run Algorithm 1's optimisation on every chart of a batch.

    Parameters
    ----------
    batch : ChartBatch
    cfg : SolverConfig
    seeds : list of int
        One seed per chart (its network's initialisation).
    lr_scale : (B,) array, optional
        Per-chart factor on the learning rate / initial step (the retry schedule halves it).
    callback : callable, optional
        ``callback(event, step, model)`` for a single chart (``B == 1``): ``"warmup_end"``,
        ``"step"`` after each accepted step, ``"end"``; ``model`` is a Siren with the current weights.
    progress : tqdm-like, optional
        Updated once per accepted step of a single chart.
    deadline : float, optional
        ``time.perf_counter()`` value at which every chart stops (``stop == "time"``).
    profile : bool
        Synchronise the device around each phase so ``timing`` is exact (slower on CUDA).

    Returns
    -------
    EngineResult

    Notes
    -----
    Charts that stop (budget, early stop, stall) leave the batch as soon as at
    most half of it is still running, so a batch never keeps evaluating the
    networks of finished charts for long.
    """
    dev = batch.X.device
    B0, d = batch.B, batch.X.shape[2]
    residual = batch.base is not None
    net = dict(width=cfg.width, n_layers=cfg.n_layers, omega0=float(cfg.omega0))
    theta = init_params(seeds, d, cfg, residual=residual, device=dev)
    P = theta.shape[1]
    timing = {"forward": 0.0, "objective": 0.0, "backward": 0.0, "optimiser": 0.0, "bookkeeping": 0.0}
    sync = (lambda: torch.cuda.synchronize(dev)) if (profile and dev.type == "cuda") else (lambda: None)
    clock = [time.perf_counter()]

    def tick(key):
        sync()
        now = time.perf_counter()
        timing[key] += now - clock[0]
        clock[0] = now

    # --- warm-up (absolute mode only: the residual network already equals its base)
    if batch.target is not None and cfg.warmup_iters > 0:
        theta = _warmup(theta, batch, cfg, net)
    if callback is not None:
        callback("warmup_end", 0, to_module(theta[0], d, cfg, None if batch.base is None else batch.base[0]))

    n_it = cfg.iterations
    lbfgs = cfg.optimizer == "lbfgs"
    f64 = dict(dtype=torch.float64, device=dev)

    def evaluate(th, it_eval, bt):
        th = leaves(th, d, cfg.width, cfg.n_layers)
        u = forward(th, bt.X, bt.base, mask=bt.mask, **net)
        tick("forward")
        o = chart_objective(u.reshape(-1, 2), bt.F, bt.dC_inv, bt.w, bt.face_chart, bt.B, _alpha(it_eval, cfg),
                            cfg.eps_J, cfg.eps)
        tick("objective")
        return th, u, o

    zeros = torch.zeros(B0, **f64)
    th, u, cur = evaluate(theta, zeros, batch)
    cur.loss.sum().backward()
    tick("backward")
    st = _State(
        rows=torch.arange(B0, device=dev), theta=theta, g=flat_grad(th),
        scale0=torch.ones(B0, **f64) if lr_scale is None else torch.as_tensor(np.asarray(lr_scale, float), **f64),
        loss=cur.loss.detach(), flips=cur.flips, mind=cur.min_det.detach(),
        best_key=torch.stack([cur.flips.to(torch.float64), cur.esd.detach()], 1), best_u=u.detach().clone(),
        it=torch.zeros(B0, **f64), active=torch.ones(B0, dtype=torch.bool, device=dev),
        stop=torch.zeros(B0, dtype=torch.long, device=dev), backtracks=torch.zeros(B0, dtype=torch.long, device=dev),
        rejected=torch.zeros(B0, dtype=torch.long, device=dev), scale=torch.ones(B0, **f64),
        best_ring=torch.full((B0, max(int(cfg.patience), 1)), float("inf"), **f64),
    )
    start_esd = cur.esd.detach().cpu().numpy()
    n_back = 1
    if lbfgs:
        mem = LBFGSMemory(B0, P, _history(cfg, batch), dtype=theta.dtype, device=dev)
        st.dirn = torch.zeros_like(theta)
        st.gd = torch.zeros(B0, **f64)
        st.in_ls = torch.zeros(B0, dtype=torch.bool, device=dev)
    else:
        st.m1 = torch.zeros_like(theta)
        st.m2 = torch.zeros_like(theta)
        st.steps = torch.zeros(B0, **f64)
        b1, b2 = (float(x) for x in cfg.betas)
    pat = max(int(cfg.patience), 1)
    early_from = max(pat, int(cfg.early_after * n_it))
    # results of charts that left the batch, by original index
    out_u = np.zeros((B0, batch.n, 2))
    out_theta = torch.zeros(B0, P, dtype=theta.dtype, device=dev)
    out_stop = np.zeros(B0, np.int64)
    rec = _Recorder(B0, dev)
    t0 = time.perf_counter()
    rounds = 0
    bt = batch
    tick("bookkeeping")
    while True:
        if deadline is not None and time.perf_counter() > deadline:
            st.stop = torch.where(st.active, torch.full_like(st.stop, 3), st.stop)
            st.active = torch.zeros_like(st.active)
        n_active = int(st.active.sum())
        if n_active == 0:
            break
        if n_active <= bt.B // 2:   # drop finished charts from the batch
            keep = torch.nonzero(st.active).squeeze(1)
            gone = torch.nonzero(~st.active).squeeze(1)
            _store(st, gone, out_u, out_theta, out_stop)
            st.select(keep)
            if lbfgs:
                mem.select(keep)
            bt = _subset(bt, keep.cpu().numpy())
        B = bt.B
        rounds += 1
        # ---- propose a trial for every active chart
        with torch.no_grad():
            if lbfgs:
                fresh = st.active & ~st.in_ls
                gnorm = st.g.norm(dim=1).clamp_min(1e-30).to(torch.float64)
                sd = -st.g * (cfg.lr * st.scale0 / gnorm).to(st.g.dtype)[:, None]     # scaled steepest descent
                dnew = torch.where((mem.gamma > 0)[:, None], -mem.apply(st.g), sd)
                gdn = _dot(st.g, dnew)
                bad = (gdn >= 0) & fresh
                if bool(bad.any()):  # not a descent direction: forget this chart's curvature pairs
                    mem.reset(bad)
                    dnew = torch.where(bad[:, None], sd, dnew)
                    gdn = torch.where(bad, _dot(st.g, sd), gdn)
                st.dirn = torch.where(fresh[:, None], dnew, st.dirn)
                st.gd = torch.where(fresh, gdn, st.gd)
                st.scale = torch.where(fresh, torch.ones_like(st.scale), st.scale)
                trial = torch.where(st.active[:, None], st.theta + st.scale.to(st.theta.dtype)[:, None] * st.dirn, st.theta)
                lr_used = st.scale
            else:
                lr_it = _cosine(st.it, cfg, cfg.lr * st.scale0) * st.scale
                # Adam (PyTorch's formula): m ← β₁m + (1−β₁)g, v ← β₂v + (1−β₂)g², θ ← θ − lr·m̂/(√v̂ + 1e-8)
                m1n = torch.lerp(st.m1, st.g, 1 - b1)
                m2n = torch.lerp(st.m2, st.g * st.g, 1 - b2)
                stn = st.steps + 1
                bc1 = 1 - b1**stn
                denom = m2n.sqrt().div_((1 - b2**stn).sqrt().to(st.g.dtype)[:, None]).add_(1e-8)
                if B == 1:
                    trial = torch.addcdiv(st.theta, m1n, denom, value=-float(lr_it[0] / bc1[0]))
                else:
                    upd = (lr_it / bc1).to(st.g.dtype)[:, None] * m1n / denom
                    trial = torch.where(st.active[:, None], st.theta - upd, st.theta)
                lr_used = lr_it
        tick("optimiser")
        # ---- evaluate it (forward; the loss at the next barrier weight)
        th, u, new = evaluate(trial, st.it + 1, bt)
        with torch.no_grad():
            loss_new = new.loss.detach()
            cmp_new = new.stable.detach() + _alpha(st.it, cfg) * new.barrier.detach()   # at the same α as st.loss
            ok = torch.isfinite(loss_new) & torch.isfinite(cmp_new)
            if cfg.reject:
                ok &= new.flips <= st.flips
                if cfg.det_drop > 0:
                    guard = new.min_det >= torch.clamp(cfg.det_drop * st.mind, max=cfg.eps)
                    ok &= guard | (st.flips > 0)
                if lbfgs:
                    ok &= cmp_new <= st.loss + cfg.armijo * st.scale * st.gd
                elif cfg.loss_rise > 0:
                    ok &= cmp_new <= st.loss * (1.0 + cfg.loss_rise)
            acc = st.active & ok
            n_acc = int(acc.sum())
            all_acc = n_acc == B
        tick("bookkeeping")
        if n_acc:
            (new.loss * acc.to(new.loss.dtype)).sum().backward()
            n_back += 1
            tick("backward")
            gnew = flat_grad(th)
        with torch.no_grad():
            if n_acc:
                a1 = acc[:, None]
                if lbfgs:
                    mem.push(trial - st.theta, gnew - st.g, acc)
                    st.in_ls = st.in_ls & ~acc
                elif all_acc:
                    st.m1, st.m2, st.steps = m1n, m2n, stn
                else:
                    st.m1 = torch.where(a1, m1n, st.m1)
                    st.m2 = torch.where(a1, m2n, st.m2)
                    st.steps = torch.where(acc, stn, st.steps)
                if all_acc:
                    st.theta, st.g = trial, gnew
                else:
                    st.theta = torch.where(a1, trial, st.theta)
                    st.g = torch.where(a1, gnew, st.g)
                st.loss = torch.where(acc, loss_new, st.loss)
                st.flips = torch.where(acc, new.flips, st.flips)
                st.mind = torch.where(acc, new.min_det.detach(), st.mind)
                st.it = st.it + acc.to(st.it.dtype)
                key = torch.stack([new.flips.to(torch.float64), new.esd.detach()], 1)
                better = acc & ((key[:, 0] < st.best_key[:, 0]) | ((key[:, 0] == st.best_key[:, 0]) & (key[:, 1] < st.best_key[:, 1])))
                if bool(better.any()):
                    st.best_key = torch.where(better[:, None], key, st.best_key)
                    st.best_u[better] = u.detach()[better]
            rej = st.active & ~acc
            st.rejected = st.rejected + rej.long()
            st.backtracks = torch.where(acc, torch.zeros_like(st.backtracks), st.backtracks + rej.long())
            if lbfgs:
                st.in_ls = st.in_ls | rej
                st.scale = torch.where(rej, st.scale * cfg.backtrack, st.scale)
            else:
                st.scale = torch.where(acc, torch.clamp(st.scale * cfg.step_recover, max=1.0),
                                       torch.where(rej, st.scale * cfg.backtrack, st.scale))
            stalled = rej & (st.backtracks > cfg.max_backtracks)
            st.stop = torch.where(stalled, torch.full_like(st.stop, 2), st.stop)
            st.active = st.active & ~stalled & ~(st.it >= n_it)
            # early stopping: the best E_SD improved by less than tol over the last `patience` accepted steps
            if cfg.early_stop and n_acc:
                slot = (st.it.long() % pat)[:, None]
                old = st.best_ring.gather(1, slot).squeeze(1)      # best E_SD `pat` accepted steps ago
                st.best_ring.scatter_(1, slot, torch.where(acc, st.best_key[:, 1], old)[:, None])
                es = (acc & st.active & (st.it >= early_from) & (st.best_key[:, 0] == 0)
                      & ((old - st.best_key[:, 1]) <= cfg.tol * st.best_key[:, 1].abs()))
                st.stop = torch.where(es, torch.ones_like(st.stop), st.stop)
                st.active = st.active & ~es
            rec.add(st.rows, acc, st.loss, new.esd.detach(), st.mind, st.flips, st.rejected, lr_used,
                    time.perf_counter() - t0)
        if callback is not None and bool(acc[0]):
            callback("step", int(st.it[0]), to_module(st.theta[0], d, cfg, None if bt.base is None else bt.base[0]))
        if progress is not None and bool(acc[0]):
            progress.update(1)
            if int(st.it[0]) % 25 == 0:
                progress.set_postfix(esd=f"{float(st.best_key[0, 1]):.4g}", min_det=f"{float(st.mind[0]):.3g}",
                                     rej=int(st.rejected[0]))
        tick("bookkeeping")
    if callback is not None:
        callback("end", int(st.it[0]), to_module(st.theta[0], d, cfg, None if bt.base is None else bt.base[0]))
    _store(st, torch.arange(bt.B, device=dev), out_u, out_theta, out_stop)
    names = {0: "budget", 1: "early_stop", 2: "stalled", 3: "time"}
    return EngineResult(best_uv=out_u, theta=out_theta, traces=rec.traces(),
                        stop=[names[int(s)] for s in out_stop], start_esd=start_esd,
                        rounds=rounds, backward=n_back, timing=timing)


def _store(st, idx, out_u, out_theta, out_stop):
    """Copy the results of the charts at rows ``idx`` to the per-chart outputs."""
    if len(idx) == 0:
        return
    orig = st.rows[idx].cpu().numpy()
    n = st.best_u.shape[1]
    out_u[orig, :n] = st.best_u[idx].cpu().numpy()
    out_theta[st.rows[idx]] = st.theta[idx]
    out_stop[orig] = st.stop[idx].cpu().numpy()


def _history(cfg, batch):
    """L-BFGS memory for this batch: ``cfg.history``, fewer for batches of tiny charts.

    The memory's cost per step is ``O(m·P)`` per chart whatever the chart's size,
    while the network's is ``O(n·P)``: for charts of a few dozen vertices a full
    memory would cost more than the network itself.
    """
    return int(min(cfg.history, max(5, batch.n // 4)))


def _dot(a, b):
    """Row-wise dot products ``(B,)`` in float64."""
    return torch.linalg.vecdot(a, b).to(torch.float64)


def _rowdots(A, x):
    """``A[b] @ x[b]`` for every chart: ``(B, k, P)``, ``(B, P)`` → ``(B, k)``.

    Written as ``xᵀ Aᵀ`` (a row times a transposed matrix), which the batched
    GEMM runs an order of magnitude faster on the CPU than ``A x`` for these shapes.
    """
    return torch.bmm(x[:, None, :], A.transpose(1, 2))[:, 0]


class LBFGSMemory:
    """The curvature pairs of every chart, and ``H g`` in the compact form (Byrd, Nocedal & Schnabel 1994).

    ``H g = γ g + S p₁ + γ Y p₂`` with ``[p₁; p₂] = M [Sᵀg; γYᵀg]`` and the
    ``2m × 2m`` middle matrix built from ``R = triu(SᵀY)``, ``D = diag(SᵀY)`` and
    ``YᵀY``: two batched products with the stored pairs per step (one to read
    ``Sᵀg, Yᵀg``, one to form ``S p₁ + Y p₂``) and one per update, instead of the
    two-loop recursion's ``4m`` small vector operations. One ring buffer of ``m``
    slots serves all charts; a chart that did not move this round stores a zero
    pair, which contributes nothing.
    """

    def __init__(self, B, P, m, *, dtype, device):
        self.m = max(int(m), 1)
        self.SY_vecs = torch.zeros(B, 2 * self.m, P, dtype=dtype, device=device)   # rows 0..m-1: s_i, m..2m-1: y_i
        self.SY = torch.zeros(B, self.m, self.m, dtype=torch.float64, device=device)   # s_i · y_j
        self.YY = torch.zeros_like(self.SY)                                            # y_i · y_j
        self.valid = torch.zeros(B, self.m, dtype=torch.bool, device=device)
        self.gamma = torch.zeros(B, dtype=torch.float64, device=device)                # 0: no pair yet
        self.ptr = 0

    def push(self, s, y, acc):
        """Store the pair ``(s, y)`` of the charts in ``acc`` whose curvature ``s·y`` is positive."""
        m, k = self.m, self.ptr
        z = torch.zeros((), dtype=s.dtype, device=s.device)
        self.SY_vecs[:, k] = 0
        self.SY_vecs[:, m + k] = 0
        dots = torch.stack([_rowdots(self.SY_vecs, s), _rowdots(self.SY_vecs, y)], 2).to(torch.float64)  # (B, 2m, 2)
        ss = _dot(s, s)
        sy = _dot(s, y)
        yy = _dot(y, y)
        good = acc & (sy > 1e-10 * torch.sqrt(yy * ss))
        g1 = good[:, None].to(torch.float64)
        self.SY_vecs[:, k] = torch.where(good[:, None], s, z)
        self.SY_vecs[:, m + k] = torch.where(good[:, None], y, z)
        self.SY[:, k, :] = dots[:, m:, 0] * g1                                  # s · y_j
        self.SY[:, :, k] = dots[:, :m, 1] * g1                                  # s_j · y
        self.SY[:, k, k] = sy * g1[:, 0]
        self.YY[:, k, :] = dots[:, m:, 1] * g1                                  # y · y_j
        self.YY[:, :, k] = dots[:, m:, 1] * g1
        self.YY[:, k, k] = yy * g1[:, 0]
        self.valid[:, k] = good
        self.gamma = torch.where(good, sy / yy.clamp_min(1e-300), self.gamma)
        self.ptr = (k + 1) % m

    def select(self, keep):
        """Keep only the charts ``keep`` (the batch was compacted)."""
        for k in ("SY_vecs", "SY", "YY", "valid", "gamma"):
            setattr(self, k, getattr(self, k)[keep])

    def reset(self, mask):
        """Forget every pair of the charts in ``mask``."""
        self.SY_vecs[mask] = 0
        self.SY[mask] = 0
        self.YY[mask] = 0
        self.valid[mask] = False
        self.gamma = torch.where(mask, torch.zeros_like(self.gamma), self.gamma)

    def apply(self, g):
        """``H g`` for every chart (``(B, P)``); charts without pairs get ``γ g`` with γ = 0."""
        m = self.m
        o = torch.as_tensor([(self.ptr + j) % m for j in range(m)], device=g.device)  # oldest first
        inv = torch.empty_like(o)
        inv[o] = torch.arange(m, device=g.device)
        gam = self.gamma[:, None]
        ab = _rowdots(self.SY_vecs, g).to(torch.float64)                               # [Sᵀg; Yᵀg]
        a = ab[:, :m][:, o]
        b = gam * ab[:, m:][:, o]
        SY = self.SY[:, o][:, :, o]
        R = torch.triu(SY) + torch.diag_embed((~self.valid[:, o]).to(SY.dtype))        # empty slots: identity rows
        u = torch.linalg.solve_triangular(R, a[:, :, None], upper=True)[:, :, 0]
        t = torch.diagonal(SY, dim1=1, dim2=2) * u + gam * torch.bmm(self.YY[:, o][:, :, o], u[:, :, None])[:, :, 0] - b
        p1 = torch.linalg.solve_triangular(R.transpose(1, 2), t[:, :, None], upper=False)[:, :, 0]
        p = torch.cat([p1[:, inv], (-gam * u)[:, inv]], 1).to(g.dtype)                 # back to slot order
        return gam.to(g.dtype) * g + torch.bmm(p[:, None, :], self.SY_vecs)[:, 0]


def _warmup(theta, batch, cfg, net):
    """Fit every chart's network to its absolute-mode target (Adam, ``warmup_lr``)."""
    m1 = torch.zeros_like(theta)
    m2 = torch.zeros_like(theta)
    b1, b2 = 0.9, 0.999
    mask = torch.zeros(batch.B, batch.n, 1, dtype=torch.float64, device=theta.device)
    for c, k in enumerate(batch.sizes):
        mask[c, :k] = 1.0 / k
    d = batch.X.shape[2]
    for s in range(1, cfg.warmup_iters + 1):
        th = leaves(theta, d, net["width"], net["n_layers"])
        u = forward(th, batch.X, None, **net)
        fit = (((u - batch.target) ** 2).sum(2, keepdim=True) * mask).sum() * 0.5
        fit.backward()
        with torch.no_grad():
            g = flat_grad(th)
            m1 = b1 * m1 + (1 - b1) * g
            m2 = b2 * m2 + (1 - b2) * g * g
            theta = theta - cfg.warmup_lr / (1 - b1**s) * m1 / ((m2 / (1 - b2**s)).sqrt() + 1e-8)
    return theta.detach()


class _Recorder:
    """Per-round values of every chart, in preallocated chunks (one row per round, one column per chart).

    Writing into buffers allocated once per 1,024 rounds, instead of keeping
    small per-round tensors alive, keeps the heap unfragmented: large activations
    freed every round can go back to the system (RSS stays flat).
    """

    FIELDS = (("acc", torch.bool), ("loss", torch.float64), ("esd", torch.float64), ("min_det", torch.float64),
              ("flips", torch.long), ("rejected", torch.long), ("lr", torch.float64))
    CHUNK = 1024

    def __init__(self, B, device):
        self.B, self.device = B, device
        self.chunks, self.times, self.r = [], [], 0

    def add(self, rows, acc, loss, esd, min_det, flips, rejected, lr, t):
        k = self.r % self.CHUNK
        if k == 0:
            self.chunks.append({n: torch.zeros(self.CHUNK, self.B, dtype=dt, device=self.device) for n, dt in self.FIELDS})
        c = self.chunks[-1]
        full = len(rows) == self.B   # no chart has left the batch: rows are 0..B-1
        for (n, _), v in zip(self.FIELDS, (acc, loss, esd, min_det, flips, rejected, lr)):
            if full:
                c[n][k].copy_(v)
            else:
                c[n][k, rows] = v.to(c[n].dtype)
        self.times.append(t)
        self.r += 1

    def traces(self):
        """One dict of lists per chart: the rounds where it accepted a step."""
        keys = ("iter", "loss", "esd", "min_det", "flips", "rejected", "lr", "time")
        if not self.r:
            return [{k: [] for k in keys} for _ in range(self.B)]
        cols = {n: torch.cat([c[n] for c in self.chunks])[: self.r].cpu().numpy() for n, _ in self.FIELDS}
        t = np.asarray(self.times)
        out = []
        for b in range(self.B):
            sel = np.flatnonzero(cols["acc"][:, b])
            out.append({"iter": list(range(1, len(sel) + 1)), "loss": cols["loss"][sel, b].tolist(),
                        "esd": cols["esd"][sel, b].tolist(), "min_det": cols["min_det"][sel, b].tolist(),
                        "flips": cols["flips"][sel, b].astype(int).tolist(),
                        "rejected": cols["rejected"][sel, b].astype(int).tolist(), "lr": cols["lr"][sel, b].tolist(),
                        "time": t[sel].tolist()})
        return out
