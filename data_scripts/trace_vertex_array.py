"""Follow the vertex array through ``build_atlas`` and ``repair_layout``: steps, modules, climbs.

What it runs (deterministic: fixed inputs, seed 0, one torch thread, CPU)
-----------------------------------------------------------------------
(a) ``neuraluv.build_atlas(V, F, "test", resolution=256, padding=2, device="cpu", pack_trials=2)``
    on ``neuraluv.datasets.sphere(2)`` (162 vertices, 320 faces; 5 charts at ec29ff8);
(b) ``neuraluv.repair_layout(V, F, UV_bad, FUV, "test", seed=0, device="cpu", resolution=256, padding=2)``
    on that atlas (its ``V, F, FUV``), damaged twice (built outside the trace):
    a *local fold* -- the interior ``vt`` row of the largest island nearest the island's UV
    centre (no boundary row within 2 rings) is pushed across its ring, to twice the distance
    of its farthest ring neighbour (``neuraluv.repair.damage.row_rings`` / ``boundary_rows``);
    and *overlapping islands* -- the smallest island translated onto the second largest
    (``neuraluv.repair.damage.overlap_islands``).
Each entry point runs under ``sys.setprofile`` (and ``threading.setprofile``).

What it counts
--------------
*vertex array*: an ``np.ndarray`` of a float dtype with ``ndim == 2 and shape[1] == 3`` (the
    mesh ``V``, the normalised mesh, a sub-mesh's vertices). torch tensors, arrays inside lists,
    dicts or objects (``self.V``, a chart's ``.V``) do not count; positional, keyword, ``*args``
    and ``**kwargs`` arguments do.
*step*: a Python ``call`` event into a function whose module (``f_globals["__name__"]``) is
    ``neuraluv`` or ``neuraluv.*`` and one of whose arguments is a vertex array. Every call
    counts once (recursion included; a generator counts at its first entry, not at each
    resume). Calls whose frames between them and the nearest enclosing ``neuraluv`` frame
    include a numpy/scipy/torch frame (callbacks from an optimiser, ``np.apply_along_axis``)
    are excluded and reported separately. The entry-point call itself is step 1.
*caller* of a step: the module of the nearest enclosing ``neuraluv`` frame (whether or not that
    frame received the array); the entry-point call's caller is ``<script>``.
*entry*: a step whose callee module differs from its caller's module (the entry-point call
    counts as one entry into its module). "entries per module" = entries into that module.
*climb (layer)*: a step whose callee module is in a higher layer (:data:`LAYERS`) than its
    caller's module (e.g. atlas -> repair, solver -> atlas, core -> solver).
*re-entry*: the stack of ``neuraluv`` frames, with consecutive frames of the same module
    merged, is a path of module *visits*. A step that enters module B from a visit of module
    A that has already entered B once before (A -> B, back to A, -> B again; A's helpers count
    as A) is a re-entry of B. Reported per module B.
*normalisations*: calls of ``neuraluv.meshfix.normalize_unit_box`` (any argument), with their
    callers and vertex counts ``n``; "whole mesh" = as many vertices as the entry point's ``V``.

Layers (from docs/ARCHITECTURE.md, editable in :data:`LAYERS`): the longest matching dotted
prefix wins. A module no prefix matches gets :data:`DEFAULT_FLAT_LAYER` when it is a flat module
``neuraluv/<name>.py`` (the architecture puts every flat module in the core) and
:data:`DEFAULT_PACKAGE_LAYER` when it is in an unknown sub-package; such modules are listed
under "defaulted" in the output so the map can be updated.

Run (from the repository root; ~1-2 min on 1 core)::

    PYTHONPATH=$PWD MPLBACKEND=Agg OPENBLAS_NUM_THREADS=1 python data_scripts/trace_vertex_array.py \
        [--json OUT.json] [--chain OUT.txt] [--top N]

``--json`` writes every number; ``--chain`` writes the step tree (one line per step, indented
by step depth, with caller -> callee and the climb / re-entry marks); ``--top`` prints the N
most-called functions per entry point.
"""
from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from collections import Counter

import numpy as np

