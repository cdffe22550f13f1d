"""neuraluv.layout: the facts of a layout, the overlap engine, validation, rigid fits, the raster and free space."""
import numpy as np
import pytest

from neuraluv.jacobian import signed_areas_2d
from neuraluv.layout import texel_density, upright, validate_layout
from neuraluv.layout.overlap import overlapping_pairs, pair_areas


def test_upright_lays_main_axis_along_u_without_mirroring():
    rng = np.random.default_rng(1)
    P = rng.normal(size=(50, 2)) * [0.2, 3.0]
    V = np.column_stack([P[:, 0], P[:, 1], np.zeros(50)])  # 3D +Y is the long axis
    r = upright(P, V)
    ext = r.max(0) - r.min(0)
    assert ext[0] > 5 * ext[1]
    M = np.linalg.lstsq(P - P.mean(0), r - r.mean(0), rcond=None)[0]
    assert np.linalg.det(M) > 0  # a rotation, not a reflection


def test_island_density_is_scale_of_the_map():
    V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    assert texel_density(V, np.array([[0, 1, 2]]), 3 * V[:, :2]) == pytest.approx(3.0)


def test_stacked_validation_still_catches_partial_overlaps():
    V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2], [0, 1, 2]])
    UV = np.array([[.1, .1], [.4, .1], [.1, .4], [.2, .2], [.5, .2], [.2, .5]])
    on_top = np.array([[.1, .1], [.4, .1], [.1, .4]] * 2)
    FUV = np.array([[0, 1, 2], [3, 4, 5]])
    assert validate_layout(V, F, UV, FUV, stacked=True)["overlapping_pairs"] == 1
    r = validate_layout(V, F, on_top, FUV, stacked=True)
    assert r["overlapping_pairs"] == 0 and r["stacked_islands"] == 1 and r["valid"]


def test_float32_uvs_keeps_needles_positive_and_moves_nothing_else():
    """Rounding to float32 (what OBJ/GLB carry) must not flip a needle the solver kept positive."""
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


def test_validate_layout_detects_each_failure():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2], [0, 1, 2]])
    FUV = np.array([[0, 1, 2], [3, 4, 5]])
    good = np.array([[0.1, 0.1], [0.3, 0.1], [0.1, 0.3], [0.6, 0.6], [0.8, 0.6], [0.6, 0.8]])
    assert validate_layout(V, F, good, FUV, padding=4, resolution=64)["valid"]
    near = good.copy()
    near[3:] -= 0.35  # 0.07 apart, closer than 8 texels at 64 (0.125), not touching
    r = validate_layout(V, F, near, FUV, padding=8, resolution=64)
    assert r["padding_violations"] == 1 and not r["valid"]
    over = good.copy()
    over[3:] = good[:3] + 0.05
    assert validate_layout(V, F, over, FUV)["overlapping_pairs"] == 1
    flip = good.copy()
    flip[[4, 5]] = flip[[5, 4]]
    assert validate_layout(V, F, flip, FUV)["flips"] == 1
    out = good.copy()
    out[0] = [-0.01, 0.1]
    assert not validate_layout(V, F, out, FUV)["uv_in_unit_square"]
    fold = np.array([[0.1, 0.1], [0.5, 0.1], [0.1, 0.5], [0.4, 0.4]])  # two faces of one island overlapping
    r = validate_layout(np.vstack([V, [[1, 1, 0]]]), np.array([[0, 1, 2], [0, 1, 3]]), fold, np.array([[0, 1, 2], [0, 1, 3]]))
    assert r["self_overlapping_islands"] == 1 and not r["valid"]


def test_overlap_test_agrees_with_exact_polygon_areas():
    rng = np.random.default_rng(0)
    P = rng.random((400, 3, 2))
    Q = rng.random((400, 3, 2)) * 0.6 + 0.2
    sat = overlapping_pairs(P, Q)
    area = pair_areas(P, Q)
    assert np.array_equal(sat, area > 1e-12)
    assert 50 < sat.sum() < 400  # both outcomes occur


def test_texel_density_counts_faces_oriented_like_their_island():
    from neuraluv.layout import layout_facts

    V = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]])
    F = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 2]])
    UV = 0.5 * V[:, :2]
    fold = UV.copy()
    fold[4] = [0.3, 0.2]  # the third face folds back over the first: it does not count
    assert texel_density(V, F, UV) == pytest.approx(0.5)
    assert texel_density(V, F[:2], fold) == pytest.approx(0.5) and texel_density(V, F, fold) == pytest.approx(0.5)
    f = layout_facts(V, F, fold * [-1, 1])  # mirrored: the reversed faces are the island's own
    assert f.mirrored.tolist() == [True] and f.density[0] * 1.0 == pytest.approx(0.5 * f.density[0] / 0.5)
    assert texel_density(V, F, UV, labels=np.array([0, 0, 1])).tolist() == pytest.approx([0.5, 0.5])


