"""The stable objective: C² inverse-determinant extension, E_SD and the barrier.

For 2x2 Jacobians ‖J⁻¹‖²_F = ‖J‖²_F / det(J)², so only the factor ``q(d) = d⁻²``
is singular. Below ``ε_J`` it is replaced by its second-order Taylor polynomial
at ``ε_J`` (matching value, first and second derivative), and an injectivity
barrier ``α(s) Σ_t [ε − det J_t]₊²`` is added (paper Sec. 3, "Stable objective").
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import torch

__all__ = ["inv_det_sq", "face_terms", "jacobian_entries", "jacobians_torch", "fro2_det", "stable_esd", "true_esd", "barrier",
           "alpha_schedule", "objective", "Objective", "chart_objective", "ChartObjective"]


def inv_det_sq(d, eps_J=1e-4):
    """``q(d) = d⁻²`` above ``ε_J``, its C² Taylor extension below.

    Parameters
    ----------
    d : torch tensor or numpy array
        Determinants.
    eps_J : float
        Switch point (paper: 1e-4).

    Returns
    -------
    q : same type and shape as ``d``

    Notes
    -----
    For ``d ≤ ε_J``:

    .. math:: q(d) = ε_J^{-2} − 2(d − ε_J) ε_J^{-3} + 3(d − ε_J)^2 ε_J^{-4}

    which equals ``d⁻²``, ``−2 d⁻³`` and ``6 d⁻⁴`` at ``d = ε_J``. The
    polynomial is finite and convex for every ``d``, so flipped triangles get a
    finite, restoring gradient.

    Examples
    --------
    >>> float(inv_det_sq(np.array(2.0)))
    0.25
    >>> float(inv_det_sq(np.array(0.0), eps_J=0.5))  # 4 + 2*0.5*8 + 3*0.25*16
    24.0
    """
    if isinstance(d, torch.Tensor):
        safe = torch.where(d > eps_J, d, torch.full_like(d, eps_J))
        t = d - eps_J
        poly = eps_J**-2 - 2.0 * t * eps_J**-3 + 3.0 * t * t * eps_J**-4
        return torch.where(d > eps_J, safe**-2, poly)
    d = np.asarray(d, float)
    t = d - eps_J
    poly = eps_J**-2 - 2.0 * t * eps_J**-3 + 3.0 * t * t * eps_J**-4
    with np.errstate(divide="ignore"):
        return np.where(d > eps_J, np.where(d > eps_J, d, eps_J) ** -2.0, poly)


def jacobian_entries(UV, F, dC_inv):
    """The entries ``(a, b, c, d)`` of every face's ``J = [[a, b], [c, d]] = ΔU ΔC⁻¹`` (torch).

    Parameters
    ----------
    UV : (n,2) torch tensor
    F : (m,3) torch long tensor
    dC_inv : (m,2,2) torch tensor

    Returns
    -------
    a, b, c, d : (m,) torch tensors

    Notes
    -----
    Written out entry by entry (one gather of the corners, no batched 2x2
    matrix products): this runs every solver iteration.
    """
    m = F.shape[0]
    P = UV[F.reshape(-1)].view(m, 3, 2)
    e1 = P[:, 1] - P[:, 0]
    e2 = P[:, 2] - P[:, 0]
    k00, k01, k10, k11 = dC_inv[:, 0, 0], dC_inv[:, 0, 1], dC_inv[:, 1, 0], dC_inv[:, 1, 1]
    return (e1[:, 0] * k00 + e2[:, 0] * k10, e1[:, 0] * k01 + e2[:, 0] * k11,
            e1[:, 1] * k00 + e2[:, 1] * k10, e1[:, 1] * k01 + e2[:, 1] * k11)


def jacobians_torch(UV, F, dC_inv):
    """Per-face Jacobians of a UV map (torch, differentiable).

    Parameters
    ----------
    UV : (n,2) torch tensor
    F : (m,3) torch long tensor
    dC_inv : (m,2,2) torch tensor

    Returns
    -------
    J : (m,2,2) torch tensor

    Examples
    --------
    >>> from neuraluv.jacobian import local_frames
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> dCi, _ = local_frames(V, F)
    >>> J = jacobians_torch(torch.tensor(3 * V[:, :2]), torch.tensor(F), torch.tensor(dCi))
    >>> J[0].tolist()
    [[3.0, 0.0], [0.0, 3.0]]
    """
    a, b, c, d = jacobian_entries(UV, F, dC_inv)
    return torch.stack([torch.stack([a, b], -1), torch.stack([c, d], -1)], -2)


def fro2_det(J):
    """``‖J‖²_F`` and ``det J`` of 2x2 Jacobians ``J (m,2,2)`` (torch or numpy)."""
    return _fro2_det(J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1])


def _fro2_det(a, b, c, d):
    return a * a + b * b + c * c + d * d, a * d - b * c


def face_terms(fro2, det, eps_J, eps):
    """Per face: the stable energy ``‖J‖²(1 + q(det))``, the barrier ``[ε − det]₊²``, the true energy.

    The one place the paper's per-face formulas are written (torch); the solver's per-chart
    sums with their slope ``q'`` for the written-out gradient are :class:`_ChartTerms`.

    Parameters
    ----------
    fro2, det : (m,) torch tensors
        ``‖J_t‖²_F`` and ``det J_t``.
    eps_J, eps : float

    Returns
    -------
    stable, barrier, true : (m,) torch tensors (``true`` without gradient)
    """
    stable = fro2 * (1.0 + inv_det_sq(det, eps_J))
    bar = torch.clamp(eps - det, min=0.0) ** 2
    with torch.no_grad():
        true = fro2 * (1.0 + det.pow(-2.0))
    return stable, bar, true


def stable_esd(J, A, eps_J=1e-4):
    """Area-weighted mean of ``‖J‖²_F (1 + q(det J))``: the stable energy ``Ẽ_SD`` (torch).

    Parameters
    ----------
    J : (m,2,2) torch tensor
    A : (m,) torch tensor
        Face areas.
    eps_J : float

    Returns
    -------
    scalar torch tensor (4 at an isometry; the true E_SD wherever every det J > ε_J)

    Notes
    -----
    Paper Eq. (1) divided by ``Σ_t A_t``, with ``‖J⁻¹‖²_F = ‖J‖²_F q(det J)``:

    .. math:: \\tilde E_{SD} = \\frac{1}{\\sum_t A_t}\\sum_t A_t \\|J_t\\|_F^2 (1 + q(\\det J_t)).
    """
    fro2, det = fro2_det(J)
    return torch.sum(A * face_terms(fro2, det, eps_J, 0.0)[0]) / torch.sum(A)


def true_esd(J, A):
    """The true area-weighted E_SD (no extension; ``inf`` at det J = 0), without gradient.

    Agrees with :func:`neuraluv.metrics.distortion_metrics` ``["esd"]``.
    """
    fro2, det = fro2_det(J)
    return torch.sum(A * face_terms(fro2.detach(), det.detach(), 1.0, 0.0)[2]) / torch.sum(A)


def barrier(det, eps=1e-3):
    """Injectivity barrier ``Σ_t [ε − det J_t]₊²`` (torch).

    Notes
    -----
    A plain sum over faces, as in the paper's loss, while the energy beside it is
    an area-weighted *mean*: the barrier's weight relative to the energy grows
    with the chart's face count (docs/ARCHITECTURE.md, "The objective's scale").
    """
    return torch.sum(face_terms(torch.zeros_like(det), det, 1.0, eps)[1])


def alpha_schedule(s, n, alpha_start=10.0, alpha_end=0.1):
    """Exponentially annealed barrier weight ``α(s)``, from ``alpha_start`` at
    ``s = 0`` to ``alpha_end`` at ``s = n``.

    Examples
    --------
    >>> alpha_schedule(0, 100), round(alpha_schedule(50, 100), 6), round(alpha_schedule(100, 100), 6)
    (10.0, 1.0, 0.1)
    """
    frac = min(max(s / max(n, 1), 0.0), 1.0)
    return float(alpha_start * math.exp(frac * math.log(alpha_end / alpha_start)))


class Objective(NamedTuple):
    """The terms of the paper's loss at one map (see :func:`objective`)."""

    loss: torch.Tensor  #: ``Ẽ_SD + α B`` (differentiable)
    stable: torch.Tensor  #: ``Ẽ_SD`` (differentiable)
    barrier: torch.Tensor  #: ``B = Σ_t [ε − det J_t]₊²`` (differentiable)
    esd: torch.Tensor  #: the true E_SD (no gradient)
    det: torch.Tensor  #: ``(m,)`` determinants

    def at(self, alpha):
        """The loss with another barrier weight (no recomputation)."""
        return self.stable + alpha * self.barrier