#: Layer of each part of the package (longest dotted prefix wins). Higher = closer to the user.
LAYERS = {
    # core, flat and torch-free (docs/ARCHITECTURE.md "Layers")
    "neuraluv": 0, "neuraluv.errors": 0, "neuraluv.io": 0, "neuraluv.meshfix": 0, "neuraluv.topology": 0,
    "neuraluv.jacobian": 0, "neuraluv.metrics": 0, "neuraluv.spectral": 0, "neuraluv.tutte": 0,
    "neuraluv.relax": 0, "neuraluv.packing": 0, "neuraluv.plot": 0, "neuraluv.check": 0,
    "neuraluv.notebook": 0, "neuraluv.datasets": 0,
    # the planned shared layout layer, between the core and the solver
    "neuraluv.layout": 0.5,
    "neuraluv.solver": 1,
    "neuraluv.atlas": 2,
    "neuraluv.repair": 3,
    "neuraluv.baselines": 4, "neuraluv.bench": 4, "neuraluv.cli": 4, "neuraluv.__main__": 4,
}
#: Layer of an unmapped flat module ``neuraluv/<name>.py`` (the core is flat).
DEFAULT_FLAT_LAYER = 0
#: Layer of a module in an unmapped sub-package ``neuraluv/<pkg>/...``: the top (a call into it
#: from anything mapped reads as a climb, so a forgotten entry shows up).
DEFAULT_PACKAGE_LAYER = 4

EXCLUDE_CALLERS = ("numpy", "scipy", "torch")
_GEN_FLAGS = 0x20 | 0x80 | 0x200  # CO_GENERATOR | CO_COROUTINE | CO_ASYNC_GENERATOR
_PKG_DIRS = None


def _is_package_module(mod):
    """True when ``neuraluv.<top>`` of ``mod`` is a sub-package (a folder), not a flat module."""
    global _PKG_DIRS
    if _PKG_DIRS is None:
        import pathlib

        import neuraluv

        root = pathlib.Path(neuraluv.__file__).parent
        _PKG_DIRS = {p.name for p in root.iterdir() if (p / "__init__.py").exists()}
    parts = mod.split(".")
    return len(parts) > 1 and parts[1] in _PKG_DIRS


def layer_of(mod, defaulted=None):
    """Layer of a dotted module name (see :data:`LAYERS`); records defaults in ``defaulted``."""
    parts = mod.split(".")
    for k in range(len(parts), 0, -1):
        key = ".".join(parts[:k])
        if key in LAYERS and (k > 1 or len(parts) == 1):
            return LAYERS[key]
    lay = DEFAULT_PACKAGE_LAYER if _is_package_module(mod) else DEFAULT_FLAT_LAYER
    if defaulted is not None:
        defaulted[mod] = lay
    return lay


def _is_vertex_array(x):
    return (isinstance(x, np.ndarray) and x.ndim == 2 and x.shape[1] == 3
            and np.issubdtype(x.dtype, np.floating))


def _args(frame):
    """The argument values of a frame at its call event (named, *args items, **kwargs values)."""
    co = frame.f_code
    loc = frame.f_locals
    n = co.co_argcount + co.co_kwonlyargcount
    names = list(co.co_varnames[:n])
    flags = co.co_flags
    out = [loc.get(a) for a in names]
    i = n
    if flags & 0x04:  # CO_VARARGS
        out += list(loc.get(co.co_varnames[i], ()) or ())
        i += 1
    if flags & 0x08:  # CO_VARKEYWORDS
        out += list((loc.get(co.co_varnames[i]) or {}).values())
    return out


def _qualname(frame):
    """A frame's function name; a dataclass's generated ``__init__`` is named after its class."""
    q = frame.f_code.co_qualname
    if q.endswith("__create_fn__.<locals>.__init__") and "self" in frame.f_locals:
        return f"{type(frame.f_locals['self']).__qualname__}.__init__"
    return q


