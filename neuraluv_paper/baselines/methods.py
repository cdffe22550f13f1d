"""Classical parameterization baselines behind one signature.

Every method takes a mesh and returns a :class:`BaselineResult` — the neural
solver's :class:`~neuraluv.solver.ChartResult` plus the mesh the UVs live on —
with metrics from the one metric definition
(:func:`neuraluv.metrics.distortion_metrics`). The benchmark runners read only
this type, so a table row means the same thing for every method.

=====================  ==========================================  ===============
name                   what runs                                   metrics scale
=====================  ==========================================  ===============
``harmonic``           libigl harmonic map, cotangent weights,     rescaled
                       boundary on a circle (arc-length spaced)
``lscm``               libigl LSCM, two boundary vertices pinned   rescaled
``arap``               libigl ARAP (local/global) from harmonic    as solved
``slim-20``            libigl SLIM, symmetric Dirichlet, 20 iters  as solved
                       from the uniform Tutte map (ours' start)
``slim-1k``            same, 1,000 iterations                      as solved
``bff``                Boundary First Flattening (:mod:`neuraluv_paper.baselines.bff`)     rescaled
``bff-cli``            the BFF v1.6 command-line tool (optional    rescaled
                       binary, ``make baselines``): no cones,
                       free boundary, ``--normalizeUVs``
``xatlas``             xatlas charting + packing of the whole mesh rescaled
``blender-smart``      Blender Smart UV Project (optional ``bpy``) rescaled
``blender-angle``      Blender Unwrap, ANGLE_BASED                 rescaled
``blender-conformal``  Blender Unwrap, CONFORMAL                   rescaled
``blender-minstretch`` Blender Unwrap, MINIMUM_STRETCH             rescaled
``optcuts``            OptCuts binary (optional, ``make            as solved
                       baselines``; recuts)
``neural``             :func:`neuraluv.solver.solve_chart`         as solved
=====================  ==========================================  ===============

"rescaled": the map has no intrinsic scale (a circle radius, a pin distance,
a packed atlas), so it is multiplied by one global factor
(:func:`neuraluv.metrics.match_area`) so its UV area equals the 3D area before
the metrics are taken; E_SD and area distortion are meaningless otherwise.
"as solved": the method minimises an energy with a 3D-scale target, and its
output is measured as is.

Every map is also given the orientation of its faces: a chart (a connected
component of the mesh the UVs live on; an island for cut methods) that is
mirrored as a whole (negative total signed area) is reflected in place, because
a mirror image is an equally good parameterization (xatlas returns some
islands mirrored); flips are then the faces that disagree with their chart's
majority, and ``config["mirrored_charts"]`` counts the reflected charts.

Status vocabulary (``BaselineResult.status``):

* ``"ok"`` — the method produced a map (valid or not: the metrics say whether
  it flips);
* ``"neural"`` / ``"fallback"`` — the ``neural`` method keeps the solver's own
  status (a fallback is still a map, see ``reason``);
* ``"init fail"`` — the method cannot start on this input (libigl methods given
  several components or boundary loops, as the paper reports on Bob);
* ``"unavailable"`` — an optional dependency or binary is absent (``reason``
  says what to install);
* ``"error"`` — the method raised; ``reason`` is a one-line message.

``BaselineResult.produced`` is True for the first two groups. Failed results
carry ``uv=None`` and metrics with ``nan`` values (see :func:`empty_metrics`).
"""
from __future__ import annotations

import argparse
import time
from dataclasses import dataclass, field

import numpy as np

from neuraluv import datasets
from neuraluv.metrics import distortion_metrics, match_area
from neuraluv.solver import get_config
from neuraluv.solver.result import ChartResult
from neuraluv.topology import components, topology_scan
from neuraluv_paper.baselines.bff import bff_map
from neuraluv_paper.baselines.common import InitFail, Unavailable, orient_charts
from neuraluv_paper.baselines.external import BLENDER_MODES, bff_cli_map, blender_map, optcuts_map, xatlas_map
from neuraluv_paper.baselines.libigl import arap, harmonic, lscm, slim

