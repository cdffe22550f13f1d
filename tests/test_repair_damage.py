"""Added damage on texture layouts that the authored-asset bench left unfixed (issue 27), as small procedural cases.

Each test is the smallest layout with the cause found on a real asset: a vertex flung across a small island
(tube.obj, vertex noise), ...
"""
import numpy as np

from neuraluv.layout.facts import layout_facts
from neuraluv.layout.purpose import layout_intent
from neuraluv.repair.repair import repair_layout


def grid(nx=6, ny=2):
    """A flat ``nx`` × ``ny`` quad grid split into triangles: ``V (n,3), F (m,3)``."""
    x, y = np.meshgrid(np.arange(nx + 1.0), np.arange(ny + 1.0))
    V = np.c_[x.ravel(), y.ravel(), 0 * x.ravel()]
    w = nx + 1
    q = np.array([[i + w * j, i + 1 + w * j, i + 1 + w * (j + 1), i + w * (j + 1)] for j in range(ny) for i in range(nx)])
    return V, np.r_[q[:, [0, 1, 2]], q[:, [0, 2, 3]]]


def test_a_vertex_flung_across_a_small_island_is_a_fold_not_a_mirrored_island():
    # one boundary vertex thrown far past the island: one of its two faces reverses and covers more UV area than
    # the 22 faces it folds over; by UV area alone the island looked mirrored and its 22 faces the folds (the
    # repair turned the whole island over). Its 3D area says which orientation holds the surface.
    V, F = grid()
    UV = V[:, :2] / 20 + 0.3
    bad = UV.copy()
    bad[3] = [0.47, 2.0]
    f = layout_facts(V, F, bad, F)
    it = layout_intent(f)
    assert -f.signed_uv[f.det < 0].sum() > f.signed_uv[f.det > 0].sum()  # the reversed face holds more UV area
    assert not f.mirrored[0]
    assert set(np.flatnonzero(it.fold)) == set(np.flatnonzero(f.det < 0))
    res = repair_layout(V, F, bad, F, purpose="texture", device="cpu")
    assert res.after.validation["valid"]
    assert res.changed_faces.sum() <= 3  # the flung vertex's faces only
