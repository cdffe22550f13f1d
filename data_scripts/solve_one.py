#!/usr/bin/env python
"""Solve one named chart with a preset and config overrides; print metrics and trace milestones.

    python data_scripts/solve_one.py camel paper '{"betas": [0.9, 0.95]}'
    python data_scripts/solve_one.py hand fast
    python data_scripts/solve_one.py camel paper '{"seed": 1}'

Used for the solver sweeps quoted in docs/RESULTS.md (one torch thread, so
two runs can share a 2-core machine). Multi-component inputs are solved
component by component.
"""
import json
import sys

import torch

from neuraluv import datasets
from neuraluv.solver import get_config, solve_chart


def main(argv):
    name, preset = argv[0], argv[1]
    over = json.loads(argv[2]) if len(argv) > 2 else {}
    seed = int(over.pop("seed", 0))  # the solver's first seed, not a config field
    torch.set_num_threads(1)
    for V, F in datasets.load_charts(name):
        r = solve_chart(V, F, get_config(preset, **over), seed=seed, device="cpu")
        t = r.trace
        n = len(t["esd"])
        m = {k: round(v, 4) if isinstance(v, float) else v for k, v in r.metrics.items()}
        print(name, preset, over, "seed", seed, r.status, r.start, m, "time", round(r.time, 1), r.stop,
              "rejected", t["rejected"][-1] if n else 0,
              "iterations", n, flush=True)
        if r.reason:
            print("   reason:", r.reason)
        for i in sorted({0, 10, 50, 100, 200, 500, 1000, 2000, 3000, 4000, n - 1}):
            if 0 <= i < n:
                print(f"   it {i:5d}  E_SD {t['esd'][i]:10.4f}  min det {t['min_det'][i]:.2e}  "
                      f"rejected {t['rejected'][i]:5d}  lr {t['lr'][i]:.1e}  t {t['time'][i]:.1f}s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
