"""Validation-first atlas construction (paper Sec. 4 and Figure 4) and unwrapping.

A whole, possibly messy, input mesh becomes a packed UV atlas:

=================  ==========================================================
``prepare``        1. repair: weld, drop degenerate/duplicate faces, orient,
                   split non-manifold edges and vertices
``candidates``     2. chart candidates: components, xatlas seams, bisection
                   until every candidate is disk-like
``routing``        3. each candidate → an exact unfold (no interior vertex), the
                   neural solver (all charts in batches), or a marked fallback
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
from neuraluv.atlas.build import AtlasResult, build_atlas, repack
from neuraluv.atlas.candidates import chart_candidates, seam_charts
from neuraluv.atlas.export import atlas_file, read_atlas, save_renders, write_atlas
from neuraluv.atlas.prepare import prepare_mesh
from neuraluv.atlas.routing import (FALLBACK_MAX_ESD, AtlasChart, fallback_islands, pca_uv, per_face_uv, route_chart,
                                    route_charts, tutte_slim_uv, unfold_tree)

__all__ = [
    "AtlasChart", "AtlasResult", "prepare_mesh", "seam_charts", "chart_candidates",
    "pca_uv", "per_face_uv", "fallback_islands", "route_chart", "route_charts", "unfold_tree", "build_atlas",
    "tutte_slim_uv", "FALLBACK_MAX_ESD",
    "write_atlas", "read_atlas", "save_renders", "atlas_file", "repack",
]
