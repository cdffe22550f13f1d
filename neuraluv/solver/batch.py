"""A batch of prepared charts for the engine: inputs padded to one vertex count, faces on the flattened rows.

:func:`make_batch` stacks :class:`~neuraluv.solver.chart.PreparedChart` objects; :func:`subset_batch` keeps some
of them (the engine's compaction when charts stop).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

__all__ = ["ChartBatch", "make_batch", "subset_batch"]


@dataclass
class ChartBatch:
    """Prepared charts padded to one vertex count ``n`` (see :func:`make_batch`).

    Attributes
    ----------
    X : (B, n, d) float32 tensor — SIREN inputs (zero rows pad short charts).
    base : (B, n, 2) float64 tensor or None — residual base (the valid start); None in absolute mode.
    target : (B, n, 2) float64 tensor or None — the warm-up target in absolute mode.
    F : (M, 3) long tensor — faces of all charts, indexing the flattened ``(B·n)`` vertex rows.
    face_chart : (M,) long tensor — chart of each face.
    dC_inv : (M, 2, 2) float64 tensor; w : (M,) float64 tensor — area weights, summing to 1 per chart.
    sizes : (B,) int array — vertex count of each chart.
    mask : (B, n, 1) float64 tensor or None — 0 on pinned vertices (their UV stays the base), 1 elsewhere.
    """

    X: torch.Tensor
    base: torch.Tensor | None
    target: torch.Tensor | None
    F: torch.Tensor
    face_chart: torch.Tensor
    dC_inv: torch.Tensor
    w: torch.Tensor
    sizes: np.ndarray
    mask: torch.Tensor | None = None

    @property
    def B(self):
        return self.X.shape[0]

    @property
    def n(self):
        return self.X.shape[1]


def make_batch(preps, *, residual=True, device="cpu"):
    """Stack :class:`~neuraluv.solver.chart.PreparedChart` objects into one :class:`ChartBatch`.

    Parameters
    ----------
    preps : list of PreparedChart
    residual : bool
        Residual mode: the network's output is added to ``prep.u_start``.
    device : torch.device or str

    Returns
    -------
    ChartBatch
    """
    B = len(preps)
    n = max(len(p.X) for p in preps)
    d = preps[0].X.shape[1]
    X = np.zeros((B, n, d), np.float32)
    U = np.zeros((B, n, 2))
    T = np.zeros((B, n, 2))
    Fs, fc, dci, ws = [], [], [], []
    for c, p in enumerate(preps):
        k = len(p.X)
        X[c, :k] = p.X
        U[c, :k] = p.u_start
        if p.target is not None:
            T[c, :k] = p.target
        Fs.append(np.asarray(p.F, np.int64) + c * n)
        fc.append(np.full(len(p.F), c, np.int64))
        dci.append(p.dC_inv)
        ws.append(p.A / p.A.sum())
    dev = torch.device(device)
    has_target = all(p.target is not None for p in preps)
    mask = None
    if residual and any(getattr(p, "free", None) is not None for p in preps):
        mask = np.ones((B, n, 1))
        for c, p in enumerate(preps):
            if getattr(p, "free", None) is not None:
                mask[c, : len(p.X), 0] = np.asarray(p.free, float)
    return ChartBatch(
        X=torch.as_tensor(X, device=dev),
        base=torch.as_tensor(U, device=dev) if residual else None,
        target=torch.as_tensor(T, device=dev) if (has_target and not residual) else None,
        F=torch.as_tensor(np.concatenate(Fs), device=dev),
        face_chart=torch.as_tensor(np.concatenate(fc), device=dev),
        dC_inv=torch.as_tensor(np.concatenate(dci), device=dev),
        w=torch.as_tensor(np.concatenate(ws), device=dev),
        sizes=np.array([len(p.X) for p in preps]),
        mask=None if mask is None else torch.as_tensor(mask, device=dev),
    )


def subset_batch(batch, keep, *, trim=False):
    """The charts ``keep`` (sorted indices) of a batch, re-indexed; with ``trim``, padded only to the largest
    of them (the vertex rows past it are padding for every kept chart)."""
    keep_t = torch.as_tensor(keep, device=batch.X.device)
    sizes = batch.sizes[np.asarray(keep)]
    n = int(sizes.max()) if (trim and len(sizes)) else batch.n
    remap = torch.full((batch.B,), -1, dtype=torch.long, device=batch.X.device)
    remap[keep_t] = torch.arange(len(keep), device=batch.X.device)
    fmask = remap[batch.face_chart] >= 0
    F = batch.F[fmask]
    old_c = batch.face_chart[fmask]
    new_c = remap[old_c]
    F = F - (old_c * batch.n)[:, None] + (new_c * n)[:, None]
    return ChartBatch(X=batch.X[keep_t, :n], base=None if batch.base is None else batch.base[keep_t, :n],
                      target=None if batch.target is None else batch.target[keep_t, :n], F=F, face_chart=new_c,
                      dC_inv=batch.dC_inv[fmask], w=batch.w[fmask], sizes=sizes,
                      mask=None if batch.mask is None else batch.mask[keep_t, :n])