__all__ = ["BaselineResult", "METHODS", "SCALE_FREE", "OK_STATUSES", "run_baseline", "empty_metrics"]

OK_STATUSES = ("ok", "neural", "fallback")


@dataclass
class BaselineResult(ChartResult):
    """A :class:`~neuraluv.solver.ChartResult` plus the mesh the UVs live on.

    Attributes
    ----------
    V : (n',3) float array or None
        The mesh the UVs are defined on. It is the input mesh for fixed-chart
        methods (harmonic, LSCM, ARAP, SLIM, BFF, neural) and a cut mesh for
        methods that cut seams or return per-corner UVs (xatlas: the mesh
        ``V[vmapping]``; Blender: its loop UVs welded into a cut mesh, one
        vertex per distinct (vertex, uv) corner; OptCuts: its output mesh). ``uv`` has one row per row of
        ``V`` and ``metrics`` are computed on ``(V, F, uv)``.
    F : (m',3) int array or None
        Faces of that mesh; face ``t`` is always the input's face ``t`` (same
        order, same 3D triangle) except for OptCuts, which may re-order.
    method : str
        The method name (a key of :data:`METHODS`).
    rescaled : bool
        Whether ``uv`` was multiplied by :func:`~neuraluv.metrics.match_area`
        before the metrics (scale-free methods, see the module docstring).
    components : list of BaselineResult
        Per-component results when run with ``per_component=True``.
    """

    V: np.ndarray = field(default=None, repr=False)
    F: np.ndarray = field(default=None, repr=False)
    method: str = ""
    rescaled: bool = False
    components: list = field(default_factory=list, repr=False)

    @property
    def produced(self):
        """True when the method returned a map (valid or not)."""
        return self.status in OK_STATUSES and self.uv is not None

    def summary(self):
        d = super().summary()
        d.update({"method": self.method, "rescaled": self.rescaled})
        return d


def empty_metrics(n_faces=0):
    """Metrics dict of a method that produced no map: every number ``nan``.

    Examples
    --------
    >>> import math
    >>> m = empty_metrics(4); m["n_faces"], m["valid"], math.isnan(m["esd"])
    (4, False, True)
    """
    nan = float("nan")
    return {"esd": nan, "conformal": nan, "area": nan, "flips": nan, "flip_percent": nan,
            "min_det": nan, "n_faces": int(n_faces), "valid": False}



def _neural(V, F, preset="fast", seed=0, device="auto", **overrides):
    """The paper's solver: one chart, or every component when there are several."""
    from neuraluv.solver.chart import solve_chart

    if topology_scan(V, F).components == 1:
        return solve_chart(V, F, _cfg(preset, overrides), seed=seed, device=device)
    parts = components(V, F)
    results = []
    for vi, fi, Fc in parts:
        results.append(_result_from_chart(_neural(V[vi], Fc, preset, seed, device, **overrides), "neural", V[vi], Fc))
    return _combine(results, parts, V, F, "neural")


def _cfg(preset, overrides):
    return get_config(preset, **overrides)



def _result_from_chart(res, method, V, F):
    if isinstance(res, BaselineResult):
        return res
    return BaselineResult(uv=res.uv, metrics=res.metrics, status=res.status, reason=res.reason, trace=res.trace,
                          time=res.time, seed=res.seed, attempts=res.attempts, stop=res.stop, config=res.config,
                          network=res.network, attempt_metrics=res.attempt_metrics, neural_uv=res.neural_uv,
                          V=np.asarray(V, float), F=np.asarray(F, np.int64), method=method, rescaled=False)


def _failed(method, status, reason, V, F, t=0.0):
    return BaselineResult(uv=None, metrics=empty_metrics(len(F)), status=status, reason=reason, time=t,
                          V=np.asarray(V, float), F=np.asarray(F, np.int64), method=method)