class Tracer:
    """``sys.setprofile`` hook collecting the steps of one entry point."""

    def __init__(self):
        import neuraluv.meshfix

        self.norm_code = neuraluv.meshfix.normalize_unit_box.__code__
        self.steps = []            # dicts, in call order
        self.excluded = Counter()  # callee -> count (called from numpy/scipy/torch)
        self.normalisations = []   # ("caller module.function", n vertices) per call
        self.visits = {}           # id(outermost frame of a module visit) -> (frame, set of modules entered)
        self.gen_seen = {}         # id(generator frame) -> frame (first entry seen)
        self.defaulted = {}

    # -- the hook
    def __call__(self, frame, event, arg):
        if event == "return":
            v = self.visits.get(id(frame))
            if v is not None and v[0] is frame and not (frame.f_code.co_flags & _GEN_FLAGS):
                del self.visits[id(frame)]
            return
        if event != "call":
            return
        mod = frame.f_globals.get("__name__", "")
        if not (mod == "neuraluv" or mod.startswith("neuraluv.")):
            return
        co = frame.f_code
        if co.co_flags & _GEN_FLAGS:
            if id(frame) in self.gen_seen and self.gen_seen[id(frame)] is frame:
                return  # a generator resumed
            self.gen_seen[id(frame)] = frame
        try:
            args = _args(frame)
        except Exception:  # noqa: BLE001 - odd frames: not a step
            return
        if co is self.norm_code:
            n = len(args[0]) if args and hasattr(args[0], "__len__") else -1
            self.normalisations.append((self._caller_name(frame), n))
        if not any(_is_vertex_array(a) for a in args):
            return
        self._step(frame, mod)

    @staticmethod
    def _caller_name(frame):
        f = frame.f_back
        while f is not None:
            m = f.f_globals.get("__name__", "")
            if m == "neuraluv" or m.startswith("neuraluv."):
                return f"{m}.{_qualname(f)}"
            f = f.f_back
        return "<script>"

    def _step(self, frame, mod):
        # neuraluv frames on the stack (innermost first), and whether numpy/scipy/torch sits between
        chain, between_foreign, f = [], False, frame.f_back
        while f is not None:
            m = f.f_globals.get("__name__", "")
            if m == "neuraluv" or m.startswith("neuraluv."):
                chain.append((m, f))
            elif not chain and m.split(".")[0] in EXCLUDE_CALLERS:
                between_foreign = True
            f = f.f_back
        name = f"{mod}.{_qualname(frame)}"
        if between_foreign:
            self.excluded[name] += 1
            return
        caller_mod = chain[0][0] if chain else "<script>"
        caller_fn = _qualname(chain[0][1]) if chain else ""
        # module visits: merge consecutive same-module frames; the visit is keyed by its outermost frame
        depth_mod = 0
        visit_frame = None
        if chain:
            j = 0
            while j + 1 < len(chain) and chain[j + 1][0] == caller_mod:
                j += 1
            visit_frame = chain[j][1]
            prev = None
            for m, _ in reversed(chain):
                if m != prev:
                    depth_mod += 1
                    prev = m
        entered = mod != caller_mod
        reentry = False
        if entered and visit_frame is not None:
            v = self.visits.get(id(visit_frame))
            if v is None or v[0] is not visit_frame:
                v = (visit_frame, set())
                self.visits[id(visit_frame)] = v
            reentry = mod in v[1]
            v[1].add(mod)
        lc = layer_of(caller_mod, self.defaulted) if chain else None
        le = layer_of(mod, self.defaulted)
        climb = lc is not None and le > lc
        self.steps.append({
            "i": len(self.steps) + 1, "depth": len(chain), "module_depth": depth_mod,
            "callee": name, "module": mod, "caller": f"{caller_mod}.{caller_fn}" if chain else "<script>",
            "caller_module": caller_mod, "entered": entered, "climb": climb, "reentry": reentry,
            "layers": [lc, le],
        })

    # -- running
    def run(self, fn, *args, **kwargs):
        threading.setprofile(self)
        sys.setprofile(self)
        try:
            return fn(*args, **kwargs)
        finally:
            sys.setprofile(None)
            threading.setprofile(None)
            self.visits.clear()
            self.gen_seen.clear()

    def summary(self, n_whole):
        """The numbers; ``n_whole``: the entry point's vertex count (a normalisation of that many
        vertices is one of the whole mesh, fewer: of a sub-mesh)."""
        s = self.steps
        entries = Counter(x["module"] for x in s if x["entered"])
        reentries = Counter(x["module"] for x in s if x["reentry"])
        climbs = [x for x in s if x["climb"]]
        return {
            "steps": len(s),
            "modules": len({x["module"] for x in s}),
            "module_entries": sum(entries.values()),
            "entries_per_module": dict(sorted(entries.items(), key=lambda kv: (-kv[1], kv[0]))),
            "steps_per_module": dict(sorted(Counter(x["module"] for x in s).items(), key=lambda kv: (-kv[1], kv[0]))),
            "climbs": len(climbs),
            "climbs_by_edge": dict(sorted(Counter(f"{x['caller_module']} -> {x['module']}" for x in climbs).items(),
                                          key=lambda kv: (-kv[1], kv[0]))),
            "reentries": sum(reentries.values()),
            "reentries_per_module": dict(sorted(reentries.items(), key=lambda kv: (-kv[1], kv[0]))),
            "max_depth": max((x["depth"] for x in s), default=0),
            "max_module_depth": max((x["module_depth"] for x in s), default=0),
            "normalisations": len(self.normalisations),
            "normalisations_whole_mesh": sum(n == n_whole for _, n in self.normalisations),
            "normalise_callers": dict(Counter(f"{c} (n={n})" for c, n in self.normalisations)),
            "excluded_calls": sum(self.excluded.values()),
            "excluded": dict(self.excluded),
            "defaulted_modules": dict(self.defaulted),
            "functions": dict(Counter(x["callee"] for x in s).most_common()),
        }


