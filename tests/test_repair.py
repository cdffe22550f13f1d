"""UV repair with minimal change: diagnosis, local untangling, island moves, new charts, the OBJ patch, the CLI."""
import json

import numpy as np

from neuraluv import datasets
from neuraluv.io import read_obj
from neuraluv.layout import layout_facts
from neuraluv.layout import texel_density as reference_scale
from neuraluv.metrics import distortion_metrics, face_dets
from neuraluv.repair.diagnose import diagnose_layout
from neuraluv.repair.repair import repair_layout
from neuraluv.repair.untangle import polish, untangle
from neuraluv.tutte import tutte
from neuraluv_paper import damage

from conftest import grid, rolled, two_islands


def _flat_disk(n_rings=16):
    V, F = datasets.disk(n_rings)
    UV = tutte(V, F) * 0.4 + 0.5
    # relax to a good map first, so "undamaged" is a meaningful reference
    s = reference_scale(V, F, UV)
    UV, _ = polish(V, F, UV, F, np.arange(len(F)), np.arange(len(V)), scale=s, max_iter=300)
    return V, F, UV


# ---------------------------------------------------------------- building blocks


def test_untangle_only_moves_free_rows_and_leaves_no_flip():
    V, F, UV = _flat_disk()
    bad, info = damage.local_fold(V, F, UV, F, rings=2, seed=1)
    assert info["flipped"] > 0
    dist = damage.row_rings(F, len(V), info["center"], 4)
    free = np.flatnonzero(dist >= 0)
    region = np.flatnonzero(np.isin(F, free).any(1))
    out, uinfo = untangle(V, F, bad, F, region, free, scale=reference_scale(V, F, UV))
    assert uinfo["ok"] and (face_dets(V, F, out) > 0).all()
    fixed = np.setdiff1d(np.arange(len(V)), free)
    assert out[fixed].tobytes() == bad[fixed].tobytes()


def test_polish_lowers_the_energy_without_flipping():
    V, F, UV = _flat_disk()
    rng = np.random.default_rng(3)
    noisy = UV + rng.normal(scale=2e-3, size=UV.shape)
    assert (face_dets(V, F, noisy) > 0).all()
    s = reference_scale(V, F, UV)
    out, info = polish(V, F, noisy, F, np.arange(len(F)), np.arange(len(V)), scale=s)
    assert info["energy_after"] < info["energy_before"]
    assert distortion_metrics(V, F, out)["flips"] == 0


# ---------------------------------------------------------------- diagnosis


def test_diagnosis_names_every_kind_of_problem():
    V, F, UV, FUV, a, b = two_islands()
    assert diagnose_layout(V, F, UV, FUV).ok
    kinds = {}
    uv, _ = damage.mirror_island(UV, FUV, a)
    kinds["mirrored_island"] = uv
    uv, _ = damage.overlap_islands(UV, FUV, a, b)
    kinds["island_overlap"] = uv
    uv, _ = damage.push_out(UV, FUV, a)
    kinds["outside_unit_square"] = uv
    uv = UV.copy()
    uv[FUV[a[0], 0]] = np.nan
    kinds["non_finite_uv"] = uv
    for kind, uv in kinds.items():
        d = diagnose_layout(V, F, uv, FUV)
        assert kind in [p["kind"] for p in d.problems], (kind, [p["kind"] for p in d.problems])
        assert all(p["action"] for p in d.problems)
    FUVm = FUV.copy()
    FUVm[b[:3]] = -1
    d = diagnose_layout(V, F, UV, FUVm)
    assert [p["kind"] for p in d.problems] == ["missing_uv"] and d.problems[0]["faces"] == 3
    text = d.format("x.obj")
    assert "faces without texture coordinates" in text and "new charts" in text


