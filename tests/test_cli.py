"""CLI round trips and bad-input errors (one line, non-zero exit, no traceback)."""
import json
import subprocess
import sys

import numpy as np
import pytest

from neuraluv import datasets
from neuraluv.atlas import build_atlas
from neuraluv.cli import main
from neuraluv.datasets.generated import generated_asset
from neuraluv.io import read_obj
from neuraluv.metrics import distortion_metrics
from neuraluv.repair.diagnose import diagnose_layout
from neuraluv_paper import damage

from conftest import strip_island, three_copies, two_islands, write_layout, write_mesh


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "neuraluv.cli", *map(str, args)], capture_output=True, text=True, timeout=600)


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
def test_cli_closed_mesh_says_why(tmp_path):
    write_mesh(tmp_path / "s.ply", *datasets.sphere(1))
    r = run_cli("unwrap", tmp_path / "s.ply", "-o", tmp_path / "o.obj", "--preset", "test", "--quiet")
    assert r.returncode == 2 and "closed surface" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.slow
def test_cli_demo(tmp_path):
    r = run_cli("demo", "-o", tmp_path, "--preset", "test", "--quiet", "--mesh", "cap")
    assert r.returncode == 0, r.stderr
    for n in ("demo.obj", "demo_report.json", "demo_checkerboard.png", "demo_uv_layout.png"):
        assert (tmp_path / n).stat().st_size > 0
    from matplotlib.image import imread

    img = imread(tmp_path / "demo_checkerboard.png")
    assert img[..., :3].std() > 0.05  # a real picture, not a blank canvas


@pytest.mark.slow
def test_cli_atlas_stack_reads_back_valid(tmp_path, capsys):
    from neuraluv.cli import main

    from conftest import write_mesh

    V, F, _ = three_copies()
    write_mesh(tmp_path / "in.obj", V, F)
    rc = main(["atlas", str(tmp_path / "in.obj"), "-o", str(tmp_path / "out.obj"), "--preset", "test", "--stack",
               "--resolution", "256", "--padding", "2", "--quiet", "--device", "cpu"])
    out = capsys.readouterr().out
    assert rc == 0 and "islands stacked on identical ones" in out, out


@pytest.mark.slow
def test_atlas_cuts_a_long_island_validly_and_whole_islands_keeps_it(tmp_path, capsys):
    from neuraluv.cli import main

    from conftest import write_mesh

    uv, F = strip_island(24, 1.0)  # a flat 24:1 ribbon: one long island, a poor fit for a square texture
    V = np.column_stack([uv, 0.1 * np.sin(uv[:, 0])])
    res = build_atlas(V, F, "test", resolution=256, padding=2)
    whole = build_atlas(V, F, "test", resolution=256, padding=2, cut_islands=False)
    assert whole.info["cut_islands"] == 0 and whole.info["cut"] is False and res.info["cut"] is True
    assert res.info["cut_islands"] > 0 and res.info["utilisation"] >= whole.info["utilisation"] + 0.01
    for r in (res, whole):
        v = r.validation
        assert v["valid"] and v["flips"] == 0 and v["overlapping_pairs"] == 0 and v["padding_violations"] == 0
        assert v["density_spread"] < 0.05  # each part scaled to its own 3D area
    assert res.validation["islands"] == whole.validation["islands"] + res.info["cut_islands"]
    write_mesh(tmp_path / "in.obj", V, F)
    for flag, said in (([], True), (["--whole-islands"], False)):
        rc = main(["atlas", str(tmp_path / "in.obj"), "-o", str(tmp_path / "out.obj"), "--preset", "test",
                   "--resolution", "256", "--padding", "2", "--quiet", "--device", "cpu", *flag])
        out = capsys.readouterr().out
        assert rc == 0 and ("islands added by cutting large ones" in out) == said, out


@pytest.mark.slow
def test_cli_check_uv_and_repair(tmp_path, capsys):
    import json

    from neuraluv.cli import main

    V, F, UV, FUV, a, b = two_islands()
    good = tmp_path / "good.obj"
    write_layout(good, V, F, UV, FUV)
    assert main(["check", "--uv", str(good)]) == 0
    assert "nothing to repair" in capsys.readouterr().out
    assert main(["repair", str(good), "-o", str(tmp_path / "same.obj"), "--quiet"]) == 0
    assert (tmp_path / "same.obj").read_bytes() == good.read_bytes()
    assert "nothing to repair" in capsys.readouterr().out
    uv, _ = damage.overlap_islands(UV, FUV, a, b)
    uv, _ = damage.mirror_island(uv, FUV, b)
    broken = tmp_path / "broken.obj"
    write_layout(broken, V, F, uv, FUV)
    # the default purpose (texture): a mirrored island and two islands on the same texels are intent, not damage
    assert main(["check", "--uv", str(broken), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["purpose"] == "texture" and rep["ok"] and not rep["problems"]
    assert {"mirrored", "shared_texels"} <= {p["kind"] for p in rep["features"]}
    assert main(["repair", str(broken), "-o", str(tmp_path / "kept.obj"), "--quiet"]) == 0
    assert (tmp_path / "kept.obj").read_bytes() == broken.read_bytes()
    assert "purpose: texture (default" in capsys.readouterr().out
    # a bake's rules: both are problems, and repair makes the layout unique
    assert main(["check", "--uv", str(broken), "--json", "--purpose", "bake"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert {"mirrored_island", "island_overlap"} <= {p["kind"] for p in rep["problems"]}
    code = main(["repair", str(broken), "-o", str(tmp_path / "fixed.obj"), "--report", str(tmp_path / "r.json"),
                 "--figure", str(tmp_path / "r.png"), "--quiet", "--purpose", "bake"])
    assert code == 0, capsys.readouterr()
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["readback"]["valid"] and r["after"]["ok"] and r["readback"]["purpose"] == "bake"
    assert (tmp_path / "r.png").stat().st_size > 1000
    d = diagnose_layout(*read_obj(tmp_path / "fixed.obj"))
    assert d.ok, [p["kind"] for p in d.problems]


@pytest.mark.slow
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
               "--resolution", "512", "--threads", "1", "--quiet", "--pack-trials", "2"])
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


def test_the_command_exits_with_mains_status_and_its_output_whole(tmp_path):
    # console() ends the process without the interpreter's teardown: the status and every line must still arrive
    r = run_cli("--version")
    assert r.returncode == 0 and r.stdout.strip().startswith("neuraluv ")
    r = run_cli("check", tmp_path / "missing.obj")
    assert r.returncode == 2 and r.stderr.startswith("neuraluv: error:")
    write_mesh(tmp_path / "d.obj", *datasets.disk(3))
    r = run_cli("check", tmp_path / "d.obj", "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["faces"] > 0
