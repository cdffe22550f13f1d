"""glTF 2.0 layouts: read a UV set of every textured triangle primitive, and write a copy of the file that
differs only in that UV set (or in an added one).

:func:`read_gltf_layout` gathers the primitives of a ``.glb`` / ``.gltf`` file that
have the asked-for ``TEXCOORD_n``: positions in world coordinates (the first node
that instances the mesh; distortion needs consistent scale), triangles (strips and
fans unrolled), and the texture coordinates with ``v`` flipped to the OBJ
convention (glTF's origin is the image's top-left corner). Primitives without
that UV set, points and lines are left out and listed. A glTF vertex is split
for its normals as well as for its UVs (hard edges, flat shading): the rows of
an edge two faces share in 3D and in UV are joined (:func:`seamless_rows`), so
that islands and folds are read as the map has them, as an OBJ's shared ``vt``.

A layout is read where its material's textures sample it: a ``KHR_texture_transform`` shared by every
texture of the primitive's material on that set (gltfpack's dequantization, for one) is applied
(:func:`~neuraluv.io.gltf_extensions.sampled_transform`), and undone when the set is written back.

:func:`~neuraluv.io.gltf_write.write_gltf_uvs` writes a copy of the file that differs only in that UV set.
"""
from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from neuraluv.errors import NeuralUVError
from neuraluv.io.files import atomic_write
from neuraluv.io.gltf_extensions import refuse_unreadable, sampled_transform, transform_map

__all__ = ["GltfLayout", "GltfDoc", "read_gltf_layout", "load_gltf", "read_accessor", "image_bytes", "external_file",
           "seamless_rows", "COMPONENT_DTYPE", "TYPE_WIDTH", "GLB_MAGIC", "CHUNK_JSON", "CHUNK_BIN"]

#: glTF accessor component types and element widths; the GLB header's magic and chunk types (glTF 2.0 §4.4, §5.1).
COMPONENT_DTYPE = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
TYPE_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
GLB_MAGIC, CHUNK_JSON, CHUNK_BIN = 0x46546C67, 0x4E4F534A, 0x004E4942


@dataclass
class GltfDoc:
    """A glTF document as read (:func:`load_gltf`): its JSON, its buffers and the JSON's bytes as read."""
    path: Path
    json: dict
    buffers: list  # bytearray per buffer (the GLB's BIN chunk is buffer 0)
    glb: bool
    json_chunk: bytes = b""  # the JSON (a GLB's JSON chunk) as read: written back unchanged when it did not change
    base: Path = None  # a second folder relative URIs resolve in (the final folder of a file written in a stage)

    def folders(self):
        """The folders a relative URI of this document resolves in, in order: the file's, then ``base``."""
        return _folders(self.path, self.base)


def _folders(path, base):
    return [Path(path).parent] + ([Path(base)] if base is not None else [])


def load_gltf(path, base=None):
    """The JSON and the buffers of a ``.glb`` or ``.gltf`` file (one-line errors for what is not glTF 2.0).

    A relative URI (an external buffer or image) resolves beside the file, else in ``base``: a ``.gltf``
    written into a staging folder refers to the unchanged files beside its final place.
    """
    path = Path(path)
    folders = _folders(path, base)
    raw = path.read_bytes()
    if not raw.strip():
        raise NeuralUVError(f"{path.name} is empty")
    if raw[:4] == b"glTF":
        if len(raw) < 20:
            raise NeuralUVError(f"{path.name}: truncated GLB header")
        _, version, length = struct.unpack("<4sII", raw[:12])
        if version != 2:
            raise NeuralUVError(f"{path.name}: GLB version {version}, need 2")
        pos, doc, bin_chunk = 12, None, None
        while pos + 8 <= min(length, len(raw)):
            clen, ctype = struct.unpack("<II", raw[pos:pos + 8])
            body = raw[pos + 8:pos + 8 + clen]
            if ctype == CHUNK_JSON and doc is None:
                doc = json.loads(body.decode("utf-8"))
                json_chunk = bytes(body)
            elif ctype == CHUNK_BIN and bin_chunk is None:
                bin_chunk = bytearray(body)
            pos += 8 + clen
        if doc is None:
            raise NeuralUVError(f"{path.name}: GLB without a JSON chunk")
        refuse_unreadable(path, doc)
        buffers = []
        for i, b in enumerate(doc.get("buffers", [])):
            if "uri" not in b and i == 0:
                buffers.append(bin_chunk if bin_chunk is not None else bytearray())
            else:
                buffers.append(_external(path, b, folders))
        return GltfDoc(path, doc, buffers, True, json_chunk, base)
    try:
        doc = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        raise NeuralUVError(f"{path.name}: neither a GLB nor glTF JSON") from None
    if not isinstance(doc, dict):
        raise NeuralUVError(f"{path.name}: its JSON is not a glTF object")
    refuse_unreadable(path, doc)
    return GltfDoc(path, doc, [_external(path, b, folders) for b in doc.get("buffers", [])], False, raw, base)


