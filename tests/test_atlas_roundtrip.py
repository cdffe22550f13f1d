"""The atlas keeps what a user's file holds: an OBJ's lines, a GLB's scene, every face (issue 31).

A client's view: files in, files out, compared attribute by attribute; the Khronos glTF validator runs
on every GLB written here when it is installed (``make gltf-validator``), and skips with the reason
otherwise.
"""
import json

import numpy as np
import pytest

from conftest import gltf_validate as _gltf_validate
from conftest import gltf_validator_missing
from neuraluv.cli import main

#: small atlases: validity and what is kept, not quality
FAST = ["--preset", "test", "--iterations", "20", "--device", "cpu", "--pack-trials", "2", "--quiet",
        "--resolution", "512", "--padding", "2"]
def _grid(n=4, bend=0.6):
    """A bent n x n grid of quads: ``(V, quads)``."""
    u, v = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    V = np.c_[u.ravel(), v.ravel(), bend * (u.ravel() - 0.5) ** 2]
    k = np.arange(n * (n + 1)).reshape(n, n + 1)[:, :n].ravel()
    return V, np.c_[k, k + 1, k + n + 2, k + n + 1]


def _obj_text(V, Q):
    """An OBJ a modelling tool might write: comments, a material library, groups, normals, quads, a
    double-sided quad (its back face), a face wound against its neighbours and a degenerate triangle."""
    lines = ["# made by hand", "mtllib grid.mtl", "o grid"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in V]
    lines += ["vn 0 0 1", "vn 0 0 -1", "g front", "usemtl paint", "s 1"]
    for i, q in enumerate(Q):
        c = q[::-1] if i == 5 else q  # one quad wound against the others
        lines.append("f " + " ".join(f"{a + 1}//1" for a in c))
    back = Q[0][[0, 3, 2, 1]]  # the first quad seen from behind (same diagonal): a double-sided quad
    lines += ["g back", "usemtl paint_back", "f " + " ".join(f"{a + 1}//2" for a in back)]
    lines += [f"f {Q[1][0] + 1}//1 {Q[1][1] + 1}//1 {Q[1][1] + 1}//1"]  # degenerate: a repeated corner
    return "\n".join(lines) + "\n"


@pytest.mark.slow
def test_obj_atlas_keeps_every_line_but_the_uvs_and_every_face(tmp_path, capsys):
    from neuraluv.io import read_obj

    V, Q = _grid()
    src, out, rep = tmp_path / "grid.obj", tmp_path / "out.obj", tmp_path / "r.json"
    src.write_text(_obj_text(V, Q))
    (tmp_path / "grid.mtl").write_text("newmtl paint\nKd 1 0 0\nnewmtl paint_back\nKd 0 0 1\n")
    assert main(["atlas", str(src), "-o", str(out), "--report", str(rep), *FAST]) == 0, capsys.readouterr()
    printed = capsys.readouterr().out
    a, b = src.read_text().splitlines(), out.read_text().splitlines()
    assert [x for x in a if x.split()[:1] not in (["vt"], ["f"])] == \
        [x for x in b if x.split()[:1] not in (["vt"], ["f"])]  # comments, v, vn, g, usemtl, s, mtllib: as they were
    fa, fb = [x for x in a if x.startswith("f ")], [x for x in b if x.startswith("f ")]

    def corners(line):  # (v, vn) of each corner
        return [(t.split("/")[0], t.split("/")[2]) for t in line.split()[1:]]
    r = json.loads(rep.read_text())
    split = r["written"]["polygons_split"]
    assert len(fb) == len(fa) + split  # a polygon the seams cross becomes its two triangles, counted
    if split == 0:
        assert [corners(x) for x in fa] == [corners(x) for x in fb]  # positions, normals, winding: kept
    assert all(len(t.split("/")) == 3 and t.split("/")[1] for x in fb for t in x.split()[1:])  # every corner a vt
    Vb, Fb, UVb, FUVb = read_obj(out)
    Va, Fa, _, _ = read_obj(src)
    assert len(Fb) == len(Fa) and r["faces"]["in"] == r["faces"]["out"] == len(Fa)
    assert r["faces"]["twin_faces"] == 2 and r["faces"]["collapsed_faces"] == 1 and r["ok"]
    # the back face carries its front's UVs, corner by corner
    front, back = [np.flatnonzero(np.all(np.sort(Fb, 1) == np.sort(Fb[k]), 1)) for k in (0, 1)]
    for grp in (front, back):
        assert len(grp) == 2
        P = [dict(zip(Fb[t], map(tuple, UVb[FUVb[t]]))) for t in grp]
        assert P[0] == P[1]
    assert "faces: 35 in, 35 out; 2 duplicate / double-sided faces given their twin's UVs; 1 faces" in printed


