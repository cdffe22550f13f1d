"""``neuraluv bench ntk --trajectory``: the NTK–LBO alignment followed over a solve (the paper's Fig. 8, fig:ntk_trajectory).

For each of ``n_charts`` xatlas charts the probe records S(16) along the
optimisation of the recipe (Tutte residual) and of a random absolute start, and
correlates the alignment with the flip rate and the determinant margin (Pearson r
beside the paper's). ``trajectory_probe.{csv,png}`` and a Markdown block for ``ntk_compact_controls.md``.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from neuraluv import plot
from neuraluv.solver import get_config, solve_chart
from neuraluv_paper.bench.charts import chart_pool, default_sources, select_charts
from neuraluv_paper.bench.provenance import progress
from neuraluv_paper.ntk import TrajectoryRecorder, make_probe

__all__ = ["trajectory_probe", "pearson", "probe_markdown", "probe_figure", "draw_probe", "milestones",
           "PAPER_PROBE_R", "PROBE_RUNS"]


def milestones(n):
    """Probe steps during an ``n``-iteration solve (5, 10, 25, 50, 75 %).

    Examples
    --------
    >>> milestones(100)
    [5, 10, 25, 50, 75]
    """
    return sorted({max(1, int(round(f * n))) for f in (0.05, 0.1, 0.25, 0.5, 0.75)} - {n}) if n > 0 else []


#: The paper's strongest |r| of early S(r) with the final flip rate / final det margin (Fig. 8 (fig:ntk_trajectory) and its text).
PAPER_PROBE_R = {"flip_percent": 0.41, "min_det": 0.44}
PROBE_RUNS = (("tutte-residual", {}), ("random-absolute", {"init": "random", "residual": False}))


def pearson(x, y):
    """Pearson r of two samples (nan when either is constant or fewer than 3 pairs).

    Examples
    --------
    >>> round(pearson([1, 2, 3, 4], [2, 4, 5, 9]), 3), pearson([1, 2, 3], [5, 5, 5])
    (0.965, nan)
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan")
    return float(np.corrcoef(x, y)[0, 1])


def trajectory_probe(n_charts=25, faces=(300, 3000), preset="paper", iterations=1000, *, samples=256, seed=0,
                     device="auto", cache_dir=None, show_progress=True, sources=None):
    """The paper's trajectory probe (Fig. 8): S(r) over the solve on xatlas charts, and its correlation with the outcome.

    Parameters
    ----------
    n_charts : int
        Disk-like xatlas charts of the default sources, taken evenly over ``faces``.
    faces : (int, int)
        Face-count range of the charts.
    preset, iterations : solver preset and budget (no retries: the outcome is the attempt's).
    sources : list of str, optional
        Meshes to cut (default :func:`neuraluv_paper.bench.charts.default_sources`).

    Returns
    -------
    dict
        ``rows`` (one per run and probed step: S4/S8/S16, the run's final flip %, min det J, validity),
        ``correlations`` (Pearson r of each early feature with each outcome, over all runs and over the
        recipe's runs), ``checks`` (claims) and ``charts`` / ``runs`` counts.
    """
    pool, _ = chart_pool(sources or default_sources(), cache_dir)
    chosen = select_charts(pool, n_charts, [(faces[0], faces[1] + 1, "probe")])
    rows, runs = [], []
    for c in progress(chosen, desc="trajectory probe", disable=not show_progress):
        name = f"{c['source']}#{c['chart']}"
        V, F = c["V"], c["F"]
        probe = make_probe(V, F, 16, n_samples=samples, r_max=16, start=0)
        for run, kw in PROBE_RUNS:
            cfg = get_config(preset, k=16, iterations=iterations, retries=0, **kw)
            rec = TrajectoryRecorder(probe, milestones(iterations))
            res = solve_chart(V, F, cfg, seed=seed, device=device, callback=rec, label=name)
            m = res.attempt_metrics[0]
            out = {"chart": name, "faces": len(F), "run": run, "ends_valid": bool(m["valid"]),
                   "flip_percent_final": float(m["flip_percent"]), "min_det_final": float(m["min_det"]),
                   "esd_final": float(m["esd"]), "time_s": round(float(res.time), 2)}
            recs = rec.of_attempt(0)
            runs.append({**out, "features": {(r["event"], r["step"]): r["curve"] for r in recs}})
            for r in recs:
                rows.append({**out, "event": r["event"], "step": r["step"],
                             "S4": r["curve"][3], "S8": r["curve"][7], "S16": r["curve"][15]})
    corr = []
    steps = sorted({k for run in runs for k in run["features"] if k[0] != "end"}, key=lambda k: k[1])
    for subset, sel in (("all runs", runs), ("recipe runs", [r for r in runs if r["run"] == "tutte-residual"])):
        for outcome in ("flip_percent", "min_det"):
            for ev, st in steps:
                for rank in (4, 8, 16):
                    have = [r for r in sel if (ev, st) in r["features"]]
                    corr.append({"subset": subset, "outcome": outcome, "event": ev, "step": st, "feature": f"S{rank}",
                                 "n": len(have),
                                 "r": pearson([r["features"][(ev, st)][rank - 1] for r in have],
                                              [r[f"{outcome}_final"] for r in have])})
    return {"rows": rows, "correlations": corr, "checks": probe_checks(runs, corr), "charts": len(chosen),
            "runs": [{k: v for k, v in r.items() if k != "features"} for r in runs], "preset": preset,
            "iterations": iterations, "faces": faces}


