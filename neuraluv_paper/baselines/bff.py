"""Boundary First Flattening (Sawhney & Crane 2017) on scipy.

BFF builds a conformal flattening of a disk by first deciding the flat
boundary curve and then extending it to the interior:

1. **Dirichlet-to-Neumann.** Given target boundary log scale factors ``u|∂``
   (``0`` by default: the flattening with minimal area distortion), solve the
   discrete Yamabe equation ``L u = −Ω`` at interior vertices (``L`` the
   positive semi-definite cotangent Laplacian, ``Ω`` the angle defects); the
   boundary residual ``h = (L u)|∂`` is the normal derivative ``∂u/∂n`` and
   the flat boundary curvature is ``k̃ = k + h`` (``k = π − Σθ`` the discrete
   geodesic curvature).
2. **Best-fit curve.** Integrate the tangent angles ``φ_i = Σ_{j≤i} k̃_j``
   with target edge lengths ``l̃_ij = e^{(u_i+u_j)/2} l_ij``, after projecting
   ``l̃`` to the nearest lengths (in the ``N⁻¹`` norm, ``N = diag(l̃)`` the
   boundary edge mass matrix) for which the polygon closes.
3. **Extension.** Extend the curve ``γ`` into the interior: the real part
   harmonically and the imaginary part as its discrete harmonic conjugate (a
   Neumann problem), or both parts harmonically.

A target boundary curvature ``k̃`` can be given instead (Neumann-to-Dirichlet:
solve ``L u = −Ω`` in the interior and ``(L u)|∂ = k̃ − k`` on the boundary).

This is a compact re-implementation of the method for benchmarking (the
reference is the authors' C++ ``bff`` command-line tool); it handles one disk.
"""
from __future__ import annotations

import igl
import numpy as np
import scipy.sparse.linalg as spla

from neuraluv.errors import TopologyError
from neuraluv.metrics import match_area
from neuraluv.spectral import cotangent_laplacian
from neuraluv.topology import boundary_loop, components, is_disk_like
from neuraluv_paper.baselines.common import InitFail, orient_charts

__all__ = ["bff", "bff_map", "oriented_boundary_loop", "angle_defects", "dirichlet_to_neumann", "best_fit_curve", "extend_curve"]


def oriented_boundary_loop(F):
    """The boundary loop with the faces on its left (:func:`neuraluv.topology.boundary_loop`).

    Raises :class:`~neuraluv.errors.TopologyError` for a loop of fewer than 3 vertices.

    Examples
    --------
    >>> oriented_boundary_loop(np.array([[0, 1, 2], [0, 2, 3]])).tolist()
    [0, 1, 2, 3]
    """
    bnd = boundary_loop(F, oriented=True)
    if len(bnd) < 3:
        raise TopologyError("BFF needs a boundary loop of at least 3 vertices (is the chart closed?)")
    return bnd


def angle_defects(V, F, bnd):
    """Angle defects at interior vertices and geodesic curvature at boundary vertices.

    Returns
    -------
    omega : (n,) float array
        ``2π − Σθ`` at interior vertices, 0 on the boundary.
    k : (b,) float array
        ``π − Σθ`` at ``bnd`` (the turning angle of the boundary).

    Notes
    -----
    Discrete Gauss–Bonnet: ``Σ Ω + Σ k = 2π χ = 2π`` for a disk.

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> V, F = disk(3); bnd = oriented_boundary_loop(F)
    >>> om, k = angle_defects(V, F, bnd)
    >>> round(float(om.sum() + k.sum()) / (2 * np.pi), 9), round(float(abs(om).max()), 9)
    (1.0, 0.0)
    """
    F = np.asarray(F, np.int64)
    theta = np.asarray(igl.internal_angles(np.asarray(V, float), F))
    s = np.bincount(F.ravel(), theta.ravel(), minlength=len(V))
    omega = 2 * np.pi - s
    omega[bnd] = 0.0
    return omega, np.pi - s[bnd]


def _solve(A, b):
    return spla.splu(A.tocsc()).solve(np.asarray(b, float))


