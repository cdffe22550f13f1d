"""Validation-first atlas construction (paper Sec. 4 and Figure 4).

A whole, possibly messy, input mesh becomes a packed UV atlas:

1. **repair** — weld coincident vertices, drop degenerate/duplicate faces,
   orient every component consistently (``igl.bfs_orient``) and split
   non-manifold edges and vertices (``igl.split_nonmanifold``);
2. **chart candidates** — connected components; components that are not
   disk-like get seams from xatlas's charting, and any piece that is still not
   disk-like is bisected until it is (every candidate passes
   :func:`neuraluv.topology.is_disk_like`);
3. **routing** — each candidate goes to the neural solver
   (:func:`neuraluv.solver.solve_chart`): a short preview pass, then a
   stricter retry when the preview is invalid, self-overlapping or above the
   quality threshold. Charts with fewer than ``min_neural_faces`` faces skip the
   network (their isometric unfold is exact). Charts that still fail become
   **marked fallbacks** — PCA projection when it is flip-free and
   overlap-free, else a split into halves (PCA each, recursively), else
   per-face islands — each with its reason;
4. **packing** — the paper's area-scaled shelf packer (or xatlas's) with a
   padding in texels at a target resolution;
5. **validation** — :func:`validate_atlas`: zero flipped faces (det J ≤ 0),
   no overlap between islands (exact polygon geometry, not sampling), every UV
   in ``[0,1]²`` and the padding respected; the CLI runs it on the file it
   wrote, read back.

The routed-face split is the paper's Table 8 quantity (52.1% neural /
47.9% fallback on Amara).
"""
from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import NeuralUVError
from .io import atomic_write, check_mesh_arrays, read_obj, write_obj
from .metrics import distortion_metrics
from .repair import repair_mesh
from .topology import is_disk_like, topology_scan

__all__ = [
    "AtlasChart", "AtlasResult", "prepare_mesh", "seam_charts", "bisect_faces", "chart_candidates",
    "pca_uv", "per_face_uv", "self_overlap", "route_chart", "build_atlas", "validate_atlas",
    "write_atlas", "read_atlas", "plot_routes", "save_renders", "atlas_file", "uv_islands", "repack", "ROUTE_COLORS",
]

#: Figure 8 colours: neural charts blue, fallbacks red.
ROUTE_COLORS = {"neural": (0.16, 0.40, 0.80, 1.0), "fallback": (0.86, 0.18, 0.15, 1.0)}


# --------------------------------------------------------------------------- helpers
def _local(F, fidx):
    """Vertices and re-indexed faces of the sub-mesh ``F[fidx]``."""
    Fs = F[fidx]
    vi = np.unique(Fs)
    return vi, np.searchsorted(vi, Fs)


def _normalize(V):
    """Unit-box copy of ``V`` that survives huge coordinates."""
    V = np.asarray(V, float)
    m = float(np.abs(V).max()) if V.size else 1.0
    Vs = V / m if (m > 0 and np.isfinite(m)) else V
    lo, hi = Vs.min(0), Vs.max(0)
    s = float((hi - lo).max())
    return (Vs - 0.5 * (lo + hi)) / (s if s > 0 else 1.0)


