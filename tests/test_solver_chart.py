"""The chart solver: zero flips, step rejection with state restore, retry, fallback."""
from dataclasses import replace

import numpy as np
import pytest
import torch

from neuraluv import datasets
from neuraluv.errors import TopologyError
from neuraluv.solver import PRESETS, get_config, prepare_chart, solve_chart, solve_charts


@pytest.mark.parametrize("name", ["cap", "saddle", pytest.param("bumpy", marks=pytest.mark.slow),
                                  pytest.param("glove", marks=pytest.mark.slow)])
def test_test_preset_zero_flips(name):
    V, F = datasets.procedural(name)
    res = solve_chart(V, F, "test", device="cpu")
    assert res.status == "neural"
    assert res.metrics["flips"] == 0 and res.metrics["min_det"] > 0
    assert np.all(np.isfinite(res.uv))
    # the solver improves on its Tutte start (measured before any step, not the trace's first step)
    start_esd = prepare_chart(V, F, "test").start_metrics["esd"]
    assert res.metrics["esd"] < start_esd
    t = res.trace
    assert len(t["iter"]) == len(t["esd"]) == len(t["min_det"]) == len(t["lr"]) == len(t["time"])
    assert all(f == 0 for f in t["flips"])


@pytest.mark.slow
def test_glove_improves_substantially():
    V, F = datasets.glove()
    from neuraluv.metrics import distortion_metrics
    from neuraluv.tutte import tutte

    e0 = distortion_metrics(V, F, tutte(V, F))["esd"]
    res = solve_chart(V, F, get_config("test", iterations=150), device="cpu")
    assert res.metrics["flips"] == 0
    assert res.metrics["esd"] < 0.5 * e0


def test_forced_bad_steps_are_rejected():
    """A huge learning rate proposes flipping steps: rejection keeps every accepted state valid."""
    V, F = datasets.glove(res=2)
    cfg = get_config("test", lr=0.05, lr_min=0.05, iterations=40, retries=0)
    res = solve_chart(V, F, cfg, device="cpu")
    assert res.trace["rejected"][-1] > 0  # bad steps were proposed and refused
    assert all(f == 0 for f in res.trace["flips"])
    assert res.metrics["flips"] == 0 and res.status == "neural"
    # the same run without rejection flips triangles: the test above can fail
    bad = solve_chart(V, F, get_config("test", lr=0.05, lr_min=0.05, iterations=40, retries=0, reject=False), device="cpu")
    assert max(bad.trace["flips"]) > 0


def test_rejection_restores_state_exactly():
    """A rejected trial leaves no trace: the next accepted step starts from the restored state.

    Two runs from the same seed: one where every step must pass the checks, one
    that only ever takes the accepted steps of the first. With exact restores the
    accepted trajectories (losses, parameters) are identical.
    """
    V, F = datasets.glove(res=2)
    cfg = get_config("test", lr=0.05, lr_min=0.05, iterations=15, retries=0)
    params = []
    res = solve_chart(V, F, cfg, device="cpu",
                      callback=lambda ev, s, m: params.append([p.detach().clone() for p in m.parameters()]) if ev == "step" else None)
    assert res.trace["rejected"][-1] > 0
    # replay: the learning rate each accepted step used is in the trace
    replay = []
    it = iter(res.trace["lr"])
    from neuraluv.solver import engine

    orig = engine._cosine
    engine._cosine = lambda *a, **k: torch.tensor([next(it)], dtype=torch.float64)
    try:
        res2 = solve_chart(V, F, get_config(cfg, reject=False), device="cpu",
                           callback=lambda ev, s, m: replay.append([p.detach().clone() for p in m.parameters()]) if ev == "step" else None)
    finally:
        engine._cosine = orig
    assert len(replay) == len(params)
    for a, b in zip(params, replay):
        assert all(torch.equal(x, y) for x, y in zip(a, b))
    assert res2.trace["loss"] == res.trace["loss"]


def test_invalid_absolute_init_falls_back_marked():
    """Random absolute initialisation starts folded; the result is a marked fallback."""
    V, F = datasets.spherical_cap(5)
    res = solve_chart(V, F, get_config("test", init="random", residual=False, iterations=10, retries=1), device="cpu")
    assert res.attempts == 2
    assert res.status == "fallback" and "the valid start (tutte) used" in res.reason
    assert res.metrics["flips"] == 0  # the fallback is the (valid) Tutte map


