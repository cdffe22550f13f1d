"""UV repair: charts from seams, only flipped charts re-solved, valid charts bit-identical."""
import json

import numpy as np
import pytest

from neuraluv.datasets import disk, spherical_cap
from neuraluv.io import read_obj, write_obj
from neuraluv.metrics import distortion_metrics
from neuraluv.tutte import tutte
from neuraluv.metrics import face_dets
from neuraluv.atlas.uvrepair import chart_mesh, repair_uvs, uv_charts

from conftest import real_mesh


def _layout_with_one_folded_chart():
    """Three charts side by side: two valid Tutte maps and one with a fold."""
    V1, F1 = disk(n_rings=5)
    V2, F2 = spherical_cap(n_rings=5)
    u1 = tutte(V1, F1)
    u1 = (u1 - u1.min(0)) / np.ptp(u1, 0).max() * 0.3
    u2 = tutte(V2, F2)
    u2 = (u2 - u2.min(0)) / np.ptp(u2, 0).max() * 0.3
    bad = u1.copy() + [0.35, 0.0]
    bad[0] += [0.12, 0.0]  # drag the centre vertex across its neighbours: real flips
    V = np.vstack([V1, V2 + [3, 0, 0], V1 + [0, 3, 0]])
    F = np.vstack([F1, F2 + len(V1), F1 + len(V1) + len(V2)])
    UV = np.vstack([u1 + [0.0, 0.6], u2 + [0.6, 0.6], bad])
    return V, F, UV, F.copy()


def test_uv_charts_follow_seams():
    V, F, UV, FUV = _layout_with_one_folded_chart()
    n, lab = uv_charts(F, FUV)
    assert n == 3
    # cutting the vt sharing along one edge does not split a chart, a full seam does
    ti, Vc, Fc = chart_mesh(V, F, FUV, np.flatnonzero(lab == 0))
    assert len(ti) == len(np.unique(F[lab == 0])) and Fc.shape == (int((lab == 0).sum()), 3)


def test_repair_resolves_only_the_flipped_chart(tmp_path):
    V, F, UV, FUV = _layout_with_one_folded_chart()
    det = face_dets(V, F, UV, FUV)
    assert (det <= 0).sum() > 0
    res = repair_uvs(V, F, UV, FUV, preset="test", threads=1)
    assert res.before["flips"] > 0 and res.after["flips"] == 0
    assert res.after["overlapping_pairs"] == 0 and not res.repacked
    actions = [c["action"] for c in res.charts]
    assert actions.count("kept") == 2 and actions.count("resolved") == 1
    n, lab = uv_charts(F, FUV)
    keep = np.isin(lab, [c["chart"] for c in res.charts if c["action"] == "kept"])
    # bit-identical: same vt indices and same numbers for every valid chart
    assert np.array_equal(res.FUV[keep], FUV[keep])
    assert np.array_equal(res.UV[res.FUV[keep]], UV[FUV[keep]])
    # the repaired chart stays inside its original box (uniform scale, no mirroring)
    fixed = ~keep
    lo, hi = UV[FUV[fixed]].reshape(-1, 2).min(0), UV[FUV[fixed]].reshape(-1, 2).max(0)
    new = res.UV[res.FUV[fixed]].reshape(-1, 2)
    assert (new >= lo - 1e-12).all() and (new <= hi + 1e-12).all()
    # through the CLI and back from disk
    from neuraluv.cli import main

    src, out, rep = tmp_path / "in.obj", tmp_path / "out.obj", tmp_path / "rep.json"
    write_obj(src, V, F, UV, FUV)
    assert main(["repair", str(src), "-o", str(out), "--report", str(rep), "--preset", "test", "--quiet", "--threads", "1"]) == 0
    V2, F2, UV2, FUV2 = read_obj(out)
    V1, F1, UV1, FUV1 = read_obj(src)
    assert (face_dets(V2, F2, UV2, FUV2) > 0).all()
    assert np.array_equal(UV2[FUV2[keep]], UV1[FUV1[keep]])
    r = json.loads(rep.read_text())
    assert r["changed_charts"] == 1 and r["readback_flips"] == 0


def test_repair_keeps_a_valid_layout_untouched():
    V, F = disk(n_rings=4)
    UV = tutte(V, F) * 0.4 + 0.5
    res = repair_uvs(V, F, UV, preset="test")
    assert all(c["action"] == "kept" for c in res.charts)
    assert np.array_equal(res.UV, UV) and np.array_equal(res.FUV, F)


def test_repair_lscm_camel_real_flips():
    igl = pytest.importorskip("igl")
    V, F = real_mesh("camel")
    b = igl.boundary_loop(F)
    uv, _ = igl.lscm(V, F, np.array([b[0], b[len(b) // 2]]), np.array([[0.0, 0.0], [1.0, 0.0]]))
    if distortion_metrics(V, F, uv)["flips"] * 2 > len(F):
        uv[:, 0] *= -1
    flips = distortion_metrics(V, F, uv)["flips"]
    assert flips > 0  # SOURCES.md: LSCM flips 0.22% of camel
    uv = (uv - uv.min(0)) / np.ptp(uv, 0).max()
    res = repair_uvs(V, F, uv, preset="test", threads=1)
    assert res.before["flips"] == flips and res.after["flips"] == 0


def test_repair_blender_smart_uv():
    bpy = pytest.importorskip("bpy", reason="Blender's bpy module is not installed (optional)")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_monkey_add()
    obj = bpy.context.active_object
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.quads_convert_to_tris()
    bpy.ops.uv.smart_project()
    bpy.ops.object.mode_set(mode="OBJECT")
    me = obj.data
    V = np.array([v.co[:] for v in me.vertices])
    F = np.array([p.vertices[:] for p in me.polygons])
    UV = np.array([d.uv[:] for d in me.uv_layers.active.data])
    FUV = np.array([p.loop_indices[:] for p in me.polygons])
    res = repair_uvs(V, F, UV, FUV, preset="test", threads=1)
    assert res.after["flips"] == 0
    kept = [c["chart"] for c in res.charts if c["action"] == "kept"]
    n, lab = uv_charts(F, FUV)
    keep = np.isin(lab, kept)
    assert np.array_equal(res.UV[res.FUV[keep]], UV[FUV[keep]])


def test_repair_repacks_only_when_the_chart_no_longer_fits():
    V, F, UV, FUV = _layout_with_one_folded_chart()
    n, lab = uv_charts(F, FUV)
    # move the small valid chart 1 into the middle of the folded chart's box: shrinking cannot help
    t1 = np.unique(FUV[lab == 1])
    bad = np.unique(FUV[lab == 2])
    c = 0.5 * (UV[bad].min(0) + UV[bad].max(0))
    UV = UV.copy()
    UV[t1] = (UV[t1] - UV[t1].mean(0)) * 0.2 + c
    res = repair_uvs(V, F, UV, FUV, preset="test", threads=1)
    assert res.repacked
    assert res.after["flips"] == 0 and res.after["overlapping_pairs"] == 0 and res.after["uv_in_unit_square"]