def external_file(uri, folders):
    """The file a relative ``uri`` (percent-encoded, ``/``-separated) names in the first of ``folders`` holding
    it; None for a data URI. Raises FileNotFoundError when no folder holds it."""
    from urllib.parse import unquote

    if uri.startswith("data:"):
        return None
    for folder in folders:
        p = Path(folder) / unquote(uri)
        if p.is_file():
            return p
    raise FileNotFoundError(uri)


def _external(path, b, folders=None):
    import base64

    uri = b.get("uri", "")
    if uri.startswith("data:"):
        return bytearray(base64.b64decode(uri.split(",", 1)[1]))
    try:
        return bytearray(external_file(uri, folders or [path.parent]).read_bytes())
    except FileNotFoundError:
        raise NeuralUVError(f"{path.name}: {uri!r} not found beside it") from None


def read_accessor(doc, i, *, raw=False):
    """Accessor ``i`` as an array (count, width); normalized integers as floats unless ``raw``."""
    a = doc.json["accessors"][i]
    dt = np.dtype(COMPONENT_DTYPE[a["componentType"]]).newbyteorder("<")
    w = TYPE_WIDTH[a["type"]]
    n = int(a["count"])
    if "sparse" in a:
        raise NeuralUVError(f"{doc.path.name}: accessor {i} is sparse (not supported)")
    if "bufferView" not in a:
        out = np.zeros((n, w), dt)
    else:
        bv = doc.json["bufferViews"][a["bufferView"]]
        buf = doc.buffers[bv["buffer"]]
        start = bv.get("byteOffset", 0) + a.get("byteOffset", 0)
        stride = bv.get("byteStride") or dt.itemsize * w
        if n and start + stride * (n - 1) + dt.itemsize * w > len(buf):
            raise NeuralUVError(f"{doc.path.name}: accessor {i} runs past its buffer")
        out = np.ndarray((n, w), dt, buffer=buf, offset=start, strides=(stride, dt.itemsize)).copy()  # no buffer copy
    if raw or not a.get("normalized", False):
        return out
    return np.maximum(out.astype(float) / np.iinfo(dt).max, -1.0)