def _wound_strip(turns=1.15, n=60):
    """A straight 3D strip laid out in UV along a circle of more than one turn: every triangle positive,
    the island overlaps itself."""
    t = np.linspace(0, 2 * np.pi * turns, n)
    UV = np.empty((2 * n, 2))
    UV[0::2] = np.c_[np.cos(t), np.sin(t)]
    UV[1::2] = 1.3 * np.c_[np.cos(t), np.sin(t)]
    F = np.array([f for k in range(n - 1) for f in ([2 * k, 2 * k + 1, 2 * k + 2], [2 * k + 1, 2 * k + 3, 2 * k + 2])])
    s = np.r_[0, np.cumsum(np.full(n - 1, 1.15 * np.diff(t)[0]))]
    V = np.zeros((2 * n, 3))
    V[0::2, 0], V[1::2, 0], V[1::2, 1] = s, s, 0.3
    return V, F, UV * 0.3 + 0.5


def test_the_compiled_untangle_energy_is_the_numpy_one():
    """numba's loop (the ``fast`` extra) and the NumPy form give the same energy, gradient and smallest det on a
    folded region, so an untangle does not depend on whether numba is installed (beyond rounding)."""
    import pytest

    from neuraluv.lazy import HAS_NUMBA
    from neuraluv.repair.kernels import untangle_kernels as _kernels
    from neuraluv.repair.untangle import RegionEnergy, untangle_energy

    if not HAS_NUMBA:
        pytest.skip("numba is not installed (the optional extra `fast`): only the NumPy energy runs here")
    V, F, UV = _flat_disk(8)
    bad, info = damage.local_fold(V, F, UV, F, rings=2, seed=3)
    free = np.flatnonzero(damage.row_rings(F, len(V), info["center"], 3) >= 0)
    region = np.flatnonzero(np.isin(F, free).any(1))
    R = RegionEnergy.build(V, F, F, region, free, reference_scale(V, F, UV))
    x = bad[R.free].reshape(-1)
    for eps in (1.0, 1e-2, 1e-6):
        E0, g0, d0 = untangle_energy(R, bad, x, 0.5, eps)
        E1, g1, d1 = _kernels()[0](bad, R.T, R.K, R.w, R.slot, len(R.free), x, 0.5, eps)
        assert d0 < 0 and d1 == d0
        assert np.isclose(E1, E0, rtol=1e-12) and np.allclose(g1, g0, rtol=1e-10, atol=1e-12 * np.abs(g0).max())


def test_the_compiled_polish_takes_the_numpy_polish_steps(monkeypatch):
    """numba's polish (energy, flip-free step bound, L-BFGS) runs the NumPy polish's iterations: the same number
    of steps, the same energies and map to rounding, on a region with a fixed boundary."""
    import pytest

    import neuraluv.repair.untangle as un
    from neuraluv.lazy import HAS_NUMBA
    from neuraluv.metrics import distortion_metrics

    if not HAS_NUMBA:
        pytest.skip("numba is not installed (the optional extra `fast`): only the NumPy polish runs here")
    V, F, UV = _flat_disk(8)
    UV = UV + 0.02 * np.sin(7 * UV[:, ::-1])  # a valid map with distortion to lower
    free = np.flatnonzero(np.linalg.norm(UV - UV.mean(0), axis=1) < 0.25)
    region = np.flatnonzero(np.isin(F, free).any(1))
    s = reference_scale(V, F, UV)
    outs = {}
    for compiled in (False, True):
        monkeypatch.setattr(un, "COMPILED_FROM", 1 if compiled else 10**9)
        outs[compiled] = un.polish(V, F, UV, F, region, free, scale=s)
    (a, ia), (b, ib) = outs[False], outs[True]
    assert ia["iterations"] == ib["iterations"] > 5 and ia["converged"] == ib["converged"]
    assert np.isclose(ia["energy_after"], ib["energy_after"], rtol=1e-9) and ia["energy_after"] < ia["energy_before"]
    assert np.allclose(a, b, atol=1e-9) and distortion_metrics(V, F, b)["flips"] == 0
    fixed = np.setdiff1d(np.arange(len(UV)), free)
    assert np.array_equal(b[fixed], UV[fixed])  # only the free rows move


def test_self_overlap_without_flips_is_found_and_repaired():
    V, F, UV = _wound_strip()
    f = layout_facts(V, F, UV, F)
    assert (f.det > 0).all()
    d = diagnose_layout(V, F, UV, F)
    assert [p["kind"] for p in d.problems] == ["self_overlap"]
    res = repair_layout(V, F, UV, F, preset="test")
    assert res.after.validation["valid"], res.after.validation


