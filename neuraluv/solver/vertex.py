"""The per-vertex control: the solver's objective and checked steps over the UVs themselves.

The paper's title claim is that the *network* is a prior: ``u = φ_θ(x)``
instead of free vertex coordinates. To isolate it, ``SolverConfig(param="vertex")``
keeps everything of Algorithm 1 — the valid start (Tutte, un-crushed by SLIM
where the preset says so), the C² objective, the barrier and its annealed
weight, the validity-checked (rejection) step, Adam or L-BFGS, retries and the
marked fallback — and replaces only the parameters: ``θ`` is the displacement
of every vertex from the start,

.. math:: \\mathbf u_i = \\mathbf u_i^{\\mathrm{start}} + \\theta_i, \\qquad \\theta \\in \\mathbb R^{n \\times 2},

zero at the start, exactly as the residual SIREN's zero head. This is what
"direct methods optimize all u_i independently" (paper Sec. 3) means, with the
solver's own step rule; it is the control of notebook 03d.

The engine (:mod:`neuraluv.solver.engine`) evaluates the flat parameters
``theta (B, 2n)`` of a batch with :func:`forward` instead of the SIREN's; the
features ``X`` are not read (so :func:`~neuraluv.solver.chart.prepare_chart`
skips the LBO eigen-solve when ``param == "vertex"``).
"""
from __future__ import annotations

import torch
from torch import nn

from neuraluv.solver.siren import to_module as _siren_module

__all__ = ["PARAMS", "VertexMap", "init_params", "leaves", "forward", "to_module", "check_param", "chart_module"]

#: The parameterisations of :attr:`SolverConfig.param <neuraluv.solver.config.SolverConfig>`.
PARAMS = ("siren", "vertex")


class VertexMap(nn.Module):
    """Free per-vertex UVs as a module: ``forward(X)`` returns ``base + displacement`` and ignores ``X``.

    The stand-in for :class:`~neuraluv.solver.siren.Siren` in the solver's
    callbacks (film strips) and in :attr:`ChartResult.network <neuraluv.solver.result.ChartResult>`.

    Parameters
    ----------
    base : (n,2) float64 tensor
        The valid start.
    displacement : (n,2) tensor, optional
        ``θ`` (default zero: the module reproduces ``base``).

    Examples
    --------
    >>> m = VertexMap(torch.zeros(3, 2, dtype=torch.float64), torch.ones(3, 2))
    >>> m(torch.zeros(3, 19)).sum().item()
    6.0
    """

    def __init__(self, base, displacement=None):
        super().__init__()
        self.register_buffer("base", torch.as_tensor(base, dtype=torch.float64))
        d = torch.zeros_like(self.base) if displacement is None else torch.as_tensor(displacement).to(self.base)
        self.displacement = nn.Parameter(d.reshape(self.base.shape).clone())

    def forward(self, X=None):
        if X is not None and len(X) != len(self.base):
            raise ValueError(f"a per-vertex map has {len(self.base)} vertices, got {len(X)} feature rows: it is "
                             "defined on its own chart's vertices only (no features, no other points)")
        return self.base + self.displacement


def init_params(B, n, *, device="cpu"):
    """Zero displacements of ``B`` charts padded to ``n`` vertices: ``(B, 2n)`` float64 (the start itself)."""
    return torch.zeros(B, 2 * n, dtype=torch.float64, device=device)


def leaves(theta):
    """``theta (B, 2n)`` as one leaf that requires grad, in the layout :func:`~neuraluv.solver.siren.flat_grad` reads."""
    return [(theta.detach().requires_grad_(True),)]


def forward(theta, base, *, mask=None):
    """UVs of every chart: ``base + θ`` reshaped to ``(B, n, 2)`` (float64).

    Parameters
    ----------
    theta : (B, 2n) tensor, or its :func:`leaves`
    base : (B, n, 2) float64 tensor
        The valid start of every chart (the residual base).
    mask : (B, n, 1) tensor, optional
        0 on pinned vertices (they stay at ``base``), as in the SIREN's :func:`~neuraluv.solver.siren.forward`.

    Returns
    -------
    (B, n, 2) float64 tensor

    Examples
    --------
    >>> base = torch.zeros(1, 3, 2, dtype=torch.float64)
    >>> th = init_params(1, 3)
    >>> th[0, 0] = 1.0
    >>> forward(th, base)[0, 0].tolist(), forward(th, base, mask=torch.zeros(1, 3, 1))[0, 0].tolist()
    ([1.0, 0.0], [0.0, 0.0])
    """
    t = theta if torch.is_tensor(theta) else theta[0][0]
    out = t.reshape(base.shape).to(base.dtype)
    if mask is not None:
        out = out * mask
    return base + out


def to_module(theta_row, base):
    """A :class:`VertexMap` holding one chart's displacement ``theta_row (2n',)`` on ``base (n,2)`` (n ≤ n')."""
    n = len(base)
    return VertexMap(base, theta_row.detach().reshape(-1, 2)[:n]).to(theta_row.device)


def check_param(cfg):
    """``cfg.param`` (``"siren"`` or ``"vertex"``), or a ValueError that lists the choices."""
    p = getattr(cfg, "param", "siren")
    if p not in PARAMS:
        raise ValueError(f"param must be one of {PARAMS}, got {p!r}")
    return p


def chart_module(theta_row, d, cfg, base=None):
    """One chart's map as a module holding ``theta_row``: a :class:`~neuraluv.solver.siren.Siren`
    (``param="siren"``, ``d`` input features) or a :class:`VertexMap` on ``base (n,2)`` (``param="vertex"``)."""
    if check_param(cfg) == "vertex":
        return to_module(theta_row, base)
    return _siren_module(theta_row, d, cfg, base)
