"""glTF as JSON (``.gltf``) with its buffers and images in files beside it: read, repaired and written back
as a ``.gltf`` or ``.glb`` that keeps the whole document, and converted both ways (issue 27, item 4).

The Khronos sample models ship this way (``glTF/``: ``Model.gltf``, ``Model.bin``, the textures), and so do
exporters' "separate" options; a repair must not reduce such a file to positions and UVs.
"""
import hashlib
import json

import numpy as np
import pytest

from conftest import gltf_validate
from neuraluv.cli import main
from neuraluv.io import read_gltf_layout
from neuraluv.io.gltf import image_bytes, load_gltf, read_accessor
from neuraluv.io.gltf_write import new_accessor, write_gltf
from test_purpose import _glb, fold_cases, intent_layouts

RUN = ["--preset", "test", "--device", "cpu"]


def _separate(glb, folder, stem="model", bin_name=None):
    """``glb`` as ``folder/stem.gltf`` with its buffer in a ``.bin`` and its images in PNG files beside it (the
    layout of the Khronos samples' ``glTF/`` folders)."""
    folder.mkdir(exist_ok=True)
    doc = load_gltf(glb)
    doc.path = folder / f"{stem}.gltf"  # the images' URIs below are relative to it
    prim = doc.json["meshes"][0]["primitives"][0]
    P = read_accessor(doc, prim["attributes"]["POSITION"])
    N = np.c_[P[:, :2] * 0.1, np.ones(len(P))]
    prim["attributes"]["NORMAL"] = new_accessor(doc, N / np.linalg.norm(N, axis=1)[:, None])  # normals to keep
    doc.json["buffers"][0]["byteLength"] = len(doc.buffers[0])
    for i, im in enumerate(doc.json.get("images", [])):
        name = f"{stem}_image{i}.png"
        (folder / name).write_bytes(image_bytes(doc, i))
        del im["bufferView"]
        im["uri"] = name
    write_gltf(doc, folder / f"{stem}.gltf")
    if bin_name:  # the buffer under another name
        js = json.loads((folder / f"{stem}.gltf").read_text())
        (folder / f"{stem}.bin").rename(folder / bin_name)
        js["buffers"][0]["uri"] = bin_name
        (folder / f"{stem}.gltf").write_text(json.dumps(js))
    return folder / f"{stem}.gltf"


def _digests(folder):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir()) if p.is_file()}


def _corners(path, attribute, base=None):
    """Per triangle corner, the values of ``attribute`` of the first primitive (through its indices)."""
    doc = load_gltf(path, base)
    prim = doc.json["meshes"][0]["primitives"][0]
    idx = read_accessor(doc, prim["indices"]).ravel()
    return read_accessor(doc, prim["attributes"][attribute])[idx]


def _attributes(path):
    return set(load_gltf(path).json["meshes"][0]["primitives"][0]["attributes"])


def _validate(path):
    v = gltf_validate(path)  # None without node / the validator package
    assert v is None or v["errors"] == 0, v


def test_a_gltf_with_its_files_beside_it_is_repaired_into_a_gltf_that_keeps_the_document(tmp_path, capsys):
    _, V, F, UV, bad = fold_cases()[0]
    src = _separate(_glb(tmp_path, bad, V, F), tmp_path / "in")
    before = _digests(tmp_path / "in")
    (tmp_path / "out").mkdir()
    out = tmp_path / "out" / "fixed.gltf"
    assert main(["repair", str(src), "-o", str(out), "--report", str(tmp_path / "r.json"), *RUN]) == 0, \
        capsys.readouterr()
    printed = capsys.readouterr().out
    assert "keeps positions and UVs only" not in printed and "re-baked image 0" in printed
    assert _digests(tmp_path / "in") == before  # the input's files are untouched
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["fixed.bin", "fixed.gltf"]
    a, b = json.loads(src.read_text()), json.loads(out.read_text())
    for key in ("nodes", "meshes", "materials", "textures", "samplers", "scenes", "scene"):
        assert a.get(key) == b.get(key), key
    assert b["buffers"] == [{"byteLength": (tmp_path / "out" / "fixed.bin").stat().st_size, "uri": "fixed.bin"}]
    assert "bufferView" in b["images"][0]  # the re-baked image, stored in the new .bin
    for att in _attributes(src) - {"TEXCOORD_0"}:
        assert np.array_equal(_corners(src, att), _corners(out, att)), att
    uv0, uv1 = _corners(src, "TEXCOORD_0"), _corners(out, "TEXCOORD_0")
    assert 0 < (uv0 != uv1).any(1).mean() < 0.5  # only the fold's corners moved
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["readback"]["valid"] and r["written"]["mode"] == "replace"
    assert read_gltf_layout(out).F.shape == F.shape
    _validate(out)