def test_not_disk_raises():
    with pytest.raises(TopologyError, match="closed surface"):
        solve_chart(*datasets.sphere(1), "test", device="cpu")


def test_presets_follow_the_paper():
    p = PRESETS["paper"]
    assert (p.omega0, p.n_layers, p.width, p.k) == (15.0, 5, 256, 16)
    assert (p.eps_J, p.eps, p.alpha_start, p.alpha_end) == (1e-4, 1e-3, 10.0, 0.1)
    assert (p.lr, p.lr_min, p.warmup_iters, p.iterations) == (5e-4, 1e-6, 200, 5000)
    with pytest.raises(ValueError):
        get_config("nope")


def test_seeded_runs_are_reproducible():
    V, F = datasets.saddle(5)
    a = solve_chart(V, F, "test", device="cpu", seed=3)
    b = solve_chart(V, F, "test", device="cpu", seed=3)
    assert np.allclose(a.uv, b.uv)


def test_start_relax_only_when_crushed():
    """The SLIM un-crushing applies only below relax_below, stops once min det J >= eps, keeps validity."""
    from neuraluv.meshfix import normalize_unit_box
    from neuraluv.metrics import face_dets
    from neuraluv.relax import slim_relax_until
    from neuraluv.tutte import tutte

    V, F = datasets.glove()
    plain = solve_chart(V, F, get_config("test", iterations=5, start_relax=5, relax_below=1e-9), device="cpu")
    assert plain.start == "tutte"  # glove's Tutte min det (~5e-3) is above the trigger
    relaxed = solve_chart(V, F, get_config("test", iterations=5, start_relax=30, relax_below=1.0, eps=0.05), device="cpu")
    n = int(relaxed.start.removeprefix("tutte+slim"))
    assert 1 <= n < 30 and relaxed.metrics["flips"] == 0
    assert relaxed.trace["esd"][0] < plain.trace["esd"][0]
    # the relaxation stops at the first SLIM iterate that clears the target, not later
    Vn = normalize_unit_box(V)[0]
    UV, its = slim_relax_until(Vn, F, tutte(Vn, F), 0.05, 30)
    assert its == n and face_dets(Vn, F, UV).min() >= 0.05
    UV_prev, _ = slim_relax_until(Vn, F, tutte(Vn, F), 1.0, n - 1)
    assert n == 1 or face_dets(Vn, F, UV_prev).min() < 0.05


def test_literal_preset_is_the_paper_text():
    """``literal`` switches off every stated deviation; ``paper`` only adds them."""
    lit, pap = PRESETS["literal"], PRESETS["paper"]
    assert tuple(lit.betas) == (0.9, 0.999)  # PyTorch's Adam defaults
    assert (lit.det_drop, lit.loss_rise, lit.start_relax) == (0.0, 0.0, 0)
    assert (pap.det_drop, pap.loss_rise, pap.start_relax) != (0.0, 0.0, 0)
    assert replace(pap, betas=lit.betas, det_drop=0.0, loss_rise=0.0, start_relax=0) == lit


def test_loss_rise_guard_bounds_every_accepted_step():
    """With ``loss_rise`` no accepted step raises the loss by more than that fraction."""
    V, F = datasets.glove(res=2)
    cfg = get_config("test", lr=0.02, lr_min=0.02, iterations=60, retries=0, loss_rise=0.01)
    res = solve_chart(V, F, cfg, device="cpu")
    loss = np.array(res.trace["loss"])
    assert len(loss) > 10 and res.trace["rejected"][-1] > 0
    assert np.all(loss[1:] <= loss[:-1] * 1.01 * (1 + 1e-12))
    # without the guard the same run does take loss-raising steps: the check above can fail
    free = solve_chart(V, F, replace(cfg, loss_rise=0.0), device="cpu")
    lf = np.array(free.trace["loss"])
    assert np.any(lf[1:] > lf[:-1] * 1.01)



def test_no_progress_from_the_start_is_a_marked_fallback():
    """A run whose best map is still its start is not reported as a neural chart."""
    V, F = datasets.glove(res=2)
    # with a zero learning rate every step is accepted but none moves the map
    res = solve_chart(V, F, get_config("test", lr=0.0, lr_min=0.0, iterations=5, retries=0), device="cpu")
    assert res.status == "fallback" and "no accepted step improved on the start" in res.reason
    assert res.metrics["flips"] == 0
    ok = solve_chart(V, F, get_config("test", iterations=5, retries=0), device="cpu")
    assert ok.status == "neural"


