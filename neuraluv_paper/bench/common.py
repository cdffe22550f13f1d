"""What the benchmark runners share: method and mesh names, labels, loading, the neural options, result rows."""
from __future__ import annotations

import resource
import time

import numpy as np

from neuraluv import datasets
from neuraluv.metrics import distortion_metrics
from neuraluv.relax import slim_relax

__all__ = ["METHODS", "LABELS", "RECUT", "DEFAULT_MESHES", "QUICK_MESHES", "QUICK_SIZES", "QUICK_METHODS", "MESH_LABELS",
           "load_meshes", "neural_options", "result_row", "iteration_override", "peak_rss_mb", "slim_reference"]

#: Table 1's (tab:compact_prelim) methods, in the paper's order (OptCuts last: it recuts), then the external tools the
#: paper names beside them: the BFF v1.6 binary next to our BFF, and Blender's unwrappers (optional
#: binaries / ``bpy``: rows read ``unavailable`` without them, and ``--resume`` recomputes such rows).
METHODS = ["lscm", "arap", "slim-1k", "bff", "bff-cli", "neural", "optcuts",
           "blender-angle", "blender-conformal", "blender-minstretch", "blender-smart"]
#: Display names.
LABELS = {"harmonic": "Harmonic", "lscm": "LSCM", "arap": "ARAP", "slim-20": "SLIM-20", "slim-1k": "SLIM-1k",
          "bff": "BFF", "bff-cli": "BFF v1.6 binary", "neural": "Ours", "neural-k0": "Ours, k=0", "optcuts": "OptCuts (re-cut)", "xatlas": "xatlas (re-cut)",
          "blender-smart": "Blender Smart UV (re-cut)", "blender-angle": "Blender Angle Based",
          "blender-conformal": "Blender Conformal", "blender-minstretch": "Blender Min. Stretch"}
#: Methods that cut their own seams (not fixed-chart solvers).
RECUT = {"optcuts", "xatlas", "blender-smart"}
DEFAULT_MESHES = ["hand", "bob", "camel"]
#: Procedural stand-ins for quick runs: a fingered chart and a 3-component input.
QUICK_MESHES = ["glove", "components"]
#: Smaller procedural sizes for quick runs.
QUICK_SIZES = {"glove": {"res": 2}, "components": {"n_rings": 4}, "cap": {"n_rings": 5}, "saddle": {"n_rings": 5},
               "bumpy": {"n_rings": 5}, "disk": {"n_rings": 5}}
#: Table 1's (tab:compact_prelim) methods under ``quick``: SLIM-20 stands in for SLIM-1k.
QUICK_METHODS = ["lscm", "arap", "slim-20", "bff", "neural", "optcuts"]
MESH_LABELS = {"hand": "Hand", "bob": "Bob", "camel": "Camel"}


def load_meshes(names, quick=False):
    """Load meshes by name: a list of ``(name, V, F)``, one per name.

    Under ``quick``, procedural meshes are built at the small :data:`QUICK_SIZES`.
    A real mesh that is not cached is an error, never a row left out: a table
    with fewer meshes than asked for would read as a result.

    Raises
    ------
    neuraluv.datasets.DataMissing
        One line naming every missing mesh, the folder searched and ``make data``.
    """
    loaded, missing = [], []
    for n in names:
        try:
            if quick and n in QUICK_SIZES:
                V, F = datasets.procedural(n, **QUICK_SIZES[n])
            else:
                V, F = datasets.load(n)
        except datasets.DataMissing:
            missing.append(n)
            continue
        loaded.append((n, np.asarray(V, float), np.asarray(F, np.int64)))
    if missing:
        raise datasets.DataMissing(f"the real mesh(es) {', '.join(missing)} not in {datasets.data_dir()}: "
                                   f"{datasets.FETCH_HINT}")
    return loaded


def neural_options(preset, quick, seed=0, device="auto", **overrides):
    """Keyword arguments for ``run_baseline("neural", ...)`` and the resume key's config."""
    preset = preset or ("test" if quick else "fast")
    kw = {"preset": preset, "seed": int(seed), "device": device, **overrides}
    return kw


def iteration_override(args):
    """``{"iterations": N}`` when the command line set ``--iterations``, else ``{}``.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> iteration_override(SimpleNamespace(iterations=200)), iteration_override(SimpleNamespace())
    ({'iterations': 200}, {})
    """
    n = getattr(args, "iterations", None)
    return {"iterations": n} if n else {}


def result_row(res):
    """The numbers of a :class:`~neuraluv_paper.baselines.BaselineResult` as a flat dict."""
    m = res.metrics
    row = {k: m.get(k) for k in ("esd", "conformal", "area", "flips", "flip_percent", "min_det", "n_faces", "valid")}
    row.update({"status": res.status, "reason": res.reason, "time": float(res.time),
                "attempts": getattr(res, "attempts", 1), "stop": getattr(res, "stop", "")})
    return row


def peak_rss_mb(reset=False):
    """Peak resident set size of this process in MB (Linux ``VmHWM``); ``reset`` starts a new peak."""
    if reset:
        try:
            with open("/proc/self/clear_refs", "w") as fh:
                fh.write("5")
        except OSError:
            pass
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return float(line.split()[1]) / 1024.0
    except OSError:
        pass

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def slim_reference(preps, iterations):
    """SLIM from each chart's own start (the solver's Tutte / un-crushed map); (seconds, area-weighted E_SD, flips)."""
    t = time.perf_counter()
    uvs = [slim_relax(p.Vn, p.F, p.u_start, iterations) for p in preps]
    dt = time.perf_counter() - t
    ms = [distortion_metrics(p.V, p.F, uv * p.scale) for p, uv in zip(preps, uvs)]
    return dt, combine_metrics(ms, preps), sum(m["flips"] for m in ms)


def combine_metrics(metrics, preps):
    w = np.array([p.A.sum() * p.scale**2 for p in preps])
    return float(sum(m["esd"] * wi for m, wi in zip(metrics, w)) / w.sum())