def dirichlet_to_neumann(L, omega, bnd, u_b):
    """Scale factors ``u`` with ``u|∂ = u_b`` and their normal derivative ``h``.

    Parameters
    ----------
    L : (n,n) sparse matrix
        Positive semi-definite cotangent Laplacian.
    omega : (n,) float array
        Interior angle defects.
    bnd : (b,) int array
    u_b : (b,) float array

    Returns
    -------
    u : (n,) float array
    h : (b,) float array
        ``(L u)|∂``, the integrated normal derivative ``∂u/∂n``.

    Notes
    -----
    ``L_II u_I = −Ω_I − L_IB u_B``: the linearised Yamabe equation
    ``Δu = K − K̃ e^{2u}`` with flat target ``K̃ = 0`` (paper Eq. 4).
    """
    n = L.shape[0]
    interior = np.setdiff1d(np.arange(n), bnd)
    u = np.zeros(n)
    u[bnd] = u_b
    if len(interior):
        LII = L[interior][:, interior]
        rhs = -omega[interior] - L[interior][:, bnd] @ u[bnd]
        u[interior] = _solve(LII, rhs)
    return u, np.asarray(L[bnd] @ u).ravel()


def neumann_to_dirichlet(L, omega, bnd, k, k_target):
    """Scale factors ``u`` whose boundary curvature becomes ``k_target``.

    Solves the Neumann problem ``L u = −Ω`` (interior), ``(L u)|∂ = k̃ − k``
    (boundary), unique up to a constant fixed by ``mean(u|∂) = 0``.

    Returns
    -------
    u : (n,) float array
    """
    n = L.shape[0]
    rhs = -np.asarray(omega, float).copy()
    rhs[bnd] = np.asarray(k_target, float) - k
    if abs(rhs.sum()) > 1e-6 * max(1.0, np.abs(rhs).sum()):
        raise ValueError(f"target boundary curvature must sum to 2π (Gauss–Bonnet); it sums to {np.sum(k_target):.6f}")
    keep = np.arange(1, n)  # pin u[0] = 0; the system is consistent
    u = np.zeros(n)
    u[keep] = _solve(L[keep][:, keep], rhs[keep])
    return u - u[bnd].mean()


def best_fit_curve(l_target, k_target):
    """Closed polygon with turning angles ``k̃`` and edge lengths closest to ``l̃``.

    Parameters
    ----------
    l_target : (b,) float array
        Target length of boundary edge ``i`` (from vertex ``i`` to ``i+1``).
    k_target : (b,) float array
        Turning angle at vertex ``i`` (sums to 2π).

    Returns
    -------
    gamma : (b,2) float array
        Vertex positions, ``gamma[0] = 0``.

    Notes
    -----
    With tangents ``T_i = (cos φ_i, sin φ_i)``, ``φ_i = Σ_{j=1}^{i} k̃_j``,
    the lengths are ``l = l̃ − N Tᵀ (T N Tᵀ)⁻¹ T l̃`` with ``N = diag(l̃)``:
    the minimiser of ``‖l − l̃‖²_{N⁻¹}`` subject to ``T l = 0`` (the curve closes).

    Examples
    --------
    Right angles and one edge too long: the lengths are adjusted until the
    rectangle closes.

    >>> g = best_fit_curve(np.array([1.0, 1.0, 1.0, 1.2]), np.full(4, np.pi / 2))
    >>> g.round(4).tolist()
    [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0909], [0.0, 1.0909]]
    """
    l_target = np.asarray(l_target, float)
    k_target = np.asarray(k_target, float)
    phi = np.concatenate([[0.0], np.cumsum(k_target[1:])])
    T = np.stack([np.cos(phi), np.sin(phi)])  # (2,b)
    N = l_target
    l = l_target - N * (T.T @ np.linalg.solve((T * N) @ T.T, T @ l_target))
    steps = T.T * l[:, None]
    return np.vstack([[0.0, 0.0], np.cumsum(steps[:-1], axis=0)])