# ---------------------------------------------------------------- repair: minimal change


def test_local_fold_is_repaired_locally():
    V, F, UV = _flat_disk()
    bad, info = damage.local_fold(V, F, UV, F, rings=2, seed=0)
    res = repair_layout(V, F, bad, F)
    assert res.before.validation["flips"] > 0 and res.after.validation["valid"]
    same = (res.UV[res.FUV] == bad[F]).all(axis=(1, 2))
    damaged = (bad[F] != UV[F]).any(axis=(1, 2))
    assert (~same).sum() <= 4 * damaged.sum() and same.mean() >= 0.85  # the repair stays near the damage
    assert res.islands[0]["actions"][0]["step"].startswith("untangle")
    s = reference_scale(V, F, UV)
    e0 = distortion_metrics(V, F, UV / s)["esd"]
    e1 = distortion_metrics(V, F, res.UV / s, res.FUV)["esd"]
    assert e1 <= 1.05 * e0


def test_a_fold_on_a_regular_layout_changes_only_the_faces_the_damage_touched():
    # a grid mapped to itself (rolled onto a quarter of a cylinder, so that no planar projection made the map: a
    # fold of one is put back onto it, test_projection.py): the rows the fold moved are the only ones whose every
    # face is distorted, and freeing exactly those (not the ring around them) leaves every face the damage did
    # not touch bit-identical
    n = 12
    V, F = grid(n, n)
    UV = V[:, :2] / n
    V = rolled(V, n)
    for rings in (1, 2):
        bad, _ = damage.local_fold(V, F, UV, F, rings=rings, seed=0)
        res = repair_layout(V, F, bad, F, purpose="texture")
        damaged = (bad != UV).any(1)[F].any(1)
        assert res.before.validation["flips"] > 0 and res.after.ok
        assert res.changed_faces.any() and not (res.changed_faces & ~damaged).any()
        assert res.islands[0]["actions"][0]["rings"] == -2


def test_a_fold_beside_a_band_the_artist_stretched_leaves_the_band_along_its_length():
    # the artist squeezed columns 5-8 of a grid eightfold in u; a fold next to them is repaired without re-solving
    # the squeezed band along its whole length (its faces read as "stretched neighbours" of the fold: at c73eee0's
    # rule, 112-115 faces the damage did not touch changed, from the bottom row to the top)
    n = 12
    V, F = grid(n, n)
    UV = np.c_[np.interp(V[:, 0], [0, 5, 8, n], [0, 5, 5 + 3 / 8, 5 + 3 / 8 + n - 8]), V[:, 1]] / n
    cy = V[F, 1].mean(1)
    for seed in (1, 2, 3):
        bad, info = damage.local_fold(V, F, UV, F, rings=1, seed=seed, rows=np.array([4 + (n + 1) * 6]))
        assert info["flipped"] > 0
        res = repair_layout(V, F, bad, F, purpose="texture")
        damaged = (bad != UV).any(1)[F].any(1)
        assert res.after.ok
        far = (cy < cy[damaged].min() - 3.5) | (cy > cy[damaged].max() + 3.5)  # more than 3 rows from the damage
        assert not (res.changed_faces & far).any()


def test_mirrored_island_is_reflected_not_resolved():
    V, F, UV, FUV, a, b = two_islands()
    uv, _ = damage.mirror_island(UV, FUV, a)
    res = repair_layout(V, F, uv, FUV)
    assert res.after.validation["valid"]
    steps = [s["step"] for s in res.islands[0]["actions"]]
    assert steps == ["reflected"]
    assert np.allclose(res.UV[np.unique(FUV[a])], UV[np.unique(FUV[a])], atol=1e-12)  # back where it was
    assert res.UV[np.unique(FUV[b])].tobytes() == UV[np.unique(FUV[b])].tobytes()


