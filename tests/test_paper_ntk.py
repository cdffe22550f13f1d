"""NTK–LBO probes: alignment score, NTK Gram, farthest-point sampling, trajectory, bench runner."""

import numpy as np
import pytest
import scipy.sparse.csgraph
import torch
from torch.nn.utils import parameters_to_vector, vector_to_parameters

from neuraluv import datasets
from neuraluv.solver import get_config, solve_chart
from neuraluv.solver.siren import Siren
from neuraluv_paper.ntk import (TrajectoryRecorder, _edge_graph, alignment_curve, farthest_point_sampling, lbo_basis,
                                make_probe, ntk_gram, subspace_alignment, top_eigenspace)


def _orth(rng, s, r):
    return np.linalg.qr(rng.standard_normal((s, r)))[0]


def _rotation(rng, r):
    Q = _orth(rng, r, r)
    return Q * rng.choice([-1.0, 1.0], size=r)  # rotation/reflection with sign flips


# --- the alignment score --------------------------------------------------------------------------

def test_alignment_in_unit_interval_and_random_baseline():
    rng = np.random.default_rng(0)
    s = 64
    for r in (1, 4, 8, 16):
        vals = [subspace_alignment(_orth(rng, s, r), _orth(rng, s, r)) for _ in range(40)]
        assert min(vals) >= 0.0 and max(vals) <= 1.0 + 1e-12
        # E[s_r] = r/s for independent uniformly random subspaces
        assert abs(np.mean(vals) - r / s) < 0.5 * r / s + 0.02


def test_alignment_one_for_same_span_zero_for_orthogonal():
    rng = np.random.default_rng(1)
    A = _orth(rng, 50, 6)
    assert subspace_alignment(A, A @ _rotation(rng, 6)) == pytest.approx(1.0, abs=1e-12)
    P = np.eye(50) - A @ A.T
    B = np.linalg.qr(P @ rng.standard_normal((50, 6)))[0]
    assert subspace_alignment(A, B) == pytest.approx(0.0, abs=1e-12)
    # half overlap: 3 shared directions out of 6
    C = np.linalg.qr(np.c_[A[:, :3], B[:, :3]])[0]
    assert subspace_alignment(A, C) == pytest.approx(0.5, abs=1e-12)


def test_alignment_invariant_to_sign_flips_and_rotations():
    rng = np.random.default_rng(2)
    A, B = _orth(rng, 40, 5), _orth(rng, 40, 5)
    s0 = subspace_alignment(A, B)
    for _ in range(5):
        assert subspace_alignment(A @ _rotation(rng, 5), B @ _rotation(rng, 5)) == pytest.approx(s0, abs=1e-12)
    assert subspace_alignment(-A, B * np.array([1, -1, 1, -1, -1])) == pytest.approx(s0, abs=1e-12)


def test_alignment_rejects_mismatched_shapes():
    with pytest.raises(ValueError):
        subspace_alignment(np.eye(4)[:, :2], np.eye(4)[:, :3])


def test_alignment_curve_uses_top_eigenvectors():
    # Θ whose top-2 eigenvectors are e3, e4: aligned with a basis of e3, e4 only at r = 2
    Theta = np.diag([1.0, 2.0, 10.0, 9.0, 0.5])
    Psi = np.eye(5)[:, [3, 2, 0]]
    c = alignment_curve(Theta, Psi)
    assert c.tolist() == pytest.approx([0.0, 1.0, 2.0 / 3.0])
    Q, w = top_eigenspace(Theta, 2)
    assert np.all(np.diff(w) <= 0) and np.allclose(np.abs(Q[[2, 3]]), np.eye(2))


def test_lbo_basis_orthonormal_and_nested():
    V, F = datasets.spherical_cap(n_rings=6)
    from neuraluv.spectral import lbo_eigenfunctions

    _, phi = lbo_eigenfunctions(V, F, 8)
    idx = farthest_point_sampling(V, 40, F=F)
    for const in (True, False):
        P = lbo_basis(phi, idx, 8, constant=const)
        assert np.allclose(P.T @ P, np.eye(8), atol=1e-10)
        P4 = lbo_basis(phi, idx, 4, constant=const)
        assert subspace_alignment(P[:, :4], P4) == pytest.approx(1.0)
    assert np.allclose(np.abs(lbo_basis(phi, idx, 1)[:, 0]), 1 / np.sqrt(40))  # constant mode first