# ---------------------------------------------------------------- inputs


def atlas_input():
    from neuraluv.datasets.procedural import sphere

    return sphere(2)


def damaged_layout(atlas):
    """The atlas's layout with a local fold in its largest island and two overlapping islands."""
    from neuraluv.metrics import face_dets
    from neuraluv_paper import damage
    from neuraluv.repair.diagnose import layout_facts

    V, F, UV, FUV = atlas.V, atlas.F, np.asarray(atlas.UV, float), atlas.FUV
    facts = layout_facts(V, F, UV, FUV)
    sizes = np.bincount(facts.label[facts.label >= 0], minlength=facts.n_islands)
    order = np.argsort(-sizes, kind="stable")
    if len(order) < 3:
        raise SystemExit(f"the atlas has {len(order)} islands; the damage needs 3")
    big, second, small = int(order[0]), int(order[1]), int(order[-1])
    rows = np.unique(FUV[facts.island_faces(big)])
    n = len(UV)
    bd = damage.boundary_rows(FUV, n)
    ok = [r for r in rows if not bd[damage.row_rings(FUV, n, int(r), 2) >= 0].any()]
    if not ok:
        raise SystemExit("no interior row 2 rings from the largest island's boundary")
    ok = np.asarray(ok)
    c = int(ok[np.argmin(np.linalg.norm(UV[ok] - UV[rows].mean(0), axis=1))])
    ring = np.flatnonzero(damage.row_rings(FUV, n, c, 1) == 1)
    far = ring[np.argmax(np.linalg.norm(UV[ring] - UV[c], axis=1))]
    bad = UV.copy()
    bad[c] = UV[c] + 2.0 * (UV[far] - UV[c])  # across its ring
    flipped = int((~(face_dets(V, F, bad, FUV) > 0)).sum())
    bad, info = damage.overlap_islands(bad, FUV, facts.island_faces(small), facts.island_faces(second))
    return V, F, bad, FUV, {"islands": int(facts.n_islands), "fold_row": c, "fold_flipped_faces": flipped,
                            "moved_island_faces": int(sizes[small]), "onto_island_faces": int(sizes[second]),
                            "shift": [round(x, 6) for x in info["shift"]]}


# ---------------------------------------------------------------- output


def _table(title, summ, top):
    w = []
    w.append(f"== {title}")
    w.append(f"steps {summ['steps']} | modules {summ['modules']} | module entries {summ['module_entries']} | "
             f"climbs {summ['climbs']} | re-entries {summ['reentries']} | normalisations {summ['normalisations']} "
             f"({summ['normalisations_whole_mesh']} whole mesh) | "
             f"max depth {summ['max_depth']} frames / {summ['max_module_depth']} modules | "
             f"excluded (from numpy/scipy/torch) {summ['excluded_calls']}")
    mods = sorted(summ["steps_per_module"], key=lambda m: (layer_of(m), m))
    w.append(f"  {'module':32s} {'layer':>5s} {'steps':>6s} {'entered':>8s} {'re-entered':>10s}")
    for m in mods:
        w.append(f"  {m:32s} {layer_of(m):>5g} {summ['steps_per_module'][m]:>6d} "
                 f"{summ['entries_per_module'].get(m, 0):>8d} {summ['reentries_per_module'].get(m, 0):>10d}")
    if summ["climbs_by_edge"]:
        w.append("  climbs (caller module -> callee module: count)")
        for e, k in summ["climbs_by_edge"].items():
            w.append(f"    {e}: {k}")
    w.append("  normalize_unit_box called from: " + (", ".join(f"{k} x{v}" for k, v in summ["normalise_callers"].items())
                                                     or "-"))
    if summ["excluded"]:
        w.append("  excluded: " + ", ".join(f"{k} x{v}" for k, v in summ["excluded"].items()))
    if summ["defaulted_modules"]:
        w.append("  layer defaulted (not in LAYERS): " + ", ".join(f"{k}={v}" for k, v in summ["defaulted_modules"].items()))
    if top:
        w.append(f"  top {top} functions by steps")
        for k, v in list(summ["functions"].items())[:top]:
            w.append(f"    {v:5d}  {k}")
    return "\n".join(w)


