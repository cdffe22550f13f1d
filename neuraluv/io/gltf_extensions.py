"""What glTF extensions ask of a reader of UV layouts.

A file whose required extensions compress its geometry or buffers (Draco, meshopt) cannot be read from
its accessors: it is refused by the extension's name (:func:`refuse_unreadable`), never read as zeros.
``KHR_texture_transform`` moves where a material samples its texture: :func:`texture_transform` maps
UVs to the place they are sampled at (a re-bake works there).
"""
from __future__ import annotations

import numpy as np

from neuraluv.errors import NeuralUVError

__all__ = ["UNREADABLE_EXTENSIONS", "refuse_unreadable", "texture_transform"]

#: Required extensions whose data neuraluv does not read (the geometry or buffers are compressed): such a file
#: is refused by name, never read as zeros.
UNREADABLE_EXTENSIONS = {"KHR_draco_mesh_compression": "Draco-compressed geometry",
                         "EXT_meshopt_compression": "meshopt-compressed buffers"}


def refuse_unreadable(path, doc):
    """Raise a one-line error naming the first required extension of ``doc`` whose data neuraluv cannot read."""
    for ext in doc.get("extensionsRequired", []) if isinstance(doc, dict) else []:
        if ext in UNREADABLE_EXTENSIONS:
            raise NeuralUVError(f"{path.name} requires {ext} ({UNREADABLE_EXTENSIONS[ext]}), which neuraluv does not "
                                "read: export it without mesh compression (or decompress it) first")


def texture_transform(info):
    """The ``KHR_texture_transform`` of a material's texture reference, as a map of OBJ-convention UVs to the
    UVs the texture is sampled at (None when it has none).

    The extension's matrix (translation · rotation · scale, as its specification's GLSL builds it) acts on
    glTF UVs (``v`` down); the map flips ``v`` to them and back.

    Examples
    --------
    >>> t = texture_transform({"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0], "scale": [2, 1]}}})
    >>> t(np.array([[0.25, 1.0]])).tolist()
    [[1.0, 1.0]]
    >>> texture_transform({"index": 0}) is None
    True
    """
    ext = ((info or {}).get("extensions") or {}).get("KHR_texture_transform")
    if not ext:
        return None
    ox, oy = (float(x) for x in ext.get("offset", [0.0, 0.0]))
    sx, sy = (float(x) for x in ext.get("scale", [1.0, 1.0]))
    r = float(ext.get("rotation", 0.0))
    c, s = np.cos(r), np.sin(r)

    def apply(uv):
        uv = np.asarray(uv, float)
        u, v = uv[:, 0], 1.0 - uv[:, 1]
        x = c * sx * u - s * sy * v + ox
        y = s * sx * u + c * sy * v + oy
        return np.c_[x, 1.0 - y]
    return apply
