"""Added damage on texture layouts that the authored-asset bench left unfixed (issue 27), as small procedural cases.

Each test is the smallest layout with the cause found on a real asset: a vertex flung across a small island
(tube.obj, vertex noise), a fold on the rows two mirrored halves share (Blender's mirrored Suzanne), folds
next to the pole of a latitude-longitude map (capsule.obj, vertex noise), a NaN on a palette's point (chair_model.obj,
NaN UVs).
"""
import numpy as np

from neuraluv.layout.facts import layout_facts
from neuraluv.layout.purpose import layout_intent
from neuraluv.layout.facts import face_clusters
from neuraluv.layout.overlap import overlap_pairs
from neuraluv.repair.local import with_stretched_neighbours
from neuraluv.repair.repair import repair_layout

from conftest import grid, rolled


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


def test_a_band_pushed_over_its_neighbours_is_a_fold_not_a_mirrored_copy():
    # a push across a narrow strip (the bench's local fold on the stacked cylinder, seed 12) reverses a band that
    # is as regular as a mirrored copy and a large part of the island; it lies on the faces next to it, where a
    # copy lies on the part it copies. Read as a mirrored copy it was kept as intent (the faces it folded over
    # were the "fold"), and the band stayed reversed in the output.
    V, F = grid(12, 2)
    V = np.c_[V[:, 0], V[:, 1], 0.3 * np.sin(V[:, 0] / 2)]
    UV = V[:, :2] / 13 + 0.01
    w = np.clip(1 - np.maximum(np.abs(V[:, 0] - 6), np.abs(V[:, 1] - 1)) / 3, 0, None)  # 2 rings, tapered
    for push in ([5.0, 0.0], [-5.9, 0.85]):
        bad = UV + w[:, None] * np.array(push) / 13
        f = layout_facts(V, F, bad, F)
        it = layout_intent(f)
        assert (f.det < 0).sum() == 10 and not it.mirrored_shell.any()
        assert it.fold[f.det < 0].all()
        res = repair_layout(V, F, bad, F, purpose="texture", device="cpu")
        assert res.after.validation["valid"] and (layout_facts(V, F, res.UV, res.FUV).det > 0).all()


def twin_halves(n=4, rows=4):
    """A mirror modifier's halves sharing their UVs: the right half an ``n`` × ``rows`` grid at ``x >= 0``, the
    left half its mirror image (winding reversed, merged at ``x = 0``), every face using its mirror face's
    ``vt`` rows. Returns ``V, F, UV, FUV``."""
    V, FR = grid(n, rows)
    P = V[:, :2]
    right = np.flatnonzero(P[:, 0] > 0)
    left_of = np.arange(len(P))
    left_of[right] = len(P) + np.arange(len(right))
    V2 = np.r_[P, P[right] * [-1, 1]]
    return np.c_[V2, 0.2 * np.cos(V2[:, 0])], np.r_[FR, left_of[FR][:, ::-1]], P / 10 + 0.1, np.r_[FR, FR[:, ::-1]]


def test_a_fold_on_rows_twin_halves_share_is_repaired_in_both_halves_at_once():
    # a row both halves use pushed over its neighbours folds both: each half's folded faces lie, by orientation,
    # in the other half's sheet, where they are not reversed but lie over their neighbours, and every row is
    # shared with the other half (locked). Repaired in the half's own layer (joined in 3D and in UV), the
    # twins follow: valid, and the halves still share every row.
    V, F, UV, FUV = twin_halves()
    assert not layout_intent(layout_facts(V, F, UV, FUV)).fold.any()
    bad = UV.copy()
    bad[12] += [0.15, 0.03]
    assert layout_intent(layout_facts(V, F, bad, FUV)).fold.sum() == 12
    res = repair_layout(V, F, bad, FUV, purpose="texture", device="cpu")
    assert res.after.validation["valid"]
    assert len(res.UV) == len(UV) and np.array_equal(res.FUV, FUV)  # no row split off: still twins
    assert res.changed_rows.sum() <= 4


