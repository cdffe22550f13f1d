"""libigl baselines: harmonic, LSCM, ARAP and SLIM (the paper's compact-chart rows, libigl 2.6)."""
from __future__ import annotations

import igl
import numpy as np

from neuraluv.metrics import match_area
from neuraluv.relax import slim_relax
from neuraluv.topology import boundary_loop
from neuraluv.tutte import circle_boundary, tutte
from neuraluv_paper.baselines.common import require_disk

__all__ = ["harmonic", "lscm", "arap", "slim"]



def _harmonic_uv(V, F):
    bnd = boundary_loop(F)
    bc = circle_boundary(V, bnd)
    return np.asarray(igl.harmonic(V, F, bnd, bc, 1))


def harmonic(V, F):
    """Harmonic (Tutte with cotangent weights) map with the boundary on a circle.

    Returns
    -------
    UV : (n,2) float array (unit-circle boundary: scale-free)

    Notes
    -----
    Solves ``Δu = 0`` with the cotangent Laplacian and ``u|∂ = circle``
    (Eck et al. 1995); can fold where cotangent weights are negative.
    """
    require_disk(V, F, "harmonic")
    return _harmonic_uv(V, F)


def lscm(V, F):
    """Least-squares conformal map (Lévy et al. 2002) through libigl.

    Two boundary vertices (the loop's first and the one halfway along) are
    pinned at (0,0) and (1,0).

    Returns
    -------
    UV : (n,2) float array (scale-free)

    Notes
    -----
    Minimises ``Σ_t A_t |∂u/∂x + i ∂u/∂y|²`` (the conformal energy
    ``½ Σ_t A_t ‖J_t − R J_t R^T‖²``) subject to the two pins.
    """
    require_disk(V, F, "lscm")
    bnd = boundary_loop(F)
    b = np.array([bnd[0], bnd[len(bnd) // 2]], np.int64)
    bc = np.array([[0.0, 0.0], [1.0, 0.0]])
    uv, _ = igl.lscm(V, F, b, bc)
    return np.asarray(uv)


def arap(V, F, *, max_iter=100):
    """As-rigid-as-possible parameterization (Liu et al. 2008) from the harmonic map.

    Returns
    -------
    UV : (n,2) float array at 3D scale

    Notes
    -----
    Local/global iterations on ``Σ_t A_t ‖J_t − R_t‖²_F`` with ``R_t`` the
    closest rotation; no vertex is pinned (libigl tutorial 503: dynamic
    regularisation). The harmonic start is first rescaled to the 3D area, since
    the dynamic term ties the iterates to the start's scale (on Camel, a
    unit-circle start leaves 40% of the faces flipped, a 3D-scale one 6%).
    """
    require_disk(V, F, "arap")
    start = match_area(V, F, _harmonic_uv(V, F))  # at 3D scale: the dynamics term remembers the start
    data = igl.ARAPData()
    data.max_iter = int(max_iter)
    data.with_dynamics = True  # dynamic regularisation: no pinned vertex needed (tutorial 503)
    b = np.zeros(0, np.int32)
    igl.arap_precomputation(V, F, 2, b, data)
    return np.asarray(igl.arap_solve(np.zeros((0, 2)), data, start))


def slim(V, F, *, iterations=1000):
    """SLIM (Rabinovich et al. 2017) on the symmetric Dirichlet energy, libigl.

    Starts from the uniform Tutte map of :func:`neuraluv.tutte.tutte` (the
    neural solver's start), with no pinned vertex.

    Returns
    -------
    UV : (n,2) float array at 3D scale

    Notes
    -----
    Minimises ``Σ_t A_t (‖J_t‖²_F + ‖J_t⁻¹‖²_F)`` by reweighted local/global
    proxies with a flip-preventing line search.
    """
    require_disk(V, F, "slim")
    return slim_relax(V, F, tutte(V, F), iterations)
