"""The batched engine: stacked per-chart networks, per-chart acceptance, compaction, L-BFGS in compact form."""
import numpy as np
import pytest
import torch

from neuraluv import datasets
from neuraluv.solver import get_config, prepare_chart, solve_charts
from neuraluv.solver.batch import make_batch
from neuraluv.solver.engine import optimise
from neuraluv.solver.lbfgs import LBFGSMemory
from neuraluv.solver.siren import forward, init_params, param_count, to_module


def _two_loop(g, pairs, gamma):
    """The textbook L-BFGS two-loop recursion (Nocedal & Wright, Alg. 7.4): H g."""
    q = g.clone()
    alphas = []
    for s, y in reversed(pairs):
        a = (s @ q) / (y @ s)
        q = q - a * y
        alphas.append(a)
    r = gamma * q
    for (s, y), a in zip(pairs, reversed(alphas)):
        b = (y @ r) / (y @ s)
        r = r + s * (a - b)
    return r


def test_compact_lbfgs_matches_the_two_loop_recursion():
    gen = torch.Generator().manual_seed(0)
    B, P, m = 3, 40, 4
    mem = LBFGSMemory(B, P, m, dtype=torch.float64, device="cpu")
    pairs = [[] for _ in range(B)]
    for step in range(6):  # more pushes than slots: the ring buffer wraps
        s = torch.randn(B, P, generator=gen, dtype=torch.float64)
        y = s + 0.3 * torch.randn(B, P, generator=gen, dtype=torch.float64)  # positive curvature
        acc = torch.tensor([True, step % 2 == 0, True])  # chart 1 moves every other round only
        mem.push(s, y, acc)
        for b in range(B):
            if acc[b]:
                pairs[b].append((s[b], y[b]))
    g = torch.randn(B, P, generator=gen, dtype=torch.float64)
    Hg = mem.apply(g)
    for b in range(B):
        # the ring keeps the last m rounds: a chart that skipped rounds keeps fewer pairs
        kept = 6 - m
        ref_pairs = [p for p in pairs[b]][-m:] if b != 1 else pairs[b][-2:]
        s_last, y_last = ref_pairs[-1]
        gamma = float((s_last @ y_last) / (y_last @ y_last))
        assert torch.allclose(Hg[b], _two_loop(g[b], ref_pairs, gamma), rtol=1e-9, atol=1e-9), (b, kept)


def test_the_dots_a_push_reads_for_the_next_direction_are_those_apply_would_read():
    """``push(..., g_next=g)`` reads ``[Sᵀg; Yᵀg]`` of the updated memory in its own pass over the pairs: the next
    ``apply(g, after_push=True)`` gives ``H g`` as a fresh read does, for the charts that accepted."""
    gen = torch.Generator().manual_seed(1)
    B, P, m = 3, 30, 3
    mem = LBFGSMemory(B, P, m, dtype=torch.float64, device="cpu")
    for step in range(5):  # wraps the ring; chart 2 accepts every other round
        s = torch.randn(B, P, generator=gen, dtype=torch.float64)
        y = s + 0.3 * torch.randn(B, P, generator=gen, dtype=torch.float64)
        g = torch.randn(B, P, generator=gen, dtype=torch.float64)
        acc = torch.tensor([True, True, step % 2 == 0])
        mem.push(s, y, acc, g_next=g)
        fresh, cached = mem.apply(g), mem.apply(g, after_push=True)
        assert torch.allclose(cached[acc], fresh[acc], rtol=1e-12, atol=1e-12), step
    mem.select(torch.tensor([0, 2]))  # a compacted batch keeps its charts' dots
    assert torch.allclose(mem.apply(g[[0, 2]], after_push=True)[0], mem.apply(g[[0, 2]])[0], rtol=1e-12, atol=1e-12)


_CONCURRENT = """
import sys, numpy as np, torch
from neuraluv import datasets
from neuraluv.solver import get_config, solve_charts
charts = [datasets.spherical_cap(3), datasets.spherical_cap(4), datasets.glove(res=2), datasets.disk(6)]
cfg = get_config("fast", iterations=60, retries=0)
old = torch.get_num_threads()
torch.set_num_threads(1)
one = solve_charts(charts, cfg, device="cpu", workers=1, max_batch=1)
two = solve_charts(charts, cfg, device="cpu", workers=2, max_batch=1, pool=sys.argv[1])
torch.set_num_threads(old)
assert torch.get_num_threads() == old
for a, b in zip(one, two):
    assert np.array_equal(a.uv, b.uv) and a.trace["esd"] == b.trace["esd"] and a.stop == b.stop, a.trace["esd"][-1]
print("same")
"""


