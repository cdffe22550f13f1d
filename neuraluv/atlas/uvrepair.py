"""UV repair: fix only the flipped charts of an existing layout.

This is the paper's "supplied-chart validity" use case (Sec. 1, Sec. 6): an
existing UV layout (LSCM, Blender Smart UV, a generator's UVs) is valid almost
everywhere, and a few charts contain flipped triangles. The charts are read off
the layout's seams — faces joined by an edge whose two corners carry the same
``vt`` indices on both sides belong to one chart — and

* every valid chart passes through **unchanged** (same ``vt`` indices, same
  numbers, same placement: bit-identical);
* every chart with a flipped face is re-solved by the neural solver on its
  own chart mesh (one vertex per ``vt`` index, so its boundary topology is
  kept), then scaled uniformly (no mirroring) into the chart's original UV
  bounding box;
* only if a repaired chart then overlaps another island is it shrunk inside
  its box, and only if that fails is the whole layout repacked.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from neuraluv import __version__
from neuraluv.atlas.candidates import chart_candidates
from neuraluv.atlas.routing import route_charts
from neuraluv.atlas.validate import triangles_union, uv_islands, validate_atlas
from neuraluv.io import check_mesh_arrays, jsonable
from neuraluv.meshfix import normalize_unit_box
from neuraluv.packing import rotate_to_min_box, shelf_pack
from neuraluv.solver.config import get_config
from neuraluv.solver.device import torch_threads
from neuraluv.topology import faces_sharing, submesh
from neuraluv.errors import NeuralUVError
from neuraluv.metrics import face_dets

__all__ = ["uv_charts", "chart_mesh", "UVRepairResult", "repair_uvs"]


def uv_charts(F, FUV):
    """Label faces by UV chart: faces sharing an edge with the same ``vt`` on both ends.

    Parameters
    ----------
    F : (m,3) int array
    FUV : (m,3) int array

    Returns
    -------
    n : int
    labels : (m,) int array

    Examples
    --------
    >>> F = np.array([[0, 1, 2], [2, 1, 3]])
    >>> uv_charts(F, np.array([[0, 1, 2], [2, 1, 3]]))[0], uv_charts(F, np.array([[0, 1, 2], [5, 4, 3]]))[0]
    (1, 2)
    """
    F = np.asarray(F, np.int64)
    FUV = np.asarray(FUV, np.int64)
    a, b = [0, 1, 2], [1, 2, 0]
    va, vb = F[:, a].reshape(-1), F[:, b].reshape(-1)
    ta, tb = FUV[:, a].reshape(-1), FUV[:, b].reshape(-1)
    swap = va > vb
    key = np.stack([np.where(swap, vb, va), np.where(swap, va, vb), np.where(swap, tb, ta), np.where(swap, ta, tb)], 1)
    return faces_sharing(key, np.repeat(np.arange(len(F)), 3), len(F))


def chart_mesh(V, F, FUV, fidx):
    """The chart mesh of faces ``fidx``: one vertex per ``vt`` index.

    Returns
    -------
    ti : (k,) int array, the chart's ``vt`` indices (its vertices, in order).
    Vc : (k,3) float array, position of each (first corner wins).
    Fc : (len(fidx),3) int array, local faces.
    """
    T = FUV[fidx]
    ti = np.unique(T)
    Fc = np.searchsorted(ti, T)
    Vc = np.zeros((len(ti), 3))
    Vc[Fc.reshape(-1)[::-1]] = V[F[fidx].reshape(-1)[::-1]]
    return ti, Vc, Fc


def _fit_into_box(islands_uv, islands_f, lo, hi):
    """Place repaired island(s) into the box [lo, hi]: rotate to fit, uniform scale, centre."""
    if len(islands_uv) == 1:
        u = rotate_to_min_box(islands_uv[0])
        boxes = [u]
    else:
        boxes = shelf_pack([rotate_to_min_box(u) for u in islands_uv], islands_f, padding=0, resolution=None).uvs
    allp = np.vstack(boxes)
    ext = allp.max(0) - allp.min(0)
    W = hi - lo
    if (W[0] >= W[1]) != (ext[0] >= ext[1]):  # turn a quarter to match the box's aspect
        R = np.array([[0.0, -1.0], [1.0, 0.0]])
        boxes = [b @ R for b in boxes]
        allp = np.vstack(boxes)
        ext = allp.max(0) - allp.min(0)
    s = float(np.min(W / np.maximum(ext, 1e-300)))
    c_new = 0.5 * (allp.max(0) + allp.min(0))
    c_box = 0.5 * (lo + hi)
    return [(b - c_new) * s + c_box for b in boxes], s


@dataclass
class UVRepairResult:
    """Output of :func:`repair_uvs`.

    Attributes
    ----------
    V, F : the input mesh (unchanged).
    UV : (p',2) float array; the input rows are kept (rows of repaired charts
        may be overwritten in place or new rows appended).
    FUV : (m,3) int array; rows of untouched charts are identical to the input.
    charts : list of dict, one per input chart: faces, flips before/after, action.
    repacked : bool, whether the whole layout had to be repacked.
    before, after : dict from :func:`validate_atlas` (no padding requirement).
    """

    V: np.ndarray
    F: np.ndarray
    UV: np.ndarray
    FUV: np.ndarray
    charts: list
    repacked: bool
    before: dict
    after: dict
    time: float = 0.0
    info: dict = field(default_factory=dict)

    def report(self):
        changed = [c for c in self.charts if c["action"] != "kept"]
        return jsonable({
            "neuraluv": __version__,
            "charts": len(self.charts),
            "changed_charts": len(changed),
            "kept_charts": len(self.charts) - len(changed),
            "flips_before": self.before["flips"], "flips_after": self.after["flips"],
            "repacked": self.repacked,
            "before": self.before, "after": self.after,
            "changed": changed,
            "info": self.info, "time": self.time,
        })


def repair_uvs(V, F, UV, FUV=None, preset="fast", *, seed=0, device="auto", threads=None, padding=2.0,
               resolution=1024, **overrides):
    """Re-solve only the UV charts that contain flipped faces.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional (default ``F``)
    preset : str or SolverConfig
    seed : int
    device : str
    threads : int, optional
        torch CPU threads during the solves.
    padding, resolution : float, int
        Used only if the layout has to be repacked.
    **overrides
        SolverConfig overrides.

    Returns
    -------
    UVRepairResult

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> from neuraluv.tutte import tutte
    >>> V, F = disk(n_rings=4); UV = tutte(V, F) * 0.2 + 0.5
    >>> UV2 = UV.copy(); UV2[0] += [0.3, 0.0]            # fold the centre vertex over
    >>> res = repair_uvs(V, F, UV2, preset="test")
    >>> res.before["flips"] > 0, res.after["flips"]
    (True, 0)
    """
    import shapely

    t0 = time.perf_counter()
    V, F = check_mesh_arrays(V, F)
    UV = np.asarray(UV, float)
    FUV = F.copy() if FUV is None else np.asarray(FUV, np.int64)
    if FUV.shape != F.shape or (len(FUV) and (FUV.min() < 0 or FUV.max() >= len(UV))):
        raise NeuralUVError("texture indices (FUV) do not match the faces or point outside the vt list")
    Vn = normalize_unit_box(V)[0]
    before = validate_atlas(Vn, F, UV, FUV, check_padding=False)
    det = face_dets(Vn, F, UV, FUV)
    bad_face = ~(det > 0)
    n, lab = uv_charts(F, FUV)
    cfg = get_config(preset, **overrides)
    # vt indices used by more than one chart cannot be overwritten in place
    owner = -np.ones(len(UV), np.int64)
    shared = np.zeros(len(UV), bool)
    for c in range(n):
        t = np.unique(FUV[lab == c])
        shared[t[owner[t] >= 0]] = True
        owner[t] = c
    UVo = UV.copy()
    FUVo = FUV.copy()
    new_rows = []
    charts, repaired = [], []
    with torch_threads(threads):
        for c in range(n):
            fidx = np.flatnonzero(lab == c)
            nbad = int(bad_face[fidx].sum())
            entry = {"chart": c, "faces": int(len(fidx)), "flips_before": nbad, "action": "kept"}
            if nbad == 0:
                entry["flips_after"] = 0
                charts.append(entry)
                continue
            tc = time.perf_counter()
            ti, Vc, Fc = chart_mesh(Vn, F, FUV, fidx)
            cands = chart_candidates(Vc, Fc)
            islands, routes, reasons = [], [], []
            for ch in route_charts(Vc, Fc, cands, cfg, seed=seed, device=device):
                islands += ch.islands
                routes.append(ch.route)
                if ch.reason:
                    reasons.append(ch.reason)
            fin = UV[ti][np.all(np.isfinite(UV[ti]), axis=1)]
            if len(fin) >= 2 and np.all(np.ptp(fin, axis=0) > 0):
                lo, hi = fin.min(0), fin.max(0)
            else:
                lo, hi = np.array([0.0, 0.0]), np.array([1.0, 1.0])
                entry["note"] = "original bounding box unusable; placed in the unit square before repacking"
            placed, s = _fit_into_box([isl[3] for isl in islands], [isl[2] for isl in islands], lo, hi)
            same_topology = len(islands) == 1 and len(cands) == 1
            if same_topology and not shared[ti].any():
                # one island on the chart's own vt indices: overwrite in place
                UVo[ti[islands[0][1]]] = placed[0]
                rows = [ti]
            else:
                rows = []
                for isl, p in zip(islands, placed):
                    fl, vl, Fl, _ = isl  # fl: chart-local faces, vl: chart-local vertices
                    base = len(UV) + sum(len(r) for r in new_rows)
                    new_rows.append(p)
                    FUVo[fidx[fl]] = Fl + base
                    rows.append(base + np.arange(len(p)))
            entry.update({
                "action": "resolved" if same_topology else f"split into {len(islands)} islands",
                "routes": routes, "reason": "; ".join(dict.fromkeys(reasons)) if reasons else "",
                "scale_in_box": s, "box": [lo.tolist(), hi.tolist()], "time": time.perf_counter() - tc,
            })
            charts.append(entry)
            repaired.append((c, fidx, rows, lo, hi))
    if new_rows:
        UVo = np.vstack([UVo] + new_rows)
    # overlap with other islands: shrink inside the box, else repack everything
    repacked = False
    if repaired:
        def polys_of(fsel):
            return triangles_union(UVo, FUVo[fsel])[0]

        others = [polys_of(np.flatnonzero(lab == c)) for c in range(n)]
        tree = shapely.STRtree(np.array(others, dtype=object))
        for c, fidx, rows, lo, hi in repaired:
            ctr = 0.5 * (lo + hi)
            rr = np.unique(FUVo[fidx])
            orig = UVo[rr].copy()
            ok = False
            for k in range(12):
                f = 0.8**k
                UVo[rr] = (orig - ctr) * f + ctr
                P = polys_of(fidx)
                hits = [j for j in tree.query(P, predicate="intersects") if j != c and P.intersection(others[j]).area > 0]
                if not hits:
                    ok = True
                    if k:
                        charts[c]["shrunk"] = f
                    break
            others[c] = polys_of(fidx)
            if not ok:
                UVo[rr] = orig
                repacked = True
        if repacked:
            nl, isl_lab = uv_islands(FUVo)
            uvs, fls, parts = [], [], []
            for i in range(nl):
                fi = np.flatnonzero(isl_lab == i)
                vi, Fl = submesh(FUVo, fi)
                uvs.append(rotate_to_min_box(UVo[vi]))
                fls.append(Fl)
                parts.append((fi, Fl))
            pk = shelf_pack(uvs, fls, padding=padding, resolution=resolution)
            rows = [pk.uvs[i] for i in range(nl)]
            off = np.cumsum([0] + [len(r) for r in rows])
            for (fi, Fl), o in zip(parts, off[:-1]):
                FUVo[fi] = Fl + o
            UVo = np.vstack(rows)
    after = validate_atlas(Vn, F, UVo, FUVo, check_padding=False)
    det2 = face_dets(Vn, F, UVo, FUVo)
    for e in charts:
        e["flips_after"] = int((~(det2[lab == e["chart"]] > 0)).sum())
    return UVRepairResult(V=V, F=F, UV=UVo, FUV=FUVo, charts=charts, repacked=repacked, before=before, after=after,
                          time=time.perf_counter() - t0,
                          info={"preset": preset if isinstance(preset, str) else "custom", "iterations": cfg.iterations})
