"""Atlas construction: repair, candidates, routing, fallbacks, packing, validation, export, CLI.

Every atlas test validates the exported file after reading it back.
"""
import json

import numpy as np
import pytest

from neuraluv.atlas import (FALLBACK_MAX_ESD, build_atlas, chart_candidates, fallback_islands, pca_uv, per_face_uv,
                            prepare_mesh, read_atlas, route_chart, tutte_slim_uv, write_atlas)
from neuraluv.atlas.candidates import merge_small_charts
from neuraluv.datasets import disk, sphere, spherical_cap
from neuraluv.datasets.generated import add_nonmanifold, flip_windings, generated_asset, unweld
from neuraluv.layout import boundary_is_simple, self_overlap, uv_islands, validate_layout
from neuraluv.metrics import distortion_metrics
from neuraluv.solver import get_config
from neuraluv.topology import bisect_faces, is_disk_like, topology_scan
from neuraluv.tutte import tutte

from conftest import three_copies

#: atlases here test validity and routing, not packing: two packing trials instead of the default twelve
FAST = dict(preset="test", iterations=30, resolution=512, padding=4, threads=1, device="cpu", pack_trials=2)


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


def test_route_chart_neural_on_a_curved_disk():
    V, F = spherical_cap(n_rings=4)   # a flat disk's start is an isometry already: routed exact (test below)
    ch = route_chart(V, F, np.arange(len(F)), get_config("fast", iterations=60, retries=0))
    assert ch.route == "neural" and ch.method == "neural" and ch.reason == ""
    assert ch.metrics["flips"] == 0 and ch.solver["status"] == "neural"


@pytest.mark.slow
def test_atlas_closed_sphere_obj_readback(tmp_path):
    res = build_atlas(*sphere(2), **FAST)
    t = res.totals()
    assert t["coverage"] == 1.0 and t["flips"] == 0
    assert t["neural_share"] >= 0.8
    v = _readback_ok(res, tmp_path / "sphere.obj")
    assert v["islands"] == t["islands"] >= 2
    rep = json.loads(json.dumps(res.report()))
    assert {"route", "reason", "metrics", "time"} <= set(rep["charts"][0])
    assert rep["info"]["threads"] == {"n": 1, "why": "as given"}


def test_the_report_says_how_many_threads_auto_chose_and_why():
    res = build_atlas(*sphere(1), **{**FAST, "threads": "auto"})
    th = res.info["threads"]
    assert th["n"] >= 1 and f"{th['n']} of " in th["why"] and "busy" in th["why"]


@pytest.mark.slow
def test_atlas_generated_messy_glb_readback(tmp_path):
    V, F, info = generated_asset(2, res=16)  # soup, flips, slivers, fragments, non-manifold
    res = build_atlas(V, F, **FAST)
    t = res.totals()
    assert t["covered_faces"] == t["repaired_faces"] and t["flips"] == 0
    assert all(c.reason for c in res.charts if c.route == "fallback")  # every fallback says why
    _readback_ok(res, tmp_path / "gen.glb")
    _readback_ok(res, tmp_path / "gen.obj")


@pytest.mark.slow
def test_atlas_xatlas_packer(tmp_path):
    res = build_atlas(*sphere(1), packer="xatlas", **FAST)
    assert 0 < res.info["utilisation"] <= 1
    _readback_ok(res, tmp_path / "x.obj")


@pytest.mark.slow
def test_bad_inputs_are_refused_or_valid(tmp_path):
    from neuraluv.errors import NeuralUVError

    with pytest.raises(NeuralUVError):
        build_atlas(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]]), **FAST)
    with pytest.raises(NeuralUVError):
        build_atlas(np.array([[0.0, 0, 0], [1, 0, np.nan], [0, 1, 0]]), np.array([[0, 1, 2]]), **FAST)
    huge = np.array([[0.0, 0, 0], [1e300, 0, 0], [0, 1e300, 0], [1e300, 1e300, 1e290]])
    res = build_atlas(huge, np.array([[0, 1, 2], [1, 3, 2]]), **FAST)
    _readback_ok(res, tmp_path / "huge.obj")


@pytest.mark.slow
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


@pytest.mark.slow
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


