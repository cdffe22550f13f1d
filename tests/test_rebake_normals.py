"""Normal maps carried over a new layout: a tangent-space vector turns with its face (issue 27, item 3).

A normal map stores vectors in the frame of the layout (+X along +u, +Y along +v). An atlas turns islands by
quarter turns and a repacked layout moves them: copied texel for texel, the stored vectors would keep their
old direction in a turned frame and light the surface from another side.
"""
import json

import numpy as np
import pytest

from neuraluv.repair.rebake import appearance_change, rebake_image, sample_image, uv_turns
from neuraluv.repair.textures import looks_like_normal_map


def _quad(lo, hi):
    return np.array([[lo, lo], [hi, lo], [hi, hi], [lo, hi]], float)


def _encode(n):
    return np.rint((np.asarray(n, float) + 1.0) * 0.5 * 255).astype(np.uint8)


def test_a_normal_map_turns_with_a_face_turned_a_quarter():
    V = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2], [0, 2, 3]])
    UV0 = _quad(0.1, 0.4)
    c = UV0.mean(0)
    quarter = np.array([[0., -1], [1, 0]])
    UV1 = (UV0 - c) @ quarter.T + c + 0.5   # turned 90° (counter-clockwise in u, v) and moved
    img = np.zeros((64, 64, 3), np.uint8) + _encode([0.6, 0.0, 0.8])   # every vector tilted towards +u
    out, info = rebake_image(img, UV0, F, UV1, F, np.ones(2, bool), normal_map=True)
    inside = sample_image(out, (UV1.mean(0))[None])[0]
    assert info["texels_written"] > 0
    assert np.allclose(inside, _encode([0.0, 0.6, 0.8]), atol=1.5)   # now towards +v: turned with the face
    plain, _ = rebake_image(img, UV0, F, UV1, F, np.ones(2, bool))
    assert np.allclose(sample_image(plain, UV1.mean(0)[None])[0], _encode([0.6, 0.0, 0.8]), atol=1.5)
    turn = uv_turns(UV0, F, UV1, F)
    assert np.allclose(turn, quarter)
    kept = appearance_change(V, F, img, UV0, F, out, UV1, F, samples=2000, turn=turn)
    wrong = appearance_change(V, F, img, UV0, F, plain, UV1, F, samples=2000, turn=turn)
    assert kept["mean"] < 1.0 and wrong["mean"] > 50   # measured in the old frame


def test_a_mirrored_face_mirrors_its_normals_and_a_grey_bump_map_is_no_normal_map():
    F = np.array([[0, 1, 2], [0, 2, 3]])
    UV0 = _quad(0.1, 0.4)
    UV1 = UV0 * np.array([-1.0, 1.0]) + np.array([1.0, 0.0])   # mirrored in u
    img = np.zeros((32, 32, 3), np.uint8) + _encode([0.6, 0.0, 0.8])
    out, _ = rebake_image(img, UV0, F, UV1, F, np.ones(2, bool), normal_map=True)
    assert np.allclose(sample_image(out, UV1.mean(0)[None])[0], _encode([-0.6, 0.0, 0.8]), atol=1.5)
    flat = np.zeros((8, 8, 3), np.uint8) + _encode([0.0, 0.0, 1.0])
    assert looks_like_normal_map(flat) and not looks_like_normal_map(np.full((8, 8, 3), 90, np.uint8))
    assert not looks_like_normal_map(np.full((8, 8), 128, np.uint8))


@pytest.mark.slow
def test_an_atlas_replacing_the_uvs_rebakes_a_glb_normal_texture_as_a_normal_map(tmp_path, capsys):
    import trimesh
    from PIL import Image

    from neuraluv.cli import main

    yy, xx = np.mgrid[0:64, 0:64] / 64.0
    colour = Image.fromarray(np.stack([255 * xx, 255 * yy, 0 * xx + 128], -1).astype(np.uint8))
    n = np.stack([0.5 * np.sin(6 * xx), 0.5 * np.cos(5 * yy), np.ones_like(xx)], -1)
    normals = Image.fromarray(_encode(n / np.linalg.norm(n, axis=2, keepdims=True)))
    V = trimesh.creation.icosphere(2).vertices
    sphere = trimesh.creation.icosphere(2)
    mat = trimesh.visual.material.PBRMaterial(baseColorTexture=colour, normalTexture=normals)
    sphere.visual = trimesh.visual.TextureVisuals(uv=V[:, :2] * 0.45 + 0.5, material=mat)
    src = tmp_path / "ball.glb"
    src.write_bytes(trimesh.Scene(sphere).export(file_type="glb"))
    out = tmp_path / "out.glb"
    assert main(["atlas", str(src), "-o", str(out), "--replace-uvs", "--report", str(tmp_path / "r.json"),
                 "--preset", "test", "--iterations", "20", "--device", "cpu", "--pack-trials", "2", "--quiet",
                 "--resolution", "256", "--padding", "2"]) == 0, capsys.readouterr()
    assert "(a normal map: its vectors turned with each face)" in capsys.readouterr().out
    tex = json.loads((tmp_path / "r.json").read_text())["textures"]
    assert sorted(bool(t.get("normal_map")) for t in tex) == [False, True]
    assert all("appearance" in t for t in tex)


