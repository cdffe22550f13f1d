"""Atlas steps 3–5 in one call: :func:`build_atlas` (repair → candidates → routing → packing → validation).

The routed-face split is the paper's Table 7 (tab:amara_coverage_validity) quantity (52.1% neural /
47.9% fallback on Amara); :class:`AtlasResult` carries it with the UVs.
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass, replace

import numpy as np

from neuraluv import __version__
from neuraluv.atlas.candidates import chart_candidates, congruent_components, merge_small_charts
from neuraluv.atlas.prepare import prepare_mesh
from neuraluv.atlas.routing import ROUTES, START_SLIM, route_charts
from neuraluv.errors import NeuralUVError
from neuraluv.io import check_mesh_arrays, jsonable
from neuraluv.layout.facts import island_densities, layout_facts
from neuraluv.layout.pack import PACK_TRIALS, PACKERS, SPLIT_SHARE, shelf_pack, tight_pack, xatlas_pack
from neuraluv.layout.precision import float32_uvs
from neuraluv.layout.rigid import rigid_fit, rotate_to_min_box, upright
from neuraluv.layout.validate import validate_facts
from neuraluv.meshfix import normalize_unit_box
from neuraluv.solver.config import get_config
from neuraluv.solver.device import auto_threads, resolve_device, torch_threads
from neuraluv.topology import topology_scan

__all__ = ["AtlasResult", "PACKERS", "build_atlas", "repack", "stack_groups"]


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
    face_route : (m,) int array, the route of each face: 1 neural, 2 exact (unfold, isometric start), 0 marked fallback
        (:data:`~neuraluv.atlas.routing.ROUTES`).
    validation : dict from :func:`~neuraluv.layout.validate_facts` (in memory).
    info : dict, input counts, repair, packing, timings.
    source : (n,) int array, the input vertex of each vertex of ``V``
        (:func:`~neuraluv.atlas.prepare.input_layout` carries the layout back to the input's faces).
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
    source: np.ndarray = None

    @property
    def valid(self):
        return bool(self.validation.get("valid", False))

    def totals(self):
        """Table 7 (tab:amara_coverage_validity) quantities: coverage, routed face shares, flips, overlaps."""
        m = len(self.F)
        nf = int((self.face_route == ROUTES["neural"]).sum())
        ne = int((self.face_route == ROUTES["exact"]).sum())
        nb = m - nf - ne
        charts = self.charts
        reasons = {}
        for c in charts:
            if c.route == "fallback":
                key = fallback_cause(c.reason)
                reasons[key] = reasons.get(key, 0) + len(c.faces)
        v = self.validation
        return {
            "input_faces": self.info["input_faces"],
            "repaired_faces": m,
            "covered_faces": int(v.get("covered_faces", 0)),
            "coverage": v.get("covered_faces", 0) / m if m else 0.0,
            "neural_faces": nf,
            "exact_faces": ne,
            "fallback_faces": nb,
            "neural_share": nf / m if m else 0.0,
            "exact_share": ne / m if m else 0.0,
            "fallback_share": nb / m if m else 0.0,
            "charts": len(charts),
            "neural_charts": sum(c.route == "neural" for c in charts),
            "exact_charts": sum(c.route == "exact" for c in charts),
            "fallback_charts": sum(c.route == "fallback" for c in charts),
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
        return jsonable({
            "neuraluv": __version__,
            "info": self.info,
            "totals": self.totals(),
            "validation": self.validation,
            "charts": [c.summary(i) for i, c in enumerate(self.charts)],
        })


def fallback_cause(reason):
    """The cause a fallback chart's reason names, without its details (for counts by cause).

    Examples
    --------
    >>> fallback_cause("neural: time budget exhausted before this chart's solve; the valid start (tutte) is returned")
    "time budget exhausted before this chart's solve"
    >>> fallback_cause("exact unfold overlaps itself; neural solver error: RuntimeError: boom")
    'neural solver error'
    >>> fallback_cause("neural map overlaps itself in UV (3.2% of its area)")
    'neural map overlaps itself in UV'
    """
    last = reason.rsplit("neural: ", 1)[-1] if "neural: " in reason else reason.rsplit("; ", 1)[-1]
    return re.split(r"[;:(]", last, maxsplit=1)[0].strip() or "unspecified"


def build_atlas(V, F, preset="fast", *, resolution=1024, padding=4.0, packer="tight", seed=0, device="auto",
                max_cost=4.0, merge=True, merge_faces=8, merge_curvature=0.2, texel_density=None, orient="compact",
                stack=False, pack_trials=PACK_TRIALS, cut_islands=True, time_budget=None, threads=None, progress=False,
                min_height=1e-6, **overrides):
    """Build a validated UV atlas of a whole (possibly messy) mesh.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    preset : str or SolverConfig
        The neural solver's preset (every chart that needs it is solved with it, in batches).
    resolution : int
        Target texture resolution the padding refers to.
    padding : float
        Minimum gap between islands (and to the border) in texels.
    packer : ``"tight"`` (default: charts' rasterised shapes placed largest first at the
        largest common density that fits, :func:`~neuraluv.layout.pack.tight_pack`), ``"shelf"`` (the paper's
        area-scaled shelf packer of bounding boxes) or ``"xatlas"`` (xatlas's packer on the
        charts' bounding boxes).
    seed : int
    device : str
    max_cost : float
        xatlas charting cost for seams.
    merge : bool
        Merge small candidates into neighbours before solving
        (:func:`~neuraluv.atlas.candidates.merge_small_charts`).
    merge_faces, merge_curvature : int, float
        Its size limit and curvature budget (radians).
    texel_density : float, optional
        Texels per unit length of the input mesh, instead of the largest density that
        fits one ``resolution``² texture (``"tight"`` only). Islands that do not fit
        one texture go to further UDIM tiles (tile ``k`` at ``u + k % 10, v + k // 10``).
    orient : ``"compact"`` (each island turned to its smallest bounding box, lying wide)
        or ``"upright"`` (each island's main axis along U).
    stack : bool
        Give identical parts one shared place in the texture. Copies of a component
        (same triangulation in the same face order, moved rigidly: duplicated or
        instanced objects, :func:`~neuraluv.atlas.candidates.congruent_components`)
        are not charted or solved but take the original's charts; identical islands
        (:func:`stack_groups`) are packed once and the copies lie exactly on the first
        one. Validation counts them as ``stacked_islands``, not as overlaps.
    pack_trials : int
        Packings the ``tight`` packer tries (the raster settings of
        :data:`~neuraluv.layout.pack.RASTER_TRIALS`, then the first one with the placement
        order perturbed; :func:`~neuraluv.layout.pack.tight_pack`); the fullest is kept.
        More trials pack fuller on average; a perturbed trial that cannot beat the best
        so far costs one placement per rule.
    cut_islands : bool
        Let the ``tight`` packer cut islands that hold more than
        :data:`~neuraluv.layout.pack.SPLIT_SHARE` of the total UV area into parts
        (:func:`~neuraluv.layout.pack.granular_islands`: straight cuts, the UVs kept, so
        no flip or overlap can appear) when that packs fuller by at least
        :data:`~neuraluv.layout.pack.SPLIT_GAIN`; the cost is seam length, reported as
        ``info["cut_islands"]`` (added islands). False keeps every island whole.
    min_height : float
        Sliver threshold of :func:`prepare_mesh` (relative to the diagonal).
    time_budget : float, optional
        Seconds after which running neural solves stop with their best valid map and
        charts not yet solved become marked fallbacks.
    threads : int or "auto", optional
        torch CPU threads during the solves (restored afterwards); ``"auto"``:
        :func:`~neuraluv.solver.device.auto_threads`. The report's ``info["threads"]`` says
        how many and why.
    progress : bool
    **overrides
        SolverConfig overrides.

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
    >>> res = build_atlas(*sphere(1), "test", resolution=256, padding=2, device="cpu")
    >>> res.valid, res.totals()["coverage"], res.totals()["flips"]
    (True, 1.0, 0)
    """
    t0 = time.perf_counter()
    V, F = check_mesh_arrays(V, F)
    Vin = V
    Vn, _, unit = normalize_unit_box(V)  # once: every step below works on the unit-box mesh
    if texel_density is not None:  # no island is longer than the mesh's diagonal: refuse a hopeless density now
        span = float(np.linalg.norm(V.max(0) - V.min(0))) * float(texel_density)
        if not span >= 1.0:
            raise NeuralUVError(f"at texel density {texel_density:g} the whole mesh spans {span:.2g} texels, less "
                                f"than one: raise the density (texels per unit length of the input)")
    Vr, Fr, vmap, rinfo = prepare_mesh(Vn, F, min_height=min_height)
    if len(Fr) == 0:
        raise NeuralUVError("no usable faces: every face is degenerate (zero area or repeated corners)")
    topo = topology_scan(Vr, Fr)
    cfg = get_config(preset, **overrides)
    t_rep = time.perf_counter()
    cands = chart_candidates(Vr, Fr, max_cost=max_cost)
    n_cand = len(cands)
    if merge:
        cands = merge_small_charts(Vr, Fr, cands, max_faces=merge_faces, max_curvature=merge_curvature)
    copies = congruent_components(Vr, Fr) if stack else []
    if copies:  # copies of a component are not charted or solved: they take the original's charts
        is_copy = np.zeros(len(Fr), bool)
        for _, fc, _, _ in copies:
            is_copy[fc] = True
        cands = [c for c in cands if not is_copy[c[0]].any()]
    t_cand = time.perf_counter()
    deadline = None if time_budget is None else t0 + float(time_budget)
    threads, threads_why = (auto_threads() if threads == "auto"
                            else (threads, "as given" if threads else "torch's default"))
    with torch_threads(threads):
        charts = route_charts(Vr, Fr, cands, cfg, seed=seed, device=device, deadline=deadline, progress=progress)
    charts += _copied_charts(charts, copies, len(Fr))
    t_route = time.perf_counter()
    UV, FUV, face_chart, face_route, pinfo = _pack(charts, Vr, unit, len(Fr), packer, padding, resolution,
                                                   fixed_density=texel_density, orient=orient, stack=stack,
                                                   pack_trials=pack_trials, cut=cut_islands)
    t_pack = time.perf_counter()
    validation = validate_facts(layout_facts(Vr, Fr, UV, FUV, normalized=True), padding=padding, resolution=resolution,
                                tiles=pinfo["pages"] > 1, stacked=stack)
    info = {
        "input_vertices": int(len(Vin)), "input_faces": int(len(F)),
        "repaired_vertices": int(len(Vr)), "repaired_faces": int(len(Fr)),
        "repair": rinfo, "topology": topo.as_dict(),
        "preset": preset if isinstance(preset, str) else "custom",
        "solver": {"iterations": cfg.iterations, "retries": cfg.retries, "optimizer": cfg.optimizer, "width": cfg.width,
                   "start_slim": START_SLIM},
        "max_cost": max_cost, "time_budget": time_budget,
        "candidates": {"xatlas_and_splits": n_cand, "after_merge": len(cands), "merge": bool(merge),
                       "merge_faces": merge_faces, "merge_curvature": merge_curvature},
        **pinfo,
        "timings": {"repair": t_rep - t0, "candidates": t_cand - t_rep, "routing": t_route - t_cand,
                    "packing": t_pack - t_route, "validation": time.perf_counter() - t_pack},
        "time": time.perf_counter() - t0, "device": str(resolve_device(device)), "seed": seed,
        "threads": {"n": threads, "why": threads_why},
    }
    return AtlasResult(V=Vin[vmap], F=Fr, UV=UV, FUV=FUV, charts=charts, face_chart=face_chart,
                       face_route=face_route, validation=validation, info=info, source=vmap)


def _copied_charts(charts, copies, m):
    """The charts of every copy component: the original's charts, faces and vertices renamed."""
    chart_of = np.full(m, -1, np.int64)
    for i, c in enumerate(charts):
        chart_of[c.faces] = i
    out = []
    for rf, fc, rv, vc in copies:  # rf is sorted (faces of a component in index order)
        fmap = lambda f: fc[np.searchsorted(rf, f)]  # noqa: E731
        order = np.argsort(rv)
        vmap = lambda v: vc[order[np.searchsorted(rv, v, sorter=order)]]  # noqa: E731
        for i in np.unique(chart_of[rf][chart_of[rf] >= 0]):
            c = charts[i]
            out.append(replace(c, faces=fmap(c.faces), reason=(c.reason + "; " if c.reason else "") + f"copy of chart {i}",
                               islands=[(fmap(f), vmap(v), Fl, uv) for f, v, Fl, uv in c.islands], time=0.0))
    return out


def stack_groups(V, islands, rtol=1e-4):
    """Groups of identical islands: same local triangulation and 3D vertices congruent by a proper rigid motion.

    Parameters
    ----------
    V : (n,3) float array (any uniform scale: the test is relative)
    islands : list of ``(faces, vertex_ids, local_faces, uv)`` tuples (as in ``AtlasChart.islands``)
    rtol : float
        Largest vertex misfit after the best rotation, relative to the island's size.

    Returns
    -------
    rep : (k,) int array, for every island the index of the island whose place it takes
        (itself when it is not a copy).

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [5, 0, 0], [5, 1, 0], [4, 0, 0]])
    >>> f = np.array([[0, 1, 2]])
    >>> stack_groups(V, [(None, np.array([0, 1, 2]), f, None), (None, np.array([3, 4, 5]), f, None)]).tolist()
    [0, 0]
    """
    V = np.asarray(V, float)
    rep = np.arange(len(islands))
    keys = {}
    for i, (_, vi, Fl, _) in enumerate(islands):
        keys.setdefault((len(vi), len(Fl), np.asarray(Fl).tobytes()), []).append(i)
    for group in keys.values():
        for a_pos, i in enumerate(group):
            if rep[i] != i:
                continue
            A = V[islands[i][1]]
            A = A - A.mean(0)
            size = float(np.sqrt((A ** 2).sum(1).max())) or 1.0
            for j in group[a_pos + 1:]:
                if rep[j] != j:
                    continue
                B = V[islands[j][1]]
                B = B - B.mean(0)
                R, _, t = rigid_fit(A, B)
                if np.abs(A @ R + t - B).max() <= rtol * size:
                    rep[j] = i
    return rep


def _pack(charts, Vn, unit, m, packer, padding, resolution, *, fixed_density=None, orient="compact", stack=False,
          pack_trials=PACK_TRIALS, cut=True):
    """Pack the charts' islands at one texel density and assemble per-corner UVs for ``m`` faces.

    Every island is first scaled so its UV area equals its 3D area on the unit-box mesh
    ``Vn`` (one texel density everywhere: the checkerboard has one cell size), then turned
    (``orient``) and packed. ``unit`` is the input's length per ``Vn`` length, for
    ``fixed_density`` (``build_atlas(texel_density=...)``, texels per input unit). With
    ``stack``, copies of an island (:func:`stack_groups`) are not packed: they take their
    original's packed UVs, vertex for vertex. With ``cut`` (not with ``stack``), the tight packer may pack large islands
    in parts (``tight_pack(split=SPLIT_SHARE)``).

    Returns
    -------
    UV, FUV, face_chart, face_route, info (the packing's part of ``AtlasResult.info``)
    """
    if orient not in ("compact", "upright"):
        raise NeuralUVError(f"unknown orientation {orient!r}: use 'compact' or 'upright'")
    if packer not in PACKERS:
        raise NeuralUVError(f"unknown packer {packer!r}: use one of {', '.join(PACKERS)}")
    if fixed_density is not None and packer != "tight":
        raise NeuralUVError("--texel-density needs the 'tight' packer")
    islands = [isl for c in charts for isl in c.islands]
    rep = stack_groups(Vn, islands) if stack else np.arange(len(islands))
    own = np.flatnonzero(rep == np.arange(len(islands)))  # the islands packed (copies take their original's place)
    fl = [islands[i][2] for i in own]
    xyz = [Vn[islands[i][1]] for i in own]
    uvs = []
    for i, d, x in zip(own, island_densities(xyz, fl, [islands[i][3] for i in own]), xyz):
        uv = islands[i][3]
        u = uv / d if np.isfinite(d) and d > 0 else uv
        uvs.append(upright(u, x) if orient == "upright" else rotate_to_min_box(u))
    if packer == "tight":
        try:
            packed = tight_pack(uvs, fl, padding=padding, resolution=resolution,
                                texel_density=None if fixed_density is None else fixed_density * unit,
                                trials=pack_trials, rotate=orient != "upright",
                                split=SPLIT_SHARE if cut and not stack else None, xyz=xyz)
        except ValueError as exc:
            if fixed_density is not None:
                raise NeuralUVError(str(exc)) from None
            packed = shelf_pack(uvs, fl, padding=padding, resolution=resolution)  # the shelf packer always fits
            packed.packer = "shelf (tight failed: " + str(exc) + ")"
    elif packer == "shelf":
        packed = shelf_pack(uvs, fl, padding=padding, resolution=resolution)
    else:
        packed = xatlas_pack(uvs, fl, padding=padding, resolution=resolution)
    where = np.searchsorted(own, rep)  # island -> its packed original
    pages = packed.pages if packed.n_pages > 1 else None
    # (global faces, their corners in the packed island's UVs, packed island) per placed island
    placed = [(isl[0], isl[2], k) for isl, k in zip(islands, where)]
    if packed.pieces:  # islands cut by the packer (never with stack: every island is its own original)
        placed = [(islands[own[i]][0][idx], np.searchsorted(vi, islands[own[i]][2][idx]), k)
                  for k, (i, idx, vi) in enumerate(packed.pieces)]
    FUV = -np.ones((m, 3), np.int64)
    UVs, off = [], 0
    for fidx, Fl, k in placed:
        FUV[fidx] = Fl + off
        uv = np.clip(packed.uvs[k], 0.0, 1.0)
        if pages is not None:  # UDIM tile k: u + k % 10, v + k // 10
            uv = uv + [pages[k] % 10, pages[k] // 10]
        UVs.append(uv)
        off += len(uv)
    # float32-representable values, so OBJ and GLB (float32 TEXCOORD_0) carry the
    # same layout and the in-memory validation speaks for both files
    UV = float32_uvs(np.vstack(UVs), FUV[(FUV >= 0).all(1)])  # needles nudged a few ulps, never flipped
    face_chart = np.zeros(m, np.int64)
    face_route = np.zeros(m, np.int8)
    for i, c in enumerate(charts):
        face_chart[c.faces] = i
        face_route[c.faces] = ROUTES[c.route]
    info = {"packer": packed.packer, "resolution": resolution, "padding": padding, "orient": orient,
            "stack": bool(stack), "stacked_islands": int(len(islands) - len(own)), "cut": bool(cut),
            "cut_islands": len(packed.pieces) - len(own) if packed.pieces else 0,
            "pack_trials": int(pack_trials) if packer == "tight" and packed.packer == "tight" else None,
            "texel_density": fixed_density, "pages": packed.n_pages, "utilisation": packed.utilisation,
            "pack_scale": packed.scale}
    return UV, FUV, face_chart, face_route, info


def repack(res, packer="shelf", *, padding=None, resolution=None, pack_trials=None, cut_islands=None):
    """Re-pack an atlas's charts with another packer or padding, without re-solving.

    Parameters
    ----------
    res : AtlasResult
    packer : one of :data:`PACKERS`
    padding, resolution, pack_trials, cut_islands : optional, default the atlas's own.

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
    padding = res.info["padding"] if padding is None else padding
    resolution = res.info["resolution"] if resolution is None else resolution
    orient = res.info.get("orient", "compact")
    stack = res.info.get("stack", False)
    trials = (res.info.get("pack_trials") or PACK_TRIALS) if pack_trials is None else pack_trials
    Vn, _, unit = normalize_unit_box(res.V)
    UV, FUV, fc, fr, pinfo = _pack(res.charts, Vn, unit, len(res.F), packer, padding, resolution, orient=orient,
                                   stack=stack, pack_trials=trials,
                                   cut=res.info.get("cut", True) if cut_islands is None else cut_islands)
    validation = validate_facts(layout_facts(Vn, res.F, UV, FUV, normalized=True), padding=padding,
                                resolution=resolution, tiles=pinfo["pages"] > 1, stacked=stack)
    return replace(res, UV=UV, FUV=FUV, face_chart=fc, face_route=fr, info=dict(res.info, **pinfo),
                   validation=validation)
