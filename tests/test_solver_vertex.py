"""The per-vertex control (``param="vertex"``): the solver's objective and checked steps over free UVs."""
import numpy as np
import pytest
import torch

from neuraluv import datasets
from neuraluv.solver import get_config, prepare_chart, solve_chart, solve_charts
from neuraluv.solver.energy import chart_objective
from neuraluv.solver.batch import make_batch
from neuraluv.solver.engine import optimise
from neuraluv.solver.vertex import VertexMap, forward, init_params, leaves


def _cap(rings=5):
    return datasets.spherical_cap(n_rings=rings)


def test_one_triangle_by_hand():
    """u = base + θ on a single right triangle: the objective's gradient is the one of E_SD + barrier in the UVs."""
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2]])
    p = prepare_chart(V, F, "test", check=False, start_uv=np.array([[0.0, 0], [1, 0], [0, 1]]))
    b = make_batch([p])
    th = leaves(init_params(1, 3))
    u = forward(th, b.base)
    assert torch.equal(u, b.base)                         # zero displacement: the start itself
    o = chart_objective(u.reshape(-1, 2), b.F, b.dC_inv, b.w, b.face_chart, 1, 10.0)
    o.loss.sum().backward()
    # J = I (the start is the triangle itself, normalised the same way): E_SD = 4, no barrier, zero gradient
    assert float(o.esd) == pytest.approx(4.0) and int(o.flips) == 0
    assert torch.allclose(th[0][0].grad, torch.zeros(1, 6, dtype=torch.float64), atol=1e-9)
    # moving vertex 1 outwards stretches the triangle: the gradient pulls it back (negative x-derivative sign)
    th = leaves(torch.tensor([[0.0, 0, 0.2, 0, 0, 0]], dtype=torch.float64))
    o = chart_objective(forward(th, b.base).reshape(-1, 2), b.F, b.dC_inv, b.w, b.face_chart, 1, 10.0)
    o.loss.sum().backward()
    assert float(th[0][0].grad[0, 2]) > 0


@pytest.mark.parametrize("optimizer,lr", [("adam", 1e-3), ("lbfgs", 1e-2)])
def test_vertex_solve_is_valid_and_uses_the_same_start_and_checks(optimizer, lr):
    V, F = _cap()
    cfg = get_config("test", param="vertex", optimizer=optimizer, lr=lr, iterations=80)
    res = solve_chart(V, F, cfg, device="cpu")
    siren = solve_chart(V, F, get_config(cfg, param="siren"), device="cpu")
    assert res.status == "neural" and res.metrics["flips"] == 0 and max(res.trace["flips"]) == 0
    assert isinstance(res.network, VertexMap)
    assert res.start == siren.start                                   # the same valid start
    assert res.metrics["esd"] < res.attempt_metrics[0]["esd"] + 1e-12  # (one attempt)
    # the returned map is the module's map, at the chart's scale
    p = prepare_chart(V, F, cfg)
    with torch.no_grad():
        uv = res.network(torch.as_tensor(p.X)).numpy() * p.scale
    assert res.trace["esd"][-1] <= res.trace["esd"][0]
    assert np.isfinite(uv).all()


def test_vertex_prepare_skips_the_eigen_solve():
    V, F = _cap(4)
    p = prepare_chart(V, F, get_config("test", param="vertex"))
    assert p.X.shape[1] == 3 + get_config("test").k and not p.X[:, 3:].any()


def test_rejection_is_the_same_rule():
    """A huge Adam step folds the map when nothing refuses it; with rejection every accepted iterate is flip-free."""
    V, F = _cap()
    cfg = get_config("test", param="vertex", optimizer="adam", lr=0.5, lr_min=0.5, iterations=20, retries=0)
    on = solve_chart(V, F, cfg, device="cpu")
    off = solve_chart(V, F, get_config(cfg, reject=False), device="cpu")
    assert max(on.trace["flips"], default=0) == 0 and on.trace["rejected"][-1] > 0
    assert max(off.trace["flips"]) > 0
    assert off.metrics["flips"] == 0            # the solver still returns its best valid iterate (or the start)


def test_a_batch_of_vertex_charts_equals_single_solves():
    charts = [_cap(4), _cap(6)]
    cfg = get_config("test", param="vertex", optimizer="adam", lr=1e-3, iterations=30, retries=0)
    together = solve_charts(charts, cfg, device="cpu")
    for (V, F), r in zip(charts, together):
        alone = solve_chart(V, F, cfg, device="cpu")
        assert np.allclose(r.uv, alone.uv, atol=1e-12) and r.trace["esd"] == pytest.approx(alone.trace["esd"])


def test_pinned_vertices_stay_at_the_start():
    V, F = _cap(5)
    free = np.arange(len(V)) % 3 != 0
    cfg = get_config("test", param="vertex", optimizer="adam", lr=1e-3, iterations=20)
    p = prepare_chart(V, F, cfg, free=free)
    out = optimise(make_batch([p]), cfg, [0])
    assert np.array_equal(out.best_uv[0][~free], p.u_start[~free])
    assert not np.array_equal(out.best_uv[0][free], p.u_start[free])


def test_bad_settings_say_what_to_fix():
    V, F = _cap(4)
    with pytest.raises(ValueError, match="residual=True"):
        solve_chart(V, F, get_config("test", param="vertex", residual=False), device="cpu")
    with pytest.raises(ValueError, match="param must be"):
        solve_chart(V, F, get_config("test", param="mlp"), device="cpu")
    with pytest.raises(ValueError, match="vertices"):
        VertexMap(torch.zeros(3, 2))(torch.zeros(4, 5))