def _wound_strip(turns=1.6, n=48, rows=4):
    """A strip wound ``turns`` times round on a sphere of radius 5 (``n`` columns of ``rows`` vertices): its plane
    coordinates ``(x, y)`` are a flip-free map that crosses itself after one turn."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(rows), indexing="ij")
    th = 2 * np.pi * turns * i / n
    r = 1.0 + 0.12 * j + 0.25 * th / (2 * np.pi)
    x, y = r * np.cos(th), r * np.sin(th)
    V = np.stack([x, y, np.sqrt(25.0 - x**2 - y**2)], -1).reshape(-1, 3)
    q = (i * rows + j)[:-1, :-1].ravel()
    return V, np.concatenate([np.stack([q, q + rows + 1, q + rows], 1), np.stack([q, q + 1, q + rows + 1], 1)])


def test_a_split_piece_keeps_its_parents_map_where_that_map_is_injective_on_it():
    from neuraluv.atlas.candidates import chart_mesh
    from neuraluv.atlas.routing import _on_parent

    V, F = _wound_strip()
    every = np.arange(len(F))
    whole = chart_mesh(V, F, every)
    parent = (every, whole[1], V[whole[0], :2])
    assert not boundary_is_simple(V[whole[0], :2], whole[1])
    assert _on_parent(V, every, whole, parent) is None                  # the whole strip overlaps itself there
    half = every[F.min(1) // 4 < 24]                                      # its first 0.8 turn does not
    m = chart_mesh(V, F, half)
    assert np.array_equal(_on_parent(V, half, m, parent), V[m[0], :2])     # no hole: no filler vertex
    assert _on_parent(V, half, m, None) is None
    # a piece with a hole (closed by a filler fan while it is checked) on a flat parent map; a mirrored map flips
    Vd, Fd = disk(n_rings=3)
    ring = np.array([f for f in range(len(Fd)) if 0 not in Fd[f]])
    m, pm = chart_mesh(Vd, Fd, ring), chart_mesh(Vd, Fd, np.arange(len(Fd)))
    assert len(m[2]) == 1
    flat = (np.arange(len(Fd)), pm[1], Vd[pm[0], :2])
    uv = _on_parent(Vd, ring, m, flat)                                      # the ring's vertices, then its hub
    assert np.array_equal(uv[:-1], Vd[m[0], :2]) and np.allclose(uv[-1], 0.0)
    assert _on_parent(Vd, ring, m, flat[:2] + (Vd[pm[0], :2] * [1, -1],)) is None


@pytest.mark.slow
def test_a_chart_whose_neural_map_fails_is_split_and_routed_again(monkeypatch):
    """Routing bisects a failing candidate; a half on which the failed map is no good is solved again."""
    from neuraluv.atlas import routing

    real = routing.boundary_is_simple
    V, F = spherical_cap(n_rings=5)   # curved: a flat disk's start is an isometry (routed exact)
    whole = len(F)

    def fails_whole(UV, Fl):  # pretend the neural map of the whole chart crosses itself
        return False if len(Fl) == whole else real(UV, Fl)

    monkeypatch.setattr(routing, "boundary_is_simple", fails_whole)
    cfg = get_config("test", iterations=20)
    charts = routing.route_charts(V, F, [(np.arange(len(F)), "component")], cfg,
                                  start_slim=0)   # the Tutte start: the tiny test network improves on it
    assert len(charts) >= 2 and all(c.route in ("neural", "exact") for c in charts)
    assert sorted(np.concatenate([c.faces for c in charts]).tolist()) == list(range(len(F)))
    assert all("split after: neural map overlaps itself" in c.source for c in charts)
    # the halves are injective on the whole chart's (flip-free) map: they keep it, no solve of their own
    # each half is injective on the whole chart's flip-free map: its solve starts there, not at its Tutte circle
    assert all(c.method == "neural" and c.solver["start"] == routing.PARENT_START for c in charts)
    # a half whose solve finds nothing better than that start keeps the split chart's map, as a neural chart
    from dataclasses import replace as _replace

    from neuraluv.solver import chart as solver_chart
    real_solve = solver_chart.solve_charts

    def no_better(charts_, cfg_, **k):
        out = real_solve(charts_, cfg_, **k)
        return [_replace(r, status="fallback", reason="no accepted step improved on the start",
                         uv=p.u_start * p.scale, metrics=distortion_metrics(p.V, p.F, p.u_start * p.scale))
                if p.start == routing.PARENT_START else r for r, p in zip(out, k["preps"])]

    monkeypatch.setattr(solver_chart, "solve_charts", no_better)
    kept = routing.route_charts(V, F, [(np.arange(len(F)), "component")], cfg, start_slim=0)
    assert [c.route for c in kept] == [c.route for c in charts] and all(c.method == "neural" for c in kept)
    assert all(c.solver["status"] == "fallback" for c in kept)
    monkeypatch.setattr(solver_chart, "solve_charts", real_solve)
    monkeypatch.setattr(routing, "_on_parent", lambda *a: None)
    charts = routing.route_charts(V, F, [(np.arange(len(F)), "component")], cfg, start_slim=0)
    assert all(c.solver["start"] == "tutte" for c in charts if c.method == "neural")


def test_a_neural_map_whose_boundary_crosses_itself_is_solved_on_before_it_is_split(monkeypatch):
    """The solver's stop test sees distortion, not the boundary: routing first goes on from where it stopped."""
    from neuraluv.atlas import routing
    from neuraluv.solver import chart as solver_chart

    real, real_solve = routing.boundary_is_simple, solver_chart.solve_charts
    V, F = spherical_cap(n_rings=5)   # curved: a flat disk's start is an isometry (routed exact)
    whole, seen, starts = len(F), [], []

    def fails_once(UV, Fl):  # the first map of the whole chart crosses itself, the next ones do not
        if len(Fl) == whole:
            seen.append(1)
            if len(seen) == 1:
                return False
        return real(UV, Fl)

    def solve(*a, **k):
        starts.append(k.get("theta0"))
        return real_solve(*a, **k)

    monkeypatch.setattr(routing, "boundary_is_simple", fails_once)
    monkeypatch.setattr(solver_chart, "solve_charts", solve)
    charts = routing.route_charts(V, F, [(np.arange(len(F)), "component")], get_config("test", iterations=20),
                                  start_slim=0)
    assert [c.route for c in charts] == ["neural"] and "split after" not in charts[0].source
    assert len(starts) == 2 and starts[0] is None and starts[1] is not None and starts[1][0] is not None