def test_det_drop_guard_bounds_every_accepted_step():
    """With ``det_drop`` no accepted step halves the smallest det J below ε; without it some do."""
    V, F = datasets.glove(res=2)
    cfg = get_config("test", lr=0.03, lr_min=0.03, iterations=60, retries=0, loss_rise=0.0, det_drop=0.5, eps=0.05)
    res = solve_chart(V, F, cfg, device="cpu")
    start = prepare_chart(V, F, cfg).start_metrics["min_det"]
    md = np.array([start] + res.trace["min_det"])
    assert np.all(md[1:] >= np.minimum(cfg.eps, 0.5 * md[:-1]) * (1 - 1e-12))
    free = solve_chart(V, F, replace(cfg, det_drop=0.0), device="cpu")
    mf = np.array([start] + free.trace["min_det"])
    assert np.any(mf[1:] < np.minimum(cfg.eps, 0.5 * mf[:-1]))  # the check above can fail


def test_early_stop():
    """A plateau stops the run early (after half the budget); without early stopping the budget is used."""
    V, F = datasets.spherical_cap(5)
    cfg = get_config("test", iterations=80, retries=0, early_stop=True, patience=10, tol=0.05)
    res = solve_chart(V, F, cfg, device="cpu")
    assert res.stop == "early_stop" and 40 <= len(res.trace["iter"]) < 80
    full = solve_chart(V, F, replace(cfg, early_stop=False), device="cpu")
    assert full.stop == "budget" and len(full.trace["iter"]) == 80


def test_retries_halve_the_learning_rate_and_change_the_seed():
    V, F = datasets.spherical_cap(5)
    cfg = get_config("test", init="random", residual=False, iterations=5, retries=2, lr=1e-3)
    res = solve_chart(V, F, cfg, device="cpu", seed=7)
    assert res.attempts == 3 and len(res.attempt_log) == 3
    assert [a["seed"] for a in res.attempt_log] == [7, 8, 9]
    assert [a["lr"] for a in res.attempt_log] == pytest.approx([1e-3, 5e-4, 2.5e-4])
    assert not any(a["valid"] for a in res.attempt_log)
    ok = solve_chart(V, F, get_config("test", iterations=5), device="cpu")
    assert ok.attempts == 1 and ok.attempt_log[0]["valid"]  # a valid first attempt is not retried


def test_spectral_init_fits_the_spectral_map():
    """``init="spectral"``: the warm-up fits the first two LBO eigenfunctions (scaled to the Tutte radius)."""
    V, F = datasets.spherical_cap(5)
    cfg = get_config("test", init="spectral", residual=False, warmup_iters=150, warmup_lr=1e-3, iterations=1, retries=0)
    prep = prepare_chart(V, F, cfg)
    phi = prep.eig[1][:, :2] - prep.eig[1][:, :2].mean(0)
    assert np.allclose(prep.target / np.linalg.norm(prep.target, axis=0), phi / np.linalg.norm(phi, axis=0))
    assert np.sqrt((prep.target**2).sum(1).mean()) == pytest.approx(np.sqrt((prep.u_start**2).sum(1).mean()))

    def warm_map(c):
        """The network's map right after the warm-up of a solve with config ``c``."""
        got = {}

        def cb(ev, s, model):
            if ev == "warmup_end":
                with torch.no_grad():
                    got["u"] = model(torch.as_tensor(prep.X)).numpy()

        solve_chart(V, F, c, device="cpu", callback=cb)
        return got["u"]

    def err(u, ref):
        return float(((u - ref) ** 2).mean())

    fitted, untrained = warm_map(cfg), warm_map(replace(cfg, warmup_iters=0))
    # the warm-up brings the network onto the spectral map (from far off), and not onto the Tutte map
    assert err(fitted, prep.target) < 0.01 * err(untrained, prep.target)
    assert err(fitted, prep.target) < 0.01 * err(fitted, prep.u_start)


