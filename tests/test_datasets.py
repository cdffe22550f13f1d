"""Data registry, derived compact charts, packing, and the environment files."""
import re
from pathlib import Path

import pytest

from neuraluv import datasets
from neuraluv.errors import NeuralUVError
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
