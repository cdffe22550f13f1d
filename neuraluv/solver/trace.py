"""The per-round trace of a batch of chart optimisations, in preallocated chunks."""
from __future__ import annotations

import numpy as np
import torch

__all__ = ["TraceRecorder"]


class TraceRecorder:
    """Per-round values of every chart, in preallocated chunks (one row per round, one column per chart).

    Writing into buffers allocated once per 1,024 rounds, instead of keeping
    small per-round tensors alive, keeps the heap unfragmented: large activations
    freed every round can go back to the system (RSS stays flat).

    Parameters
    ----------
    B : int
        Charts of the batch (the columns; a chart keeps its column after others leave the batch).
    device : torch.device or str

    Examples
    --------
    >>> rec = TraceRecorder(2, "cpu")
    >>> v = lambda *x: torch.tensor(x)
    >>> rec.add(torch.arange(2), v(True, False), v(3.0, 5.0), v(4.5, 6.0), v(0.5, 0.25), v(0, 0), v(0, 1), v(0.5, 0.5), 0.1)
    >>> rec.traces()[0]["esd"], rec.traces()[1]["iter"]
    ([4.5], [])
    """

    FIELDS = (("acc", torch.bool), ("loss", torch.float64), ("esd", torch.float64), ("min_det", torch.float64),
              ("flips", torch.long), ("rejected", torch.long), ("lr", torch.float64))
    CHUNK = 1024

    def __init__(self, B, device):
        self.B, self.device = B, device
        self.chunks, self.times, self.r = [], [], 0

    def add(self, rows, acc, loss, esd, min_det, flips, rejected, lr, t):
        """One round: ``rows (b,)`` the columns of the running charts, the other tensors ``(b,)``, ``t`` seconds."""
        k = self.r % self.CHUNK
        if k == 0:
            self.chunks.append({n: torch.zeros(self.CHUNK, self.B, dtype=dt, device=self.device) for n, dt in self.FIELDS})
        c = self.chunks[-1]
        full = len(rows) == self.B   # no chart has left the batch: rows are 0..B-1
        for (n, _), v in zip(self.FIELDS, (acc, loss, esd, min_det, flips, rejected, lr)):
            if full:
                c[n][k].copy_(v)
            else:
                c[n][k, rows] = v.to(c[n].dtype)
        self.times.append(t)
        self.r += 1

    def traces(self):
        """One dict of lists per chart: the rounds where it accepted a step."""
        keys = ("iter", "loss", "esd", "min_det", "flips", "rejected", "lr", "time")
        if not self.r:
            return [{k: [] for k in keys} for _ in range(self.B)]
        cols = {n: torch.cat([c[n] for c in self.chunks])[: self.r].cpu().numpy() for n, _ in self.FIELDS}
        t = np.asarray(self.times)
        out = []
        for b in range(self.B):
            sel = np.flatnonzero(cols["acc"][:, b])
            out.append({"iter": list(range(1, len(sel) + 1)), "loss": cols["loss"][sel, b].tolist(),
                        "esd": cols["esd"][sel, b].tolist(), "min_det": cols["min_det"][sel, b].tolist(),
                        "flips": cols["flips"][sel, b].astype(int).tolist(),
                        "rejected": cols["rejected"][sel, b].astype(int).tolist(), "lr": cols["lr"][sel, b].tolist(),
                        "time": t[sel].tolist()})
        return out
