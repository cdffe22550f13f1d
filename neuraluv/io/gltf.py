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

:func:`write_gltf_uvs` writes the binary glTF (GLB) back: every byte of the
input — nodes, transforms, normals, materials, images, skins, other UV sets,
extensions — is kept. Under ``mode="replace"`` only the changed rows of the
UV accessors are overwritten in place (float accessors; a normalized integer
accessor is replaced by a float one). Under ``mode="add"`` every primitive gets
the new layout as one UV set ``TEXCOORD_k`` (the first ``k`` unused on all of
them), leaving the others alone; a primitive with fewer sets has its missing
lower ones filled with the same accessor (glTF set indices run on from 0).
When the new layout splits a vertex (one vertex, two UVs), the primitive's
vertex attributes are gathered onto the split vertices in new accessors (the
values are copied, not changed).

Nothing here changes a file's meaning beyond the UVs: it is the GLB
counterpart of :func:`~neuraluv.io.obj.patch_obj`.
"""
from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from neuraluv.errors import NeuralUVError
from neuraluv.io.files import atomic_write
from neuraluv.io.gltf_extensions import refuse_unreadable

__all__ = ["GltfLayout", "read_gltf_layout", "write_gltf_uvs", "load_gltf", "image_bytes", "replace_images"]

_DTYPE = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_GLB_MAGIC, _JSON, _BIN = 0x46546C67, 0x4E4F534A, 0x004E4942


@dataclass
class _Doc:
    path: Path
    json: dict
    buffers: list  # bytearray per buffer (the GLB's BIN chunk is buffer 0)
    glb: bool
    json_chunk: bytes = b""  # the JSON chunk as read: written back unchanged when the JSON did not change


def load_gltf(path):
    """The JSON and the buffers of a ``.glb`` or ``.gltf`` file (one-line errors for what is not glTF 2.0)."""
    path = Path(path)
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
            if ctype == _JSON and doc is None:
                doc = json.loads(body.decode("utf-8"))
                json_chunk = bytes(body)
            elif ctype == _BIN and bin_chunk is None:
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
                buffers.append(_external(path, b))
        return _Doc(path, doc, buffers, True, json_chunk)
    try:
        doc = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        raise NeuralUVError(f"{path.name}: neither a GLB nor glTF JSON") from None
    refuse_unreadable(path, doc)
    return _Doc(path, doc, [_external(path, b) for b in doc.get("buffers", [])], False)


def _external(path, b):
    import base64
    from urllib.parse import unquote

    uri = b.get("uri", "")
    if uri.startswith("data:"):
        return bytearray(base64.b64decode(uri.split(",", 1)[1]))
    p = path.parent / unquote(uri)
    if not p.is_file():
        raise NeuralUVError(f"{path.name}: buffer {uri!r} not found beside it")
    return bytearray(p.read_bytes())


def _accessor(doc, i, *, raw=False):
    """Accessor ``i`` as an array (count, width); normalized integers as floats unless ``raw``."""
    a = doc.json["accessors"][i]
    dt = np.dtype(_DTYPE[a["componentType"]]).newbyteorder("<")
    w = _WIDTH[a["type"]]
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


def read_gltf_layout(path, texcoord=0, *, untextured=False, weld=True):
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

    Returns
    -------
    GltfLayout

    Raises
    ------
    NeuralUVError
        Not glTF 2.0, or no primitive has that UV set.
    """
    doc = load_gltf(path)
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
            key = (attrs["POSITION"], attrs.get(name), prim.get("indices"), mode)
            if key in done:  # the same data under another primitive (another material): read once, written with it
                blocks[done[key]]["aliases"].append((mi, pi))
                continue
            done[key] = len(blocks)
            P = _accessor(doc, attrs["POSITION"]).astype(float)
            T = np.zeros((len(P), 2)) if not name or missing else _accessor(doc, attrs[name]).astype(float)
            if len(T) != len(P):
                raise NeuralUVError(f"{Path(path).name}: {where}: {name} has {len(T)} entries, POSITION {len(P)}")
            idx = _accessor(doc, prim["indices"]).reshape(-1) if "indices" in prim else np.arange(len(P))
            if len(idx) and (idx.min() < 0 or idx.max() >= len(P)):
                raise NeuralUVError(f"{Path(path).name}: {where}: an index is out of range")
            tri = _triangles(idx, mode)
            M = world.get(mi, np.eye(4))
            Vs.append(P @ M[:3, :3].T + M[:3, 3])
            Us.append(np.c_[T[:, 0], 1.0 - T[:, 1]])
            Fs.append(tri + rows)
            if missing:
                untextured_faces.append(np.arange(faces, faces + len(tri)))
            blocks.append({"mesh": mi, "primitive": pi, "uv_accessor": attrs.get(name), "rows": (rows, len(P)),
                           "faces": (faces, len(tri)), "mode": mode, "indices": tri, "aliases": []})
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


