"""Validation-first atlas construction (paper Sec. 4 and Figure 4) and unwrapping.

A whole, possibly messy, input mesh becomes a packed UV atlas:

=================  ==========================================================
``prepare``        1. repair: weld, drop degenerate/duplicate faces, orient,
                   split non-manifold edges and vertices
``candidates``     2. chart candidates: components, xatlas seams, bisection
                   until every candidate is disk-like
``routing``        3. each candidate → an exact unfold (no interior vertex), the
                   neural solver (all charts in batches), or a marked fallback
                   (PCA → split → per-face), with its reason
``build``          4. packing (area-scaled shelf or xatlas) and the
                   :class:`AtlasResult`; :func:`build_atlas` runs 1–5
``validate``       5. exact validation: flips, overlaps, bounds, padding
``export``         OBJ/GLB writing, read-back validation, figures
``unwrap``         unwrap disk-like component(s) without cutting
``sweep``          many assets on a dask cluster
=================  ==========================================================

Repairing a supplied layout (rather than making one) is :mod:`neuraluv.repair`.
"""
from neuraluv.atlas.build import AtlasResult, build_atlas, repack
from neuraluv.atlas.candidates import bisect_faces, chart_candidates, seam_charts
from neuraluv.atlas.export import atlas_file, read_atlas, save_renders, write_atlas
from neuraluv.atlas.prepare import prepare_mesh
from neuraluv.atlas.routing import (FALLBACK_MAX_ESD, AtlasChart, boundary_is_simple, fallback_islands, pca_uv,
                                    per_face_uv, route_chart, route_charts, tutte_slim_uv, unfold_tree)
from neuraluv.atlas.validate import face_texel_density, self_overlap, triangles_union, uv_islands, validate_atlas

__all__ = [
    "AtlasChart", "AtlasResult", "prepare_mesh", "seam_charts", "bisect_faces", "chart_candidates",
    "pca_uv", "per_face_uv", "fallback_islands", "self_overlap", "triangles_union", "route_chart", "route_charts", "unfold_tree", "boundary_is_simple", "build_atlas",
    "tutte_slim_uv", "FALLBACK_MAX_ESD",
    "validate_atlas", "write_atlas", "read_atlas", "save_renders", "atlas_file", "uv_islands", "repack",
    "face_texel_density",
]
