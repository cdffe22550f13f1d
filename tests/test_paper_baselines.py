"""Baselines: one result type, the paper's failure modes, optional tools skipping cleanly."""
import stat
import sys
import textwrap

import numpy as np
import pytest

from neuraluv import datasets
from neuraluv.metrics import distortion_metrics
from neuraluv.solver import ChartResult
from neuraluv.tutte import tutte
from neuraluv_paper.baselines import METHODS, BaselineResult, blender_python, run_baseline

from conftest import real_mesh

LIBIGL = ["harmonic", "lscm", "arap", "slim-20"]


def test_method_names_and_unknown_method():
    assert {"harmonic", "lscm", "arap", "slim-20", "slim-1k", "bff", "xatlas", "blender-smart", "blender-angle",
            "blender-conformal", "blender-minstretch", "optcuts", "bff-cli", "neural"} == set(METHODS)
    with pytest.raises(ValueError, match="unknown method"):
        run_baseline("nope", *datasets.disk(3))


def test_lscm_on_planar_disk_is_a_similarity():
    V, F = datasets.disk(n_rings=5)
    r = run_baseline("lscm", V, F)
    assert isinstance(r, BaselineResult) and isinstance(r, ChartResult)
    assert r.status == "ok" and r.rescaled and r.time > 0
    assert abs(r.metrics["conformal"] - 1) < 1e-6
    assert abs(r.metrics["esd"] - 4) < 1e-6  # rescaled to the 3D area: an isometry
    assert r.metrics == distortion_metrics(r.V, r.F, r.uv)


def test_slim_improves_on_its_tutte_start_without_flips():
    V, F = datasets.bumpy_disk(n_rings=5)
    start = distortion_metrics(V, F, tutte(V, F))["esd"]
    r20 = run_baseline("slim-20", V, F)
    r1k = run_baseline("slim-1k", V, F)
    assert r1k.status == "ok" and not r1k.rescaled
    assert r1k.metrics["flips"] == 0 and r20.metrics["flips"] == 0
    assert r1k.metrics["esd"] < start - 0.1
    assert r1k.metrics["esd"] <= r20.metrics["esd"] + 1e-9


def test_arap_and_harmonic_on_a_cap():
    V, F = datasets.spherical_cap(n_rings=6)
    h = run_baseline("harmonic", V, F)
    a = run_baseline("arap", V, F)
    assert h.status == a.status == "ok"
    assert a.metrics["flips"] == 0
    assert a.metrics["area"] < h.metrics["area"]  # ARAP trades angles for areas


def test_libigl_init_fail_on_several_components_then_per_component():
    V, F = datasets.several_components(4)
    for m in LIBIGL:
        r = run_baseline(m, V, F)
        assert r.status == "init fail" and "3 connected components" in r.reason and r.uv is None
        assert not r.produced and np.isnan(r.metrics["esd"])
        pc = run_baseline(m, V, F, per_component=True)
        assert pc.status == "ok" and pc.produced, (m, pc.reason)
        assert len(pc.components) == 3 and pc.metrics["n_faces"] == len(F)
        assert pc.metrics["flips"] == sum(c.metrics["flips"] for c in pc.components)
        assert np.isclose(pc.time, sum(c.time for c in pc.components))


def test_init_fail_on_closed_and_annulus_inputs():
    r = run_baseline("lscm", *datasets.sphere(1))
    assert r.status == "init fail" and "closed" in r.reason
    V, F = datasets.disk(n_rings=5)
    centre = np.flatnonzero(np.linalg.norm(V, axis=1) < 1e-9)
    annulus = F[~np.isin(F, centre).any(axis=1)]
    r = run_baseline("slim-20", V, annulus)
    assert r.status == "init fail" and "boundary loops" in r.reason


def test_bff_handles_components():
    V, F = datasets.several_components(4)
    r = run_baseline("bff", V, F)
    ref = run_baseline("lscm", V, F, per_component=True)
    assert r.status == "ok" and r.metrics["flips"] == 0 and len(r.V) == len(V)
    assert r.metrics["conformal"] < ref.metrics["conformal"] + 0.01  # as conformal as LSCM


def test_xatlas_covers_every_face_of_a_closed_mesh():
    V, F = datasets.sphere(2)
    r = run_baseline("xatlas", V, F)
    assert r.status == "ok" and r.rescaled
    assert r.metrics["n_faces"] == len(F)
    np.testing.assert_allclose(r.V[r.F], V[F])  # face t of the cut mesh is input face t
    assert len(r.V) > len(V)  # seams were cut
    assert r.metrics["flips"] == 0 and np.isfinite(r.metrics["esd"])


def test_error_is_reported_not_raised():
    r = run_baseline("slim-20", *datasets.disk(3), iterations="many")
    assert r.status == "error" and "ValueError" in r.reason and "\n" not in r.reason


def test_optcuts_unavailable(monkeypatch, tmp_path):
    monkeypatch.setenv("NEURALUV_OPTCUTS", str(tmp_path / "missing"))
    r = run_baseline("optcuts", *datasets.disk(3))
    assert r.status == "unavailable" and "NEURALUV_OPTCUTS" in r.reason