def probe_checks(runs, corr):
    checks = []
    valid = [r for r in runs if r["ends_valid"]]
    invalid = [r for r in runs if not r["ends_valid"]]
    recipe = [r for r in runs if r["run"] == "tutte-residual"]
    checks.append(("Some charts of the probe end invalid under the recipe (paper: its 25 Thingi charts split into "
                   "valid- and invalid-ending groups)", any(not r["ends_valid"] for r in recipe), f"{sum(r['ends_valid'] for r in recipe)}/{len(recipe)} recipe runs end valid; random absolute "
                   f"init: {sum(r['ends_valid'] for r in runs if r['run'] != 'tutte-residual')}/{len(runs) - len(recipe)}"))

    def drift(group):
        d = [r["features"] for r in group]
        out = []
        for f in d:
            ks = sorted(f, key=lambda k: (k[0] == "end", k[1]))
            s0 = next(f[k][15] for k in ks if k[0] == "warmup_end")
            out.append(abs(f[ks[-1]][15] - s0))
        return float(np.mean(out)) if out else float("nan")

    dv, di = drift(valid), drift(invalid)
    if valid and invalid:
        checks.append(("Charts that end valid drift away from the initial NTK–LBO subspace; charts that end invalid "
                       "stay stuck", dv > di,
                       f"mean |S(16) end − S(16) after warm-up|: {dv:.3f} over {len(valid)} valid-ending runs vs "
                       f"{di:.3f} over {len(invalid)} invalid-ending runs"))
    for outcome, label in (("flip_percent", "final flip rate"), ("min_det", "final determinant margin")):
        best = {}
        for subset in ("recipe runs", "all runs"):
            cs = [c for c in corr if c["subset"] == subset and c["outcome"] == outcome and np.isfinite(c["r"])]
            if cs:
                best[subset] = max(cs, key=lambda c: abs(c["r"]))
        claim = (f"Early S(r) correlates only moderately with the {label} (paper: strongest |r| "
                 f"{PAPER_PROBE_R[outcome]} over its 25 charts)")
        pooled = (f"; pooled with the random-init runs |r| {abs(best['all runs']['r']):.2f} "
                  f"({best['all runs']['feature']} {_at(best['all runs'])}, n={best['all runs']['n']}; it mostly "
                  "separates the two initialisations)") if "all runs" in best else ""
        b = best.get("recipe runs")
        if b is None:
            checks.append((claim, None, f"the recipe's runs show no variance in the {label}: not testable" + pooled))
            continue
        checks.append((claim, abs(b["r"]) < 0.7,
                       f"the recipe's runs: strongest |r| {abs(b['r']):.2f} ({b['feature']} {_at(b)}, n={b['n']})" + pooled))
    return checks


def _at(c):
    return "after warm-up" if c["event"] == "warmup_end" else f"at step {c['step']}"


def probe_markdown(probe):
    runs = probe["runs"]
    L = ["## Trajectory probe (the paper's Fig. 8, fig:ntk_trajectory)", ""]
    L.append(f"{probe['charts']} disk-like xatlas charts of {probe['faces'][0]:,}–{probe['faces'][1]:,} faces; preset "
             f"`{probe['preset']}`, {probe['iterations']} iterations, k = 16, no retry; per chart the recipe's solve "
             "(Tutte residual) and the random absolute initialisation. S(r) probed after warm-up, at 5/10/25/50/75% "
             "of the budget and at the end (`trajectory_probe.csv`, figure `trajectory_probe.png`).")
    L.append("")
    L.append("| Run | Runs | End valid | Median final flip % | Median final min det J | Mean S(16) after warm-up | Mean S(16) at end |")
    L.append("|:--|--:|--:|--:|--:|--:|--:|")
    for run, _ in PROBE_RUNS:
        rs = [r for r in runs if r["run"] == run]
        if not rs:
            continue
        s0 = [r["S16"] for r in probe["rows"] if r["run"] == run and r["event"] == "warmup_end"]
        s1 = [r["S16"] for r in probe["rows"] if r["run"] == run and r["event"] == "end"]
        L.append(f"| {run} | {len(rs)} | {sum(r['ends_valid'] for r in rs)}/{len(rs)} | "
                 f"{np.median([r['flip_percent_final'] for r in rs]):.3g} | {np.median([r['min_det_final'] for r in rs]):.3g} | "
                 f"{np.mean(s0):.3f} | {np.mean(s1):.3f} |")
    L.append("")
    L.append("Strongest correlations of an early S(r) (after warm-up up to 75% of the budget) with the outcome "
             "(`probe_correlations.csv` has all of them):")
    L.append("")
    L.append("| Outcome | Runs | Strongest |r| | Feature | Probed at | n | Paper |")
    L.append("|:--|:--|--:|:--|:--|--:|--:|")
    for outcome in ("flip_percent", "min_det"):
        for subset in ("all runs", "recipe runs"):
            cs = [c for c in probe["correlations"] if c["subset"] == subset and c["outcome"] == outcome
                  and np.isfinite(c["r"])]
            if not cs:
                L.append(f"| final {outcome} | {subset} | — (no variance) | | | | {PAPER_PROBE_R[outcome]} |")
                continue
            b = max(cs, key=lambda c: abs(c["r"]))
            L.append(f"| final {outcome} | {subset} | {abs(b['r']):.2f} | {b['feature']} | {_at(b)} | "
                     f"{b['n']} | {PAPER_PROBE_R[outcome]} |")
    L.append("")
    return L


