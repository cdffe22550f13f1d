"""CLI round trips and bad-input errors (one line, non-zero exit, no traceback)."""

import numpy as np
import pytest

from neuraluv import datasets
from neuraluv.errors import MeshLoadError
from neuraluv.io import load_mesh, patch_obj, read_obj, write_obj

from conftest import write_mesh


def test_write_read_roundtrip(tmp_path):
    V, F = datasets.spherical_cap(4)
    UV = np.random.default_rng(0).random((len(V), 2))
    write_obj(tmp_path / "a.obj", V, F, UV)
    V2, F2, UV2, FUV2 = read_obj(tmp_path / "a.obj")
    assert np.array_equal(F2, F) and np.array_equal(FUV2, F)
    assert np.array_equal(V2, V) and np.array_equal(UV2, UV)  # 17 digits: exact


@pytest.mark.parametrize("ext", ["obj", "off", "ply", "stl", "glb"])
def test_load_formats(tmp_path, ext):
    V, F = datasets.saddle(3)
    write_mesh(tmp_path / f"m.{ext}", V, F)
    V2, F2 = load_mesh(tmp_path / f"m.{ext}")
    assert len(F2) == len(F)
    if ext != "stl":  # STL stores triangle soups
        assert len(V2) == len(V)


BAD = {
    "missing.obj": None,
    "empty.obj": "",
    "garbage.obj": "this is not a mesh\x00\x01\x02 {{{\n",
    "points.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
    "nan.obj": "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
    "lines.obj": "v 0 0 0\nv 1 0 0\nl 1 2\n",
}


def test_load_mesh_errors(tmp_path):
    with pytest.raises(MeshLoadError, match="no such file"):
        load_mesh(tmp_path / "nope.obj")
    (tmp_path / "e.ply").write_bytes(b"")
    with pytest.raises(MeshLoadError, match="empty"):
        load_mesh(tmp_path / "e.ply")


QUAD = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"


def test_obj_byte_order_mark_and_line_continuation_read_as_the_plain_file(tmp_path):
    plain, odd = tmp_path / "plain.obj", tmp_path / "odd.obj"
    plain.write_text(QUAD + "f 1/1 2/2 3/3 4/4\n", encoding="utf-8")
    # a byte-order mark before the first vertex, and the face continued over two lines (CRLF endings)
    odd.write_bytes(("\ufeff" + QUAD + "f 1/1 2/2 \\\n  3/3 4/4\n").replace("\n", "\r\n").encode("utf-8"))
    a, b = read_obj(plain), read_obj(odd)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    assert b.notes["lines"] == 10
    with pytest.raises(MeshLoadError, match="line 9"):  # errors name the continued line's first line
        (tmp_path / "bad.obj").write_text(QUAD + "f 1/1 2/2 \\\n 3/3 9/9\n", encoding="utf-8")
        read_obj(tmp_path / "bad.obj")
    (tmp_path / "end.obj").write_text(QUAD + "f 1/1 2/2 3/3 \\\n", encoding="utf-8")
    with pytest.raises(MeshLoadError, match="ends inside a continued line"):
        read_obj(tmp_path / "end.obj")


def test_patch_obj_keeps_the_byte_order_mark_and_rewrites_a_continued_face_whole(tmp_path):
    from neuraluv.io import patch_obj
    src, dst = tmp_path / "src.obj", tmp_path / "dst.obj"
    src.write_bytes(("\ufeffvt 0.5 0.5\n" + QUAD + "f 1/2 2/3 \\\n 3/4 4/5\n").encode("utf-8"))
    V, F, UV, FUV = read_obj(src)
    UV2 = UV.copy()
    UV2[0] = [0.25, 0.25]  # the first line's vt changes: the mark stays
    FUV2 = FUV.copy()
    FUV2[0, 1] = 0  # the continued face changes: its two lines become one
    patch_obj(src, dst, UV2, FUV2)
    out = dst.read_bytes().decode("utf-8")
    assert out.startswith("\ufeffvt 0.25 0.25\n") and "\\" not in out
    V3, F3, UV3, FUV3 = read_obj(dst)
    np.testing.assert_array_equal(F3, F)
    np.testing.assert_array_equal(UV3[FUV3], UV2[FUV2])


def test_atomic_write_removes_what_a_killed_write_left(tmp_path):
    import subprocess
    import sys

    from neuraluv.io import atomic_write
    out = tmp_path / "mesh.obj"
    # a writer killed mid-write (SIGKILL: no handler runs) leaves its temporary file
    code = ("import os, signal, sys; from neuraluv.io import atomic_write\n"
            "with atomic_write(sys.argv[1]) as fh:\n    fh.write('half'); fh.flush(); os.kill(os.getpid(), signal.SIGKILL)")
    subprocess.run([sys.executable, "-c", code, str(out)])
    left = list(tmp_path.glob(".mesh.obj.*.tmp"))
    assert len(left) == 1 and not out.exists()
    other = tmp_path / ".mesh.obj.notapid.x.tmp"  # not one of ours: kept
    other.write_text("keep")
    with atomic_write(out) as fh:
        fh.write("whole")
    assert out.read_text() == "whole"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["mesh.obj", other.name])


def test_patch_obj_defines_new_rows_above_their_first_use(tmp_path):
    # vt rows interleaved with faces (as exporters write one object after another): a new row used by the first
    # object's faces must be defined above them, and the second object's rows, now further down, renumbered
    src = tmp_path / "a.obj"
    src.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                   "vt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n"
                   "vt 0.5 0.5\nvt 0.9 0.5\nvt 0.5 0.9\nf 2/4 4/5 3/6\n")
    V, F, UV, FUV = read_obj(src)
    UV2 = np.vstack([UV, [[0.2, 0.2], [0.3, 0.2], [0.2, 0.3]]])
    FUV2 = FUV.copy()
    FUV2[0] = [6, 7, 8]  # the first face gets new rows
    info = patch_obj(src, tmp_path / "b.obj", UV2, FUV2)
    V3, F3, UV3, FUV3 = read_obj(tmp_path / "b.obj")  # the strict reader: every row defined above its use
    assert info["vt_lines_added"] == 3
    assert np.array_equal(F3, F) and np.array_equal(UV3[FUV3], UV2[FUV2])
    lines = (tmp_path / "b.obj").read_text().splitlines()
    assert lines[:7] == src.read_text().splitlines()[:7]  # untouched above the insertion point
