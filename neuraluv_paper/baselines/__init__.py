"""Classical baselines behind one signature, :func:`run_baseline` (see :mod:`neuraluv_paper.baselines.methods`).

=================  ==========================================================
``methods``        :class:`BaselineResult`, :data:`METHODS`, :func:`run_baseline`
``libigl``         harmonic, LSCM, ARAP, SLIM (libigl)
``bff``            Boundary First Flattening (our scipy implementation)
``external``       xatlas, Blender (``bpy``), OptCuts, the BFF binary
``common``         failure kinds, chart orientation, loop-UV welding
=================  ==========================================================
"""
from neuraluv_paper.baselines.common import InitFail, Unavailable, weld_corners
from neuraluv_paper.baselines.external import bff_binary, blender_python, optcuts_binary
from neuraluv_paper.baselines.methods import (
                                              METHODS,
                                              OK_STATUSES,
                                              SCALE_FREE,
                                              BaselineResult,
                                              empty_metrics,
                                              run_baseline,
)

__all__ = ["METHODS", "SCALE_FREE", "OK_STATUSES", "BaselineResult", "run_baseline", "empty_metrics", "InitFail",
           "Unavailable", "weld_corners", "blender_python", "optcuts_binary", "bff_binary"]