def _make(method, fn, scale_free, cut=False):
    """Wrap a raw map function into ``f(V, F, **kw) -> BaselineResult``."""

    def run(V, F, **kw):
        V = np.asarray(V, float)
        F = np.asarray(F, np.int64)
        t0 = time.perf_counter()
        try:
            out = fn(V, F, **kw)
        except InitFail as e:
            return _failed(method, "init fail", str(e), V, F, time.perf_counter() - t0)
        except Unavailable as e:
            return _failed(method, "unavailable", str(e), V, F)
        except Exception as e:  # noqa: BLE001 - reported, never raised
            msg = " ".join(str(e).split()) or type(e).__name__
            return _failed(method, "error", f"{type(e).__name__}: {msg}", V, F, time.perf_counter() - t0)
        elapsed = time.perf_counter() - t0
        cfg = dict(kw)
        if cut:
            UV, Vm, Fm = out[:3]
            if len(out) > 3:  # the tool's own timing (Blender: operator time inside the subprocess)
                cfg["wall_time_subprocess"] = elapsed
                elapsed = out[3]
        else:
            UV, Vm, Fm = out, V, F
        UV = np.asarray(UV, float)
        if not np.all(np.isfinite(UV)):
            return _failed(method, "error", f"{method} returned non-finite UVs", Vm, Fm, elapsed)
        if scale_free:
            UV = match_area(Vm, Fm, UV)
        UV, mirrored = orient_charts(Vm, Fm, UV)
        if mirrored:
            cfg["mirrored_charts"] = mirrored
        return BaselineResult(uv=UV, metrics=distortion_metrics(Vm, Fm, UV), status="ok", reason="", time=elapsed,
                              config=cfg, V=Vm, F=Fm, method=method, rescaled=bool(scale_free))

    run.__name__ = method.replace("-", "_")
    run.__doc__ = f"Run the ``{method}`` baseline: ``(V, F, **kw) -> BaselineResult`` (see :func:`{fn.__name__}`)."
    return run


def _blender(mode):
    def fn(V, F, **kw):
        return blender_map(V, F, mode, **kw)

    fn.__name__ = "blender_map"
    return fn


def _neural_method(V, F, **kw):
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    t0 = time.perf_counter()
    try:
        res = _neural(V, F, **kw)
    except Exception as e:  # noqa: BLE001
        from neuraluv.errors import TopologyError

        status = "init fail" if isinstance(e, TopologyError) else "error"
        return _failed("neural", status, f"{type(e).__name__}: {' '.join(str(e).split())}", V, F, time.perf_counter() - t0)
    return _result_from_chart(res, "neural", V, F)


#: Methods whose output scale is arbitrary (rescaled with match_area before metrics).
SCALE_FREE = {"harmonic", "lscm", "bff", "bff-cli", "xatlas", *BLENDER_MODES}

#: name -> function(V, F, **kw) -> BaselineResult
METHODS = {
    "harmonic": _make("harmonic", harmonic, True),
    "lscm": _make("lscm", lscm, True),
    "arap": _make("arap", arap, False),
    "slim-20": _make("slim-20", lambda V, F, iterations=20: slim(V, F, iterations=iterations), False),
    "slim-1k": _make("slim-1k", lambda V, F, iterations=1000: slim(V, F, iterations=iterations), False),
    "bff": _make("bff", bff_map, True),
    "bff-cli": _make("bff-cli", bff_cli_map, True, cut=True),
    "xatlas": _make("xatlas", xatlas_map, True, cut=True),
    **{name: _make(name, _blender(mode), True, cut=True) for name, mode in BLENDER_MODES.items()},
    "optcuts": _make("optcuts", optcuts_map, False, cut=True),
    "neural": _neural_method,
}