def _append(doc, data, *, target=None):
    """Append bytes to buffer 0 (4-byte aligned) as a new bufferView; its index."""
    buf = doc.buffers[0]
    pad = (-len(buf)) % 4
    buf.extend(b"\0" * pad)
    view = {"buffer": 0, "byteOffset": len(buf), "byteLength": len(data)}
    if target:
        view["target"] = target
    buf.extend(data)
    doc.json.setdefault("bufferViews", []).append(view)
    return len(doc.json["bufferViews"]) - 1


def _new_accessor(doc, arr, like=None, *, target=34962):
    """A new accessor holding ``arr`` (n,w): float32, the component type and flags of accessor ``like``, or
    (for indices, ``target=34963``) the unsigned integer type of ``arr``."""
    arr = np.asarray(arr)
    if target == 34963:
        comp = {np.dtype(np.uint8): 5121, np.dtype(np.uint16): 5123}.get(arr.dtype, 5125)
        dt, norm, typ = np.dtype(_DTYPE[comp]).newbyteorder("<"), False, "SCALAR"
    elif like is not None:
        a0 = doc.json["accessors"][like]
        dt, comp, norm = np.dtype(_DTYPE[a0["componentType"]]).newbyteorder("<"), a0["componentType"], \
            a0.get("normalized", False)
        typ = a0["type"]
    else:
        dt, comp, norm = np.dtype("<f4"), 5126, False
        typ = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[arr.shape[1]]
    data = np.ascontiguousarray(arr.astype(dt))
    view = _append(doc, data.tobytes(), target=target)
    acc = {"bufferView": view, "componentType": comp, "count": int(len(arr)), "type": typ}
    if norm:
        acc["normalized"] = True
    if like is not None and ("min" in doc.json["accessors"][like] or "max" in doc.json["accessors"][like]) and len(arr):
        acc["min"] = data.min(0).tolist()
        acc["max"] = data.max(0).tolist()
    doc.json["accessors"].append(acc)
    return len(doc.json["accessors"]) - 1


def _float_uv(uv):
    """OBJ-convention UVs to glTF float32 rows (``v`` flipped back)."""
    return np.c_[uv[:, 0], 1.0 - uv[:, 1]].astype("<f4")


