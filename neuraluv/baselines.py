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
``bff``                Boundary First Flattening (:mod:`.bff`)     rescaled
``xatlas``             xatlas charting + packing of the whole mesh rescaled
``blender-smart``      Blender Smart UV Project (optional ``bpy``) rescaled
``blender-angle``      Blender Unwrap, ANGLE_BASED                 rescaled
``blender-conformal``  Blender Unwrap, CONFORMAL                   rescaled
``blender-minstretch`` Blender Unwrap, MINIMUM_STRETCH             rescaled
``optcuts``            OptCuts binary (optional, recuts)           as solved
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

import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .metrics import distortion_metrics, match_area
from .solver import ChartResult
from .topology import is_disk_like, split_components, topology_scan

__all__ = [
    "BaselineResult", "METHODS", "SCALE_FREE", "OK_STATUSES", "run_baseline", "empty_metrics",
    "InitFail", "Unavailable", "blender_python", "optcuts_binary", "weld_corners",
]

#: Statuses of results that carry a map.
OK_STATUSES = ("ok", "neural", "fallback")


class InitFail(RuntimeError):
    """The method cannot start on this input (reported as ``"init fail"``)."""


class Unavailable(RuntimeError):
    """An optional dependency or binary is missing (reported as ``"unavailable"``)."""


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


# ------------------------------------------------------------------ helpers

def _orient(V, F, UV):
    """Reflect every chart of ``UV`` whose total signed area is negative.

    A chart is a connected component of ``(V, F)`` (for cut meshes: an atlas
    island). A chart mirrored as a whole is an equally good parameterization
    (xatlas returns some islands mirrored), so it is reflected in place about
    its bounding-box centre line; flips are then the faces that disagree with
    their chart's majority.

    Returns
    -------
    UV : (n,2) float array
    mirrored : int
        Number of charts reflected.
    """
    from .jacobian import jacobians, local_frames
    from .topology import vertex_components

    dC_inv, A = local_frames(V, F)
    sdet = A * np.linalg.det(jacobians(UV, F, dC_inv))
    ncomp, lab = vertex_components(len(V), F)
    flab = lab[F[:, 0]]
    per = np.bincount(flab, weights=sdet, minlength=ncomp)
    bad = np.flatnonzero(per < 0)
    if len(bad) == 0:
        return UV, 0
    UV = UV.copy()
    for c in bad:
        vi = np.flatnonzero(lab == c)
        y = UV[vi, 1]
        UV[vi, 1] = y.min() + y.max() - y
    return UV, int(len(bad))


def weld_corners(F, corner_uv):
    """A cut mesh from per-corner UVs: one vertex per distinct (vertex, uv) pair.

    Parameters
    ----------
    F : (m,3) int array
    corner_uv : (3m,2) float array
        UV of corner ``j`` of face ``t`` at row ``3t+j`` (Blender loop UVs).

    Returns
    -------
    vidx : (n',) int array
        Input vertex of each cut-mesh vertex (cut-mesh positions are ``V[vidx]``).
    F_cut : (m,3) int array
        Same faces, indexing the cut mesh.
    UV : (n',2) float array

    Examples
    --------
    >>> F = np.array([[0, 1, 2], [0, 2, 3]])
    >>> uv = np.array([[0, 0], [1, 0], [1, 1], [0, 0], [1, 1], [0, 1.]])
    >>> vidx, Fc, UV = weld_corners(F, uv)
    >>> vidx.tolist(), Fc.tolist()
    ([0, 1, 2, 3], [[0, 1, 2], [0, 2, 3]])
    """
    F = np.asarray(F, np.int64)
    corner_uv = np.asarray(corner_uv, float)
    key = np.column_stack([F.reshape(-1), corner_uv])
    uniq, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return F.reshape(-1)[first], inv.reshape(-1).reshape(F.shape), corner_uv[first]


def _require_disk(V, F, method):
    """Raise :class:`InitFail` unless ``(V, F)`` is one disk (libigl methods)."""
    ok, why = is_disk_like(V, F)
    if not ok:
        raise InitFail(f"{method} needs one disk-like chart: {why}")


def _boundary(F):
    import igl

    return np.asarray(igl.boundary_loop(np.ascontiguousarray(F, dtype=np.int64)), np.int64)


def _circle(V, bnd):
    """Boundary loop on the unit circle, arc-length spaced (libigl)."""
    import igl

    return np.asarray(igl.map_vertices_to_circle(np.asfortranarray(V, dtype=np.float64),
                                                 np.ascontiguousarray(bnd, dtype=np.int32)))


# ------------------------------------------------------------------ libigl