@pytest.mark.parametrize("pool", ["thread", "process"])
def test_concurrent_batches_give_the_results_of_one_batch_after_another(pool):
    """Batches run at once (``workers``, in threads or forked processes) do not depend on each other: the same maps,
    seeds and traces.

    Run in a process of its own with MKL's strict mode (``MKL_CBWR=AUTO,STRICT``, read when torch loads MKL): by
    default MKL may take other code paths for the same call from another thread (seen on an AVX-512 machine: a chart
    solved in a worker thread ended 1e-2 away in E_SD), which is MKL's doing, not the batches'."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "MKL_CBWR": "AUTO,STRICT", "OPENBLAS_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", _CONCURRENT, pool], capture_output=True, text=True, env=env,
                         timeout=300)
    assert out.returncode == 0 and out.stdout.strip().endswith("same"), out.stderr[-2000:]


def test_flat_network_is_the_siren_module():
    V, F = datasets.spherical_cap(4)
    cfg = get_config("fast")
    p = prepare_chart(V, F, cfg)
    b = make_batch([p])
    theta = init_params([3], b.X.shape[2], cfg)
    assert theta.shape == (1, param_count(b.X.shape[2], cfg.width, cfg.n_layers))
    net = to_module(theta[0], b.X.shape[2], cfg, b.base[0])
    u = forward(theta, b.X, b.base, width=cfg.width, n_layers=cfg.n_layers, omega0=cfg.omega0)[0]
    assert torch.allclose(u, net(b.X[0]), atol=1e-6)
    # the residual head starts at zero: the network reproduces the start exactly
    assert torch.equal(u, b.base[0])


@pytest.mark.parametrize("preset", ["test", "fast"])
def test_many_charts_in_one_batch_each_valid_with_its_own_trace(preset):
    charts = [datasets.spherical_cap(n) for n in (3, 4, 5)] + [datasets.glove(res=2), datasets.disk(3)]
    cfg = get_config(preset, iterations=80, retries=0)
    res = solve_charts(charts, cfg, device="cpu")
    assert len(res) == len(charts)
    for r, (V, F) in zip(res, charts):
        assert r.status == "neural" and r.metrics["flips"] == 0 and r.uv.shape == (len(V), 2)
        t = r.trace
        assert 0 < len(t["iter"]) <= 80 and len(t["esd"]) == len(t["iter"]) and all(f == 0 for f in t["flips"])
        assert min(t["esd"]) <= r.metrics["esd"] * (1 + 1e-9)  # the returned map is the best iterate


def test_compaction_keeps_the_results_of_finished_charts():
    """Charts stopping at different times leave the batch; every chart still gets its own best map."""
    charts = [datasets.spherical_cap(3), datasets.glove(res=2), datasets.spherical_cap(4), datasets.disk(2)]
    cfg = get_config("fast", iterations=300, patience=20, tol=0.05, early_after=0.0)
    preps = [prepare_chart(V, F, cfg) for V, F in charts]
    batch = make_batch(preps)
    r = optimise(batch, cfg, [0] * len(preps))
    its = [len(t["iter"]) for t in r.traces]
    assert len(set(its)) > 1 and min(its) < 300  # charts stopped at different rounds
    for k, p in enumerate(preps):
        n = len(p.X)
        assert np.all(np.isfinite(r.best_uv[k, :n]))
        from neuraluv.metrics import distortion_metrics

        assert distortion_metrics(p.Vn, p.F, r.best_uv[k, :n])["flips"] == 0


def test_a_compacted_batch_padded_to_its_largest_chart_evaluates_the_same_maps_and_losses():
    """``subset_batch(trim=True)`` drops the padding rows past the largest kept chart and re-indexes the faces: the kept
    charts' maps, losses and gradients are those of the untrimmed subset."""
    from neuraluv.solver.energy import chart_objective
    from neuraluv.solver.batch import subset_batch
    from neuraluv.solver.siren import flat_grad, leaves

    charts = [datasets.spherical_cap(3), datasets.glove(res=2), datasets.disk(2), datasets.spherical_cap(2)]
    cfg = get_config("fast")
    batch = make_batch([prepare_chart(V, F, cfg) for V, F in charts])
    keep = np.array([0, 2, 3])
    assert batch.sizes[keep].max() < batch.n  # the glove, the largest, leaves
    out = []
    for trim in (False, True):
        sub = subset_batch(batch, keep, trim=trim)
        theta = init_params([0, 1, 2], sub.X.shape[2], cfg, residual=True)
        th = leaves(theta, sub.X.shape[2], cfg.width, cfg.n_layers)
        u = forward(th, sub.X, sub.base, width=cfg.width, n_layers=cfg.n_layers, omega0=float(cfg.omega0))
        o = chart_objective(u.reshape(-1, 2), sub.F, sub.dC_inv, sub.w, sub.face_chart, sub.B,
                            torch.full((sub.B,), 1.0, dtype=torch.float64), cfg.eps_J, cfg.eps)
        o.loss.sum().backward()
        out.append((sub.n, u.detach(), o.loss.detach(), flat_grad(th)))
    (n0, u0, l0, g0), (n1, u1, l1, g1) = out
    assert n1 == batch.sizes[keep].max() < n0
    assert torch.allclose(u1, u0[:, :n1]) and torch.allclose(l1, l0, rtol=1e-6) and torch.allclose(g1, g0, rtol=1e-4,
                                                                                                     atol=1e-7)


