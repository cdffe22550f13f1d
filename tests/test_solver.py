"""The chart solver: zero flips, step rejection with state restore, retry, fallback."""
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
    """The optional SLIM relaxation applies only below relax_below and keeps validity."""
    V, F = datasets.glove()
    plain = solve_chart(V, F, get_config("test", iterations=5, start_relax=5, relax_below=1e-9), device="cpu")
    assert plain.start == "tutte"  # glove's Tutte min det (~5e-3) is above the trigger
    relaxed = solve_chart(V, F, get_config("test", iterations=5, start_relax=5, relax_below=1.0), device="cpu")
    assert relaxed.start == "tutte+slim5" and relaxed.metrics["flips"] == 0
    assert relaxed.trace["esd"][0] < plain.trace["esd"][0]
