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

__all__ = ["inv_det_sq", "jacobians_torch", "fro2_det", "stable_esd", "true_esd", "barrier", "alpha_schedule", "objective", "Objective"]


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
    dU = torch.stack([UV[F[:, 1]] - UV[F[:, 0]], UV[F[:, 2]] - UV[F[:, 0]]], dim=-1)
    return dU @ dC_inv


def fro2_det(J):
    """``‖J‖²_F`` and ``det J`` of 2x2 Jacobians ``J (m,2,2)`` (torch or numpy)."""
    a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
    return a * a + b * b + c * c + d * d, a * d - b * c


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
    return torch.sum(A * fro2 * (1.0 + inv_det_sq(det, eps_J))) / torch.sum(A)


def true_esd(J, A):
    """The true area-weighted E_SD (no extension; ``inf`` at det J = 0), without gradient.

    Agrees with :func:`neuraluv.metrics.distortion_metrics` ``["esd"]``.
    """
    with torch.no_grad():
        fro2, det = fro2_det(J)
        return torch.sum(A * fro2 * (1.0 + det.pow(-2.0))) / torch.sum(A)


def barrier(det, eps=1e-3):
    """Injectivity barrier ``Σ_t [ε − det J_t]₊²`` (torch).

    Notes
    -----
    A plain sum over faces, as in the paper's loss, while the energy beside it is
    an area-weighted *mean*: the barrier's weight relative to the energy grows
    with the chart's face count (docs/ARCHITECTURE.md, "The objective's scale").
    """
    return torch.sum(torch.clamp(eps - det, min=0.0) ** 2)


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