def test_faces_without_3d_area_are_reported_not_counted_as_flips():
    V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]])
    F = np.array([[0, 1, 2], [0, 1, 3]])  # the second face is a sliver of no area on the x axis
    UV = np.array([[.1, .1], [.4, .1], [.1, .4], [.7, .5]])
    FUV = np.array([[0, 1, 2], [1, 0, 3]])
    r = validate_layout(V, F, UV, FUV)
    assert r["zero_area_faces"] == 1 and r["flips"] == 0 and r["valid"], r


def test_validation_reports_mirrored_islands_and_faces_without_uvs():
    V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2], [0, 1, 2]])
    UV = np.array([[.1, .1], [.4, .1], [.1, .4], [.9, .1], [.6, .1], [.9, .4]])
    r = validate_layout(V, F, UV, np.array([[0, 1, 2], [3, 4, 5]]))
    assert r["mirrored_islands"] == 1 and r["flips"] == 1 and not r["valid"]
    r = validate_layout(V, F, UV, np.array([[0, 1, 2], [3, -1, 5]]))
    assert r["covered_faces"] == 1 and r["flips"] == 1 and r["islands"] == 1 and not r["valid"]


def test_rigid_fit_recovers_a_motion_and_never_returns_a_reflection():
    from neuraluv.layout import rigid_fit

    rng = np.random.default_rng(1)
    P = rng.normal(size=(12, 3))
    a = 0.7
    R0 = np.array([[np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0], [0, 0, 1]])
    R, s, t = rigid_fit(P, P @ R0 + [1, 2, 3])
    assert np.allclose(R, R0) and s == 1.0 and np.allclose(t, [1, 2, 3])
    M = P * [-1, 1, 1]  # a mirror image: the best proper fit leaves a residual
    R, _, t = rigid_fit(P, M)
    assert np.linalg.det(R) == pytest.approx(1.0) and np.abs(P @ R + t - M).max() > 0.1
    R, s, t = rigid_fit(P, M, proper=False, scale=True)
    assert np.linalg.det(R) == pytest.approx(-1.0) and s == pytest.approx(1.0) and np.allclose(P @ R + t, M)
    R, s, t = rigid_fit(P[:, :2], 3 * P[:, :2] @ R0[:2, :2], scale=True)
    assert s == pytest.approx(3.0) and np.allclose(R, R0[:2, :2])


@pytest.mark.parametrize("size", [40, 1100])  # a float32 page and a float64 one
def test_page_free_spots_are_exactly_where_a_mask_fits(size):
    from neuraluv.layout.raster import Page

    rng = np.random.default_rng(size)
    taken = rng.random((size, size)) < 0.002
    mask = rng.random((5, 7)) < 0.6
    page = Page(taken.shape)
    page.add(taken, 0, 0)
    free = page.free(mask)
    assert free.shape == (size - 4, size - 6)
    for y, x in rng.integers(0, [size - 4, size - 6], size=(300, 2)):
        assert free[y, x] == (not (taken[y:y + 5, x:x + 7] & mask).any())
    assert Page((3, 3)).free(np.ones((4, 1), bool)).size == 0  # larger than the page: nowhere


@pytest.mark.parametrize("scan", [False, True])  # the FFT correlation, the compiled scan of free runs
def test_page_spot_is_the_rules_best_free_spot(scan, monkeypatch):
    from neuraluv.layout import raster

    if scan and not raster.SCAN:
        pytest.skip("numba is not installed")
    monkeypatch.setattr(raster, "SCAN", scan)
    rng = np.random.default_rng(3)
    for trial in range(20):
        taken = rng.random((60, 50)) < rng.choice([0.005, 0.03, 0.2])
        mask = rng.random((rng.integers(1, 9), rng.integers(1, 9))) < 0.7
        page = raster.Page(taken.shape)
        page.add(taken, 0, 0)
        h, w = mask.shape
        lo, hi = (2, 3), (55 - h, 47 - w)
        free = [(y, x) for y in range(lo[0], hi[0] + 1) for x in range(lo[1], hi[1] + 1)
                if not (taken[y:y + h, x:x + w] & mask).any()]
        W, H = rng.integers(0, 50, 2)
        want = min(free, key=lambda p: (max(W, H, p[1] + w, p[0] + h), p[0] + p[1], p[0])) if free else None
        assert page.spot(mask, lo, hi) == (free[0] if free else None)
        assert page.spot(mask, lo, hi, box=(W, H)) == want


def test_a_mask_with_more_room_than_the_page_fits_nowhere_and_the_others_are_correlated():
    # room() is the largest free square's half side; place() skips the correlation of a mask whose room is larger
    # than the page's. That must never skip a mask that fits somewhere: brute force on random pages and masks.
    from neuraluv.layout.raster import Page, room

    rng = np.random.default_rng(7)
    skipped = 0
    for trial in range(200):
        taken = rng.random((24, 24)) < rng.choice([0.01, 0.05, 0.2, 0.4])
        mask = rng.random((rng.integers(1, 12), rng.integers(1, 12))) < rng.choice([0.5, 1.0])
        page = Page(taken.shape)
        page.add(taken, 0, 0)
        fits = page.free(mask).any()
        assert page.room() == room(~taken)
        if room(mask) > page.room():
            skipped += 1
            assert not fits
    assert skipped >= 5  # the bound does skip