def objective(J, A, alpha, eps_J=1e-4, eps=1e-3):
    """The paper's loss ``Ẽ_SD + α Σ_t [ε − det J_t]₊²``, built from :func:`stable_esd` and :func:`barrier`.

    Parameters
    ----------
    J : (m,2,2) torch tensor
    A : (m,) torch tensor
    alpha : float
        Barrier weight ``α(s)``.
    eps_J, eps : float
        Switch point of the C² extension; barrier margin.

    Returns
    -------
    Objective
        ``loss, stable, barrier, esd, det``; ``esd`` is the true E_SD.

    Examples
    --------
    >>> J = torch.tensor([[[2.0, 0.0], [0.0, 2.0]]], dtype=torch.float64)
    >>> o = objective(J, torch.ones(1, dtype=torch.float64), alpha=10.0)
    >>> float(o.loss), float(o.esd), float(o.barrier)
    (8.5, 8.5, 0.0)
    """
    stable = stable_esd(J, A, eps_J)
    _, det = fro2_det(J)
    bar = barrier(det, eps)
    return Objective(stable + alpha * bar, stable, bar, true_esd(J, A), det)


class ChartObjective(NamedTuple):
    """The loss terms of every chart of a batch, ``(B,)`` each (see :func:`chart_objective`)."""

    loss: torch.Tensor  #: ``Ẽ_SD + α B`` per chart (differentiable)
    stable: torch.Tensor  #: ``Ẽ_SD`` per chart (differentiable)
    barrier: torch.Tensor  #: ``Σ_t [ε − det J_t]₊²`` per chart (differentiable)
    esd: torch.Tensor  #: true E_SD per chart (no gradient)
    flips: torch.Tensor  #: faces with det J ≤ 0 per chart (long)
    min_det: torch.Tensor  #: smallest det J per chart (no gradient)


