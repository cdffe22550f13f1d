"""Data registry, derived compact charts, packing, and the environment files."""
from pathlib import Path

import numpy as np

from neuraluv.packing import shelf_pack



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