def test_a_repair_recomputes_the_tangents_of_the_vertices_it_moved_and_keeps_the_others(tmp_path, capsys):
    # a normal-mapped GLB with a fold, its TANGENT rows made from its UVs as they are (as an exporter makes them):
    # after the repair the moved vertices' tangents follow the repaired UVs (close to the frame of the layout as
    # intended, unlike the rows made on the fold), the rest keep their bytes
    import trimesh
    from PIL import Image

    from neuraluv.cli import main
    from neuraluv.io.gltf import load_gltf, read_accessor
    from neuraluv.io.gltf_tangents import vertex_tangents
    from neuraluv.io.gltf_write import new_accessor, write_gltf
    from test_purpose import fold_cases

    _, V, F, UV, bad = fold_cases()[0]
    flat = Image.fromarray(np.zeros((32, 32, 3), np.uint8) + _encode([0.0, 0.0, 1.0]))
    mesh = trimesh.Trimesh(V, F, process=False, visual=trimesh.visual.TextureVisuals(
        uv=bad, material=trimesh.visual.material.PBRMaterial(baseColorTexture=flat, normalTexture=flat)))
    mesh.vertex_normals  # noqa: B018 - computed, so the GLB carries NORMAL
    glb = tmp_path / "t.glb"
    glb.write_bytes(trimesh.Scene(mesh).export(file_type="glb", include_normals=True))
    doc = load_gltf(glb)
    prim = doc.json["meshes"][0]["primitives"][0]
    P, N = read_accessor(doc, prim["attributes"]["POSITION"]), read_accessor(doc, prim["attributes"]["NORMAL"])
    order = np.argsort(np.linalg.norm(P[:, None] - V[None], axis=2).argmin(1))   # trimesh keeps the vertex order
    assert np.array_equal(order, np.arange(len(V)))
    T0 = vertex_tangents(P, N, UV, F)   # the frame of the layout as intended (UV v up, as read)
    prim["attributes"]["TANGENT"] = new_accessor(doc, vertex_tangents(P, N, bad, F))
    doc.json["buffers"][0]["byteLength"] = len(doc.buffers[0])
    src = tmp_path / "src.glb"
    write_gltf(doc, src)
    out = tmp_path / "out.glb"
    assert main(["repair", str(src), "-o", str(out), "--preset", "test", "--device", "cpu", "--no-rebake",
                 "--report", str(tmp_path / "r.json")]) == 0, capsys.readouterr()
    assert "TANGENT recomputed" in capsys.readouterr().out
    a, b = load_gltf(src), load_gltf(out)
    pa, pb = a.json["meshes"][0]["primitives"][0], b.json["meshes"][0]["primitives"][0]
    ua, ub = (read_accessor(d, p["attributes"]["TEXCOORD_0"]) for d, p in ((a, pa), (b, pb)))
    ta, tb = (read_accessor(d, p["attributes"]["TANGENT"]).astype(float) for d, p in ((a, pa), (b, pb)))
    moved = (ua != ub).any(1)
    assert moved.any() and np.array_equal(ta[~moved], tb[~moved])
    assert json.loads((tmp_path / "r.json").read_text())["written"]["tangents"] == int(moved.sum())
    cos = (tb[moved, :3] * T0[moved, :3]).sum(1)
    stale = (ta[moved, :3] * T0[moved, :3]).sum(1)   # the same rows as made on the fold
    assert np.allclose(np.linalg.norm(tb[:, :3], axis=1), 1, atol=1e-5) and set(tb[:, 3]) <= {-1.0, 1.0}
    assert np.median(stale) < 0.5   # made on the fold: far off (median cosine 0.03)
    assert np.median(cos) > 0.95 and np.array_equal(tb[moved, 3], T0[moved, 3]), (np.median(cos), np.median(stale))


def test_a_bake_repair_of_an_obj_carries_its_textures_and_turns_its_normal_map(tmp_path, capsys):
    # under --purpose bake the OBJ's one vt set is replaced by a unique layout: the maps its material reads are
    # re-baked onto it as under texture (before, only texture repairs re-baked: the output's material still
    # pointed at images painted for the old layout)
    from PIL import Image

    from conftest import write_layout
    from neuraluv.cli import main
    from test_purpose import intent_layouts

    V, F, UV, FUV, _ = intent_layouts()["mirrored copy"]
    src = tmp_path / "m.obj"
    write_layout(src, V, F, UV, FUV)
    src.write_text("mtllib m.mtl\nusemtl skin\n" + src.read_text())
    (tmp_path / "m.mtl").write_text("newmtl skin\nmap_Kd col.png\nmap_Bump nrm.png\n")
    yy, xx = np.mgrid[0:128, 0:128] / 128.0
    Image.fromarray(np.stack([255 * xx, 255 * yy, 0 * xx + 60], -1).astype(np.uint8)).save(tmp_path / "col.png")
    n = np.stack([0.4 * np.sin(9 * xx), 0.4 * np.cos(7 * yy), np.ones_like(xx)], -1)
    Image.fromarray(_encode(n / np.linalg.norm(n, axis=2, keepdims=True))).save(tmp_path / "nrm.png")
    out = tmp_path / "out.obj"
    assert main(["repair", str(src), "-o", str(out), "--purpose", "bake", "--preset", "test", "--device", "cpu",
                 "--resolution", "256", "--padding", "2", "--report", str(tmp_path / "r.json")]) == 0, \
        capsys.readouterr()
    tex = json.loads((tmp_path / "r.json").read_text())["textures"]
    assert [(t["image"], bool(t.get("normal_map"))) for t in tex] == [("col.png", False), ("nrm.png", True)]
    assert (tmp_path / "out.mtl").read_text() == "newmtl skin\nmap_Kd out.col.png\nmap_Bump out.nrm.png\n"
    assert all(t["ok"] for t in tex)   # mean colour change over the surface within 1 level (0.82 and 0.42 here)
