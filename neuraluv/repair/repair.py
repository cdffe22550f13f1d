"""Repair a supplied UV layout with minimal change (``neuraluv repair``).

:func:`repair_layout` diagnoses the layout (:func:`~neuraluv.repair.diagnose.diagnose_layout`)
and fixes each problem with the smallest change that works, in this order:

1. a **mirrored island** is reflected back about its centre (not re-solved);
2. each **cluster of folded faces** is repaired locally
   (:func:`~neuraluv.repair.local.repair_cluster`: untangle + polish in a region grown
   ring by ring, then the neural solver with the ring pinned); only if that fails is
   the whole island untangled, and only if that fails is it re-solved as a chart by
   the atlas router (neural, or a marked fallback) and put back where it was;
3. an island that **overlaps itself** is untangled around the overlap, else re-solved; under a bake's
   rules, where it overlaps or mirrors itself because several surfaces share its rows (stacked copies,
   a mirror modifier's halves), each surface but the largest first gets copies of those rows, an
   island of its own for steps 1 and 5;
4. faces with **missing or non-finite UVs** get new charts, solved like ``atlas``
   does, at the layout's median texel density; so, under a bake's rules, do the
   faces of an island with no UV area (a palette collapse);
5. islands that **overlap each other**, lie **outside [0,1]²**, or are new are
   moved into free space (:class:`~neuraluv.layout.place.FreeSpace`): only the
   islands involved, translated and if needed turned by quarter turns, never
   mirrored, scaled down only when they fit nowhere (reported); the whole layout
   is repacked only when even that fails.

Every other ``vt`` row stays bit-identical; the result records, per island,
what changed (faces, rows, the largest UV displacement in texels) and the
before/after distortion. A layout with nothing wrong is returned unchanged.

Size: the escalation of :func:`repair_layout` (reflect, local, whole island, new charts, separation) and its report are read top to bottom as one procedure; the steps themselves live in :mod:`~neuraluv.repair.local`, :mod:`~neuraluv.repair.bake` (steps 1-3 under a bake's rules), :mod:`~neuraluv.repair.untangle`, :mod:`~neuraluv.repair.shells` (the texture purpose; its twin layers in :mod:`~neuraluv.repair.twins`), :mod:`~neuraluv.repair.separate` (step 5) and :mod:`neuraluv.layout` (facts, purpose, overlaps, placement, packing).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from neuraluv import __version__
from neuraluv.atlas.candidates import chart_candidates
from neuraluv.atlas.routing import fallback_islands, route_charts
from neuraluv.errors import NeuralUVError
from neuraluv.io import jsonable
from neuraluv.layout.facts import coincident_rows, defect_area, layout_facts, no_3d_area
from neuraluv.layout.purpose import check_purpose, layout_intent
from neuraluv.plot import plot_repair
from neuraluv.repair.bake import collapsed_faces, own_rows_per_surface, repair_islands
from neuraluv.repair.diagnose import UVDiagnosis, diagnose_layout
from neuraluv.repair.projected import onto_projections
from neuraluv.repair.region import island_esds
from neuraluv.repair.separate import SHRINK_SCALES, input_islands, repack_all, separate
from neuraluv.repair.shells import repair_shells
from neuraluv.repair.untangle import budget_spent
from neuraluv.solver.config import get_config
from neuraluv.solver.device import torch_threads
from neuraluv.topology import submesh

__all__ = ["RepairResult", "repair_layout", "SHRINK_SCALES"]


@dataclass
class RepairResult:
    """Output of :func:`repair_layout`.

    Attributes
    ----------
    V, F : the mesh as given.
    UV : (p',2) float array — the input's rows first (rows not listed in ``changed_rows`` are
        bit-identical), then any new rows.
    FUV : (m,3) int array — rows of faces that did not change are identical to the input.
    changed_rows : (p',) bool array — rows whose value changed or that are new.
    changed_faces : (m,) bool array — faces with a corner whose UV or ``vt`` index changed.
    islands : list of dict — per input island: actions, faces and rows changed, largest
        displacement in texels, placement, E_SD before and after.
    new_charts : list of dict — charts made for faces without usable UVs.
    before, after : UVDiagnosis of the input and of the result.
    repacked : bool — the whole layout had to be repacked.
    time : float — seconds.
    UV_in, FUV_in : the layout as given (for the diff and the figure).
    """

    V: np.ndarray
    F: np.ndarray
    UV: np.ndarray
    FUV: np.ndarray
    changed_rows: np.ndarray
    changed_faces: np.ndarray
    islands: list
    new_charts: list
    before: UVDiagnosis
    after: UVDiagnosis
    repacked: bool = False
    time: float = 0.0
    info: dict = field(default_factory=dict)
    UV_in: np.ndarray | None = None
    FUV_in: np.ndarray | None = None

    @property
    def unchanged(self):
        return not self.changed_rows.any() and not self.changed_faces.any()

    def summary(self):
        """One line for the command line."""
        a, b = self.before.validation, self.after.validation
        if self.unchanged and self.before.ok:
            return (f"nothing to repair under the {self.before.purpose} purpose: the layout is valid and was left "
                    "byte-identical")
        undone = sum(1 for i in self.islands for a in i["actions"] if a.get("step") == "left undone")
        if self.unchanged:
            return (f"could not repair under the {self.before.purpose} purpose: {len(self.before.problems)} problem(s) "
                    "left as they were ("
                    + ("the time budget ran out: a larger --time-budget, 0 for none" if undone else
                       "see the report's actions") + "); the layout was left byte-identical")
        ch = [i for i in self.islands if any(a.get("step") != "left undone" for a in i["actions"])]
        bit = 1.0 - self.changed_faces.mean() if len(self.changed_faces) else 1.0
        head = (f"{len(ch)} of {len(self.islands)} islands changed"
                + (f", {len(self.new_charts)} new charts" if self.new_charts else "")
                + (f", {undone} island(s) / shell(s) left as they were: the time budget ran out (--time-budget)"
                   if undone else "")
                + f"; faces bit-identical {100 * bit:.1f}%; ")
        if b.get("purpose") == "texture":
            lost = [v["faces"] - v["covered_faces"] + v["non_finite_faces"] for v in (a, b)]
            return (head + f"folded faces {a['folded_faces']} -> {b['folded_faces']}, UV-degenerate "
                    f"{a['degenerate_faces']} -> {b['degenerate_faces']}, faces without usable UVs {lost[0]} -> "
                    f"{lost[1]} (texture purpose: mirrored, stacked, tiled and palette shells kept); {self.time:.1f}s")
        lost = [v["faces"] - v["covered_faces"] + v["non_finite_faces"] for v in (a, b)]
        return (head + f"flips {a['flips'] - lost[0]} -> {b['flips'] - lost[1]}"
                + (f" (and faces without usable UVs {lost[0]} -> {lost[1]})" if any(lost) else "") + ", "
                f"overlapping island pairs {a['overlapping_pairs']} -> {b['overlapping_pairs']}, "
                f"self-overlapping islands {a['self_overlapping_islands']} -> {b['self_overlapping_islands']}, "
                f"in [0,1]²: {'yes' if b['uv_in_unit_square'] else 'no'}"
                + (f"; repacked ({self._repack_why()})" if self.repacked else "") + f"; {self.time:.1f}s")

    def _repack_why(self):
        whys = [a["why"] for i in self.islands for a in i["actions"] if a.get("step") == "repacked" and "why" in a]
        return whys[0] if whys else "a layout of its own"

    def report(self):
        """JSON-ready dict: before/after diagnosis, per-island diff, totals."""
        return jsonable({
            "neuraluv": __version__, "unchanged": self.unchanged, "summary": self.summary(),
            "faces": int(len(self.F)), "faces_changed": int(self.changed_faces.sum()),
            "faces_bit_identical": float(1.0 - self.changed_faces.mean()) if len(self.F) else 1.0,
            "rows_changed": int(self.changed_rows[: self.info.get("rows_in", len(self.changed_rows))].sum()),
            "rows_added": int(len(self.UV) - self.info.get("rows_in", len(self.UV))),
            "repacked": self.repacked, "islands": self.islands, "new_charts": self.new_charts,
            "before": self.before.as_dict(), "after": self.after.as_dict(), "time": self.time, "info": self.info,
        })

    def figure(self, *, title=None):
        """Before / after layouts, changed faces highlighted (matplotlib figure)."""
        return plot_repair(self, title=title)


def repair_layout(V, F, UV, FUV=None, preset="fast", *, seed=0, device="auto", threads=None, resolution=1024,
                  padding=2.0, time_budget=None, neural=True, purpose="bake", repack=False, min_defect=0.0,
                  **overrides):
    """Repair a supplied UV layout, changing only what is broken.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional
        Per-corner ``vt`` indices (default ``F``); -1 where a face has none.
    preset : str or SolverConfig
        Neural solver preset for the steps that use it.
    seed : int
    device : str
    threads : int, optional
        torch CPU threads for the neural steps.
    resolution, padding : int, float
        Moved and new islands keep ``padding`` texels from every other island at ``resolution``.
    min_defect : float
        Texels (of area) at ``resolution``: overlaps smaller than this (an island with itself, or a pair of
        islands, in all) are noted and left alone (:func:`~neuraluv.repair.diagnose.diagnose_layout`); 0: exact.
    time_budget : float, optional
        Seconds for the whole repair: every long loop (untangling, polishing, neural solves, island moves)
        checks it; past it, a running solve keeps its best valid map, islands not yet repaired are left as
        they were (``"left undone"`` in their actions, counted in the summary) and islands not yet placed
        are repacked. Twice the opening diagnosis's time is kept back for the closing one.
    neural : bool
        Allow the neural solver (local step 2 and whole-island re-solves).
    purpose : {"bake", "lightmap", "texture"}
        What the layout is for (:mod:`~neuraluv.layout.purpose`). ``bake`` / ``lightmap``: the
        steps above, to a unique, unmirrored layout in ``[0,1]²``. ``texture``: only the folds
        and UV-degenerate faces inside each shell are repaired: in an island made by a planar
        projection, a fold's rows go back where the projection puts them
        (:func:`~neuraluv.repair.projected.onto_projections`); the rest are untangled, locally, in the shell's own
        orientation (a mirrored shell stays mirrored; rows a shell shares with another shell
        stacked on it stay where they are), and faces without usable UVs get new charts placed
        in free space; mirrored, stacked, tiled and palette shells are not touched, nothing is
        moved or repacked, and a layout with only those comes back unchanged.
    repack : bool
        After steps 1-4, pack every island afresh at the layout's median texel density (the tight
        packer, ``padding`` held) instead of moving the fewest: for a layout of its own that no
        texture reads yet, e.g. a lightmap written to a new glTF UV set. Not with ``texture``.
    **overrides
        :class:`~neuraluv.solver.config.SolverConfig` fields for the neural steps.

    Returns
    -------
    RepairResult

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> from neuraluv.tutte import tutte
    >>> V, F = disk(n_rings=8); UV = tutte(V, F) * 0.4 + 0.5
    >>> bad = UV.copy(); bad[0] += [0.1, 0.0]                  # fold the centre over its ring
    >>> res = repair_layout(V, F, bad)
    >>> res.before.validation["flips"] > 0, res.after.validation["flips"], res.islands[0]["actions"][0]["step"]
    (True, 0, 'untangle+polish')
    >>> bool(res.changed_faces.mean() < 0.2), repair_layout(V, F, UV).unchanged
    (True, True)
    """
    t0 = time.perf_counter()
    deadline = None if not time_budget else t0 + float(time_budget)
    F = np.asarray(F, np.int64)
    V = np.asarray(V, float)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3:
        raise NeuralUVError("need V (n,3) and F (m,3)")
    UV = np.asarray(UV, float).reshape(-1, 2)
    FUV = F.copy() if FUV is None else np.asarray(FUV, np.int64)
    if FUV.shape != F.shape:
        raise NeuralUVError(f"texture indices have shape {FUV.shape}, faces {F.shape}")
    cfg = get_config(preset, **overrides)
    purpose = check_purpose(purpose)
    if repack and purpose == "texture":
        raise NeuralUVError("repack=True builds a layout of its own: use it with purpose 'bake' or 'lightmap'")
    facts = layout_facts(V, F, UV, FUV, min_overlap=defect_area(min_defect, resolution))
    before = diagnose_layout(V, F, UV, FUV, resolution=resolution, padding=padding, facts=facts, purpose=purpose)
    if deadline is not None:  # the closing diagnosis (and a caller's read-back) cost what the opening one did
        deadline -= 2.0 * (time.perf_counter() - t0)
    p_in = len(UV)
    if before.ok and not (repack and any(w["kind"] == "padding" for w in before.warnings)):
        after = before
        return RepairResult(V=V, F=F, UV=UV.copy(), FUV=FUV.copy(), changed_rows=np.zeros(p_in, bool),
                            changed_faces=np.zeros(len(F), bool),
                            islands=[{**_island_base(isl), "actions": []} for isl in before.islands],
                            new_charts=[], before=before, after=after, time=time.perf_counter() - t0,
                            info={"rows_in": p_in}, UV_in=UV, FUV_in=FUV)
    Vn = facts.Vn
    UVw = facts.UV.copy()
    UVw[~np.isfinite(UVw).all(1)] = 0.0  # non-finite rows: their faces get new charts, the rows are neutralised
    # rows that are one point of the map (a glTF vertex split for its normals) move as one: the steps work on the
    # smallest row of each group, and every row of the group takes its value at the end
    canon = coincident_rows(Vn, F, facts.UV, facts.FUV, facts.label)
    FUVc = np.where(facts.FUV >= 0, canon[np.maximum(facts.FUV, 0)], -1)
    FUVw = FUVc.copy()

    def unweld(U, FU):
        """The layout as written: every row of a group takes its value; a face whose rows no step replaced keeps
        its own."""
        U = U.copy()
        U[:p_in] = U[canon]
        return U, np.where(FU == FUVc, facts.FUV, FU)
    med = facts.median_density or 1.0
    actions = {i: [] for i in range(facts.n_islands)}
    movers_pref = set()  # islands (input labels) already changed: first choice when something must move

    with torch_threads(threads):
        if purpose == "texture":  # 1.-3. folds and degenerate faces inside each shell, in its own orientation
            # a fold of an island made by a planar projection: its rows back where the projection puts them
            UV0, f0 = onto_projections(Vn, F, UVw, FUVw, facts, actions,
                                       written=lambda U: _written(Vn, F, U, FUVw, facts, unweld))
            UV1, FUV1 = repair_shells(Vn, F, UV0, FUVw, f0, actions, med, cfg, seed=seed, device=device,
                                       deadline=deadline, neural=neural)
            if not (np.array_equal(UV1, UVw) and np.array_equal(FUV1, FUVw)):  # unchanged: nothing new to read
                UV1, FUV1 = _second_pass(Vn, F, UV1, FUV1, facts, actions, med, cfg, unweld, seed=seed,
                                         device=device, deadline=deadline, neural=neural)
            UVw, FUVw = UV1, FUV1
        else:
            f1, it = facts, (layout_intent(facts) if facts.n_islands else None)  # read once for both steps
            collapsed = collapsed_faces(facts, actions, it)
            if collapsed.any():  # no texels of their own to repair: new charts (step 4), like faces without UVs
                FUVw = FUVw.copy()
                FUVw[collapsed] = -1
                f1, it = layout_facts(Vn, F, UVw, FUVw, normalized=True, min_overlap=facts.min_overlap), None
            UVw, FUVw, f1 = own_rows_per_surface(Vn, F, UVw, FUVw, f1, actions, movers_pref, it)
            acts1, pref1 = {j: [] for j in range(f1.n_islands)}, set()
            UVw, FUVw = repair_islands(Vn, F, UVw, FUVw, f1, acts1, pref1, med, cfg, seed=seed,
                                        device=device, deadline=deadline, neural=neural, keep_small=not repack)
            origin = input_islands(facts, f1)
            for j, a in acts1.items():
                if origin[j] >= 0:
                    actions[origin[j]].extend(a)
            movers_pref |= {int(origin[j]) for j in pref1 if origin[j] >= 0}
        # 4. faces without usable UVs: new charts
        new_charts = []
        lost = np.flatnonzero(facts.missing | facts.non_finite | (purpose != "texture") & (FUVw < 0).any(1))
        if len(lost):
            UVw, FUVw, new_charts = _new_charts(Vn, F, UVw, FUVw, lost, med, cfg, seed=seed, device=device,
                                                deadline=deadline, share=purpose == "texture")
    # 5. overlaps between islands, out of the square, new islands: move the fewest (or pack them all afresh)
    if repack:
        f5 = layout_facts(Vn, F, UVw, FUVw, normalized=True, min_overlap=facts.min_overlap)
        UVw, FUVw = repack_all(Vn, F, UVw, FUVw, f5, padding, resolution, tight=True)
        placements, repacked = {}, True
        for i in input_islands(facts, f5):
            if i >= 0:
                placements.setdefault(int(i), {"step": "repacked (a layout of its own)"})
    else:
        UVw, FUVw, placements, repacked = separate(Vn, F, UVw, FUVw, facts, movers_pref, resolution, padding,
                                                    only_new=purpose == "texture", deadline=deadline)
    for i, pl in placements.items():
        if i >= 0:
            actions[i].append(pl)
    UVw, FUVw = unweld(UVw, FUVw)
    after = diagnose_layout(V, F, UVw, FUVw, resolution=resolution, padding=padding,
                            facts=layout_facts(Vn, F, UVw, FUVw, normalized=True, min_overlap=facts.min_overlap),
                            purpose=purpose)
    changed_rows = np.ones(len(UVw), bool)
    changed_rows[:p_in] = ~_same_bits(UVw[:p_in], UV)
    changed_faces = (FUVw != FUV).any(1) | changed_rows[FUVw].any(1)
    islands = []
    groups = [facts.island_faces(isl["island"]) for isl in before.islands]
    dens = np.where(np.isfinite(facts.density), facts.density, med)
    e_before = island_esds(Vn, F, UV, FUV, groups, dens)
    touched = [k for k, fi in enumerate(groups) if changed_faces[fi].any()]
    e_after = e_before.copy()
    e_after[touched] = island_esds(Vn, F, UVw, FUVw, [groups[k] for k in touched], dens[touched])
    for isl, fi, eb, ea in zip(before.islands, groups, e_before, e_after):
        i = isl["island"]
        ch = changed_faces[fi]
        disp = np.abs(UVw[FUVw[fi]] - np.where(np.isfinite(UV[FUV[fi]]), UV[FUV[fi]], np.nan))
        dmax = float(np.nanmax(disp)) * resolution if ch.any() and np.isfinite(disp).any() else 0.0
        islands.append({**_island_base(isl), "actions": actions[i], "faces_changed": int(ch.sum()),
                        "rows_changed": int(changed_rows[np.unique(FUV[fi])].sum()),
                        "max_displacement_texels": dmax, "esd_before": float(eb), "esd_after": float(ea)})
    return RepairResult(V=V, F=F, UV=UVw, FUV=FUVw, changed_rows=changed_rows, changed_faces=changed_faces,
                        islands=islands, new_charts=new_charts, before=before, after=after, repacked=repacked,
                        time=time.perf_counter() - t0,
                        info={"rows_in": p_in, "preset": preset if isinstance(preset, str) else "custom",
                              "resolution": resolution, "padding": padding, "neural": neural},
                        UV_in=UV, FUV_in=FUV)


def _second_pass(Vn, F, UVw, FUVw, facts, actions, med, cfg, unweld, **kw):
    """Read the repaired texture layout again, as it will be written (``unweld``), and repair the folds it shows
    that the input did not.

    Which sheet of an island is a shell and which a fold is read off the layout around it
    (:func:`~neuraluv.layout.purpose.layout_intent`): a small reversed sheet next to damage can read as a
    shell of its own, and as a fold once the damage beside it is repaired. One more pass repairs those (its
    actions are marked ``"pass": 2``); folds the first pass could not repair are not tried again.
    """
    before = layout_intent(facts)
    f2 = _written(Vn, F, UVw, FUVw, facts, unweld)
    it2 = layout_intent(f2)
    new = (it2.fold | it2.degenerate) & ~(before.fold | before.degenerate) & facts.usable
    if not new.any() or budget_spent(kw["deadline"]):
        return UVw, FUVw
    acts = {j: [] for j in range(f2.n_islands)}
    UVw, FUVw = repair_shells(Vn, F, UVw, FUVw, f2, acts, med, cfg, only=new, **kw)
    for j, i in enumerate(input_islands(facts, f2)):
        if acts[j] and i >= 0:
            actions[int(i)].extend({**x, "pass": 2} for x in acts[j])
    return UVw, FUVw


def _written(Vn, F, UVw, FUVw, facts, unweld):
    """The facts of the working layout as it will be written (``unweld``; rows without usable UVs, neutralised for
    the steps, still without: step 4 gives their faces new charts)."""
    U, FU = unweld(UVw, FUVw)
    lost = ~np.isfinite(facts.UV).all(1)
    U[:len(lost)][lost] = np.nan
    return layout_facts(Vn, F, U, FU, normalized=True, min_overlap=facts.min_overlap)


def _island_base(isl):
    return {k: isl[k] for k in ("island", "faces", "uv_rows", "texel_density", "mirrored", "flipped", "degenerate",
                                "self_overlap_pairs", "outside_unit_square", "shells", "mirrored_faces", "folded",
                                "palette") if k in isl}


def _same_bits(A, B):
    """Rows of ``A`` and ``B`` equal bit for bit (NaN rows equal only to the same NaN bits)."""
    return (np.ascontiguousarray(A).view(np.int64) == np.ascontiguousarray(B).view(np.int64)).all(1)


def _new_charts(Vn, F, UV, FUV, lost, density, cfg, *, seed, device, deadline, share=True):
    """Charts for the faces ``lost`` (no usable UVs), solved by the atlas router, appended as new rows.

    Lost faces without 3D area have no map to solve: their three corners get one new row (a point: no UV
    area, so no overlap), as ``check --uv`` leaves such faces' UVs alone. So do lost faces whose three
    corners used one ``vt`` row (a point whatever its value: a palette collapse, e.g. one flat colour's
    faces on one texel), one new row per such row: they stay a point, not thousands of charts.
    A lost face on the same three vertices as an earlier one (double-sided geometry: a back face of the
    opposite winding) is not charted: with ``share`` it uses its front face's rows (stacked, mirrored: the
    texture purpose's double-sided face), else a copy of them, reflected where the winding is reversed (a
    unique, unmirrored island of its own). Charted with their twins, every edge of such a surface has
    four faces, and the router cut it into a chart per face or two (chair_model.obj: 960 charts).
    """
    UV, FUV = np.asarray(UV, float), np.asarray(FUV, np.int64).copy()
    out0 = []
    for why, flat in (("no 3D area", no_3d_area(Vn, F[lost])),
                      ("one vt row", (FUV[lost] == FUV[lost][:, :1]).all(1) & (FUV[lost][:, 0] >= 0))):
        if not flat.any():
            continue
        _, point = np.unique(FUV[lost[flat], 0] if why == "one vt row" else np.zeros(int(flat.sum()), np.int64),
                             return_inverse=True)
        FUV[lost[flat]] = (len(UV) + point.reshape(-1))[:, None]
        UV = np.vstack([UV, np.zeros((int(point.max()) + 1, 2))])
        out0.append({"faces": int(flat.sum()), "route": "point", "method": why,
                     "reason": "nothing to map" if why == "no 3D area" else "a point in the input (a palette)"})
        lost = lost[~flat]
        if not len(lost):
            return UV, FUV, out0
    lost, twins, front = _repeated_faces(F, lost)
    vi, Fl = submesh(F, lost)
    Vl = Vn[vi]
    UVo, FUVo = UV.copy(), FUV.copy()
    out = []
    try:
        charts = [(ch.route, ch.method, ch.reason, ch.islands)
                  for ch in route_charts(Vl, Fl, chart_candidates(Vl, Fl), cfg, seed=seed, device=device, deadline=deadline)]
    except Exception as exc:  # noqa: BLE001 - a messy face set (non-manifold, degenerate): per-piece fallback
        method, islands, why = fallback_islands(Vl, Fl, np.arange(len(Fl)), f"charting failed ({type(exc).__name__})")
        charts = [("fallback", method, why, islands)]
    for route, method, reason, islands in charts:
        for fl, vl, Fp, uv in islands:
            base = len(UVo)
            UVo = np.vstack([UVo, np.asarray(uv, float) * density])
            FUVo[lost[fl]] = Fp + base
            out.append({"faces": int(len(fl)), "route": route, "method": method, "reason": reason})
    if len(twins):
        UVo, FUVo = _twin_rows(F, UVo, FUVo, twins, front, share)
        out.append({"faces": int(len(twins)), "route": "twin", "method": "front face's rows" if share else
                    "front face's rows, copied", "reason": "a repeated face (double-sided geometry)"})
    return UVo, FUVo, out0 + out


def _repeated_faces(F, faces):
    """``(first, repeats, front)``: the ``faces`` on three vertices no earlier one of them uses, the others, and for
    each of those the first face on its vertices.

    Examples
    --------
    >>> _repeated_faces(np.array([[0, 1, 2], [1, 2, 3], [0, 2, 1]]), np.arange(3))
    (array([0, 1]), array([2]), array([0]))
    """
    faces = np.asarray(faces, np.int64)
    _, first, inv = np.unique(np.sort(F[faces], 1), axis=0, return_index=True, return_inverse=True)
    rep = np.ones(len(faces), bool)
    rep[first] = False
    return faces[~rep], faces[rep], faces[first[inv.reshape(-1)][rep]]


def _twin_rows(F, UV, FUV, twins, front, share):
    """Rows for the faces ``twins`` from their ``front`` faces' (the corner on the same vertex): those rows
    (``share``), else copies of them, reflected in ``u`` where the twin's winding is reversed. One copy per row
    for each winding and each repeat of a front face in that winding (the second face of one winding on the
    same vertices gets a second copy), so the copies keep the front faces' islands and no two faces share texels.

    Examples
    --------
    >>> F = np.array([[0, 1, 2], [0, 2, 1], [1, 2, 0], [2, 0, 1]])  # a face, its back face, two repeats of it
    >>> UV, FUV = _twin_rows(F, np.eye(3)[:, :2], np.array([[0, 1, 2]] * 4), np.array([1, 2, 3]), np.zeros(3, int),
    ...                      share=False)
    >>> FUV.tolist(), UV[3:6, 0].tolist()
    ([[0, 1, 2], [9, 11, 10], [4, 5, 3], [8, 6, 7]], [1.0, 0.0, 0.0])
    """
    pos = np.argmax(F[twins][:, :, None] == F[front][:, None, :], axis=2)       # the front corner of each corner
    rows = np.take_along_axis(FUV[front], pos, axis=1)
    if share:
        FUV[twins] = rows
        return UV, FUV
    rev = np.linalg.det(np.stack([pos == k for k in range(3)], 2).astype(float)) < 0   # an odd corner order
    key = 2 * np.asarray(front, np.int64) + rev
    order = np.argsort(key, kind="stable")
    first = np.r_[0, np.flatnonzero(np.diff(key[order])) + 1]
    repeat = np.empty(len(key), np.int64)
    repeat[order] = np.arange(len(key)) - np.repeat(first, np.diff(np.r_[first, len(key)]))
    for flip in (False, True):
        for r in range(int(repeat.max()) + 1 if len(repeat) else 0):
            sel = (rev == flip) & (repeat == r)
            if sel.any():
                used, inv = np.unique(rows[sel], return_inverse=True)
                FUV[twins[sel]] = len(UV) + inv.reshape(-1, 3)
                UV = np.vstack([UV, UV[used] * ([-1.0, 1.0] if flip else 1.0)])
    return UV, FUV

