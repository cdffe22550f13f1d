"""glTF vertex tangents (``TANGENT``) recomputed where a written layout moved a vertex.

A primitive's ``TANGENT`` (xyz along +u in the vertex's tangent plane, w the handedness of the
bitangent ``cross(N, t) · w``) is the frame its tangent-space normal map is read in, built from the
UV set the normal texture samples. When that set changes, the tangents of the moved vertices are
stale: :func:`retangent` recomputes them from the new UVs (per vertex, the sum of its faces'
``∂P/∂u`` made orthogonal to the normal; the handedness from ``∂P/∂v``), in the file's own
handedness convention (read off the primitive as it was), and leaves every other row as it was.
"""
from __future__ import annotations

import numpy as np

from neuraluv.io.gltf import _triangles, read_accessor

__all__ = ["vertex_tangents", "normal_texcoord", "retangent"]


def normal_texcoord(doc, prim):
    """The UV set a primitive's normal texture samples (0 without one): the set its tangents belong to."""
    mat = prim.get("material")
    nt = (doc.json["materials"][mat].get("normalTexture") or {}) if mat is not None else {}
    ext = (nt.get("extensions") or {}).get("KHR_texture_transform") or {}
    return int(ext.get("texCoord", nt.get("texCoord", 0)))


def vertex_tangents(P, N, UV, T):
    """Per-vertex tangents ``(n,4)`` of a triangle mesh for a UV map (v up: the bitangent along +v).

    Parameters
    ----------
    P : (n,3) float array, positions
    N : (n,3) float array or None, vertex normals (None: from the faces)
    UV : (n,2) float array
    T : (m,3) int array, triangles

    Returns
    -------
    (n,4) float array: a unit ``t`` orthogonal to the normal (along +u), and ``w = ±1`` with
    ``cross(N, t) · w`` on the side of +v.

    Examples
    --------
    >>> P = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); T = np.array([[0, 1, 2]])
    >>> vertex_tangents(P, None, P[:, :2] @ np.array([[0., 1], [-1, 0]]).T, T)[0].round(6).tolist()  # u along +y
    [0.0, 1.0, 0.0, 1.0]
    """
    P, UV, T = np.asarray(P, float), np.asarray(UV, float), np.asarray(T, np.int64)
    e1, e2 = P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]
    d1, d2 = UV[T[:, 1]] - UV[T[:, 0]], UV[T[:, 2]] - UV[T[:, 0]]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    ok = np.isfinite(det) & (det != 0)
    r = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
    ft, fb = (e1 * d2[:, 1:] - e2 * d1[:, 1:]) * r, (e2 * d1[:, :1] - e1 * d2[:, :1]) * r
    t, b = np.zeros_like(P), np.zeros_like(P)
    for k in range(3):
        np.add.at(t, T[:, k], ft)
        np.add.at(b, T[:, k], fb)
    if N is None:
        N = np.zeros_like(P)
        for k in range(3):
            np.add.at(N, T[:, k], np.cross(e1, e2))
    N = np.asarray(N, float)
    N = N / np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)
    t = t - N * (N * t).sum(1, keepdims=True)
    length = np.linalg.norm(t, axis=1, keepdims=True)
    side = np.where(np.abs(N[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])   # no UV gradient: any unit tangent
    spare = np.cross(N, side)
    t = np.where(length > 1e-12, t / np.maximum(length, 1e-300), spare / np.maximum(
        np.linalg.norm(spare, axis=1, keepdims=True), 1e-300))
    w = np.where((np.cross(N, t) * b).sum(1) < 0, -1.0, 1.0)
    return np.c_[t, w]


def _frame(doc, prim, texcoord):
    P = read_accessor(doc, prim["attributes"]["POSITION"]).astype(float)
    N = read_accessor(doc, prim["attributes"]["NORMAL"]).astype(float) if "NORMAL" in prim["attributes"] else None
    UV = read_accessor(doc, prim["attributes"][f"TEXCOORD_{texcoord}"]).astype(float) * [1.0, -1.0]  # v up
    idx = read_accessor(doc, prim["indices"]).reshape(-1) if "indices" in prim else np.arange(len(P))
    return P, N, UV, _triangles(idx, prim.get("mode", 4))


def retangent(doc, prim, verts, texcoord, before=None):
    """Recompute the ``TANGENT`` rows of vertices ``verts`` of ``prim`` from its current ``TEXCOORD_<texcoord>``.

    Parameters
    ----------
    doc : GltfDoc, being written (changed in place)
    prim : dict, the primitive (its attributes as written)
    verts : (k,) int array, the vertices whose UVs moved
    texcoord : int, the UV set that changed
    before : (GltfDoc, dict), optional
        The document and primitive as read: the file's handedness convention is the one its tangents had
        there (glTF's is w = +1 where ``cross(N, t)`` runs along +v, up the image).

    Returns
    -------
    int or None
        Rows written; 0 when there is nothing to do (no ``TANGENT``, or tangents of another set); None when
        the tangents are stored so that they cannot be written in place (quantized or sparse).
    """
    ti = prim["attributes"].get("TANGENT")
    verts = np.asarray(verts, np.int64)
    if ti is None or not len(verts) or normal_texcoord(doc, prim) != texcoord:
        return 0
    acc = doc.json["accessors"][ti]
    if acc.get("componentType") != 5126 or acc.get("type") != "VEC4" or "bufferView" not in acc or "sparse" in acc:
        return None
    sign = 1.0
    if before is not None and "TANGENT" in before[1]["attributes"]:
        odoc, oprim = before
        stored = read_accessor(odoc, oprim["attributes"]["TANGENT"])[:, 3]
        ours = vertex_tangents(*_frame(odoc, oprim, texcoord))[:, 3]
        if np.mean(np.sign(stored) == ours) < 0.5:   # the file counts handedness the other way round
            sign = -1.0
    new = vertex_tangents(*_frame(doc, prim, texcoord))[verts]
    new[:, 3] *= sign
    bv = doc.json["bufferViews"][acc["bufferView"]]
    start = bv.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = bv.get("byteStride") or 16
    buf = doc.buffers[bv["buffer"]]
    for v, row in zip(verts, new.astype("<f4")):
        buf[start + stride * v:start + stride * v + 16] = row.tobytes()
    if "min" in acc or "max" in acc:
        vals = read_accessor(doc, ti)
        acc["min"], acc["max"] = vals.min(0).tolist(), vals.max(0).tolist()
    return int(len(verts))
