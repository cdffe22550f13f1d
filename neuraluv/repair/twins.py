"""Twin layers in a repair: the stacked halves of a mirror modifier that share their ``vt`` rows.

Under the ``texture`` purpose a fold on rows two stacked halves share folds both halves at once;
:func:`~neuraluv.repair.shells.repair_twin_layers` repairs it in a half's layer
(:func:`~neuraluv.layout.purpose.twin_layers`), and the twins follow, mirrored.
"""
from __future__ import annotations

import numpy as np

from neuraluv.jacobian import signed_areas_2d
from neuraluv.layout.facts import holds_more
from neuraluv.layout.purpose import twin_layers
from neuraluv.meshfix import face_areas
from neuraluv.repair.region import face_dets_of, mended

__all__ = ["layer_sign", "twin_layers_hold", "twins_follow"]


def twins_follow(FUV_old, FUV_new, island, mine, twin):
    """``FUV_new`` with every twin of a face of the layer (``mine``, over ``island``) on its face's new rows."""
    FUV = FUV_new.copy()
    for k in np.flatnonzero(~mine & (twin >= 0)):
        t = twin[k]
        if mine[t]:
            new = dict(zip(FUV_old[island[t]].tolist(), FUV_new[island[t]].tolist()))
            FUV[island[k]] = [new[r] for r in FUV_old[island[k]].tolist()]
    return FUV


def layer_sign(Vn, F, UV, FUV, faces):
    """The orientation of a layer (or any face set): -1.0 when its reversed faces hold more of it
    (:func:`~neuraluv.layout.facts.holds_more`), else 1.0."""
    pos = face_dets_of(Vn, F, UV, FUV, faces) > 0
    a2, a3 = np.abs(signed_areas_2d(UV, FUV[faces])), face_areas(Vn, F[faces])
    return -1.0 if holds_more(a2[~pos].sum(), a2[pos].sum(), a3[~pos].sum(), a3[pos].sum()) else 1.0


def twin_layers_hold(Vn, F, UV, FUV, island, cluster):
    """Whether every face of ``cluster`` is oriented like its layer (:func:`~neuraluv.layout.purpose.twin_layers`):
    a fold a twin-layer repair already undid (seen from the other half's shell, its faces are the repaired faces'
    twins)."""
    island = np.sort(np.asarray(island, np.int64))
    layer, _ = twin_layers(F, FUV, island)
    at = np.searchsorted(island, cluster)
    for lay in np.unique(layer[at]):
        sign = np.array([layer_sign(Vn, F, UV, FUV, island[layer == lay]), 1.0])
        if not mended(Vn, F, UV * sign, FUV, cluster[layer[at] == lay]).all():
            return False
    return True