def probe_figure(out):
    """Redraw ``trajectory_probe.png`` in ``out`` from its ``trajectory_probe.csv`` and ``probe_correlations.csv``."""
    out = Path(out)

    def read(name, num):
        with open(out / name, newline="") as fh:
            rows = list(csv.DictReader(fh))
        for r in rows:
            for k in num:
                r[k] = float(r[k]) if r[k] not in ("", "None") else float("nan")
            if "step" in r:
                r["step"] = int(r["step"])
            if "ends_valid" in r:
                r["ends_valid"] = r["ends_valid"] == "True"
        return rows

    rows = read("trajectory_probe.csv", ("S4", "S8", "S16"))
    corr = read("probe_correlations.csv", ("r",))
    return draw_probe({"rows": rows, "correlations": corr, "charts": len({r["chart"] for r in rows})},
                         out / "trajectory_probe.png")


def draw_probe(probe, path):
    plt = plot.pyplot()
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4), gridspec_kw={"width_ratios": [1.3, 1]})
    groups = {}
    for r in probe["rows"]:
        groups.setdefault((r["chart"], r["run"]), []).append(r)
    # a run that stops early keeps its network: its S(16) holds to the end of the budget
    budget = max(r["step"] for r in probe["rows"])
    grid = sorted({r["step"] for r in probe["rows"] if r["event"] != "end"} | {budget})
    mean = {True: [], False: []}
    for (chart, run), rs in groups.items():
        ok = rs[0]["ends_valid"]
        rs = sorted(rs, key=lambda r: (r["step"], r["event"] == "end"))
        held = [next(r for r in reversed(rs) if r["step"] <= g)["S16"] for g in grid]
        ax.plot(grid, held, color="tab:blue" if ok else "tab:red", lw=0.6, alpha=0.35,
                ls="-" if run == "tutte-residual" else "--")
        mean[ok].append(held)
    for ok, col in ((True, "tab:blue"), (False, "tab:red")):
        if mean[ok]:
            ax.plot(grid, np.mean(mean[ok], axis=0), color=col, lw=2.5, marker="o", ms=3,
                    label=f"{'ends valid' if ok else 'ends invalid'} (mean of {len(mean[ok])} runs)")
    ax.set_xlabel("optimisation step (0 = end of warm-up)")
    ax.set_ylabel("S(16)")
    ax.set_ylim(0, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, title="solid: recipe, dashed: random init", title_fontsize=7)
    ax.set_title(f"NTK–LBO alignment over the solve, {probe['charts']} xatlas charts", fontsize=9)
    cs = [c for c in probe["correlations"] if c["subset"] == "all runs"]
    cols = sorted({(c["event"], c["step"]) for c in cs}, key=lambda k: k[1])
    feats = ["S4", "S8", "S16"]
    grid = np.full((2 * len(feats), len(cols)), np.nan)
    for c in cs:
        i = ["flip_percent", "min_det"].index(c["outcome"]) * len(feats) + feats.index(c["feature"])
        grid[i, cols.index((c["event"], c["step"]))] = abs(c["r"])
    im = ax2.imshow(grid, vmin=0, vmax=1, cmap="viridis", aspect="auto")
    ax2.set_xticks(range(len(cols)), ["warm-up" if e == "warmup_end" else f"{s}" for e, s in cols], fontsize=7)
    ax2.set_yticks(range(grid.shape[0]), [f"flip %: {f}" for f in feats] + [f"min det: {f}" for f in feats], fontsize=7)
    ax2.set_xlabel("probed at step")
    ax2.set_title("|r| of early S(r) with the final outcome (all runs)", fontsize=9)
    for i in range(grid.shape[0]):
        for j in range(grid.shape[1]):
            if np.isfinite(grid[i, j]):
                ax2.text(j, i, f"{grid[i, j]:.2f}", ha="center", va="center", fontsize=6,
                         color="w" if grid[i, j] < 0.6 else "k")
    fig.colorbar(im, ax=ax2, fraction=0.046, label="|r|")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
