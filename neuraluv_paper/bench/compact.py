"""Table 1 (tab:compact_prelim): the compact pre-cut chart benchmark (Hand, Bob, Camel).

Every method runs through :func:`neuraluv_paper.baselines.run_baseline` and is
measured by the one metric definition, so the rows compare like with like.
Multi-component inputs (Bob) get a whole-mesh row per method (libigl methods
then fail to initialise, as in the paper) and a per-component row (each
component flattened on its own, metrics over all faces). The distortion of maps
that still flip is greyed; the best value among foldover-free fixed-chart
solvers is bold; the paper's value stands beside ours in brackets.

Also writes the compact figures: checkerboard transfers and UV layouts (flips
in red), det J and conformal-distortion heatmaps.

Python API: :func:`bench`; command line: ``neuraluv bench compact``.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from neuraluv import plot
from neuraluv.errors import NeuralUVError
from neuraluv.jacobian import jacobians, local_frames
from neuraluv.metrics import face_metrics
from neuraluv.topology import topology_scan
from neuraluv_paper.baselines import METHODS as ALL
from neuraluv_paper.baselines import run_baseline
from neuraluv_paper.bench import paper_values as PV
from neuraluv_paper.bench.common import (DEFAULT_MESHES, LABELS, MESH_LABELS, METHODS, QUICK_MESHES, QUICK_METHODS,
                                         RECUT, iteration_override, load_meshes, neural_options, result_row)
from neuraluv_paper.bench.provenance import (GREY_NOTE, PAPER_NOTE, BenchOutput, bold, command_line, findings_markdown,
                                             fmt_num, fmt_pct, fmt_time, grey, markdown_table, print_report, progress,
                                             save_figure, start_run, with_paper, write_csv, write_markdown)
from neuraluv_paper.claims import heading

__all__ = ["bench", "add_arguments", "run"]

def _mesh_label(name):
    return MESH_LABELS.get(name, name)


def _cache_uv(out, mesh, method, mode, res):
    if res.uv is None:
        return
    d = Path(out) / "cache"
    d.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(d / f"{mesh}__{method}__{mode}.npz", V=res.V, F=res.F, uv=res.uv)


def _load_uv(out, mesh, method, mode):
    p = Path(out) / "cache" / f"{mesh}__{method}__{mode}.npz"
    if not p.exists():
        return None
    z = np.load(p)
    return z["V"], z["F"], z["uv"]


# ------------------------------------------------------------------ the benchmark

def bench(meshes=None, methods=None, *, preset=None, quick=False, output="results/compact", resume=False, seed=0,
          device="auto", show_progress=True, figures=True, per_component=True, args=None, **overrides):
    """Run Table 1 (tab:compact_prelim) and write ``compact_prelim.{csv,md}`` (+ figures) to ``output``.

    Parameters
    ----------
    meshes : list of str, optional
        Default Hand, Bob, Camel (under ``quick``: the procedural ``glove`` and
        ``components`` stand-ins).
    methods : list of str, optional
        Default :data:`METHODS`.
    preset : str, optional
        Neural preset (default ``fast``; ``test`` under ``quick``).
    resume : bool
        Keep rows already in ``output/rows.jsonl``.
    figures : bool
        Write the map and heatmap plates (needs pyvista off-screen rendering).
    per_component : bool
        Add per-component rows for multi-component meshes.
    **overrides
        SolverConfig overrides for the neural rows (e.g. ``iterations=300``).

    Returns
    -------
    BenchOutput
    """
    names = list(meshes or (QUICK_MESHES if quick else DEFAULT_MESHES))
    methods = list(methods or (QUICK_METHODS if quick else METHODS))
    nkw = neural_options(preset, quick, seed, device, **overrides)
    loaded = load_meshes(names, quick)
    out, machine, log = start_run(output, resume=resume, device=device)

    jobs = []
    for name, V, F in loaded:
        comps = topology_scan(V, F).components
        for meth in methods:
            jobs.append((name, V, F, meth, "whole"))
        if per_component and comps > 1:
            for meth in methods:
                if meth in ("neural",) or meth in RECUT:
                    continue  # neural already solves per component; recutters take the whole mesh
                jobs.append((name, V, F, meth, "per component"))

    rows = []
    for name, V, F, meth, mode in progress(jobs, desc="compact", disable=not show_progress):
        cfg = {"mode": mode, **({k: v for k, v in nkw.items() if k != "device"} if meth == "neural" else {})}
        key = (name, meth, cfg)

        def compute():
            kw = nkw if meth == "neural" else {}
            res = run_baseline(meth, V, F, per_component=(mode == "per component"), **kw)
            _cache_uv(out, name, meth, mode.replace(" ", "-"), res)
            return result_row(res)

        row = dict(log.run(key, compute))
        row.update({"mesh": name, "method": meth, "mode": mode})
        rows.append(row)

    findings = _findings(rows, names)
    table_rows, csv_rows = _format(rows)
    body = [f"Neural rows: preset `{nkw['preset']}`" + (f" with overrides {overrides}" if overrides else "")
            + f", seed {seed}. The paper's neural rows use the `paper` preset (5,000 iterations) on CUDA.", ""]
    if quick and meshes is None:
        body += ["Quick run: procedural stand-ins (`glove` for a fingered chart, `components` for a "
                 "3-component input) at small sizes, the tiny `test` preset and SLIM-20 in place of SLIM-1k; "
                 "no paper values apply to them.", ""]
    body.append(markdown_table(["Mesh", "Method", "E_SD ↓", "Conf. ↓", "Area ↓", "%Flip ↓", "min det J",
                                "Time (s)", "Status"], table_rows, "llrrrrrrl"))
    notes = [GREY_NOTE, PAPER_NOTE,
             "**Bold**: best value among foldover-free fixed-chart solvers on that mesh (the methods that cut their own "
             "seams — OptCuts, xatlas, Blender Smart UV — are excluded).",
             "BFF v1.6 binary: the Boundary First Flattening command-line tool (`make baselines`), run as documented "
             "(`--normalizeUVs`); its file prints UVs with six decimals, which rounds Hand's crushed finger triangles "
             "to zero or negative area (results/baselines/bff_agreement.md). Blender rows: `bpy` 4.5 "
             "(`make blender-env`), operator time inside Blender.",
             "Time is wall-clock on the machine below (the paper's: its own machine and, for ours, CUDA)."]
    reasons = sorted({f"{LABELS.get(r['method'], r['method'])} on {_mesh_label(r['mesh'])} ({r['mode']}): "
                      f"{r['status']} — {r['reason']}" for r in rows if r["status"] not in ("ok", "neural") and r["reason"]})
    if reasons:
        notes.append("Status details:\n\n" + "\n".join(f"- {s}" for s in reasons))
    if log.skipped:
        notes.append(f"{log.skipped} row(s) taken from the resume log ({out / 'rows.jsonl'}).")
    fm = findings_markdown(findings)
    if fm:
        body += ["", fm]
    body += ["", f"Paper caption: “{PV.CAPTIONS['tab:compact_prelim']}”"]

    files = []
    if figures:
        lacking = _uncached(out, rows, loaded, methods)
        plates = [out / "compact_maps.png", out / "compact_heatmaps.png"]
        if lacking and all(p.exists() for p in plates):
            files += plates
            notes.append(f"Figures not regenerated by this run: the UV maps of {', '.join(lacking)} (rows taken from "
                         f"the resume log) are not in {out / 'cache'}; the plates are those of the run that computed "
                         "them, without the rows added since.")
        else:
            files += _figures(out, loaded, methods)
        if files:
            body += ["", "## Figures", ""] + [f"![{p.stem}]({p.name})" for p in files]
    command = command_line("compact", args)
    files.insert(0, write_csv(out / "compact_prelim.csv", csv_rows))
    md = write_markdown(out / "compact_prelim.md", heading("tab:compact_prelim", "compact pre-cut charts"), "\n".join(body),
                        command=command, machine=machine, notes=notes, findings=findings)
    files.insert(1, md)
    return BenchOutput("compact", rows, md.read_text(), files, findings, log.skipped)


def _uncached(out, rows, loaded, methods):
    """``"mesh/method"`` of the maps the plates need that are not in ``out/cache`` (resumed rows)."""
    single = {n for n, V, F in loaded if topology_scan(V, F).components == 1}
    need = {(r["mesh"], r["method"]) for r in rows if r["mesh"] in single and r["mode"] == "whole"
            and r["method"] in methods and r["method"] not in RECUT and _ok(r)}
    return sorted(f"{m}/{k}" for m, k in need if _load_uv(out, m, k, "whole") is None)


def _paper(name, meth, mode):
    meth = PV.paper_method(meth)
    if mode != "whole" or (name, meth) not in PV.COMPACT_PRELIM:
        return None, False
    return PV.COMPACT_PRELIM[(name, meth)], (name, meth) in PV.COMPACT_PRELIM_GREYED


def _format(rows):
    # best among valid fixed-chart whole-mesh rows per mesh (bold)
    best = {}
    for r in rows:
        if r["method"] in RECUT or not r.get("valid"):
            continue
        for k in ("esd", "conformal", "area"):
            b = best.setdefault((r["mesh"], r["mode"], k), math.inf)
            best[(r["mesh"], r["mode"], k)] = min(b, r[k])
    table, csv_rows = [], []
    for r in rows:
        pv, pgrey = _paper(r["mesh"], r["method"], r["mode"])
        produced = r["status"] in ("ok", "neural", "fallback") and r.get("esd") is not None and not _isnan(r.get("esd"))
        flipped = produced and (r.get("flips") or 0) > 0
        cells = []
        for k in ("esd", "conformal", "area"):
            s = fmt_num(r[k]) if produced else "—"
            if flipped:
                s = grey(s)
            elif produced and r.get("valid") and r["method"] not in RECUT and r[k] == best.get((r["mesh"], r["mode"], k)):
                s = bold(s)
            p = None
            if (r["mesh"], PV.paper_method(r["method"])) in PV.COMPACT_PRELIM and r["mode"] == "whole":
                p = "—" if pv is None else (grey(fmt_num(pv[k])) if pgrey else fmt_num(pv[k]))
            cells.append(with_paper(s, p))
        has_p = (r["mesh"], PV.paper_method(r["method"])) in PV.COMPACT_PRELIM and r["mode"] == "whole"
        cells.append(with_paper(fmt_pct(r["flip_percent"]) if produced else "—",
                                ("—" if pv is None else fmt_pct(pv["flip_percent"])) if has_p else None))
        cells.append(fmt_num(r["min_det"], 3) if produced else "—")
        cells.append(with_paper(fmt_time(r["time"]) if produced else "—",
                                ("—" if pv is None else fmt_time(pv["time"])) if has_p else None))
        status = r["status"]
        if r["method"] == "neural" and r.get("attempts", 1) > 1:
            status += f" ({r['attempts']} attempts)"
        if r["method"] == "neural" and r.get("stop"):
            status += f", stop: {r['stop']}"
        mesh = _mesh_label(r["mesh"]) + (" (per comp.)" if r["mode"] != "whole" else "")
        table.append([mesh, LABELS.get(r["method"], r["method"])] + cells + [status])
        c = {k: r.get(k) for k in ("mesh", "mode", "method", "status", "esd", "conformal", "area", "flips",
                                   "flip_percent", "min_det", "n_faces", "valid", "time", "attempts", "reason")}
        c["greyed"] = bool(flipped)
        for k in ("esd", "conformal", "area", "flip_percent", "time"):
            c[f"paper_{k}"] = (pv[k] if pv else None) if has_p else None
        c["paper_dash"] = bool(has_p and pv is None)
        csv_rows.append(c)
    return table, csv_rows


def _isfinite(x):
    try:
        return math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def _isnan(x):
    try:
        return math.isnan(float(x))
    except (TypeError, ValueError):
        return True


def _get(rows, mesh, meth, mode="whole"):
    for r in rows:
        if r["mesh"] == mesh and r["method"] == meth and r["mode"] == mode:
            return r
    return None


def _ok(r):
    return r is not None and r["status"] in ("ok", "neural", "fallback") and not _isnan(r.get("esd"))


def _desc(r):
    if r is None:
        return "not run"
    if not _ok(r):
        return r["status"]
    return f"{fmt_pct(r['flip_percent'])} flips, E_SD {fmt_num(r['esd'])}"


def _findings(rows, names):
    """Check the paper's qualitative Table 1 (tab:compact_prelim) statements on our rows."""
    F = []
    have = {r["mesh"] for r in rows}
    fixed = [m for m in ("lscm", "arap", "slim-1k", "bff") if any(r["method"] == m for r in rows)]
    compact = [m for m in DEFAULT_MESHES if m in have]
    if compact and any(r["method"] == "neural" for r in rows):
        ours_ok = all((_get(rows, m, "neural") or {}).get("status") == "neural" and _get(rows, m, "neural").get("valid")
                      for m in compact)
        others_fail = {b: [m for m in compact if not (_ok(_get(rows, m, b)) and _get(rows, m, b)["valid"])] for b in fixed}
        holds = ours_ok and all(others_fail[b] for b in fixed)
        det = "; ".join(f"{LABELS[b]} fails/flips on {', '.join(map(_mesh_label, v)) or 'none'}" for b, v in others_fail.items())
        F.append(("Among fixed-chart solvers, only ours is foldover-free on every chart", holds,
                  f"ours valid on {sum((_get(rows, m, 'neural') or {}).get('valid', False) for m in compact)}/{len(compact)}; {det}"))
    if "hand" in have:
        rs = {b: _get(rows, "hand", b) for b in fixed}
        holds = all(_ok(r) and r["flips"] > 0 for r in rs.values())
        F.append(("Hand: LSCM, ARAP, SLIM-1k and BFF all fold (13.6–15.7% flips in the paper)", holds,
                  "; ".join(f"{LABELS[b]} {_desc(r)}" for b, r in rs.items())))
    if "bob" in have:
        libigl = [b for b in ("lscm", "arap", "slim-1k") if b in fixed]
        init = all((_get(rows, "bob", b) or {}).get("status") == "init fail" for b in libigl)
        F.append(("Bob: the libigl methods cannot initialise on the 3-component input", init,
                  "; ".join(f"{LABELS[b]}: {(_get(rows, 'bob', b) or {}).get('status', 'not run')}" for b in libigl)))
        b, n = _get(rows, "bob", "bff"), _get(rows, "bob", "neural")
        if b is not None and n is not None:
            holds = _ok(b) and b["valid"] and _ok(n) and n["valid"]
            F.append(("Bob: BFF and ours both solve it with zero flips", holds, f"BFF {_desc(b)}; ours {_desc(n)}"))
            if holds:
                F.append(("Bob: BFF has higher E_SD and area distortion than ours", b["esd"] > n["esd"] and b["area"] > n["area"],
                          f"E_SD {fmt_num(b['esd'])} vs {fmt_num(n['esd'])}, area {fmt_num(b['area'])} vs {fmt_num(n['area'])}"))
    if "camel" in have:
        s, n = _get(rows, "camel", "slim-1k"), _get(rows, "camel", "neural")
        if s is not None and n is not None:
            holds = _ok(s) and s["valid"] and _ok(n) and s["esd"] <= n["esd"]
            F.append(("Camel: SLIM-1k is zero-flip and the better fixed-chart solver (E_SD 4.09 vs ours 4.14)", holds,
                      f"SLIM-1k {_desc(s)}; ours {_desc(n)}"))
        rs = {b: _get(rows, "camel", b) for b in ("lscm", "arap") if b in fixed}
        if rs:
            F.append(("Camel: LSCM and ARAP still fold (0.22% and 7.61% flips in the paper)",
                      all(_ok(r) and r["flips"] > 0 for r in rs.values()),
                      "; ".join(f"{LABELS[b]} {_desc(r)}" for b, r in rs.items())))
    slower = []
    for m in compact:
        n = _get(rows, m, "neural")
        fast = [_get(rows, m, b) for b in ("lscm", "arap", "bff") if b in fixed]
        fast = [r for r in fast if _ok(r)]
        if n is not None and _ok(n) and fast:
            slower.append((m, n["time"], max(r["time"] for r in fast)))
    if slower:
        F.append(("Our PyTorch solver is slower than LSCM, ARAP and BFF", all(a > b for _, a, b in slower),
                  "; ".join(f"{_mesh_label(m)}: ours {fmt_time(a)} s vs ≤ {fmt_time(b)} s" for m, a, b in slower)))
    if any(r["method"] == "optcuts" for r in rows):
        st = {r["status"] for r in rows if r["method"] == "optcuts"}
        if st == {"unavailable"}:
            F.append(("OptCuts resolves Hand and Camel when recutting is allowed", None,
                      "OptCuts binary not installed (`make baselines`, or set NEURALUV_OPTCUTS)"))
        else:
            rs = {m: _get(rows, m, "optcuts") for m in ("hand", "camel") if m in have}
            if rs:
                F.append(("OptCuts resolves Hand and Camel when recutting is allowed",
                          all(_ok(r) and r["valid"] for r in rs.values()),
                          "; ".join(f"{_mesh_label(m)}: {_desc(r)}" for m, r in rs.items())))
            if "bob" in have:
                r = _get(rows, "bob", "optcuts")
                F.append(("OptCuts fails on Bob's 3-component chart (the paper's 'cleanup fail')",
                          r is not None and not (_ok(r) and r["valid"]), f"OptCuts on Bob: {_desc(r)}"
                          + (f" ({r['reason']})" if r is not None and r.get("reason") else "")))
    pairs = [(m, _get(rows, m, "bff"), _get(rows, m, "bff-cli")) for m in names if m in have]
    pairs = [(m, a, b) for m, a, b in pairs if a is not None and b is not None and _ok(a) and _ok(b)]
    if pairs:
        same = all(abs(b["esd"] - a["esd"]) <= 0.01 * a["esd"] and b["flips"] == a["flips"] if _isfinite(b["esd"])
                   and _isfinite(a["esd"]) else False for _, a, b in pairs)
        F.append(("(ours, not the paper's) the BFF v1.6 binary, run as documented, gives our Python BFF's map "
                  "(E_SD within 1%, same flips)", same,
                  "; ".join(f"{_mesh_label(m)}: E_SD {fmt_num(b['esd'])} vs ours {fmt_num(a['esd'])}, "
                            f"flips {fmt_pct(b['flip_percent'])} vs {fmt_pct(a['flip_percent'])}" for m, a, b in pairs)
                  + " (see results/baselines/bff_agreement.md)"))
    return F