def test_overlapping_islands_move_only_one_without_scaling():
    V, F, UV, FUV, a, b = two_islands()
    uv, _ = damage.overlap_islands(UV, FUV, a, b)
    res = repair_layout(V, F, uv, FUV, padding=2.0, resolution=1024)
    v = res.after.validation
    assert v["valid"] and v["overlapping_pairs"] == 0
    moved = [i for i in res.islands if i["actions"]]
    assert len(moved) == 1 and moved[0]["actions"][0]["scale"] == 1.0
    other = b if moved[0]["island"] == 0 else a
    assert res.UV[np.unique(FUV[other])].tobytes() == uv[np.unique(FUV[other])].tobytes()
    # rigid: edge lengths of the moved island unchanged
    mv = a if moved[0]["island"] == 0 else b
    e0 = np.linalg.norm(uv[FUV[mv, 1]] - uv[FUV[mv, 0]], axis=1)
    e1 = np.linalg.norm(res.UV[res.FUV[mv, 1]] - res.UV[res.FUV[mv, 0]], axis=1)
    assert np.allclose(e0, e1, rtol=1e-9)


def test_island_outside_the_square_is_moved_in():
    V, F, UV, FUV, a, b = two_islands()
    uv, _ = damage.push_out(UV, FUV, b, shift=(0.5, 0.0))
    res = repair_layout(V, F, uv, FUV)
    assert res.after.validation["valid"] and res.after.validation["uv_in_unit_square"]


def test_nan_and_missing_uvs_get_new_charts_and_the_rest_is_untouched():
    V, F, UV, FUV, a, b = two_islands()
    uv = UV.copy()
    rows = np.unique(FUV[a[:4]])
    uv[rows[0]] = np.nan
    res = repair_layout(V, F, uv, FUV, preset="test")
    assert res.after.validation["valid"] and res.new_charts
    assert res.UV[np.unique(FUV[b])].tobytes() == uv[np.unique(FUV[b])].tobytes()
    FUVm = FUV.copy()
    FUVm[b[:5]] = -1
    res = repair_layout(V, F, UV, FUVm, preset="test")
    assert res.after.validation["valid"] and res.after.validation["covered_faces"] == len(F)


def test_a_valid_layout_comes_back_unchanged():
    V, F, UV, FUV, a, b = two_islands()
    res = repair_layout(V, F, UV, FUV)
    assert res.unchanged and res.UV.tobytes() == UV.tobytes() and "nothing to repair" in res.summary()


def test_neural_step_pins_the_ring():
    from neuraluv.repair.local import neural_region

    V, F, UV = _flat_disk()
    s = reference_scale(V, F, UV)
    dist = damage.row_rings(F, len(V), int(np.argmin(np.linalg.norm(V, axis=1))), 3)
    free = np.flatnonzero(dist >= 0)
    region = np.flatnonzero(np.isin(F, free).any(1))
    noisy = UV.copy()
    noisy[free] += np.random.default_rng(0).normal(scale=1e-3, size=(len(free), 2))
    assert (face_dets(V, F, noisy) > 0).all()
    out, res = neural_region(V, F, noisy, F, region, free, s, "test", device="cpu")
    pinned = np.setdiff1d(np.unique(F[region]), free)
    assert len(pinned) and out[pinned].tobytes() == noisy[pinned].tobytes()
    assert res.status == "neural" and (face_dets(V, F, out) > 0).all()
    assert not np.array_equal(out[free], noisy[free])


# ---------------------------------------------------------------- the OBJ patch and the CLI


