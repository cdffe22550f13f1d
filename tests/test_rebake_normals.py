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
