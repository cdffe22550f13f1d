"""Limited-memory BFGS for a batch of chart networks, in compact form (the ``fast`` preset's optimiser).

:class:`LBFGSMemory` keeps the curvature pairs of every chart of a batch in one
ring buffer and applies the inverse-Hessian approximation ``H g`` to all charts
at once; :func:`memory_length` picks the buffer's length for a batch. The
line search and the validity checks of each trial live in
:mod:`neuraluv.solver.engine`, which shares them with Adam.
"""
from __future__ import annotations

import torch

__all__ = ["LBFGSMemory", "memory_length", "row_dot"]


def memory_length(cfg, n):
    """Number of curvature pairs to keep for a batch padded to ``n`` vertices: ``cfg.history``, fewer for tiny charts.

    Parameters
    ----------
    cfg : SolverConfig
    n : int
        Vertex count of the batch's largest chart.

    Returns
    -------
    int
        ``min(cfg.history, max(3, n // 8))``: a pair per 8 vertices.

    Notes
    -----
    The memory costs ``O(m·P)`` per chart and step whatever the chart's size,
    the network ``O(n·P)``: for charts of a few dozen vertices a full memory
    would cost more than the network itself. The pairs are read twice per
    step from memory (tens of megabytes for a batch of small charts), so the
    step's time follows ``m`` closely. One pair per 8 vertices instead of per
    4 (issue 28), on the solver batches of the atlases of cow, spot and
    fertility, one thread: solver time −25% on cow's batch of 47 charts of
    ≤ 53 vertices, −15% to −17% over every batch of spot and fertility, for
    0.3–2.4% more steps in all and the same mean E_SD to 1e-4.

    Examples
    --------
    >>> from neuraluv.solver.config import get_config
    >>> memory_length(get_config("fast"), 40), memory_length(get_config("fast"), 10_000)
    (5, 30)
    """
    return int(min(cfg.history, max(3, n // 8)))


def row_dot(a, b):
    """Row-wise dot products of two ``(B, P)`` tensors, ``(B,)`` in float64.

    Examples
    --------
    >>> row_dot(torch.tensor([[1.0, 2.0], [3.0, 4.0]]), torch.tensor([[1.0, 1.0], [0.0, 1.0]]))
    tensor([3., 4.], dtype=torch.float64)
    """
    return torch.linalg.vecdot(a, b).to(torch.float64)


def _rowdots(A, x):
    """``A[b] @ x[b]`` for every chart: ``(B, k, P)``, ``(B, P)`` → ``(B, k)``.

    Written as ``xᵀ Aᵀ`` (a row times a transposed matrix), which the batched
    GEMM runs an order of magnitude faster on the CPU than ``A x`` for these shapes.
    """
    return torch.bmm(x[:, None, :], A.transpose(1, 2))[:, 0]


class LBFGSMemory:
    """The curvature pairs of every chart, and ``H g`` in the compact form (Byrd, Nocedal & Schnabel 1994).

    Parameters
    ----------
    B : int
        Charts in the batch.
    P : int
        Parameters per chart.
    m : int
        Slots of the ring buffer (at least 1).
    dtype, device
        Of the stored pairs (the parameters').

    Attributes
    ----------
    SY_vecs : (B, 2m, P) tensor — rows ``0..m-1`` the steps ``s_i``, rows ``m..2m-1`` the gradient changes ``y_i``.
    SY, YY : (B, m, m) float64 tensors — ``s_i · y_j`` and ``y_i · y_j``.
    valid : (B, m) bool tensor — slots holding a pair.
    gamma : (B,) float64 tensor — ``s·y / y·y`` of the newest pair (0: none yet).

    Notes
    -----
    ``H g = γ g + S p₁ + γ Y p₂`` with ``[p₁; p₂] = M [Sᵀg; γYᵀg]`` and the
    ``2m × 2m`` middle matrix built from ``R = triu(SᵀY)``, ``D = diag(SᵀY)`` and
    ``YᵀY``: two batched products with the stored pairs per accepted step instead of
    the two-loop recursion's ``4m`` small vector operations — one in :meth:`push`, which
    reads the new pair's dots and, with ``g_next``, the next ``Sᵀg, Yᵀg`` in the same pass,
    and one in :meth:`apply` to form ``S p₁ + Y p₂``. The stored pairs of a batch of small
    charts are tens of megabytes (47 charts × 26 rows × 9,730 parameters on cow's atlas, a
    pair per 4 vertices): one pass over them took 3.3 ms there, the 47 networks' forward and
    backward pass 11.5 ms (one thread). One ring buffer of ``m`` slots serves all charts; a
    chart that did not move this round stores a zero pair, which contributes nothing.

    Examples
    --------
    One pair of a quadratic with Hessian ``2I`` (``y = 2s``): ``H`` is ``I/2``.

    >>> mem = LBFGSMemory(1, 3, 5, dtype=torch.float64, device="cpu")
    >>> s = torch.tensor([[1.0, 0.0, 0.0]], dtype=torch.float64)
    >>> mem.push(s, 2 * s, torch.tensor([True]))
    >>> mem.apply(torch.tensor([[2.0, 4.0, 0.0]], dtype=torch.float64))
    tensor([[1., 2., 0.]], dtype=torch.float64)
    """

    def __init__(self, B, P, m, *, dtype, device):
        self.m = max(int(m), 1)
        self.SY_vecs = torch.zeros(B, 2 * self.m, P, dtype=dtype, device=device)   # rows 0..m-1: s_i, m..2m-1: y_i
        self.SY = torch.zeros(B, self.m, self.m, dtype=torch.float64, device=device)   # s_i · y_j
        self.YY = torch.zeros_like(self.SY)                                            # y_i · y_j
        self.valid = torch.zeros(B, self.m, dtype=torch.bool, device=device)
        self.gamma = torch.zeros(B, dtype=torch.float64, device=device)                # 0: no pair yet
        self.ptr = 0
        self._ab = None    # [Sᵀg; Yᵀg] read by the last push, for its g_next

    def push(self, s, y, acc, g_next=None):
        """Store the pair ``(s, y)`` (``(B, P)`` each) of the charts in ``acc (B,)`` with a positive curvature ``s·y``.

        With ``g_next (B, P)``, the gradient at the charts' new point, the same pass over
        the stored pairs also reads ``[Sᵀg; Yᵀg]`` of the updated memory for the next
        :meth:`apply` with ``after_push=True`` (one pass over the pairs per step instead of two).
        """
        m, k = self.m, self.ptr
        z = torch.zeros((), dtype=s.dtype, device=s.device)
        self.SY_vecs[:, k] = 0
        self.SY_vecs[:, m + k] = 0
        rows = (s, y) if g_next is None else (s, y, g_next)
        dots = torch.bmm(torch.stack(rows, 1), self.SY_vecs.transpose(1, 2)).to(torch.float64)  # (B, r, 2m)
        ss = row_dot(s, s)
        sy = row_dot(s, y)
        yy = row_dot(y, y)
        good = acc & (sy > 1e-10 * torch.sqrt(yy * ss))
        g1 = good[:, None].to(torch.float64)
        self.SY_vecs[:, k] = torch.where(good[:, None], s, z)
        self.SY_vecs[:, m + k] = torch.where(good[:, None], y, z)
        self.SY[:, k, :] = dots[:, 0, m:] * g1                                  # s · y_j
        self.SY[:, :, k] = dots[:, 1, :m] * g1                                  # s_j · y
        self.SY[:, k, k] = sy * g1[:, 0]
        self.YY[:, k, :] = dots[:, 1, m:] * g1                                  # y · y_j
        self.YY[:, :, k] = dots[:, 1, m:] * g1
        self.YY[:, k, k] = yy * g1[:, 0]
        self.valid[:, k] = good
        self.gamma = torch.where(good, sy / yy.clamp_min(1e-300), self.gamma)
        self.ptr = (k + 1) % m
        self._ab = None
        if g_next is not None:
            ab = dots[:, 2].clone()
            ab[:, k] = row_dot(s, g_next) * g1[:, 0]
            ab[:, m + k] = row_dot(y, g_next) * g1[:, 0]
            self._ab = ab

    def select(self, keep):
        """Keep only the charts ``keep`` (the batch was compacted)."""
        for k in ("SY_vecs", "SY", "YY", "valid", "gamma"):
            setattr(self, k, getattr(self, k)[keep])
        if self._ab is not None:
            self._ab = self._ab[keep]

    def reset(self, mask):
        """Forget every pair of the charts in ``mask (B,)``."""
        self.SY_vecs[mask] = 0
        self.SY[mask] = 0
        self.YY[mask] = 0
        self.valid[mask] = False
        self.gamma = torch.where(mask, torch.zeros_like(self.gamma), self.gamma)
        if self._ab is not None:
            self._ab[mask] = 0

    def apply(self, g, after_push=False):
        """``H g`` for every chart (``(B, P)``); charts without pairs get ``γ g`` with γ = 0.

        ``after_push=True`` reuses the dots the last :meth:`push` read with its ``g_next``:
        exact for the charts whose ``g`` is that ``g_next`` (those that accepted that step),
        not for the others.
        """
        m = self.m
        o = torch.as_tensor([(self.ptr + j) % m for j in range(m)], device=g.device)  # oldest first
        inv = torch.empty_like(o)
        inv[o] = torch.arange(m, device=g.device)
        gam = self.gamma[:, None]
        ab = self._ab if (after_push and self._ab is not None) else _rowdots(self.SY_vecs, g).to(torch.float64)
        a = ab[:, :m][:, o]
        b = gam * ab[:, m:][:, o]
        SY = self.SY[:, o][:, :, o]
        R = torch.triu(SY) + torch.diag_embed((~self.valid[:, o]).to(SY.dtype))        # empty slots: identity rows
        u = torch.linalg.solve_triangular(R, a[:, :, None], upper=True)[:, :, 0]
        t = torch.diagonal(SY, dim1=1, dim2=2) * u + gam * torch.bmm(self.YY[:, o][:, :, o], u[:, :, None])[:, :, 0] - b
        p1 = torch.linalg.solve_triangular(R.transpose(1, 2), t[:, :, None], upper=False)[:, :, 0]
        p = torch.cat([p1[:, inv], (-gam * u)[:, inv]], 1).to(g.dtype)                 # back to slot order
        return gam.to(g.dtype) * g + torch.bmm(p[:, None, :], self.SY_vecs)[:, 0]
