"""The stable objective: C² inverse-determinant extension, E_SD and the barrier.

For 2x2 Jacobians ‖J⁻¹‖²_F = ‖J‖²_F / det(J)², so only the factor ``q(d) = d⁻²``
is singular. Below ``ε_J`` it is replaced by its second-order Taylor polynomial
at ``ε_J`` (matching value, first and second derivative), and an injectivity
barrier ``α(s) Σ_t [ε − det J_t]₊²`` is added (paper Sec. 3, "Stable objective").
"""
from __future__ import annotations

import math

import numpy as np
import torch

__all__ = ["inv_det_sq", "stable_esd", "barrier", "alpha_schedule", "objective"]


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


def _fro2_det(J):
    a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
    return a * a + b * b + c * c + d * d, a * d - b * c


def stable_esd(J, A, eps_J=1e-4):
    """Area-weighted mean of ``‖J‖²_F (1 + q(det J))`` (torch).

    Parameters
    ----------
    J : (m,2,2) torch tensor
    A : (m,) torch tensor
        Face areas.
    eps_J : float

    Returns
    -------
    scalar torch tensor (4 at an isometry)
    """
    fro2, det = _fro2_det(J)
    return torch.sum(A * fro2 * (1.0 + inv_det_sq(det, eps_J))) / torch.sum(A)


def barrier(det, eps=1e-3):
    """Injectivity barrier ``Σ_t [ε − det J_t]₊²`` (torch)."""
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


def objective(J, A, alpha, eps_J=1e-4, eps=1e-3):
    """The paper's loss ``Ẽ_SD + α Σ [ε − det J]₊²`` and the determinants.

    Returns
    -------
    loss : scalar tensor
    det : (m,) tensor
    fro2 : (m,) tensor
    """
    fro2, det = _fro2_det(J)
    esd = torch.sum(A * fro2 * (1.0 + inv_det_sq(det, eps_J))) / torch.sum(A)
    return esd + alpha * torch.sum(torch.clamp(eps - det, min=0.0) ** 2), det, fro2
