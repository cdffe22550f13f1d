"""``neuraluv bench speed --pareto``: the Pareto study behind the ``fast`` preset's design.

Network width and depth, ω₀, optimiser and budget are varied on the compact charts
(Camel, Hand, Bob); ``pareto.{csv,md,png}`` put E_SD against time beside the paper's
Pareto points and SLIM's from the same start.
"""
from __future__ import annotations

import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from neuraluv import datasets
from neuraluv.jacobian import local_frames
from neuraluv.solver.config import get_config
from neuraluv.solver.device import resolve_device
from neuraluv_paper.bench import paper_values as PV
from neuraluv_paper.bench.common import slim_reference
from neuraluv_paper.bench.provenance import (BenchOutput, command_line, machine_info, markdown_table, save_figure,
                                             write_csv, write_markdown)

__all__ = ["pareto", "DEFAULT_GRID", "PARETO_BUDGETS", "PARETO_MESHES"]


#: The designs compared for ``fast``: overrides of the ``paper`` preset (its recipe: LBO features, Tutte
#: residual start, C² objective + barrier, validity-checked steps). The paper's network comes first.
DEFAULT_GRID = [
    {"label": "paper 5x256 w15 Adam", "iterations": 1500},
    {"label": "4x64 w15 Adam", "width": 64, "n_layers": 4, "iterations": 3000},
    {"label": "4x64 w45 Adam lr2e-3", "width": 64, "n_layers": 4, "omega0": 45.0, "lr": 2e-3, "step_recover": 1.1,
     "iterations": 3000},
    {"label": "4x64 w15 L-BFGS", "width": 64, "n_layers": 4, "optimizer": "lbfgs", "lr": 1e-2, "iterations": 3000},
    {"label": "4x64 w30 L-BFGS", "width": 64, "n_layers": 4, "omega0": 30.0, "optimizer": "lbfgs", "lr": 1e-2, "iterations": 3000},
    {"label": "4x64 w45 L-BFGS", "width": 64, "n_layers": 4, "omega0": 45.0, "optimizer": "lbfgs", "lr": 1e-2, "iterations": 3000},
    {"label": "4x64 w60 L-BFGS", "width": 64, "n_layers": 4, "omega0": 60.0, "optimizer": "lbfgs", "lr": 1e-2, "iterations": 3000},
    {"label": "4x64 w60 L-BFGS m10", "width": 64, "n_layers": 4, "omega0": 60.0, "optimizer": "lbfgs", "lr": 1e-2, "history": 10,
     "iterations": 3000},
    {"label": "4x48 w60 L-BFGS", "width": 48, "n_layers": 4, "omega0": 60.0, "optimizer": "lbfgs", "lr": 1e-2, "iterations": 3000},
    {"label": "4x96 w60 L-BFGS", "width": 96, "n_layers": 4, "omega0": 60.0, "optimizer": "lbfgs", "lr": 1e-2, "iterations": 3000},
    {"label": "3x64 w60 L-BFGS", "width": 64, "n_layers": 3, "omega0": 60.0, "optimizer": "lbfgs", "lr": 1e-2, "iterations": 3000},
    {"label": "5x64 w60 L-BFGS", "width": 64, "n_layers": 5, "omega0": 60.0, "optimizer": "lbfgs", "lr": 1e-2, "iterations": 3000},
]
PARETO_BUDGETS = (100, 250, 500, 750, 1000, 1500, 2000, 3000)
PARETO_MESHES = ("camel", "hand", "bob")


