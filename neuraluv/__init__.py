"""neuraluv: continuous neural reparameterization for fixed-chart UV repair.

The executable companion to *Continuous Neural Reparameterization as a Deep
Geometric Prior for Robust Fixed-Chart UV Repair*. Plain arrays in and out:
``V (n,3)``, ``F (m,3)``, ``UV (n,2)``.

Layers (each imports only the ones above it in this list):

* the geometry core, flat and torch-free: :mod:`~neuraluv.errors`,
  :mod:`~neuraluv.io`, :mod:`~neuraluv.meshfix`, :mod:`~neuraluv.topology`,
  :mod:`~neuraluv.jacobian`, :mod:`~neuraluv.metrics`, :mod:`~neuraluv.spectral`,
  :mod:`~neuraluv.tutte`, :mod:`~neuraluv.relax`, :mod:`~neuraluv.check`,
  :mod:`~neuraluv.datasets`;
* :mod:`neuraluv.layout`: a UV layout over a mesh (its facts, overlaps, validation,
  rigid fits, free space, the packers); :mod:`neuraluv.plot`: every figure;
* :mod:`neuraluv.solver`: the SIREN chart solver (torch);
* :mod:`neuraluv.atlas` (unwrap, atlases, sweeps) and :mod:`neuraluv.repair`
  (``check --uv``, repair of supplied layouts), both clients of :mod:`~neuraluv.layout`;
* :mod:`neuraluv.cli`: the command line.

The paper's reproduction harness (benchmarks, baselines, NTK probes, the claims
checklist) is the separate package :mod:`neuraluv_paper`, a client of this one.

The names below are re-exported lazily: ``import neuraluv`` loads neither
torch nor scipy.
"""
from __future__ import annotations

from neuraluv.lazy import lazy_exports

__version__ = "0.3.0"

#: name -> module that defines it (imported on first access).
_EXPORTS = {
    "NeuralUVError": "errors", "MeshLoadError": "errors", "TopologyError": "errors",
    "load_mesh": "io", "read_obj": "io", "write_obj": "io",
    "local_frames": "jacobian", "jacobians": "jacobian",
    "distortion_metrics": "metrics", "face_metrics": "metrics", "match_area": "metrics",
    "normalize_unit_box": "meshfix", "repair_mesh": "meshfix",
    "chart_features": "spectral", "laplacian": "spectral", "lbo_eigenfunctions": "spectral",
    "is_disk_like": "topology", "split_components": "topology", "topology_scan": "topology",
    "tutte": "tutte",
    "PRESETS": "solver.config", "SolverConfig": "solver.config", "get_config": "solver.config",
    "ChartResult": "solver.result", "solve_chart": "solver.chart", "prepare_chart": "solver.chart",
    "unwrap": "atlas.unwrap", "build_atlas": "atlas.build", "repair_layout": "repair.repair",
    "diagnose_layout": "repair.diagnose",
    "layout_facts": "layout.facts", "validate_layout": "layout.validate",
}

__all__ = sorted(_EXPORTS) + ["__version__"]


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
