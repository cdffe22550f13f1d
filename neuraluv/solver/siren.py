"""The chart network: a SIREN mapping per-vertex features to UV coordinates.

``h_{l+1} = sin(ω₀ (W_l h_l + b_l))`` (paper Eq. 3) with Sitzmann et al.'s
initialisation, followed by a linear 2-D head. In residual mode the output is
``u = u_Tutte + head(h)`` with a zero-initialised head, so the untrained network
reproduces the Tutte map exactly.

The same network is evaluated for a whole batch of charts from stacked flat
parameters ``theta (B, P)`` (:func:`forward`, used by the optimisation engine);
:func:`init_params` and :func:`to_module` convert between the two forms.
"""
from __future__ import annotations

import math

import torch
from torch import nn

__all__ = ["SineLayer", "Siren", "param_count", "leaves", "flat_grad", "forward", "init_params", "to_module"]


class SineLayer(nn.Module):
    """``sin(ω₀ (W x + b))`` with SIREN initialisation.

    The first layer draws ``W ~ U(-1/in, 1/in)``; later layers
    ``W ~ U(-√(6/in)/ω₀, √(6/in)/ω₀)`` so pre-activations stay unit-scale.
    """

    def __init__(self, in_features, out_features, omega0=15.0, first=False, generator=None):
        super().__init__()
        self.omega0 = float(omega0)
        self.linear = nn.Linear(in_features, out_features)
        bound = 1.0 / in_features if first else math.sqrt(6.0 / in_features) / self.omega0
        with torch.no_grad():
            self.linear.weight.uniform_(-bound, bound, generator=generator)
            self.linear.bias.uniform_(-bound, bound, generator=generator)

    def forward(self, x):
        return torch.sin(self.omega0 * self.linear(x))


class Siren(nn.Module):
    """SIREN chart network.

    Parameters
    ----------
    in_features : int
        Feature width (3 + k).
    width : int
        Hidden width (paper: 256).
    n_layers : int
        Number of linear layers including the head (paper: 5, i.e. four sine
        layers and one linear output layer).
    omega0 : float
        Sine frequency (paper: 15).
    base : (n,2) tensor, optional
        Residual base map (the Tutte UVs). When given, ``forward`` returns
        ``base + head(h)`` and the head starts at zero (residual mode); otherwise
        the head keeps a small SIREN initialisation (absolute mode).
    generator : torch.Generator, optional
        Random generator of the initialisation (default: torch's global one).

    Examples
    --------
    >>> torch.manual_seed(0) is not None
    True
    >>> base = torch.randn(5, 2, dtype=torch.float64)
    >>> net = Siren(4, width=16, n_layers=3, base=base)
    >>> bool(torch.equal(net(torch.randn(5, 4)), base))
    True
    """

    def __init__(self, in_features, width=256, n_layers=5, omega0=15.0, base=None, generator=None):
        super().__init__()
        if n_layers < 2:
            raise ValueError("n_layers must be >= 2 (at least one sine layer and the head)")
        layers = [SineLayer(in_features, width, omega0, first=True, generator=generator)]
        layers += [SineLayer(width, width, omega0, generator=generator) for _ in range(n_layers - 2)]
        self.body = nn.Sequential(*layers)
        self.head = nn.Linear(width, 2)
        self.residual = base is not None
        with torch.no_grad():
            if self.residual:
                self.head.weight.zero_()
                self.head.bias.zero_()
            else:
                bound = math.sqrt(6.0 / width) / float(omega0)
                self.head.weight.uniform_(-bound, bound, generator=generator)
                self.head.bias.zero_()
        if self.residual:
            self.register_buffer("base", torch.as_tensor(base))
        else:
            self.base = None

    def forward(self, x):
        out = self.head(self.body(x))
        if self.residual:
            return self.base + out.to(self.base.dtype)
        return out.to(torch.float64)


# --------------------------------------------------------------------------- the network on flat parameters


def _shapes(d, width, n_layers):
    """``[(in, out), ...]`` of the SIREN's linear layers (the last is the 2-D head)."""
    dims = [d] + [width] * (n_layers - 1) + [2]
    return list(zip(dims[:-1], dims[1:]))


def param_count(d, width, n_layers):
    """Number of parameters of one chart network.

    Examples
    --------
    >>> param_count(19, 256, 5)  # the paper's network with k = 16
    203010
    """
    return sum(i * o + o for i, o in _shapes(d, width, n_layers))


