"""Validation-first atlas construction (paper Sec. 4 and Figure 4) and unwrapping.

A whole, possibly messy, input mesh becomes a packed UV atlas:

=================  ==========================================================
``prepare``        1. repair: weld, drop degenerate/duplicate faces, orient,
                   split non-manifold edges and vertices
``candidates``     2. chart candidates: components, xatlas seams, bisection
                   until every candidate is disk-like
``routing``        3. each candidate → an exact unfold (no interior vertex) or
                   isometric start (flat), the neural solver (all charts in
                   batches, each from its Tutte map moved on by SLIM), or a marked fallback
                   (PCA → Tutte + SLIM → split → per-face), with its reason
``build``          4. packing (:mod:`neuraluv.layout.pack`) and the
                   :class:`AtlasResult`; :func:`build_atlas` runs 1–4 and
                   validates the layout (:func:`neuraluv.layout.validate_layout`)
``export``         OBJ/GLB writing, read-back validation, figures
``unwrap``         unwrap disk-like component(s) without cutting
``sweep``          many assets on a dask cluster
=================  ==========================================================

Repairing a supplied layout (rather than making one) is :mod:`neuraluv.repair`; what a
layout is, and everything both ask of one, is :mod:`neuraluv.layout`.
"""
from __future__ import annotations

from neuraluv.lazy import lazy_exports

#: name -> module of this package that defines it (imported on first use: ``neuraluv unwrap`` needs
#: only :mod:`~neuraluv.atlas.unwrap`, not the atlas pipeline's modules and trimesh).
_WHERE = {
    "AtlasResult": "build", "build_atlas": "build", "repack": "build",
    "chart_candidates": "candidates", "seam_charts": "candidates",
    "atlas_file": "export", "read_atlas": "export", "save_renders": "export", "write_atlas": "export",
    "prepare_mesh": "prepare",
    "FALLBACK_MAX_ESD": "routing", "AtlasChart": "routing", "fallback_islands": "routing", "pca_uv": "routing",
    "per_face_uv": "routing", "route_chart": "routing", "route_charts": "routing", "tutte_slim_uv": "routing",
    "unfold_tree": "routing",
}

__all__ = [
    "AtlasChart", "AtlasResult", "prepare_mesh", "seam_charts", "chart_candidates",
    "pca_uv", "per_face_uv", "fallback_islands", "route_chart", "route_charts", "unfold_tree", "build_atlas",
    "tutte_slim_uv", "FALLBACK_MAX_ESD",
    "write_atlas", "read_atlas", "save_renders", "atlas_file", "repack",
]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, globals())
