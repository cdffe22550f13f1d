"""Atlas step 3: route each disk-like candidate to the neural solver or a marked fallback."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from neuraluv.atlas.candidates import bisect_faces
from neuraluv.atlas.validate import self_overlap
from neuraluv.metrics import distortion_metrics
from neuraluv.topology import submesh

__all__ = ["AtlasChart", "pca_uv", "per_face_uv", "fallback_islands", "route_chart"]


def pca_uv(V, F):
    """Project a chart on its two principal axes, oriented like its faces.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array

    Returns
    -------
    UV : (n,2) float array (at 3D scale)

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> distortion_metrics(V, np.array([[0, 1, 2]]), pca_uv(V, np.array([[0, 1, 2]])))["flips"]
    0
    """
    V = np.asarray(V, float)
    X = V - V.mean(0)
    _, _, vt = np.linalg.svd(X, full_matrices=False)
    a, b = vt[0], vt[1] if len(vt) > 1 else np.array([0.0, 1.0, 0.0])
    nrm = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]).sum(0)
    if np.dot(np.cross(a, b), nrm) < 0:
        b = -b
    return np.column_stack([X @ a, X @ b])


def per_face_uv(V, F):
    """Each triangle laid out isometrically on its own (always flip-free).

    Returns
    -------
    list of (3,2) float arrays, one per face (corners in face order).
    """
    from neuraluv.jacobian import local_frames

    dCi, _ = local_frames(V, F)
    C = np.linalg.inv(dCi)  # columns: c_j - c_i, c_k - c_i
    return [np.array([[0.0, 0.0], C[t][:, 0], C[t][:, 1]]) for t in range(len(F))]


@dataclass
class AtlasChart:
    """One chart candidate and where it was routed.

    Attributes
    ----------
    faces : (k,) int array, faces of the repaired mesh.
    route : ``"neural"`` or ``"fallback"``.
    method : ``"neural"``, ``"neural-retry"``, ``"pca"``, ``"split-pca"``,
        ``"per-face"``.
    reason : why a fallback was used (or the retry reason for neural charts).
    source : how the candidate arose (component, xatlas seams, split).
    islands : list of ``(fidx, vidx, Fl, uv)``: faces, vertices, local faces and
        UVs (3D scale) of each packed island (one for neural charts).
    metrics : chart metrics (:func:`distortion_metrics`) at 3D scale over all islands.
    time : seconds spent routing the chart.
    solver : summary of the last neural attempt (``ChartResult.summary()``) or None.
    """

    faces: np.ndarray
    route: str
    method: str
    reason: str
    source: str
    islands: list
    metrics: dict = field(default_factory=dict)
    time: float = 0.0
    solver: dict | None = None

    def summary(self, i):
        return {
            "chart": i, "faces": int(len(self.faces)), "islands": len(self.islands), "route": self.route,
            "method": self.method, "reason": self.reason, "source": self.source, "metrics": self.metrics,
            "time": self.time, "solver": self.solver,
        }


def fallback_islands(V, F, fidx, why, depth=0):
    """A marked fallback: PCA → split into halves (PCA each, recursively) → per-face islands.

    Returns
    -------
    method : ``"pca"``, ``"split-pca"`` or ``"per-face"``
    islands : list of ``(fidx, vidx, Fl, uv)`` (see :class:`AtlasChart`)
    why : the reason passed in
    """
    vi, Fl = submesh(F, fidx)
    uv = pca_uv(V[vi], Fl)
    m = distortion_metrics(V[vi], Fl, uv)
    if m["valid"] and self_overlap(uv, Fl) == 0.0:
        return "pca", [(fidx, vi, Fl, uv)], why
    if depth < 6 and len(fidx) > 1:
        out = []
        for p in bisect_faces(V, F, fidx):
            _, isl, _ = fallback_islands(V, F, p, why, depth + 1)
            out += isl
        return ("split-pca" if depth == 0 else "split"), out, why
    out = []
    for f, uvf in zip(fidx, per_face_uv(V, F[fidx])):
        out.append((np.array([f]), F[f].copy(), np.array([[0, 1, 2]]), uvf))
    return "per-face", out, why


def route_chart(V, F, fidx, preview, retry, *, seed=0, device="cpu", min_neural_faces=3, max_esd=1e3,
                source="component", deadline=None):
    """Route one disk-like candidate: neural (preview, then retry) or a marked fallback.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    fidx : (k,) int array, the candidate's faces.
    preview, retry : SolverConfig
        The short preview pass and the stricter retry schedule.
    seed : int
    device : str
    min_neural_faces : int
        Candidates with fewer faces skip the network and take the exact
        per-face/PCA unfold (marked fallback, reason "small chart").
    max_esd : float
        Quality threshold: a preview above it is retried (the retry result is
        kept whenever it is valid).
    source : str
    deadline : float, optional
        ``time.perf_counter()`` value after which no more neural solves start
        (remaining charts become fallbacks, reason "time budget").

    Returns
    -------
    AtlasChart

    Examples
    --------
    >>> from neuraluv.datasets import spherical_cap
    >>> from neuraluv.solver.config import get_config
    >>> V, F = spherical_cap(n_rings=4)
    >>> c = route_chart(V, F, np.arange(len(F)), get_config("test", iterations=10, retries=0), get_config("test"))
    >>> c.route, c.metrics["flips"]
    ('neural', 0)
    """
    from neuraluv.solver.chart import solve_chart

    t0 = time.perf_counter()
    fidx = np.asarray(fidx, np.int64)
    vi, Fl = submesh(F, fidx)
    Vc = V[vi]
    chart = None
    solver_summary = None
    if len(fidx) < min_neural_faces:
        why = f"small chart ({len(fidx)} < {min_neural_faces} faces): exact unfold, network skipped"
    elif deadline is not None and time.perf_counter() > deadline:
        why = "time budget exhausted before this chart"
    else:
        why, retry_why = "", ""
        for stage, cfg in (("preview", preview), ("retry", retry)):
            try:
                res = solve_chart(Vc, Fl, cfg, seed=seed, device=device, check=False, label=f"{stage}")
            except Exception as exc:  # degenerate input for eigensolvers etc.
                why = f"neural solver error in {stage}: {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
                continue
            solver_summary = res.summary()
            solver_summary.pop("metrics", None)
            if res.status != "neural":
                why = f"{stage}: {res.reason}"
            else:
                ov = self_overlap(res.uv, Fl)
                if ov > 0:
                    why = f"{stage}: chart overlaps itself in UV ({100 * ov:.3g}% of its area)"
                elif stage == "preview" and not (res.metrics["esd"] <= max_esd):
                    why = f"preview E_SD {res.metrics['esd']:.4g} above the quality threshold {max_esd:g}"
                    retry_why = why
                    best = res
                    continue
                else:
                    chart = AtlasChart(fidx, "neural", "neural" if stage == "preview" else "neural-retry",
                                       retry_why or (why if stage == "retry" else ""), source, [(fidx, vi, Fl, res.uv)])
                    break
            if deadline is not None and time.perf_counter() > deadline:
                why += "; time budget exhausted before the retry"
                break
        if chart is None and retry_why and "best" in locals():
            # the retry was invalid, the preview valid but above the threshold: keep the preview
            chart = AtlasChart(fidx, "neural", "neural", f"{retry_why}; retry did not improve it", source,
                               [(fidx, vi, Fl, best.uv)])
    if chart is None:
        method, islands, why = fallback_islands(V, F, fidx, why)
        chart = AtlasChart(fidx, "fallback", method, why, source, islands)
    # chart metrics over its islands (exploded so islands are independent)
    Vx = np.vstack([V[isl[1]] for isl in chart.islands])
    off = np.cumsum([0] + [len(isl[1]) for isl in chart.islands])
    Fx = np.vstack([isl[2] + o for isl, o in zip(chart.islands, off[:-1])])
    Ux = np.vstack([isl[3] for isl in chart.islands])
    chart.metrics = distortion_metrics(Vx, Fx, Ux)
    chart.solver = solver_summary
    chart.time = time.perf_counter() - t0
    return chart
