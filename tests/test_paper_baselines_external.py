"""The external binaries built by `make baselines`: the BFF command-line tool and OptCuts.

Tests that run a binary skip with the reason when it has not been built; the
adapters' lookup and their "unavailable" message are tested without it.
"""
import os
import stat

import numpy as np
import pytest

from neuraluv import datasets
from neuraluv.metrics import distortion_metrics
from neuraluv_paper.baselines import bff_binary, optcuts_binary, run_baseline
from neuraluv_paper.baselines.external import built_binary

NO_BFF = "bff-command-line not built (run `make baselines`, or set NEURALUV_BFF)"
NO_OPTCUTS = "OptCuts_bin not built (run `make baselines`, or set NEURALUV_OPTCUTS)"


def test_built_binaries_are_found_under_the_cache(tmp_path, monkeypatch):
    tool = tmp_path / ".cache" / "third_party" / "bin" / "neuraluv-fake-tool"
    tool.parent.mkdir(parents=True)
    tool.write_text("#!/bin/sh\n")
    assert built_binary("neuraluv-fake-tool") is None  # not executable, not under the cwd yet
    tool.chmod(tool.stat().st_mode | stat.S_IEXEC)
    monkeypatch.chdir(tmp_path)
    assert built_binary("neuraluv-fake-tool") == str(tool)


def test_environment_variables_win(tmp_path, monkeypatch):
    fake = tmp_path / "tool"
    fake.write_text("")
    monkeypatch.setenv("NEURALUV_BFF", str(fake))
    monkeypatch.setenv("NEURALUV_OPTCUTS", str(fake))
    assert bff_binary() == optcuts_binary() == str(fake)
    monkeypatch.setenv("NEURALUV_BFF", str(tmp_path / "missing"))
    assert bff_binary() is None


def test_bff_cli_unavailable_names_make_baselines(monkeypatch, tmp_path):
    monkeypatch.setenv("NEURALUV_BFF", str(tmp_path / "missing"))
    r = run_baseline("bff-cli", *datasets.disk(3))
    assert r.status == "unavailable" and "make baselines" in r.reason and "NEURALUV_BFF" in r.reason
    monkeypatch.setenv("NEURALUV_OPTCUTS", str(tmp_path / "missing"))
    r = run_baseline("optcuts", *datasets.disk(3))
    assert r.status == "unavailable" and "make baselines" in r.reason and "Triangle" in r.reason


@pytest.mark.skipif(bff_binary() is None, reason=NO_BFF)
def test_bff_cli_agrees_with_our_bff_on_a_disk():
    V, F = datasets.bumpy_disk(n_rings=6)
    cli = run_baseline("bff-cli", V, F)
    ours = run_baseline("bff", V, F)
    assert cli.status == "ok", cli.reason
    assert cli.rescaled and cli.uv.shape == (len(cli.V), 2) and cli.F.shape == F.shape
    np.testing.assert_allclose(cli.V[cli.F], V[F])  # the input's faces, in the input's order
    assert len(cli.V) == len(V)  # a disk is not cut
    assert cli.metrics["flips"] == 0 and cli.metrics["min_det"] > 0
    assert cli.metrics == distortion_metrics(cli.V, cli.F, cli.uv)
    assert ours.metrics["esd"] > 4.01  # the disk is curved: not a trivial isometry
    assert abs(cli.metrics["esd"] - ours.metrics["esd"]) < 0.03 * ours.metrics["esd"]
    assert abs(cli.metrics["area"] - ours.metrics["area"]) < 0.05 * max(ours.metrics["area"], 1e-3)


@pytest.mark.skipif(bff_binary() is None, reason=NO_BFF)
def test_bff_cli_on_several_components_keeps_every_face():
    V, F = datasets.several_components(4)
    r = run_baseline("bff-cli", V, F)
    assert r.status == "ok", r.reason
    np.testing.assert_allclose(r.V[r.F], V[F])
    assert r.metrics["flips"] == 0 and r.metrics["n_faces"] == len(F)


@pytest.mark.skipif(optcuts_binary() is None, reason=NO_OPTCUTS)
def test_optcuts_binary_on_a_tiny_cap():
    V, F = datasets.spherical_cap(n_rings=5)
    r = run_baseline("optcuts", V, F, timeout=300)
    assert r.status == "ok", r.reason
    assert not r.rescaled and r.uv.shape == (len(r.V), 2) and r.F.shape == F.shape
    assert r.metrics["n_faces"] == len(F) and r.metrics["flips"] == 0
    assert np.isfinite(r.metrics["esd"]) and r.metrics["esd"] < 4.2  # OptCuts' bound is 4.1 on E_SD
    # OptCuts may re-order faces and cut seams, but the surface is the same: same total 3D area
    a = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()
    b = np.linalg.norm(np.cross(r.V[r.F[:, 1]] - r.V[r.F[:, 0]], r.V[r.F[:, 2]] - r.V[r.F[:, 0]]), axis=1).sum()
    assert abs(a - b) < 1e-6 * a
    assert os.path.basename(optcuts_binary()).startswith("OptCuts")


@pytest.mark.skipif(bff_binary() is None, reason=NO_BFF)
def test_bff_agreement_report(tmp_path):
    from neuraluv_paper.bench.baselines import bff_agreement

    res = bff_agreement(["disk"], output=tmp_path, repeats=1, show_progress=False)
    assert [r["variant"] for r in res.rows][0] == "ours (Python BFF)" and len(res.rows) == 3
    assert all(r["status"] == "ok" and r["flips"] == 0 for r in res.rows)
    assert all(abs(r["esd_rel_diff"]) < 0.01 and r["rms_distance"] < 1e-3 for r in res.rows[1:])
    md = (tmp_path / "bff_agreement.md").read_text()
    assert "Produced by" in md and "Machine:" in md and (tmp_path / "bff_agreement.csv").exists()