# --- the NTK Gram --------------------------------------------------------------------------------

def _explicit_jacobian(net, x):
    """(2, s, P) Jacobian by one autograd call per output entry."""
    params = list(net.parameters())
    out = net(x)
    rows = []
    for c in range(2):
        Jc = []
        for i in range(x.shape[0]):
            g = torch.autograd.grad(out[i, c], params, retain_graph=True, allow_unused=True)
            Jc.append(torch.cat([(gi if gi is not None else torch.zeros_like(p)).reshape(-1) for gi, p in zip(g, params)]))
        rows.append(torch.stack(Jc))
    return torch.stack(rows)


def test_ntk_gram_matches_explicit_and_finite_difference_jacobian():
    torch.manual_seed(0)
    net = Siren(3, width=6, n_layers=3, omega0=5.0).double()
    x = torch.randn(7, 3, dtype=torch.float64)
    T = ntk_gram(net, x)
    J = _explicit_jacobian(net, x)
    T_explicit = (J[0] @ J[0].T + J[1] @ J[1].T).numpy()
    assert np.allclose(T, T_explicit, rtol=1e-10, atol=1e-12)
    # finite differences of the outputs along the parameter vector
    theta0 = parameters_to_vector(net.parameters()).detach().clone()
    h = 1e-6
    Jfd = torch.zeros_like(J)
    with torch.no_grad():
        for p in range(theta0.numel()):
            e = torch.zeros_like(theta0)
            e[p] = h
            vector_to_parameters(theta0 + e, net.parameters())
            up = net(x)
            vector_to_parameters(theta0 - e, net.parameters())
            dn = net(x)
            Jfd[:, :, p] = ((up - dn) / (2 * h)).T
        vector_to_parameters(theta0, net.parameters())
    assert torch.allclose(Jfd, J, atol=1e-6)
    T_fd = (Jfd[0] @ Jfd[0].T + Jfd[1] @ Jfd[1].T).numpy()
    assert np.allclose(T, T_fd, rtol=1e-5, atol=1e-6)


def test_ntk_gram_symmetric_psd_float32():
    torch.manual_seed(1)
    net = Siren(5, width=32, n_layers=4)
    T = ntk_gram(net, torch.randn(40, 5))
    assert T.shape == (40, 40) and T.dtype == np.float64
    assert np.array_equal(T, T.T)
    w = np.linalg.eigvalsh(T)
    assert w.min() >= -1e-5 * w.max() and w.max() > 0


def test_residual_base_does_not_enter_theta():
    torch.manual_seed(2)
    base = torch.randn(100, 2, dtype=torch.float64)
    net = Siren(4, width=16, n_layers=3, base=base)
    x = torch.randn(12, 4)
    T0 = ntk_gram(net, x)
    with torch.no_grad():
        net.base.mul_(100.0).add_(3.0)
    assert np.allclose(ntk_gram(net, x), T0)
    # zero head at init: only the head's parameters move the output, Θ = 2 (H Hᵀ + 1 1ᵀ)
    with torch.no_grad():
        H = net.body(x).double()
    assert np.allclose(T0, 2.0 * (H @ H.T + 1.0).numpy(), rtol=1e-5, atol=1e-5)


# --- farthest-point sampling ----------------------------------------------------------------------

def test_fps_distinct_deterministic_and_well_spread():
    V, F = datasets.glove()
    s = 64
    idx = farthest_point_sampling(V, s, start=5)
    assert idx[0] == 5 and len(np.unique(idx)) == s
    assert np.array_equal(idx, farthest_point_sampling(V, s, start=5))
    D = np.linalg.norm(V[idx][:, None] - V[idx][None], axis=-1) + np.diag(np.full(s, np.inf))
    rng = np.random.default_rng(0)
    for _ in range(5):
        ridx = rng.choice(len(V), s, replace=False)
        Dr = np.linalg.norm(V[ridx][:, None] - V[ridx][None], axis=-1) + np.diag(np.full(s, np.inf))
        assert D.min() >= Dr.min()
    # Gonzalez covering property: every vertex lies within the samples' min pairwise distance
    cover = np.linalg.norm(V[:, None] - V[idx][None], axis=-1).min(axis=1).max()
    assert cover <= D.min() + 1e-12


