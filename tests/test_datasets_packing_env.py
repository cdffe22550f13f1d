"""Data registry, derived compact charts, packing, and the environment files."""
import re
from pathlib import Path

import numpy as np
import pytest

from neuraluv import datasets
from neuraluv.errors import NeuralUVError
from neuraluv.packing import shelf_pack
from neuraluv.topology import is_disk_like, topology_scan

from conftest import real_mesh

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", ["disk", "cap", "saddle", "bumpy", "glove"])
def test_procedural_charts_are_disks(name):
    assert is_disk_like(*datasets.procedural(name))[0]


def test_fetch_from_mirror_checks_hash(tmp_path, monkeypatch):
    monkeypatch.setenv("NEURALUV_DATA", str(tmp_path / "cache"))
    mirror = tmp_path / "mirror"
    mirror.mkdir()
    (mirror / "cow.off").write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    with pytest.raises(NeuralUVError, match="sha256"):
        datasets.fetch("cow", mirror)
    assert not (tmp_path / "cache" / "cow.off").exists()
    with pytest.raises(datasets.DataMissing):
        datasets.fetch("cow", download=False)
    with pytest.raises(NeuralUVError, match="unknown registry mesh"):
        datasets.fetch("nope")


def test_registry_is_complete():
    for name, (fname, url, sha, lic) in datasets.REGISTRY.items():
        assert url.startswith("https://") and url.endswith(fname)
        assert re.fullmatch(r"[0-9a-f]{64}", sha)
    assert set(datasets.COMPACT.values()) <= set(datasets.REGISTRY)


@pytest.mark.parametrize("name,nv,nf,comps", [("camel", 2032, 3576, 1), ("hand", 4712, 9376, 1), ("bob", 5647, 10688, 3)])
def test_compact_charts_derived_as_documented(name, nv, nf, comps):
    V, F = real_mesh(name)
    r = topology_scan(V, F)
    assert (len(V), len(F), r.components, r.boundary_loops) == (nv, nf, comps, comps)


def test_shelf_pack_no_overlap_padding():
    rng = np.random.default_rng(0)
    charts = [rng.random((20, 2)) * rng.uniform(0.2, 3, 2) for _ in range(12)]
    res = shelf_pack(charts, padding=4, resolution=512)
    boxes = [(u.min(0), u.max(0)) for u in res.uvs]
    for u in res.uvs:
        assert u.min() >= 0 and u.max() <= 1
    gap = 4 / 512
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            (a0, a1), (b0, b1) = boxes[i], boxes[j]
            sep = max(b0[0] - a1[0], a0[0] - b1[0], b0[1] - a1[1], a0[1] - b1[1])
            assert sep >= gap * 0.999
    assert res.padding_texels >= 4 * 0.999
    # uniform scale: relative chart sizes kept
    s = [(u.max(0) - u.min(0)) / (c.max(0) - c.min(0)) for u, c in zip(res.uvs, charts)]
    assert np.allclose(s, s[0][0])


def _names(reqs):
    return {re.split(r"[<>=!~ \[]", r.strip(), maxsplit=1)[0].lower() for r in reqs}


def test_environment_yml_matches_pyproject():
    import tomllib

    import yaml

    pp = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = pp["optional-dependencies"]
    wanted = set(pp["dependencies"]) | set(extras["test"]) | set(extras["docs"])
    env = yaml.safe_load((ROOT / "environment.yml").read_text())
    pip = [d for d in env["dependencies"] if isinstance(d, dict)][0]["pip"]
    pip = [p for p in pip if not p.startswith("-e")]
    assert set(pip) == wanted  # same names and the same pins
    assert "torch==2.13.0" in pp["dependencies"]