def _face_components(F):
    """Label faces by connectivity through shared (manifold or not) edges."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    m = len(F)
    if m == 0:
        return 0, np.zeros(0, np.int64)
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    fid = np.tile(np.arange(m), 3)
    _, inv = np.unique(E, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    A = sp.coo_matrix((np.ones(3 * m), (fid, inv)), shape=(m, inv.max() + 1)).tocsr()
    return connected_components(A @ A.T, directed=False)


@contextlib.contextmanager
def _torch_threads(n):
    if not n:
        yield
        return
    import torch

    old = torch.get_num_threads()
    torch.set_num_threads(int(n))
    try:
        yield
    finally:
        torch.set_num_threads(old)


# --------------------------------------------------------------------------- repair
def prepare_mesh(V, F, *, min_height=1e-6):
    """Repair a raw mesh for atlas construction.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    min_height : float
        Faces whose smallest height is below ``min_height`` times the bounding-box
        diagonal are removed like degenerate faces (counted in
        ``info["sliver_faces"]``): float32 outputs (GLB) cannot keep them flip-free.

    Returns
    -------
    V : (n',3) float array
    F : (m',3) int array
        Welded, degenerate/duplicate-free, each component consistently
        oriented (majority of the input winding kept), manifold.
    vmap : (n',) int array
        Input vertex of each output vertex (``V_out = V_in[vmap]``).
    info : dict
        ``repair`` (RepairReport counts), ``reoriented_faces``, ``split_vertices``,
        ``sliver_faces``.

    Examples
    --------
    >>> from neuraluv.generated import flip_windings, unweld
    >>> from neuraluv.datasets import sphere
    >>> V, F = sphere(1)
    >>> V2, F2 = unweld(V, flip_windings(F, 0.3))
    >>> V3, F3, vmap, info = prepare_mesh(V2, F2)
    >>> len(V3) == len(V), topology_scan(V3, F3).oriented
    (True, True)
    """
    import igl

    V, F = check_mesh_arrays(V, F)
    V1, F1, rep, vmap = repair_mesh(V, F, weld=True)
    info = {"repair": rep.as_dict(), "reoriented_faces": 0, "split_vertices": 0, "removed_after_split": 0}
    if len(F1) == 0:
        return V1, F1, vmap, info
    FF, C = igl.bfs_orient(F1)
    FF = np.asarray(FF, np.int64)
    C = np.asarray(C, np.int64).reshape(-1)
    flipped = ~np.all(FF == F1, axis=1)
    # keep the input's majority winding in each patch
    for c in np.unique(C[flipped]):
        inc = C == c
        if flipped[inc].sum() * 2 > inc.sum():
            FF[inc] = FF[inc][:, [0, 2, 1]]
    info["reoriented_faces"] = int((~np.all(FF == F1, axis=1)).sum())
    SV, SF, SVI = igl.split_nonmanifold(V1, FF)
    SF = np.asarray(SF, np.int64)
    SVI = np.asarray(SVI, np.int64).reshape(-1)
    info["split_vertices"] = int(len(SV) - len(V1))
    V2, F2, rep2, vm2 = repair_mesh(np.asarray(SV, float), SF)
    info["removed_after_split"] = int(rep2.degenerate_faces + rep2.duplicate_faces)
    vmap = vmap[SVI[vm2]]
    # needles thinner than min_height·diag: below what float32 (GLB, GPU UVs) resolves
    info["sliver_faces"] = 0
    if min_height and len(F2):
        P = V2[F2]
        edge = np.linalg.norm(P[:, [1, 2, 0]] - P, axis=2).max(1)
        area2 = np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
        diag = float(np.linalg.norm(V2.max(0) - V2.min(0))) or 1.0
        thin = ~(area2 >= min_height * diag * edge)
        if thin.any() and not thin.all():
            info["sliver_faces"] = int(thin.sum())
            V2, F2, _, vm3 = repair_mesh(V2, F2[~thin])
            vmap = vmap[vm3]
    return V2, F2, vmap, info


# --------------------------------------------------------------------------- candidates
def seam_charts(V, F, *, max_cost=4.0, max_iterations=2):
    """Partition a (non-disk) component into xatlas charts.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    max_cost : float
        xatlas ``ChartOptions.max_cost`` (larger: fewer, bigger charts).
    max_iterations : int

    Returns
    -------
    charts : list of (k_i,) int arrays of face indices into ``F``; faces xatlas
        left out (zero area in float32) come back as their own groups.
    """
    import xatlas

    at = xatlas.Atlas()
    at.add_mesh(_normalize(V).astype(np.float32), F.astype(np.uint32))
    co = xatlas.ChartOptions()
    co.max_cost = float(max_cost)
    co.max_iterations = int(max_iterations)
    po = xatlas.PackOptions()
    po.resolution = 256  # packing result unused; keep it cheap
    at.generate(co, po)
    out, seen = [], np.zeros(len(F), bool)
    for i in range(at.get_mesh_chart_count(0)):
        f = np.asarray(at.get_mesh_chart(0, i).faces, np.int64)
        f = f[~seen[f]]
        if len(f):
            seen[f] = True
            out.append(f)
    rest = np.flatnonzero(~seen)
    if len(rest):
        n, lab = _face_components(F[rest])
        out += [rest[lab == c] for c in range(n)]
    return out


def bisect_faces(V, F, fidx):
    """Split a face set in two along its longest principal axis.

    Returns the edge-connected pieces of the two halves (at least two pieces
    when ``len(fidx) > 1``).

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> V, F = disk(n_rings=3)
    >>> parts = bisect_faces(V, F, np.arange(len(F)))
    >>> len(parts) >= 2, sum(len(p) for p in parts) == len(F)
    (True, True)
    """
    fidx = np.asarray(fidx, np.int64)
    if len(fidx) < 2:
        return [fidx]
    c = V[F[fidx]].mean(1)
    c0 = c - c.mean(0)
    _, _, vt = np.linalg.svd(c0, full_matrices=False)
    t = c0 @ vt[0]
    order = np.argsort(t, kind="stable")
    halves = [fidx[order[: len(fidx) // 2]], fidx[order[len(fidx) // 2:]]]
    parts = []
    for h in halves:
        n, lab = _face_components(F[h])
        parts += [h[lab == k] for k in range(n)]
    return parts


def _make_disks(V, F, fidx, note, out, depth=0):
    vi, Fc = _local(F, fidx)
    ok, why = is_disk_like(V[vi], Fc)
    if ok:
        out.append((fidx, note))
        return
    for p in bisect_faces(V, F, fidx):
        _make_disks(V, F, p, f"{note}; split (not disk-like: {why})" if depth == 0 else note, out, depth + 1)


def chart_candidates(V, F, *, max_cost=4.0):
    """Disk-like chart candidates covering every face exactly once.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array (a repaired mesh, see :func:`prepare_mesh`)
    max_cost : float
        xatlas charting cost for components that need seams.

    Returns
    -------
    list of (fidx, source) pairs
        ``source`` says how the candidate arose (``"component"``,
        ``"xatlas seams (closed surface ...)"``, ``"...; split (...)"``).

    Examples
    --------
    >>> from neuraluv.datasets import several_components
    >>> V, F = several_components(3)
    >>> [s for _, s in chart_candidates(V, F)]
    ['component', 'component', 'component']
    """
    from .topology import split_components

    out = []
    for vi, fi in split_components(V, F):
        Fc = np.searchsorted(vi, F[fi])
        ok, why = is_disk_like(V[vi], Fc)
        if ok:
            out.append((fi, "component"))
            continue
        if len(fi) <= 2:
            _make_disks(V, F, fi, "component", out)
            continue
        try:
            pieces = seam_charts(V[vi], Fc, max_cost=max_cost)
        except Exception as exc:  # xatlas refuses some inputs: bisect instead
            _make_disks(V, F, fi, f"component; xatlas failed ({type(exc).__name__})", out)
            continue
        for ch in pieces:
            _make_disks(V, F, fi[ch], f"xatlas seams ({why})", out)
    return out


# --------------------------------------------------------------------------- fallbacks
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
    from .jacobian import local_frames

    dCi, _ = local_frames(V, F)
    C = np.linalg.inv(dCi)  # columns: c_j - c_i, c_k - c_i
    return [np.array([[0.0, 0.0], C[t][:, 0], C[t][:, 1]]) for t in range(len(F))]


def self_overlap(UV, F, rtol=1e-7):
    """Relative area by which a chart's UV triangles overlap each other.

    ``(Σ|A_t| − |∪ t|) / Σ|A_t|`` computed exactly with shapely polygon unions;
    0 for a globally injective chart.

    Examples
    --------
    >>> UV = np.array([[0., 0], [1, 0], [0, 1], [1, 1]])
    >>> self_overlap(UV, np.array([[0, 1, 2], [1, 3, 2]])), self_overlap(UV, np.array([[0, 1, 2], [0, 1, 3]])) > 0
    (0.0, True)
    """
    P, total = _triangles_union(UV, F)
    if total <= 0:
        return 0.0
    d = (total - P.area) / total
    return float(d) if d > rtol else 0.0


def _triangles_union(UV, F):
    import shapely

    tri = np.asarray(UV, float)[np.asarray(F)]
    a = tri[:, 1] - tri[:, 0]
    b = tri[:, 2] - tri[:, 0]
    total = float(0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]).sum())
    ring = np.concatenate([tri, tri[:, :1]], axis=1)
    polys = shapely.polygons(ring)
    return shapely.union_all(polys), total


# --------------------------------------------------------------------------- routing
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


def _fallback(V, F, fidx, why, depth=0):
    """PCA → split into halves (PCA each, recursively) → per-face islands."""
    vi, Fl = _local(F, fidx)
    uv = pca_uv(V[vi], Fl)
    m = distortion_metrics(V[vi], Fl, uv)
    if m["valid"] and self_overlap(uv, Fl) == 0.0:
        return "pca", [(fidx, vi, Fl, uv)], why
    if depth < 6 and len(fidx) > 1:
        out = []
        for p in bisect_faces(V, F, fidx):
            _, isl, _ = _fallback(V, F, p, why, depth + 1)
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
    >>> from neuraluv.solver import get_config
    >>> V, F = spherical_cap(n_rings=4)
    >>> c = route_chart(V, F, np.arange(len(F)), get_config("test", iterations=10, retries=0), get_config("test"))
    >>> c.route, c.metrics["flips"]
    ('neural', 0)
    """
    from .solver import solve_chart

    t0 = time.perf_counter()
    fidx = np.asarray(fidx, np.int64)
    vi, Fl = _local(F, fidx)
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
        method, islands, why = _fallback(V, F, fidx, why)
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


# --------------------------------------------------------------------------- result
@dataclass
class AtlasResult:
    """A packed atlas of a whole mesh.

    Attributes
    ----------
    V : (n,3) float array, repaired vertices in the input's coordinates.
    F : (m,3) int array, repaired faces (the coverage denominator).
    UV : (p,2) float array in ``[0,1]²``.
    FUV : (m,3) int array, per-corner indices into ``UV``.
    charts : list of AtlasChart.
    face_chart : (m,) int array, chart of each face.
    face_route : (m,) int array, 1 for neural-routed faces, 0 for fallback.
    validation : dict from :func:`validate_atlas` (in memory).
    info : dict, input counts, repair, packing, timings.
    """

    V: np.ndarray
    F: np.ndarray
    UV: np.ndarray
    FUV: np.ndarray
    charts: list
    face_chart: np.ndarray
    face_route: np.ndarray
    validation: dict
    info: dict

    @property
    def valid(self):
        return bool(self.validation.get("valid", False))

    def totals(self):
        """Table 8 quantities: coverage, routed face shares, flips, overlaps."""
        m = len(self.F)
        nf = int(self.face_route.sum())
        charts = self.charts
        reasons = {}
        for c in charts:
            if c.route == "fallback":
                key = c.reason.split(":")[0].split("(")[0].strip() or "unspecified"
                reasons[key] = reasons.get(key, 0) + len(c.faces)
        v = self.validation
        return {
            "input_faces": self.info["input_faces"],
            "repaired_faces": m,
            "covered_faces": int(v.get("covered_faces", 0)),
            "coverage": v.get("covered_faces", 0) / m if m else 0.0,
            "neural_faces": nf,
            "fallback_faces": m - nf,
            "neural_share": nf / m if m else 0.0,
            "fallback_share": (m - nf) / m if m else 0.0,
            "charts": len(charts),
            "neural_charts": sum(c.route == "neural" for c in charts),
            "fallback_charts": sum(c.route != "neural" for c in charts),
            "islands": int(v.get("islands", 0)),
            "flips": int(v.get("flips", -1)),
            "overlapping_pairs": int(v.get("overlapping_pairs", -1)),
            "self_overlapping_islands": int(v.get("self_overlapping_islands", -1)),
            "uv_in_unit_square": bool(v.get("uv_in_unit_square", False)),
            "min_gap_texels": v.get("min_gap_texels"),
            "utilisation": self.info.get("utilisation"),
            "fallback_faces_by_reason": reasons,
            "valid": self.valid,
            "time": self.info.get("time"),
        }

    def report(self):
        """The JSON report (per chart: route, reason, metrics, time; totals)."""
        from .unwrap import jsonable

        return jsonable({
            "neuraluv": __import__("neuraluv").__version__,
            "info": self.info,
            "totals": self.totals(),
            "validation": self.validation,
            "charts": [c.summary(i) for i, c in enumerate(self.charts)],
        })


def build_atlas(V, F, preset="fast", *, resolution=1024, padding=4.0, packer="shelf", seed=0, device="cpu",
                preview_iters=None, min_neural_faces=3, max_esd=1e3, max_cost=4.0, time_budget=None,
                threads=None, progress=False, min_height=1e-6, **overrides):
    """Build a validated UV atlas of a whole (possibly messy) mesh.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    preset : str or SolverConfig
        Solver preset for the retry; the preview uses the same preset with
        ``preview_iters`` iterations and no seed retries.
    resolution : int
        Target texture resolution the padding refers to.
    padding : float
        Minimum gap between islands (and to the border) in texels.
    packer : ``"shelf"`` (the paper's area-scaled shelf packer) or ``"xatlas"``.
    seed : int
    device : str
    preview_iters : int, optional
        Iterations of the preview pass (default: a fifth of the preset's, at least 20).
    min_neural_faces : int
        Candidates below this face count skip the network (exact unfold).
    max_esd : float
        Preview quality threshold (above it the chart is retried).
    max_cost : float
        xatlas charting cost for seams.
    min_height : float
        Sliver threshold of :func:`prepare_mesh` (relative to the diagonal).
    time_budget : float, optional
        Seconds after which no new neural solve starts (remaining charts become
        marked fallbacks).
    threads : int, optional
        torch CPU threads during the solves (restored afterwards).
    progress : bool
    **overrides
        SolverConfig overrides applied to both passes.

    Returns
    -------
    AtlasResult

    Raises
    ------
    NeuralUVError
        When nothing usable is left after repair (all faces degenerate).

    Examples
    --------
    >>> from neuraluv.datasets import sphere
    >>> res = build_atlas(*sphere(1), "test", resolution=256, padding=2)
    >>> res.valid, res.totals()["coverage"], res.totals()["flips"]
    (True, 1.0, 0)
    """
    from .solver import get_config

    t0 = time.perf_counter()
    V, F = check_mesh_arrays(V, F)
    Vin = V
    Vn = _normalize(V)
    Vr, Fr, vmap, rinfo = prepare_mesh(Vn, F, min_height=min_height)
    if len(Fr) == 0:
        raise NeuralUVError("no usable faces: every face is degenerate (zero area or repeated corners)")
    topo = topology_scan(Vr, Fr)
    cfg = get_config(preset, **overrides)
    pre_it = preview_iters if preview_iters is not None else max(20, cfg.iterations // 5)
    preview = get_config(cfg, iterations=min(pre_it, cfg.iterations), retries=0, early_stop=True)
    retry = get_config(cfg, retries=max(cfg.retries, 1), lr=cfg.lr * 0.5)
    t_rep = time.perf_counter()
    cands = chart_candidates(Vr, Fr, max_cost=max_cost)
    t_cand = time.perf_counter()
    deadline = None if time_budget is None else t0 + float(time_budget)
    charts = []
    it = cands
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = it = tqdm(cands, desc="charts", leave=False, dynamic_ncols=True)
    with _torch_threads(threads):
        for k, (fidx, src) in enumerate(it):
            charts.append(route_chart(Vr, Fr, fidx, preview, retry, seed=seed, device=device,
                                      min_neural_faces=min_neural_faces, max_esd=max_esd, source=src, deadline=deadline))
    if bar is not None:
        bar.close()
    t_route = time.perf_counter()
    Vout = Vin[vmap]
    UV, FUV, face_chart, face_route, packed = _pack(charts, len(Fr), packer, padding, resolution)
    t_pack = time.perf_counter()
    validation = validate_atlas(Vout, Fr, UV, FUV, padding=padding, resolution=resolution)
    info = {
        "input_vertices": int(len(Vin)), "input_faces": int(len(F)),
        "repaired_vertices": int(len(Vr)), "repaired_faces": int(len(Fr)),
        "repair": rinfo, "topology": topo.as_dict(),
        "preset": preset if isinstance(preset, str) else "custom",
        "preview": {"iterations": preview.iterations, "retries": preview.retries},
        "retry": {"iterations": retry.iterations, "retries": retry.retries, "lr": retry.lr},
        "min_neural_faces": min_neural_faces, "max_esd": max_esd, "max_cost": max_cost, "time_budget": time_budget,
        "packer": packer, "resolution": resolution, "padding": padding,
        "utilisation": packed.utilisation, "pack_scale": packed.scale,
        "timings": {"repair": t_rep - t0, "candidates": t_cand - t_rep, "routing": t_route - t_cand,
                    "packing": t_pack - t_route, "validation": time.perf_counter() - t_pack},
        "time": time.perf_counter() - t0, "device": str(device), "seed": seed,
    }
    return AtlasResult(V=Vout, F=Fr, UV=UV, FUV=FUV, charts=charts, face_chart=face_chart, face_route=face_route,
                       validation=validation, info=info)


def _pack(charts, m, packer, padding, resolution):
    """Pack the charts' islands and assemble per-corner UVs for ``m`` faces."""
    from .packing import rotate_to_min_box, shelf_pack, xatlas_pack

    islands = [isl for c in charts for isl in c.islands]
    uvs = [rotate_to_min_box(isl[3]) for isl in islands]
    fl = [isl[2] for isl in islands]
    if packer == "shelf":
        packed = shelf_pack(uvs, fl, padding=padding, resolution=resolution)
    elif packer == "xatlas":
        packed = xatlas_pack(uvs, fl, padding=padding, resolution=resolution)
    else:
        raise NeuralUVError(f"unknown packer {packer!r}: use 'shelf' or 'xatlas'")
    FUV = -np.ones((m, 3), np.int64)
    UVs, off = [], 0
    for isl, uv in zip(islands, packed.uvs):
        FUV[isl[0]] = isl[2] + off
        UVs.append(uv)
        off += len(uv)
    # float32-representable values, so OBJ and GLB (float32 TEXCOORD_0) carry the
    # same layout and the in-memory validation speaks for both files
    UV = np.clip(np.vstack(UVs), 0.0, 1.0).astype(np.float32).astype(np.float64)
    face_chart = np.zeros(m, np.int64)
    face_route = np.zeros(m, np.int8)
    for i, c in enumerate(charts):
        face_chart[c.faces] = i
        face_route[c.faces] = c.route == "neural"
    return UV, FUV, face_chart, face_route, packed


def repack(res, packer="shelf", *, padding=None, resolution=None):
    """Re-pack an atlas's charts with another packer or padding, without re-solving.

    Parameters
    ----------
    res : AtlasResult
    packer : ``"shelf"`` or ``"xatlas"``
    padding, resolution : optional, default the atlas's own.

    Returns
    -------
    AtlasResult (the same charts, new ``UV``/``FUV``, validation and packing info)

    Examples
    --------
    >>> from neuraluv.datasets import sphere
    >>> res = build_atlas(*sphere(1), "test", resolution=256, padding=2)
    >>> repack(res, "xatlas").validation["valid"]
    True
    """
    from dataclasses import replace

    padding = res.info["padding"] if padding is None else padding
    resolution = res.info["resolution"] if resolution is None else resolution
    UV, FUV, fc, fr, packed = _pack(res.charts, len(res.F), packer, padding, resolution)
    info = dict(res.info, packer=packer, padding=padding, resolution=resolution,
                utilisation=packed.utilisation, pack_scale=packed.scale)
    return replace(res, UV=UV, FUV=FUV, face_chart=fc, face_route=fr, info=info,
                   validation=validate_atlas(res.V, res.F, UV, FUV, padding=padding, resolution=resolution))


# --------------------------------------------------------------------------- validation
def uv_islands(FUV):
    """Label faces by UV island (faces sharing a ``vt`` index are connected).

    Returns
    -------
    n : int
    labels : (m,) int array
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    FUV = np.asarray(FUV, np.int64)
    m = len(FUV)
    if m == 0:
        return 0, np.zeros(0, np.int64)
    A = sp.coo_matrix((np.ones(3 * m), (np.repeat(np.arange(m), 3), FUV.reshape(-1))), shape=(m, FUV.max() + 1)).tocsr()
    return connected_components(A @ A.T, directed=False)


def validate_atlas(V, F, UV, FUV=None, *, padding=0.0, resolution=None, check_padding=True):
    """Check a packed atlas exactly: flips, overlaps, bounds, padding.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional (default ``F``)
    padding : float
        Required gap between islands in texels at ``resolution``.
    resolution : int, optional
    check_padding : bool

    Returns
    -------
    dict
        ``flips`` (faces with det J ≤ 0 via :func:`neuraluv.metrics.distortion_metrics`),
        ``islands``, ``overlapping_pairs`` (island pairs whose polygons share
        area), ``overlap_area``, ``self_overlapping_islands``, ``padding_violations``
        (pairs closer than ``padding/resolution``), ``min_gap_texels``,
        ``uv_in_unit_square``, ``covered_faces`` and ``valid``.

    Notes
    -----
    Islands are unions of their UV triangles (shapely/GEOS, exact polygon
    arithmetic in floating point); candidate pairs come from an STRtree query.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2], [0, 1, 2]])
    >>> UV = np.array([[.1, .1], [.4, .1], [.1, .4], [.2, .2], [.5, .2], [.2, .5]])
    >>> r = validate_atlas(V, F, UV, np.array([[0, 1, 2], [3, 4, 5]]))
    >>> r["flips"], r["overlapping_pairs"], r["valid"]
    (0, 1, False)
    """
    import shapely

    V = _normalize(V)
    F = np.asarray(F, np.int64)
    FUV = F if FUV is None else np.asarray(FUV, np.int64)
    UV = np.asarray(UV, float)
    m = len(F)
    covered = int((FUV >= 0).all(1).sum()) if m else 0
    finite = bool(np.all(np.isfinite(UV)))
    used = UV[np.unique(FUV[FUV >= 0])] if m else UV[:0]
    in_box = bool(finite and len(used) and used.min() >= 0.0 and used.max() <= 1.0)
    met = distortion_metrics(V, F, UV, FUV) if m else {"flips": 0}
    flips = int(met["flips"])
    n, lab = uv_islands(FUV)
    polys, self_ov = [], 0
    order = np.argsort(lab, kind="stable")
    bounds = np.searchsorted(lab[order], np.arange(n + 1))
    for i in range(n):
        fi = order[bounds[i]:bounds[i + 1]]
        P, total = _triangles_union(UV, FUV[fi])
        if total > 0 and (total - P.area) / total > 1e-7:
            self_ov += 1
        polys.append(P)
    polys = np.array(polys, dtype=object)
    tree = shapely.STRtree(polys)
    pad = float(padding) / float(resolution) if (resolution and check_padding) else 0.0
    ov_pairs, ov_area, pad_viol = 0, 0.0, 0
    a, b = tree.query(polys, predicate="intersects")
    keep = a < b
    for i, j in zip(a[keep], b[keep]):
        ar = polys[i].intersection(polys[j]).area
        if ar > 0:
            ov_pairs += 1
            ov_area += ar
    min_gap = float("inf")
    if n > 1:
        probe = max(pad, 1e-9)
        a, b = tree.query(polys, predicate="dwithin", distance=probe * 4)
        keep = a < b
        for i, j in zip(a[keep], b[keep]):
            d = polys[i].distance(polys[j])
            min_gap = min(min_gap, d)
            if pad > 0 and d < pad * (1 - 1e-6):
                pad_viol += 1
    gap_tex = (min_gap * resolution) if (resolution and math.isfinite(min_gap)) else (None if n > 1 and not math.isfinite(min_gap) else min_gap)
    if resolution and not math.isfinite(min_gap):
        gap_tex = f">{4 * max(pad, 1e-9) * resolution:.3g}" if n > 1 else "inf"
    valid = (covered == m and flips == 0 and ov_pairs == 0 and self_ov == 0 and in_box and pad_viol == 0)
    return {
        "faces": m, "covered_faces": covered, "flips": flips, "min_det": met.get("min_det"),
        "islands": int(n), "overlapping_pairs": ov_pairs, "overlap_area": ov_area,
        "self_overlapping_islands": self_ov, "padding_violations": pad_viol, "padding_texels": padding,
        "resolution": resolution, "min_gap_texels": gap_tex, "uv_in_unit_square": in_box, "valid": bool(valid),
    }


# --------------------------------------------------------------------------- export
def write_atlas(path, V, F, UV, FUV):
    """Write an atlas as OBJ (per-corner ``vt``) or GLB (``TEXCOORD_0``), atomically.

    For GLB, one vertex is written per distinct (position, UV) pair.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".obj":
        write_obj(path, V, F, UV, FUV)
    elif ext in (".glb", ".gltf"):
        import trimesh
        from trimesh.visual import TextureVisuals

        pairs = np.stack([np.asarray(F).reshape(-1), np.asarray(FUV).reshape(-1)], 1)
        uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
        mesh = trimesh.Trimesh(vertices=np.asarray(V, float)[uniq[:, 0]], faces=inv.reshape(-1, 3),
                               visual=TextureVisuals(uv=np.asarray(UV, float)[uniq[:, 1]]), process=False)
        data = mesh.export(file_type="glb")
        with atomic_write(path, "wb") as fh:
            fh.write(data)
    else:
        raise NeuralUVError(f"output must be .obj or .glb, got {path.name}")


def read_atlas(path):
    """Read an atlas written by :func:`write_atlas`: ``(V, F, UV, FUV)``."""
    path = Path(path)
    if path.suffix.lower() == ".obj":
        V, F, UV, FUV = read_obj(path)
        if FUV is None:
            raise NeuralUVError(f"{path.name} has no per-corner texture coordinates")
        return V, F, UV, FUV
    import trimesh

    sc = trimesh.load(str(path), process=False)
    geoms = list(sc.geometry.values()) if isinstance(sc, trimesh.Scene) else [sc]
    Vs, Fs, Us, off = [], [], [], 0
    for g in geoms:
        uv = getattr(g.visual, "uv", None)
        if uv is None:
            raise NeuralUVError(f"{path.name} has no TEXCOORD_0")
        Vs.append(np.asarray(g.vertices, float))
        Fs.append(np.asarray(g.faces, np.int64) + off)
        Us.append(np.asarray(uv, float))
        off += len(g.vertices)
    F = np.vstack(Fs)
    return np.vstack(Vs), F, np.vstack(Us), F.copy()


# --------------------------------------------------------------------------- figures
def _route_face_colors(face_route):
    return np.array([ROUTE_COLORS["neural"] if r else ROUTE_COLORS["fallback"] for r in face_route])


def plot_routes(res, *, zoom=True, view=None):
    """Figure 8: the surface and the packed atlas coloured by route.

    Parameters
    ----------
    res : AtlasResult
    zoom : bool
        Add a third panel zoomed on the fallback islands (when there are any).

    Returns
    -------
    fig : matplotlib Figure
    """
    import matplotlib.pyplot as plt

    from .plot import plot_uv_layout, render_surface

    fb = res.face_route == 0
    ncol = 3 if (zoom and fb.any()) else 2
    fig, axes = plt.subplots(1, ncol, figsize=(4.2 * ncol, 4.2))
    from matplotlib.colors import ListedColormap

    cmap = ListedColormap([ROUTE_COLORS["fallback"][:3], ROUTE_COLORS["neural"][:3]])
    img = render_surface(res.V, res.F, scalars=res.face_route.astype(float), cmap=cmap, clim=(0, 1), view=view)
    axes[0].imshow(img)
    axes[0].axis("off")
    t = res.totals()
    axes[0].set_title(f"(a) routes: neural {100 * t['neural_share']:.1f}% / fallback {100 * t['fallback_share']:.1f}% of faces", fontsize=9)
    fc = _route_face_colors(res.face_route)
    plot_uv_layout(res.V, res.F, res.UV, ax=axes[1], FUV=res.FUV, face_colors=fc,
                   title=f"(b) atlas: {t['islands']} islands, {t['flips']} flips")
    if ncol == 3:
        plot_uv_layout(res.V, res.F, res.UV, ax=axes[2], FUV=res.FUV, face_colors=fc, show_box=False,
                       title="(c) zoom on fallback islands")
        uvf = res.UV[res.FUV[fb]].reshape(-1, 2)
        lo, hi = uvf.min(0), uvf.max(0)
        c, h = 0.5 * (lo + hi), 0.5 * max((hi - lo).max(), 0.02)
        axes[2].set_xlim(c[0] - h, c[0] + h)
        axes[2].set_ylim(c[1] - h, c[1] + h)
    fig.tight_layout()
    return fig


def save_renders(res, outdir, stem="atlas"):
    """Write the checkerboard transfer and the route figure as PNGs; returns the paths."""
    import matplotlib.pyplot as plt

    from .plot import plot_checkerboard_transfer

    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in (("checkerboard", lambda: plot_checkerboard_transfer(res.V, res.F, res.UV, res.FUV)),
                       ("routes", lambda: plot_routes(res))):
        fig = make()
        p = outdir / f"{stem}_{name}.png"
        with atomic_write(p, "wb") as fh:
            fig.savefig(fh, format="png", dpi=110)
        plt.close(fig)
        paths.append(p)
    return paths


def atlas_file(inp, out, *, report=None, renders=None, **kw):
    """Load a mesh, build its atlas, write it, read it back and validate the file.

    Parameters
    ----------
    inp : path of the input mesh.
    out : path of the output ``.obj`` or ``.glb``.
    report : path, optional
        JSON report (with the read-back validation under ``"readback"``).
    renders : folder, optional
        Checkerboard transfer and route figure PNGs.
    **kw
        Passed to :func:`build_atlas`.

    Returns
    -------
    res : AtlasResult
    rep : dict, the report (``rep["readback"]["valid"]`` is the verdict on the file).
    """
    import json

    from .io import load_mesh

    out = Path(out)
    if out.suffix.lower() not in (".obj", ".glb"):
        raise NeuralUVError(f"output must be .obj or .glb, got {out.name}")
    V, F = load_mesh(inp)
    res = build_atlas(V, F, **kw)
    write_atlas(out, res.V, res.F, res.UV, res.FUV)
    back = validate_atlas(*read_atlas(out), padding=res.info["padding"], resolution=res.info["resolution"])
    rep = res.report()
    from .unwrap import jsonable

    rep["input"] = str(inp)
    rep["output"] = str(out)
    rep["readback"] = jsonable(back)
    rep["ok"] = bool(back["valid"] and back["covered_faces"] == len(res.F))
    if renders:
        rep["renders"] = [str(p) for p in save_renders(res, renders, stem=out.stem)]
    if report:
        with atomic_write(report) as fh:
            json.dump(rep, fh, indent=2)
    return res, rep
