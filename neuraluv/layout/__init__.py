"""A UV layout over a mesh: the one home of its ideas (torch-free).

Both the atlas (which makes layouts) and repair (which mends supplied ones) are
clients of this package:

==============  ================================================================
``facts``       :func:`layout_facts`: faces, islands, det J, mirrored islands and
                the one texel density, read once (:class:`LayoutFacts`)
``overlap``     the one exact overlap engine (triangle pairs), island outlines,
                gaps, :func:`boundary_is_simple`
``validate``    :func:`validate_layout`: flips, overlaps, bounds, padding
``rigid``       the one rigid fit (Procrustes), quarter turns, island orientation
``raster``      the one rasteriser and free-spot search (:class:`~neuraluv.layout.raster.Page`)
``place``       moving an island into free space (:class:`FreeSpace`)
``pack``        the packers and their :class:`~neuraluv.layout.pack.PackResult`
``precision``   float32 UVs for writing, without a flipped triangle
==============  ================================================================

Layouts are plain arrays: ``UV (p,2)`` rows indexed per corner by ``FUV (m,3)``
(-1 where a face has no ``vt``) over a mesh ``V (n,3)``, ``F (m,3)``.
"""
from neuraluv.layout.facts import (LayoutFacts, density_spread, face_clusters, face_texel_density, island_densities,
                                   layout_facts, texel_density, uv_islands)
from neuraluv.layout.overlap import boundary_is_simple, find_overlaps, overlap_pairs, self_overlap, triangles_union
from neuraluv.layout.place import FreeSpace, Placement
from neuraluv.layout.precision import float32_uvs
from neuraluv.layout.rigid import quarter_turn, rigid_fit, rotate_to_min_box, upright
from neuraluv.layout.validate import validate_facts, validate_layout

__all__ = ["LayoutFacts", "layout_facts", "uv_islands", "face_clusters", "texel_density", "island_densities",
           "face_texel_density", "density_spread", "find_overlaps", "overlap_pairs", "self_overlap", "triangles_union",
           "boundary_is_simple", "validate_layout", "validate_facts", "rigid_fit", "quarter_turn", "rotate_to_min_box",
           "upright", "FreeSpace", "Placement", "float32_uvs"]