def test_patch_obj_keeps_every_other_line(tmp_path):
    from neuraluv.io import patch_obj

    src = tmp_path / "in.obj"
    text = ("# header\r\nmtllib x.mtl\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nvn 0 0 1\r\n"
            "vt 0.1 0.1\r\nvt 0.4 0.1\r\nvt 0.4 0.4\r\nvt 0.1 0.4\r\ng quad\r\nusemtl m\r\n"
            "f 1/1/1 2/2/1 3/3/1 4/4/1 # a quad\r\nf -4/-4/1 -3/-3/1 -1/-1/1\r\n")
    src.write_bytes(text.encode())
    data = read_obj(src, keep_lines=True)
    V, F, UV, FUV = data
    # unchanged: identical bytes
    patch_obj(src, tmp_path / "same.obj", UV, FUV, data=data)
    assert (tmp_path / "same.obj").read_bytes() == src.read_bytes()
    # one row moved, one face given new rows
    UV2 = np.vstack([UV, [[0.7, 0.7], [0.9, 0.7], [0.9, 0.9]]])
    UV2[0] = [0.12, 0.1]
    FUV2 = FUV.copy()
    FUV2[2] = [4, 5, 6]
    info = patch_obj(src, tmp_path / "new.obj", UV2, FUV2, data=data)
    assert info == {"vt_lines_changed": 1, "vt_lines_added": 3, "f_lines_changed": 1, "polygons_split": 0}
    out = (tmp_path / "new.obj").read_bytes().decode()
    for keep in ("# header\r\n", "mtllib x.mtl\r\n", "vn 0 0 1\r\n", "g quad\r\n", "usemtl m\r\n",
                 "f 1/1/1 2/2/1 3/3/1 4/4/1 # a quad\r\n"):
        assert keep in out
    V3, F3, UV3, FUV3 = read_obj(tmp_path / "new.obj")
    assert np.array_equal(F3, F) and np.array_equal(FUV3, FUV2) and np.array_equal(UV3, UV2)




def test_check_text_shows_a_few_of_each_kind_counts_the_rest_and_ends_with_a_summary():
    from neuraluv.repair.diagnose import UVDiagnosis
    probs = [dict(kind="island_overlap", islands=[i, i + 1], message=f"islands {i} and {i + 1} overlap",
                  action="move one") for i in range(40)]
    probs.append(dict(kind="mirrored_island", island=3, message="mirrored island", action="reflect it"))
    d = UVDiagnosis(faces=100, islands=[], problems=probs, warnings=[], validation={})
    text = d.format("x.obj").splitlines()
    assert sum(ln.startswith("  problem: islands") for ln in text) == 5
    assert any("35 more problems of this kind (island_overlap" in ln for ln in text)
    assert any("mirrored island" in ln for ln in text)
    assert text[-1].startswith("summary: 41 problems (island_overlap 40; mirrored_island 1), 0 warnings")
    assert sum(ln.startswith("  problem:") for ln in d.format("x.obj", limit=None).splitlines()) == 41


def test_an_island_re_solved_as_a_chart_leaves_its_faces_without_3d_area_as_they_are():
    # wallhole.obj (trimesh's tests): a re-solved island holding a face with no 3D area made the router
    # return non-finite UVs for it and the rigid fit fail (internal error "SVD did not converge")
    from neuraluv import datasets
    from neuraluv.repair.local import resolve_as_chart
    from neuraluv.solver.config import get_config
    V, F = datasets.spherical_cap(2)
    V = np.vstack([V, V[F[0, 0]]])  # a sliver with no 3D area: two corners at one place
    F = np.vstack([F, [F[0, 0], F[0, 1], len(V) - 1]])
    UV = np.vstack([V[:, :2], [[0.3, 0.3]]])
    faces = np.arange(len(F))
    UV2, FUV2, info = resolve_as_chart(V, F, UV, F.copy(), faces, 1.0, get_config("test"), seed=0, device="cpu",
                                       deadline=None)
    assert info["pieces"] and np.isfinite(UV2[FUV2]).all()
    assert np.array_equal(FUV2[-1], F[-1]) and np.array_equal(UV2[F[-1]], UV[F[-1]])  # the sliver keeps its UVs