def extend_curve(L, bnd, gamma, extension="conjugate"):
    """Extend boundary positions ``gamma`` to the interior.

    Parameters
    ----------
    L : (n,n) sparse matrix
        Positive semi-definite cotangent Laplacian.
    bnd : (b,) int array
        Counter-clockwise boundary loop.
    gamma : (b,2) float array
    extension : {"conjugate", "harmonic"}
        ``"conjugate"``: ``a`` = harmonic extension of ``γ_x``; ``b`` its
        harmonic conjugate, ``L b = h`` with ``h_i = −(a_{i+1} − a_{i−1})/2``
        on the boundary (Cauchy–Riemann: ``∂b/∂n = −∂a/∂t``), 0 inside.
        ``"harmonic"``: both coordinates harmonic with ``γ`` as Dirichlet data.

    Returns
    -------
    UV : (n,2) float array
    """
    n = L.shape[0]
    interior = np.setdiff1d(np.arange(n), bnd)
    LII = L[interior][:, interior]
    LIB = L[interior][:, bnd]

    def harmonic(g):
        x = np.zeros((n,) + g.shape[1:])
        x[bnd] = g
        if len(interior):
            x[interior] = _solve(LII, -(LIB @ g))
        return x

    if extension == "harmonic":
        return harmonic(gamma)
    if extension != "conjugate":
        raise ValueError(f"extension must be 'conjugate' or 'harmonic', got {extension!r}")
    a = harmonic(gamma[:, 0])
    h = np.zeros(n)
    h[bnd] = -0.5 * (a[np.roll(bnd, -1)] - a[np.roll(bnd, 1)])
    keep = np.setdiff1d(np.arange(n), bnd[:1])  # pin b at one boundary vertex to γ_y
    b = np.zeros(n)
    b[bnd[0]] = gamma[0, 1]
    b[keep] = _solve(L[keep][:, keep], h[keep] - L[keep][:, bnd[:1]] @ b[bnd[:1]])
    return np.column_stack([a, b])


def bff(V, F, *, boundary_u=0.0, target_k=None, extension="conjugate"):
    """Boundary First Flattening of a disk-like chart.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
        One consistently oriented disk.
    boundary_u : float or (b,) float array
        Target log scale factors along :func:`oriented_boundary_loop` (0: keep
        boundary lengths, the minimal-area-distortion flattening).
    target_k : (b,) float array, optional
        Target boundary turning angles (sum 2π) instead of scale factors.
    extension : {"conjugate", "harmonic"}
        Interior extension (see :func:`extend_curve`).

    Returns
    -------
    UV : (n,2) float array
        Counter-clockwise (orientation-preserving), near the 3D scale (exactly
        the 3D boundary lengths up to the closure projection when ``u = 0``).

    Notes
    -----
    Sawhney & Crane, *Boundary First Flattening*, ACM TOG 2017. With
    ``u|∂ = 0``: ``L_II u_I = −Ω_I``, ``k̃ = k + (L u)|∂`` (Eq. 4 and the
    Dirichlet-to-Neumann map), ``l̃ = e^{(u_i+u_j)/2} l_ij``, closure
    ``l = l̃ − N Tᵀ(T N Tᵀ)⁻¹ T l̃`` (Sec. 4.3), then the conjugate-harmonic
    extension ``f = a + i b`` (Sec. 4.4).

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> from neuraluv.metrics import distortion_metrics
    >>> V, F = disk(4)
    >>> m = distortion_metrics(V, F, bff(V, F))
    >>> m["flips"], round(m["conformal"], 6), round(m["esd"], 6)
    (0, 1.0, 4.0)
    """
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    bnd = oriented_boundary_loop(F)
    L = (-cotangent_laplacian(V, F)).tocsr()  # positive semi-definite
    omega, k = angle_defects(V, F, bnd)
    if target_k is None:
        u_b = np.broadcast_to(np.asarray(boundary_u, float), bnd.shape).copy()
        u, h = dirichlet_to_neumann(L, omega, bnd, u_b)
        k_t = k + h
    else:
        k_t = np.asarray(target_k, float)
        u = neumann_to_dirichlet(L, omega, bnd, k, k_t)
    nxt = np.roll(bnd, -1)
    l = np.linalg.norm(V[nxt] - V[bnd], axis=1)
    l_t = np.exp(0.5 * (u[bnd] + u[nxt])) * l
    gamma = best_fit_curve(l_t, k_t)
    return extend_curve(L, bnd, gamma, extension)



def bff_map(V, F, **kw):
    """Boundary First Flattening, each component separately (see :mod:`neuraluv_paper.baselines.bff`)."""
    parts = components(V, F)
    UV = np.zeros((len(V), 2))
    x0 = 0.0
    for i, (vi, fi, Fc) in enumerate(parts):
        ok, why = is_disk_like(V[vi], Fc)
        if not ok:
            what = "input" if len(parts) == 1 else f"component {i}"
            raise InitFail(f"bff needs disk-like components: {what}: {why}")
        uv = bff(V[vi], Fc, **kw)
        uv = orient_charts(V[vi], Fc, match_area(V[vi], Fc, uv))[0]
        uv = uv - uv.min(0) + [x0, 0.0]
        x0 = uv[:, 0].max() + 0.1 * np.ptp(uv[:, 1])
        UV[vi] = uv
    return UV
