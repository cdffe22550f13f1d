#!/usr/bin/env python
"""Issue-2 acceptance: the neural solver on the paper's compact charts.

For Camel, Hand and Bob (every component) this runs, in one process:
the ``paper`` preset, the ``fast`` preset, and libigl SLIM with 1,000
iterations from the same Tutte start, and prints one table with E_SD, flips,
min det J and wall time, next to the paper's Table 1 (tab:compact_prelim) values.

    NEURALUV_DATA=... python data_scripts/solver_acceptance.py [--meshes camel hand bob] [--skip-paper]

Times are wall seconds on this machine (the solver's ChartResult.time covers
features, Tutte, warm-up and optimisation; SLIM's covers precompute + solve).
"""
import argparse
import json
import platform
import sys
import time


from neuraluv import datasets
from neuraluv_paper.baselines import run_baseline
from neuraluv.meshfix import face_areas
from neuraluv.solver import resolve_device, solve_chart

PAPER = {"camel": 4.14, "hand": 12.73, "bob": 4.39}
TARGET = {"camel": 4.14, "hand": 13.5, "bob": 4.39}


def charts(name):
    for i, (V, F) in enumerate(datasets.load_charts(name)):
        yield f"{name}[{i}]" if name == "bob" else name, V, F


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--meshes", nargs="*", default=["camel", "hand", "bob"])
    p.add_argument("--skip-paper", action="store_true")
    p.add_argument("--json", help="also write the rows here")
    a = p.parse_args(argv)
    import torch

    print(f"# machine: {platform.processor() or platform.machine()}, {torch.get_num_threads()} torch threads, "
          f"device {resolve_device('auto')}, torch {torch.__version__}, {time.strftime('%Y-%m-%d %H:%M')}")
    rows = []
    hdr = f"{'chart':10s} {'method':8s} {'E_SD':>9s} {'flips':>6s} {'min det':>9s} {'time s':>8s} {'iters':>6s} {'status':8s}"
    print(hdr)
    for name in a.meshes:
        for label, V, F in charts(name):
            runs = [] if a.skip_paper else [("paper", lambda: solve_chart(V, F, "paper", label=label))]
            runs += [("fast", lambda: solve_chart(V, F, "fast", label=label)),
                     ("slim-1k", lambda: run_baseline("slim-1k", V, F))]
            for method, fn in runs:
                r = fn()
                m = r.metrics
                its = len(r.trace.get("iter", [])) if r.trace else 1000
                row = dict(chart=label, method=method, area=float(face_areas(V, F).sum()), esd=m["esd"], flips=m["flips"], min_det=m["min_det"],
                           time=r.time, iterations=its, status=r.status)
                rows.append(row)
                print(f"{label:10s} {method:8s} {m['esd']:9.4f} {m['flips']:6d} {m['min_det']:9.3g} {r.time:8.1f} {its:6d} {r.status:8s}", flush=True)
    print("\n# summary (E_SD area-weighted over a mesh's charts; paper = Table 1 (tab:compact_prelim) 'Ours')")
    for name in a.meshes:
        for method in (["paper"] if not a.skip_paper else []) + ["fast", "slim-1k"]:
            rs = [r for r in rows if r["chart"].startswith(name) and r["method"] == method]
            if not rs:
                continue
            flips = sum(r["flips"] for r in rs)
            esd = sum(r["esd"] * r["area"] for r in rs) / sum(r["area"] for r in rs)
            t = sum(r["time"] for r in rs)
            print(f"{name:6s} {method:8s} flips {flips:3d}  E_SD {esd:8.4f}  "
                  f"paper {PAPER[name]:6.2f}  target <= {TARGET[name]:5.2f}  time {t:7.1f}s")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
