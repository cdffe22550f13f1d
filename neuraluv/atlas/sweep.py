"""Atlas many assets with dask.distributed (paper Table 9, "Larger Amara sweep").

Each asset is one task: by default a ``neuraluv atlas`` subprocess with a hard
per-asset timeout (and a soft time budget of 80% of it, after which remaining
charts become marked fallbacks), so a stuck or crashing asset never takes a
worker down. Finished assets (a report whose read-back validation passed) are
skipped on the next run (resume). Results: one CSV row per asset and a
summary like Table 9 (tab:amara_large_sweep; tried, OK, faces, flips, neural/fallback face shares,
median time) as CSV and Markdown.
"""
from __future__ import annotations

import csv
import io
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from neuraluv.atlas import atlas_file
from neuraluv.errors import NeuralUVError
from neuraluv.io import MESH_EXTENSIONS as MESH_EXTS
from neuraluv.io import atomic_write

__all__ = ["MESH_EXTS", "list_assets", "atlas_asset", "summarize", "SweepResult", "sweep"]

COLUMNS = ["name", "status", "ok", "faces", "flips", "overlaps", "neural_share", "exact_share", "fallback_share", "charts",
           "islands", "time", "input", "output", "error"]


def list_assets(inputs):
    """Mesh paths from folders, files and ``.txt`` lists (sorted, de-duplicated).

    Examples
    --------
    >>> list_assets([])
    []
    """
    if isinstance(inputs, (str, Path)):
        inputs = [inputs]
    out = []
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            out += sorted(q for q in p.rglob("*") if q.suffix.lower() in MESH_EXTS and q.is_file())
        elif p.suffix.lower() == ".txt" and p.is_file():
            out += [Path(line.strip()) for line in p.read_text().splitlines() if line.strip() and not line.startswith("#")]
        elif p.is_file():
            out.append(p)
        else:
            raise NeuralUVError(f"{p}: no such file or folder")
    seen, uniq = set(), []
    for p in out:
        if str(p) not in seen:
            seen.add(str(p))
            uniq.append(p)
    return uniq


def _asset_name(path):
    p = Path(path)
    return f"{p.parent.name}__{p.stem}" if p.parent.name else p.stem


def _row_from_report(name, rep, status, t):
    tot = rep.get("totals", {})
    back = rep.get("readback", {})
    return {
        "name": name, "status": status, "ok": bool(rep.get("ok", False)), "faces": int(tot.get("repaired_faces", 0)),
        "flips": int(back.get("flips", -1)), "overlaps": int(back.get("overlapping_pairs", -1)),
        "neural_share": float(tot.get("neural_share", 0.0)), "exact_share": float(tot.get("exact_share", 0.0)),
        "fallback_share": float(tot.get("fallback_share", 0.0)),
        "charts": int(tot.get("charts", 0)), "islands": int(tot.get("islands", 0)), "time": float(t),
        "input": rep.get("input", ""), "output": rep.get("output", ""), "error": "",
    }


