"""Hand-computed Jacobians and metrics on single triangles, plus invariants."""
import numpy as np
import pytest
import torch

from neuraluv.jacobian import jacobians, local_frames
from neuraluv.solver.energy import jacobians_torch


def test_local_frame_isometric(tri):
    V = np.array([[1.0, 2.0, 3.0], [1.0, 5.0, 3.0], [1.0, 2.0, 7.0]])  # legs 3 and 4 in the y-z plane
    dCi, A = local_frames(V, [[0, 1, 2]])
    assert A[0] == pytest.approx(6.0)
    dC = np.linalg.inv(dCi[0])
    assert np.linalg.det(dC) == pytest.approx(2 * 6.0)
    assert np.linalg.norm(dC[:, 0]) == pytest.approx(3.0)
    assert np.linalg.norm(dC[:, 1]) == pytest.approx(4.0)


def test_torch_matches_numpy():
    rng = np.random.default_rng(0)
    V = rng.normal(size=(10, 3))
    F = np.array([[0, 1, 2], [3, 4, 5], [6, 7, 8], [1, 5, 9]])
    UV = rng.normal(size=(10, 2))
    dCi, _ = local_frames(V, F)
    Jn = jacobians(UV, F, dCi)
    Jt = jacobians_torch(torch.tensor(UV), torch.tensor(F), torch.tensor(dCi)).numpy()
    assert np.allclose(Jn, Jt)
