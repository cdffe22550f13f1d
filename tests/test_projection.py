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


def test_a_fold_along_a_projection_s_silhouette_is_found_and_put_back_where_the_projection_puts_it():
    # rows near the silhouette (the near and far sides meet there on shared rows) pulled off the projection:
    # before, faces within EDGE_ON of edge-on moved off it were read by the sheets, which took many of them for
    # intent, and no local untangle could keep both sides' orientations; now the projection judges them, and
    # the repair moves the fold's rows back onto it (no solve)
    V, F, UV = _projected_blob()
    f0 = layout_facts(V, F, UV, F)
    rows = np.flatnonzero(np.abs(V[:, 2]) < 0.25)
    cases = 0
    for seed in range(6):
        bad, _ = damage.local_fold(V, F, UV, F, rings=1, seed=seed, rows=rows, strength=2.0)
        f = layout_facts(V, F, bad, F)
        rev = (f.det * f0.det < 0) & ~f.degenerate3d
        if not rev.any():
            continue
        cases += 1
        it = layout_intent(f)
        assert (it.fold | it.degenerate)[rev].all()
        res = repair_layout(V, F, bad, F, "test", purpose="texture", device="cpu")
        assert res.after.ok and res.after.validation["valid"]
        assert [a["step"] for a in res.islands[0]["actions"]][0] == "back onto its planar projection"
        moved = ~(bad == UV).all(1)
        assert not (res.changed_rows & ~moved).any()                  # only the damaged rows moved ...
        assert np.abs(res.UV - UV).max() < 1e-9                       # ... back onto the projection
    assert cases >= 3


def test_a_projection_island_s_fold_whose_rows_go_back_is_mended_without_touching_a_second_island():
    # two projected blobs side by side (two islands): a fold on one is put back; the other island's rows are
    # bit-identical
    V, F, UV = _projected_blob()
    V2, F2, UV2 = np.r_[V, V + [3.0, 0, 0]], np.r_[F, F + len(V)], np.r_[UV * 0.5, UV * 0.5 + [0.5, 0]]
    rows = np.flatnonzero((V[:, 2] < -0.2) & (V[:, 2] > -0.7))
    bad, _ = damage.local_fold(V2, F2, UV2, F2, rings=2, seed=0, rows=rows, strength=2.0)
    res = repair_layout(V2, F2, bad, F2, "test", purpose="texture", device="cpu")
    assert res.after.ok and res.after.validation["valid"]
    assert not res.changed_rows[len(V):].any() and np.abs(res.UV - UV2).max() < 1e-9


def test_a_projection_stored_on_a_12_bit_grid_is_read_by_its_projection_and_mended_on_the_grid():
    # gltfpack and gltf-transform store UVs as 12-bit integers: rounding turns over and collapses the projection's
    # thinnest faces, which the grid, not damage, did (before: dozens of folds on the Khronos Duck so stored)
    V, F, UV = _projected_blob()
    Q = np.rint(UV * 4095) / 4095
    f = layout_facts(V, F, Q, F)
    turned = (np.sign(f.det) != np.sign(layout_facts(V, F, UV, F).det)) & ~f.degenerate3d
    assert turned.sum() + (f.det == 0).sum() > 0             # the grid turned or collapsed some faces
    it = layout_intent(f)
    assert not it.fold.any() and not it.degenerate.any() and it.info["projections"] == [0]
    rows = np.flatnonzero((V[:, 2] < -0.2) & (V[:, 2] > -0.7))
    bad, _ = damage.local_fold(V, F, Q, F, rings=2, seed=0, rows=rows, strength=2.0)
    res = repair_layout(V, F, bad, F, "test", purpose="texture", device="cpu")
    assert res.after.ok and res.islands[0]["actions"][0]["step"] == "back onto its planar projection"
    moved = res.changed_rows
    assert np.abs(res.UV[moved] * 4095 - np.rint(res.UV[moved] * 4095)).max() < 1e-2   # on the grid
    assert np.abs(res.UV - Q).max() * 4095 < 1.01         # where it was, up to a step (a fit to rounded data)
