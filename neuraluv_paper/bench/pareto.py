"""Table 6 (tab:runtime_pareto): the runtime–quality Pareto sweep over iteration budgets.

The same network (the ``paper`` preset: width 256, five layers, k = 16,
ω0 = 15, 200 warm-up iterations) is run for a fixed number of iterations with
early stopping off, on two sets: the compact charts (Hand, Bob, Camel) and
three xatlas-cut charts near 1K, 6.5K and 40K faces (the paper's "Thingi"
probe; here the registry charts closest to those sizes, midpoint-subdivided
where no native chart is within a factor 1.5). For each budget:
valid count with its denominator, median E_SD, mean min det J, mean flip
percentage and median time — and a figure of median E_SD against median time.

Python API: :func:`bench`; command line: ``neuraluv bench pareto``.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from neuraluv import plot
from neuraluv_paper.baselines import run_baseline
from neuraluv_paper.bench import paper_values as PV
from neuraluv_paper.bench.charts import chart_arrays, chart_pool, default_sources, subdivided_charts
from neuraluv_paper.bench.common import DEFAULT_MESHES, MESH_LABELS, QUICK_MESHES, load_meshes, neural_options
from neuraluv_paper.bench.provenance import (PAPER_NOTE, BenchOutput, command_line, findings_markdown, fmt_num, fmt_pct,
                                             fmt_time, fraction, markdown_table, print_report, progress, save_figure,
                                             start_run, with_paper, write_csv, write_markdown)
from neuraluv_paper.claims import heading

__all__ = ["bench", "add_arguments", "run", "closest_charts", "pareto_figure", "read_summary", "BUDGETS", "XATLAS_TARGETS"]

#: The paper's iteration budgets.
BUDGETS = [500, 750, 1000, 5000]
QUICK_BUDGETS = [10, 20, 40]
#: Face counts of the paper's three Thingi probe charts.
XATLAS_TARGETS = [1000, 6500, 40000]


def closest_charts(pool, targets=XATLAS_TARGETS, within=1.5):
    """The disk-like charts of ``pool`` closest (in log size) to each of ``targets``, each used once.

    A target with no native chart within a factor ``within`` of it takes the closest
    midpoint-subdivided copy of a native chart instead
    (:func:`~neuraluv_paper.bench.charts.subdivided_charts`, as Table 5's (tab:thingi_scale) upper strata: xatlas
    cuts no chart above about 10K faces from our meshes); its ``chart`` ends in ``/s<level>``.

    Examples
    --------
    >>> pool = [{"source": "m", "chart": i, "faces": n, "disk": True} for i, n in enumerate([900, 1200, 10000])]
    >>> [(c["chart"], c["faces"]) for c in closest_charts(pool, [1000, 6500, 40000])]
    [(0, 900), ('1/s1', 4800), ('2/s1', 40000)]
    """
    disk = [c for c in pool if c["disk"]]
    finer = subdivided_charts(disk, low=0, high=float("inf"))
    chosen = []
    for t in targets:
        def gap(c):
            return abs(math.log(c["faces"] / t))

        def free(cs):
            return [c for c in cs if all((c["source"], c["chart"]) != (d["source"], d["chart"]) for d in chosen)]

        if not free(disk):
            break
        best = min(free(disk), key=gap)
        if gap(best) > math.log(within) and free(finer):
            best = min([best, *free(finer)], key=gap)
        chosen.append(best)
    return chosen


def _xatlas_set(cache_dir, targets=XATLAS_TARGETS):
    """:func:`closest_charts` of the default sources' xatlas charts, as ``(name, V, F)``."""
    pool, _ = chart_pool(default_sources(), cache_dir)
    return [(f"{c['source']}#{c['chart']}", *chart_arrays(c)) for c in closest_charts(pool, targets)]


