"""What glTF extensions ask of a reader of UV layouts.

A file whose required extensions compress its geometry or buffers (Draco, meshopt) cannot be read from
its accessors: it is refused by the extension's name (:func:`refuse_unreadable`), never read as zeros.
``KHR_texture_transform`` moves where a material samples its texture: :func:`texture_transform` maps
UVs to the place they are sampled at (and back); a layout is read where every texture of its material
samples it (:func:`sampled_transform`: gltfpack's quantized UVs, for one, are dequantized this way), so that
its folds, texel sizes and tiles are judged as the renderer shows them.
"""
from __future__ import annotations

import numpy as np

from neuraluv.errors import NeuralUVError

__all__ = ["UNREADABLE_EXTENSIONS", "refuse_unreadable", "texture_transform", "texture_refs",
           "sampled_transform", "transform_map"]

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


def texture_transform(info, *, inverse=False):
    """The ``KHR_texture_transform`` of a material's texture reference, as a map of OBJ-convention UVs to the
    UVs the texture is sampled at (None when it has none); ``inverse``: from there back (:func:`transform_map`).

    Examples
    --------
    >>> t = texture_transform({"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0], "scale": [2, 1]}}})
    >>> t(np.array([[0.25, 1.0]])).tolist()
    [[1.0, 1.0]]
    >>> texture_transform({"index": 0}) is None
    True
    """
    ext = ((info or {}).get("extensions") or {}).get("KHR_texture_transform")
    return transform_map(ext, inverse=inverse) if ext else None


def transform_map(ext, *, inverse=False):
    """A ``KHR_texture_transform`` object (``offset``, ``rotation``, ``scale``) as a map of OBJ-convention UVs
    to where they are sampled (``inverse``: back); the identity for None.

    The extension's matrix (translation · rotation · scale, as its specification's GLSL builds it) acts on
    glTF UVs (``v`` down); the map flips ``v`` to them and back.

    Examples
    --------
    >>> back = transform_map({"offset": [0.5, 0], "scale": [2, 1]}, inverse=True)
    >>> back(np.array([[1.0, 1.0]])).tolist()
    [[0.25, 1.0]]
    """
    if not ext:
        return lambda uv: np.asarray(uv, float)
    ox, oy = (float(x) for x in ext.get("offset", [0.0, 0.0]))
    sx, sy = (float(x) for x in ext.get("scale", [1.0, 1.0]))
    r = float(ext.get("rotation", 0.0))
    c, s = np.cos(r), np.sin(r)
    M, o = np.array([[c * sx, -s * sy], [s * sx, c * sy]]), np.array([ox, oy])
    if inverse:
        if not abs(np.linalg.det(M)) > 0:
            raise NeuralUVError("a KHR_texture_transform with a zero scale cannot be undone")
        M = np.linalg.inv(M)
        o = -M @ o

    def apply(uv):
        uv = np.asarray(uv, float)
        g = np.c_[uv[:, 0], 1.0 - uv[:, 1]] @ M.T + o
        return np.c_[g[:, 0], 1.0 - g[:, 1]]
    return apply


def texture_refs(doc, material, texcoord):
    """The texture references (``textureInfo`` dicts) of material ``material`` that sample UV set ``texcoord``
    (the extension's ``texCoord`` wins over the reference's): base colour, metallic-roughness, normal,
    occlusion and emissive."""
    if material is None:
        return []
    mat = doc["materials"][material]
    pbr = mat.get("pbrMetallicRoughness", {})
    out = []
    for ti in (pbr.get("baseColorTexture"), pbr.get("metallicRoughnessTexture"), mat.get("normalTexture"),
               mat.get("occlusionTexture"), mat.get("emissiveTexture")):
        ext = ((ti or {}).get("extensions") or {}).get("KHR_texture_transform")
        if ti and (ext or {}).get("texCoord", ti.get("texCoord", 0)) == texcoord:
            out.append(ti)
    return out


def sampled_transform(doc, prim, texcoord):
    """The ``KHR_texture_transform`` (its JSON object) through which every texture of the primitive's material
    samples UV set ``texcoord``: the layout as the renderer shows it. None when no texture has one, or when
    they differ (the layout is then read as stored; a re-bake transforms each image on its own).

    Examples
    --------
    >>> tt = {"KHR_texture_transform": {"scale": [16, 16]}}
    >>> doc = {"materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": tt}}}]}
    >>> sampled_transform(doc, {"material": 0}, 0), sampled_transform(doc, {"material": 0}, 1)
    ({'scale': [16, 16]}, None)
    """
    ts = [((ti.get("extensions") or {}).get("KHR_texture_transform")) for ti in
          texture_refs(doc, prim.get("material"), texcoord)]
    if not ts or any(t is None or t != ts[0] for t in ts):
        return None
    t = {k: v for k, v in ts[0].items() if k != "texCoord"}
    return t or None
