#!/usr/bin/env python
"""Texture repair of the authored assets under more damage seeds than ``bench authored`` runs.

    NEURALUV_DATA=.cache/neuraluv-data python data_scripts/authored_damage_sweep.py [FIRST LAST] [--more] [FILE ...]

For every authored asset (``make data``; or the layout files named) and seeds ``FIRST..LAST-1`` (default
10..13) of the benchmark's three damages (:func:`neuraluv_paper.bench.authored._damaged`: a local fold on
the largest island, 1% vertex noise, three NaN rows), and with ``--more`` four the benchmark does not make
(on the largest island: one row dragged six edge lengths away, a 2-ring patch turned over, a 2-ring patch of
NaN rows, three 1-ring folds), :func:`~neuraluv.repair.repair_layout` under the ``texture`` purpose with
the CLI's tolerance, in process, one thread (torch and BLAS). Prints per case whether the result is
valid, how many of the faces the damage reversed or left without UVs it still has so
(:func:`neuraluv_paper.damage.damage_left`, against the asset as made), the share of the faces the damage left alone that stayed bit-identical (also leaving out the faces
that the repair of the undamaged asset changes: a real asset may arrive with folds of its own), of all faces,
and the seconds; a summary per damage; and flags (``<--``) the cases that are not valid, leave damage, keep less than 90% of
the faces outside the damage, or take over 10 s. Figures quoted in the issue-27 notes.
"""
import sys
import time
import warnings
from pathlib import Path

import numpy as np


def _more(kind, V, F, UV, FUV, seed):
    """The damages the benchmark does not make, on the largest island (:mod:`neuraluv_paper.damage`)."""
    from neuraluv_paper import damage
    from neuraluv_paper.bench.authored import largest_island_rows

    rows = largest_island_rows(V, F, UV, FUV)
    if kind == "spike":
        return damage.spike(V, F, UV, FUV, seed=seed, rows=rows)[0]
    if kind == "patch turned over":
        return damage.flip_patch(V, F, UV, FUV, rings=2, seed=seed, rows=rows)[0]
    if kind == "NaN patch":
        return damage.nan_patch(V, F, UV, FUV, rings=2, seed=seed, rows=rows)[0]
    out = UV
    for k in range(3):  # three folds
        out = damage.local_fold(V, F, out, FUV, rings=1, seed=7 * seed + k, rows=rows)[0]
    return out


MORE = ("spike", "patch turned over", "NaN patch", "three folds")


def main(first=10, last=14, more=False, files=()):
    warnings.filterwarnings("ignore")
    import torch
    from threadpoolctl import threadpool_limits

    from neuraluv import datasets
    from neuraluv.io import read_layout
    from neuraluv.layout import DEFECT_TEXELS
    from neuraluv.layout.facts import layout_facts
    from neuraluv.repair.repair import repair_layout
    from neuraluv_paper.bench.authored import _damaged
    from neuraluv_paper.damage import damage_left

    torch.set_num_threads(1)
    names = list(files) or [n for n in sorted(datasets.AUTHORED) if n.endswith((".obj", ".glb"))]
    kinds = ("local fold", "vertex noise", "NaN UVs") + (MORE if more else ())
    tally = {}
    with threadpool_limits(1, "blas"):
        for name in names:
            try:
                V, F, UV, FUV, _ = read_layout(name if files else datasets.authored_path(name))
            except datasets.DataMissing as exc:
                print(f"authored_damage_sweep: {exc}")
                return 2
            name = Path(name).name
            # the asset's own problems (a real asset may arrive with folds): faces its repair changes undamaged
            flat0 = layout_facts(V, F, UV, FUV).degenerate3d  # faces without 3D area: no orientation to judge
            own = repair_layout(V, F, UV, FUV, purpose="texture", min_defect=DEFECT_TEXELS, device="cpu").changed_faces
            for kind in kinds:
                for seed in range(first, last):
                    try:
                        bad = (_more if kind in MORE else _damaged)(kind, V, F, UV, FUV, seed)
                    except ValueError:  # the island is too small for this damage
                        continue
                    moved = ~((bad == UV) | (np.isnan(bad) & np.isnan(UV))).all(1)
                    untouched = ~moved[np.maximum(FUV, 0)].any(1)
                    t = time.perf_counter()
                    r = repair_layout(V, F, bad, FUV, purpose="texture", min_defect=DEFECT_TEXELS, device="cpu")
                    dt = time.perf_counter() - t
                    kept = float(1 - r.changed_faces[untouched].mean()) if untouched.any() else float("nan")
                    alone = untouched & ~own
                    kept_own = float(1 - r.changed_faces[alone].mean()) if alone.any() else float("nan")
                    left, hit = damage_left((UV, FUV), (bad, FUV), (r.UV, r.FUV), judged=~flat0)
                    flag = "" if r.after.ok and not left.any() and not kept < 0.9 and dt <= 10 else "  <--"
                    tally.setdefault(kind, []).append((r.after.ok and not left.any(), kept, kept_own, dt))
                    print(f"{name:34s} {kind:12s} {seed:3d} valid {str(r.after.ok):5s} damage left "
                          f"{int(left.sum())}/{int(hit.sum())} kept outside the damage "
                          f"{100 * kept:5.1f}% (and the asset's own repairs {100 * kept_own:5.1f}%), all "
                          f"{100 * (1 - r.changed_faces.mean()):5.1f}%, {dt:5.1f} s{flag}", flush=True)
    for kind, rows in tally.items():
        ok, kept, kept_own, dt = (np.array(c, float) for c in zip(*rows))
        print(f"{kind}: valid with no damage left {int(ok.sum())}/{len(ok)}; kept outside the damage median {100 * np.nanmedian(kept):.1f}%"
              f" (>= 90% in {int((kept >= 0.9).sum())}/{int(np.isfinite(kept).sum())}; outside the asset's own "
              f"repairs too: {int((kept_own >= 0.9).sum())}/{int(np.isfinite(kept_own).sum())}); seconds median "
              f"{np.median(dt):.1f}, max {dt.max():.1f}")
    return 0


if __name__ == "__main__":
    args = sys.argv[1:]
    nums = [int(a) for a in args[:2] if a.isdigit()]
    sys.exit(main(*nums, more="--more" in args, files=[a for a in args if not a.isdigit() and a != "--more"]))