def _world_matrices(doc):
    """The world matrix of the first node that instances each mesh (identity for meshes in no node)."""
    nodes = doc.json.get("nodes", [])
    scenes = doc.json.get("scenes", [])
    roots = scenes[doc.json.get("scene", 0)].get("nodes", []) if scenes else \
        sorted(set(range(len(nodes))) - {c for n in nodes for c in n.get("children", [])})
    out = {}
    stack = [(r, np.eye(4)) for r in reversed(roots)]
    seen = set()
    while stack:
        k, parent = stack.pop()
        if k in seen or k >= len(nodes):  # a cycle or a dangling index: the file is not a tree
            continue
        seen.add(k)
        n = nodes[k]
        if "matrix" in n:
            M = np.asarray(n["matrix"], float).reshape(4, 4).T
        else:
            t = np.asarray(n.get("translation", [0, 0, 0]), float)
            x, y, z, w = n.get("rotation", [0, 0, 0, 1])
            R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                          [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                          [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
            M = np.eye(4)
            M[:3, :3] = R * np.asarray(n.get("scale", [1, 1, 1]), float)[None, :]
            M[:3, 3] = t
        W = parent @ M
        if "mesh" in n and n["mesh"] not in out:
            out[n["mesh"]] = W
        for c in reversed(n.get("children", [])):
            stack.append((c, W))
    return out


def seamless_rows(V, F, UV, FUV):
    """The row each row is joined with: rows at the ends of an edge two faces share in 3D and in UV (both ends
    at bit-identical positions and UVs) though not in rows. A glTF exporter splits a vertex for its normals
    (hard edges, flat shading) as well as for its UVs; the faces on either side of such a split are one
    piece of the map, and the layout's topology (islands, folds, rings) is read on the joined rows.
    Faces that merely touch at a point, and faces without UV area (a palette's), join nothing.

    Parameters
    ----------
    V : (n,3) float array; F, FUV : (m,3) int arrays (``FUV`` -1 where a face has no UVs); UV : (p,2) float array

    Returns
    -------
    canon : (p,) int array, ``canon[r] <= r``, each group mapped to its smallest row.

    Examples
    --------
    Two triangles of a square, flat shaded (each with vertices of its own), one UV map:

    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    >>> F = np.array([[0, 1, 2], [3, 4, 5]])
    >>> seamless_rows(V, F, V[:, :2], F).tolist()
    [0, 1, 2, 1, 4, 2]
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    p = len(UV)
    ok = (FUV >= 0).all(1)
    ok[ok] = np.isfinite(UV[FUV[ok]]).all(axis=(1, 2))
    T = UV[FUV[ok]]
    ok[ok] = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]) != 0  # a face collapsed in UV (a palette's) joins nothing
    fin = np.isfinite(UV).all(1)
    if not ok.any() or len(np.unique(UV[fin], axis=0)) == fin.sum():  # no two rows alike: nothing to join
        return np.arange(p)
    f = np.flatnonzero(ok)
    rows = FUV[f].reshape(-1)
    key = np.c_[UV[rows], np.asarray(V, float)[np.asarray(F, np.int64)[f].reshape(-1)]]
    _, corner = np.unique(key, axis=0, return_inverse=True)
    corner = corner.reshape(-1, 3)  # per corner: its (UV, 3D) point
    R = rows.reshape(-1, 3)
    a, b = [0, 1, 2], [1, 2, 0]
    pa, pb = corner[:, a].reshape(-1), corner[:, b].reshape(-1)
    ra, rb = R[:, a].reshape(-1), R[:, b].reshape(-1)
    swap = pa > pb
    e = np.c_[np.where(swap, pb, pa), np.where(swap, pa, pb)]
    r1, r2 = np.where(swap, rb, ra), np.where(swap, ra, rb)  # the rows at the edge's first and second point
    _, eid = np.unique(e, axis=0, return_inverse=True)
    eid = eid.reshape(-1)
    first = np.full(eid.max() + 1, -1)
    first[eid[::-1]] = np.arange(len(eid))[::-1]  # one occurrence of each edge: the others join its rows
    j = first[eid]
    i = np.r_[r1, r2]
    k = np.r_[r1[j], r2[j]]
    A = coo_matrix((np.ones(len(i)), (i, k)), shape=(p, p))
    _, comp = connected_components(A, directed=False)
    low = np.full(comp.max() + 1, p, np.int64)
    np.minimum.at(low, comp, np.arange(p))
    return low[comp]


def _triangles(idx, mode):
    """Triangle index rows of a primitive's index list under its mode (4 list, 5 strip, 6 fan)."""
    idx = np.asarray(idx, np.int64).reshape(-1)
    if mode == 4:
        return idx[: len(idx) // 3 * 3].reshape(-1, 3)
    if len(idx) < 3:
        return np.zeros((0, 3), np.int64)
    k = np.arange(len(idx) - 2)
    if mode == 5:  # strip: every other triangle's first two corners swap, to keep the winding
        a, b = np.where(k % 2 == 0, idx[k], idx[k + 1]), np.where(k % 2 == 0, idx[k + 1], idx[k])
        return np.stack([a, b, idx[k + 2]], 1)
    return np.stack([np.full(len(k), idx[0]), idx[k + 1], idx[k + 2]], 1)  # fan


@dataclass
class GltfLayout:
    """A glTF file's UV layout over its textured triangle primitives (:func:`read_gltf_layout`).

    Attributes
    ----------
    V : (n,3) float array, world positions (one row per vertex of each read primitive).
    F : (m,3) int array; UV : (n,2) float array, ``v`` flipped to the OBJ convention; FUV : (m,3) int array,
        ``F`` with the rows of vertices split only for their normals joined (:func:`seamless_rows`: the map's
        topology, as an OBJ's shared ``vt``); -1 on the faces of primitives read without the UV set.
    blocks : list of dict, one per primitive read: ``mesh``, ``primitive``, ``uv_accessor``, ``rows`` (first row,
        count), ``faces`` (first face, count), ``mode``, ``indices`` (the primitive's triangle rows, local),
        ``aliases`` (``(mesh, primitive)`` of the primitives with the same positions, UV set and indices: read
        once, written with it; see :meth:`primitives`).
    skipped : list of str, primitives left out and why.
    texcoord : int, the UV set read (a dict per primitive, or None for geometry only: see :func:`read_gltf_layout`).
    materials, textures : int, counts in the file.
    """

    V: np.ndarray
    F: np.ndarray
    UV: np.ndarray
    FUV: np.ndarray
    blocks: list
    skipped: list
    texcoord: object
    doc: object = field(repr=False, default=None)
    materials: int = 0
    textures: int = 0

    def primitives(self, b):
        """The ``(mesh, primitive)`` of block ``b`` and of its aliases: every primitive that reads its data."""
        return [(b["mesh"], b["primitive"]), *b.get("aliases", [])]


def read_gltf_layout(path, texcoord=0, *, untextured=False, weld=True, base=None):
    """Read the ``TEXCOORD_<texcoord>`` layout of every triangle primitive of a glTF / GLB file.

    Parameters
    ----------
    path : str or Path
    texcoord : int, dict or None
        The UV set: one index for every primitive, a dict ``{(mesh, primitive): index}`` (primitives not in
        it are left out), or None for every triangle primitive's geometry with zero UVs (a mesh to unwrap).
    untextured : bool
        Read the triangle primitives without that UV set too, as faces without texture coordinates
        (``FUV`` -1, as an OBJ's faces without ``vt``: a layout for the whole mesh, a lightmap, gives them
        charts of their own).
    weld : bool
        Join the rows of vertices split only for their normals (:func:`seamless_rows`), so that the layout's
        islands and folds are read as the map has them (as an OBJ's shared ``vt``); False: one row per vertex
        (a layout about to be replaced by a new one, a lightmap, needs no such reading).
    base : path, optional
        A second folder for the file's relative URIs (:func:`load_gltf`).

    Returns
    -------
    GltfLayout

    Raises
    ------
    NeuralUVError
        Not glTF 2.0, or no primitive has that UV set.
    """
    doc = load_gltf(path, base)
    world = _world_matrices(doc)
    Vs, Fs, Us, blocks, skipped, untextured_faces = [], [], [], [], [], []
    rows = faces = 0
    done = {}
    for mi, mesh in enumerate(doc.json.get("meshes", [])):
        for pi, prim in enumerate(mesh.get("primitives", [])):
            mode = prim.get("mode", 4)
            attrs = prim.get("attributes", {})
            where = f"mesh {mi} ({mesh.get('name', '')!s}) primitive {pi}"
            k = texcoord.get((mi, pi)) if isinstance(texcoord, dict) else texcoord
            name = None if texcoord is None else f"TEXCOORD_{k}"
            if mode not in (4, 5, 6):
                skipped.append(f"{where}: points or lines (mode {mode}), no faces")
                continue
            if isinstance(texcoord, dict) and k is None:
                skipped.append(f"{where}: not asked for")
                continue
            missing = name is not None and name not in attrs
            if (missing and not untextured) or "POSITION" not in attrs:
                skipped.append(f"{where}: no {name or 'POSITION'}" + (" (not textured by this UV set)" if name else ""))
                continue
            tt = sampled_transform(doc.json, prim, k) if name and not missing else None  # read as sampled
            key = (attrs["POSITION"], attrs.get(name), prim.get("indices"), mode, json.dumps(tt, sort_keys=True))
            if key in done:  # the same data under another primitive (another material): read once, written with it
                blocks[done[key]]["aliases"].append((mi, pi))
                continue
            done[key] = len(blocks)
            P = read_accessor(doc, attrs["POSITION"]).astype(float)
            T = np.zeros((len(P), 2)) if not name or missing else read_accessor(doc, attrs[name]).astype(float)
            if len(T) != len(P):
                raise NeuralUVError(f"{Path(path).name}: {where}: {name} has {len(T)} entries, POSITION {len(P)}")
            idx = read_accessor(doc, prim["indices"]).reshape(-1) if "indices" in prim else np.arange(len(P))
            if len(idx) and (idx.min() < 0 or idx.max() >= len(P)):
                raise NeuralUVError(f"{Path(path).name}: {where}: an index is out of range")
            tri = _triangles(idx, mode)
            M = world.get(mi, np.eye(4))
            Vs.append(P @ M[:3, :3].T + M[:3, 3])
            Us.append(transform_map(tt)(np.c_[T[:, 0], 1.0 - T[:, 1]]))
            Fs.append(tri + rows)
            if missing:
                untextured_faces.append(np.arange(faces, faces + len(tri)))
            blocks.append({"mesh": mi, "primitive": pi, "uv_accessor": attrs.get(name), "rows": (rows, len(P)),
                           "faces": (faces, len(tri)), "mode": mode, "indices": tri, "aliases": [],
                           "transform": tt})
            rows += len(P)
            faces += len(tri)
    if not blocks:
        what = "TEXCOORD_%d" % texcoord if isinstance(texcoord, int) else "the asked-for UV sets" \
            if texcoord is not None else "positions"
        raise NeuralUVError(f"{Path(path).name} has no triangle primitive with {what}"
                            + (f" ({skipped[0]})" if skipped else ""))
    F = np.vstack(Fs).astype(np.int64)
    V = np.vstack(Vs)
    bad = ~np.isfinite(V).all(1)
    if bad.any():
        raise NeuralUVError(f"{Path(path).name} has {int(bad.sum())} vertices with NaN or infinite coordinates "
                            "(after the node transforms); fix or remove them")
    FUV = F.copy()
    if untextured_faces:  # faces without texture coordinates, as an OBJ's faces without vt
        FUV[np.concatenate(untextured_faces)] = -1
    UV = np.vstack(Us)
    if weld and texcoord is not None:  # a vertex split for its normals is no seam of the map
        canon = seamless_rows(V, F, UV, FUV)
        FUV = np.where(FUV >= 0, canon[np.maximum(FUV, 0)], -1)
    return GltfLayout(V=V, F=F, UV=UV, FUV=FUV, blocks=blocks, skipped=skipped,
                      texcoord=texcoord if texcoord is None or isinstance(texcoord, dict) else int(texcoord),
                      doc=doc, materials=len(doc.json.get("materials", [])),
                      textures=len(doc.json.get("textures", [])))


def image_bytes(doc, i):
    """The encoded bytes of image ``i`` (from its bufferView, a data URI or a file beside the glTF)."""
    im = doc.json["images"][i]
    if "bufferView" in im:
        bv = doc.json["bufferViews"][im["bufferView"]]
        start = bv.get("byteOffset", 0)
        return bytes(doc.buffers[bv["buffer"]][start:start + bv["byteLength"]])
    return bytes(_external(doc.path, {"uri": im.get("uri", "")}, doc.folders()))