def bench(meshes=None, budgets=None, *, sets=("compact", "xatlas"), preset=None, quick=False, output="results/pareto",
          resume=False, seed=0, device="auto", show_progress=True, args=None, **overrides):
    """Run Table 6 (tab:runtime_pareto) and write ``runtime_pareto.{csv,md}`` and ``pareto.png``.

    Parameters
    ----------
    meshes : list of str, optional
        The compact set (default Hand, Bob, Camel; quick: procedural stand-ins).
    budgets : list of int, optional
        Iteration budgets (default 500, 750, 1000, 5000; quick 10, 20, 40).
    sets : tuple of str
        ``"compact"`` and/or ``"xatlas"`` (the 1K/6.5K/40K-face probe; skipped
        under ``quick``).
    preset : str, optional
        Default ``paper`` (``test`` under quick); early stopping is always off.

    Returns
    -------
    BenchOutput
        ``extra["summary"]``: one row per (set, budget).
    """
    budgets = sorted(budgets or (QUICK_BUDGETS if quick else BUDGETS))
    preset = preset or ("test" if quick else "paper")
    nkw = neural_options(preset, quick, seed, device, **{"early_stop": False, **overrides})
    nkw.pop("iterations", None)
    out, machine, log = start_run(output, resume=resume, device=device)
    groups = []
    if "compact" in sets:
        loaded = load_meshes(list(meshes or (QUICK_MESHES if quick else DEFAULT_MESHES)), quick)
        groups.append(("compact", loaded))
    if "xatlas" in sets and not quick:
        groups.append(("xatlas", _xatlas_set(out / "cache")))

    jobs = [(g, n, V, F, b) for g, items in groups for b in budgets for n, V, F in items]
    rows = []
    for g, n, V, F, b in progress(jobs, desc="pareto", disable=not show_progress):
        kw = {**nkw, "iterations": int(b)}
        key = (n, "neural", {k: v for k, v in kw.items() if k != "device"})

        def compute():
            res = run_baseline("neural", V, F, **kw)
            m = res.metrics
            return {"status": res.status, "valid": bool(res.status == "neural" and m.get("valid")),
                    "esd": m.get("esd"), "min_det": m.get("min_det"), "flip_percent": m.get("flip_percent"),
                    "time": float(res.time), "faces": int(len(F))}

        row = dict(log.run(key, compute))
        row.update({"set": g, "mesh": n, "iterations": int(b)})
        rows.append(row)

    summary = []
    for g, items in groups:
        for b in budgets:
            rs = [r for r in rows if r["set"] == g and r["iterations"] == b]
            if not rs:
                continue
            summary.append({"set": g, "iterations": b, "valid": sum(bool(r["valid"]) for r in rs), "n": len(rs),
                            "median_esd": float(np.median([r["esd"] for r in rs])),
                            "mean_min_det": float(np.mean([r["min_det"] for r in rs])),
                            "mean_flip": float(np.mean([r["flip_percent"] for r in rs])),
                            "median_time": float(np.median([r["time"] for r in rs]))})
    table = []
    for s in summary:
        p = PV.RUNTIME_PARETO.get(("compact" if s["set"] == "compact" else "thingi", s["iterations"]))
        table.append([f"{'Compact' if s['set'] == 'compact' else 'xatlas probe'} / {s['iterations']:,}",
                      with_paper(fraction(s["valid"], s["n"]), None if p is None else fraction(*p["valid"])),
                      with_paper(fmt_num(s["median_esd"]), None if p is None else fmt_num(p["median_esd"])),
                      with_paper(fmt_num(s["mean_min_det"], 3), None if p is None else fmt_num(p["mean_min_det"], 3)),
                      with_paper(fmt_pct(s["mean_flip"]), None if p is None else fmt_pct(p["mean_flip"])),
                      with_paper(fmt_time(s["median_time"]) + "s", None if p is None else fmt_time(p["median_time"]) + "s")])
    findings = _findings(summary)
    members = "; ".join(f"{g}: " + ", ".join(f"{MESH_LABELS.get(n, n)} ({len(F):,} faces)" for n, _, F in items)
                        for g, items in groups)
    body = [f"Preset `{preset}` with early stopping off" + (f", overrides {overrides}" if overrides else "")
            + f"; seed {seed}. Sets — {members}. The paper's rows ran on CUDA; ours on the device below.", "",
            markdown_table(["Set / iters", "Valid", "Med. E_SD", "Mean min det J", "Mean flip", "Med. time"], table),
            "", "![pareto](pareto.png)"]
    fm = findings_markdown(findings)
    if fm:
        body += ["", fm]
    body += ["", f"Paper caption: “{PV.CAPTIONS['tab:runtime_pareto']}”"]
    notes = [PAPER_NOTE, "The xatlas probe stands in for the paper's Thingi charts (≈1K, 6.5K, 40K faces): the "
             "disk-like registry charts closest in size (see the set list above); where no native xatlas chart is "
             "within a factor 1.5 of the target, the closest midpoint-subdivided copy of one (named `.../s<level>`: "
             "the same surface and boundary, each triangle split into 4 per level), as in Table 5 (tab:thingi_scale)."]
    if log.skipped:
        notes.append(f"{log.skipped} row(s) taken from the resume log.")
    files = [write_csv(out / "runtime_pareto_runs.csv", rows), write_csv(out / "runtime_pareto.csv", summary),
             _figure(out, summary)]
    md = write_markdown(out / "runtime_pareto.md", heading("tab:runtime_pareto", "runtime–quality Pareto sweep"), "\n".join(body),
                        command=command_line("pareto", args), machine=machine, notes=notes, findings=findings)
    files.append(md)
    return BenchOutput("pareto", rows, md.read_text(), files, findings, log.skipped, {"summary": summary})


