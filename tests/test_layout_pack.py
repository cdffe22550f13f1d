"""neuraluv.layout.pack: every packer keeps the padding, the orientation and one scale; cuts only when fuller."""


import numpy as np
import pytest

from neuraluv.jacobian import signed_areas_2d
from neuraluv.layout import validate_layout
from neuraluv.layout.pack import PACK_TRIALS, raster_pack, shelf_pack, tight_pack
from neuraluv.layout.pack.raster import largest_fit
from neuraluv.layout.pack.result import min_gap

from conftest import l_shaped_islands, strip_island


@pytest.mark.slow
def test_tight_pack_keeps_padding_orientation_and_beats_shelf():
    uvs, fs = l_shaped_islands()
    for pad, res in ((4, 256), (2.5, 512)):
        t = tight_pack(uvs, fs, padding=pad, resolution=res)
        s = shelf_pack(uvs, fs, padding=pad, resolution=res)
        UV = np.vstack(t.uvs)
        off = np.cumsum([0] + [len(u) for u in uvs])
        F = np.vstack([f + o for f, o in zip(fs, off[:-1])])
        V = np.column_stack([np.vstack(uvs), np.zeros(len(UV))])
        val = validate_layout(V, F, UV, F, padding=pad, resolution=res)
        assert val["valid"], val  # no flip (no mirrored island), no overlap, gaps >= padding, inside [0,1]^2
        assert (UV >= pad / res * (1 - 1e-6)).all() and (UV <= 1 - pad / res * (1 - 1e-6)).all()
        assert t.utilisation > s.utilisation
        # one common scale: every chart keeps its relative size
        ratios = [np.sqrt(np.abs(signed_areas_2d(p, f)).sum() / np.abs(signed_areas_2d(u, f)).sum())
                  for p, u, f in zip(t.uvs, uvs, fs)]
        assert np.ptp(ratios) < 1e-9 * max(ratios)


# An island from generated asset 0 (fast preset) with a triangle of ~1e-7 of its area:
# xatlas drops such triangles and placed the island's pieces apart, so the tight packer
# used to fall back to shelves for the whole atlas.
_SPLIT_U = [[0.118097, 0.001501], [0.097267, 0.036296], [0.073025, -0.072022], [0.072174, -0.072358],
            [0.094965, -0.010731], [0.05526, -0.035258], [0.071099, -0.069418], [0.072398, 0.023844],
            [0.03898, 0.002957], [0.021226, 0.041628], [0.007908, 0.074661], [0.04917, -0.038781],
            [0.011136, -0.060665], [0.021402, -0.00861], [-0.001178, -0.023582], [-0.018889, 0.01484],
            [-0.018841, 0.014701], [-0.035684, 0.055454], [-0.032998, -0.050411], [-0.018917, 0.014826],
            [-0.055894, -0.012217], [-0.055531, 0.041125], [-0.056342, 0.030438], [-0.067583, -0.072358],
            [-0.090177, -0.037356], [-0.092418, 0.047394], [-0.096481, 0.04223]]


_SPLIT_F = [[0, 1, 4], [5, 6, 2], [5, 2, 4], [6, 12, 3], [6, 5, 11], [4, 1, 7], [6, 11, 12], [8, 5, 4], [7, 8, 4],
            [5, 8, 11], [11, 8, 13], [14, 12, 11], [9, 8, 7], [13, 14, 11], [13, 8, 15], [8, 9, 15], [14, 13, 16],
            [13, 15, 16], [14, 20, 18], [10, 17, 9], [16, 20, 14], [16, 15, 19], [9, 17, 15], [18, 20, 23],
            [19, 15, 21], [23, 20, 24], [19, 21, 22], [21, 25, 22], [22, 25, 26]]


