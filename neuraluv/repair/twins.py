"""Twin layers: the stacked halves of a mirror modifier that share their ``vt`` rows, read off a layout.

Under the ``texture`` purpose a fold on rows two stacked halves share folds both halves at once;
:func:`~neuraluv.repair.shells.repair_twin_layers` repairs it in a half's layer (:func:`twin_layers`), and the
twins follow, mirrored.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from neuraluv.jacobian import signed_areas_2d
from neuraluv.layout.facts import holds_more
from neuraluv.meshfix import face_areas
from neuraluv.repair.region import face_dets_of
from neuraluv.topology import undirected_edges

__all__ = ["twin_layers", "layer_sign", "twin_layers_hold", "twins_follow"]


def twin_layers(F, FUV, faces):
    """The layers of an island whose stacked halves share ``vt`` rows: its faces joined through edges shared in
    3D *and* in UV, never a face to its twin (a face with the same three ``vt`` rows).

    A mirror modifier's halves that share their rows are one island, and a fold on the shared rows folds both
    halves at once: each half's folded faces then lie, by orientation, in the other half's sheet. A half is
    still what the surface joins: its faces meet along 3D edges, and where the halves meet (the mirror plane)
    the face across the edge is the twin.

    Parameters
    ----------
    F, FUV : (m,3) int arrays
    faces : (k,) int array, the island's faces

    Returns
    -------
    layer : (k,) int array, the layer of each face of ``faces``
    twin : (k,) int array, per face the index (into ``faces``) of a twin, -1 where none
    """
    faces = np.asarray(faces, np.int64)
    key = (faces.tobytes(), np.asarray(F)[faces].tobytes(), np.asarray(FUV)[faces].tobytes())
    if key not in _LAYERS:  # read once per island and texture indices: every fold of the island asks again
        if len(_LAYERS) >= 8:
            _LAYERS.pop(next(iter(_LAYERS)))
        _LAYERS[key] = tuple(a.setflags(write=False) or a for a in _twin_layers(F, FUV, faces))
    return _LAYERS[key]


_LAYERS = {}  # twin_layers' last results, by (faces, their F rows, their FUV rows)


def _twin_layers(F, FUV, faces):
    k = len(faces)
    T = np.sort(np.asarray(FUV)[faces], 1)
    _, group = np.unique(T, axis=0, return_inverse=True)
    group = group.reshape(-1)
    twin = -np.ones(k, np.int64)
    order = np.argsort(group, kind="stable")
    pair = group[order[1:]] == group[order[:-1]]
    twin[order[1:][pair]], twin[order[:-1][pair]] = order[:-1][pair], order[1:][pair]
    e3, eu = undirected_edges(np.asarray(F)[faces])[1], undirected_edges(np.asarray(FUV)[faces])[1]
    _, key = np.unique(np.c_[e3, eu], axis=0, return_inverse=True)
    key = key.reshape(-1)
    fid = np.tile(np.arange(k), 3)
    order = np.argsort(key, kind="stable")
    same = key[order[1:]] == key[order[:-1]]
    a, b = fid[order[:-1][same]], fid[order[1:][same]]
    keep = group[a] != group[b]
    A = sp.coo_matrix((np.ones(int(keep.sum())), (a[keep], b[keep])), shape=(k, k))
    return connected_components(A, directed=False)[1], twin


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
    """Whether every face of ``cluster`` is oriented like its layer (:func:`twin_layers`): a fold a twin-layer
    repair already undid (seen from the other half's shell, its faces are the repaired faces' twins)."""
    island = np.sort(np.asarray(island, np.int64))
    layer, _ = twin_layers(F, FUV, island)
    at = np.searchsorted(island, cluster)
    for lay in np.unique(layer[at]):
        sign = np.array([layer_sign(Vn, F, UV, FUV, island[layer == lay]), 1.0])
        if not (face_dets_of(Vn, F, UV * sign, FUV, cluster[layer[at] == lay]) > 0).all():
            return False
    return True
