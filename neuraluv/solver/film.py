"""Watching a solve: UV snapshots recorded through the solver's callback.

:func:`record_solve` runs :func:`~neuraluv.solver.chart.solve_chart` with a
:class:`SolveRecorder` as its ``callback(event, step, model)``; the recorder
evaluates the chart network on the chart's features at a geometric schedule of
accepted steps (0, 1, 2, 3, 4, 6, 8, …, and the last one) and keeps the UVs,
det J per face, E_SD and the flip count of each snapshot. The film is drawn by
:func:`neuraluv.plot.solve_filmstrip` (matplotlib) and
:func:`neuraluv.plot.plotly_solve_slider` (plotly, with an iteration slider).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from neuraluv.jacobian import jacobians
from neuraluv.metrics import face_metrics

__all__ = ["SolveFilm", "SolveRecorder", "record_solve"]


@dataclass
class SolveFilm:
    """Snapshots of one solve, all on the unit-box chart (``Vn``; E_SD is scale-free).

    Attributes
    ----------
    V : (n,3) float array — the chart normalised to the unit box.
    F : (m,3) int array.
    frames : list of dict ``{"step", "event", "uv" (n,2), "det" (m,), "esd", "flips", "min_det"}``
        of the returned attempt, in order.
    label : str
    """

    V: np.ndarray
    F: np.ndarray
    frames: list = field(default_factory=list)
    label: str = "chart"

    @property
    def steps(self):
        return [f["step"] for f in self.frames]

    def pick(self, n):
        """``n`` frames spread over the film (always the first and the last)."""
        if n >= len(self.frames):
            return list(self.frames)
        idx = np.unique(np.round(np.linspace(0, len(self.frames) - 1, n)).astype(int))
        return [self.frames[i] for i in idx]


class SolveRecorder:
    """A ``solve_chart`` callback that keeps UV snapshots at a geometric schedule of accepted steps.

    Parameters
    ----------
    prep : PreparedChart
        The chart's preparation for the same config (its features ``X``, ``Vn``, frames).
    growth : float
        Ratio between recorded steps (1.3: about 30 snapshots over 2,000 steps).

    Attributes
    ----------
    attempts : list of list of dict
        Frames per attempt (a new attempt starts at each ``"warmup_end"``).
    """

    def __init__(self, prep, growth=1.3):
        import torch

        self.prep = prep
        self.growth = float(growth)
        self.attempts = []
        self._next = 0.0
        self._X = torch.as_tensor(np.asarray(prep.X, np.float32))

    def _snapshot(self, event, step, model):
        import torch

        with torch.no_grad():
            X = self._X.to(next(model.parameters()).device)
            uv = model(X).detach().cpu().numpy().astype(float)
        fm = face_metrics(jacobians(uv, self.prep.F, self.prep.dC_inv))
        det = fm["det"]
        w = self.prep.A / self.prep.A.sum()
        esd = float(w @ fm["sd"]) if np.isfinite(fm["sd"]).all() else float("inf")
        return {"step": int(step), "event": event, "uv": uv, "det": det, "esd": esd,
                "flips": int((det <= 0).sum()), "min_det": float(det.min())}

    def __call__(self, event, step, model):
        if event == "warmup_end":
            self.attempts.append([])
            self._next = 1.0
            self.attempts[-1].append(self._snapshot(event, step, model))
            return
        if not self.attempts:
            self.attempts.append([])
        frames = self.attempts[-1]
        if event == "step":
            if step < self._next:
                return
            while self._next <= step:
                self._next = max(self._next + 1.0, self._next * self.growth)
        elif frames and frames[-1]["step"] == step:  # "end" at a step already recorded
            frames[-1]["event"] = "end"
            return
        frames.append(self._snapshot(event, step, model))


def record_solve(V, F, config="fast", *, seed=0, growth=1.3, label="chart", callback=None, **solve_kw):
    """Solve one chart and record the film of its returned attempt.

    Parameters
    ----------
    V, F : the chart
    config : str or SolverConfig
    seed : int
    growth : float
        See :class:`SolveRecorder`.
    callback : callable, optional
        Another ``callback(event, step, model)`` called at every step as well (e.g. an
        NTK :class:`~neuraluv_paper.ntk.TrajectoryRecorder`).
    **solve_kw
        Passed to :func:`~neuraluv.solver.chart.solve_chart` (``device``, ``deadline``, ...).

    Returns
    -------
    result : ChartResult
        Exactly what ``solve_chart`` returns without the recorder.
    film : SolveFilm

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> res, film = record_solve(*spherical_cap(n_rings=4), "test", device="cpu")
    >>> film.steps[0], film.frames[-1]["event"], res.metrics["flips"], film.frames[-1]["flips"]
    (0, 'end', 0, 0)
    """
    from neuraluv.solver.chart import prepare_chart, solve_chart

    prep = prepare_chart(V, F, config, label=label)
    rec = SolveRecorder(prep, growth=growth)

    def both(event, step, model):
        rec(event, step, model)
        if callback is not None:
            callback(event, step, model)

    res = solve_chart(V, F, config, seed=seed, callback=both, label=label, **solve_kw)
    k = int(getattr(res, "seed", seed)) - int(seed)
    frames = rec.attempts[k] if 0 <= k < len(rec.attempts) else (rec.attempts[-1] if rec.attempts else [])
    return res, SolveFilm(V=prep.Vn, F=np.asarray(prep.F), frames=frames, label=label)
