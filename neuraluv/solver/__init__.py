"""The neural chart solver (paper Sec. 3–4, Algorithm 1).

=================  ==========================================================
``config``         :class:`SolverConfig`, :data:`PRESETS` (torch-free)
``device``         device selection, CPU thread control
``siren``          the chart network (SIREN with a residual head), also on stacked flat parameters
``vertex``         the per-vertex control (``param="vertex"``): free UVs, the same objective and checked steps
``energy``         Jacobians in torch, the C² extension, E_SD, barrier, objective
``result``         :class:`ChartResult`, :class:`Stop` (why a solve ended; torch-free)
``batch``          a batch of prepared charts, padded to one vertex count (the engine's input)
``engine``         the batched, validity-checked optimisation loop (Adam, L-BFGS)
``pool``           several batches at once: forked worker processes or threads
``lbfgs``          L-BFGS memory of a batch in compact form
``trace``          the per-round trace of a batch, in preallocated chunks
``chart``          :func:`prepare_chart`, :func:`prepare_charts`, :func:`solve_chart`, :func:`solve_charts`
``film``           UV snapshots of a solve through its callback (the notebooks' film strips)
=================  ==========================================================

The NTK–LBO probes of the chart network (the paper's Table 4) are the harness's
(:mod:`neuraluv_paper.ntk`).

``import neuraluv.solver`` loads only the torch-free configuration; the rest
is imported on first use.
"""
from __future__ import annotations

from neuraluv.lazy import lazy_exports

from neuraluv.solver.config import PRESET_HELP, PRESETS, SolverConfig, get_config

__all__ = ["SolverConfig", "PRESETS", "PRESET_HELP", "get_config", "ChartResult", "PreparedChart", "prepare_chart",
           "prepare_charts", "solve_chart", "solve_charts", "build_network", "resolve_device", "torch_threads", "Stop"]

_LAZY = {
    "ChartResult": "result", "Stop": "result", "PreparedChart": "chart", "prepare_chart": "chart", "solve_chart": "chart",
    "prepare_charts": "chart", "solve_charts": "chart",
    "build_network": "chart", "resolve_device": "device", "torch_threads": "device",
}


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())