def test_triangles_union_from_boundary_loops_is_geos_union():
    import shapely

    from neuraluv.layout.overlap import _boundary_polygon, _polygons, triangles_union

    n = 6  # a 5x5 grid of squares, the middle one left out (a hole)
    UV = np.array([[x, y] for y in range(n) for x in range(n)], float)
    F = [[y * n + x, y * n + x + 1, (y + 1) * n + x + 1] for y in range(n - 1) for x in range(n - 1)]
    F += [[y * n + x, (y + 1) * n + x + 1, (y + 1) * n + x] for y in range(n - 1) for x in range(n - 1)]
    F = np.array([f for k, f in enumerate(F) if k % 25 != 12])
    rng = np.random.default_rng(0)
    for uv, f, loops in [(UV + rng.normal(0, 0.05, UV.shape), F, True),  # one shell and a hole
                         (UV, np.vstack([F, F[:1]]), False),  # a face twice: GEOS
                         (np.vstack([UV, [[1.2, 1.2], [1.8, 1.2], [1.5, 1.8]]]), np.vstack([F, [[36, 37, 38]]]), False),  # over
                         (np.vstack([UV, [[2.5, 2.5]]]), np.vstack([F, [[14, 15, 36]]]), True),  # in the hole
                         (UV, F[:, ::-1], False)]:  # clockwise faces: GEOS
        union = triangles_union(uv, f)[0]
        assert union.is_valid and union.equals(shapely.union_all(_polygons(uv[f])))
        assert (_boundary_polygon(uv, f) is not None) == loops
    assert len(triangles_union(UV, F)[0].interiors) == 1


def test_rasterise_covers_outline_and_keeps_holes_free_unless_filled_later():
    from shapely.geometry import Polygon, box

    from neuraluv.layout.overlap import outline_rings
    from neuraluv.layout.raster import rasterise

    ring = Polygon([(0, 0), (1, 0), (1, 1), (0, 1)], [[(0.3, 0.3), (0.7, 0.3), (0.7, 0.7), (0.3, 0.7)]])
    m, lo = rasterise(outline_rings(ring, holes=True), 20, lo=(0, 0), shape=(20, 20))
    assert m[1, 1] and m[18, 18] and not m[10, 10]  # the hole's inside is free
    nested = outline_rings(ring, holes=True) + outline_rings(box(0.45, 0.45, 0.55, 0.55))
    assert rasterise(nested, 20, lo=(0, 0), shape=(20, 20))[0][10, 10]  # an island drawn inside it stays
    assert rasterise(outline_rings(ring), 20, lo=(0, 0), shape=(20, 20))[0][10, 10]  # holes left out: filled


def test_free_space_moves_an_island_the_least_and_keeps_the_padding():
    from shapely.geometry import box

    from neuraluv.layout import FreeSpace

    T = np.array([[0, 1, 2], [1, 3, 2]])
    uv = np.array([[0.40, 0.40], [0.50, 0.40], [0.40, 0.50], [0.50, 0.50]])  # on top of the fixed block
    fixed = box(0.3, 0.3, 0.6, 0.6)
    space = FreeSpace([fixed], resolution=256, padding=4)
    p = space.place(uv, T)
    P = box(*p.uv.min(0), *p.uv.max(0))
    assert p.uv is not None and p.turns == 0 and p.scale == 1.0
    assert P.distance(fixed) >= 4 / 256 * (1 - 1e-9) and np.allclose(np.ptp(p.uv, 0), [0.1, 0.1])
    assert p.distance < 0.3  # beside the block, not across the texture
    space.add(P)
    assert not space.clear(P.buffer(-0.01)) and space.clear(box(0.9, 0.9, 0.95, 0.95))
    full = FreeSpace([box(0, 0, 1, 1)], resolution=64, padding=1)
    assert full.place(uv, T).uv is None



def test_dilate_is_the_binary_dilation_by_a_disk():
    from scipy import ndimage

    from neuraluv.layout.raster import dilate, disk

    rng = np.random.default_rng(3)
    for _ in range(100):
        h, w = rng.integers(1, 40, 2)
        r = int(rng.integers(1, 8))
        m = rng.random((h, w)) < rng.uniform(0.01, 0.5)
        assert np.array_equal(dilate(m, r), ndimage.binary_dilation(np.pad(m, r), disk(r)))
        big = np.pad(m, r + 2)
        assert np.array_equal(dilate(big, r, grow=False), ndimage.binary_dilation(big, disk(r)))