def atlas_asset(path, out_dir, *, timeout=600.0, resume=True, isolate=True, out_format="obj", **kw):
    """Atlas one asset into ``out_dir/<name>/`` and return its results row.

    Parameters
    ----------
    path : input mesh path.
    out_dir : output folder.
    timeout : float
        Hard limit in seconds (subprocess mode); 80% of it is the soft budget.
    resume : bool
        Return the stored row when a passing report already exists.
    isolate : bool
        Run ``python -m neuraluv.cli atlas`` in a subprocess (hard timeout,
        crash isolation) instead of in this process.
    out_format : ``"obj"`` or ``"glb"``
    **kw
        ``preset``, ``packer``, ``resolution``, ``padding``, ``iterations``.

    Returns
    -------
    dict, a row with :data:`COLUMNS` (``status``: ok, failed, error, timeout, cached).
    """
    name = _asset_name(path)
    d = Path(out_dir) / name
    rep_path = d / "report.json"
    out = d / f"atlas.{out_format}"
    if resume and rep_path.exists():
        try:
            rep = json.loads(rep_path.read_text())
            if rep.get("ok"):
                return _row_from_report(name, rep, "cached", rep.get("info", {}).get("time", 0.0))
        except (OSError, ValueError):
            pass
    d.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    row = {c: "" for c in COLUMNS}
    row.update({"name": name, "input": str(path), "output": str(out), "ok": False, "time": 0.0})
    budget = 0.8 * float(timeout)
    if isolate:
        cmd = [sys.executable, "-m", "neuraluv.cli", "atlas", str(path), "-o", str(out), "--report", str(rep_path),
               "--quiet", "--threads", str(kw.get("threads") or 1), "--time-budget", f"{budget:.3f}"]
        for k in ("preset", "packer", "resolution", "padding", "iterations", "seed", "device"):
            if kw.get(k) is not None:
                cmd += [f"--{k.replace('_', '-')}", str(kw[k])]
        try:
            pr = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                                env={**os.environ, "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg"})
        except subprocess.TimeoutExpired:
            row.update({"status": "timeout", "error": f"no result within {timeout:g}s", "time": time.perf_counter() - t0})
            return row
        t = time.perf_counter() - t0
        if pr.returncode in (0, 3) and rep_path.exists():
            rep = json.loads(rep_path.read_text())
            return _row_from_report(name, rep, "ok" if rep.get("ok") else "failed", t)
        err = (pr.stderr.strip().splitlines() or ["unknown error"])[-1]
        row.update({"status": "error", "error": err, "time": t})
        return row

    try:
        opts = {k: v for k, v in kw.items() if v is not None}
        opts.setdefault("threads", 1)
        _, rep = atlas_file(path, out, report=rep_path, time_budget=budget, **opts)
    except Exception as exc:  # one bad asset must not stop the sweep
        row.update({"status": "error", "error": f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}",
                    "time": time.perf_counter() - t0})
        return row
    return _row_from_report(name, rep, "ok" if rep.get("ok") else "failed", time.perf_counter() - t0)


def summarize(rows, label="sweep"):
    """A Table 9 (tab:amara_large_sweep) row: tried, OK, faces, flips, neural / exact-unfold / fallback face shares, median time.

    Face shares are face-weighted over the successful assets.

    Examples
    --------
    >>> r = [{"ok": True, "faces": 30, "flips": 0, "neural_share": 1.0, "time": 2.0},
    ...      {"ok": True, "faces": 10, "flips": 0, "neural_share": 0.6, "time": 4.0}]
    >>> s = summarize(r); s["tried"], s["ok"], s["faces"], round(s["neural_share"], 3), s["median_time"]
    (2, 2, 40, 0.9, 3.0)
    """
    ok = [r for r in rows if r.get("ok")]
    faces = sum(int(r["faces"]) for r in ok)
    nf = sum(int(r["faces"]) * float(r["neural_share"]) for r in ok)
    ne = sum(int(r["faces"]) * float(r.get("exact_share") or 0.0) for r in ok)
    times = [float(r["time"]) for r in ok]
    return {
        "run": label, "tried": len(rows), "ok": len(ok), "faces": faces,
        "flips": sum(max(int(r["flips"]), 0) for r in ok),
        "neural_share": nf / faces if faces else 0.0, "exact_share": ne / faces if faces else 0.0,
        "fallback_share": 1 - (nf + ne) / faces if faces else 0.0,
        "median_time": float(np.median(times)) if times else float("nan"),
    }


def _markdown(s):
    return ("| Run | Tried | OK | Faces | Flips | Neural / exact / fallback faces | Med. time |\n"
            "|---|---:|---:|---:|---:|---:|---:|\n"
            f"| {s['run']} | {s['tried']} | {s['ok']} | {s['faces']:,} | {s['flips']} | "
            f"{100 * s['neural_share']:.1f} / {100 * s['exact_share']:.1f} / {100 * s['fallback_share']:.1f}% | "
            f"{s['median_time']:.2f}s |\n")


