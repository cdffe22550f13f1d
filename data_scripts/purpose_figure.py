#!/usr/bin/env python
"""The README's purpose figure: a real textured asset repaired as a texture layout and as a bake layout.

    NEURALUV_DATA=.cache/neuraluv-data python data_scripts/purpose_figure.py [-o docs/img/purpose_fuze.png]

Needs the authored assets (``make data``). Left: trimesh's ``fuze.obj`` as made, over its own
texture — its mirrored island (blue) and its one folded face (red). Middle: ``--purpose texture``
(the default): only the fold's neighbourhood changed (orange). Right: ``--purpose bake``: the
mirrored island is reflected back and islands are moved (orange), which no texture painted for
the old layout survives without a re-bake.
"""
import argparse
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from PIL import Image  # noqa: E402

from neuraluv import datasets  # noqa: E402
from neuraluv.io import read_obj  # noqa: E402
from neuraluv.layout.facts import layout_facts  # noqa: E402
from neuraluv.layout.purpose import layout_intent  # noqa: E402
from neuraluv.repair.repair import repair_layout  # noqa: E402


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-o", "--output", default="docs/img/purpose_fuze.png")
    a = p.parse_args(argv)
    try:
        path = datasets.authored_path("fuze.obj")
        img = np.asarray(Image.open(datasets.authored_path("fuze uv.jpg")))
    except datasets.DataMissing as exc:
        print(f"purpose_figure: {exc}")
        return 2
    V, F, UV, FUV = read_obj(path)
    it = layout_intent(layout_facts(V, F, UV, FUV))
    res = {p: repair_layout(V, F, UV, FUV, "fast", purpose=p, device="cpu") for p in ("texture", "bake")}
    fig, axes = plt.subplots(1, 3, figsize=(13.5, 4.8))
    panels = [("as made: a mirrored island (blue), a fold (red)", UV, FUV, None),
              ("--purpose texture (default)", res["texture"].UV, res["texture"].FUV, res["texture"]),
              ("--purpose bake", res["bake"].UV, res["bake"].FUV, res["bake"])]
    for ax, (title, U, T, r) in zip(axes, panels):
        ax.imshow(img, extent=(0, 1, 0, 1), alpha=0.55)
        tris = U[T]
        colors = np.full(len(F), "none", dtype=object)
        if r is None:
            colors[it.mirrored_shell] = "tab:blue"
            colors[it.fold] = "red"
        else:
            colors[r.changed_faces] = "tab:orange"
        ax.add_collection(PolyCollection(tris, facecolors=list(colors), edgecolors="k", linewidths=0.15, alpha=0.8))
        if r is None:  # the fold is one small face: ringed so it can be found
            c = tris[it.fold].reshape(-1, 2).mean(0)
            ax.add_patch(plt.Circle(c, 0.03, fill=False, color="red", lw=2))
        lo, hi = np.minimum(U[T].reshape(-1, 2).min(0), 0), np.maximum(U[T].reshape(-1, 2).max(0), 1)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        sub = "" if r is None else f"\n{100 * (1 - r.changed_faces.mean()):.1f}% of faces bit-identical, " \
                                   f"{int(r.changed_faces.sum())} changed"
        ax.set_title(title + sub, fontsize=10)
        ax.set_xticks([0, 1])
        ax.set_yticks([0, 1])
    fig.suptitle("fuze.obj (trimesh's test model) over its own texture: what each purpose changes", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    fig.savefig(a.output, dpi=90)
    print(f"wrote {a.output}: texture {res['texture'].summary()[:80]} | bake {res['bake'].summary()[:80]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