@pytest.mark.slow
@pytest.mark.parametrize("method", ["raster", "xatlas"])
def test_tight_pack_places_charts_with_degenerate_triangles_rigidly(method):
    uvs, fs = l_shaped_islands(8, seed=3)
    u, f = np.array(_SPLIT_U), np.array(_SPLIT_F)
    assert np.abs(signed_areas_2d(u, f)).min() < 1e-5 * np.abs(signed_areas_2d(u, f)).sum()
    uvs.append(u * 0.3 / np.sqrt(np.abs(signed_areas_2d(u, f)).sum()))
    fs.append(f)
    t = tight_pack(uvs, fs, padding=3, resolution=256, method=method)
    for p, u in zip(t.uvs, uvs):  # each chart is a scaled rotation of its input (no mirror, no split)
        a, b = u - u.mean(0), p - p.mean(0)
        Uu, _, Vt = np.linalg.svd(a.T @ b)
        R = Uu @ Vt
        assert np.linalg.det(R) > 0
        assert np.abs(a @ R * t.scale - b).max() < 1e-9
    # the layout is grown up to the padding line on at least one axis
    UV = np.vstack(t.uvs)
    assert np.isclose(UV.min(), 3 / 256, atol=1e-3) and 1 - 3 / 256 - 1e-3 < UV.max() <= 1 - 3 / 256


def test_tight_pack_without_rotation_only_scales_and_translates():
    uvs, fs = l_shaped_islands(10, seed=5)
    for method in ("raster", "xatlas"):
        t = tight_pack(uvs, fs, padding=2, resolution=256, rotate=False, method=method)
        for p, u in zip(t.uvs, uvs):  # upright islands stay upright: p = s u + offset
            assert np.allclose(p - p.mean(0), (u - u.mean(0)) * t.scale, atol=1e-6)  # xatlas: float32 fit


@pytest.mark.slow
def test_raster_pack_nests_irregular_shapes_fuller_than_boxes():
    # few large L-shapes: the reading-order raster fill beats xatlas's placement of the same shapes
    uvs, fs = l_shaped_islands(6, seed=2)
    r = tight_pack(uvs, fs, padding=4, resolution=512, method="raster")
    x = tight_pack(uvs, fs, padding=4, resolution=512, method="xatlas")
    assert r.padding_texels >= 4 and x.padding_texels >= 4
    assert r.utilisation > x.utilisation


@pytest.mark.parametrize("start", [0.5, 2.9, 3.05, 9.0])
def test_largest_fit_brackets_the_largest_fitting_scale_from_any_start(start):
    calls = []

    def attempt(s):
        calls.append(s)
        return (s,) if s <= 3.0 else None

    s = largest_fit(attempt, start, 10.0, 0.01)[0]
    assert 3.0 / 1.01 <= s <= 3.0
    # galloping from a close start costs a few placements (a bisection of [hi/2, hi] costs 7), a far one more
    assert len(calls) <= (6 if abs(np.log(start / 3.0)) < 0.05 else 16)
    if start > 3.0:  # without a search downwards a start that does not fit gives nothing
        assert largest_fit(attempt, start, 10.0, 0.01, down=False) is None
    with pytest.raises(ValueError):
        largest_fit(lambda s: None, 1.0, 10.0, 0.01)


def test_raster_pack_gap_from_moved_unions_is_the_gap_of_the_placed_triangles():
    # the packer measures the padding on each island's union moved with it; it must be the placed triangles' gap
    uvs, fs = l_shaped_islands(5, seed=3)
    r = raster_pack(uvs, fs, padding=4, resolution=256, grid=128, angles=4)
    assert r.padding_texels == pytest.approx(min_gap(r.uvs, fs, r.pages) * 256, abs=1e-9)
    assert r.padding_texels >= 4


@pytest.mark.slow
def test_perturbed_order_trials_pack_at_least_as_full_and_misses_are_cheap():
    uvs, fs = l_shaped_islands(9, seed=4)
    two = tight_pack(uvs, fs, padding=4, resolution=256, trials=2)
    more = tight_pack(uvs, fs, padding=4, resolution=256, trials=PACK_TRIALS)
    assert more.utilisation >= two.utilisation and more.padding_texels >= 4
    # a different placement order packs differently
    w = np.ones(len(uvs))
    w[np.argsort([-np.abs(signed_areas_2d(u, f)).sum() for u, f in zip(uvs, fs)])[:2]] = [0.1, 10.0]
    a = raster_pack(uvs, fs, padding=4, resolution=256, grid=256, angles=4)
    b = raster_pack(uvs, fs, padding=4, resolution=256, grid=256, angles=4, weights=w)
    assert not np.allclose(np.vstack(a.uvs), np.vstack(b.uvs))
    # above the best scale nothing fits: one placement per rule, then ValueError
    with pytest.raises(ValueError, match="floor"):
        raster_pack(uvs, fs, padding=4, resolution=256, grid=256, angles=4, floor=2 * a.scale)
    c = raster_pack(uvs, fs, padding=4, resolution=256, grid=256, angles=4, floor=0.9 * a.raster_scale)
    assert c.raster_scale >= 0.9 * a.raster_scale


