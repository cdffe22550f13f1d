#!/usr/bin/env python
"""Texture repair of the authored assets under more damage seeds than ``bench authored`` runs.

    NEURALUV_DATA=.cache/neuraluv-data python data_scripts/authored_damage_sweep.py [FIRST LAST]

For every authored asset (``make data``) and seeds ``FIRST..LAST-1`` (default 10..13) of the benchmark's
three damages (:func:`neuraluv_paper.bench.authored._damaged`: a local fold on the largest island, 1%
vertex noise, three NaN rows), :func:`~neuraluv.repair.repair_layout` under the ``texture`` purpose with
the CLI's tolerance, in process, one thread (torch and BLAS). Prints per case whether the result is
valid, the share of the faces the damage left alone that stayed bit-identical, of all faces, and the
seconds; a summary per damage; and flags (``<--``) the cases that are not valid, keep less than 90% of
the faces outside the damage, or take over 10 s. Figures quoted in the issue-27 notes.
"""
import sys
import time
import warnings

import numpy as np


def main(first=10, last=14):
    warnings.filterwarnings("ignore")
    import torch
    from threadpoolctl import threadpool_limits

    from neuraluv import datasets
    from neuraluv.io import read_layout
    from neuraluv.layout import DEFECT_TEXELS
    from neuraluv.repair.repair import repair_layout
    from neuraluv_paper.bench.authored import _damaged

    torch.set_num_threads(1)
    names = [n for n in sorted(datasets.AUTHORED) if n.endswith((".obj", ".glb"))]
    tally = {}
    with threadpool_limits(1, "blas"):
        for name in names:
            try:
                V, F, UV, FUV, _ = read_layout(datasets.authored_path(name))
            except datasets.DataMissing as exc:
                print(f"authored_damage_sweep: {exc}")
                return 2
            for kind in ("local fold", "vertex noise", "NaN UVs"):
                for seed in range(first, last):
                    try:
                        bad = _damaged(kind, V, F, UV, FUV, seed)
                    except ValueError:  # the island is too small for this damage
                        continue
                    moved = ~((bad == UV) | (np.isnan(bad) & np.isnan(UV))).all(1)
                    untouched = ~moved[np.maximum(FUV, 0)].any(1)
                    t = time.perf_counter()
                    r = repair_layout(V, F, bad, FUV, purpose="texture", min_defect=DEFECT_TEXELS, device="cpu")
                    dt = time.perf_counter() - t
                    kept = float(1 - r.changed_faces[untouched].mean()) if untouched.any() else float("nan")
                    flag = "" if r.after.ok and not kept < 0.9 and dt <= 10 else "  <--"
                    tally.setdefault(kind, []).append((r.after.ok, kept, dt))
                    print(f"{name:34s} {kind:12s} {seed:3d} valid {str(r.after.ok):5s} kept outside the damage "
                          f"{100 * kept:5.1f}%, all {100 * (1 - r.changed_faces.mean()):5.1f}%, {dt:5.1f} s{flag}",
                          flush=True)
    for kind, rows in tally.items():
        ok, kept, dt = (np.array(c, float) for c in zip(*rows))
        print(f"{kind}: valid {int(ok.sum())}/{len(ok)}; kept outside the damage median {100 * np.nanmedian(kept):.1f}%"
              f" (>= 90% in {int((kept >= 0.9).sum())}/{int(np.isfinite(kept).sum())}); seconds median "
              f"{np.median(dt):.1f}, max {dt.max():.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(*map(int, sys.argv[1:3])))