# ------------------------------------------------------------------ figures

def _figures(out, loaded, methods):
    """The compact map plate and heatmap plate (single-component meshes only, like the paper)."""
    plt = plot.pyplot()
    meths = [m for m in methods if m not in RECUT]
    single = [(n, V, F) for n, V, F in loaded if topology_scan(V, F).components == 1]
    if not single or not meths:
        return []
    win = (300, 300)
    files = []
    # --- checkerboard transfer + UV layout
    fig, axes = plt.subplots(2 * len(single), len(meths), figsize=(2.3 * len(meths), 4.6 * len(single)), squeeze=False)
    for i, (name, V, F) in enumerate(single):
        for j, m in enumerate(meths):
            a, b = axes[2 * i, j], axes[2 * i + 1, j]
            got = _load_uv(out, name, m, "whole")
            if got is None:
                for ax in (a, b):
                    ax.set_axis_off()
                a.set_title(f"{_mesh_label(name)} / {LABELS.get(m, m)}: no map", fontsize=8)
                continue
            Vm, Fm, uv = got
            uvn = (uv - uv.min(0)) / max(np.ptp(uv, axis=0).max(), 1e-12)
            a.imshow(plot.render_checkerboard(Vm, Fm, uvn, window_size=win))
            a.set_axis_off()
            a.set_title(f"{_mesh_label(name)} / {LABELS.get(m, m)}", fontsize=8)
            plot.plot_uv_layout(Vm, Fm, uvn, ax=b, show_box=False)
            b.title.set_fontsize(7)
    fig.tight_layout()
    files.append(save_figure(fig, out / "compact_maps.png"))
    # --- det J and conformal heatmaps
    fig, axes = plt.subplots(2 * len(single), len(meths), figsize=(2.3 * len(meths), 4.6 * len(single)), squeeze=False)
    for i, (name, V, F) in enumerate(single):
        for j, m in enumerate(meths):
            a, b = axes[2 * i, j], axes[2 * i + 1, j]
            got = _load_uv(out, name, m, "whole")
            if got is None:
                a.set_axis_off()
                b.set_axis_off()
                continue
            Vm, Fm, uv = got
            dCi, _ = local_frames(Vm, Fm)
            fm = face_metrics(jacobians(uv, Fm, dCi))
            conf = np.where(np.isfinite(fm["conformal"]), fm["conformal"], 10.0)
            plot.plot_face_heatmap(Vm, Fm, np.clip(fm["det"], -1, 3), ax=a, cmap="RdBu", clim=(-1, 3),
                                   title=f"{_mesh_label(name)} / {LABELS.get(m, m)}: det J")
            plot.plot_face_heatmap(Vm, Fm, np.clip(conf, 1, 3), ax=b, cmap="magma_r", clim=(1, 3),
                                   title="conformal σmax/σmin")
            for ax in (a, b):
                ax.title.set_fontsize(7)
    fig.text(0.5, 0.003, "det J colour range [-1, 3] (red ≤ 0: flipped); conformal range [1, 3]", ha="center", fontsize=7)
    fig.tight_layout()
    files.append(save_figure(fig, out / "compact_heatmaps.png"))
    return files


# ------------------------------------------------------------------ CLI

def add_arguments(p):
    p.add_argument("--methods", nargs="+", default=None, metavar="M",
                   help=f"methods (default: {' '.join(METHODS)}; any key of neuraluv_paper.baselines.METHODS)")
    p.add_argument("--no-figures", action="store_true", help="skip the map and heatmap plates")


def run(args):
    bad = [m for m in (args.methods or []) if m not in ALL]
    if bad:
        raise NeuralUVError(f"unknown method(s) {', '.join(bad)}; choose from {', '.join(ALL)}")
    ov = iteration_override(args)
    res = bench(args.meshes, args.methods, preset=args.preset, quick=args.quick, output=args.output,
                resume=args.resume, seed=args.seed, device=args.device, show_progress=not args.quiet,
                figures=not args.no_figures, args=args, **ov)
    return print_report(res)