def test_perturbed_order_trials_stop_after_order_patience_trials_in_a_row_that_pack_no_fuller(monkeypatch):
    """Equal squares pack the same in every order: the trials after the first settings stop early."""
    from neuraluv.layout.pack import ORDER_PATIENCE, RASTER_TRIALS, tight as tight_mod

    sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]])
    q = np.array([[0, 1, 2], [0, 2, 3]])
    res = tight_pack([sq] * 6, [q] * 6, padding=4, resolution=128, trials=PACK_TRIALS)
    assert res.trials == len(RASTER_TRIALS) + ORDER_PATIENCE < PACK_TRIALS
    # a trial that packs fuller every time keeps them going: all PACK_TRIALS run
    real, calls = tight_mod.raster_pack, []

    def fuller_each_time(*a, **k):
        r = real(*a, **{**k, "floor": None})
        calls.append(1)
        r.utilisation += 0.001 * len(calls)
        return r

    monkeypatch.setattr(tight_mod, "raster_pack", fuller_each_time)
    assert tight_pack([sq] * 6, [q] * 6, padding=4, resolution=128, trials=PACK_TRIALS).trials == PACK_TRIALS


@pytest.mark.slow
def test_tight_pack_fixed_density_spills_to_pages():
    uvs, fs = l_shaped_islands(20)
    one = tight_pack(uvs, fs, padding=2, resolution=128)
    dense = tight_pack(uvs, fs, padding=2, resolution=128, texel_density=2 * one.scale * 128)
    with pytest.raises(ValueError, match="more than a 128-texel tile"):
        tight_pack(uvs, fs, padding=2, resolution=128, texel_density=50 * one.scale * 128)
    with pytest.raises(ValueError, match="less than one texel"):  # not an atlas of points
        tight_pack(uvs, fs, padding=2, resolution=128, texel_density=1e-9)
    assert one.pages.max() == 0 and dense.pages.max() >= 1
    for p in range(int(dense.pages.max()) + 1):
        on = [u for u, g in zip(dense.uvs, dense.pages) if g == p]
        assert on and all((u >= 0).all() and (u <= 1).all() for u in on)


def test_granular_islands_cut_only_the_large_islands_into_connected_parts():
    from neuraluv.layout.pack import granular_islands
    from neuraluv.topology import bisect_faces, face_components

    big, Fb = strip_island(40)
    small, Fs = strip_island(2)
    pieces = granular_islands([big, small], [Fb, Fs], max_share=0.2)
    assert [i for i, _ in pieces].count(1) == 1  # the small strip (2% of the area) stays whole
    parts = [idx for i, idx in pieces if i == 0]
    assert sorted(np.concatenate(parts).tolist()) == list(range(len(Fb)))  # every face in exactly one part
    total = np.abs(signed_areas_2d(big, Fb)).sum() + np.abs(signed_areas_2d(small, Fs)).sum()
    for idx in parts:
        assert face_components(Fb[idx])[0] == 1  # edge-connected
        assert np.abs(signed_areas_2d(big, Fb[idx])).sum() <= 0.2 * total
    assert 5 <= len(parts) <= 8  # halving 40/41 of the area down to <= 1/5: 8 parts at most, no over-cutting
    a, b = bisect_faces(big, Fb, np.arange(len(Fb)))  # a straight cut across the strip's length: two halves of 40 faces
    assert len(a) == len(b) == 40 and (big[Fb[a]][..., 0].max() <= big[Fb[b]][..., 0].min() + 1e-12 or
                                       big[Fb[b]][..., 0].max() <= big[Fb[a]][..., 0].min() + 1e-12)