def _chain_lines(title, steps):
    out = [f"== {title}"]
    for x in steps:
        mark = (" CLIMB" if x["climb"] else "") + (" RE-ENTRY" if x["reentry"] else "")
        out.append(f"{x['i']:5d} {'  ' * min(x['depth'], 40)}{x['caller']} -> {x['callee']}{mark}")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", help="write all numbers here")
    ap.add_argument("--chain", help="write the step tree here")
    ap.add_argument("--top", type=int, default=0, help="print the N most-called functions per entry point")
    a = ap.parse_args(argv)

    import torch

    torch.set_num_threads(1)
    torch.manual_seed(0)
    np.random.seed(0)
    import neuraluv

    out, chain = {}, []
    V, F = atlas_input()
    tr = Tracer()
    t0 = time.perf_counter()
    atlas = tr.run(neuraluv.build_atlas, V, F, "test", resolution=256, padding=2, device="cpu", pack_trials=2)
    ta = time.perf_counter() - t0
    sa = tr.summary(len(V))
    out["build_atlas"] = {"input": {"mesh": "sphere(2)", "vertices": len(V), "faces": len(F)},
                          "result": {"charts": len(atlas.charts), "valid": atlas.valid}, **sa}
    chain += _chain_lines("build_atlas", tr.steps)
    print(f"build_atlas(sphere(2): {len(V)} vertices, {len(F)} faces, 'test', resolution=256, padding=2, "
          f"pack_trials=2): {len(atlas.charts)} charts, valid {atlas.valid}, {ta:.1f} s traced")
    print(_table("build_atlas", sa, a.top))

    Vr, Fr, bad, FUV, dmg = damaged_layout(atlas)
    tr = Tracer()
    t0 = time.perf_counter()
    res = tr.run(neuraluv.repair_layout, Vr, Fr, bad, FUV, "test", seed=0, device="cpu", resolution=256, padding=2)
    tb = time.perf_counter() - t0
    sb = tr.summary(len(Vr))
    kinds = sorted({p["kind"] for p in res.before.problems})
    out["repair_layout"] = {"input": {**dmg, "problems_before": kinds},
                            "result": {"valid_after": bool(res.after.validation.get("valid", False)),
                                       "problems_after": sorted({p["kind"] for p in res.after.problems}),
                                       "actions": [[s.get("step") for s in isl.get("actions", [])]
                                                   for isl in res.islands]}, **sb}
    chain += _chain_lines("repair_layout", tr.steps)
    print(f"\nrepair_layout(atlas above; fold at row {dmg['fold_row']} ({dmg['fold_flipped_faces']} flipped faces) + "
          f"island of {dmg['moved_island_faces']} faces moved onto one of {dmg['onto_island_faces']}; 'test'): "
          f"problems {kinds} -> after {out['repair_layout']['result']['problems_after']}, "
          f"valid {out['repair_layout']['result']['valid_after']}, {tb:.1f} s traced")
    print(_table("repair_layout", sb, a.top))

    out["definitions"] = {"layers": LAYERS, "default_flat_layer": DEFAULT_FLAT_LAYER,
                          "default_package_layer": DEFAULT_PACKAGE_LAYER, "excluded_callers": EXCLUDE_CALLERS}
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)
    if a.chain:
        with open(a.chain, "w") as fh:
            fh.write("\n".join(chain) + "\n")


if __name__ == "__main__":
    main()