def test_deadline_stops_every_chart_with_a_valid_map():
    import time

    V, F = datasets.glove()
    res = solve_charts([(V, F)], get_config("fast", iterations=100000, early_stop=False), device="cpu",
                       deadline=time.perf_counter() + 1.0)[0]
    assert res.stop == "time" and res.metrics["flips"] == 0 and res.time < 10


def test_fast_preset_is_the_papers_recipe_with_a_smaller_network_and_lbfgs():
    f, p = get_config("fast"), get_config("paper")
    assert (f.width, f.n_layers, f.omega0, f.optimizer) == (64, 4, 60.0, "lbfgs")
    same = ("k", "init", "residual", "eps_J", "eps", "alpha_start", "alpha_end", "reject", "det_drop", "start_relax",
            "relax_below", "retries")
    assert all(getattr(f, a) == getattr(p, a) for a in same)
    assert f.start_slim == p.start_slim == get_config("literal").start_slim == 0   # the atlas's routing sets it


def test_every_chart_of_a_batch_reports_why_it_stopped():
    """Budget and stall in one batch (the stalled chart leaves it first), as ``Stop`` members, never RUNNING."""
    from neuraluv.solver.result import Stop

    charts = [datasets.spherical_cap(4), datasets.glove(res=2)]
    cfg = get_config("test", iterations=12, max_backtracks=2)
    preps = [prepare_chart(V, F, cfg) for V, F in charts]
    # a learning rate 10^4 times the preset's makes every step of the second chart fold: it stalls at its start
    r = optimise(make_batch(preps), cfg, [0, 0], lr_scale=[1.0, 1e4])
    assert r.stop == [Stop.BUDGET, Stop.STALLED]
    assert len(r.traces[0]["iter"]) == 12 and r.traces[1]["iter"] == []
    assert r.traces[0]["rejected"][-1] == 0
    # the stalled chart's best map is its start, kept after it left the batch
    n = len(preps[1].X)
    assert np.array_equal(r.best_uv[1, :n], preps[1].u_start)


def test_a_passed_deadline_stops_every_chart_before_any_step():
    import time

    from neuraluv.solver.result import Stop

    charts = [datasets.spherical_cap(3), datasets.spherical_cap(4)]
    cfg = get_config("fast", iterations=50)
    preps = [prepare_chart(V, F, cfg) for V, F in charts]
    r = optimise(make_batch(preps), cfg, [0, 0], deadline=time.perf_counter() - 1.0)
    assert r.stop == [Stop.TIME, Stop.TIME] and r.rounds == 0 and r.backward == 1
    assert all(t["iter"] == [] for t in r.traces)


