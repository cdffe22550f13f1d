"""CLI round trips and bad-input errors (one line, non-zero exit, no traceback)."""

import numpy as np
import pytest

from neuraluv import datasets
from neuraluv.errors import MeshLoadError
from neuraluv.io import load_mesh, read_obj, write_obj

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
