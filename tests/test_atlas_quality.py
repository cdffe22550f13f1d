"""Atlas quality (issue 16): tight packing, one texel density, merging, UDIM tiles, upright islands."""
import numpy as np
import pytest

from neuraluv.atlas import build_atlas
from neuraluv.atlas.candidates import chart_candidates, merge_small_charts
from neuraluv.layout import validate_layout
from neuraluv.datasets import sphere
from neuraluv.jacobian import signed_areas_2d
from neuraluv.layout import texel_density, upright
from neuraluv.layout.pack import PACK_TRIALS, raster_pack, shelf_pack, tight_pack


def _shapes(k=12, seed=0):
    rng = np.random.default_rng(seed)
    uvs, fs = [], []
    for _ in range(k):  # L-shaped charts of random sizes: boxes waste space, shapes do not
        s = rng.uniform(0.5, 2.0)
        P = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float) * s
        uvs.append(P)
        fs.append(np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]))
    return uvs, fs


def test_tight_pack_keeps_padding_orientation_and_beats_shelf():
    uvs, fs = _shapes()
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


@pytest.mark.parametrize("method", ["raster", "xatlas"])
def test_tight_pack_places_charts_with_degenerate_triangles_rigidly(method):
    uvs, fs = _shapes(8, seed=3)
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
    uvs, fs = _shapes(10, seed=5)
    for method in ("raster", "xatlas"):
        t = tight_pack(uvs, fs, padding=2, resolution=256, rotate=False, method=method)
        for p, u in zip(t.uvs, uvs):  # upright islands stay upright: p = s u + offset
            assert np.allclose(p - p.mean(0), (u - u.mean(0)) * t.scale, atol=1e-6)  # xatlas: float32 fit


def test_raster_pack_nests_irregular_shapes_fuller_than_boxes():
    # few large L-shapes: the reading-order raster fill beats xatlas's placement of the same shapes
    uvs, fs = _shapes(6, seed=2)
    r = tight_pack(uvs, fs, padding=4, resolution=512, method="raster")
    x = tight_pack(uvs, fs, padding=4, resolution=512, method="xatlas")
    assert r.padding_texels >= 4 and x.padding_texels >= 4
    assert r.utilisation > x.utilisation


def test_perturbed_order_trials_pack_at_least_as_full_and_misses_are_cheap():
    uvs, fs = _shapes(9, seed=4)
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


def test_tight_pack_fixed_density_spills_to_pages():
    uvs, fs = _shapes(20)
    one = tight_pack(uvs, fs, padding=2, resolution=128)
    dense = tight_pack(uvs, fs, padding=2, resolution=128, texel_density=2 * one.scale * 128)
    with pytest.raises(ValueError, match="texels"):
        tight_pack(uvs, fs, padding=2, resolution=128, texel_density=50 * one.scale * 128)
    assert one.pages.max() == 0 and dense.pages.max() >= 1
    for p in range(int(dense.pages.max()) + 1):
        on = [u for u, g in zip(dense.uvs, dense.pages) if g == p]
        assert on and all((u >= 0).all() and (u <= 1).all() for u in on)


def test_upright_lays_main_axis_along_u_without_mirroring():
    rng = np.random.default_rng(1)
    P = rng.normal(size=(50, 2)) * [0.2, 3.0]
    V = np.column_stack([P[:, 0], P[:, 1], np.zeros(50)])  # 3D +Y is the long axis
    r = upright(P, V)
    ext = r.max(0) - r.min(0)
    assert ext[0] > 5 * ext[1]
    M = np.linalg.lstsq(P - P.mean(0), r - r.mean(0), rcond=None)[0]
    assert np.linalg.det(M) > 0  # a rotation, not a reflection


def test_merge_small_charts_keeps_disks_and_covers_once():
    V, F = sphere(2)
    cands = chart_candidates(V, F)
    merged = merge_small_charts(V, F, cands, max_faces=10**9, max_curvature=0.5)
    assert len(merged) <= len(cands)
    allf = np.sort(np.concatenate([f for f, _ in merged]))
    assert np.array_equal(allf, np.arange(len(F)))


def test_atlas_has_one_texel_density_and_udim_tiles_validate():
    V, F = sphere(2)
    res = build_atlas(V, F, "test", resolution=256, padding=2, device="cpu")
    assert res.valid and res.validation["density_spread"] < 0.01
    assert res.info["packer"] == "tight" and res.info["pages"] == 1
    dens = 1.5 * res.info["pack_scale"] * 256 / 2.0  # 1.5 x the density that fits one page (sphere: unit = 2)
    tiled = build_atlas(V, F, "test", resolution=256, padding=2, device="cpu", texel_density=dens)
    assert tiled.info["pages"] > 1 and tiled.valid, tiled.validation
    assert tiled.UV.max() > 1  # UDIM tiles beyond the first
    with pytest.raises(Exception, match="resolution"):
        build_atlas(V, F, "test", resolution=256, padding=2, device="cpu", texel_density=40 * dens)
    with pytest.raises(Exception, match="tight"):
        build_atlas(V, F, "test", resolution=256, padding=2, device="cpu", packer="shelf", texel_density=dens)