@dataclass
class SweepResult:
    rows: list
    summary: dict
    markdown: str
    paths: dict


def _write_csv(path, rows, cols):
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    with atomic_write(path) as fh:
        fh.write(buf.getvalue())


def sweep(inputs, out_dir, *, scheduler=None, n_workers=2, threads_per_worker=1, processes=True, timeout=600.0,
          resume=True, progress=True, isolate=True, out_format="obj", limit=None, label=None, client=None, **kw):
    """Atlas every asset on a dask cluster and write the results tables.

    Parameters
    ----------
    inputs : folder, file, ``.txt`` list, or a list of those.
    out_dir : output folder.
    scheduler : str, optional
        Address of a running dask scheduler (``tcp://host:port``); default a ``LocalCluster``. Its
        workers must see the same files (a shared filesystem) and run the same ``neuraluv`` version:
        inputs and outputs are sent to them as absolute paths.
    n_workers, threads_per_worker, processes : LocalCluster settings.
    timeout : float, per-asset seconds.
    resume : bool, skip assets whose stored report passed validation.
    progress : bool, a tqdm bar over finished assets.
    isolate : bool, one subprocess per asset (see :func:`atlas_asset`).
    out_format : ``"obj"`` or ``"glb"``.
    limit : int, optional, only the first assets.
    client : dask.distributed.Client, optional, use this client.
    **kw : atlas options (``preset``, ``packer``, ``resolution``, ``padding``, ``iterations``, ``seed``,
        ``device``, ``threads``: torch threads per asset, default 1).

    Returns
    -------
    SweepResult
        ``rows`` (one per asset), ``summary`` (:func:`summarize`), ``markdown`` and
        the written ``paths`` (``csv``, ``summary_csv``, ``markdown``).
    """
    from dask.distributed import Client, LocalCluster, as_completed

    assets = list_assets(inputs)
    if limit is not None:
        assets = assets[: int(limit)]
    if not assets:
        raise NeuralUVError("no mesh files found (extensions: " + ", ".join(MESH_EXTS) + ")")
    # workers of a separately started cluster run in their own working folders: send absolute paths
    assets = [Path(p).resolve() for p in assets]
    out_dir = Path(out_dir).resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    own = []
    if client is None:
        if scheduler:
            client = Client(scheduler)
        else:
            cluster = LocalCluster(n_workers=n_workers, threads_per_worker=threads_per_worker, processes=processes,
                                   dashboard_address=":0")
            own.append(cluster)
            client = Client(cluster)
        own.insert(0, client)
    try:
        futs = [client.submit(atlas_asset, str(p), str(out_dir), timeout=timeout, resume=resume, isolate=isolate,
                              out_format=out_format, pure=False, key=f"atlas-{i}-{_asset_name(p)}", **kw)
                for i, p in enumerate(assets)]
        bar = None
        if progress:
            bar = tqdm(total=len(futs), desc="assets", dynamic_ncols=True)
        rows = []
        for f in as_completed(futs):
            try:
                rows.append(f.result())
            except Exception as exc:  # a worker died
                rows.append({"name": f.key, "status": "error", "ok": False, "faces": 0, "flips": -1,
                             "error": f"{type(exc).__name__}: {exc}", "time": 0.0, "neural_share": 0.0})
            if bar is not None:
                bar.update(1)
                bar.set_postfix(ok=sum(bool(r.get("ok")) for r in rows))
        if bar is not None:
            bar.close()
    finally:
        for o in own:
            o.close()
    rows.sort(key=lambda r: r["name"])
    s = summarize(rows, label or out_dir.name)
    md = _markdown(s)
    paths = {"csv": out_dir / "results.csv", "summary_csv": out_dir / "summary.csv", "markdown": out_dir / "summary.md"}
    _write_csv(paths["csv"], rows, COLUMNS)
    _write_csv(paths["summary_csv"], [s], list(s))

    with atomic_write(paths["markdown"]) as fh:
        fh.write(md)
    return SweepResult(rows=rows, summary=s, markdown=md, paths=paths)
