"""``neuraluv bench ntk``: the NTK–LBO alignment table (paper's Table 4, tab:ntk_compact_controls) on the compact charts.

For each compact chart (Hand, Bob, Camel) and each setting of Table 4 (tab:ntk_compact_controls), build
the chart network exactly as :func:`neuraluv.solver.solve_chart` does, probe
its NTK at initialisation (the ``warmup_end`` callback; the residual Tutte
warm-up is stationary) and after optimisation (``ChartResult.network``), and
average ``S(4), S(8), S(16)`` over the charts. Bob has three components; we
probe its **largest** component (2,705 of 5,647 vertices) as "the Bob chart".

Outputs (default ``results/ntk/``): ``alignment.csv`` (per chart and setting,
full curves r = 1..16, both LBO-basis conventions), ``ntk_compact_controls.csv`` and
``ntk_compact_controls.md`` (averages beside the paper's numbers, with the effect checks
computed from the data), ``alignment_curves.png``, ``run.json`` and
``trajectory.csv`` / ``trajectory.png`` (S(r) over optimisation of the k=16
solves, which end valid, and, with ``--trajectory``, of the random-init
ablation, which ends invalid). ``--probe-timing`` only times one probe per chart.

``--trajectory`` also runs the paper's **trajectory probe** (Fig. 8) on
``--probe-charts`` xatlas charts (default 25, 300–3,000 faces, taken evenly
over that range by :func:`neuraluv_paper.bench.charts.select_charts`): on each, the
recipe's solve (Tutte residual, k = 16, no retry) and the random absolute
initialisation, S(r) probed at the end of warm-up and at 5, 10, 25, 50 and 75%
of the budget. The Pearson correlations of every early S(4)/S(8)/S(16) value
with the final flip rate and the final minimum det J (the paper: strongest
|r| 0.41 and 0.44) are written to ``probe_correlations.csv`` and drawn in
``trajectory_probe.png`` beside S(16) over the solve (thin: runs; bold: means
of the runs that end valid / invalid). Our solver leaves almost every xatlas
chart valid, so the invalid-ending group comes from the random-init runs; the
correlations are given over all runs and over the recipe's runs alone.
``neuraluv bench ntk`` dispatches here (``neuraluv.cli.bench``); its common
``--resume`` option is ignored (one pass, nothing to resume).

Programmatic use::

    from neuraluv.cli import main
    raise SystemExit(main(["bench", "ntk", "--quick"]))
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from tqdm.auto import tqdm

from neuraluv import datasets
from neuraluv.errors import NeuralUVError
from neuraluv.io import write_csv
from neuraluv.plot import plot_alignment_curves
from neuraluv.solver import get_config, resolve_device, solve_chart
from neuraluv_paper.bench.ntk_trajectory import draw_probe, milestones, probe_markdown, trajectory_probe
from neuraluv_paper.bench.paper_values import NTK_COMPACT_CONTROLS
from neuraluv_paper.bench.provenance import command_line, machine_info, machine_line, write_findings
from neuraluv_paper.ntk import TrajectoryRecorder, alignment_curve, make_probe
from neuraluv_paper.claims import heading

__all__ = ["PAPER_TABLE5", "CHARTS", "SETTINGS", "add_arguments", "run", "effect_checks"]

#: Table 4 (tab:ntk_compact_controls) of the paper (compact rows average Hand, Bob, Camel):
#: ``(set, state, k, omega0) -> (S4, S8, S16)`` — the one copy in :mod:`neuraluv_paper.bench.paper_values`.
PAPER_TABLE5 = NTK_COMPACT_CONTROLS

#: The compact charts of the paper.
CHARTS = ("hand", "bob", "camel")

#: Table 4's (tab:ntk_compact_controls) compact rows: ``(state, k, omega0)``; "final" rows need a solve.
SETTINGS = (
    ("init", 0, 15.0),
    ("init", 16, 15.0),
    ("final", 0, 15.0),
    ("final", 16, 15.0),
    ("init", 16, 30.0),
)

RANK_COLS = (4, 8, 16)


def add_arguments(parser):
    """The ``bench ntk`` options beyond the shared ones (``--quick`` is the default mode)."""
    parser.add_argument("--full", action="store_true", help="the paper's 5000-iteration solves ('paper' preset)")
    parser.add_argument("--samples", type=int, default=256, help="farthest-point samples (default 256)")
    parser.add_argument("--trajectory", action="store_true",
                        help="also record S(r) during a valid-ending and an invalid-ending (random-init ablation) solve")
    parser.add_argument("--probe-charts", type=int, default=25,
                        help="with --trajectory: xatlas charts of the trajectory probe (default 25; 0: none)")
    parser.add_argument("--probe-faces", type=int, nargs=2, default=(300, 3000), metavar=("LO", "HI"),
                        help="face range of the trajectory probe's charts (default 300 3000)")
    parser.add_argument("--probe-timing", action="store_true",
                        help="only time one probe (FPS + LBO basis, NTK Gram, alignment) per chart with the preset's network, then exit")
    return parser


def _charts(args):
    return list(args.meshes or CHARTS)


def effect_checks(table):
    """Decide the paper's qualitative claims from averaged numbers.

    Parameters
    ----------
    table : dict ``(state, k, omega0) -> {"S4","S8","S16"}``

    Returns
    -------
    list of (claim, holds: bool or None, evidence str)

    Examples
    --------
    >>> t = {("init", 0, 15.0): {"S4": .2, "S8": .4, "S16": .5}, ("init", 16, 15.0): {"S4": .4, "S8": .5, "S16": .7}}
    >>> [(c[:20], h) for c, h, _ in effect_checks(t)][:1]
    [('Spectral inputs rais', True)]
    """
    out = []
    i0, i16 = table.get(("init", 0, 15.0)), table.get(("init", 16, 15.0))
    f0, f16 = table.get(("final", 0, 15.0)), table.get(("final", 16, 15.0))
    w30 = table.get(("init", 16, 30.0))
    if i0 and i16:
        d = i16["S16"] - i0["S16"]
        out.append(("Spectral inputs raise S(16) at init (k=16 vs k=0, omega0=15)", d > 0,
                    f"S(16): {i0['S16']:.3f} -> {i16['S16']:.3f} (diff {d:+.3f}; paper +0.189)"))
        d4 = i16["S4"] - i0["S4"]
        out.append(("Spectral inputs raise S(4) at init", d4 > 0, f"S(4): {i0['S4']:.3f} -> {i16['S4']:.3f} (diff {d4:+.3f}; paper +0.211)"))
    if i0 and i16 and f0 and f16:
        gi, gf = i16["S16"] - i0["S16"], f16["S16"] - f0["S16"]
        out.append(("The k=16 vs k=0 S(16) gap shrinks after optimisation", abs(gf) < abs(gi),
                    f"gap at init {gi:+.3f}, after optimisation {gf:+.3f} (paper +0.189 -> +0.090)"))
    if i16 and w30:
        d = w30["S16"] - i16["S16"]
        out.append(("omega0=30 weakens init alignment (S(16), k=16)", d < 0,
                    f"S(16): omega0=15 {i16['S16']:.3f} vs omega0=30 {w30['S16']:.3f} (diff {d:+.3f}; paper -0.112)"))
    return out


def _curve_cols(curve, prefix="s"):
    return {f"{prefix}{r}": float(v) for r, v in enumerate(curve, start=1)}


def _markdown(table, table_nc, checks, info, args, timing, per_chart, probe=None):
    L = ["# " + heading("tab:ntk_compact_controls", "NTK–LBO alignment on the compact charts"), ""]
    L.append(f"Produced by `{command_line('ntk', args)}` on {info['date']}.")
    L.append("")
    L.append(f"Charts: {', '.join(_charts(args))} (Bob: largest component). FPS samples: {args.samples}, "
             f"seed {args.seed}. Solves: preset `{timing['preset']}`, {timing['iterations']} iterations "
             f"({'paper budget' if timing['iterations'] >= 5000 else 'SHORT budget: final rows are not the paper protocol'}).")
    L.append(f"Wall time {timing['total']:.0f} s.")
    L.append("")
    L.append("S(r) = ||Q_r^T Psi_r||_F^2 / r; Q_r = top-r eigenvectors of the NTK Gram (traced over both UV outputs) on "
             "the samples; Psi_r = constant mode + first r-1 LBO eigenfunctions restricted to the samples, "
             "Euclidean-orthonormalised. Random-subspace baseline: r/256.")
    L.append("")
    L.append("| State | k | omega0 | S(4) ours | S(4) paper | S(8) ours | S(8) paper | S(16) ours | S(16) paper |")
    L.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for key in SETTINGS:
        if key not in table:
            continue
        p = PAPER_TABLE5.get(("compact",) + key, (float("nan"),) * 3)
        t = table[key]
        L.append(f"| {key[0]} | {key[1]} | {key[2]:g} | " + " | ".join(f"{t[f'S{r}']:.3f} | {pv:.3f}" for r, pv in zip(RANK_COLS, p)) + " |")
    L.append("")
    L.append("Sensitivity to the LBO-basis convention (Psi_r = psi_1..psi_r, constant mode excluded):")
    L.append("")
    L.append("| State | k | omega0 | S(4) | S(8) | S(16) |")
    L.append("|---|---:|---:|---:|---:|---:|")
    for key in SETTINGS:
        if key in table_nc:
            t = table_nc[key]
            L.append(f"| {key[0]} | {key[1]} | {key[2]:g} | {t['S4']:.3f} | {t['S8']:.3f} | {t['S16']:.3f} |")
    L.append("")
    stalled = sorted({r["chart"] for r in per_chart if r["state"] == "final" and r["iterations"] == 0})
    if stalled:
        L.append(f"**Note:** the solver accepted no optimisation step on {', '.join(stalled)} (every first step was "
                 "rejected by the determinant guard), so those charts' final networks equal their initial ones and "
                 "pull the final rows towards the init rows.")
        L.append("")
    L.append("## Does our data show the paper's effects?")
    L.append("")
    for claim, holds, ev in checks:
        verdict = "NOT TESTED" if holds is None else "YES" if holds else "NO"
        L.append(f"- **{claim}: {verdict}.** {ev}.")
    L.append("")
    L.append("## Per chart")
    L.append("")
    L.append("| Chart | n | State | k | omega0 | S(4) | S(8) | S(16) | valid | flips | E_SD | min det J | steps |")
    L.append("|---|---:|---|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|")
    for r in per_chart:
        esd = f"{r['esd']:.3f}" if np.isfinite(r["esd"]) else ""
        mind = f"{r['min_det']:.3g}" if np.isfinite(r["min_det"]) else ""
        L.append(f"| {r['chart']} | {r['n_vertices']} | {r['state']} | {r['k']} | {r['omega0']:g} | {r['S4']:.3f} | {r['S8']:.3f} | "
                 f"{r['S16']:.3f} | {r['valid']} | {r['flips']} | {esd} | {mind} | {r['iterations'] if r['state'] == 'final' else ''} |")
    L.append("")
    if probe is not None:
        L += probe_markdown(probe)
    L.append("Alignment is a diagnostic of update geometry, not a validity predictor (paper Sec. 5).")
    L.append("")
    L.append(machine_line(info))
    return "\n".join(L) + "\n"


def run(args):
    """Run the benchmark; returns a process exit code (0 on success)."""
    import torch


    if args.threads:
        torch.set_num_threads(int(args.threads))
    full = bool(getattr(args, "full", False))
    preset = args.preset or ("paper" if full else "fast")
    iterations = args.iterations if args.iterations is not None else (5000 if full else 200)
    if iterations < 0:
        raise NeuralUVError("--iterations must be >= 0")
    device = resolve_device(args.device)
    info = machine_info(device)
    print(f"bench ntk on {info['platform']} | CPU {info['cpu']} ({info['cores']} cores, {info['threads']} torch threads) "
          f"| torch {info['torch']} on {info['device']}")
    if not getattr(args, "probe_timing", False):
        print(f"mode: {'full' if full else 'quick'} (preset {preset}, {iterations} iterations), charts: {' '.join(_charts(args))}")
    charts = {}
    for name in _charts(args):
        try:
            charts[name] = datasets.load_charts(name, largest=True)[0]
        except datasets.DataMissing as exc:  # missing data is a user error, not a crash
            raise datasets.DataMissing(f"cannot load chart {name!r}: {exc}") from None
        except Exception as exc:
            raise NeuralUVError(f"cannot load chart {name!r}: {exc}") from exc

    if getattr(args, "probe_timing", False):
        return _probe_timing(charts, get_config(preset), args, device)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)

    settings = list(SETTINGS)
    solves = sorted({(k, w) for s, k, w in settings if s == "final"})
    inits = sorted({(k, w) for s, k, w in settings if s == "init"} - set(solves))
    n_tasks = len(charts) * (len(solves) + len(inits) + (1 if args.trajectory else 0))
    bar = tqdm(total=n_tasks, desc="bench ntk", disable=args.quiet, dynamic_ncols=True)
    per_chart, traj_rows = [], []
    t_all = time.perf_counter()
    for name, (V, F) in charts.items():
        probes = {}
        for k, w in solves + inits:
            if k not in probes:
                probes[k] = make_probe(V, F, k, n_samples=args.samples, r_max=16, start=0)
            probe = probes[k]
            final = (k, w) in solves
            n_it = iterations if final else 0
            cfg = get_config(preset, k=k, omega0=w, iterations=n_it, **({} if final else {"retries": 0}))
            rec = TrajectoryRecorder(probe, milestones(n_it) if final and k == 16 else [])
            bar.set_postfix_str(f"{name} k={k} w0={w:g} {'solve' if final else 'init'}")
            t0 = time.perf_counter()
            res = solve_chart(V, F, cfg, seed=args.seed, device=device, callback=rec, label=name)
            t_solve = time.perf_counter() - t0
            states = [("init", rec.of_attempt(0)[0], {})]  # attempt 0's untrained network
            if final:  # the returned attempt's network after optimisation
                states.append(("final", rec.of_attempt(res.seed - args.seed)[-1], res.metrics))
            for state, r, m in states:
                row = {"chart": name, "n_vertices": len(V), "state": state, "k": k, "omega0": w,
                       "S4": r["curve"][3], "S8": r["curve"][7], "S16": r["curve"][15],
                       "valid": m.get("valid", ""), "flips": m.get("flips", ""),
                       "esd": m.get("esd", np.nan), "min_det": m.get("min_det", np.nan),
                       "status": res.status if m else "", "iterations": len(res.trace.get("iter", [])) if m else 0,
                       "solve_time_s": round(t_solve, 2)}
                row.update(_curve_cols(r["curve"]))
                row.update(_curve_cols(r["curve_nc"], "nc_s"))
                per_chart.append(row)
            if final and k == 16:
                for r in rec.of_attempt(res.seed - args.seed):
                    traj_rows.append({"chart": name, "run": "tutte-residual", "ends_valid": res.valid, "event": r["event"],
                                      "step": r["step"], "S4": r["curve"][3], "S8": r["curve"][7], "S16": r["curve"][15]})
            bar.update(1)
        if args.trajectory:
            k = 16
            cfg = get_config(preset, k=k, init="random", residual=False, iterations=iterations, retries=0)
            rec = TrajectoryRecorder(probes[k], milestones(iterations))
            bar.set_postfix_str(f"{name} random-init ablation")
            res = solve_chart(V, F, cfg, seed=args.seed, device=device, callback=rec, label=name)
            ends_valid = bool(res.attempt_metrics[0]["valid"])
            for r in rec.of_attempt(0):
                traj_rows.append({"chart": name, "run": "random-absolute", "ends_valid": ends_valid, "event": r["event"],
                                  "step": r["step"], "S4": r["curve"][3], "S8": r["curve"][7], "S16": r["curve"][15],
                                  "flips_final": res.attempt_metrics[0]["flips"]})
            bar.update(1)
    bar.close()

    def average(prefix, skip=()):
        tab, curves = {}, {}
        for key in settings:
            rows = [r for r in per_chart if (r["state"], r["k"], r["omega0"]) == key and r["chart"] not in skip]
            if not rows:
                continue
            c = np.mean([[r[f"{prefix}{i}"] for i in range(1, 17)] for r in rows], axis=0)
            curves[key] = c
            tab[key] = {"S4": float(c[3]), "S8": float(c[7]), "S16": float(c[15]), "n_charts": len(rows)}
        return tab, curves

    probe = None
    if args.trajectory and getattr(args, "probe_charts", 0) > 0:
        probe = trajectory_probe(args.probe_charts, tuple(args.probe_faces), preset, iterations, samples=args.samples,
                                 seed=args.seed, device=device, cache_dir=out / "cache", show_progress=not args.quiet)
        write_csv(out / "trajectory_probe.csv", probe["rows"])
        write_csv(out / "probe_correlations.csv", probe["correlations"])
        draw_probe(probe, out / "trajectory_probe.png")
    total = time.perf_counter() - t_all
    table, curves = average("s")
    table_nc, _ = average("nc_s")
    checks = effect_checks(table) + (probe["checks"] if probe else [])
    stalled = sorted({r["chart"] for r in per_chart if r["state"] == "final" and r["iterations"] == 0})
    if stalled and len(stalled) < len(charts):
        sub, _ = average("s", skip=stalled)
        checks += [(f"{c} [without {', '.join(stalled)}]", h, e) for c, h, e in effect_checks(sub) if "after optimisation" in c]

    write_csv(out / "alignment.csv", per_chart)
    t5 = []
    for key, t in table.items():
        p = PAPER_TABLE5.get(("compact",) + key, (np.nan,) * 3)
        t5.append({"state": key[0], "k": key[1], "omega0": key[2], "n_charts": t["n_charts"],
                   "S4": round(t["S4"], 4), "S4_paper": p[0], "S8": round(t["S8"], 4), "S8_paper": p[1],
                   "S16": round(t["S16"], 4), "S16_paper": p[2],
                   "S4_nonconst": round(table_nc[key]["S4"], 4), "S8_nonconst": round(table_nc[key]["S8"], 4),
                   "S16_nonconst": round(table_nc[key]["S16"], 4)})
    write_csv(out / "ntk_compact_controls.csv", t5)
    timing = {"total": total, "preset": preset, "iterations": iterations}
    (out / "ntk_compact_controls.md").write_text(_markdown(table, table_nc, checks, info, args, timing, per_chart, probe))
    write_findings(out / "ntk_compact_controls.md", [(claim, holds, f"{ev}.") for claim, holds, ev in checks])
    (out / "run.json").write_text(json.dumps({"machine": info, "args": {k: v for k, v in vars(args).items() if k != "func"},
                                              "timing": timing, "checks": [list(c) for c in checks]}, indent=2, default=str))


    matplotlib.use("Agg", force=False)

    fig, ax = plt.subplots(figsize=(6, 4))
    plot_alignment_curves({f"{s} k={k} w0={w:g}": c for (s, k, w), c in curves.items()}, ax=ax,
                          title=f"NTK-LBO alignment, mean over {len(charts)} compact charts")
    fig.tight_layout()
    fig.savefig(out / "alignment_curves.png", dpi=110)
    plt.close(fig)
    if traj_rows:
        write_csv(out / "trajectory.csv", traj_rows)
        fig, ax = plt.subplots(figsize=(6, 4))
        for (chart, runname), grp in _groups(traj_rows):
            steps = [r["step"] for r in grp]
            ax.plot(steps, [r["S16"] for r in grp], marker="o", ms=3,
                    label=f"{chart} {runname} ({'valid' if grp[0]['ends_valid'] else 'invalid'})",
                    ls="-" if grp[0]["ends_valid"] else "--")
        ax.set_xlabel("optimisation step (0 = end of warm-up)")
        ax.set_ylabel("S(16)")
        ax.set_ylim(0, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "trajectory.png", dpi=110)
        plt.close(fig)

    print((out / "ntk_compact_controls.md").read_text())
    print(f"wrote {out}/ntk_compact_controls.md, ntk_compact_controls.csv, alignment.csv, alignment_curves.png" + (", trajectory.csv, trajectory.png" if traj_rows else "")
          + f" in {total:.0f} s")
    return 0



def _probe_timing(charts, cfg, args, device):
    """Time one full probe per chart: make_probe, the network, ntk_gram, alignment_curve."""

    from neuraluv.solver.chart import build_network, prepare_chart

    for name, (V, F) in charts.items():
        t0 = time.perf_counter()
        probe = make_probe(V, F, cfg.k, n_samples=args.samples, r_max=16)
        t1 = time.perf_counter()
        net = build_network(prepare_chart(V, F, cfg, check=False), cfg, seed=args.seed, device=device)
        t2 = time.perf_counter()
        T = probe.gram(net)
        t3 = time.perf_counter()
        curve = alignment_curve(T, probe.psi)
        t4 = time.perf_counter()
        n_par = sum(p.numel() for p in net.parameters())
        print(f"probe timing {name}: {len(V)} vertices, {len(probe.idx)} samples, network width {cfg.width} x {cfg.n_layers} layers "
              f"({n_par} parameters): FPS+LBO basis {t1 - t0:.2f} s, Tutte+network {t2 - t1:.2f} s, NTK Gram {t3 - t2:.2f} s, "
              f"alignment {t4 - t3:.3f} s; probe total (FPS+LBO+Gram+alignment) {t1 - t0 + t4 - t2:.2f} s; "
              f"S(4,8,16) = {curve[3]:.3f}, {curve[7]:.3f}, {curve[15]:.3f}")
    return 0


def _groups(rows):
    keys = []
    for r in rows:
        k = (r["chart"], r["run"])
        if k not in keys:
            keys.append(k)
    return [(k, [r for r in rows if (r["chart"], r["run"]) == k]) for k in keys]