def _scene_glb(tmp_path, double_sided=True):
    """A GLB with two nodes (one rotated and scaled), normals, a textured material and TEXCOORD_0; the
    mesh holds a back face for each face of its first row (double-sided geometry)."""
    import trimesh
    from PIL import Image

    V, Q = _grid(5)
    F = np.r_[Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]]
    if double_sided:  # back faces on copies of their vertices (their own normals), as exporters write them
        back = F[:5, ::-1]
        used = np.unique(back)
        F = np.r_[F, len(V) + np.searchsorted(used, back)]
        V = np.r_[V, V[used]]
    yy, xx = np.mgrid[0:64, 0:64]
    img = Image.fromarray(np.stack([4 * xx, 4 * yy, 128 + 0 * xx], -1).astype(np.uint8))
    mesh = trimesh.Trimesh(V, F, process=False, visual=trimesh.visual.TextureVisuals(
        uv=V[:, :2] * 0.8 + 0.1, material=trimesh.visual.material.SimpleMaterial(image=img)))
    mesh.vertex_normals  # noqa: B018 - computed, so the GLB carries NORMAL
    other = trimesh.creation.icosphere(1)
    other.visual = trimesh.visual.TextureVisuals(uv=other.vertices[:, :2] * 0.3 + 0.5)
    scene = trimesh.Scene()
    T = trimesh.transformations.rotation_matrix(0.5, [0, 0, 1]) @ trimesh.transformations.scale_matrix(3.0)
    scene.add_geometry(mesh, transform=T, geom_name="grid")
    scene.add_geometry(other, transform=trimesh.transformations.translation_matrix([4, 0, 0]), geom_name="ball")
    p = tmp_path / "scene.glb"
    p.write_bytes(scene.export(file_type="glb", include_normals=True))
    return p


def _corner_attr(doc, lay, name):
    """The attribute ``name`` at every corner of the layout's triangles (per primitive, as read)."""
    from neuraluv.io.gltf import read_accessor

    out = []
    for b in lay.blocks:
        prim = doc.json["meshes"][b["mesh"]]["primitives"][b["primitive"]]
        out.append(read_accessor(doc, prim["attributes"][name]).astype(float)[b["indices"]])
    return np.concatenate(out)


@pytest.mark.slow
def test_glb_atlas_adds_a_uv_set_and_keeps_the_scene(tmp_path, capsys):
    from neuraluv.io import read_gltf_layout
    from neuraluv.io.gltf import load_gltf

    src, out = _scene_glb(tmp_path), tmp_path / "out.glb"
    assert main(["atlas", str(src), "-o", str(out), "--report", str(tmp_path / "r.json"), *FAST]) == 0, \
        capsys.readouterr()
    printed = capsys.readouterr().out
    r = json.loads((tmp_path / "r.json").read_text())
    a, b = load_gltf(src), load_gltf(out)
    for key in ("nodes", "scenes", "materials", "images", "textures", "samplers"):
        assert a.json.get(key) == b.json.get(key), key
    assert [len(m["primitives"]) for m in a.json["meshes"]] == [len(m["primitives"]) for m in b.json["meshes"]]
    la, lb = read_gltf_layout(src, 0), read_gltf_layout(out, 0)
    assert len(la.F) == len(lb.F) == r["faces"]["in"] == r["faces"]["out"]
    assert r["faces"]["twin_faces"] == 5 and r["readback"]["valid"] and r["ok"]
    assert np.array_equal(la.UV[la.FUV], lb.UV[lb.FUV])  # the textures' UV set: the same at every corner
    assert np.allclose(la.V[la.F], lb.V[lb.F])  # world positions (node transforms kept)
    assert np.array_equal(_corner_attr(a, la, "NORMAL"), _corner_attr(b, lb, "NORMAL"))
    atlas = read_gltf_layout(out, 1)
    assert len(atlas.F) == len(la.F) and "added UV set TEXCOORD_1" in printed
    v = _gltf_validate(out)
    assert v is None or (v["errors"] == 0 and v["warnings"] == 0), v