def _findings(summary):
    F = []
    for g in ("compact", "xatlas"):
        ss = [s for s in summary if s["set"] == g]
        if len(ss) < 2:
            continue
        allv = all(s["valid"] == s["n"] for s in ss)
        F.append((f"{g}: every budget stays zero-flip", allv,
                  ", ".join(f"{s['iterations']}: {fraction(s['valid'], s['n'])}" for s in ss)))
        e = [s["median_esd"] for s in ss]
        if g == "compact":
            gain_last = (e[-2] - e[-1]) / e[-2] if e[-2] else 0
            F.append(("compact: median E_SD saturates (little gain from the last budget increase)", gain_last <= 0.05,
                      f"median E_SD {', '.join(fmt_num(x) for x in e)}; last step gains {100 * gain_last:.1f}%"))
        else:
            F.append(("larger charts keep improving with more iterations", e[-1] < e[0],
                      f"median E_SD {', '.join(fmt_num(x) for x in e)}"))
    return F


def read_summary(folder=None):
    """The committed sweep's summary rows (``runtime_pareto.csv``: set, iterations, valid, n, median_esd,
    mean_min_det, mean_flip, median_time; numbers as floats). Default folder: ``results/pareto``."""
    import csv

    from neuraluv_paper.claims import results_dir

    path = Path(folder if folder is not None else results_dir() / "pareto") / "runtime_pareto.csv"
    with path.open(newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return [{k: (v if k == "set" else float(v)) for k, v in r.items()} for r in rows]


def pareto_figure(summary, ax=None, *, title="Runtime–quality trade-off (budget annotated)"):
    """The paper's Fig. 9 (fig:runtime_pareto) on our data: median E_SD against median runtime per iteration budget.

    Our sets (solid, budget annotated) beside the paper's published CUDA points (dashed, hollow;
    :data:`~neuraluv_paper.bench.paper_values.RUNTIME_PARETO`). Both axes are logarithmic with plain tick labels.

    Parameters
    ----------
    summary : list of dict
        Rows with ``set`` ("compact" / "xatlas"), ``iterations``, ``n``, ``median_esd``, ``median_time``
        (:func:`bench`'s summary, or :func:`read_summary`).
    ax : matplotlib Axes, optional
    title : str

    Returns
    -------
    ax : matplotlib Axes
    """
    plt = plot.pyplot()
    from matplotlib.ticker import FuncFormatter, NullFormatter

    if ax is None:
        _, ax = plt.subplots(figsize=(6.5, 4.2))
    for g, col in (("compact", "tab:blue"), ("xatlas", "tab:orange")):
        ss = sorted((s for s in summary if s["set"] == g), key=lambda s: s["iterations"])
        if ss:
            ax.plot([s["median_time"] for s in ss], [s["median_esd"] for s in ss], "o-", color=col,
                    label=f"ours (CPU): {g} ({int(ss[0]['n'])} charts)")
            for s in ss:
                ax.annotate(f"{int(s['iterations'])}", (s["median_time"], s["median_esd"]), fontsize=7,
                            textcoords="offset points", xytext=(4, 4))
        key = "compact" if g == "compact" else "thingi"
        ps = sorted((it, v) for (k, it), v in PV.RUNTIME_PARETO.items() if k == key)
        ax.plot([v["median_time"] for _, v in ps], [v["median_esd"] for _, v in ps], "o--", mfc="none", color=col,
                alpha=0.6, label=f"paper (CUDA): {key}")
        for it, v in ps:
            ax.annotate(f"{it}", (v["median_time"], v["median_esd"]), fontsize=6, color=col, alpha=0.8,
                        textcoords="offset points", xytext=(4, -9))
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain = FuncFormatter(lambda x, _: f"{x:g}")
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_formatter(plain)
    ax.yaxis.set_minor_formatter(FuncFormatter(lambda x, _: f"{x:g}" if f"{x:g}"[0] in "246" else ""))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("median time (s)")
    ax.set_ylabel("median E_SD")
    ax.legend(fontsize=7)
    ax.set_title(title, fontsize=9)
    return ax


def _figure(out, summary):
    ax = pareto_figure(summary)
    ax.figure.tight_layout()
    return save_figure(ax.figure, Path(out) / "pareto.png", dpi=100)



def add_arguments(p):
    p.add_argument("--budgets", nargs="+", type=int, default=None, help="iteration budgets (default 500 750 1000 5000)")
    p.add_argument("--sets", nargs="+", choices=["compact", "xatlas"], default=["compact", "xatlas"],
                   help="which sets to run (default both)")


def run(args):
    res = bench(args.meshes, args.budgets, sets=tuple(args.sets), preset=args.preset, quick=args.quick,
                output=args.output, resume=args.resume, seed=args.seed, device=args.device,
                show_progress=not args.quiet, args=args)
    return print_report(res)
