"""The C² inverse-determinant extension, the barrier and its schedule."""
import numpy as np
import pytest
import torch

from neuraluv.jacobian import local_frames
from neuraluv.solver.energy import alpha_schedule, barrier, inv_det_sq, jacobians_torch, objective, stable_esd

EPS_J = 1e-4


def q_true(d):
    return d**-2.0


def test_value_and_derivatives_match_at_switch():
    d = torch.tensor(EPS_J, dtype=torch.float64, requires_grad=True)
    # derivatives of the polynomial branch, taken at eps_J from below
    dm = torch.tensor(EPS_J * (1 - 1e-12), dtype=torch.float64, requires_grad=True)
    for x in (d, dm):
        q = inv_det_sq(x, EPS_J)
        (g,) = torch.autograd.grad(q, x, create_graph=True)
        (h,) = torch.autograd.grad(g, x)
        assert q.item() == pytest.approx(EPS_J**-2, rel=1e-9)
        assert g.item() == pytest.approx(-2 * EPS_J**-3, rel=1e-9)
        assert h.item() == pytest.approx(6 * EPS_J**-4, rel=1e-9)


def test_numerical_derivatives_continuous():
    # central differences straddling eps_J agree with d^-2's derivatives
    h = 1e-9
    f = lambda x: float(inv_det_sq(np.array(x), EPS_J))
    d1 = (f(EPS_J + h) - f(EPS_J - h)) / (2 * h)
    d2 = (f(EPS_J + h) - 2 * f(EPS_J) + f(EPS_J - h)) / h**2
    assert d1 == pytest.approx(-2 * EPS_J**-3, rel=1e-5)
    assert d2 == pytest.approx(6 * EPS_J**-4, rel=1e-3)


def test_extension_is_finite_and_exact_above():
    d = np.array([-1.0, -1e-3, 0.0, 5e-5, 1e-4, 2e-4, 0.5, 3.0])
    q = inv_det_sq(d, EPS_J)
    assert np.all(np.isfinite(q))
    above = d > EPS_J
    assert np.allclose(q[above], q_true(d[above]))
    # the polynomial is decreasing below eps_J: flipping further costs more
    assert np.all(np.diff(q[:4]) < 0)
    assert np.allclose(inv_det_sq(torch.tensor(d), EPS_J).numpy(), q)


def test_extension_gradient_has_no_nan_at_zero():
    d = torch.tensor([0.0, -2.0, 1.0], dtype=torch.float64, requires_grad=True)
    inv_det_sq(d, EPS_J).sum().backward()
    assert torch.all(torch.isfinite(d.grad))


def test_stable_esd_equals_true_esd_on_valid_maps():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2]])
    dCi, A = local_frames(V, F)
    UV = torch.tensor(2.0 * V[:, :2])
    J = jacobians_torch(UV, torch.tensor(F), torch.tensor(dCi))
    assert stable_esd(J, torch.tensor(A)).item() == pytest.approx(2 * (4 + 0.25))
    o = objective(J, torch.tensor(A), alpha=10.0)
    assert o.loss.item() == pytest.approx(8.5)  # det = 4 > eps: no barrier
    assert o.esd.item() == pytest.approx(8.5) and o.barrier.item() == 0.0


def _random_chart_map(seed=0, fold=False):
    from neuraluv.datasets import bumpy_disk
    from neuraluv.tutte import tutte

    V, F = bumpy_disk(5)
    rng = np.random.default_rng(seed)
    UV = tutte(V, F) + 0.02 * rng.standard_normal((len(V), 2))
    if fold:
        UV[F[0, 0]] += 0.5  # drag a vertex across its neighbours: some faces flip
    return V, F, UV