@pytest.mark.slow
def test_tight_pack_cuts_a_dominant_island_only_when_it_packs_fuller():
    from neuraluv.layout.pack import SPLIT_GAIN

    big, Fb = strip_island(30, 0.5)  # a 30:0.5 sliver fills a square texture poorly whole
    sq = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    q = np.array([[0, 1, 2], [0, 2, 3]])
    uvs, fs = [big, sq, sq], [Fb, q, q]
    whole = tight_pack(uvs, fs, padding=2, resolution=256)
    cut = tight_pack(uvs, fs, padding=2, resolution=256, split=0.1, xyz=[np.column_stack([u, 0 * u[:, 0]]) for u in uvs])
    assert whole.pieces is None and cut.pieces is not None
    assert cut.utilisation >= whole.utilisation + SPLIT_GAIN
    for (i, idx, vi), p in zip(cut.pieces, cut.uvs):  # each part is its chart's faces, moved rigidly
        f = np.searchsorted(vi, fs[i][idx])
        assert (signed_areas_2d(p, f) > 0).all()
        assert np.isclose(np.abs(signed_areas_2d(p, f)).sum(), np.abs(signed_areas_2d(uvs[i], fs[i][idx])).sum()
                          * cut.scale ** 2, rtol=1e-6)
    assert sorted((i, int(j)) for i, idx, _ in cut.pieces for j in idx) == [(i, j) for i in range(3)
                                                                          for j in range(len(fs[i]))]
    same = tight_pack([sq] * 12, [q] * 12, padding=2, resolution=256, split=0.1)
    assert same.pieces is None  # no island above the share (each holds 1/12): nothing is cut


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


def _rigid_scale(a, b):
    """The uniform scale taking ``a`` to ``b`` by a proper motion (None when ``b`` is not such a copy)."""
    from neuraluv.layout import rigid_fit

    R, s, t = rigid_fit(a, b, scale=True)
    ok = np.linalg.det(R) > 0 and np.abs(s * a @ R + t - b).max() <= 1e-7 * max(np.ptp(b), 1e-300)
    return s if ok else None


@pytest.mark.parametrize("packer", ["xatlas_pack", "xatlas_shape_pack"])
def test_xatlas_packers_keep_padding_and_never_mirror(packer):
    from neuraluv.layout import pack

    uvs, fs = l_shaped_islands(7, seed=11)
    res = getattr(pack, packer)(uvs, fs, padding=4, resolution=256)
    assert res.packer == {"xatlas_pack": "xatlas", "xatlas_shape_pack": "xatlas-shapes"}[packer]
    scale = [_rigid_scale(a, u) for a, u in zip(uvs, res.uvs)]
    assert None not in scale  # every island a proper rigid copy (quarter turns at most, never a mirror)
    # one common scale (one texel density); the box packer shrinks an island a little where xatlas's box is tighter
    assert np.allclose(scale, max(scale), rtol=1e-6 if packer == "xatlas_shape_pack" else 0.01)
    for u, f in zip(res.uvs, fs):
        assert (signed_areas_2d(u, f) > 0).all() and u.min() >= 0 and u.max() <= 1
    UV = np.vstack(res.uvs)
    off = np.cumsum([0] + [len(u) for u in uvs])
    F = np.vstack([f + o for f, o in zip(fs, off[:-1])])
    v = validate_layout(np.column_stack([UV, np.zeros(len(UV))]), F, UV, F, padding=4, resolution=256)
    assert v["valid"] and v["padding_violations"] == 0, v


def test_every_packer_returns_its_declared_result():
    from dataclasses import fields

    from neuraluv.layout.pack import PackResult, xatlas_pack

    uvs, fs = l_shaped_islands(4, seed=2)
    declared = {f.name for f in fields(PackResult)}
    for res in (shelf_pack(uvs, fs, padding=2, resolution=128), raster_pack(uvs, fs, padding=2, resolution=128),
                tight_pack(uvs, fs, padding=2, resolution=128, trials=2), xatlas_pack(uvs, fs, padding=2, resolution=128)):
        assert set(vars(res)) == declared  # nothing bolted on
        assert len(res.uvs) == len(uvs) and res.n_pages == 1 and 0 < res.utilisation <= 1 and res.packer