def pareto(grid=None, meshes=PARETO_MESHES, *, output="results/speed", device="cpu", budgets=PARETO_BUDGETS,
           quick=False, argv=None, show_progress=True):
    """E_SD against time of candidate ``fast`` designs on the compact charts (``pareto.{csv,md,png}``).

    Every design runs once per chart with early stopping off; the E_SD after
    ``k`` accepted steps (the best so far) and the wall time to reach it
    (features and start included) give one point per budget ``k``. SLIM-100 and
    SLIM-1k from the same starts are run alongside.
    """
    from neuraluv.solver.chart import prepare_chart, solve_charts

    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    dev = resolve_device(device)
    grid = [dict(g) for g in (grid or DEFAULT_GRID)]
    if quick:
        grid = [dict(g, iterations=min(g.get("iterations", 100), 60)) for g in grid[3:5]]
        meshes, budgets = ("glove",), (20, 60)
    machine = machine_info(dev)
    charts = {m: datasets.load_charts(m) for m in meshes}
    rows = []
    for m, cs in charts.items():
        preps = [prepare_chart(V, F, "paper") for V, F in cs]
        for its in (10, 100) if quick else (100, 1000):
            dt, esd, flips = slim_reference(preps, its)
            rows.append({"design": f"SLIM-{its if its < 1000 else '1k'}", "mesh": m, "iterations": its, "esd": esd,
                         "time": dt, "flips": flips})
    for spec in grid:
        label = spec.pop("label")
        cfg = get_config("paper", early_stop=False, **spec)
        for m, cs in charts.items():
            t = time.perf_counter()
            rs = solve_charts(cs, cfg, device=dev)
            wall = time.perf_counter() - t
            w = np.array([local_frames(V, F)[1].sum() for V, F in cs])
            solve = max((r.trace["time"][-1] if r.trace["time"] else 0.0) for r in rs)
            prep = wall - solve
            for k in budgets:
                if k > cfg.iterations:
                    continue
                vals, tk = [], 0.0
                for r in rs:
                    e = r.trace["esd"][:k]
                    vals.append(min(e) if e else float("nan"))
                    if r.trace["time"]:
                        tk = max(tk, r.trace["time"][min(k, len(r.trace["time"])) - 1])
                rows.append({"design": label, "mesh": m, "iterations": k, "esd": float(np.dot(vals, w) / w.sum()),
                             "time": prep + tk, "flips": sum(r.metrics["flips"] for r in rs),
                             **{f"cfg_{a}": b for a, b in spec.items()}})
            if show_progress:
                print(f"pareto {label:24s} {m:6s} E_SD {rows[-1]['esd']:.4f} after {rows[-1]['iterations']} its, "
                      f"{wall:6.1f}s", flush=True)
    cmd = command_line("speed") if argv is None else "neuraluv " + " ".join(argv)
    files = [write_csv(out / "pareto.csv", rows)]
    md = _pareto_markdown(rows, list(charts))
    files.append(write_markdown(out / "pareto.md", "The fast preset's Pareto study: E_SD against time", md,
                                command=cmd, machine=machine))
    files.append(_pareto_figure(rows, list(charts), out / "pareto.png"))
    return BenchOutput(name="pareto-fast", rows=rows, markdown=md, files=files)


def _median_rows(rows, meshes):
    """Per (design, iterations): the median E_SD and median time over the meshes."""
    out = {}
    for r in rows:
        out.setdefault((r["design"], r["iterations"]), {})[r["mesh"]] = r
    med = []
    for (design, k), by in out.items():
        if set(by) >= set(meshes):
            med.append({"design": design, "iterations": k, "esd": float(np.median([by[m]["esd"] for m in meshes])),
                        "time": float(np.median([by[m]["time"] for m in meshes])),
                        "per_mesh": {m: (by[m]["esd"], by[m]["time"]) for m in meshes}})
    return med


def _pareto_markdown(rows, meshes):
    med = _median_rows(rows, meshes)
    head = ["design", "iterations", "median E_SD", "median time (s)"] + [f"{m} E_SD (s)" for m in meshes]
    body = [[r["design"], r["iterations"], f"{r['esd']:.3f}", f"{r['time']:.2f}"]
            + [f"{r['per_mesh'][m][0]:.3f} ({r['per_mesh'][m][1]:.1f})" for m in meshes] for r in med]
    paper = [[f"paper (CUDA), compact / {k}", k, f"{v['median_esd']:.2f}", f"{v['median_time']:.2f}"] + ["—"] * len(meshes)
             for (s, k), v in sorted(PV.RUNTIME_PARETO.items()) if s == "compact"]
    front = _front(med)
    text = [markdown_table(head, body), "", "The paper's compact-chart Pareto points (Table 6, tab:runtime_pareto; CUDA GPU; the median over "
            "Hand, Bob and Camel):", "", markdown_table(head, paper), "",
            "Pareto front on this machine (no design is both faster and lower in median E_SD): "
            + ", ".join(f"{r['design']} @ {r['iterations']} ({r['esd']:.3f} in {r['time']:.1f}s)" for r in front) + "."]
    return "\n".join(text)


def _front(med):
    pts = sorted(med, key=lambda r: (r["time"], r["esd"]))
    front, best = [], float("inf")
    for r in pts:
        if r["esd"] < best - 1e-12:
            front.append(r)
            best = r["esd"]
    return front


def _pareto_figure(rows, meshes, path):
    med = _median_rows(rows, meshes)
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    designs = list(dict.fromkeys(r["design"] for r in med))
    for d in designs:
        pts = sorted((r for r in med if r["design"] == d), key=lambda r: r["iterations"])
        style = dict(marker="s", ms=7, ls="none") if d.startswith("SLIM") else dict(marker="o", ms=3)
        ax.plot([p["time"] for p in pts], [p["esd"] for p in pts], label=d, **style)
    pp = [v for (s, k), v in sorted(PV.RUNTIME_PARETO.items()) if s == "compact"]
    ax.plot([v["median_time"] for v in pp], [v["median_esd"] for v in pp], "k*--", ms=9, label="paper Table 6 (tab:runtime_pareto, CUDA)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("median wall time (s), features and start included")
    ax.set_ylabel(f"median E_SD over {', '.join(meshes)}")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=6.5, ncol=2)
    fig.tight_layout()
    return save_figure(fig, path, dpi=110)


# --------------------------------------------------------------------------- atlas throughput
