"""Sweeps on a dask LocalCluster: results, resume, timeout, tables."""
import csv

import numpy as np
import pytest

pytest.importorskip("distributed", reason="dask.distributed is not installed")

from neuraluv.atlas.sweep import atlas_asset, list_assets, summarize, sweep  # noqa: E402
from neuraluv.datasets.generated import generated_asset  # noqa: E402
from neuraluv.io import write_obj  # noqa: E402

#: sweeps here test scheduling, resume and tables, not packing: the shelf packer (milliseconds)
KW = dict(preset="test", iterations=10, resolution=512, padding=4, packer="shelf")


@pytest.fixture
def assets(tmp_path):
    d = tmp_path / "in"
    for i in (1, 4, 7):
        V, F, info = generated_asset(i, res=12)
        write_obj(d / f"{info['name']}.obj", V, F, np.zeros((len(V), 2)))
    (d / "broken.obj").write_text("not a mesh\n")
    return d


@pytest.mark.slow
def test_sweep_local_cluster_resume_and_tables(assets, tmp_path):
    out = tmp_path / "out"
    assert len(list_assets(assets)) == 4
    res = sweep(assets, out, n_workers=2, processes=False, isolate=False, progress=False, timeout=120, **KW)
    by = {r["name"].split("__")[-1]: r for r in res.rows}
    assert by["broken"]["status"] == "error" and not by["broken"]["ok"]
    good = [r for n, r in by.items() if n != "broken"]
    assert all(r["ok"] and r["flips"] == 0 and r["overlaps"] == 0 for r in good)
    s = res.summary
    assert (s["tried"], s["ok"], s["flips"]) == (4, 3, 0)
    assert s["faces"] == sum(r["faces"] for r in good) > 0
    assert abs(s["neural_share"] + s.get("exact_share", 0) + s["fallback_share"] - 1) < 1e-9
    rows = list(csv.DictReader(open(res.paths["csv"])))
    assert len(rows) == 4
    md = res.paths["markdown"].read_text()
    assert "| Tried | OK |" in md and "Neural / exact / fallback faces" in md
    # resume: finished assets are not recomputed
    res2 = sweep(assets, out, n_workers=2, processes=False, isolate=False, progress=False, timeout=120, **KW)
    st = {r["name"].split("__")[-1]: r["status"] for r in res2.rows}
    assert [st[n] for n in sorted(st) if n != "broken"] == ["cached"] * 3
    assert res2.summary["faces"] == s["faces"]


def test_subprocess_timeout_is_reported(assets, tmp_path):
    row = atlas_asset(assets / "gen_001.obj", tmp_path / "t", timeout=0.5, isolate=True, **KW)
    assert row["status"] == "timeout" and not row["ok"]


def test_summarize_counts_only_successes():
    rows = [{"ok": True, "faces": 10, "flips": 0, "neural_share": 0.5, "time": 1.0},
            {"ok": False, "faces": 0, "flips": -1, "neural_share": 0.0, "time": 9.0}]
    s = summarize(rows)
    assert (s["tried"], s["ok"], s["faces"], s["median_time"]) == (2, 1, 10, 1.0)


def _dask_cli():
    import shutil
    import sys
    from pathlib import Path

    exe = Path(sys.executable).with_name("dask")
    return str(exe) if exe.exists() else shutil.which("dask")


@pytest.mark.slow
@pytest.mark.skipif(_dask_cli() is None, reason="the dask command line is not installed (pip install 'neuraluv[sweep]')")
def test_sweep_on_a_separately_started_cluster_with_relative_paths(tmp_path, monkeypatch, capsys):
    """`dask scheduler` and two `dask worker`s started in another folder; the sweep names its inputs relatively."""
    import json
    import subprocess
    import time

    from neuraluv.cli import main

    dask = _dask_cli()
    (tmp_path / "workers").mkdir()
    (tmp_path / "in").mkdir()
    for i in (1, 4):
        V, F, info = generated_asset(i, res=12)
        write_obj(tmp_path / "in" / f"{info['name']}.obj", V, F, np.zeros((len(V), 2)))
    sched_file = tmp_path / "scheduler.json"
    quiet = dict(cwd=tmp_path / "workers", stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([dask, "scheduler", "--scheduler-file", str(sched_file), "--port", "0",
                               "--dashboard-address", ":0", "--no-show"], **quiet)]
    try:
        end = time.time() + 60
        while not sched_file.exists() and time.time() < end:
            time.sleep(0.2)
        address = json.loads(sched_file.read_text())["address"]
        procs += [subprocess.Popen([dask, "worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard"],
                                   **quiet) for _ in range(2)]
        monkeypatch.chdir(tmp_path)  # the sweep runs elsewhere than the workers, and names its paths relatively
        code = main(["sweep", "in", "-o", "out", "--scheduler", address, "--in-process", "--preset", "test",
                     "--iterations", "10", "--resolution", "512", "--packer", "shelf", "--quiet"])
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            p.wait(timeout=30)
    out = capsys.readouterr().out
    assert code == 0, out
    rows = list(csv.DictReader(open(tmp_path / "out" / "results.csv")))
    assert [r["ok"] for r in rows] == ["True", "True"], rows
