#!/usr/bin/env python
"""How many of the faces a damage reverses the texture purpose calls folds (not intent), on real layouts.

    NEURALUV_DATA=.cache/neuraluv-data python data_scripts/purpose_fold_recall.py [FILE ...]

For eight authored assets (``make data``; or the layout files named), six seeds each of a 1-ring and a 3-ring local fold
(strength 1.5 / 2.5, on the largest island) and of 2% vertex noise (:mod:`neuraluv_paper.damage`):
the faces whose det J changed sign, and how many of them :func:`~neuraluv.layout.purpose.layout_intent`
calls folds or degenerate faces (the rest it would take for a mirrored or stacked shell). The figure
quoted in :mod:`neuraluv.layout.purpose` and the README.
"""
import sys
from pathlib import Path

import numpy as np

from neuraluv import datasets
from neuraluv.io import read_layout
from neuraluv.layout.facts import layout_facts
from neuraluv.layout.purpose import layout_intent
from neuraluv_paper import damage

ASSETS = ["bl_spot_seams_unwrap.obj", "capsule.obj", "bl_spot_udim.obj", "fuze.obj", "bl_suzanne_mirrored_halves.obj",
          "Duck.glb", "tube.obj", "ico4uv.obj"]


def main(files=()):
    tot = miss = n = 0
    by_asset = {}
    for name in files or ASSETS:
        try:
            path = name if files else datasets.authored_path(name)
        except datasets.DataMissing as exc:
            print(f"purpose_fold_recall: {exc}")
            return 2
        name = Path(name).name
        V, F, UV, FUV, _ = read_layout(path)
        f0 = layout_facts(V, F, UV, FUV)
        big = np.argmax(np.bincount(f0.label[f0.label >= 0]))
        rows = np.unique(FUV[f0.island_faces(big)])
        for seed in range(6):
            for kind in ("fold1", "fold3", "noise"):
                try:
                    if kind == "noise":
                        uv, _ = damage.vertex_noise(V, F, UV, FUV, fraction=0.02, seed=seed)
                    else:
                        uv, _ = damage.local_fold(V, F, UV, FUV, rings=int(kind[-1]), seed=seed, rows=rows,
                                                  strength=(1.5, 2.5)[seed % 2])
                except ValueError:  # the island is too small for this fold
                    continue
                f = layout_facts(V, F, uv, FUV)
                it = layout_intent(f)
                reversed_ = (f.det * f0.det < 0) & ~f.degenerate3d
                missed = reversed_ & ~it.fold & ~it.degenerate
                n += 1
                tot += int(reversed_.sum())
                miss += int(missed.sum())
                a = by_asset.setdefault(name, [0, 0])
                a[0] += int(reversed_.sum())
                a[1] += int(missed.sum())
    for name, (t, m) in by_asset.items():
        print(f"{name:32s} reversed by the damage {t:5d}, not called folds {m:4d} ({100 * m / max(t, 1):.1f}%)")
    print(f"{n} damaged layouts: {tot} faces reversed by the damage, {miss} not called folds "
          f"({100 * miss / max(tot, 1):.1f}%)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