def test_merge_small_charts_keeps_disks_and_covers_once():
    V, F = sphere(2)
    cands = chart_candidates(V, F)
    merged = merge_small_charts(V, F, cands, max_faces=10**9, max_curvature=0.5)
    assert len(merged) <= len(cands)
    allf = np.sort(np.concatenate([f for f, _ in merged]))
    assert np.array_equal(allf, np.arange(len(F)))


@pytest.mark.slow
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


@pytest.mark.slow
def test_stacking_identical_parts_shares_their_place_and_stays_valid():
    V, F, m = three_copies()
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


@pytest.mark.slow
def test_chart_with_a_hole_is_solved_whole_with_a_filler():
    from neuraluv.atlas.candidates import chart_is_disk, chart_mesh
    from neuraluv.atlas.routing import route_charts
    from neuraluv.datasets import disk
    from neuraluv.solver.config import get_config
    from neuraluv.topology import is_disk_like, submesh

    V, F = spherical_cap(n_rings=5)   # curved: a flat disk's start is an isometry (routed exact)
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


def test_a_flat_chart_whose_solver_start_is_an_isometry_is_routed_exact_with_it():
    """The ``fast`` start (Tutte moved on by SLIM while injective) of a flat disk with interior vertices is an
    isometry already: routed exact (``isometric-start``), never a stalled neural solve that gets split."""
    from neuraluv.atlas.routing import ISOMETRIC_START, route_charts

    V, F = disk(6)
    V = V * np.array([6.0, 0.25, 0.0])   # flat, far from its Tutte circle
    (c,) = route_charts(V, F, [(np.arange(len(F)), "component")])
    assert (c.route, c.method, c.metrics["flips"]) == ("exact", "isometric-start", 0)
    assert c.metrics["esd"] <= 4.0 * (1 + ISOMETRIC_START) and len(c.islands) == 1
    Vc, Fc = spherical_cap(4)
    (n,) = route_charts(Vc, Fc, [(np.arange(len(Fc)), "component")])
    assert n.route == "neural"   # a curved chart still goes to the network


def test_a_slim_start_the_network_cannot_improve_is_a_marked_fallback_kept_whole():
    """A network that finds nothing better than its SLIM-moved start (here: every step far too long, refused) returns
    the start, an injective map: routed as a marked fallback in one island, not split into more seams."""
    from neuraluv.atlas.routing import route_charts

    V, F = spherical_cap(n_rings=5)
    cfg = get_config("test", iterations=5, retries=0, lr=1e6, max_backtracks=0)
    (c,) = route_charts(V, F, [(np.arange(len(F)), "component")], cfg, start_slim=10)
    assert (c.route, c.method, len(c.islands)) == ("fallback", "slim-start", 1)
    assert "at its start (tutte+slim" in c.reason and c.metrics["flips"] == 0
    assert boundary_is_simple(c.islands[0][3], c.islands[0][2])


def test_a_face_on_one_point_is_a_marked_fallback_not_an_endless_split():
    # a face whose corners are one point (in a repair's rows: a palette's faces, every corner on one texel) is not
    # disk-like and cannot be halved: splitting it again and again ended in a RecursionError (chair_model.obj under
    # --purpose bake). It is a candidate of its own, routed to a marked fallback with finite UVs.
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 2, 2]], float)
    F = np.array([[0, 1, 2], [3, 3, 3]])
    from neuraluv.atlas.routing import route_charts

    cands = chart_candidates(V, F)
    assert [f.tolist() for f, _ in cands] == [[0], [1]] and "not disk-like" in cands[1][1]
    charts = route_charts(V, F, cands, get_config("test"))
    assert [c.route for c in charts] == ["exact", "fallback"]
    assert all(np.isfinite(isl[3]).all() for c in charts for isl in c.islands)