def test_an_added_uv_set_has_one_index_on_every_primitive(tmp_path):
    """A mesh whose textured part has TEXCOORD_0 and whose plain part has none gets the new layout as
    TEXCOORD_1 on both (a baker reads one set index), the plain part's missing TEXCOORD_0 filled with it."""
    import trimesh

    from neuraluv.io import read_gltf_layout, write_gltf_uvs

    textured = trimesh.creation.box()
    textured.visual = trimesh.visual.TextureVisuals(uv=textured.vertices[:, :2] * 0.5 + 0.5)
    plain = trimesh.creation.icosphere(1)
    scene = trimesh.Scene()
    scene.add_geometry(textured, geom_name="textured")
    scene.add_geometry(plain, geom_name="plain", transform=trimesh.transformations.translation_matrix([3, 0, 0]))
    src, out = tmp_path / "two.glb", tmp_path / "out.glb"
    src.write_bytes(scene.export(file_type="glb"))
    lay = read_gltf_layout(src, None)  # geometry of both parts
    assert len(lay.blocks) == 2
    UV = np.c_[lay.V[:, 0], lay.V[:, 1]] * 0.1 + 0.5  # any finite layout will do
    info = write_gltf_uvs(lay, np.r_[lay.UV, UV], lay.FUV + len(lay.UV), out, mode="add")
    assert info["texcoord"] == [1, 1] and len(info["filled"]) == 1 and info["filled"][0][2] == [0]
    new = read_gltf_layout(out, 1)
    assert len(new.F) == len(lay.F) and np.allclose(new.UV[new.FUV], UV[lay.FUV], atol=1e-6)
    before, after = read_gltf_layout(src, 0), read_gltf_layout(out, 0)  # the textured part's own set: as it was
    assert np.array_equal(before.UV[before.FUV], after.UV[after.FUV][:len(before.F)])
    v = _gltf_validate(out)
    assert v is None or (v["errors"] == 0 and v["warnings"] == 0), v


def test_primitives_with_the_same_data_are_written_together(tmp_path):
    """Two primitives on the same positions, UV set and indices (one mesh drawn with two materials) are read
    once, and both get what is written: the added set, or the split vertices of a replaced one."""
    import copy

    import trimesh

    from neuraluv.io import read_gltf_layout, write_gltf_uvs
    from neuraluv.io.gltf import load_gltf, read_accessor
    from neuraluv.io.gltf_write import write_glb

    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(uv=box.vertices[:, :2] * 0.5 + 0.5)
    src = tmp_path / "box.glb"
    src.write_bytes(box.export(file_type="glb"))
    doc = load_gltf(src)
    mats = doc.json.setdefault("materials", [{}])
    mats.append(copy.deepcopy(mats[0]) | {"name": "second"})
    prim = doc.json["meshes"][0]["primitives"][0]
    doc.json["meshes"][0]["primitives"].append(copy.deepcopy(prim) | {"material": len(mats) - 1})
    write_glb(doc, src)
    lay = read_gltf_layout(src, 0)
    assert len(lay.blocks) == 1 and lay.blocks[0]["aliases"] == [(0, 1)] and not lay.skipped
    UV = lay.V[:, :2] * 0.1 + 0.5
    add = tmp_path / "add.glb"
    info = write_gltf_uvs(lay, np.r_[lay.UV, UV], lay.FUV + len(lay.UV), add, mode="add")
    assert info["texcoord"] == [1, 1]
    prims = load_gltf(add).json["meshes"][0]["primitives"]
    assert prims[0]["attributes"]["TEXCOORD_1"] == prims[1]["attributes"]["TEXCOORD_1"]
    # replaced with every face on rows of its own: the vertices are split, for both primitives alike
    per_corner = lay.UV[lay.FUV].reshape(-1, 2) * 0.5
    rep = tmp_path / "rep.glb"
    info = write_gltf_uvs(lay, np.r_[lay.UV, per_corner], len(lay.UV) + np.arange(lay.F.size).reshape(-1, 3), rep)
    assert info["primitives_split"] == 2
    d = load_gltf(rep)
    p0, p1 = d.json["meshes"][0]["primitives"]
    assert p0["indices"] == p1["indices"] and p0["attributes"] == p1["attributes"] and p1["material"] == 1
    corners = read_accessor(d, p1["attributes"]["TEXCOORD_0"])[read_accessor(d, p1["indices"]).reshape(-1)]
    assert np.allclose(corners, np.c_[per_corner[:, 0], 1 - per_corner[:, 1]], atol=1e-6)
    for out in (add, rep):
        v = _gltf_validate(out)
        assert v is None or v["errors"] == 0, v


def test_a_copied_quantized_attribute_keeps_its_elements_4_byte_aligned(tmp_path):
    """Split vertices copy every attribute: a quantized one (3 normalized bytes a normal, KHR_mesh_quantization)
    gets a byte stride of 4, as glTF wants of vertex attributes (the validator's MESH_PRIMITIVE_ACCESSOR_UNALIGNED)."""
    import trimesh

    from neuraluv.io.gltf import load_gltf, read_accessor
    from neuraluv.io.gltf_write import new_accessor

    src = tmp_path / "box.glb"
    src.write_bytes(trimesh.creation.box().export(file_type="glb"))
    doc = load_gltf(src)
    n = np.array([[127, 0, 0], [0, 127, 0], [0, 0, 129]], np.uint8)
    doc.json["accessors"].append({"componentType": 5121, "normalized": True, "type": "VEC3", "count": 3})
    acc = new_accessor(doc, n, like=len(doc.json["accessors"]) - 1)
    view = doc.json["bufferViews"][doc.json["accessors"][acc]["bufferView"]]
    assert view["byteStride"] == 4 and view["byteOffset"] % 4 == 0 and view["byteLength"] == 12
    assert np.array_equal(read_accessor(doc, acc, raw=True), n)


