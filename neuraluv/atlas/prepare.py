"""Atlas step 1: repair a raw mesh (weld, drop degenerate/duplicate faces, orient, split non-manifold)."""
from __future__ import annotations

import igl
import numpy as np

from neuraluv.io import check_mesh_arrays
from neuraluv.meshfix import repair_mesh
from neuraluv.topology import topology_scan  # noqa: F401  (doctest)

__all__ = ["prepare_mesh"]


def prepare_mesh(V, F, *, min_height=1e-6):
    """Repair a raw mesh for atlas construction.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    min_height : float
        Faces whose smallest height is below ``min_height`` times the bounding-box
        diagonal are removed like degenerate faces (counted in
        ``info["sliver_faces"]``): float32 outputs (GLB) cannot keep them flip-free.

    Returns
    -------
    V : (n',3) float array
    F : (m',3) int array
        Welded, degenerate/duplicate-free, each component consistently
        oriented (majority of the input winding kept), manifold.
    vmap : (n',) int array
        Input vertex of each output vertex (``V_out = V_in[vmap]``).
    info : dict
        ``repair`` (RepairReport counts), ``reoriented_faces``, ``split_vertices``,
        ``sliver_faces``.

    Examples
    --------
    >>> from neuraluv.datasets.generated import flip_windings, unweld
    >>> from neuraluv.datasets import sphere
    >>> V, F = sphere(1)
    >>> V2, F2 = unweld(V, flip_windings(F, 0.3))
    >>> V3, F3, vmap, info = prepare_mesh(V2, F2)
    >>> len(V3) == len(V), topology_scan(V3, F3).oriented
    (True, True)
    """
    V, F = check_mesh_arrays(V, F)
    V1, F1, rep, vmap = repair_mesh(V, F, weld=True)
    info = {"repair": rep.as_dict(), "reoriented_faces": 0, "split_vertices": 0, "removed_after_split": 0}
    if len(F1) == 0:
        return V1, F1, vmap, info
    FF, C = igl.bfs_orient(F1)
    FF = np.asarray(FF, np.int64)
    C = np.asarray(C, np.int64).reshape(-1)
    flipped = ~np.all(FF == F1, axis=1)
    # keep the input's majority winding in each patch
    for c in np.unique(C[flipped]):
        inc = C == c
        if flipped[inc].sum() * 2 > inc.sum():
            FF[inc] = FF[inc][:, [0, 2, 1]]
    info["reoriented_faces"] = int((~np.all(FF == F1, axis=1)).sum())
    SV, SF, SVI = igl.split_nonmanifold(V1, FF)
    SF = np.asarray(SF, np.int64)
    SVI = np.asarray(SVI, np.int64).reshape(-1)
    info["split_vertices"] = int(len(SV) - len(V1))
    V2, F2, rep2, vm2 = repair_mesh(np.asarray(SV, float), SF)
    info["removed_after_split"] = int(rep2.degenerate_faces + rep2.duplicate_faces)
    vmap = vmap[SVI[vm2]]
    # needles thinner than min_height·diag: below what float32 (GLB, GPU UVs) resolves
    info["sliver_faces"] = 0
    if min_height and len(F2):
        P = V2[F2]
        edge = np.linalg.norm(P[:, [1, 2, 0]] - P, axis=2).max(1)
        area2 = np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
        diag = float(np.linalg.norm(V2.max(0) - V2.min(0))) or 1.0
        thin = ~(area2 >= min_height * diag * edge)
        if thin.any() and not thin.all():
            info["sliver_faces"] = int(thin.sum())
            V2, F2, _, vm3 = repair_mesh(V2, F2[~thin])
            vmap = vmap[vm3]
    return V2, F2, vmap, info
