"""Blender and xatlas beside our atlas and packer (``bench speed --atlas``, issue 28 items 1 and 4): tiny inputs."""
import re

import numpy as np
import pytest

from neuraluv import datasets
from neuraluv_paper.baselines.external import blender_python
from neuraluv_paper.bench.pack_reference import (
    PACKER_LABELS,
    blender_atlas,
    island_list,
    packer_reference,
    packers_markdown,
)

NO_BPY = "Blender's bpy not installed (`make blender-env`, or set NEURALUV_BPY_PYTHON to a Python with bpy 4.5)"
RES, PAD = 128, 4.0


def _squares():
    """Three flat square islands (sides 1, 2, 1.5) laid out apart: a layout whose 3D and UV agree."""
    V, F, UV = [], [], []
    x = 0.0
    for s in (1.0, 2.0, 1.5):
        q = np.array([[0, 0], [s, 0], [s, s], [0, s]]) + [x, 0]
        k = len(UV)
        V += [[a, b, 0.0] for a, b in q]
        UV += list(q / 10)
        F += [[k, k + 1, k + 2], [k, k + 2, k + 3]]
        x += s + 1
    F = np.array(F)
    return np.array(V), F, np.array(UV), F.copy()


def _row(md, label):
    """The cells of the table row holding ``label``."""
    line = next(ln for ln in md.splitlines() if label in ln)
    return [c.strip() for c in line.strip("|").split("|")]


def _pct(cell):
    assert re.fullmatch(r"\d+\.\d+%", cell), cell
    return float(cell[:-1]) / 100


def test_island_list_splits_by_shared_vt_rows():
    uvs, tris, rows = island_list(*_squares()[2:])
    assert [len(u) for u in uvs] == [4, 4, 4] and [t.tolist() for t in tris] == [[[0, 1, 2], [0, 2, 3]]] * 3
    assert [r.tolist() for r in rows] == [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]]


def test_packers_without_blender_say_so_in_one_line(monkeypatch, tmp_path):
    monkeypatch.setenv("NEURALUV_BPY_PYTHON", str(tmp_path / "no-python"))  # as in CI: no bpy
    rows = packer_reference(*_squares(), RES, PAD)
    by = {r["packer"]: r for r in rows}
    assert list(by) == ["ours", "xatlas", "blender"]
    for k in ("ours", "xatlas"):
        r = by[k]
        assert r["status"] == "ok" and r["islands"] == 3 and r["seconds"] > 0, r
        assert 0.2 < r["utilisation"] < 1 and r["flips"] == r["overlapping_pairs"] == r["mirrored_islands"] == 0
        assert r["min_gap_texels"] >= PAD * (1 - 1e-6) and r["padding_violations"] == 0
    assert by["ours"]["density_spread"] < 1e-6  # the islands keep their relative scales
    assert by["blender"]["status"] == "unavailable" and "make blender-env" in by["blender"]["reason"]
    md = packers_markdown({"squares": rows}, RES, PAD)
    for k in ("ours", "xatlas"):
        cells = _row(md, PACKER_LABELS[k])
        assert cells[:2] == ["squares", "3"] and float(cells[3]) >= 0
        assert _pct(cells[4]) == pytest.approx(by[k]["utilisation"], abs=1e-4)
    assert "unavailable: Blender's bpy module not found" in _row(md, PACKER_LABELS["blender"])[3]
    assert "\n" not in by["blender"]["reason"]
    b = blender_atlas(*datasets.sphere(1), RES, PAD)
    assert b["status"] == "unavailable" and set(b) == {"status", "reason"}


def test_atlas_speed_blender_columns_without_blender_are_one_line():
    from neuraluv_paper.bench.speed_atlas import blender_markdown

    why = "Blender's bpy module not found: run `make blender-env`"
    rows = [{"asset": "cow", "kind": "registry", "wall_s": 20.0, "utilisation": 0.7, "xatlas_utilisation": 0.55,
             "blender_status": "unavailable", "blender_reason": why}]
    md = "\n".join(blender_markdown(rows))
    assert _row(md, "| cow |")[1:4] == ["70.00%", "55.00%", "—"]
    line = f"Blender not run on 1 of 1 assets — unavailable: {why}"
    assert [ln for ln in md.splitlines() if "not run" in ln] == [line]


@pytest.mark.skipif(blender_python() is None, reason=NO_BPY)
def test_blender_atlas_and_pack_islands_are_timed_and_measured():
    V, F = datasets.sphere(2)
    b = blender_atlas(V, F, RES, PAD)
    assert b["status"] == "ok", b.get("reason")
    assert b["unwrap_s"] > 0 and b["pack_s"] > 0 and b["process_s"] > b["unwrap_s"] + b["pack_s"]
    assert b["version"].startswith("4.5") and b["islands"] >= 2 and 0.2 < b["utilisation"] < 1
    assert b["flips"] == b["overlapping_pairs"] == b["mirrored_islands"] == 0
    assert b["min_gap_texels"] >= 0.9 * PAD  # Blender's margin is the padding, to its packer's precision
    rows = packer_reference(*_squares(), RES, PAD)
    r = rows[-1]
    assert r["packer"] == "blender" and r["status"] == "ok", r.get("reason")
    assert r["islands"] == 3 and r["mirrored_islands"] == r["flips"] == r["overlapping_pairs"] == 0
    assert 0 < r["seconds"] < r["process_s"] and 0.2 < r["utilisation"] < 1 and r["density_spread"] < 1e-4
    assert r["min_gap_texels"] >= 0.9 * PAD
    cells = _row(packers_markdown({"squares": rows}, RES, PAD), PACKER_LABELS["blender"])
    assert _pct(cells[4]) == pytest.approx(r["utilisation"], abs=1e-4) and "process" in cells[3]
