"""Repair of a supplied UV layout with minimal change (``neuraluv repair``, ``neuraluv check --uv``).

Layer: above :mod:`neuraluv.atlas` (whose router re-solves an island as a chart
when nothing smaller works) and :mod:`neuraluv.solver` (the neural step on a
region with its ring pinned); the diagnosis, untangling, polishing and placing
are NumPy/SciPy/shapely and do not import torch.

=============  ==============================================================
``diagnose``   every problem of a layout under its purpose, where it is, and what
               repair does; the intentional features it keeps
``untangle``   Garanzha et al. 2021 untangling; flip-free polish of the stable objective
``local``      fold repair in the smallest ring-grown region that works
``region``     what a repaired region is measured by: overlaps, distortion, det J
``shells``     the texture purpose: folds repaired in each shell's own orientation
``seams``      a fold on the seam of two shells that share rows, repaired across them
``bake``       the bake purpose: rows of their own per surface, then each island's repair
``separate``   step 5: overlapping, out-of-square and new islands moved; repacking
``repair``     the escalation for a whole layout, the diff and the report
=============  ==============================================================

What a layout is — its facts, overlaps, validation, island placement and packing —
lives in :mod:`neuraluv.layout`, shared with the atlas; generated damage for the
benchmark is the harness's (:mod:`neuraluv_paper.damage`).
"""
from __future__ import annotations

from neuraluv.lazy import lazy_exports

__all__ = ["diagnose_layout", "repair_layout", "untangle", "polish", "RepairResult", "UVDiagnosis"]

_WHERE = {"diagnose_layout": "diagnose", "UVDiagnosis": "diagnose", "repair_layout": "repair",
          "RepairResult": "repair", "untangle": "untangle", "polish": "untangle"}


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, globals())
