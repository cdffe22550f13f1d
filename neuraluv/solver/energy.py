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

    The one place the paper's per-face formulas are written (torch).

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
    fro2, det = _fro2_det(*jacobian_entries(UV, F, dC_inv))
    stable_f, bar_f, true_f = face_terms(fro2, det, eps_J, eps)
    if n_charts == 1:  # one chart: plain sums are cheaper than segment sums
        stable = (w * stable_f).sum()[None]
        bar = bar_f.sum()[None]
        with torch.no_grad():
            esd = (w * true_f).sum()[None]
            flips = (det <= 0).sum()[None]
            min_det = det.detach().min()[None]
        return ChartObjective(stable + alpha * bar, stable, bar, esd, flips, min_det)
    z = torch.zeros(n_charts, dtype=fro2.dtype, device=fro2.device)
    stable = z.index_add(0, face_chart, w * stable_f)
    bar = z.index_add(0, face_chart, bar_f)
    with torch.no_grad():
        esd = z.index_add(0, face_chart, w * true_f)
        flips = torch.zeros(n_charts, dtype=torch.long, device=fro2.device).index_add(0, face_chart, (det <= 0).long())
        min_det = torch.full_like(z, float("inf")).scatter_reduce(0, face_chart, det.detach(), "amin")
    return ChartObjective(stable + alpha * bar, stable, bar, esd, flips, min_det)
