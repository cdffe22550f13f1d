"""Validity-checked optimisation of chart networks, many charts at once (Algorithm 1, lines 4–13).

Every chart has its own SIREN (the paper's per-chart network). The networks of
a batch of charts are evaluated together: their weights are stacked into one
flat tensor ``theta (B, P)`` (chart ``c``'s parameters in row ``c``), their
inputs padded to a common vertex count, and each layer is one batched matrix
product (``torch.baddbmm``). A chart with ``B = 1`` is the same code.

:func:`optimise` runs rounds; one *round* (a method of the run each):

1. ``propose`` a trial for every running chart (Adam's update, or the L-BFGS
   direction scaled by the chart's current step);
2. ``evaluate`` all trials in one forward pass (energy, barrier, flips, smallest det J);
3. ``decide`` per chart, as tensor operations without a Python loop over charts:
   accept when there is no new flipped face, no collapse of the smallest det J,
   and no loss rise / sufficient decrease;
4. ``merge``: backpropagate only if some chart accepted, and take the accepted
   trials with ``torch.where`` — the optimiser state is never copied, the
   accepted and the trial states are kept side by side;

then ``adapt`` halves the step of each refused chart (retried from the same
state next round, so a refused trial costs one forward pass) and stops the
charts that are done (:class:`~neuraluv.solver.result.Stop`); ``retire`` drops
them from the batch.

Two parameterisations share that loop (``cfg.param``): ``"siren"``, the
paper's network, and ``"vertex"``, free per-vertex displacements from the same
start (:mod:`neuraluv.solver.vertex`, the control of "what the network adds");
only ``evaluate`` differs.

Two optimisers share that loop:

* ``adam`` — the paper's (Adam with a cosine learning rate), written out on
  the stacked parameters; mathematically PyTorch's ``torch.optim.Adam``.
* ``lbfgs`` — limited-memory BFGS with a backtracking (Armijo) line search whose
  trials are the same validity-checked trials; the ``fast`` preset's optimiser.
  Its memory (:class:`~neuraluv.solver.lbfgs.LBFGSMemory`) writes one history
  slot for all charts every round (a zero pair, i.e. a no-op, for charts that
  did not move), so all charts share one ring buffer and no per-chart gather is
  needed.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import torch

from neuraluv.metrics import ESD_ISOMETRY
from neuraluv.solver import vertex
from neuraluv.solver.batch import subset_batch
from neuraluv.solver.energy import chart_objective
from neuraluv.solver.lbfgs import LBFGSMemory, memory_length, row_dot
from neuraluv.solver.result import Stop
from neuraluv.solver.siren import flat_grad, forward, init_params, leaves
from neuraluv.solver.trace import TraceRecorder
from neuraluv.solver.vertex import chart_module, check_param

__all__ = ["optimise", "EngineResult"]


# --------------------------------------------------------------------------- the optimisation loop


@dataclass
class EngineResult:
    """What :func:`optimise` returns, per chart (row ``c`` of every array)."""

    best_uv: np.ndarray          #: (B, n, 2) float64, the best map (fewest flips, then lowest E_SD)
    theta: torch.Tensor          #: (B, P) final parameters
    traces: list                 #: one dict of lists per chart (iter, loss, esd, min_det, flips, rejected, lr, time)
    stop: list                   #: one :class:`~neuraluv.solver.result.Stop` per chart (never ``RUNNING``)
    start_esd: np.ndarray        #: (B,) true E_SD of the start (before any step)
    rounds: int                  #: rounds run (forward passes)
    backward: int                #: backward passes
    timing: dict                 #: seconds in forward, objective, backward, optimiser, bookkeeping


def optimise(batch, cfg, seeds, *, lr_scale=None, callback=None, progress=None, deadline=None, profile=False,
             theta0=None, until=None):
    """Run Algorithm 1's optimisation on every chart of a batch.

    Parameters
    ----------
    batch : :class:`~neuraluv.solver.batch.ChartBatch`
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
        ``time.perf_counter()`` value at which every chart stops (``Stop.TIME``).
    profile : bool
        Synchronise the device around each phase so ``timing`` is exact (slower on CUDA).
    theta0 : list of ((P,) tensor or None), optional
        Per chart, parameters to start from instead of its seed's initialisation (an
        earlier solve's ``EngineResult.theta`` row, to continue it); residual mode only.
    until : (int, callable), optional
        ``(every, done)``: every ``every`` rounds, ``done(rows, uvs)`` is asked about the running
        charts whose best map is flip-free (``rows``: their rows in the batch; ``uvs``: those maps,
        ``(n_c, 2)`` arrays without the padding) and returns one bool per chart; a chart given True
        stops (``Stop.REACHED``). Routing's solve-on ends a map as soon as its boundary no longer
        crosses itself.

    Returns
    -------
    EngineResult

    Notes
    -----
    Each round is the body of Algorithm 1's loop for every running chart:
    propose a step (line 9), evaluate
    ``L(θ) = Σ_t A_t ‖J_t‖²_F (1 + q(det J_t)) + α(s) Σ_t [ε − det J_t]₊²`` and the
    determinants at the trial (lines 6–8), refuse the trial of a chart that
    flips a face (or trips a guard) and halve its step (lines 10–11), and
    backpropagate only the accepted ones. Charts that stop (:class:`~neuraluv.solver.result.Stop`:
    budget, early stop, stall, time) leave the batch as soon as at most half of
    it is still running, so a batch never keeps evaluating the networks of
    finished charts for long.
    """
    run = _Run(batch, cfg, seeds, lr_scale=lr_scale, callback=callback, progress=progress, profile=profile,
               theta0=theta0)
    while run.retire(deadline):
        run.rounds += 1
        trial = run.propose()                                    # 1. propose
        th, u, new = run.evaluate(trial.theta, run.st.it + 1)    # 2. evaluate (at the next barrier weight)
        acc = run.decide(new)                                    # 3. decide, per chart
        run.merge(trial, th, u, new, acc)                        # 4. backpropagate the accepted, merge
        run.adapt(acc)                                           # steps halved / regrown; charts that stop
        if until is not None and run.rounds % until[0] == 0:
            run.reach(until[1])                                  # the caller's test of the best maps
        run.record(acc, new, trial.lr)
        run.report(acc)
    return run.finish()


def _alpha(it, cfg):
    """The barrier weight α(s), annealed exponentially from ``alpha_start`` to ``alpha_end`` (``(B,)``)."""
    frac = torch.clamp(it / max(cfg.iterations, 1), 0.0, 1.0)
    return cfg.alpha_start * torch.exp(frac * math.log(cfg.alpha_end / cfg.alpha_start))


def _cosine(it, cfg, lr):
    """Cosine learning rate from ``lr`` down to ``lr_min`` over ``iterations`` accepted steps (``(B,)``)."""
    return cfg.lr_min + 0.5 * (lr - cfg.lr_min) * (1.0 + torch.cos(math.pi * torch.clamp(it / max(cfg.iterations, 1), 0.0, 1.0)))


class _State:
    """Per-chart tensors of a running optimisation (row ``i`` ↔ chart ``rows[i]``), compactable."""

    def __init__(self, **tensors):
        self.__dict__.update(tensors)

    def select(self, keep):
        for k, v in list(self.__dict__.items()):
            if torch.is_tensor(v) and v.dim() > 0:
                setattr(self, k, v[keep])


@dataclass
class _Trial:
    """The point proposed for every chart of the batch in one round."""

    theta: torch.Tensor          #: (B, P) parameters (a chart that is not running keeps its own)
    lr: torch.Tensor             #: (B,) Adam's learning rate, or L-BFGS's step length along its direction
    moments: tuple = None        #: Adam's ``(m1, m2, steps)`` after this step, kept if it is accepted


class _Run:
    """One :func:`optimise` call: the batch, every chart's state, and the steps of a round.

    ``st`` holds the running charts' tensors (see :class:`_State`); a chart that
    stops leaves it (:meth:`retire`) after its results are copied to ``out_u``,
    ``out_theta`` and ``out_stop`` at its original row.
    """

    def __init__(self, batch, cfg, seeds, *, lr_scale, callback, progress, profile, theta0=None):
        dev = batch.X.device
        self.cfg, self.bt, self.d = cfg, batch, batch.X.shape[2]
        self.callback, self.progress = callback, progress
        self.net = dict(width=cfg.width, n_layers=cfg.n_layers, omega0=float(cfg.omega0))
        self.lbfgs = cfg.optimizer == "lbfgs"
        self.vertex = check_param(cfg) == "vertex"
        if self.vertex:
            if batch.base is None:
                raise ValueError("param='vertex' displaces the valid start: it needs residual=True and init='tutte'")
            theta = vertex.init_params(batch.B, batch.n, device=dev)
        else:
            theta = init_params(seeds, self.d, cfg, residual=batch.base is not None, device=dev)
        if theta0 is not None:
            if batch.base is None:
                raise ValueError("theta0 continues a residual solve: it needs residual=True and init='tutte'")
            for c, t in enumerate(theta0):
                if t is not None:
                    theta[c] = torch.as_tensor(t, dtype=theta.dtype, device=dev)
        self.timing = dict.fromkeys(("forward", "objective", "backward", "optimiser", "bookkeeping"), 0.0)
        self._sync = (lambda: torch.cuda.synchronize(dev)) if (profile and dev.type == "cuda") else (lambda: None)
        self._clock = time.perf_counter()
        # Algorithm 1, line 4: the warm-up (absolute mode only: a residual network already equals its base)
        if batch.target is not None and cfg.warmup_iters > 0:
            theta = _warmup(theta, batch, cfg, self.net)
        self._notify("warmup_end", 0, theta)
        self._start(theta, lr_scale)

    def _start(self, theta, lr_scale):
        """Evaluate the start of every chart (loss, gradient, flips) and set up the optimiser's state."""
        B0, dev, cfg = self.bt.B, self.bt.X.device, self.cfg
        f64 = dict(dtype=torch.float64, device=dev)
        th, u, cur = self.evaluate(theta, torch.zeros(B0, **f64))
        cur.loss.sum().backward()
        self.tick("backward")
        self.st = st = _State(
            rows=torch.arange(B0, device=dev), theta=theta, g=flat_grad(th),
            scale0=torch.ones(B0, **f64) if lr_scale is None else torch.as_tensor(np.asarray(lr_scale, float), **f64),
            loss=cur.loss.detach(), flips=cur.flips, mind=cur.min_det.detach(),
            best_key=torch.stack([cur.flips.to(torch.float64), cur.esd.detach()], 1), best_u=u.detach().clone(),
            it=torch.zeros(B0, **f64), active=torch.ones(B0, dtype=torch.bool, device=dev),
            stop=torch.full((B0,), int(Stop.RUNNING), dtype=torch.long, device=dev),
            backtracks=torch.zeros(B0, dtype=torch.long, device=dev),
            rejected=torch.zeros(B0, dtype=torch.long, device=dev), scale=torch.ones(B0, **f64),
            best_ring=torch.full((B0, max(int(cfg.patience), 1)), float("inf"), **f64),
        )
        self.start_esd = cur.esd.detach().cpu().numpy()
        self.n_back, self.rounds = 1, 0
        if self.lbfgs:
            self.mem = LBFGSMemory(B0, theta.shape[1], memory_length(cfg, self.bt.n), dtype=theta.dtype, device=dev)
            st.dirn = torch.zeros_like(theta)          # the current search direction
            st.gd = torch.zeros(B0, **f64)             # its slope g·d (the Armijo test's)
            st.in_ls = torch.zeros(B0, dtype=torch.bool, device=dev)   # in a line search: keep the direction
        else:
            st.m1 = torch.zeros_like(theta)
            st.m2 = torch.zeros_like(theta)
            st.steps = torch.zeros(B0, **f64)
            self.betas = tuple(float(x) for x in cfg.betas)
        self.patience = max(int(cfg.patience), 1)
        self.early_from = max(self.patience, int(cfg.early_after * cfg.iterations))
        self.esd_floor = ESD_ISOMETRY * (1.0 + cfg.tol)   # no step can lower a best E_SD below it by tol
        self.ftol_steps = min(max(int(cfg.ftol_steps), 1), self.patience)
        self.out_u = np.zeros((B0, self.bt.n, 2))
        self.out_theta = torch.zeros(B0, theta.shape[1], dtype=theta.dtype, device=dev)
        self.out_stop = np.full(B0, int(Stop.RUNNING), np.int64)
        self.rec = TraceRecorder(B0, dev)
        self.t0 = time.perf_counter()
        self.tick("bookkeeping")

    def tick(self, key):
        """Add the time since the last tick to ``timing[key]``."""
        self._sync()
        now = time.perf_counter()
        self.timing[key] += now - self._clock
        self._clock = now

    def evaluate(self, theta, it):
        """UVs and the objective of every chart at ``theta (B, P)``, barrier weight ``α(it)`` (lines 6–8)."""
        bt, cfg = self.bt, self.cfg
        if self.vertex:
            th = vertex.leaves(theta)
            u = vertex.forward(th, bt.base, mask=bt.mask)
        else:
            th = leaves(theta, self.d, cfg.width, cfg.n_layers)
            u = forward(th, bt.X, bt.base, mask=bt.mask, **self.net)
        self.tick("forward")
        o = chart_objective(u.reshape(-1, 2), bt.F, bt.dC_inv, bt.w, bt.face_chart, bt.B, _alpha(it, cfg),
                            cfg.eps_J, cfg.eps)
        self.tick("objective")
        return th, u, o

    def retire(self, deadline):
        """Stop every chart at the deadline; drop the finished charts once at most half the batch runs, and the
        padding beyond the largest chart still running.

        Returns False when no chart is running.
        """
        st = self.st
        if deadline is not None and time.perf_counter() > deadline:
            self._finish(st.active, Stop.TIME)
        n_active = int(st.active.sum())
        if n_active == 0:
            return False
        if n_active <= self.bt.B // 2:
            keep = torch.nonzero(st.active).squeeze(1)
            self._store(torch.nonzero(~st.active).squeeze(1))
            st.select(keep)
            if self.lbfgs:
                self.mem.select(keep)
            # padded to the largest running chart (the vertex parameters of param="vertex" are per padded row)
            self.bt = subset_batch(self.bt, keep.cpu().numpy(), trim=not self.vertex)
            st.best_u = st.best_u[:, : self.bt.n]
        return True

    def propose(self):
        """Step 1: a trial point for every running chart."""
        with torch.no_grad():
            trial = self._propose_lbfgs() if self.lbfgs else self._propose_adam()
        self.tick("optimiser")
        return trial

    def _propose_lbfgs(self):
        """The chart's L-BFGS direction times its step; a chart not in a line search gets a new direction (step 1)."""
        st, cfg, mem = self.st, self.cfg, self.mem
        fresh = st.active & ~st.in_ls
        if bool(fresh.any()):  # a chart that accepted its last step (the last push read its dots), or none yet
            gnorm = st.g.norm(dim=1).clamp_min(1e-30).to(torch.float64)
            sd = -st.g * (cfg.lr * st.scale0 / gnorm).to(st.g.dtype)[:, None]     # scaled steepest descent
            dnew = torch.where((mem.gamma > 0)[:, None], -mem.apply(st.g, after_push=True), sd)
            gdn = row_dot(st.g, dnew)
            bad = (gdn >= 0) & fresh
            if bool(bad.any()):  # not a descent direction: forget this chart's curvature pairs
                mem.reset(bad)
                dnew = torch.where(bad[:, None], sd, dnew)
                gdn = torch.where(bad, row_dot(st.g, sd), gdn)
            st.dirn = torch.where(fresh[:, None], dnew, st.dirn)
            st.gd = torch.where(fresh, gdn, st.gd)
            st.scale = torch.where(fresh, torch.ones_like(st.scale), st.scale)
        theta = torch.where(st.active[:, None], st.theta + st.scale.to(st.theta.dtype)[:, None] * st.dirn, st.theta)
        return _Trial(theta, st.scale)

    def _propose_adam(self):
        """Adam's step at the cosine learning rate times the chart's step factor (step 1).

        PyTorch's formula: ``m ← β₁m + (1−β₁)g``, ``v ← β₂v + (1−β₂)g²``, ``θ ← θ − lr·m̂/(√v̂ + 1e-8)``.
        """
        st, cfg = self.st, self.cfg
        b1, b2 = self.betas
        lr = _cosine(st.it, cfg, cfg.lr * st.scale0) * st.scale
        m1 = torch.lerp(st.m1, st.g, 1 - b1)
        m2 = torch.lerp(st.m2, st.g * st.g, 1 - b2)
        steps = st.steps + 1
        bc1 = 1 - b1**steps
        denom = m2.sqrt().div_((1 - b2**steps).sqrt().to(st.g.dtype)[:, None]).add_(1e-8)
        if self.bt.B == 1:
            theta = torch.addcdiv(st.theta, m1, denom, value=-float(lr[0] / bc1[0]))
        else:
            upd = (lr / bc1).to(st.g.dtype)[:, None] * m1 / denom
            theta = torch.where(st.active[:, None], st.theta - upd, st.theta)
        return _Trial(theta, lr, (m1, m2, steps))

    def decide(self, new):
        """Step 3: which running charts accept their trial (``(B,)`` bool).

        Refused: a non-finite loss; with ``cfg.reject``, more flipped faces than
        before, the smallest det J falling below ``min(det_drop · before, ε)``
        (``det_drop``), a loss rise above ``loss_rise`` (Adam) or no sufficient
        decrease (L-BFGS's Armijo test). The loss is compared at the same α.
        """
        st, cfg = self.st, self.cfg
        with torch.no_grad():
            loss_new = new.loss.detach()
            cmp_new = new.stable.detach() + _alpha(st.it, cfg) * new.barrier.detach()   # at the same α as st.loss
            ok = torch.isfinite(loss_new) & torch.isfinite(cmp_new)
            if cfg.reject:
                ok &= new.flips <= st.flips
                if cfg.det_drop > 0:
                    guard = new.min_det >= torch.clamp(cfg.det_drop * st.mind, max=cfg.eps)
                    ok &= guard | (st.flips > 0)
                if self.lbfgs:
                    ok &= cmp_new <= st.loss + cfg.armijo * st.scale * st.gd
                elif cfg.loss_rise > 0:
                    ok &= cmp_new <= st.loss * (1.0 + cfg.loss_rise)
            acc = st.active & ok
        self.tick("bookkeeping")
        return acc

    def merge(self, trial, th, u, new, acc):
        """Step 4: backpropagate the accepted charts' losses (only when some chart accepted) and take their trials."""
        n_acc = int(acc.sum())
        if not n_acc:
            return
        (new.loss * acc.to(new.loss.dtype)).sum().backward()
        self.n_back += 1
        self.tick("backward")
        g = flat_grad(th)
        st = self.st
        with torch.no_grad():
            every = n_acc == self.bt.B
            a1 = acc[:, None]
            if self.lbfgs:
                self.mem.push(trial.theta - st.theta, g - st.g, acc, g_next=g)
                st.in_ls = st.in_ls & ~acc
            elif every:
                st.m1, st.m2, st.steps = trial.moments
            else:
                m1, m2, steps = trial.moments
                st.m1 = torch.where(a1, m1, st.m1)
                st.m2 = torch.where(a1, m2, st.m2)
                st.steps = torch.where(acc, steps, st.steps)
            if every:
                st.theta, st.g = trial.theta, g
            else:
                st.theta = torch.where(a1, trial.theta, st.theta)
                st.g = torch.where(a1, g, st.g)
            st.loss = torch.where(acc, new.loss.detach(), st.loss)
            st.flips = torch.where(acc, new.flips, st.flips)
            st.mind = torch.where(acc, new.min_det.detach(), st.mind)
            st.it = st.it + acc.to(st.it.dtype)
            # the best map so far: fewest flips, then lowest E_SD
            key = torch.stack([new.flips.to(torch.float64), new.esd.detach()], 1)
            better = acc & ((key[:, 0] < st.best_key[:, 0]) | ((key[:, 0] == st.best_key[:, 0]) & (key[:, 1] < st.best_key[:, 1])))
            if bool(better.any()):
                st.best_key = torch.where(better[:, None], key, st.best_key)
                st.best_u[better] = u.detach()[better]

    def adapt(self, acc):
        """After the decision: halve the refused charts' steps (regrow Adam's accepted ones) and stop the charts
        that stalled (more than ``max_backtracks`` refusals in a row), spent their ``iterations``, or stopped
        improving (early stopping)."""
        st, cfg = self.st, self.cfg
        with torch.no_grad():
            rej = st.active & ~acc
            st.rejected = st.rejected + rej.long()
            st.backtracks = torch.where(acc, torch.zeros_like(st.backtracks), st.backtracks + rej.long())
            if self.lbfgs:
                st.in_ls = st.in_ls | rej
                st.scale = torch.where(rej, st.scale * cfg.backtrack, st.scale)
            else:
                st.scale = torch.where(acc, torch.clamp(st.scale * cfg.step_recover, max=1.0),
                                       torch.where(rej, st.scale * cfg.backtrack, st.scale))
            self._finish(rej & (st.backtracks > cfg.max_backtracks), Stop.STALLED)
            self._finish(st.active & (st.it >= cfg.iterations), Stop.BUDGET)
            if cfg.early_stop and bool(acc.any()):
                self._finish(self._plateau(acc), Stop.EARLY_STOP)

    def _plateau(self, acc):
        """Charts whose best E_SD (flip-free) improved by less than ``tol`` over their last ``patience`` accepted
        steps, or can no longer improve by that much: within ``tol`` of an isometry's E_SD; or by less than
        ``ftol`` over their last ``ftol_steps`` (converged to rounding).

        No window of steps can lower E_SD by more than its distance to :data:`~neuraluv.metrics.ESD_ISOMETRY`,
        the least E_SD of any map; a chart whose best is within ``4 · tol`` of it is sure to pass the
        plateau test once the test starts (after ``patience`` steps), and stops now instead.
        """
        st, cfg = self.st, self.cfg
        slot = (st.it.long() % self.patience)[:, None]
        old = st.best_ring.gather(1, slot).squeeze(1)      # best E_SD `patience` accepted steps ago
        recent = st.best_ring.gather(1, ((st.it.long() - self.ftol_steps) % self.patience)[:, None]).squeeze(1)
        best = st.best_key[:, 1]
        st.best_ring.scatter_(1, slot, torch.where(acc, best, old)[:, None])
        done = (((st.it >= self.early_from) & ((old - best) <= cfg.tol * best.abs())) | (best <= self.esd_floor)
                | ((recent - best) < cfg.ftol * best.abs()))   # `ftol_steps` ago (inf before: never); ftol 0: off
        return acc & st.active & (st.best_key[:, 0] == 0) & done

    def reach(self, done):
        """Stop the running charts with a flip-free best map that ``done(rows, uvs)`` accepts (``Stop.REACHED``)."""
        st = self.st
        idx = torch.nonzero(st.active & (st.best_key[:, 0] == 0)).squeeze(1).cpu().numpy()
        if len(idx):
            sizes = np.asarray(self.bt.sizes)
            best = st.best_u.detach().cpu().numpy()
            ok = np.asarray(done(st.rows[idx].cpu().numpy(), [best[i, : sizes[i]] for i in idx]), bool)
            mask = torch.zeros_like(st.active)
            mask[torch.as_tensor(idx[ok], dtype=torch.long, device=mask.device)] = True
            self._finish(mask, Stop.REACHED)
        self.tick("bookkeeping")

    def _finish(self, mask, reason):
        """Stop the charts in ``mask (B,)`` for ``reason`` (a :class:`Stop`)."""
        st = self.st
        st.stop = torch.where(mask, torch.full_like(st.stop, int(reason)), st.stop)
        st.active = st.active & ~mask

    def record(self, acc, new, lr):
        """The round's values of every chart into the trace."""
        st = self.st
        with torch.no_grad():
            self.rec.add(st.rows, acc, st.loss, new.esd.detach(), st.mind, st.flips, st.rejected, lr,
                         time.perf_counter() - self.t0)

    def report(self, acc):
        """The callback and the progress bar of a single chart, after each accepted step."""
        st = self.st
        if self.callback is not None and bool(acc[0]):
            self._notify("step", int(st.it[0]), st.theta)
        if self.progress is not None and bool(acc[0]):
            self.progress.update(1)
            if int(st.it[0]) % 25 == 0:
                self.progress.set_postfix(esd=f"{float(st.best_key[0, 1]):.4g}", min_det=f"{float(st.mind[0]):.3g}",
                                          rej=int(st.rejected[0]))
        self.tick("bookkeeping")

    def _notify(self, event, step, theta):
        """``callback(event, step, model)`` with chart 0's network at ``theta[0]``."""
        if self.callback is not None:
            base = None if self.bt.base is None else self.bt.base[0, : int(self.bt.sizes[0])]
            self.callback(event, step, chart_module(theta[0], self.d, self.cfg, base))

    def _store(self, idx):
        """Copy the results of the charts at rows ``idx`` to the per-chart outputs."""
        st = self.st
        if len(idx) == 0:
            return
        orig = st.rows[idx].cpu().numpy()
        n = st.best_u.shape[1]
        self.out_u[orig, :n] = st.best_u[idx].cpu().numpy()
        self.out_theta[st.rows[idx]] = st.theta[idx]
        self.out_stop[orig] = st.stop[idx].cpu().numpy()

    def finish(self):
        """The callback's ``"end"`` and the :class:`EngineResult` of every chart."""
        self._notify("end", int(self.st.it[0]), self.st.theta)
        self._store(torch.arange(self.bt.B, device=self.bt.X.device))
        return EngineResult(best_uv=self.out_u, theta=self.out_theta, traces=self.rec.traces(),
                            stop=[Stop(int(s)) for s in self.out_stop], start_esd=self.start_esd,
                            rounds=self.rounds, backward=self.n_back, timing=self.timing)


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