def test_island_density_is_scale_of_the_map():
    V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    assert texel_density(V, np.array([[0, 1, 2]]), 3 * V[:, :2]) == pytest.approx(3.0)


def _three_copies():
    from scipy.spatial.transform import Rotation

    V, F = sphere(1)
    R = Rotation.from_euler("xyz", [0.3, 1.0, -0.5]).as_matrix()
    return np.vstack([V, V @ R.T + [3, 0.5, 0], V + [0, 3, 0]]), np.vstack([F, F + len(V), F + 2 * len(V)]), len(F)


def test_stacking_identical_parts_shares_their_place_and_stays_valid():
    V, F, m = _three_copies()
    plain = build_atlas(V, F, "test", resolution=256, padding=2, device="cpu")
    res = build_atlas(V, F, "test", resolution=256, padding=2, device="cpu", stack=True)
    assert plain.validation["stacked_islands"] == 0 and res.valid
    k = res.validation["islands"] // 3
    assert res.validation["stacked_islands"] == 2 * k == res.info["stacked_islands"]
    assert res.validation["overlapping_pairs"] == 0 and res.totals()["flips"] == 0
    # the copies carry exactly the first copy's UVs, face for face
    for c in (1, 2):
        assert np.array_equal(res.UV[res.FUV[c * m:(c + 1) * m]], res.UV[res.FUV[:m]])
    # without stack=True the same layout is three overlaps per place
    val = validate_layout(res.V, res.F, res.UV, res.FUV, padding=2, resolution=256)
    assert val["overlapping_pairs"] == 3 * k and not val["valid"]


def test_stacked_validation_still_catches_partial_overlaps():
    V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2], [0, 1, 2]])
    UV = np.array([[.1, .1], [.4, .1], [.1, .4], [.2, .2], [.5, .2], [.2, .5]])
    on_top = np.array([[.1, .1], [.4, .1], [.1, .4]] * 2)
    FUV = np.array([[0, 1, 2], [3, 4, 5]])
    assert validate_layout(V, F, UV, FUV, stacked=True)["overlapping_pairs"] == 1
    r = validate_layout(V, F, on_top, FUV, stacked=True)
    assert r["overlapping_pairs"] == 0 and r["stacked_islands"] == 1 and r["valid"]


def test_cli_atlas_stack_reads_back_valid(tmp_path, capsys):
    from conftest import write_mesh

    from neuraluv.cli import main

    V, F, _ = _three_copies()
    write_mesh(tmp_path / "in.obj", V, F)
    rc = main(["atlas", str(tmp_path / "in.obj"), "-o", str(tmp_path / "out.obj"), "--preset", "test", "--stack",
               "--resolution", "256", "--padding", "2", "--quiet", "--device", "cpu"])
    out = capsys.readouterr().out
    assert rc == 0 and "islands stacked on identical ones" in out, out


def test_chart_with_a_hole_is_solved_whole_with_a_filler():
    from neuraluv.atlas.candidates import chart_is_disk, chart_mesh
    from neuraluv.atlas.routing import route_charts
    from neuraluv.datasets import disk
    from neuraluv.solver.config import get_config
    from neuraluv.topology import is_disk_like, submesh

    V, F = disk(n_rings=5)
    ring = np.array([f for f in range(len(F)) if 0 not in F[f]])  # an annulus: the centre's fan removed
    vi, Fl = submesh(F, ring)
    assert not is_disk_like(V[vi], Fl)[0] and chart_is_disk(V, F, ring)[0]
    vi, Fl, Vx, Fx = chart_mesh(V, F, ring)
    inner = np.setdiff1d(F[(F == 0).any(1)], [0])  # the hole's rim: the removed centre's neighbours
    assert len(Vx) == 1 and len(Fx) == len(inner) and np.allclose(Vx[0], V[inner].mean(0))
    (c,) = route_charts(V, F, [(ring, "annulus")], get_config("test", iterations=60, retries=0))
    assert c.route == "neural" and len(c.islands) == 1 and c.solver["filled_holes"] == 1
    fidx, vi2, Fl2, uv = c.islands[0]
    assert np.array_equal(fidx, ring) and len(uv) == len(vi2) and c.metrics["flips"] == 0


