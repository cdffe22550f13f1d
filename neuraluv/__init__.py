"""neuraluv: continuous neural reparameterization for fixed-chart UV repair.

The executable companion to *Continuous Neural Reparameterization as a Deep
Geometric Prior for Robust Fixed-Chart UV Repair*. Plain arrays in and out:
``V (n,3)``, ``F (m,3)``, ``UV (n,2)``.
"""
from .errors import MeshLoadError, NeuralUVError, TopologyError
from .io import load_mesh, read_obj, write_obj
from .jacobian import jacobians, jacobians_torch, local_frames
from .metrics import distortion_metrics, face_metrics, match_area
from .repair import normalize_unit_box, repair_mesh
from .solver import PRESETS, ChartResult, SolverConfig, get_config, solve_chart
from .spectral import chart_features, laplacian, lbo_eigenfunctions
from .topology import is_disk_like, split_components, topology_scan
from .tutte import tutte

__version__ = "0.1.0"