def test_degenerate_chart_is_a_clear_error_not_a_crash():
    """A chart with a zero-area 3D triangle has no Jacobian there: a one-line TopologyError says what to do."""
    V, F = datasets.disk(3)
    V = V.copy()
    t = F[5]
    V[t[2]] = 0.5 * (V[t[0]] + V[t[1]])  # a collinear (zero-area) face
    with pytest.raises(TopologyError, match="1 degenerate .*repair_mesh"):
        solve_chart(V, F, get_config("test", iterations=5, retries=0), device="cpu")


def test_invalid_start_gives_a_marked_fallback(monkeypatch):
    """When the start itself is folded and no attempt unfolds it, the result says so (never 'neural')."""
    from neuraluv.solver import chart as chart_mod

    real = chart_mod.tutte

    def folded(V, F, **kw):
        UV = real(V, F, **kw)
        UV[F[0, 0]] += 0.8  # drag one vertex across the chart
        return UV

    monkeypatch.setattr(chart_mod, "tutte", folded)
    V, F = datasets.spherical_cap(4)
    cfg = get_config("test", iterations=3, retries=1, lr=1e-6, lr_min=1e-6)
    res = solve_chart(V, F, cfg, device="cpu")
    assert res.status == "fallback" and res.attempts == 2
    assert "no flip-free map found after 2 attempts" in res.reason and "the chart may be degenerate" in res.reason
    assert res.metrics["flips"] > 0  # the map returned is marked, not passed off as valid


def test_stop_reason_round_trips_through_the_summary():
    """A run that uses its whole budget says ``budget`` in the result, the attempt log and the JSON summary."""
    import json

    from neuraluv.solver.result import Stop

    V, F = datasets.spherical_cap(4)
    res = solve_chart(V, F, get_config("test", iterations=7, retries=0), device="cpu")
    assert len(res.trace["iter"]) == 7
    assert Stop.from_label(res.stop) is Stop.BUDGET and res.attempt_log[0]["stop"] == "budget"
    summary = json.loads(json.dumps(res.summary()))
    assert summary["stop"] == "budget" and Stop.from_label(summary["stop"]) is Stop.BUDGET
    assert [Stop.from_label(s.label) for s in Stop] == list(Stop)


def test_prepare_chart_computes_the_start_as_before():
    """The frames computed once give the same Tutte map and start metrics as computing them in each callee."""
    from neuraluv.metrics import distortion_metrics
    from neuraluv.relax import slim_relax_until
    from neuraluv.tutte import tutte

    V, F = datasets.glove()
    cfg = get_config("test", start_relax=30, relax_below=1.0, eps=0.05)
    prep = prepare_chart(V, F, cfg)
    plain = tutte(prep.Vn, F)
    relaxed, n = slim_relax_until(prep.Vn, F, plain, cfg.eps, cfg.start_relax)
    assert n > 0 and prep.start == f"tutte+slim{n}"
    assert prep.u_start.tobytes() == relaxed.tobytes()
    assert prep.start_metrics == distortion_metrics(prep.Vn, F, relaxed)
    assert tutte(prep.Vn, F, frames=(prep.dC_inv, prep.A)).tobytes() == plain.tobytes()


def test_start_slim_moves_the_start_towards_the_flattening_while_it_stays_injective():
    """``start_slim``: SLIM iterations after the Tutte map, each kept only while no face flips and the outer
    boundary does not cross itself; a strip far from its Tutte circle starts near its flattening."""
    from neuraluv.layout.overlap import boundary_is_simple

    V, F = datasets.spherical_cap(4)
    strip = V * np.array([6.0, 0.25, 1.0])   # a long thin curved strip: its Tutte circle distorts it badly
    plain = prepare_chart(strip, F, get_config("test"))
    moved = prepare_chart(strip, F, get_config("test", start_slim=10))
    assert plain.start == "tutte" and moved.start.startswith("tutte+slim")
    k = int(moved.start.removeprefix("tutte+slim"))
    assert 1 <= k <= 10 and moved.start_metrics["flips"] == 0 and boundary_is_simple(moved.u_start, F)
    assert moved.start_metrics["esd"] < 0.5 * plain.start_metrics["esd"]
    res = solve_charts(None, get_config("test", start_slim=10), preps=[moved], device="cpu")[0]
    assert res.status == "neural" and res.start == moved.start and res.metrics["esd"] <= moved.start_metrics["esd"]