def test_fps_geodesic_covering_radius():
    V, F = datasets.glove()
    idx = farthest_point_sampling(V, 48, F=F)
    assert len(np.unique(idx)) == 48
    D = scipy.sparse.csgraph.dijkstra(_edge_graph(V, F), directed=False, indices=idx)  # (48, n)
    pair = D[:, idx] + np.diag(np.full(48, np.inf))
    assert D.min(axis=0).max() <= pair.min() + 1e-12
    with pytest.raises(ValueError):
        farthest_point_sampling(V, 4, start=len(V))
    assert len(farthest_point_sampling(V[:10], 50)) == 10  # clipped to n


# --- probes during a solve and the bench runner ---------------------------------------------------

@pytest.mark.slow
def test_trajectory_probe_on_a_solve():
    V, F = datasets.spherical_cap(n_rings=5)
    cfg = get_config("test", iterations=12, k=4)
    probe = make_probe(V, F, cfg.k, n_samples=32, r_max=8)
    rec = TrajectoryRecorder(probe, [3, 6])
    res = solve_chart(V, F, cfg, device="cpu", callback=rec)
    ev = [(r["event"], r["step"]) for r in rec.of_attempt(0)]
    assert ev == [("warmup_end", 0), ("step", 3), ("step", 6), ("end", 12)]
    for r in rec.records:
        assert r["curve"].shape == (8,) and np.all((r["curve"] >= 0) & (r["curve"] <= 1 + 1e-9))
    # the final network of the returned attempt is what the end event probed
    assert np.allclose(probe(res.network), rec.of_attempt(res.seed)[-1]["curve"])
    # the optimised network's NTK differs from the untrained one (the head moved)
    assert not np.allclose(rec.records[0]["curve"], rec.records[-1]["curve"])


@pytest.mark.slow
def test_bench_runner_writes_table(tmp_path):
    from neuraluv.cli import main

    assert main(["bench", "ntk", "--meshes", "cap", "--preset", "test", "--iterations", "4", "--samples", "24",
                 "-o", str(tmp_path), "--quiet"]) == 0
    md = (tmp_path / "ntk_compact_controls.md").read_text()
    assert "Spectral inputs raise S(16) at init" in md and ("YES" in md or "NO" in md)
    for f in ("ntk_compact_controls.csv", "alignment.csv", "alignment_curves.png", "run.json"):
        assert (tmp_path / f).stat().st_size > 0
    import csv

    rows = list(csv.DictReader(open(tmp_path / "ntk_compact_controls.csv")))
    assert len(rows) == 5 and all(0 <= float(r["S16"]) <= 1 for r in rows)
    assert {r["S16_paper"] for r in rows} >= {"0.716", "0.527"}


@pytest.mark.slow
def test_trajectory_probe_rows_correlations_and_claims():
    from neuraluv_paper.bench.ntk_trajectory import trajectory_probe

    pr = trajectory_probe(2, (20, 2000), "test", 10, samples=24, device="cpu", show_progress=False, sources=["sphere"])
    assert pr["charts"] == 2 and len(pr["runs"]) == 4  # recipe + random absolute init per chart
    recipe = [r for r in pr["runs"] if r["run"] == "tutte-residual"]
    assert all(r["ends_valid"] and r["flip_percent_final"] == 0 for r in recipe)  # the recipe's start is valid
    events = {(r["event"], r["step"]) for r in pr["rows"] if r["chart"] == recipe[0]["chart"] and r["run"] == "tutte-residual"}
    assert ("warmup_end", 0) in events and ("end", 10) in events and ("step", 5) in events
    # no variance in the recipe's flip rate: correlations are nan there, and the claim is marked not tested
    assert all(not np.isfinite(c["r"]) for c in pr["correlations"]
               if c["subset"] == "recipe runs" and c["outcome"] == "flip_percent")
    claims = {c[0].split(" (")[0]: c[1] for c in pr["checks"]}
    assert claims["Early S(r) correlates only moderately with the final flip rate"] is None