def _views(theta, d, width, n_layers):
    """``[(W (B,in,out), b (B,1,out)), ...]`` views into ``theta (B, P)``."""
    out, o = [], 0
    B = theta.shape[0]
    for i, k in _shapes(d, width, n_layers):
        W = theta[:, o:o + i * k].view(B, i, k)
        o += i * k
        b = theta[:, o:o + k].view(B, 1, k)
        o += k
        out.append((W, b))
    return out


def leaves(theta, d, width, n_layers):
    """The layers of ``theta (B, P)`` as separate leaf tensors that require grad (sharing its memory).

    Backpropagating into per-layer leaves and concatenating their gradients
    (:func:`flat_grad`) is cheaper than backpropagating into views of one flat
    leaf, which makes autograd scatter every layer's gradient into a full-size buffer.
    """
    return [(W.detach().requires_grad_(True), b.detach().requires_grad_(True)) for W, b in _views(theta, d, width, n_layers)]


def flat_grad(layers):
    """The gradient of :func:`leaves` as one ``(B, P)`` tensor (the layout of ``theta``)."""
    B = layers[0][0].shape[0]
    return torch.cat([t.grad.reshape(B, -1) for L in layers for t in L], 1)


def forward(theta, X, base, *, width, n_layers, omega0, mask=None):
    """UVs of every chart: ``base + head(sin(ω₀(… W₁ x + b₁ …)))`` (float64), ``(B, n, 2)``.

    Parameters
    ----------
    theta : (B, P) tensor, or its :func:`leaves`
        The stacked parameters, chart ``c`` in row ``c``.
    X : (B, n, d) float32 tensor
        The inputs (zero rows pad short charts).
    base : (B, n, 2) float64 tensor or None
        Residual base (None: absolute mode).
    width, n_layers, omega0
        The network's shape and frequency.
    mask : (B, n, 1) tensor, optional
        Multiplies the network's output: vertices with mask 0 stay exactly at
        ``base`` (pinned; used by local UV repair).

    Returns
    -------
    (B, n, 2) float64 tensor

    Notes
    -----
    The same network as :class:`Siren` (paper Eq. 3,
    ``h_{l+1} = sin(ω₀ (W_l h_l + b_l))``), evaluated for all charts at once
    from their stacked weights, each layer one ``torch.baddbmm``.

    Examples
    --------
    >>> from neuraluv.solver.config import get_config
    >>> cfg = get_config("test")
    >>> theta = init_params([0, 1], 5, cfg, residual=False)
    >>> X = torch.rand(2, 7, 5)
    >>> u = forward(theta, X, None, width=cfg.width, n_layers=cfg.n_layers, omega0=cfg.omega0)
    >>> tuple(u.shape), bool(torch.allclose(u[1], to_module(theta[1], 5, cfg)(X[1]), atol=1e-6))
    ((2, 7, 2), True)
    """
    layers = _views(theta, X.shape[2], width, n_layers) if torch.is_tensor(theta) else theta
    h = X
    for W, b in layers[:-1]:
        h = torch.sin(torch.baddbmm(b, h, W, beta=omega0, alpha=omega0))  # sin(ω₀ (h W + b)), one fused product
    W, b = layers[-1]
    out = torch.baddbmm(b, h, W).to(torch.float64)
    if mask is not None:
        out = out * mask
    return out if base is None else base + out


def init_params(seeds, d, cfg, *, residual=True, device="cpu"):
    """Stacked SIREN initialisations, one per seed (Sitzmann et al.; zero head in residual mode).

    Each row is exactly the initialisation of ``Siren(d, cfg.width, cfg.n_layers,
    cfg.omega0, base=..., generator=torch.Generator().manual_seed(seed))``.
    """
    rows = []
    for s in seeds:
        gen = torch.Generator().manual_seed(int(s) % (2**63))
        net = Siren(d, cfg.width, cfg.n_layers, cfg.omega0, base=torch.zeros(1, 2, dtype=torch.float64) if residual else None,
                    generator=gen)
        lin = [m.linear for m in net.body] + [net.head]
        rows.append(torch.cat([t for L in lin for t in (L.weight.detach().T.reshape(-1), L.bias.detach())]))
    return torch.stack(rows).to(device)


def to_module(theta_row, d, cfg, base=None):
    """A :class:`~neuraluv.solver.siren.Siren` holding one chart's parameters (for callbacks, NTK probes)."""
    net = Siren(d, cfg.width, cfg.n_layers, cfg.omega0, base=base)
    lin = [m.linear for m in net.body] + [net.head]
    with torch.no_grad():
        for L, (W, b) in zip(lin, _views(theta_row[None].detach().cpu(), d, cfg.width, cfg.n_layers)):
            L.weight.copy_(W[0].T)
            L.bias.copy_(b[0, 0])
    return net.to(theta_row.device)
