"""Atlas construction: repair, candidates, routing, fallbacks, packing, validation, export, CLI.

Every atlas test validates the exported file after reading it back.
"""
import json

import numpy as np
import pytest

from neuraluv.atlas import (
    FALLBACK_MAX_ESD, build_atlas, chart_candidates, fallback_islands, pca_uv, per_face_uv, prepare_mesh, read_atlas,
    route_chart, tutte_slim_uv, write_atlas,
)
from neuraluv.layout import boundary_is_simple, self_overlap, uv_islands
from neuraluv.layout import validate_layout
from neuraluv.datasets import disk, sphere, spherical_cap
from neuraluv.datasets.generated import add_nonmanifold, flip_windings, generated_asset, unweld
from neuraluv.metrics import distortion_metrics
from neuraluv.solver import get_config
from neuraluv.topology import bisect_faces, is_disk_like, topology_scan
from neuraluv.tutte import tutte

FAST = dict(preset="test", iterations=30, resolution=512, padding=4, threads=1, device="cpu")


def _readback_ok(res, path):
    write_atlas(path, res.V, res.F, res.UV, res.FUV)
    V, F, UV, FUV = read_atlas(path)
    assert len(F) == len(res.F)
    v = validate_layout(V, F, UV, FUV, padding=res.info["padding"], resolution=res.info["resolution"])
    assert v["covered_faces"] == len(res.F)
    assert v["flips"] == 0
    assert v["overlapping_pairs"] == 0 and v["self_overlapping_islands"] == 0
    assert v["uv_in_unit_square"]
    assert v["padding_violations"] == 0
    assert v["valid"]
    return v


def test_prepare_mesh_welds_orients_and_splits():
    V, F = sphere(1)
    V2, F2 = add_nonmanifold(V, flip_windings(F, 0.3, np.random.default_rng(1)), n=2)
    V3, F3 = unweld(V2, F2)
    assert not topology_scan(V3, F3).oriented or topology_scan(V3, F3).components > 1
    Vr, Fr, vmap, info = prepare_mesh(V3, F3)
    t = topology_scan(Vr, Fr)
    assert t.oriented and t.manifold
    assert info["repair"]["merged_vertices"] > 0 and info["reoriented_faces"] > 0 and info["split_vertices"] > 0
    np.testing.assert_array_equal(Vr, V3[vmap])
    assert len(Fr) == len(F3)  # nothing degenerate was added


def test_candidates_are_disks_and_cover_every_face_once():
    V, F, _ = generated_asset(0, res=14)
    Vr, Fr, _, _ = prepare_mesh(V, F)
    cands = chart_candidates(Vr, Fr)
    faces = np.concatenate([f for f, _ in cands])
    assert np.array_equal(np.sort(faces), np.arange(len(Fr)))
    from neuraluv.atlas.candidates import chart_mesh

    for f, src in cands:  # disks once their holes are filled and bow-ties split (what the solver is given)
        vi, Fl, Vx, Fx = chart_mesh(Vr, Fr, f)
        ok, why = is_disk_like(np.vstack([Vr[vi], Vx]), np.vstack([Fl, Fx]))
        assert ok, (src, why)
    assert any("xatlas" in s for _, s in cands)  # the closed surface needed seams


def test_bisect_and_fallbacks_are_flip_free():
    V, F = spherical_cap(n_rings=6, angle=0.95 * np.pi)  # nearly a sphere: PCA folds
    assert distortion_metrics(V, F, pca_uv(V, F))["flips"] > 0
    parts = bisect_faces(V, F, np.arange(len(F)))
    assert sum(map(len, parts)) == len(F) and len(parts) >= 2
    for uv, f in zip(per_face_uv(V, F[:5]), F[:5]):
        assert distortion_metrics(V[f], np.array([[0, 1, 2]]), uv)["esd"] == pytest.approx(4.0)
    # the fallback chain: PCA folds and the Tutte + SLIM map of a nearly closed cap is too
    # distorted, so the chart is split until every piece flattens validly
    method, islands, why = fallback_islands(V, F, np.arange(len(F)), "forced")
    assert method in ("split", "per-face") and len(islands) > 1 and why == "forced"
    for fidx, vi, Fl, uv in islands:
        assert distortion_metrics(V[vi], Fl, uv)["flips"] == 0
        assert self_overlap(uv, Fl) == 0.0
    assert sorted(np.concatenate([isl[0] for isl in islands]).tolist()) == list(range(len(F)))
    # with no distortion limit the whole cap is one injective (if stretched) island
    method, islands, _ = fallback_islands(V, F, np.arange(len(F)), "forced", max_esd=np.inf)
    assert method == "tutte-slim" and len(islands) == 1