@pytest.mark.slow
def test_glb_atlas_replacing_the_uv_set_rebakes_the_texture(tmp_path, capsys):
    from neuraluv.io.gltf import load_gltf

    src, out = _scene_glb(tmp_path, double_sided=False), tmp_path / "rep.glb"
    assert main(["atlas", str(src), "-o", str(out), "--replace-uvs", "--report", str(tmp_path / "r.json"),
                 *FAST]) == 0, capsys.readouterr()
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["written"]["mode"] == "replace" and r["textures"] and all("appearance" in t for t in r["textures"])
    a, b = load_gltf(src), load_gltf(out)
    assert a.json["nodes"] == b.json["nodes"] and a.json["materials"] == b.json["materials"]
    assert all("TEXCOORD_1" not in p["attributes"] for m in b.json["meshes"] for p in m["primitives"])
    assert b.json["images"][0] != a.json["images"][0]  # the re-baked image, inside the GLB
    v = _gltf_validate(out)
    assert v is None or v["errors"] == 0, v


def test_outputs_are_written_as_one(tmp_path, monkeypatch):
    """The report fails to write (a full disk): the old output and report stay, nothing half-new is left."""
    from neuraluv.atlas import export
    from neuraluv.datasets import sphere
    from neuraluv.io import write_obj

    V, F = sphere(0)
    src, out, rep = tmp_path / "s.obj", tmp_path / "o.obj", tmp_path / "o.json"
    write_obj(src, V, F, np.zeros((len(V), 2)))
    out.write_text("old output")
    rep.write_text("old report")

    def full(*a, **k):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(export.json, "dump", full)
    with pytest.raises(OSError):
        export.atlas_file(src, out, report=rep, preset="test", iterations=10, device="cpu", pack_trials=1,
                          progress=False)
    assert out.read_text() == "old output" and rep.read_text() == "old report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.json", "o.obj", "s.obj"]


def test_the_gltf_validator_runs_and_catches_a_broken_file(tmp_path):
    """The validator the GLB tests rely on is there (else this test skips with the reason) and fails a bad file."""
    if gltf_validator_missing():
        pytest.skip(gltf_validator_missing())
    bad = tmp_path / "bad.gltf"
    bad.write_text(json.dumps({"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": 7}}]}]}))
    assert _gltf_validate(bad)["errors"] >= 1


_BLENDER_IMPORT = """
import json, sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=sys.argv[-1])
meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
print("RESULT" + json.dumps({"objects": len(meshes), "faces": sum(len(o.data.polygons) for o in meshes),
                             "uv_layers": sorted({len(o.data.uv_layers) for o in meshes}),
                             "materials": sorted({s.material.name for o in meshes for s in o.material_slots if s.material})}))
"""


def _blender_import(path):
    import subprocess

    from neuraluv_paper.baselines.external import blender_python

    py = blender_python()
    out = subprocess.run([py, "-c", _BLENDER_IMPORT, str(path)], capture_output=True, text=True, timeout=300)
    line = [x for x in out.stdout.splitlines() if x.startswith("RESULT")]
    assert out.returncode == 0 and line, out.stderr[-2000:]
    return json.loads(line[0][len("RESULT"):])


@pytest.mark.slow
def test_blender_imports_the_atlas_glb_like_the_input(tmp_path, capsys):
    """Blender 4.5 (the optional ``bpy`` environment: ``make blender-env``) reads the atlas's GLB as it reads the
    input — the same objects, faces and materials — with one more UV layer."""
    from neuraluv_paper.baselines.external import blender_python

    if blender_python() is None:
        pytest.skip("Blender's bpy not installed (`make blender-env`, or set NEURALUV_BPY_PYTHON)")
    src, out = _scene_glb(tmp_path), tmp_path / "out.glb"
    assert main(["atlas", str(src), "-o", str(out), *FAST]) == 0, capsys.readouterr()
    a, b = _blender_import(src), _blender_import(out)
    assert (a["objects"], a["faces"], a["materials"]) == (b["objects"], b["faces"], b["materials"])
    assert b["uv_layers"] == [n + 1 for n in a["uv_layers"]]
