"""The chart network: a SIREN mapping per-vertex features to UV coordinates.

``h_{l+1} = sin(ω₀ (W_l h_l + b_l))`` (paper Eq. 3) with Sitzmann et al.'s
initialisation, followed by a linear 2-D head. In residual mode the output is
``u = u_Tutte + head(h)`` with a zero-initialised head, so the untrained network
reproduces the Tutte map exactly.
"""
from __future__ import annotations

import math

import torch
from torch import nn

__all__ = ["SineLayer", "Siren"]


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