def test_early_stop_is_reported_per_chart():
    from neuraluv.solver.result import Stop

    tol = 1e-3
    cfg = get_config("fast", iterations=300, patience=20, tol=tol, early_after=0.0)
    preps = [prepare_chart(V, F, cfg) for V, F in (datasets.spherical_cap(3), datasets.disk(2))]
    r = optimise(make_batch(preps), cfg, [0, 0])
    assert r.stop == [Stop.EARLY_STOP, Stop.EARLY_STOP]
    cap, disk = r.traces
    # the cap levels off well above an isometry's E_SD: the plateau test, after `patience` steps at the least
    assert 20 <= len(cap["iter"]) < 300 and min(cap["esd"]) > 4 * (1 + tol)
    # the flat disk comes within tol of an isometry's E_SD (4), below which no step can gain tol: it stops there
    assert len(disk["iter"]) < 20 and disk["esd"][-1] <= 4 * (1 + tol) < min(disk["esd"][:-1])


def test_a_chart_converged_to_rounding_stops_without_waiting_for_the_plateau_window():
    from neuraluv.solver.result import Stop

    charts = (datasets.spherical_cap(3), datasets.spherical_cap(4))
    runs = {}
    for ftol in (1e-9, 0.0):   # a plateau window longer than the budget: it never ends these solves
        cfg = get_config("fast", iterations=300, patience=400, tol=1e-12, early_after=0.0, ftol=ftol)
        runs[ftol] = optimise(make_batch([prepare_chart(V, F, cfg) for V, F in charts]), cfg, [0, 0])
    on, off = runs[1e-9], runs[0.0]
    assert on.stop == [Stop.EARLY_STOP, Stop.EARLY_STOP] and Stop.EARLY_STOP not in off.stop
    for a, b in zip(on.traces, off.traces):
        assert len(a["iter"]) < len(b["iter"]) <= 300
        e = np.minimum.accumulate(a["esd"])
        assert e[-6] - e[-1] < 1e-9 * e[-1] and min(a["esd"]) == pytest.approx(min(b["esd"]), rel=1e-8)


def test_until_stops_the_charts_whose_best_map_passes_the_callers_test():
    from neuraluv.solver.result import Stop

    cfg = get_config("fast", iterations=120, early_stop=False)
    preps = [prepare_chart(V, F, cfg) for V, F in (datasets.spherical_cap(3), datasets.spherical_cap(4))]
    asked, seen = [], {}

    def done(rows, uvs):   # chart 0 is done at the second question, chart 1 never
        asked.append(list(rows))
        for r, u in zip(rows, uvs):
            seen[int(r)] = u.copy()
        return [int(r) == 0 and len(asked) >= 2 for r in rows]

    r = optimise(make_batch(preps), cfg, [0, 0], until=(5, done))
    assert asked[0] == [0, 1] and asked[1] == [0, 1] and len(asked) > 2 and all(a == [1] for a in asked[2:])
    # chart 1 runs on alone until its budget, or until its line search finds no lower energy (where that happens
    # depends on the machine's floating-point kernels: an AVX-512 machine stalls it before the budget)
    assert r.stop[0] == Stop.REACHED and r.stop[1] in (Stop.BUDGET, Stop.STALLED) and r.rounds > 10
    assert r.stop[1] == Stop.STALLED or r.rounds >= 120
    assert Stop.from_label(Stop.REACHED.label) is Stop.REACHED
    # what the test saw is what the chart returns: its best map at the round it stopped (10)
    assert np.array_equal(r.best_uv[0, : len(preps[0].X)], seen[0]) and len(r.traces[0]["iter"]) <= 10
    through = solve_charts(None, cfg, preps=preps, until=(5, lambda ids, uvs: [i == 1 for i in ids]), workers=1)
    assert through[0].stop != "reached" and through[1].stop == "reached"


def test_a_solve_goes_on_from_the_parameters_it_is_given():
    """``theta0`` starts a chart where an earlier solve stopped (routing's second go), not at its initialisation."""
    V, F = datasets.spherical_cap(4)
    cfg = get_config("fast", iterations=30, early_stop=False)
    batch = make_batch([prepare_chart(V, F, cfg)])
    first = optimise(batch, cfg, [0])
    again = optimise(batch, get_config("fast", iterations=1), [0], theta0=[first.theta[0]])
    fresh = optimise(batch, get_config("fast", iterations=1), [0])
    assert fresh.start_esd[0] == pytest.approx(first.start_esd[0])
    assert again.start_esd[0] < first.start_esd[0] - 1e-6
    assert again.start_esd[0] == pytest.approx(min(first.traces[0]["esd"]), rel=1e-3)
    res = solve_charts(None, cfg, preps=[prepare_chart(V, F, cfg)], device="cpu")[0]
    assert res.theta is not None and res.theta.shape == first.theta[0].shape