def test_an_intent_only_gltf_comes_back_byte_identical_beside_it_and_pointing_back_from_elsewhere(tmp_path, capsys):
    V, F, UV, FUV, _ = intent_layouts()["stacked"]
    src = _separate(_glb(tmp_path, UV, V, F), tmp_path / "in")
    same = tmp_path / "in" / "copy.gltf"
    assert main(["repair", str(src), "-o", str(same), *RUN]) == 0, capsys.readouterr()
    assert same.read_bytes() == src.read_bytes()
    (tmp_path / "else").mkdir()
    other = tmp_path / "else" / "copy.gltf"
    assert main(["repair", str(src), "-o", str(other), *RUN]) == 0
    assert "URIs point from the output's folder at the input's" in capsys.readouterr().out
    assert sorted(p.name for p in (tmp_path / "else").iterdir()) == ["copy.gltf"]
    a, b = json.loads(src.read_text()), json.loads(other.read_text())
    assert b["buffers"][0]["uri"] == "../in/model.bin" and b["images"][0]["uri"] == "../in/model_image0.png"
    for x in (a, b):
        x["buffers"][0].pop("uri"), x["images"][0].pop("uri")
    assert a == b  # the same document but for where its files are named from
    for att in _attributes(src):
        assert np.array_equal(_corners(src, att), _corners(other, att))
    _validate(other)


def test_gltf_and_glb_convert_both_ways_keeping_every_attribute(tmp_path, capsys):
    _, V, F, UV, bad = fold_cases()[0]
    glb = _glb(tmp_path, bad, V, F)
    src = _separate(glb, tmp_path / "in")
    # .gltf -> .glb: buffers and images inside; GLB -> .gltf: the binary chunk in a .bin beside it
    assert main(["repair", str(src), "-o", str(tmp_path / "c.glb"), *RUN, "--purpose", "lightmap",
                 "--resolution", "256", "--padding", "2"]) == 0, capsys.readouterr()
    assert main(["repair", str(glb), "-o", str(tmp_path / "b.gltf"), *RUN, "--purpose", "lightmap",
                 "--resolution", "256", "--padding", "2"]) == 0, capsys.readouterr()
    a, b = load_gltf(tmp_path / "c.glb"), load_gltf(tmp_path / "b.gltf")
    assert a.glb and len(a.buffers) == 1 and "uri" not in a.json["buffers"][0]
    assert all("bufferView" in im and "uri" not in im for im in a.json["images"])
    assert image_bytes(a, 0) == (tmp_path / "in" / "model_image0.png").read_bytes()
    assert b.json["buffers"][0]["uri"] == "b.bin"
    for out in (tmp_path / "c.glb", tmp_path / "b.gltf"):
        for att in _attributes(glb) - {"NORMAL"} | {"TEXCOORD_0"}:  # the lightmap is a set of its own
            assert np.array_equal(_corners(glb, att), _corners(out, att)), (out.name, att)
        assert read_gltf_layout(out, 1).F.shape == F.shape
        _validate(out)


def test_a_new_bin_never_replaces_a_file_the_input_refers_to(tmp_path, capsys):
    # the input's buffer is named as the output's .bin would be: the output's goes under another name
    _, V, F, UV, bad = fold_cases()[0]
    src = _separate(_glb(tmp_path, bad, V, F), tmp_path / "in", stem="scene", bin_name="model.bin")
    before = _digests(tmp_path / "in")
    out = tmp_path / "in" / "model.gltf"
    assert main(["repair", str(src), "-o", str(out), *RUN]) == 0, capsys.readouterr()
    after = _digests(tmp_path / "in")
    assert {k: after[k] for k in before} == before
    assert json.loads(out.read_text())["buffers"][0]["uri"] == "model_new.bin"
    assert set(after) - set(before) == {"model.gltf", "model_new.bin"}
    assert np.array_equal(_corners(src, "POSITION"), _corners(out, "POSITION"))
    _validate(out)


