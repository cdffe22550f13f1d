"""Topology scan, the disk-like test and its reasons, repair."""
import numpy as np

from neuraluv.meshfix import normalize_unit_box, repair_mesh


def test_repair_counts():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [9, 9, 9], [0, 0, 0]])
    F = np.array([[0, 1, 2], [0, 1, 3], [2, 1, 0], [0, 0, 1], [5, 1, 2]])
    V2, F2, rep, vmap = repair_mesh(V, F)
    assert rep.degenerate_faces == 2  # repeated corner + collinear (0,1,3)
    assert rep.duplicate_faces == 1
    assert rep.unreferenced_vertices == 2  # vertex 3 (only in a degenerate face) and 4
    assert len(F2) == 2
    V3, F3, rep3, _ = repair_mesh(V, F, weld=True)
    assert rep3.merged_vertices == 1 and len(F3) == 1


def test_normalize_unit_box():
    V = np.random.default_rng(0).normal(size=(50, 3)) * 7 + 3
    Vn, c, s = normalize_unit_box(V)
    assert np.isclose((Vn.max(0) - Vn.min(0)).max(), 1.0)
    assert np.allclose(Vn * s + c, V)
