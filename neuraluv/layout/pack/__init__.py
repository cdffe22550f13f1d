"""Packers: islands (at one texel density) placed into the unit square or UDIM tiles.

==================  ============================================================
``result``          :class:`PackResult` (every packer returns it), shared measurements
``shelf``           the paper's area-scaled shelf packer of bounding boxes
``raster``          islands' rasterised shapes placed largest first (bottom-left fill)
``tight``           the default: the fullest of several raster packings (+ cut islands)
``xatlas_packer``   xatlas's packer, only its placements read back (boxes or shapes)
``cuts``            cutting large islands into parts that nest
==================  ============================================================

Every packer moves islands by translations, quarter or finer proper rotations and
one common uniform scale: never a mirror, so orientation (det J > 0) and the one
texel density are kept.
"""
from __future__ import annotations

from neuraluv.lazy import lazy_exports

#: Packers of :func:`neuraluv.atlas.build_atlas` (the first is the default).
PACKERS = ("tight", "shelf", "xatlas")

#: The first raster packings :func:`tight_pack` tries: (grid cells per side, rotations per island).
#: Later trials repeat the first setting with the placement order perturbed (:data:`ORDER_JITTER`).
RASTER_TRIALS = ((512, 4), (256, 8))

#: The fill (share of the page) :func:`raster_pack`'s scale search starts from (then gallops and bisects,
#: :func:`~neuraluv.layout.pack.raster.largest_fit`): real islands fill 50-70% of the page, so the search
#: brackets the answer in a step or two instead of bisecting from a quarter of the page.
START_FILL = 0.6

#: Spread (log-normal sigma) of the factors on the islands' areas that perturb the placement order of
#: :func:`tight_pack`'s later trials: greedy placement is chaotic, and with few large islands the
#: best of several orders packs several points fuller than largest-first alone.
ORDER_JITTER = 0.5

#: Default trials of :func:`tight_pack` (the tight packer of ``build_atlas`` and the CLI).
PACK_TRIALS = 12

#: The perturbed-order trials of :func:`tight_pack` stop after this many in a row that packed no fuller
#: than the best so far (the trials left are not run). Measured on the islands of spot, fertility and 13
#: generated assets (issue 28): packing time x0.58 of running all 12 trials, utilisation 0.09 points
#: lower on average, at most 1.23 points on one asset (2 in a row: x0.46, but 0.39 lower, 3.4 at most).
ORDER_PATIENCE = 3

#: Perturbed-order trials run only up to this many islands: with many islands one order packs
#: about as full as another (Cow, 83 islands: 12 trials no fuller than 2, packing time doubled).
ORDER_MAX_ISLANDS = 48

#: Scales whose rasterised islands :func:`~neuraluv.layout.pack.raster.raster_pack` keeps for the next trial of
#: :func:`tight_pack` (its ``rasters``): a scale search visits about ten, and the trials after the first search
#: from the best scale so far, so they rasterise little (spot, fertility, beetle: packing ~10% faster).
RASTERS_KEPT = 8

#: Above this many islands ``tight_pack(method="auto")`` places the shapes with xatlas (faster there).
RASTER_MAX_ISLANDS = 1000

#: Utilisation (absolute) the cut islands of ``tight_pack(split=...)`` must gain to be kept: cuts add seams.
SPLIT_GAIN = 0.01

#: :func:`~neuraluv.layout.pack.cuts.granular_islands` halves islands holding more than this share of the total UV area.
SPLIT_SHARE = 1 / 10

#: Texels kept beyond the padding where a layout is placed exactly at it (the border of a grown packing, Blender's
#: margin in ``bench speed --atlas``): float32 UVs written to a file may move a gap by ~1e-4 texel.
FLOAT32_SLACK = 0.01

#: name -> module of this package that defines it (imported on first use: the constants above stay cheap to
#: import, e.g. for the command line's help).
_WHERE = {"PackResult": "result", "shelf_pack": "shelf", "raster_pack": "raster", "tight_pack": "tight",
          "xatlas_pack": "xatlas_packer", "xatlas_shape_pack": "xatlas_packer", "granular_islands": "cuts"}

__all__ = ["PACKERS", "PackResult", "shelf_pack", "raster_pack", "tight_pack", "xatlas_pack", "xatlas_shape_pack",
           "granular_islands", "SPLIT_SHARE", "SPLIT_GAIN", "PACK_TRIALS", "ORDER_PATIENCE", "RASTER_TRIALS", "ORDER_JITTER",
           "ORDER_MAX_ISLANDS", "RASTER_MAX_ISLANDS", "RASTERS_KEPT", "START_FILL", "FLOAT32_SLACK"]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, globals())
