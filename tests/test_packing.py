"""Data registry, derived compact charts, packing, and the environment files."""
from pathlib import Path

import numpy as np

from neuraluv.layout.pack import shelf_pack



ROOT = Path(__file__).resolve().parents[1]


def test_shelf_pack_no_overlap_padding():
    rng = np.random.default_rng(0)
    charts = [rng.random((20, 2)) * rng.uniform(0.2, 3, 2) for _ in range(12)]
    res = shelf_pack(charts, padding=4, resolution=512)
    boxes = [(u.min(0), u.max(0)) for u in res.uvs]
    for u in res.uvs:
        assert u.min() >= 0 and u.max() <= 1
    gap = 4 / 512
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            (a0, a1), (b0, b1) = boxes[i], boxes[j]
            sep = max(b0[0] - a1[0], a0[0] - b1[0], b0[1] - a1[1], a0[1] - b1[1])
            assert sep >= gap * 0.999
    assert res.padding_texels >= 4 * 0.999
    # uniform scale: relative chart sizes kept
    s = [(u.max(0) - u.min(0)) / (c.max(0) - c.min(0)) for u, c in zip(res.uvs, charts)]
    assert np.allclose(s, s[0][0])


def test_float32_uvs_keeps_needles_positive_and_moves_nothing_else():
    """Rounding to float32 (what OBJ/GLB carry) must not flip a needle the solver kept positive."""
    from neuraluv.jacobian import signed_areas_2d
    from neuraluv.layout import float32_uvs

    rng = np.random.default_rng(0)
    # a fan of needles around a shared apex far from the origin (float32 steps ~6e-8 there), plus normal triangles
    base = np.array([0.7, 0.3])
    ring = base + 1e-5 * np.column_stack([np.linspace(0, 1, 9), 1e-4 * np.sin(np.linspace(0, 3, 9)) + 1e-9])
    apex = base + np.array([5e-6, -2e-10])
    UV = np.vstack([apex, ring, rng.uniform(0.1, 0.2, (30, 2))])
    F = [[0, i + 2, i + 1] for i in range(1, 8)] + [[10 + 3 * k, 11 + 3 * k, 12 + 3 * k] for k in range(10)]
    F = np.array(F)
    F[signed_areas_2d(UV, F) < 0] = F[signed_areas_2d(UV, F) < 0][:, [0, 2, 1]]  # every face positive in float64
    assert (signed_areas_2d(UV, F) > 0).all()
    plain = UV.astype(np.float32).astype(float)
    assert (signed_areas_2d(plain, F) <= 0).any()  # plain rounding flattens or flips some needles
    U = float32_uvs(UV, F)
    assert (signed_areas_2d(U, F) > 0).all() and (U == U.astype(np.float32)).all()
    moved = np.flatnonzero((U != plain).any(1))
    assert set(moved) <= set(np.unique(F[:7]))  # only needle corners move...
    assert np.abs(U - UV).max() < 1e-5  # ...by float32 steps, not texels
