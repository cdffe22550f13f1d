"""Islands made by a planar projection (a side projection like the Khronos Duck's, "project from view"): the
projection's own reversals — the far side stacked on the near side, concave parts folded back, slivers at the
silhouette — are intent; a face against the projection's orientation is a fold, wherever it lies (issue 27).
"""
import numpy as np
import trimesh

from neuraluv.layout.facts import layout_facts
from neuraluv.layout.projection import projection_axes, projection_signs
from neuraluv.layout.purpose import layout_intent
from neuraluv.repair.diagnose import diagnose_layout
from neuraluv.repair.repair import repair_layout
from neuraluv_paper import damage


def _projected_blob():
    """A closed surface with a dent and a bulge, projected along z: one island, its back stacked on its front
    and joined to it along the silhouette; the dent's walls fold back inside the front's image."""
    s = trimesh.creation.icosphere(3)
    V = s.vertices.copy()
    d = np.linalg.norm(V - [0.0, 0.0, 1.0], axis=1)
    V *= (1 - 0.45 * np.exp(-(d / 0.3) ** 2) + 0.2 * np.exp(-(np.linalg.norm(V - [0.8, 0, 0.6], axis=1) / 0.3) ** 2))[:, None]
    return V, s.faces, V[:, :2] * 0.45 + 0.5


def test_a_projection_s_own_reversals_are_intent():
    V, F, UV = _projected_blob()
    f = layout_facts(V, F, UV, F)
    sgn, on, edge = projection_signs(f, np.arange(len(F)))
    assert f.n_islands == 1 and on.all() and (sgn == np.sign(f.det)).all()
    assert (f.det < 0).sum() > 0.4 * len(F)    # the back, and the dent's walls inside the front
    it = layout_intent(f)
    assert not it.fold.any() and not it.degenerate.any() and it.info["projections"] == [0]
    d = diagnose_layout(V, F, UV, F, purpose="texture")
    assert d.ok and [x["message"].split(":")[0] for x in d.features if x["kind"] == "mirrored"] == \
        ["island made by a planar projection"]
    res = repair_layout(V, F, UV, F, "test", purpose="texture", device="cpu")
    assert res.unchanged and res.after.ok


def test_a_fold_on_a_projection_s_far_side_is_found_and_repaired_in_its_orientation():
    # a fold on the far side turns a patch of it to the near side's orientation: by its sheets it may join the
    # near side and pass for intent (before: 24 of 140 reversed faces), by the projection it is a fold (faces
    # within EDGE_ON of edge-on are still read by the sheets: 8 of 140)
    V, F, UV = _projected_blob()
    f0 = layout_facts(V, F, UV, F)
    rows = np.flatnonzero((V[:, 2] < -0.2) & (V[:, 2] > -0.7))
    missed = total = 0
    for seed in range(8):
        bad, _ = damage.local_fold(V, F, UV, F, rings=2, seed=seed, rows=rows, strength=2.0)
        f = layout_facts(V, F, bad, F)
        it = layout_intent(f)
        rev = (f.det * f0.det < 0) & ~f.degenerate3d
        missed += int((rev & ~it.fold).sum())
        total += int(rev.sum())
        if seed == 0:
            res = repair_layout(V, F, bad, F, "test", purpose="texture", device="cpu")
            assert res.after.ok and res.after.validation["valid"]
            after = layout_facts(V, F, res.UV, res.FUV)
            s, _, edge = projection_signs(after, np.arange(len(F)))
            judged = (s != 0) & ~edge
            assert (np.sign(after.det[judged]) == s[judged]).all()   # every face in the projection's orientation
            assert (~res.changed_faces).mean() > 0.9
    assert total > 100 and missed <= 0.1 * total


def test_a_mirror_modifier_s_copies_on_shared_rows_are_no_projection():
    # the halves share their rows at mirrored places in 3D: no one affine map of the corners fits both
    rng = np.random.default_rng(1)
    P = rng.normal(size=(40, 3))
    U = P[:, :2] * 0.1 + 0.5
    both = np.r_[P, P * [-1, 1, 1]]
    assert projection_axes(P, U) is not None and projection_axes(both, np.r_[U, U]) is None