def test_a_fold_where_twin_halves_lie_over_themselves_is_repaired_in_their_layers_keeping_those_overlaps():
    # Blender's mirrored Suzanne, one row moved by noise (seed 11): the fold lay where the half's layout lies over
    # itself on purpose, within a few rings. The twin layer's region could not be valid without those overlaps,
    # which a fold's faces may not keep, so the whole layer was re-solved (118 faces changed for one row). Here
    # the halves are a strip wound as a spiral (a turn every 4 columns, so it lies over itself 4 columns on):
    # the layer's faces that lay over another part of it may overlap again, and only the faces near the pushed row change.
    V, F, _, FUV = twin_halves(9, 2)
    t, r = np.meshgrid(np.arange(10.0), 1.0 + 0.6 * np.arange(3.0))
    ang = -t.ravel() * np.pi / 2
    UV = np.c_[r.ravel() * np.cos(ang), r.ravel() * np.sin(ang) + 0.02 * ang]
    UV = (UV - UV.min(0)) / np.ptp(UV).max() * 0.8 + 0.1
    f = layout_facts(V, F, UV, FUV)
    assert f.n_islands == 1 and not layout_intent(f).fold.any()
    assert len(overlap_pairs(UV, FUV, np.arange(len(F)))[0]) > 100  # a half over itself (and its twin)
    for k, push in ((15, 1.6), (12, 2.0), (17, 1.3)):  # a middle row, pushed past its neighbour towards the centre
        bad = UV.copy()
        bad[k] += (UV[k - 1] - UV[k]) * push
        assert layout_intent(layout_facts(V, F, bad, FUV)).fold.any()
        res = repair_layout(V, F, bad, FUV, purpose="texture", device="cpu")
        assert res.after.validation["valid"], k
        assert res.changed_rows.sum() <= 3 and res.changed_faces.sum() <= 18, (k, int(res.changed_faces.sum()))  # of 72


def test_every_face_a_fold_reverses_on_twin_halves_is_a_fold_of_its_own_half():
    # a fold of a few rings on rows two mirrored halves share flips faces of both halves at once, and each joins
    # the other half's sheet (Blender's mirrored Suzanne: 37.5% of the reversed faces were taken for the mirrored
    # copy's, data_scripts/purpose_fold_recall.py). By the surface each half is one layer: a face against its
    # layer's orientation is a fold, whatever sheet it joined.
    from neuraluv_paper.damage import local_fold

    V, F, UV, FUV = twin_halves(8, 8)
    f0 = layout_facts(V, F, UV, FUV)
    right = V[F, 0].mean(1) > 0
    for seed in (0, 1, 7):
        bad, _ = local_fold(V, F, UV, FUV, rings=2, strength=2.5, seed=seed, rows=np.unique(FUV))
        f = layout_facts(V, F, bad, FUV)
        it = layout_intent(f)
        reversed_ = f.det * f0.det < 0
        assert reversed_.sum() >= 12 and it.fold[reversed_].all(), seed
        assert not it.mirrored_shell[reversed_].any()
        res = repair_layout(V, F, bad, FUV, purpose="texture", device="cpu")
        g = layout_facts(V, F, res.UV, res.FUV)
        assert res.after.validation["valid"] and (g.det[right] > 0).all() and (g.det[~right] < 0).all()


def test_a_fold_no_local_step_repairs_on_twin_halves_gets_its_shell_resolved_on_its_own_rows(monkeypatch):
    # the last resort for a shell that shares every row with its twin (Blender's mirrored Suzanne, a fold at its
    # seam that no region, layer or untangle repaired): it was left folded and the output was invalid. Now the
    # shell is re-solved on its own copies of the shared rows, the other half keeps the originals (here it is
    # folded too, by the same damaged row, and is re-solved in turn).
    import neuraluv.repair.shells as shells

    def nothing(*a, **k):
        return None, {}

    for name in ("repair_cluster", "repair_twin_layers", "repair_across_shells", "untangle_faces"):
        monkeypatch.setattr(shells, name, nothing)
    V, F, UV, FUV = twin_halves()
    bad = UV.copy()
    bad[12] += [0.15, 0.03]
    res = repair_layout(V, F, bad, FUV, purpose="texture", device="cpu")
    assert res.after.validation["valid"]
    steps = [a for isl in res.islands for a in isl["actions"]]
    assert any(a.get("split_rows") for a in steps), steps
    assert len(res.UV) > len(UV) and not np.array_equal(res.FUV, FUV)  # on rows of its own


def pole_cap(nu=16, nv=6):
    """A latitude-longitude map of a spherical cap: an ``nu`` × ``nv`` quad grid in UV (4:1), its top row of
    vertices all at the pole in 3D, each with its own ``vt`` row, so each top quad is one stretched triangle
    and one without 3D area. Returns ``V, F, UV, FUV``."""
    gu, gv = np.meshgrid(np.arange(nu + 1.0), np.arange(nv + 1.0))
    _, FUV = grid(nu, nv)
    th, ph = 2 * np.pi * gu.ravel() / nu, 0.5 * np.pi * gv.ravel() / nv
    P = np.c_[np.cos(th) * np.cos(ph), np.sin(th) * np.cos(ph), np.sin(ph)]
    P[gv.ravel() == nv] = [0, 0, 1]
    V, vid = np.unique(P.round(12), axis=0, return_inverse=True)
    return V, vid.reshape(-1)[FUV], np.c_[0.8 * gu.ravel() / nu, 0.2 * gv.ravel() / nv] + 0.05, FUV