def test_chart_touching_itself_at_a_vertex_is_split_there_not_cut():
    from neuraluv.atlas.candidates import chart_is_disk, chart_mesh
    from neuraluv.topology import is_disk_like, submesh

    n = 4  # a 4x4 grid of cells; the chart winds round and meets itself at grid vertex (2, 2) only
    V = np.array([[c, r, 0.0] for r in range(n + 1) for c in range(n + 1)])
    vid = lambda r, c: r * (n + 1) + c  # noqa: E731
    cells = [(1, 1), (1, 0), (2, 0), (3, 0), (3, 1), (3, 2), (2, 2)]
    F = []
    for r, c in cells:
        a, b, d, e = vid(r, c), vid(r + 1, c), vid(r, c + 1), vid(r + 1, c + 1)
        F += [[a, d, e], [a, e, b]]
    F = np.array(F)
    chart = np.arange(len(F))
    vi, Fl = submesh(F, chart)
    assert not is_disk_like(V[vi], Fl)[0]
    vi, Fl, Vx, Fx = chart_mesh(V, F, chart)
    assert (vi == vid(2, 2)).sum() == 2 and len(Vx) == 0 and chart_is_disk(V, F, chart)[0]
    # two pieces touching at a vertex are not "holes": no filler, still not a disk
    two = np.array([0, 1, 12, 13])
    vi, Fl, Vx, Fx = chart_mesh(V, F, two)
    assert len(Vx) == 0 and not chart_is_disk(V, F, two)[0]


def test_bench_atlas_quality_cli_writes_the_table(tmp_path, capsys):
    from neuraluv.cli import main

    rc = main(["bench", "atlas-quality", "--quick", "--meshes", "glove", "--quiet", "-o", str(tmp_path)])
    out = capsys.readouterr().out
    assert rc == 0 and "| glove |" in out and "ours + tight" in out
    md = (tmp_path / "atlas_quality.md").read_text()
    assert "Acceptance" in md and "xatlas (own charts + packer)" in md


def test_bench_atlas_quality_generated_from_picks_the_seeds():
    from argparse import Namespace

    from neuraluv_paper.bench.atlas_quality import _assets
    from neuraluv.datasets.generated import generated_asset

    got = _assets(Namespace(meshes=["glove"], quick=False, generated=2, generated_from=7))
    assert [a[0] for a in got] == ["glove", "generated-7", "generated-8"]
    assert np.array_equal(got[2][2], generated_asset(8)[1])


def _strip(n, width=1.0):
    """A long (n,1) strip of 2n triangles in the plane: its own UVs and 3D positions."""
    x = np.repeat(np.arange(n + 1, dtype=float), 2)
    y = np.tile([0.0, width], n + 1)
    uv = np.column_stack([x, y])
    F = np.array([[2 * i, 2 * i + 2, 2 * i + 3] for i in range(n)] + [[2 * i, 2 * i + 3, 2 * i + 1] for i in range(n)])
    return uv, F


def test_granular_islands_cut_only_the_large_islands_into_connected_parts():
    from neuraluv.layout.pack import granular_islands
    from neuraluv.topology import bisect_faces, face_components

    big, Fb = _strip(40)
    small, Fs = _strip(2)
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


def test_tight_pack_cuts_a_dominant_island_only_when_it_packs_fuller():
    from neuraluv.layout.pack import SPLIT_GAIN

    big, Fb = _strip(30, 0.5)  # a 30:0.5 sliver fills a square texture poorly whole
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


def test_atlas_cuts_a_long_island_validly_and_whole_islands_keeps_it(tmp_path, capsys):
    from conftest import write_mesh

    from neuraluv.cli import main

    uv, F = _strip(24, 1.0)  # a flat 24:1 ribbon: one long island, a poor fit for a square texture
    V = np.column_stack([uv, 0.1 * np.sin(uv[:, 0])])
    res = build_atlas(V, F, "test", resolution=256, padding=2)
    whole = build_atlas(V, F, "test", resolution=256, padding=2, cut_islands=False)
    assert whole.info["cut_islands"] == 0 and whole.info["cut"] is False and res.info["cut"] is True
    assert res.info["cut_islands"] > 0 and res.info["utilisation"] >= whole.info["utilisation"] + 0.01
    for r in (res, whole):
        v = r.validation
        assert v["valid"] and v["flips"] == 0 and v["overlapping_pairs"] == 0 and v["padding_violations"] == 0
        assert v["density_spread"] < 0.05  # each part scaled to its own 3D area
    assert res.validation["islands"] == whole.validation["islands"] + res.info["cut_islands"]
    write_mesh(tmp_path / "in.obj", V, F)
    for flag, said in (([], True), (["--whole-islands"], False)):
        rc = main(["atlas", str(tmp_path / "in.obj"), "-o", str(tmp_path / "out.obj"), "--preset", "test",
                   "--resolution", "256", "--padding", "2", "--quiet", "--device", "cpu", *flag])
        out = capsys.readouterr().out
        assert rc == 0 and ("islands added by cutting large ones" in out) == said, out