def _harmonic_uv(V, F):
    import igl

    bnd = _boundary(F)
    bc = _circle(V, bnd)
    return np.asarray(igl.harmonic(V, F, bnd, bc, 1))


def harmonic(V, F):
    """Harmonic (Tutte with cotangent weights) map with the boundary on a circle.

    Returns
    -------
    UV : (n,2) float array (unit-circle boundary: scale-free)

    Notes
    -----
    Solves ``Δu = 0`` with the cotangent Laplacian and ``u|∂ = circle``
    (Eck et al. 1995); can fold where cotangent weights are negative.
    """
    _require_disk(V, F, "harmonic")
    return _harmonic_uv(V, F)


def lscm(V, F):
    """Least-squares conformal map (Lévy et al. 2002) through libigl.

    Two boundary vertices (the loop's first and the one halfway along) are
    pinned at (0,0) and (1,0).

    Returns
    -------
    UV : (n,2) float array (scale-free)

    Notes
    -----
    Minimises ``Σ_t A_t |∂u/∂x + i ∂u/∂y|²`` (the conformal energy
    ``½ Σ_t A_t ‖J_t − R J_t R^T‖²``) subject to the two pins.
    """
    import igl

    _require_disk(V, F, "lscm")
    bnd = _boundary(F)
    b = np.array([bnd[0], bnd[len(bnd) // 2]], np.int64)
    bc = np.array([[0.0, 0.0], [1.0, 0.0]])
    uv, _ = igl.lscm(V, F, b, bc)
    return np.asarray(uv)


def arap(V, F, *, max_iter=100):
    """As-rigid-as-possible parameterization (Liu et al. 2008) from the harmonic map.

    Returns
    -------
    UV : (n,2) float array at 3D scale

    Notes
    -----
    Local/global iterations on ``Σ_t A_t ‖J_t − R_t‖²_F`` with ``R_t`` the
    closest rotation; no vertex is pinned (libigl tutorial 503: dynamic
    regularisation). The harmonic start is first rescaled to the 3D area, since
    the dynamic term ties the iterates to the start's scale (on Camel, a
    unit-circle start leaves 40% of the faces flipped, a 3D-scale one 6%).
    """
    import igl

    _require_disk(V, F, "arap")
    start = match_area(V, F, _harmonic_uv(V, F))  # at 3D scale: the dynamics term remembers the start
    data = igl.ARAPData()
    data.max_iter = int(max_iter)
    data.with_dynamics = True  # dynamic regularisation: no pinned vertex needed (tutorial 503)
    b = np.zeros(0, np.int32)
    igl.arap_precomputation(V, F, 2, b, data)
    return np.asarray(igl.arap_solve(np.zeros((0, 2)), data, start))


def slim(V, F, *, iterations=1000):
    """SLIM (Rabinovich et al. 2017) on the symmetric Dirichlet energy, libigl.

    Starts from the uniform Tutte map of :func:`neuraluv.tutte.tutte` (the
    neural solver's start), with no pinned vertex.

    Returns
    -------
    UV : (n,2) float array at 3D scale

    Notes
    -----
    Minimises ``Σ_t A_t (‖J_t‖²_F + ‖J_t⁻¹‖²_F)`` by reweighted local/global
    proxies with a flip-preventing line search.
    """
    from .relax import slim_relax
    from .tutte import tutte

    _require_disk(V, F, "slim")
    return slim_relax(V, F, tutte(V, F), iterations)


# ------------------------------------------------------------------ BFF

def bff_map(V, F, **kw):
    """Boundary First Flattening, each component separately (see :mod:`neuraluv.bff`)."""
    from .bff import bff

    parts = split_components(V, F)
    UV = np.zeros((len(V), 2))
    x0 = 0.0
    for i, (vi, fi) in enumerate(parts):
        Fc = np.searchsorted(vi, F[fi])
        ok, why = is_disk_like(V[vi], Fc)
        if not ok:
            what = "input" if len(parts) == 1 else f"component {i}"
            raise InitFail(f"bff needs disk-like components: {what}: {why}")
        uv = bff(V[vi], Fc, **kw)
        uv = _orient(V[vi], Fc, match_area(V[vi], Fc, uv))[0]
        uv = uv - uv.min(0) + [x0, 0.0]
        x0 = uv[:, 0].max() + 0.1 * np.ptp(uv[:, 1])
        UV[vi] = uv
    return UV


# ------------------------------------------------------------------ xatlas

def xatlas_map(V, F):
    """xatlas charting and packing of the whole mesh.

    Returns
    -------
    (UV, V_cut, F_cut) : the atlas UVs in [0,1]² on the cut mesh
        ``V_cut = V[vmapping]``; ``F_cut`` has the input's face order.
    """
    try:
        import xatlas
    except ImportError as e:  # pragma: no cover - xatlas is a core dependency
        raise Unavailable(f"xatlas is not installed ({e}): pip install xatlas") from None
    vmapping, indices, uvs = xatlas.parametrize(np.ascontiguousarray(V, np.float32), np.ascontiguousarray(F, np.uint32))
    Vc = np.asarray(V, float)[np.asarray(vmapping, np.int64)]
    Fc = np.asarray(indices, np.int64)
    if len(Fc) != len(F):
        raise RuntimeError(f"xatlas returned {len(Fc)} faces for {len(F)} input faces")
    return np.asarray(uvs, float), Vc, Fc


# ------------------------------------------------------------------ Blender

_BLENDER_MODES = {
    "blender-smart": "SMART",
    "blender-angle": "ANGLE_BASED",
    "blender-conformal": "CONFORMAL",
    "blender-minstretch": "MINIMUM_STRETCH",
}


def blender_python():
    """The Python interpreter that can ``import bpy``, or None.

    ``$NEURALUV_BPY_PYTHON`` when set, else the current interpreter when it has
    ``bpy`` installed.
    """
    env = os.environ.get("NEURALUV_BPY_PYTHON")
    if env:
        return env if Path(env).exists() else None
    import importlib.util

    return sys.executable if importlib.util.find_spec("bpy") is not None else None


def blender_map(V, F, mode="SMART", *, timeout=600, **params):
    """Blender's UV unwrap in a subprocess; per-corner UVs on the exploded mesh.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    mode : {"SMART", "ANGLE_BASED", "CONFORMAL", "MINIMUM_STRETCH"}
    timeout : float
        Seconds before the Blender process is killed.
    **params
        Passed to the operator (e.g. ``angle_limit``, ``island_margin``, ``margin``).

    Returns
    -------
    (UV, V_cut, F_cut, seconds)
        The loop UVs welded into a cut mesh (:func:`weld_corners`: corners
        sharing a vertex and a UV become one vertex) and Blender's own
        operator time.

    Notes
    -----
    The script :mod:`neuraluv._blender_unwrap` runs under the interpreter
    returned by :func:`blender_python` (``bpy`` is ~370 MB and kept out of the
    main environment).
    """
    import json

    py = blender_python()
    if py is None:
        raise Unavailable("Blender's bpy module not found: `python -m venv /tmp/bpyvenv && /tmp/bpyvenv/bin/pip install "
                          "'bpy==4.5.*' numpy`, then set NEURALUV_BPY_PYTHON=/tmp/bpyvenv/bin/python")
    script = Path(__file__).with_name("_blender_unwrap.py")
    with tempfile.TemporaryDirectory(prefix="neuraluv_bpy_") as tmp:
        src, dst = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        np.savez(src, V=np.asarray(V, float), F=np.asarray(F, np.int64))
        cmd = [py, str(script), str(src), str(dst), mode, json.dumps(params)]
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"Blender {mode} timed out after {timeout} s") from None
        if proc.returncode != 0 or not dst.exists():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["no output"]
            raise RuntimeError(f"Blender {mode} failed (exit {proc.returncode}): {tail[0]}")
        out = np.load(dst)
        UV, secs = np.asarray(out["uv"], float), float(out["seconds"])
    m = len(F)
    if UV.shape != (3 * m, 2):
        raise RuntimeError(f"Blender returned {UV.shape} loop UVs for {m} faces")
    vidx, F_cut, UV_cut = weld_corners(F, UV)
    return UV_cut, np.asarray(V, float)[vidx], F_cut, secs


# ------------------------------------------------------------------ OptCuts

def optcuts_binary():
    """Path of the OptCuts binary: ``$NEURALUV_OPTCUTS`` or ``OptCuts_bin`` on PATH, or None."""
    env = os.environ.get("NEURALUV_OPTCUTS")
    if env:
        return env if Path(env).exists() else None
    return shutil.which("OptCuts_bin")


def optcuts_map(V, F, *, lambda_init=0.999, distortion_bound=4.1, bijective=1, method_type=0, timeout=600):
    """OptCuts (Li et al. 2018) through its command-line binary; it re-cuts the chart.

    Runs, in a temporary working directory (OptCuts writes ``output/<run>/``)::

        OptCuts_bin 100 mesh.obj <lambda_init> 0 <method_type> <distortion_bound> <bijective> 0

    i.e. the README's ``progName mode inputMeshPath lambda_init testID
    methodType distortionBound useBijectivity initialCutOption`` with mode 100
    (headless), lambda_init 0.999 (joint optimisation, updated automatically),
    methodType 0 (OptCuts), bound 4.1 on E_SD, bijectivity on; then reads
    ``finalResult_mesh.obj`` ("input model with output UV in the original
    scale"). OptCuts accepts one connected component only, so several
    components are an ``"init fail"`` (use ``per_component=True``).

    Returns
    -------
    (UV, V_cut, F_cut)
    """
    binary = optcuts_binary()
    if binary is None:
        raise Unavailable("OptCuts binary not found: install OptCuts (github.com/liminchen/OptCuts) and set "
                          "NEURALUV_OPTCUTS=/path/to/OptCuts_bin")
    from .io import atomic_write, read_obj

    ncomp = topology_scan(V, F).components
    if ncomp != 1:
        raise InitFail(f"OptCuts takes one connected component, the input has {ncomp}")
    with tempfile.TemporaryDirectory(prefix="neuraluv_optcuts_") as tmp:
        tmp = Path(tmp)
        (tmp / "input").mkdir()
        src = tmp / "input" / "mesh.obj"
        with atomic_write(src) as fh:
            fh.write("".join(f"v {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in np.asarray(V, float)))
            fh.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in np.asarray(F, np.int64)))
        cmd = [binary, "100", str(src), str(lambda_init), "0", str(int(method_type)), str(distortion_bound),
               str(int(bijective)), "0"]
        try:
            proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"OptCuts timed out after {timeout} s") from None
        found = sorted(tmp.glob("output/**/finalResult_mesh.obj"))
        if proc.returncode != 0 or not found:
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["no output"]
            raise RuntimeError(f"OptCuts failed (exit {proc.returncode}, no finalResult_mesh.obj): {tail[0]}")
        Vo, Fo, UVo, FUV = read_obj(found[0])
    if UVo is None or len(UVo) == 0:
        raise RuntimeError("OptCuts output has no texture coordinates")
    if FUV is None:
        FUV = Fo
    vidx, F_cut, UV_cut = weld_corners(Fo, np.asarray(UVo, float)[np.asarray(FUV).reshape(-1)])
    return UV_cut, np.asarray(Vo, float)[vidx], F_cut


# ------------------------------------------------------------------ neural

def _neural(V, F, preset="fast", seed=0, device="auto", **overrides):
    """The paper's solver: one chart, or every component when there are several."""
    from .solver import solve_chart

    if topology_scan(V, F).components == 1:
        return solve_chart(V, F, _cfg(preset, overrides), seed=seed, device=device)
    parts = split_components(V, F)
    results = []
    for vi, fi in parts:
        Fc = np.searchsorted(vi, F[fi])
        results.append(_result_from_chart(_neural(V[vi], Fc, preset, seed, device, **overrides), "neural", V[vi], Fc))
    return _combine(results, parts, V, F, "neural")


def _cfg(preset, overrides):
    from .solver import get_config

    return get_config(preset, **overrides)


# ------------------------------------------------------------------ plumbing

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
        UV, mirrored = _orient(Vm, Fm, UV)
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
        from .errors import TopologyError

        status = "init fail" if isinstance(e, TopologyError) else "error"
        return _failed("neural", status, f"{type(e).__name__}: {' '.join(str(e).split())}", V, F, time.perf_counter() - t0)
    return _result_from_chart(res, "neural", V, F)


#: Methods whose output scale is arbitrary (rescaled with match_area before metrics).
SCALE_FREE = {"harmonic", "lscm", "bff", "xatlas", *_BLENDER_MODES}

#: name -> function(V, F, **kw) -> BaselineResult
METHODS = {
    "harmonic": _make("harmonic", harmonic, True),
    "lscm": _make("lscm", lscm, True),
    "arap": _make("arap", arap, False),
    "slim-20": _make("slim-20", lambda V, F, iterations=20: slim(V, F, iterations=iterations), False),
    "slim-1k": _make("slim-1k", lambda V, F, iterations=1000: slim(V, F, iterations=iterations), False),
    "bff": _make("bff", bff_map, True),
    "xatlas": _make("xatlas", xatlas_map, True, cut=True),
    **{name: _make(name, _blender(mode), True, cut=True) for name, mode in _BLENDER_MODES.items()},
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
    parts = split_components(V, F)
    results = []
    for vi, fi in parts:
        Fc = np.searchsorted(vi, F[fi])
        results.append(METHODS[method](V[vi], Fc, **kw))
    return _combine(results, parts, V, F, method)


def _main(argv=None):
    """``python -m neuraluv.baselines MESH [MESH ...] [--methods a,b] [--per-component]``: print a table."""
    import argparse

    from . import datasets

    p = argparse.ArgumentParser(prog="python -m neuraluv.baselines", description=_main.__doc__)
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
    _main()