def write_gltf_uvs(layout, UV, FUV, dst, *, mode="replace"):
    """Write a GLB copy of ``layout``'s file with a new layout, changing nothing else.

    Parameters
    ----------
    layout : GltfLayout
        As read (its file's bytes are the base).
    UV : (p,2) float array
        The layout's rows first (rows equal bit for bit to ``layout.UV`` are not written), then new rows.
    FUV : (m,3) int array
        Per-triangle rows, one row of faces per face of ``layout.F``.
    dst : path of the ``.glb`` to write (atomically).
    mode : {"replace", "add"}
        ``replace``: the UV set that was read gets the new values. ``add``: a new UV set
        ``TEXCOORD_k``, one ``k`` for every primitive written (the first set free on all of them, so that a
        baker reading one set index finds the whole layout); the sets already there stay as they are. A
        primitive with fewer sets gets its missing lower sets as the same accessor (glTF wants set indices
        continuous from 0), listed in ``filled``.

    Returns
    -------
    dict: ``mode``, ``texcoord`` (the set written, per primitive), ``rows_changed``, ``primitives_split``
    (primitives whose vertices had to be split, their attributes copied to new accessors), ``filled``
    (``(mesh, primitive, [set, ...])`` for each primitive whose lower sets were filled with the new layout).
    """
    import copy

    if mode == "replace" and not isinstance(layout.texcoord, int):
        raise NeuralUVError("replacing a UV set needs a layout read with one set index (add a set instead)")
    doc = layout.doc
    doc = _Doc(doc.path, copy.deepcopy(doc.json), [bytearray(b) for b in doc.buffers], doc.glb,
               doc.json_chunk)
    original = copy.deepcopy(doc.json)
    size0 = len(doc.buffers[0])
    if not doc.glb or len(doc.buffers) > 1 or any("uri" in b for b in doc.json.get("buffers", [])):
        raise NeuralUVError("writing back needs a GLB with its one buffer inside (external or several buffers: "
                            "convert it to GLB first)")
    if not doc.buffers:
        doc.buffers.append(bytearray())
        doc.json["buffers"] = [{"byteLength": 0}]
    UV = np.asarray(UV, float)
    FUV = np.asarray(FUV, np.int64)
    p0 = len(layout.UV)
    if FUV.shape != layout.F.shape or len(UV) < p0 or not np.isfinite(UV[np.unique(FUV)]).all():
        raise NeuralUVError("the new layout must give finite UVs to every face of the one read")
    same = (np.ascontiguousarray(UV[:p0]).view(np.int64) == np.ascontiguousarray(layout.UV).view(np.int64)).all(1)
    info = {"mode": mode, "texcoord": [], "rows_changed": int((~same).sum()), "primitives_split": 0, "filled": []}
    prims = [doc.json["meshes"][mi]["primitives"][pi] for b in layout.blocks for mi, pi in layout.primitives(b)]
    k_add = max(_free_set(p) for p in prims)

    def put(b, prim, acc, k=None):  # the new layout as TEXCOORD_k (k_add); lower sets the primitive lacks: the same
        k = k_add if k is None else k
        gaps = [j for j in range(k) if f"TEXCOORD_{j}" not in prim["attributes"]]
        for j in gaps + [k]:
            prim["attributes"][f"TEXCOORD_{j}"] = acc
        if gaps:
            info["filled"].append((b["mesh"], b["primitive"], gaps))
        info["texcoord"].append(k)

    for b in layout.blocks:
        shared = {}  # the accessors made for this block, given to every primitive that reads its data
        for mi, pi in layout.primitives(b):
            _write_block(doc, b, doc.json["meshes"][mi]["primitives"][pi], layout, UV, FUV, mode, put, info, shared)
    if len(doc.buffers[0]) != size0:  # data appended (the chunk read may hold padding beyond byteLength)
        doc.json["buffers"][0]["byteLength"] = len(doc.buffers[0])
    _write_glb(doc, dst, keep_json=doc.json == original)
    return info


