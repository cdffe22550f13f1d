"""The chart solver: zero flips, step rejection with state restore, retry, fallback."""
from dataclasses import replace

import numpy as np
import pytest
import torch

from neuraluv import datasets
from neuraluv.errors import TopologyError
from neuraluv.siren import Siren
from neuraluv.solver import PRESETS, _Snapshot, get_config, solve_chart


@pytest.mark.parametrize("name", ["cap", "saddle", "bumpy", "glove"])
def test_test_preset_zero_flips(name):
    V, F = datasets.procedural(name)
    res = solve_chart(V, F, "test", device="cpu")
    assert res.status == "neural"
    assert res.metrics["flips"] == 0 and res.metrics["min_det"] > 0
    assert np.all(np.isfinite(res.uv))
    # the solver improves on its Tutte start
    assert res.metrics["esd"] <= res.trace["esd"][0] * 1.0001 or res.metrics["esd"] < 5
    t = res.trace
    assert len(t["iter"]) == len(t["esd"]) == len(t["min_det"]) == len(t["lr"]) == len(t["time"])
    assert all(f == 0 for f in t["flips"])


def test_glove_improves_substantially():
    V, F = datasets.glove()
    from neuraluv.metrics import distortion_metrics
    from neuraluv.tutte import tutte

    e0 = distortion_metrics(V, F, tutte(V, F))["esd"]
    res = solve_chart(V, F, get_config("test", iterations=150), device="cpu")
    assert res.metrics["flips"] == 0
    assert res.metrics["esd"] < 0.5 * e0


def test_snapshot_restores_params_and_adam_state():
    torch.manual_seed(0)
    net = Siren(3, width=8, n_layers=3)
    opt = torch.optim.Adam(net.parameters(), lr=0.1)
    x = torch.randn(10, 3)
    net(x).pow(2).sum().backward()
    opt.step()
    snap = _Snapshot(net, opt)
    before = [p.detach().clone() for p in net.parameters()]
    moments = [opt.state[p]["exp_avg"].clone() for p in net.parameters()]
    net(x).pow(2).sum().backward()
    opt.step()
    assert any(not torch.equal(a, p) for a, p in zip(before, net.parameters()))
    snap.restore(net, opt)
    assert all(torch.equal(a, p) for a, p in zip(before, net.parameters()))
    assert all(torch.equal(m, opt.state[p]["exp_avg"]) for m, p in zip(moments, net.parameters()))


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
    """After a rejected step the next accepted state starts from the restored one."""
    V, F = datasets.spherical_cap(4)
    seen = []
    cfg = get_config("test", lr=0.5, lr_min=0.5, iterations=5, retries=0, max_backtracks=3)
    res = solve_chart(V, F, cfg, device="cpu", callback=lambda ev, s, m: seen.append((ev, s)))
    # with 3 backtracks at this rate the solver stalls rather than accept a flip
    assert res.metrics["flips"] == 0
    assert res.stop in ("stalled", "budget")


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
    from neuraluv.metrics import face_dets
    from neuraluv.relax import slim_relax_until
    from neuraluv.repair import normalize_unit_box
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