def test_folds_along_a_pole_stay_apart_and_are_repaired_in_place():
    # the rows around a pole are stretched on purpose; a fold's stretched neighbours joined through them made
    # every fold along the pole one cluster (hundreds of faces on capsule.obj, slow, then left folded). Only
    # stretched faces within two rings of a fold join it now.
    nu, nv = 24, 24
    V, F, UV, FUV = pole_cap(nu, nv)
    bad = UV.copy()
    for c in (3, 11, 19):
        bad[c + (nu + 1) * (nv - 2)] += [0.03, -0.002]
    f = layout_facts(V, F, bad, FUV)
    folds = np.flatnonzero(layout_intent(f).fold)
    assert len(folds) == 3
    grown = with_stretched_neighbours(f.Vn, F, bad, FUV, np.flatnonzero(~f.degenerate3d), folds)
    assert len(face_clusters(FUV, grown)) == 3
    res = repair_layout(V, F, bad, FUV, purpose="texture", device="cpu")
    assert res.after.validation["valid"]


def test_a_fold_on_a_row_shared_with_faces_without_3d_area_is_repaired_without_splitting_rows():
    # the row next to the pole is shared with a face without 3D area (no map to keep): the fold's own faces
    # may move it; it was locked like another shell's row, and the fold repaired on split-off copies
    nu, nv = 16, 6
    V, F, UV, FUV = pole_cap(nu, nv)
    bad = UV.copy()
    r = 5 + (nu + 1) * (nv - 1)
    bad[r] += [0.06, 0.02]
    f = layout_facts(V, F, bad, FUV)
    assert layout_intent(f).fold.any() and f.degenerate3d[(FUV == r).any(1)].any()
    res = repair_layout(V, F, bad, FUV, purpose="texture", device="cpu")
    assert res.after.validation["valid"]
    assert len(res.UV) == len(UV)  # no row split off


def test_faces_of_a_palette_point_that_became_nan_get_a_point_not_charts():
    # faces whose three corners use one vt row are a point whatever its value (one flat colour's texel); when
    # that row is NaN they were charted like faces that never had UVs (thousands of charts on chair_model.obj)
    V, F = grid(6, 4)
    UV = V[:, :2] / 10 + 0.05
    FUV = F.copy()
    pal = np.arange(24, 48)  # the upper half: all on one row
    FUV[pal] = len(UV)
    UV = np.vstack([UV, [[np.nan, np.nan]]])
    res = repair_layout(V, F, UV, FUV, purpose="texture", device="cpu")
    assert res.after.validation["valid"] and res.after.validation["palette_faces"] == len(pal)
    assert [(c["route"], c["faces"]) for c in res.new_charts] == [("point", len(pal))]
    assert (res.FUV[pal] == res.FUV[pal[0], 0]).all() and np.isfinite(res.UV[res.FUV[pal[0], 0]]).all()


def test_two_folds_that_overlap_in_uv_are_repaired_together_in_a_small_region():
    # vertex noise on a subdivided Suzanne unwrapped without seams: a row dragged across another fold's
    # neighbourhood. Repaired one after the other, the first fold's regions overlap the second's faces until
    # they swallow it (3 rings, 130 faces here; 32 rings, 3,844 faces on the Suzanne); joined, the two folds'
    # damaged rows alone are freed.
    V, F = grid(24, 12)
    UV = V[:, :2] / 24
    V = rolled(V, 24)
    a = 8 + 25 * 6
    b = a + 4 + 25
    bad = UV.copy()
    bad[a] += np.array([-1.584, -1.767]) / 24
    bad[b] += (UV[a] - UV[b]) * 0.808 + np.array([-0.161, 0.108]) / 24
    f = layout_facts(V, F, bad, F)
    assert [len(c) for c in face_clusters(F, np.flatnonzero(layout_intent(f).fold))] == [2, 2]
    res = repair_layout(V, F, bad, F, purpose="texture", device="cpu")
    assert res.after.validation["valid"]
    untouched = ~np.isin(F, [a, b]).any(1)
    assert not res.changed_faces[untouched].any()  # every face the damage did not touch is bit-identical
    acts = [x for isl in res.islands for x in isl["actions"]]
    assert [x.get("joined_faces") for x in acts] == [2]