def _write_block(doc, b, prim, layout, UV, FUV, mode, put, info, shared):
    """Write the new layout of block ``b`` to primitive ``prim`` (the block's or an alias's): in place, as a new
    set, or on split vertices; accessors made once per block are kept in ``shared``."""
    r0, nr = b["rows"]
    f0, nf = b["faces"]
    own = FUV[f0:f0 + nf]
    local = b["indices"]  # (nf,3) vertex of each corner
    # the row each vertex needs: one per vertex unless the layout split it
    pairs = np.unique(np.c_[local.reshape(-1), own.reshape(-1)], axis=0)
    split = len(pairs) != len(np.unique(pairs[:, 0]))
    if not split:
        vrow = np.arange(nr) + r0
        vrow[pairs[:, 0]] = pairs[:, 1]  # the row each vertex reads (a joined row may be another vertex's)
        changed = (np.ascontiguousarray(UV[vrow]).view(np.int64)
                   != np.ascontiguousarray(layout.UV[r0:r0 + nr]).view(np.int64)).any(1)
        if mode == "replace":
            if not changed.any():
                info["texcoord"].append(layout.texcoord)
                return
            acc_i = b["uv_accessor"]
            acc = doc.json["accessors"][acc_i] if acc_i is not None else {}
            if acc.get("componentType") == 5126 and "bufferView" in acc and "sparse" not in acc:
                if "in place" not in shared:  # the accessor is the block's: written once for all its primitives
                    bv = doc.json["bufferViews"][acc["bufferView"]]
                    start = bv.get("byteOffset", 0) + acc.get("byteOffset", 0)
                    stride = bv.get("byteStride") or 8
                    new = _float_uv(UV[vrow[changed]])
                    buf = doc.buffers[bv["buffer"]]
                    for v, val in zip(np.flatnonzero(changed), new):
                        buf[start + stride * v:start + stride * v + 8] = val.tobytes()
                    if "min" in acc or "max" in acc:  # declared bounds must stay true (the validator checks them)
                        vals = _accessor(doc, acc_i)
                        acc["min"], acc["max"] = vals.min(0).tolist(), vals.max(0).tolist()
                    shared["in place"] = True
                info["texcoord"].append(layout.texcoord)
                return
            # a normalized integer (or odd) accessor, or none (read untextured): a float one in its place
            if "uv" not in shared:
                shared["uv"] = _new_accessor(doc, _float_uv(UV[vrow]))
            put(b, prim, shared["uv"], layout.texcoord)
            return
        if "uv" not in shared:
            shared["uv"] = _new_accessor(doc, _float_uv(UV[vrow]))
        put(b, prim, shared["uv"])
        return
    # split vertices: gather every vertex attribute (and morph target) onto the new vertices
    info["primitives_split"] += 1
    corner_v = local.reshape(-1)
    corner_r = own.reshape(-1)
    uniq, inv = np.unique(np.c_[corner_v, corner_r], axis=0, return_inverse=True)
    src_v = uniq[:, 0]
    gathered = shared.setdefault("gathered", {})  # attributes the block's primitives share: gathered once
    for name, ai in list(prim["attributes"].items()):
        if mode == "replace" and name == f"TEXCOORD_{layout.texcoord}":
            continue
        if ai not in gathered:
            gathered[ai] = _new_accessor(doc, _accessor(doc, ai, raw=True)[src_v], like=ai)
        prim["attributes"][name] = gathered[ai]
    for t in prim.get("targets", []):
        for name, ai in list(t.items()):
            if ai not in gathered:
                gathered[ai] = _new_accessor(doc, _accessor(doc, ai, raw=True)[src_v], like=ai)
            t[name] = gathered[ai]
    if "split uv" not in shared:
        shared["split uv"] = _new_accessor(doc, _float_uv(UV[uniq[:, 1]]))
        tri = inv.reshape(-1).astype(np.uint32 if len(uniq) > 65535 else np.uint16)
        shared["indices"] = _new_accessor(doc, tri.reshape(-1, 1), target=34963)
    put(b, prim, shared["split uv"], layout.texcoord if mode == "replace" else None)
    prim["indices"] = shared["indices"]
    prim["mode"] = 4


def _free_set(prim):
    k = 0
    while f"TEXCOORD_{k}" in prim["attributes"]:
        k += 1
    return k


def _write_glb(doc, dst, keep_json=False):
    body = doc.json_chunk if keep_json and doc.json_chunk else json.dumps(doc.json, separators=(",", ":")).encode()
    body += b" " * ((-len(body)) % 4)
    binary = bytes(doc.buffers[0]) + b"\0" * ((-len(doc.buffers[0])) % 4)
    chunks = struct.pack("<II", len(body), _JSON) + body
    if doc.json.get("buffers"):
        chunks += struct.pack("<II", len(binary), _BIN) + binary
    with atomic_write(dst, "wb") as fh:
        fh.write(struct.pack("<III", _GLB_MAGIC, 2, 12 + len(chunks)) + chunks)


def image_bytes(doc, i):
    """The encoded bytes of image ``i`` (from its bufferView, a data URI or a file beside the glTF)."""
    im = doc.json["images"][i]
    if "bufferView" in im:
        bv = doc.json["bufferViews"][im["bufferView"]]
        start = bv.get("byteOffset", 0)
        return bytes(doc.buffers[bv["buffer"]][start:start + bv["byteLength"]])
    return bytes(_external(doc.path, {"uri": im.get("uri", "")}))


def replace_images(src, dst, images):
    """Write a GLB copy of ``src`` whose images ``{index: PNG bytes}`` are replaced (appended to the binary
    chunk; the old data stays, unused); every other byte of the document is kept."""
    doc = load_gltf(src)
    if not doc.glb or len(doc.buffers) != 1:
        raise NeuralUVError("replacing images needs a GLB with its one buffer inside")
    for i, data in images.items():
        im = doc.json["images"][i]
        im.pop("uri", None)
        im["bufferView"] = _append(doc, data)
        im["mimeType"] = "image/png"
    doc.json["buffers"][0]["byteLength"] = len(doc.buffers[0])
    _write_glb(doc, dst)