def chart_objective(UV, F, dC_inv, w, face_chart, n_charts, alpha, eps_J=1e-4, eps=1e-3):
    """:func:`objective` for many charts at once, with per-chart sums.

    Parameters
    ----------
    UV : (N,2) torch tensor
        Vertex UVs of all charts (flattened batch).
    F : (M,3) torch long tensor
        Faces of all charts, indexing ``UV``.
    dC_inv : (M,2,2) torch tensor
    w : (M,) torch tensor
        Area weights, summing to 1 within each chart.
    face_chart : (M,) torch long tensor
        The chart of each face (``0 .. n_charts-1``).
    n_charts : int
    alpha : float or (n_charts,) tensor
        Barrier weight of each chart.
    eps_J, eps : float

    Returns
    -------
    ChartObjective

    Examples
    --------
    >>> UV = torch.tensor([[0., 0], [2, 0], [0, 2], [5, 5], [6, 5], [5, 6]], dtype=torch.float64)
    >>> F = torch.tensor([[0, 1, 2], [3, 4, 5]])
    >>> dCi = torch.eye(2, dtype=torch.float64).repeat(2, 1, 1)
    >>> o = chart_objective(UV, F, dCi, torch.ones(2, dtype=torch.float64), torch.tensor([0, 1]), 2, 10.0)
    >>> o.esd.tolist(), o.flips.tolist()
    ([8.5, 4.0], [0, 0])
    """
    stable, bar, det, true_f = _ChartTerms.apply(UV, F, dC_inv, w, face_chart, n_charts, eps_J, eps)
    with torch.no_grad():
        esd = _per_chart(w * true_f, face_chart, n_charts)
        flips = _per_chart((det <= 0).long(), face_chart, n_charts)
        min_det = (det.min()[None] if n_charts == 1 else
                   torch.full_like(stable, float("inf")).scatter_reduce(0, face_chart, det, "amin"))
    return ChartObjective(stable + alpha * bar, stable, bar, esd, flips, min_det)


