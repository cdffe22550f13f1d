"""CLI round trips and bad-input errors (one line, non-zero exit, no traceback)."""
import subprocess
import sys

import numpy as np
import pytest

from conftest import write_mesh

from neuraluv import datasets
from neuraluv.cli import main
from neuraluv.io import read_obj
from neuraluv.metrics import distortion_metrics


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "neuraluv.cli", *map(str, args)], capture_output=True, text=True, timeout=600)


def test_cli_unwrap_roundtrip_multicomponent(tmp_path):
    V, F = datasets.several_components(4)
    write_mesh(tmp_path / "in.obj", V, F)
    assert main(["unwrap", str(tmp_path / "in.obj"), "-o", str(tmp_path / "out.obj"), "--preset", "test", "--report", str(tmp_path / "r.json"), "--quiet", "--device", "cpu"]) == 0
    V2, F2, UV, FUV = read_obj(tmp_path / "out.obj")
    assert FUV is not None and len(F2) == len(F)
    assert UV.min() >= 0 and UV.max() <= 1
    m = distortion_metrics(V2, F2, UV[FUV.reshape(-1)][np.arange(3 * len(F2)).reshape(-1, 3)] if False else UV)
    assert m["flips"] == 0  # orientation preserved, no mirrored chart
    # charts do not overlap: their UV bounding boxes are disjoint
    from neuraluv.topology import split_components

    boxes = [(UV[v].min(0), UV[v].max(0)) for v, _ in split_components(V2, F2)]
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            (a0, a1), (b0, b1) = boxes[i], boxes[j]
            assert np.any(a1 <= b0) or np.any(b1 <= a0)
    import json

    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["totals"]["charts"] == 3 and rep["totals"]["flips"] == 0
    assert all(c["status"] == "neural" and c["metrics"]["esd"] >= 4 for c in rep["charts"])


BAD = {
    "missing.obj": None,
    "empty.obj": "",
    "garbage.obj": "this is not a mesh\x00\x01\x02 {{{\n",
    "points.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
    "nan.obj": "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
    "lines.obj": "v 0 0 0\nv 1 0 0\nl 1 2\n",
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_cli_bad_input(tmp_path, name):
    if BAD[name] is not None:
        (tmp_path / name).write_text(BAD[name])
    out = tmp_path / "out.obj"
    r = run_cli("unwrap", tmp_path / name, "-o", out, "--preset", "test", "--quiet")
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    lines = [l for l in r.stderr.splitlines() if l.strip()]
    assert len(lines) == 1 and lines[0].startswith("neuraluv: error:")
    assert not out.exists()
    assert not any(p.name.startswith(".out.obj") for p in tmp_path.iterdir())  # no temp files left


def test_cli_closed_mesh_says_why(tmp_path):
    write_mesh(tmp_path / "s.ply", *datasets.sphere(1))
    r = run_cli("unwrap", tmp_path / "s.ply", "-o", tmp_path / "o.obj", "--preset", "test", "--quiet")
    assert r.returncode == 2 and "closed surface" in r.stderr and "Traceback" not in r.stderr


def test_cli_demo(tmp_path):
    r = run_cli("demo", "-o", tmp_path, "--preset", "test", "--quiet", "--mesh", "cap")
    assert r.returncode == 0, r.stderr
    for n in ("demo.obj", "demo_report.json", "demo_checkerboard.png", "demo_uv_layout.png"):
        assert (tmp_path / n).stat().st_size > 0
    from matplotlib.image import imread

    img = imread(tmp_path / "demo_checkerboard.png")
    assert img[..., :3].std() > 0.05  # a real picture, not a blank canvas
