"""Tutte maps and Laplace–Beltrami features."""
import numpy as np
import pytest

from neuraluv import datasets
from neuraluv.meshfix import face_areas
from neuraluv.metrics import distortion_metrics
from neuraluv.spectral import laplacian
from neuraluv.tutte import boundary_loop, tutte


def obtuse_fan():
    """A wheel whose hub sits near the rim: obtuse angles give negative cotan weights."""
    ang = np.array([0.284, 0.339, 1.796, 2.409, 2.567, 3.238, 5.058, 5.076])
    rim = np.column_stack([np.cos(ang), np.sin(ang), np.zeros(len(ang))])
    V = np.vstack([[[-0.812, 0.899, 0.305]], rim])
    F = np.array([[0, 1 + i, 1 + (i + 1) % len(ang)] for i in range(len(ang))])
    return V, F


CHARTS = ["disk", "cap", "saddle", "bumpy", "glove"]


@pytest.mark.parametrize("name", CHARTS)
def test_tutte_flip_free(name):
    V, F = datasets.procedural(name)
    UV = tutte(V, F)
    m = distortion_metrics(V, F, UV)
    assert m["flips"] == 0 and m["min_det"] > 0
    b = boundary_loop(F)
    r = np.linalg.norm(UV[b], axis=1)
    assert np.allclose(r, r[0])  # boundary on a circle
    assert np.pi * r[0] ** 2 == pytest.approx(face_areas(V, F).sum())  # 3D area


def test_tutte_orientation_follows_winding():
    V, F = datasets.spherical_cap(4)
    assert distortion_metrics(V, F[:, ::-1], tutte(V, F[:, ::-1]))["flips"] == 0


def test_cotangent_weights_can_fold_uniform_cannot():
    V, F = obtuse_fan()
    L, _ = laplacian(V, F)
    assert (L.tocoo().data[L.tocoo().row != L.tocoo().col] < 0).any()  # negative cotan weights exist
    uni = distortion_metrics(V, F, tutte(V, F, weights="uniform"))
    cot = distortion_metrics(V, F, tutte(V, F, weights="cotangent"))
    assert uni["flips"] == 0
    assert cot["flips"] > 0
