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
from neuraluv.layout.pack.cuts import SPLIT_SHARE, granular_islands
from neuraluv.layout.pack.raster import raster_pack
from neuraluv.layout.pack.result import PackResult
from neuraluv.layout.pack.shelf import shelf_pack
from neuraluv.layout.pack.tight import (ORDER_JITTER, ORDER_MAX_ISLANDS, PACK_TRIALS, RASTER_MAX_ISLANDS, RASTER_TRIALS,
                                        SPLIT_GAIN, tight_pack)
from neuraluv.layout.pack.xatlas_packer import xatlas_pack, xatlas_shape_pack

#: Packers of :func:`neuraluv.atlas.build_atlas` (the first is the default).
PACKERS = ("tight", "shelf", "xatlas")

__all__ = ["PACKERS", "PackResult", "shelf_pack", "raster_pack", "tight_pack", "xatlas_pack", "xatlas_shape_pack",
           "granular_islands", "SPLIT_SHARE", "SPLIT_GAIN", "PACK_TRIALS", "RASTER_TRIALS",
           "ORDER_JITTER", "ORDER_MAX_ISLANDS", "RASTER_MAX_ISLANDS"]