@pytest.mark.parametrize("fold", [False, True])
def test_objective_esd_matches_distortion_metrics_on_many_faces(fold):
    """One E_SD: the torch objective's true E_SD equals the reporting metric, face by face and in total."""
    from neuraluv.jacobian import jacobians
    from neuraluv.metrics import distortion_metrics, face_metrics

    V, F, UV = _random_chart_map(1, fold)
    dCi, A = local_frames(V, F)
    J = jacobians_torch(torch.tensor(UV), torch.tensor(F), torch.tensor(dCi))
    o = objective(J, torch.tensor(A), alpha=1.0)
    m = distortion_metrics(V, F, UV)
    assert m["flips"] > 0 if fold else m["flips"] == 0
    assert o.esd.item() == pytest.approx(m["esd"], rel=1e-12)
    assert int((o.det <= 0).sum()) == m["flips"]
    assert np.allclose(o.det.numpy(), face_metrics(jacobians(UV, F, dCi))["det"])
    if not fold:  # every det J > eps_J: the stable energy is the true one
        assert o.stable.item() == pytest.approx(m["esd"], rel=1e-12)
    # the loss is built from its parts
    assert o.loss.item() == pytest.approx(o.stable.item() + 1.0 * o.barrier.item())
    assert o.at(3.0).item() == pytest.approx(o.stable.item() + 3.0 * o.barrier.item())


def test_objective_gradcheck():
    """Analytic gradients of the loss (C² extension, barrier, Jacobians) match finite differences."""
    V, F, UV = _random_chart_map(2, fold=True)
    dCi, A = local_frames(V, F)
    Ft, dCit, At = torch.tensor(F), torch.tensor(dCi), torch.tensor(A)
    u = torch.tensor(UV, requires_grad=True)

    def f(u):
        # a large eps_J puts many faces (and the folded ones) on the polynomial branch at moderate values
        return objective(jacobians_torch(u, Ft, dCit), At, alpha=5.0, eps_J=0.5, eps=0.3).loss

    dets = objective(jacobians_torch(u, Ft, dCit), At, 1.0).det
    assert (dets <= 0).any() and (dets < 0.5).sum() > 1 and (dets > 0.5).any()  # every branch is exercised
    assert torch.autograd.gradcheck(f, (u,), eps=1e-6, atol=1e-6, rtol=1e-5)


def test_barrier_and_schedule():
    det = torch.tensor([1.0, 1e-3, 0.0, -1.0], dtype=torch.float64)
    assert barrier(det, 1e-3).item() == pytest.approx(1e-6 + (1.001) ** 2)
    assert alpha_schedule(0, 10) == pytest.approx(10.0)
    assert alpha_schedule(10, 10) == pytest.approx(0.1)
    vals = [alpha_schedule(s, 10) for s in range(11)]
    ratios = np.array(vals[1:]) / np.array(vals[:-1])
    assert np.allclose(ratios, ratios[0])  # exponential


@pytest.mark.parametrize("n_charts", [1, 3])
def test_the_chart_objectives_written_out_gradient_is_autograds(n_charts):
    """:func:`chart_objective`'s hand-written backward pass equals autograd through :func:`face_terms`,
    flipped faces and determinants below ε_J included."""
    from neuraluv.solver.energy import _fro2_det, chart_objective, face_terms, jacobian_entries

    gen = torch.Generator().manual_seed(0)
    N, M = 30, 50
    UV = torch.randn(N, 2, generator=gen, dtype=torch.float64)
    F = torch.randint(0, N, (M, 3), generator=gen)
    K = torch.randn(M, 2, 2, generator=gen, dtype=torch.float64)
    w = torch.rand(M, generator=gen, dtype=torch.float64)
    fc = torch.randint(0, n_charts, (M,), generator=gen)
    alpha = torch.linspace(1.0, 5.0, n_charts, dtype=torch.float64)
    for eps_J, eps in [(EPS_J, 1e-3), (0.5, 0.8)]:
        u1 = UV.clone().requires_grad_(True)
        o = chart_objective(u1, F, K, w, fc, n_charts, alpha, eps_J, eps)
        (o.loss * torch.arange(1, n_charts + 1)).sum().backward()
        u2 = UV.clone().requires_grad_(True)
        fro2, det = _fro2_det(*jacobian_entries(u2, F, K))
        s, b, _ = face_terms(fro2, det, eps_J, eps)
        z = torch.zeros(n_charts, dtype=torch.float64)
        ref = z.index_add(0, fc, w * s) + alpha * z.index_add(0, fc, b)
        (ref * torch.arange(1, n_charts + 1)).sum().backward()
        assert torch.allclose(o.loss, ref.detach(), rtol=1e-12)
        assert torch.allclose(u1.grad, u2.grad, rtol=1e-10, atol=1e-10 * float(u2.grad.abs().max()))
        assert int((det <= 0).sum()) > 0 and o.flips.sum() == int((det <= 0).sum())
