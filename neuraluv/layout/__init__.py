"""A UV layout over a mesh: the one home of its ideas (torch-free).

Both the atlas (which makes layouts) and repair (which mends supplied ones) are
clients of this package:

==============  ================================================================
``facts``       :func:`layout_facts`: faces, islands, det J, mirrored islands and
                the one texel density, read once (:class:`LayoutFacts`)
``overlap``     the one exact overlap engine (triangle pairs), island outlines,
                gaps, :func:`boundary_is_simple`
``purpose``     :func:`layout_intent`: what a layout is for decides what is a problem
                (``texture``: mirrored, stacked, tiled and palette shells are intent;
                ``bake`` / ``lightmap``: unique, unmirrored, in the square)
``validate``    :func:`validate_layout`: flips, overlaps, bounds, padding (per purpose)
``rigid``       the one rigid fit (Procrustes), quarter turns, island orientation
``raster``      the one rasteriser and free-spot search (:class:`~neuraluv.layout.raster.Page`)
``place``       moving an island into free space (:class:`FreeSpace`)
``pack``        the packers and their :class:`~neuraluv.layout.pack.PackResult`
``precision``   float32 UVs for writing, without a flipped triangle
==============  ================================================================

Layouts are plain arrays: ``UV (p,2)`` rows indexed per corner by ``FUV (m,3)``
(-1 where a face has no ``vt``) over a mesh ``V (n,3)``, ``F (m,3)``.
"""
from __future__ import annotations

from neuraluv.lazy import lazy_exports

#: The purposes a layout can have, and what each means (:mod:`~neuraluv.layout.purpose`; here so that the
#: command line's help lists them without loading numpy).
PURPOSES = {
    "texture": "an artist's texture layout: mirrored, stacked, tiled, UDIM and palette-collapsed shells are "
               "intentional; folds, UV-degenerate faces inside a shell and missing/NaN UVs are problems",
    "bake": "a layout to bake into: unique, unmirrored, inside [0,1]², padded (every overlap, mirror or tile "
            "is a problem)",
    "lightmap": "as bake (a lightmap is baked)",
}

#: ``check --uv`` and ``repair``'s default tolerance, in texels (of area) at ``--resolution``: an island's
#: overlap with itself or with another island smaller than this in all cannot show in the texture; it is
#: noted and left alone (the library's default is 0: exact).
DEFECT_TEXELS = 0.5

#: name -> module of this package that defines it (imported on first use, so that ``neuraluv.layout.pack``'s
#: settings stay cheap to import, e.g. for the command line's help).
_WHERE = {
    "LayoutFacts": "facts", "layout_facts": "facts", "uv_islands": "facts", "coincident_rows": "facts", "face_clusters": "facts",
    "texel_density": "facts", "defect_area": "facts", "island_densities": "facts", "face_texel_density": "facts", "density_spread": "facts",
    "find_overlaps": "overlap", "overlap_pairs": "overlap", "self_overlap": "overlap", "triangles_union": "overlap",
    "boundary_is_simple": "overlap", "validate_layout": "validate", "validate_facts": "validate",
    "rigid_fit": "rigid", "quarter_turn": "rigid", "rotate_to_min_box": "rigid", "upright": "rigid",
    "FreeSpace": "place", "Placement": "place", "float32_uvs": "precision",
    "layout_intent": "purpose", "LayoutIntent": "purpose", "default_purpose": "purpose", "check_purpose": "purpose",
}

__all__ = sorted(["PURPOSES", "DEFECT_TEXELS", *_WHERE])


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, globals())