def test_the_time_budget_bounds_moving_islands_one_by_one():
    # issue 31: Blender's Lightmap Pack layout of spot under a bake's rules moved 2,868 islands one FFT search at a
    # time for 236 s against --time-budget 30; past the budget the rest are not searched for: the layout is
    # repacked (valid), and the report says why
    rng = np.random.default_rng(0)
    tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    k = 60
    V = np.vstack([np.c_[tri, np.zeros(3)] + [3 * i, 0, 0] for i in range(k)])
    F = np.arange(3 * k).reshape(-1, 3)
    UV = np.vstack([tri * 0.05 + rng.random(2) * 0.5 for _ in range(k)])  # 60 triangles piled onto each other
    res = repair_layout(V, F, UV, F, "test", device="cpu", time_budget=1e-9)
    assert res.after.validation["valid"] and res.repacked
    assert "time budget" in res.summary()
    slow = repair_layout(V, F, UV, F, "test", device="cpu")
    assert slow.after.ok and not slow.repacked  # without a budget: moved one by one (padding kept only by movers)


def test_an_overlap_below_the_texel_tolerance_is_noted_and_left_alone(tmp_path, capsys):
    """Issue 31: minimal means minimal. Two islands touching by a sliver no texture shows (well below half a
    texel at 1024²): check notes it, repair leaves the file byte-identical, the read-back agrees; with
    --min-defect 0 the same sliver is a problem that repair fixes."""
    from conftest import grid, two_islands, write_layout
    from neuraluv.cli import main
    from neuraluv.layout.facts import layout_facts

    V, F, UV, FUV, a, b = two_islands()
    rows_b = np.unique(FUV[b])
    gap = UV[rows_b, 0].min() - UV[np.unique(FUV[a]), 0].max()
    UV[rows_b, 0] -= gap + 2e-5  # the right island pushed 2e-5 into the left one
    area = layout_facts(V, F, UV, FUV).overlaps()[2].sum()
    assert 0 < area * 1024 ** 2 < 0.5
    src = tmp_path / "sliver.obj"
    write_layout(src, V, F, UV, FUV)
    assert main(["check", "--uv", str(src), "--purpose", "bake", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["ok"] and [w["kind"] for w in d["warnings"]].count("subtexel_overlap") == 1
    assert main(["repair", str(src), "-o", str(tmp_path / "same.obj"), "--purpose", "bake", "--device", "cpu"]) == 0
    assert (tmp_path / "same.obj").read_bytes() == src.read_bytes()
    capsys.readouterr()
    assert main(["check", "--uv", str(src), "--purpose", "bake", "--min-defect", "0", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert [p["kind"] for p in d["problems"]] == ["island_overlap"]
    assert main(["repair", str(src), "-o", str(tmp_path / "moved.obj"), "--purpose", "bake", "--min-defect", "0",
                 "--device", "cpu", "--report", str(tmp_path / "r.json")]) == 0
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["readback"]["valid"] and r["readback"]["overlapping_pairs"] == 0


def test_repair_stops_at_its_time_budget_and_says_what_it_left():
    """Issue 31: every long loop of repair checks the deadline. With the budget already spent, nothing is searched
    for: the fold is left as it was and the summary says so (the texture purpose's shells likewise)."""
    from neuraluv.datasets import disk

    V, F = disk(5)
    UV = tutte(V, F) * 0.4 + 0.5
    UV[0] += [0.3, 0.0]  # fold the centre over its ring
    for purpose in ("bake", "texture"):
        r = repair_layout(V, F, UV, F, "test", device="cpu", purpose=purpose, time_budget=1e-9)
        assert r.changed_faces.sum() == 0
        assert any(a["step"] == "left undone" for i in r.islands for a in i["actions"])
        assert "the time budget ran out" in r.summary()
    r = repair_layout(V, F, UV, F, "test", device="cpu", purpose="bake")
    assert r.after.ok and r.changed_faces.sum() > 0  # with time, the same fold is repaired


def test_a_fold_below_the_texel_tolerance_is_noted_and_left_alone(tmp_path, capsys):
    """Issue 31: a fold no texture shows (one corner triangle turned over by 0.15 texels at 1024²) is a warning
    under both purposes and the file comes back byte-identical; with --min-defect 0 it is a problem, repaired."""
    from conftest import write_layout
    from neuraluv.cli import main

    n = 4
    u, v = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    V = np.c_[u.ravel(), v.ravel(), 0.3 * (u.ravel() - 0.5) ** 2]
    k = np.arange(n * (n + 1)).reshape(n, n + 1)[:, :n].ravel()
    F = np.r_[np.c_[k, k + 1, k + n + 2], np.c_[k, k + n + 2, k + n + 1]]
    UV = V[:, :2] * 0.4 + 0.1
    c = n  # the corner vertex in one triangle only, pushed just across its opposite edge
    t = F[np.flatnonzero((F == c).any(1))[0]]
    a, b = [x for x in t if x != c]
    d = (UV[b] - UV[a]) / np.linalg.norm(UV[b] - UV[a])
    foot = UV[a] + d * ((UV[c] - UV[a]) @ d)
    UV[c] = foot - (UV[c] - foot) / np.linalg.norm(UV[c] - foot) * 2e-6
    src = tmp_path / "corner.obj"
    write_layout(src, V, F, UV, F)
    for purpose in ("texture", "bake"):
        assert main(["check", "--uv", str(src), "--purpose", purpose, "--json"]) == 0
        d = json.loads(capsys.readouterr().out)
        assert d["ok"] and "subtexel_fold" in {w["kind"] for w in d["warnings"]}, (purpose, d["problems"])
        assert main(["repair", str(src), "-o", str(tmp_path / "same.obj"), "--purpose", purpose, "--device", "cpu"]) == 0
        assert (tmp_path / "same.obj").read_bytes() == src.read_bytes()
        capsys.readouterr()
    assert main(["check", "--uv", str(src), "--min-defect", "0", "--json"]) == 0
    assert "folded_faces" in {p["kind"] for p in json.loads(capsys.readouterr().out)["problems"]}
    assert main(["repair", str(src), "-o", str(tmp_path / "fixed.obj"), "--min-defect", "0", "--device", "cpu",
                 "--report", str(tmp_path / "r.json")]) == 0
    assert json.loads((tmp_path / "r.json").read_text())["readback"]["valid"]


def test_double_sided_faces_without_uvs_are_charted_once():
    # every face again with the opposite winding (double-sided geometry) and no UVs: charted with their twins,
    # every edge has four faces and the router cut the surface into a chart per face (chair_model.obj: 960
    # charts). The front faces are charted; a back face takes its front face's rows (texture: the same texels,
    # read mirrored, as an artist's double-sided face does) or a reflected copy of them (bake: unique, unmirrored).
    V, F = grid(6, 4)
    V = np.c_[V[:, :2], 0.1 * np.sin(V[:, 0])]
    F2 = np.r_[F, F[:, ::-1]]
    UV = np.full((len(V), 2), np.nan)
    tex = repair_layout(V, F2, UV, F2, purpose="texture", device="cpu", preset="test")
    assert tex.after.validation["valid"] and tex.after.validation["islands"] == 1
    assert tex.after.validation["mirrored_shell_faces"] == len(F)
    twins = [c for c in tex.new_charts if c["route"] == "twin"]
    assert len(tex.new_charts) == 2 and twins[0]["faces"] == len(F)
    bake = repair_layout(V, F2, UV, F2, purpose="bake", device="cpu", preset="test")
    v = bake.after.validation
    assert v["valid"] and v["islands"] == 2 and v["mirrored_islands"] == 0 and v["overlapping_pairs"] == 0


def test_a_bake_layout_collapsed_along_lines_is_recharted_on_the_mesh():
    # every face with two corners on one row (an island collapsed along lines, as a palette collapses a region): the
    # rows say nothing of the surface, and re-solving the island on them ended in "SVD did not converge"; the
    # island has no UV area, so it gets new charts on the mesh's vertices, on new rows, as faces without UVs do
    V, F = grid(8, 3)
    V = np.c_[V[:, :2], 0.1 * np.sin(V[:, 0])]
    FUV = F.copy()
    FUV[:, 1] = FUV[:, 0]
    res = repair_layout(V, F, V[:, :2] / 10 + 0.1, FUV, purpose="bake", device="cpu", preset="test")
    assert res.after.validation["valid"] and np.isfinite(res.UV).all()
    assert "new charts" in [a["step"] for i in res.islands for a in i["actions"]] and res.new_charts
    assert len(res.UV) > len(V) and (res.FUV >= len(V)).all()