def _combine(results, parts, V, F, method):
    """Join per-component results: meshes concatenated, charts side by side at 3D scale."""
    statuses = [r.status for r in results]
    t = float(sum(r.time for r in results))
    bad = [(i, r) for i, r in enumerate(results) if not r.produced]
    if bad:
        i, r = bad[0]
        out = _failed(method, r.status, f"component {i} of {len(results)}: {r.reason}", V, F, t)
        out.components = results
        return out
    Vs, Fs, UVs, off, x0 = [], [], [], 0, 0.0
    for r in results:
        uv = r.uv - r.uv.min(0) + [x0, 0.0]
        x0 = uv[:, 0].max() + 0.1 * max(np.ptp(uv[:, 1]), 1e-12)
        Vs.append(r.V)
        Fs.append(r.F + off)
        UVs.append(uv)
        off += len(r.V)
    Vm, Fm, UV = np.vstack(Vs), np.vstack(Fs), np.vstack(UVs)
    status = "ok"
    if method == "neural":
        status = "fallback" if "fallback" in statuses else "neural"
    reason = "; ".join(f"component {i}: {r.reason}" for i, r in enumerate(results) if r.reason)
    return BaselineResult(uv=UV, metrics=distortion_metrics(Vm, Fm, UV), status=status, reason=reason, time=t,
                          config=dict(results[0].config), V=Vm, F=Fm, method=method,
                          rescaled=results[0].rescaled, components=results)


def run_baseline(method, V, F, *, per_component=False, **kw):
    """Run one method on a mesh and measure it.

    Parameters
    ----------
    method : str
        A key of :data:`METHODS`.
    V : (n,3) float array
    F : (m,3) int array
    per_component : bool
        Run the method on each connected component separately
        (:func:`neuraluv.topology.split_components`) and combine: metrics over
        all faces, time summed, charts laid side by side at 3D scale (each
        component rescaled on its own when the method is scale-free). Without
        it, a multi-component input is given to the method whole (libigl
        methods then report ``"init fail"``, as in the paper's Bob row).
    **kw
        Method options (``max_iter`` for ARAP, ``iterations`` for SLIM,
        ``extension`` for BFF, operator settings for Blender, ``preset``,
        ``seed``, ``device`` and SolverConfig overrides for ``neural``).

    Returns
    -------
    BaselineResult
        Never raises for a method failure: see the status vocabulary above.

    Examples
    --------
    >>> from neuraluv.datasets import disk, several_components
    >>> r = run_baseline("lscm", *disk(4))
    >>> r.status, r.metrics["flips"], round(r.metrics["conformal"], 3)
    ('ok', 0, 1.0)
    >>> run_baseline("slim-20", *several_components(3)).status
    'init fail'
    >>> r = run_baseline("slim-20", *several_components(3), per_component=True)
    >>> r.status, r.metrics["flips"], len(r.components)
    ('ok', 0, 3)
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {sorted(METHODS)}")
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    if not per_component:
        return METHODS[method](V, F, **kw)
    parts = components(V, F)
    results = []
    for vi, fi, Fc in parts:
        results.append(METHODS[method](V[vi], Fc, **kw))
    return _combine(results, parts, V, F, method)


def main(argv=None):
    """``python -m neuraluv_paper.baselines MESH [MESH ...] [--methods a,b] [--per-component]``: print a table."""
    p = argparse.ArgumentParser(prog="python -m neuraluv_paper.baselines", description=main.__doc__)
    p.add_argument("meshes", nargs="+", help="compact chart (camel, hand, bob), registry or procedural mesh name")
    p.add_argument("--methods", default=",".join(m for m in METHODS if m != "neural"))
    p.add_argument("--per-component", action="store_true", help="also run every method per component")
    p.add_argument("--preset", default="fast", help="solver preset for the neural method")
    a = p.parse_args(argv)
    print(f"{'mesh':8s} {'method':22s} {'status':11s} {'E_SD':>11s} {'conf':>8s} {'area':>7s} {'%flip':>7s} {'time(s)':>8s}")
    for name in a.meshes:
        V, F = datasets.procedural(name) if name in datasets.PROCEDURAL else datasets.load(name)
        for pc in ([False, True] if a.per_component else [False]):
            for m in a.methods.split(","):
                r = run_baseline(m, V, F, per_component=pc, **({"preset": a.preset} if m == "neural" else {}))
                M = r.metrics
                label = m + (" (per comp.)" if pc else "")
                print(f"{name:8s} {label:22s} {r.status:11s} {M['esd']:11.4g} {M['conformal']:8.4g} {M['area']:7.3g} "
                      f"{M['flip_percent']:7.3g} {r.time:8.3f} {r.reason[:60]}", flush=True)


if __name__ == "__main__":
    main()
