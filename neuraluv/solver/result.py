"""The result of one chart solve (torch-free: baselines, atlas and reports read it without the solver)."""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

__all__ = ["ChartResult", "Stop"]


class Stop(IntEnum):
    """Why a chart's optimisation ended (the engine keeps the codes in a tensor, one per chart).

    ``BUDGET``: it took ``iterations`` accepted steps; ``EARLY_STOP``: its best
    E_SD improved by less than ``tol`` over ``patience`` accepted steps, or came
    within ``tol`` of an isometry's (4), below which no step can gain ``tol``;
    ``STALLED``: more than ``max_backtracks`` halvings in a row were all
    rejected; ``TIME``: the deadline passed; ``REACHED``: the caller's test of
    its best map passed (``until`` of :func:`~neuraluv.solver.engine.optimise`).
    ``RUNNING`` while it runs.
    Reports and :attr:`ChartResult.stop` hold the :attr:`label`.

    Examples
    --------
    >>> Stop.EARLY_STOP.label, Stop.from_label("stalled"), int(Stop.TIME)
    ('early_stop', <Stop.STALLED: 2>, 3)
    """

    RUNNING = -1
    BUDGET = 0
    EARLY_STOP = 1
    STALLED = 2
    TIME = 3
    REACHED = 4

    @property
    def label(self):
        """The name written in results and reports (``"budget"``, ``"early_stop"``, ``"stalled"``, ``"time"``,
        ``"reached"``)."""
        return self.name.lower()

    @classmethod
    def from_label(cls, label):
        """The member whose :attr:`label` is ``label``."""
        return cls[label.upper()]


@dataclass
class ChartResult:
    """Result of solving one chart.

    Attributes
    ----------
    uv : (n,2) float array, at the chart's 3D scale.
    metrics : dict from :func:`neuraluv.metrics.distortion_metrics`.
    status : ``"neural"`` or ``"fallback"``.
    reason : why a fallback was used (empty for neural charts).
    trace : per-iteration lists: ``iter, loss, esd, min_det, flips, rejected, lr, time``
        (``rejected`` is a running total).
    time : wall seconds for the whole solve (features, Tutte, attempts).
    seed : seed of the returned attempt; attempts : number of attempts made.
    stop : why the returned attempt stopped: the :attr:`Stop.label` of a :class:`Stop`
        (``"budget"``, ``"early_stop"``, ``"stalled"``, ``"time"``, ``"reached"``; ``Stop.from_label`` reads it back).
    start : the valid start the residual network was attached to (``"tutte"``,
        or ``"tutte+slimN"`` after N SLIM iterations: ``start_relax``, ``start_slim``).
    attempt_metrics : metrics of every neural attempt, in order (ablations read
        the invalid ones here even when a fallback map is returned).
    neural_uv : (n,2) float array, the best neural attempt (equals ``uv`` for
        neural charts; the invalid map for fallbacks).
    attempt_log : one dict per attempt: ``seed``, ``lr`` (the retry schedule
        halves it), ``stop``, ``iterations``, ``rejected``, ``valid``, ``flips``.
    theta : (P,) tensor, the returned attempt's final parameters (``solve_charts(theta0=...)``
        continues the solve from them).
    """

    uv: np.ndarray
    metrics: dict
    status: str
    reason: str = ""
    trace: dict = field(default_factory=dict, repr=False)
    time: float = 0.0
    seed: int = 0
    attempts: int = 1
    stop: str = ""
    config: dict = field(default_factory=dict, repr=False)
    network: object = field(default=None, repr=False)
    start: str = "tutte"
    attempt_metrics: list = field(default_factory=list, repr=False)
    neural_uv: np.ndarray = field(default=None, repr=False)
    attempt_log: list = field(default_factory=list, repr=False)
    theta: object = field(default=None, repr=False)

    @property
    def valid(self):
        return bool(self.metrics.get("valid", False))

    def summary(self):
        """JSON-friendly dict (no arrays)."""
        return {
            "status": self.status,
            "reason": self.reason,
            "metrics": self.metrics,
            "time": self.time,
            "seed": self.seed,
            "attempts": self.attempts,
            "stop": self.stop,
            "start": self.start,
            "iterations": len(self.trace.get("iter", [])),
            "rejected_steps": int(self.trace["rejected"][-1]) if self.trace.get("rejected") else 0,
        }
