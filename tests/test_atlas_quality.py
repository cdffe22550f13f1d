"""Atlas quality (issue 16): tight packing, one texel density, merging, UDIM tiles, upright islands."""
import numpy as np
import pytest

from neuraluv.atlas import build_atlas
from neuraluv.atlas.candidates import chart_candidates, merge_small_charts
from neuraluv.atlas.validate import validate_atlas
from neuraluv.datasets import sphere
from neuraluv.jacobian import signed_areas_2d
from neuraluv.packing import island_density, shelf_pack, tight_pack, upright


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
        val = validate_atlas(V, F, UV, F, padding=pad, resolution=res)
        assert val["valid"], val  # no flip (no mirrored island), no overlap, gaps >= padding, inside [0,1]^2
        assert (UV >= pad / res * (1 - 1e-6)).all() and (UV <= 1 - pad / res * (1 - 1e-6)).all()
        assert t.utilisation > s.utilisation
        # one common scale: every chart keeps its relative size
        ratios = [np.sqrt(np.abs(signed_areas_2d(p, f)).sum() / np.abs(signed_areas_2d(u, f)).sum())
                  for p, u, f in zip(t.uvs, uvs, fs)]
        assert np.ptp(ratios) < 1e-9 * max(ratios)


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
    dens = 2 * res.info["pack_scale"] * 256 / 2.0  # twice the density that fits one page (sphere: unit = 2)
    tiled = build_atlas(V, F, "test", resolution=256, padding=2, device="cpu", texel_density=dens)
    assert tiled.info["pages"] > 1 and tiled.valid, tiled.validation
    assert tiled.UV.max() > 1  # UDIM tiles beyond the first
    with pytest.raises(Exception, match="resolution"):
        build_atlas(V, F, "test", resolution=256, padding=2, device="cpu", texel_density=40 * dens)
    with pytest.raises(Exception, match="tight"):
        build_atlas(V, F, "test", resolution=256, padding=2, device="cpu", packer="shelf", texel_density=dens)


def test_island_density_is_scale_of_the_map():
    V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    assert island_density(3 * V[:, :2], V, np.array([[0, 1, 2]])) == pytest.approx(3.0)