def test_prepare_chart_with_a_given_start_pinned_rows_and_a_lower_rank():
    """What local repair asks of prepare_chart: its start as given, a free mask, padded features."""
    from neuraluv.metrics import distortion_metrics

    V, F = datasets.spherical_cap(4)
    cfg = get_config("test")
    full = prepare_chart(V, F, cfg)
    u0 = full.u_start * 1.01
    free = np.arange(len(V)) % 3 != 0
    p = prepare_chart(V, F, cfg, k=3, start_uv=u0, start_name="repair", free=free, check=False)
    assert p.start == "repair" and p.u_start.tobytes() == u0.tobytes() and p.free.tolist() == free.tolist()
    assert p.start_metrics == distortion_metrics(p.Vn, F, u0)
    assert p.X.shape == full.X.shape and p.X.dtype == np.float32
    assert np.array_equal(p.X[:, :6], full.X[:, :6]) and not p.X[:, 6:].any()
    # the pinned rows stay exactly at the start, the free ones move
    res = solve_charts(None, get_config(cfg, iterations=10, retries=0), device="cpu", preps=[p])[0]
    assert res.uv[~free].tobytes() == (u0[~free] * p.scale).tobytes()
    assert not np.allclose(res.uv[free], u0[free] * p.scale)


def test_batch_plan_covers_every_chart_within_the_limits():
    from neuraluv.solver.chart import batch_plan

    sizes = np.random.default_rng(0).integers(3, 3000, 200)
    plan = batch_plan(sizes, max_rows=20000, max_batch=16)
    assert sorted(i for g in plan for i in g) == list(range(len(sizes)))
    for g in plan:
        n = sizes[g]
        assert len(g) <= 16 and (len(g) == 1 or n.max() * len(g) <= 20000)
        assert n.max() <= 2.5 * n.min() + 32


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device here (the solver's CUDA path is checked on a GPU)")
def test_cuda_solve_matches_cpu():
    V, F = datasets.glove(res=2)
    cfg = get_config("test", iterations=30, retries=0)
    gpu = solve_chart(V, F, cfg, device="cuda")
    cpu = solve_chart(V, F, cfg, device="cpu")
    assert gpu.status == "neural" and gpu.metrics["flips"] == 0
    assert gpu.metrics["esd"] == pytest.approx(cpu.metrics["esd"], rel=0.05)


def test_preset_help_states_the_fast_preset_as_configured():
    from neuraluv.solver.config import PRESET_HELP, PRESETS
    c = PRESETS["fast"]
    assert f"{c.n_layers}x{c.width} SIREN (omega0 {c.omega0:g})" in PRESET_HELP["fast"]


def test_auto_threads_leave_busy_cpus_alone_and_the_cli_takes_auto_or_a_count(monkeypatch):
    import argparse
    import io
    import os

    from neuraluv.cli.options import threads_arg
    from neuraluv.solver import device
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1, 2, 3})
    monkeypatch.setattr(device, "_busy_now", lambda cpus: 2.6)
    assert device.auto_threads()[0] == 1  # 4 CPUs, 2.6 busy: one free (the running count can only add)
    monkeypatch.setattr(device, "_busy_now", lambda cpus: 9.0)
    assert device.auto_threads()[0] == 1  # never fewer than one
    # a load average left by jobs that have ended does not count when the CPUs are idle now
    monkeypatch.setattr(device, "_busy_now", lambda cpus: 0.0)
    monkeypatch.setattr(os, "getloadavg", lambda: (3.5, 0.0, 0.0))
    real_open = open
    monkeypatch.setattr("builtins.open", lambda f, *a, **k: io.StringIO("3.50 2.00 1.00 1/300 4242")
                        if f == "/proc/loadavg" else real_open(f, *a, **k))
    assert device.auto_threads()[0] == 4
    # where /proc/stat cannot be read, the load average stands in
    monkeypatch.setattr(device, "_busy_now", lambda cpus: None)
    assert device.auto_threads()[0] == 1
    import torch
    before = torch.get_num_threads()
    from threadpoolctl import threadpool_info

    def blas():
        return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]

    blas_before = blas()
    with device.torch_threads("auto"):
        assert torch.get_num_threads() == 1
        assert set(blas()) <= {1}  # NumPy's and SciPy's BLAS pools too: they spin under load like torch's
    assert torch.get_num_threads() == before and blas() == blas_before
    assert threads_arg("auto") == "auto" and threads_arg("3") == 3
    with pytest.raises(argparse.ArgumentTypeError):
        threads_arg("0")
