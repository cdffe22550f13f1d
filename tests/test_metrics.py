"""Hand-computed Jacobians and metrics on single triangles, plus invariants."""
import numpy as np
import pytest

from neuraluv.jacobian import jacobians, local_frames
from neuraluv.metrics import distortion_metrics, face_metrics, match_area


def rot(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


@pytest.mark.parametrize("theta", [0.0, 0.3, 2.0])
def test_isometry_gives_esd_4(tri, theta):
    V, F = tri
    UV = V[:, :2] @ rot(theta).T + [5.0, -2.0]
    m = distortion_metrics(V, F, UV)
    assert m["esd"] == pytest.approx(4.0)
    assert m["conformal"] == pytest.approx(1.0)
    assert m["area"] == pytest.approx(0.0, abs=1e-12)
    assert m["flips"] == 0 and m["valid"]


@pytest.mark.parametrize("s", [0.5, 2.0, 3.7])
def test_uniform_scale_esd(tri, s):
    V, F = tri
    m = distortion_metrics(V, F, s * V[:, :2])
    assert m["esd"] == pytest.approx(2 * (s**2 + s**-2))
    assert m["area"] == pytest.approx(abs(np.log(s**2)))
    assert m["min_det"] == pytest.approx(s**2)


def test_anisotropic_stretch(tri):
    V, F = tri
    UV = V[:, :2] * [3.0, 1.0]
    J = jacobians(UV, F, local_frames(V, F)[0])[0]
    assert np.allclose(J, np.diag([3.0, 1.0]))
    fm = face_metrics(J[None])
    assert fm["conformal"][0] == pytest.approx(3.0)
    assert fm["sd"][0] == pytest.approx(9 + 1 + 1 / 9 + 1)


def test_mirror_is_flip_and_degenerate_is_invalid(tri):
    V, F = tri
    m = distortion_metrics(V, F, V[:, [1, 0]])
    assert m["flips"] == 1 and m["flip_percent"] == 100.0 and m["min_det"] < 0 and not m["valid"]
    m0 = distortion_metrics(V, F, np.zeros((3, 2)))
    assert m0["flips"] == 1 and np.isinf(m0["esd"]) and not m0["valid"]


def test_match_area_and_rigid_invariance():
    from neuraluv.datasets import spherical_cap
    from neuraluv.tutte import tutte

    V, F = spherical_cap(5)
    UV = tutte(V, F)
    m1 = distortion_metrics(V, F, match_area(V, F, UV))
    m2 = distortion_metrics(V, F, match_area(V, F, 7.0 * UV @ rot(1.0).T))
    assert m1["esd"] == pytest.approx(m2["esd"], rel=1e-9)
    # rotating the 3D input changes nothing
    Q, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))
    Q *= np.sign(np.linalg.det(Q))
    assert distortion_metrics(V @ Q.T, F, UV)["esd"] == pytest.approx(distortion_metrics(V, F, UV)["esd"], rel=1e-9)