def test_optcuts_adapter_with_a_stand_in_binary(monkeypatch, tmp_path):
    # a fake OptCuts_bin that writes finalResult_mesh.obj (the xy projection as UVs), as the real one would
    fake = tmp_path / "OptCuts_bin"
    fake.write_text(textwrap.dedent(f"""\
        #!{sys.executable}
        import os, sys
        assert sys.argv[1] == "100" and len(sys.argv) == 9, sys.argv
        lines = open(sys.argv[2]).read().splitlines()
        v = [l for l in lines if l.startswith("v ")]
        f = [l for l in lines if l.startswith("f ")]
        os.makedirs("output/run", exist_ok=True)
        with open("output/run/finalResult_mesh.obj", "w") as out:
            out.write("\\n".join(v) + "\\n")
            out.write("\\n".join("vt " + " ".join(l.split()[1:3]) for l in v) + "\\n")
            out.write("\\n".join("f " + " ".join(c + "/" + c for c in l.split()[1:]) for l in f) + "\\n")
        """))
    fake.chmod(fake.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setenv("NEURALUV_OPTCUTS", str(fake))
    V, F = datasets.saddle(n_rings=4)  # a height field: its xy projection is flip-free
    r = run_baseline("optcuts", V, F)
    assert r.status == "ok", r.reason
    assert r.metrics["flips"] == 0 and r.metrics["n_faces"] == len(F)
    np.testing.assert_allclose(r.metrics["esd"], distortion_metrics(V, F, V[:, :2])["esd"])  # the stand-in's map
    assert run_baseline("optcuts", *datasets.several_components(3)).status == "init fail"
    assert run_baseline("optcuts", *datasets.several_components(3), single_component=False).status == "ok"


def test_blender_unavailable(monkeypatch, tmp_path):
    monkeypatch.setenv("NEURALUV_BPY_PYTHON", str(tmp_path / "no-python"))
    assert blender_python() is None
    r = run_baseline("blender-smart", *datasets.disk(3))
    assert r.status == "unavailable" and "bpy" in r.reason and "make blender-env" in r.reason


@pytest.mark.skipif(blender_python() is None, reason="Blender's bpy not installed (`make blender-env`, or set NEURALUV_BPY_PYTHON to a Python with `pip install 'bpy==4.5.*'`)")
def test_blender_unwraps_from_loop_uvs():
    V, F = datasets.spherical_cap(n_rings=5)
    r = run_baseline("blender-conformal", V, F)
    assert r.status == "ok", r.reason
    ref = run_baseline("lscm", V, F).metrics["conformal"]  # Blender's CONFORMAL is LSCM
    assert r.metrics["flips"] == 0 and abs(r.metrics["conformal"] - ref) < 0.01
    np.testing.assert_allclose(r.V[r.F], V[F])
    r = run_baseline("blender-smart", *datasets.sphere(1))
    assert r.status == "ok" and r.metrics["n_faces"] == 80 and r.metrics["flips"] == 0


@pytest.mark.skipif(blender_python() is None, reason="Blender's bpy not installed (`make blender-env`, or set NEURALUV_BPY_PYTHON to a Python with `pip install 'bpy==4.5.*'`)")
def test_blender_row_counts_flips_on_loop_uvs():
    from neuraluv_paper.bench.generated import blender_row

    V, F = datasets.spherical_cap(n_rings=5)
    r = blender_row(V, F, "blender-conformal")
    assert r["status"] == "ok" and r["flips"] == 0 and r["coverage"] == 1.0 and r["degenerate"] == 0
    assert abs(r["conformal"] - run_baseline("lscm", V, F).metrics["conformal"]) < 0.01  # the one metric definition


def test_neural_wrapper_returns_the_same_type():
    V, F = datasets.several_components(3)
    r = run_baseline("neural", V, F, preset="test", device="cpu", iterations=5, warmup_iters=5)
    assert isinstance(r, BaselineResult) and r.status == "neural" and r.metrics["flips"] == 0
    assert r.metrics["n_faces"] == len(F) and len(r.components) == 3
    assert run_baseline("neural", *datasets.sphere(1), preset="test").status == "init fail"


# ------------------------------------------------- the paper's compact charts (Tables 1 and 2, tab:compact_prelim and tab:slim_failure_modes)

@pytest.mark.slow
def test_camel_lscm_flips_and_slim_converges():
    V, F = real_mesh("camel")
    lscm = run_baseline("lscm", V, F)
    assert 0.1 < lscm.metrics["flip_percent"] < 0.5  # the paper: 0.22%
    slim = run_baseline("slim-1k", V, F)  # ~10 s on 2 cores
    assert slim.metrics["flips"] == 0
    assert abs(slim.metrics["esd"] - 4.09) < 0.02
    bff = run_baseline("bff", V, F)
    assert bff.metrics["flips"] == 0 and abs(bff.metrics["esd"] - 4.27) < 0.05


def test_bob_libigl_init_fail_and_bff_succeeds():
    V, F = real_mesh("bob")
    assert run_baseline("lscm", V, F).status == "init fail"
    assert run_baseline("slim-20", V, F).status == "init fail"
    assert run_baseline("lscm", V, F, per_component=True).status == "ok"
    assert run_baseline("bff", V, F).metrics["flips"] == 0
