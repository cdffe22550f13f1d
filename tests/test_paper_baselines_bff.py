"""Boundary First Flattening: known cases (planar input, smooth charts, closure)."""
import numpy as np
import pytest

from neuraluv import datasets
from neuraluv.errors import TopologyError
from neuraluv.metrics import distortion_metrics
from neuraluv.spectral import cotangent_laplacian
from neuraluv_paper.baselines.bff import (angle_defects, best_fit_curve, bff, dirichlet_to_neumann,
                                          oriented_boundary_loop)
from neuraluv_paper.baselines.libigl import lscm


def _procrustes_residual(X, Y):
    """Max distance between Y and the best rigid motion of X (no scaling)."""
    Xc, Yc = X - X.mean(0), Y - Y.mean(0)
    U, _, Wt = np.linalg.svd(Xc.T @ Yc)
    R = U @ Wt
    return float(np.abs(Xc @ R - Yc).max())


def _irregular_planar_chart():
    """A planar ellipse-shaped chart with jittered interior vertices."""
    V, F = datasets.disk(n_rings=6)
    rng = np.random.default_rng(0)
    bnd = oriented_boundary_loop(F)
    interior = np.setdiff1d(np.arange(len(V)), bnd)
    V = V.copy()
    V[interior, :2] += rng.uniform(-0.02, 0.02, (len(interior), 2))
    V[:, 0] *= 1.7
    return V, F


@pytest.mark.parametrize("extension", ["conjugate", "harmonic"])
def test_planar_chart_maps_to_itself(extension):
    # flat input: Ω = 0, so u = 0, k̃ = k and the curve is the boundary itself
    V, F = _irregular_planar_chart()
    uv = bff(V, F, extension=extension)
    assert _procrustes_residual(V[:, :2], uv) < 1e-8
    m = distortion_metrics(V, F, uv)
    assert m["flips"] == 0 and abs(m["esd"] - 4.0) < 1e-8 and abs(m["conformal"] - 1.0) < 1e-8


@pytest.mark.parametrize("name", ["cap", "saddle", "bumpy"])
def test_smooth_charts_are_conformal_and_flip_free(name):
    V, F = datasets.procedural(name)
    uv = bff(V, F)
    m = distortion_metrics(V, F, uv)
    ref = distortion_metrics(V, F, lscm(V, F))["conformal"]  # the discrete optimum of a conformal energy
    assert m["flips"] == 0
    assert m["conformal"] < 1.1
    assert m["conformal"] < ref + 2e-3


def test_zero_flips_on_procedural_charts():
    for name in ["disk", "cap", "saddle", "bumpy", "glove"]:
        V, F = datasets.procedural(name)
        for ext in ["conjugate", "harmonic"]:
            assert distortion_metrics(V, F, bff(V, F, extension=ext))["flips"] == 0, (name, ext)


def test_gauss_bonnet_and_target_curvature_sum():
    V, F = datasets.procedural("cap")
    bnd = oriented_boundary_loop(F)
    omega, k = angle_defects(V, F, bnd)
    assert omega.sum() > 0.5  # a curved cap: the boundary alone does not close
    assert abs(omega.sum() + k.sum() - 2 * np.pi) < 1e-9
    _, h = dirichlet_to_neumann((-cotangent_laplacian(V, F)).tocsr(), omega, bnd, np.zeros(len(bnd)))
    assert abs((k + h).sum() - 2 * np.pi) < 1e-8  # the flat boundary closes up


def test_u_zero_keeps_boundary_lengths():
    # minimal area distortion: boundary lengths kept up to the closure projection
    V, F = datasets.procedural("saddle")
    uv = bff(V, F, extension="harmonic")
    bnd = oriented_boundary_loop(F)
    nxt = np.roll(bnd, -1)
    ratio = np.linalg.norm(uv[nxt] - uv[bnd], axis=1) / np.linalg.norm(V[nxt] - V[bnd], axis=1)
    assert np.abs(ratio - 1).max() < 1e-2
    # a positive boundary scale factor enlarges the boundary accordingly
    uv2 = bff(V, F, boundary_u=np.log(2.0), extension="harmonic")
    ratio2 = np.linalg.norm(uv2[nxt] - uv2[bnd], axis=1) / np.linalg.norm(V[nxt] - V[bnd], axis=1)
    assert abs(np.median(ratio2) - 2.0) < 2e-2


def test_target_curvature_is_reproduced():
    V, F = datasets.procedural("cap")
    bnd = oriented_boundary_loop(F)
    kt = np.full(len(bnd), 2 * np.pi / len(bnd))  # a regular-polygon-like boundary
    uv = bff(V, F, target_k=kt, extension="harmonic")
    e = np.roll(uv[bnd], -1, axis=0) - uv[bnd]
    ang = np.arctan2(e[:, 1], e[:, 0])
    turn = np.angle(np.exp(1j * (ang - np.roll(ang, 1))))
    assert np.abs(turn - kt).max() < 1e-9
    assert distortion_metrics(V, F, uv)["flips"] == 0
    with pytest.raises(ValueError, match="2π"):
        bff(V, F, target_k=kt * 1.1)


def test_best_fit_curve_closes():
    rng = np.random.default_rng(1)
    b = 40
    k = rng.uniform(0.5, 1.5, b)
    k *= 2 * np.pi / k.sum()
    g = best_fit_curve(rng.uniform(0.5, 2.0, b), k)
    closing = g[0] - g[-1]
    # the last edge closes the polygon in the direction prescribed by k
    phi = k[1:].sum()
    assert np.allclose(closing / np.linalg.norm(closing), [np.cos(phi), np.sin(phi)], atol=1e-9)


def test_orientation_and_closed_input():
    V, F = datasets.procedural("saddle")
    uv_a = bff(V, F)
    uv_b = bff(V, F[:, ::-1])  # reversed winding: still orientation-preserving
    assert distortion_metrics(V, F, uv_a)["flips"] == 0
    assert distortion_metrics(V, F[:, ::-1], uv_b)["flips"] == 0
    with pytest.raises(TopologyError, match="boundary"):
        bff(*datasets.sphere(1))