def test_a_gltf_with_embedded_buffers_keeps_them_embedded():
    import base64

    from neuraluv.io.gltf import GltfDoc

    import tempfile
    from pathlib import Path

    d = Path(tempfile.mkdtemp())
    data = np.arange(6, dtype="<f4").tobytes()
    uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    doc = GltfDoc(d / "in.gltf", {"asset": {"version": "2.0"}, "buffers": [{"byteLength": 24, "uri": uri}]},
                  [bytearray(data)], False)
    write_gltf(doc, d / "same.gltf")
    assert json.loads((d / "same.gltf").read_text())["buffers"][0]["uri"] == uri
    doc.buffers[0][:4] = b"\1\2\3\4"
    write_gltf(doc, d / "changed.gltf")
    assert sorted(p.name for p in d.iterdir()) == ["changed.gltf", "same.gltf"]  # no .bin: still embedded
    assert load_gltf(d / "changed.gltf").buffers[0] == doc.buffers[0]


@pytest.mark.slow
def test_an_atlas_is_written_as_gltf(tmp_path, capsys):
    from conftest import write_mesh
    from neuraluv.datasets import spherical_cap

    V, F = spherical_cap(n_rings=6)
    write_mesh(tmp_path / "cap.obj", V, F)
    out = tmp_path / "cap.gltf"
    assert main(["atlas", str(tmp_path / "cap.obj"), "-o", str(out), "--preset", "test", "--iterations", "20",
                 "--device", "cpu", "--quiet", "--resolution", "256", "--padding", "2"]) == 0, capsys.readouterr()
    assert (tmp_path / "cap.bin").is_file() and not out.read_bytes().startswith(b"glTF")
    assert read_gltf_layout(out).F.shape == F.shape
    _validate(out)


def test_faces_on_a_line_in_float32_take_no_part_in_a_lightmap_s_flips(tmp_path, capsys):
    # a subdivided n-gon (Blender's cap of a subdivided cylinder): triangles whose corners lie on one line, up to
    # the float32 rounding of a glTF's positions. Their UVs, written as float32 too, have no orientation to keep:
    # check, repair and the read-back must agree that they are faces without 3D area, not flips.
    from neuraluv.layout import facts

    n, k = 24, 6
    ring = np.c_[np.cos(2 * np.pi * np.arange(n) / n), np.sin(2 * np.pi * np.arange(n) / n), np.zeros(n)] * 0.7
    V = [np.zeros(3)]
    F = []
    for i in range(n):  # each rim edge cut in k: a fan of k triangles to the centre, and k-1 flat ones on the rim
        a, b = ring[i], ring[(i + 1) % n]
        idx = []
        for j in range(k + 1):
            if j == k and i == n - 1:
                idx.append(1)
                continue
            if j == 0 and i > 0:
                idx.append(last)
                continue
            V.append(a + (b - a) * j / k)
            idx.append(len(V) - 1)
        last = idx[-1]
        F += [[0, idx[j], idx[j + 1]] for j in range(k)]
        F += [[idx[0], idx[j], idx[j + 1]] for j in range(1, k)]  # corners on the rim edge: on one line
    V, F = np.asarray(V, np.float32).astype(float), np.asarray(F)
    UV = V[:, :2] * 0.5 + 0.5
    src = _glb(tmp_path, UV, V, F)
    flat = facts.layout_facts(V, F, UV, F).degenerate3d
    assert flat.sum() == n * (k - 1)  # every face on a rim edge, whatever float32 did to its corners
    # (before: 4 of them; the lightmap read back with 48 flips, exit 3)
    out = tmp_path / "lm.glb"
    assert main(["repair", str(src), "-o", str(out), "--purpose", "lightmap", *RUN, "--resolution", "256",
                 "--padding", "2", "--report", str(tmp_path / "r.json")]) == 0, capsys.readouterr()
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["readback"]["valid"] and r["readback"]["flips"] == 0 and r["readback"]["zero_area_faces"] == n * (k - 1)
    _validate(out)