def test_fallback_keeps_a_folding_chart_whole_with_tutte_slim():
    V, F = spherical_cap(n_rings=6, angle=0.7 * np.pi)  # past the equator: PCA folds
    assert distortion_metrics(V, F, pca_uv(V, F))["flips"] > 0
    method, islands, _ = fallback_islands(V, F, np.arange(len(F)), "forced")
    assert method == "tutte-slim" and len(islands) == 1
    fidx, vi, Fl, uv = islands[0]
    m = distortion_metrics(V[vi], Fl, uv)
    assert m["flips"] == 0 and self_overlap(uv, Fl) == 0.0 and boundary_is_simple(uv, Fl)
    assert m["esd"] <= FALLBACK_MAX_ESD
    Vt, Ft = V[vi], Fl  # SLIM lowered the Tutte map's distortion
    assert m["esd"] < distortion_metrics(Vt, Ft, tutte(Vt, Ft))["esd"]
    # a chart that is not a disk (a closed sphere) has no Tutte island
    Vs, Fs = sphere(1)
    assert tutte_slim_uv(Vs, Fs, np.arange(len(Fs))) is None


def test_route_chart_neural_on_a_disk():
    V, F = disk(n_rings=4)
    ch = route_chart(V, F, np.arange(len(F)), get_config("test", iterations=10, retries=0))
    assert ch.route == "neural" and ch.method == "neural" and ch.reason == ""
    assert ch.metrics["flips"] == 0 and ch.solver["status"] == "neural"


def test_atlas_closed_sphere_obj_readback(tmp_path):
    res = build_atlas(*sphere(2), **FAST)
    t = res.totals()
    assert t["coverage"] == 1.0 and t["flips"] == 0
    assert t["neural_share"] >= 0.8
    v = _readback_ok(res, tmp_path / "sphere.obj")
    assert v["islands"] == t["islands"] >= 2
    rep = json.loads(json.dumps(res.report()))
    assert {"route", "reason", "metrics", "time"} <= set(rep["charts"][0])


def test_atlas_generated_messy_glb_readback(tmp_path):
    V, F, info = generated_asset(2, res=16)  # soup, flips, slivers, fragments, non-manifold
    res = build_atlas(V, F, **FAST)
    t = res.totals()
    assert t["covered_faces"] == t["repaired_faces"] and t["flips"] == 0
    assert all(c.reason for c in res.charts if c.route == "fallback")  # every fallback says why
    _readback_ok(res, tmp_path / "gen.glb")
    _readback_ok(res, tmp_path / "gen.obj")


def test_atlas_xatlas_packer(tmp_path):
    res = build_atlas(*sphere(1), packer="xatlas", **FAST)
    assert 0 < res.info["utilisation"] <= 1
    _readback_ok(res, tmp_path / "x.obj")


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


def test_bad_inputs_are_refused_or_valid(tmp_path):
    from neuraluv.errors import NeuralUVError

    with pytest.raises(NeuralUVError):
        build_atlas(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]]), **FAST)
    with pytest.raises(NeuralUVError):
        build_atlas(np.array([[0.0, 0, 0], [1, 0, np.nan], [0, 1, 0]]), np.array([[0, 1, 2]]), **FAST)
    huge = np.array([[0.0, 0, 0], [1e300, 0, 0], [0, 1e300, 0], [1e300, 1e300, 1e290]])
    res = build_atlas(huge, np.array([[0, 1, 2], [1, 3, 2]]), **FAST)
    _readback_ok(res, tmp_path / "huge.obj")