def _per_chart(x, face_chart, n_charts):
    """Per-chart sums of the per-face ``x (M,)``, ``(n_charts,)``."""
    if n_charts == 1:  # one chart: a plain sum is cheaper than a segment sum
        return x.sum()[None]
    return torch.zeros(n_charts, dtype=x.dtype, device=x.device).index_add(0, face_chart, x)


class _ChartTerms(torch.autograd.Function):
    """Per chart ``Σ_t w_t ‖J_t‖²(1 + q(det J_t))`` and ``Σ_t [ε − det J_t]₊²`` with their gradient written out.

    The same values as :func:`face_terms` on :func:`jacobian_entries` summed per chart; the
    backward pass is the chain rule by hand (a few dozen tensor operations instead of
    autograd's graph of a hundred nodes: this runs every solver round):
    ``∂s/∂(a, b, c, d) = 2(1 + q)(a, b, c, d) + ‖J‖² q'(det) (d, −c, −b, a)``,
    ``∂[ε − det]₊²/∂(a, b, c, d) = −2[ε − det]₊ (d, −c, −b, a)``, then ``J = ΔU ΔC⁻¹``
    gives ``∂/∂ΔU = (∂/∂J) ΔC⁻ᵀ`` and each face's corners get ``(−e₁ − e₂, e₁, e₂)``'s share.

    Returns ``stable (B,)``, ``bar (B,)`` (differentiable in ``UV``) and, without gradient,
    ``det (M,)`` and the true per-face energy ``‖J‖²(1 + det⁻²) (M,)``.
    """

    @staticmethod
    def forward(ctx, UV, F, dC_inv, w, face_chart, n_charts, eps_J, eps):
        a, b, c, d = jacobian_entries(UV, F, dC_inv)
        fro2, det = _fro2_det(a, b, c, d)
        q = inv_det_sq(det, eps_J)
        big = det > eps_J   # q's slope, above ε_J and on its C² extension below
        dq = torch.where(big, -2.0 * torch.where(big, det, torch.full_like(det, eps_J))**-3,
                         -2.0 * eps_J**-3 + 6.0 * (det - eps_J) * eps_J**-4)
        hinge = torch.clamp(eps - det, min=0.0)
        stable = _per_chart(w * fro2 * (1.0 + q), face_chart, n_charts)
        bar = _per_chart(hinge * hinge, face_chart, n_charts)
        true_f = fro2 * (1.0 + det.pow(-2.0))
        ctx.save_for_backward(a, b, c, d, q, fro2 * dq, hinge, F, dC_inv, w, face_chart)
        ctx.n_charts, ctx.n_rows = n_charts, UV.shape[0]
        ctx.mark_non_differentiable(det, true_f)
        return stable, bar, det, true_f

    @staticmethod
    def backward(ctx, g_stable, g_bar, _g_det, _g_true):
        a, b, c, d, q, fdq, hinge, F, K, w, face_chart = ctx.saved_tensors
        if ctx.n_charts == 1:
            gs, gb = g_stable[0] * w, g_bar[0]
        else:
            gs, gb = g_stable[face_chart] * w, g_bar[face_chart]
        cs = 2.0 * (1.0 + q) * gs                    # ∂/∂(a, b, c, d) along (a, b, c, d)
        cd = fdq * gs - 2.0 * hinge * gb             # ∂/∂det, along (d, -c, -b, a)
        ga, gb_, gc, gd = cs * a + cd * d, cs * b - cd * c, cs * c - cd * b, cs * d + cd * a
        k00, k01, k10, k11 = K[:, 0, 0], K[:, 0, 1], K[:, 1, 0], K[:, 1, 1]
        e1 = torch.stack([ga * k00 + gb_ * k01, gc * k00 + gd * k01], 1)   # ∂/∂(P1 - P0)
        e2 = torch.stack([ga * k10 + gb_ * k11, gc * k10 + gd * k11], 1)   # ∂/∂(P2 - P0)
        corners = torch.stack([-e1 - e2, e1, e2], 1).reshape(-1, 2)
        gUV = torch.zeros(ctx.n_rows, 2, dtype=corners.dtype, device=corners.device)
        gUV.index_add_(0, F.reshape(-1), corners)
        return gUV, None, None, None, None, None, None, None
