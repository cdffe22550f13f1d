"""Data: procedural charts, the registry of real meshes, generated messy assets.

=================  ==========================================================
``procedural``     charts generated in code (disk, cap, saddle, glove, ...)
``registry``       real meshes by URL + sha256, fetch/import, the compact charts; real
                   authored assets with UV layouts (:data:`AUTHORED`)
``generated``      messy generated-like assets (holes, fragments, slivers, ...)
=================  ==========================================================

Real meshes are never committed; they are cached in :func:`data_dir` (``$NEURALUV_DATA``, else a source
checkout's ``.cache/neuraluv-data``, else the user cache).
"""
from neuraluv.datasets.procedural import (PROCEDURAL, bumpy_disk, disk, glove, procedural, saddle, several_components,
                                          sphere, spherical_cap)
from neuraluv.datasets.registry import (AUTHORED, CLOSED, COMPACT, FETCH_HINT, LARGE, REGISTRY, DataMissing,
                                        authored_path, available, checkout, data_dir, fetch, fetch_all, fetch_authored, load, load_charts,
                                        load_raw)

__all__ = [
    "disk", "spherical_cap", "saddle", "bumpy_disk", "glove", "several_components", "sphere", "PROCEDURAL",
    "procedural", "REGISTRY", "COMPACT", "CLOSED", "LARGE", "data_dir", "fetch", "fetch_all", "available", "load",
    "load_raw", "load_charts", "DataMissing", "FETCH_HINT", "checkout", "AUTHORED", "authored_path", "fetch_authored",
]