def test_cli_check_atlas_and_errors(tmp_path, capsys):
    from neuraluv.cli import main
    from neuraluv.io import write_obj

    V, F, _ = generated_asset(7, res=14)
    src = tmp_path / "in.obj"
    write_obj(src, V, F, np.zeros((len(V), 2)))
    assert main(["check", str(src), "--json"]) == 0
    chk = json.loads(capsys.readouterr().out)
    kinds = {f["kind"] for f in chk["findings"]}
    assert {"non-manifold edges", "duplicate faces"} <= kinds
    assert all(f["meaning"] and f["repair"] for f in chk["findings"])
    out, rep = tmp_path / "a.obj", tmp_path / "a.json"
    rc = main(["atlas", str(src), "-o", str(out), "--report", str(rep), "--preset", "test", "--iterations", "10",
               "--resolution", "512", "--threads", "1", "--quiet"])
    assert rc == 0
    r = json.loads(rep.read_text())
    assert r["ok"] and r["readback"]["flips"] == 0 and r["readback"]["covered_faces"] == r["totals"]["repaired_faces"]
    t = r["totals"]
    assert abs(t["neural_share"] + t["exact_share"] + t["fallback_share"] - 1) < 1e-12
    capsys.readouterr()
    (tmp_path / "empty.obj").write_text("")
    assert main(["atlas", str(tmp_path / "empty.obj"), "-o", str(tmp_path / "e.obj")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "empty" in err[0]
    assert main(["atlas", str(src), "-o", str(tmp_path / "e.png")]) == 2


def test_renders_route_figure(tmp_path):
    pytest.importorskip("pyvista")
    from neuraluv.atlas import save_renders

    V, F, _ = generated_asset(2, res=16)  # messy: neural charts, exact strips and fallbacks
    res = build_atlas(V, F, **FAST)
    assert (res.face_route == 1).any() and len(np.unique(res.face_route)) >= 2
    paths = save_renders(res, tmp_path)
    assert [p.stem for p in paths] == ["atlas_checkerboard", "atlas_routes", "atlas_density"]
    assert all(p.exists() and p.stat().st_size > 1000 for p in paths)


def test_slivers_are_removed_and_counted():
    V, F = disk(n_rings=3)
    a, b = F[0][:2]
    needle = 0.5 * (V[a] + V[b]) + [0, 0, 1e-9]  # a fin 1e-9 high on an edge
    V2 = np.vstack([V, needle])
    F2 = np.vstack([F, [[b, a, len(V)]]])
    Vr, Fr, vmap, info = prepare_mesh(V2, F2)
    assert info["sliver_faces"] == 1 and len(Fr) == len(F)
    _, _, _, info = prepare_mesh(V2, F2, min_height=0)
    assert info["sliver_faces"] == 0


def test_repack_changes_only_the_placement(tmp_path):
    """Repacking (another packer, another padding) keeps every island's shape and its validity."""
    from neuraluv.atlas import repack

    res = build_atlas(*sphere(1), **FAST, cut_islands=False)  # whole islands, as the xatlas packer keeps them
    again = repack(res, "xatlas", padding=8)
    assert again.info["packer"] == "xatlas" and again.info["padding"] == 8
    _readback_ok(again, tmp_path / "repacked.obj")
    assert len(again.charts) == len(res.charts) and again.charts is res.charts  # no re-solve
    n0, lab0 = uv_islands(res.FUV)
    n1, lab1 = uv_islands(again.FUV)
    assert n0 == n1
    # each island moved rigidly and was scaled uniformly: its edge-length ratios are unchanged
    for i in range(n0):
        f0 = np.flatnonzero(lab0 == i)
        j = lab1[f0[0]]
        assert np.array_equal(np.flatnonzero(lab1 == j), f0)
        e0 = np.linalg.norm(np.diff(res.UV[res.FUV[f0]], axis=1), axis=2).ravel()
        e1 = np.linalg.norm(np.diff(again.UV[again.FUV[f0]], axis=1), axis=2).ravel()
        r = e1 / np.maximum(e0, 1e-12)
        assert np.ptp(r[e0 > 1e-4]) < 1e-3 * r.mean()


def test_exact_unfold_of_strips_is_an_isometry():
    """A chart without interior vertices unfolds exactly (E_SD 4, no flips); one with an interior vertex does not."""
    from neuraluv.atlas import unfold_tree

    V, F = disk(n_rings=3)
    outer = np.flatnonzero(np.all(np.linalg.norm(V[F][:, :, :2], axis=2) > 0.4, axis=1))  # the outer ring: a strip
    from neuraluv.topology import submesh

    vi, Fl = submesh(F, outer[:12])
    Vc = V[vi] + np.c_[np.zeros((len(vi), 2)), 0.3 * V[vi, 0] ** 2]  # bend it in 3D
    UV = unfold_tree(Vc, Fl)
    m = distortion_metrics(Vc, Fl, UV)
    assert m["flips"] == 0 and m["esd"] == pytest.approx(4.0, abs=1e-9) and boundary_is_simple(UV, Fl)
    assert unfold_tree(*disk(n_rings=2)) is None  # interior vertices: no exact unfold
    res = route_chart(Vc, Fl, np.arange(len(Fl)), get_config("test"))
    assert res.route == "exact" and res.method == "exact-unfold" and res.metrics["esd"] == pytest.approx(4.0)


def test_a_chart_whose_neural_map_fails_is_split_and_routed_again(monkeypatch):
    """Routing bisects a failing candidate and solves the halves before falling back."""
    from neuraluv.atlas import routing

    real = routing.boundary_is_simple
    V, F = disk(n_rings=5)
    whole = len(F)

    def fails_whole(UV, Fl):  # pretend the neural map of the whole chart crosses itself
        return False if len(Fl) == whole else real(UV, Fl)

    monkeypatch.setattr(routing, "boundary_is_simple", fails_whole)
    charts = routing.route_charts(V, F, [(np.arange(len(F)), "component")], get_config("test", iterations=20))
    assert len(charts) >= 2 and all(c.route in ("neural", "exact") for c in charts)
    assert sorted(np.concatenate([c.faces for c in charts]).tolist()) == list(range(len(F)))
    assert all("split after: neural map overlaps itself" in c.source for c in charts)
