"""Write a copy of a glTF layout's file that differs only in its UV set (or in an added one).

:func:`write_gltf_uvs` writes the document back, as a binary glTF (``.glb``) or
as glTF JSON with its buffers in ``.bin`` files beside it (``.gltf``,
:func:`write_gltf`): every byte of the input's data — nodes, transforms,
normals, materials, images, skins, other UV sets, extensions — is kept. Under ``mode="replace"`` only the changed rows of the
UV accessors are overwritten in place (float accessors; a normalized integer
accessor is replaced by a float one), in the set's stored space (a
``KHR_texture_transform`` the layout was read through is undone). Under
``mode="add"`` every primitive gets the new layout as one UV set ``TEXCOORD_k``
(the first ``k`` unused on all of them), leaving the others alone; a primitive
with fewer sets has its missing lower ones filled with the same accessor (glTF
set indices run on from 0). When the new layout splits a vertex (one vertex,
two UVs), the primitive's vertex attributes are gathered onto the split
vertices in new accessors (the values are copied, not changed). Primitives
that read the same data (:meth:`~neuraluv.io.gltf.GltfLayout.primitives`) are
written together.

Nothing here changes a file's meaning beyond the UVs: it is the glTF
counterpart of :func:`~neuraluv.io.obj.patch_obj`. A ``.gltf`` output refers to
the input's unchanged external files (buffers, images) where they are, by
relative URIs from its own folder; only changed buffers are written anew. A
``.glb`` output of a ``.gltf`` input holds its buffers and images inside.
"""
from __future__ import annotations

import copy
import json
import os
import struct
from pathlib import Path
from urllib.parse import quote, unquote

import numpy as np

from neuraluv.errors import NeuralUVError
from neuraluv.io.files import atomic_write
from neuraluv.io.gltf import (CHUNK_BIN, CHUNK_JSON, COMPONENT_DTYPE, GLB_MAGIC, GltfDoc, external_file, image_bytes,
                              load_gltf, read_accessor)
from neuraluv.io.gltf_extensions import transform_map
from neuraluv.io.gltf_tangents import retangent

__all__ = ["write_gltf_uvs", "write_gltf", "write_glb", "replace_images", "new_accessor"]

#: Image MIME types by file ending (glTF core and the image extensions), for images moved into a GLB.
IMAGE_MIME = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg", ".webp": "image/webp",
              ".ktx2": "image/ktx2"}


def _append(doc, data, *, target=None, stride=None):
    """Append bytes to buffer 0 (4-byte aligned) as a new bufferView; its index."""
    buf = doc.buffers[0]
    pad = (-len(buf)) % 4
    buf.extend(b"\0" * pad)
    view = {"buffer": 0, "byteOffset": len(buf), "byteLength": len(data)}
    if stride:
        view["byteStride"] = stride
    if target:
        view["target"] = target
    buf.extend(data)
    doc.json.setdefault("bufferViews", []).append(view)
    return len(doc.json["bufferViews"]) - 1


def new_accessor(doc, arr, like=None, *, target=34962):
    """A new accessor holding ``arr`` (n,w): float32, the component type and flags of accessor ``like``, or
    (for indices, ``target=34963``) the unsigned integer type of ``arr``."""
    arr = np.asarray(arr)
    if target == 34963:
        comp = {np.dtype(np.uint8): 5121, np.dtype(np.uint16): 5123}.get(arr.dtype, 5125)
        dt, norm, typ = np.dtype(COMPONENT_DTYPE[comp]).newbyteorder("<"), False, "SCALAR"
    elif like is not None:
        a0 = doc.json["accessors"][like]
        dt, comp, norm = np.dtype(COMPONENT_DTYPE[a0["componentType"]]).newbyteorder("<"), a0["componentType"], \
            a0.get("normalized", False)
        typ = a0["type"]
    else:
        dt, comp, norm = np.dtype("<f4"), 5126, False
        typ = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[arr.shape[1]]
    data = np.ascontiguousarray(arr.astype(dt))
    raw, elem, stride = data.tobytes(), dt.itemsize * (data.shape[1] if data.ndim == 2 else 1), None
    if target == 34962 and elem % 4:  # a vertex attribute's elements start on 4-byte boundaries (quantized ones)
        stride = elem + (-elem) % 4
        padded = np.zeros((len(data), stride), np.uint8)
        padded[:, :elem] = np.frombuffer(raw, np.uint8).reshape(len(data), elem)
        raw = padded.tobytes()
    view = _append(doc, raw, target=target, stride=stride)
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


def write_gltf_uvs(layout, UV, FUV, dst, *, mode="replace", base=None):
    """Write a copy of ``layout``'s file with a new layout, changing nothing else.

    Parameters
    ----------
    layout : GltfLayout
        As read (its file's bytes are the base).
    UV : (p,2) float array
        The layout's rows first (rows equal bit for bit to ``layout.UV`` are not written), then new rows.
    FUV : (m,3) int array
        Per-triangle rows, one row of faces per face of ``layout.F``.
    dst : path of the ``.glb`` or ``.gltf`` to write (atomically; :func:`write_gltf`).
    mode : {"replace", "add"}
        ``replace``: the UV set that was read gets the new values. ``add``: a new UV set
        ``TEXCOORD_k``, one ``k`` for every primitive written (the first set free on all of them, so that a
        baker reading one set index finds the whole layout); the sets already there stay as they are. A
        primitive with fewer sets gets its missing lower sets as the same accessor (glTF wants set indices
        continuous from 0), listed in ``filled``.
    base : path, optional
        The folder the file ends up in, when ``dst`` is written into a staging folder (:func:`write_gltf`).

    Returns
    -------
    dict: ``mode``, ``texcoord`` (the set written, per primitive), ``rows_changed``, ``primitives_split``
    (primitives whose vertices had to be split, their attributes copied to new accessors), ``filled``
    (``(mesh, primitive, [set, ...])`` for each primitive whose lower sets were filled with the new layout).
    """
    if mode == "replace" and not isinstance(layout.texcoord, int):
        raise NeuralUVError("replacing a UV set needs a layout read with one set index (add a set instead)")
    doc = layout.doc
    doc = GltfDoc(doc.path, copy.deepcopy(doc.json), [bytearray(b) for b in doc.buffers], doc.glb,
                  doc.json_chunk, doc.base)
    original = copy.deepcopy(doc.json)
    sizes = [len(b) for b in doc.buffers]
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
    _clear_left_behind(doc, {b["uv_accessor"] for b in layout.blocks} - {None})
    for i, n in enumerate(sizes):
        if len(doc.buffers[i]) != n:  # data appended (the chunk read may hold padding beyond byteLength)
            doc.json["buffers"][i]["byteLength"] = len(doc.buffers[i])
    write_gltf(doc, dst, keep_json=doc.json == original, base=base)
    return info


def _write_block(doc, b, prim, layout, UV, FUV, mode, put, info, shared):
    """Write the new layout of block ``b`` to primitive ``prim`` (the block's or an alias's): in place, as a new
    set, or on split vertices; accessors made once per block are kept in ``shared``."""
    r0, nr = b["rows"]
    f0, nf = b["faces"]
    own = FUV[f0:f0 + nf]
    stored = transform_map(b.get("transform") if mode == "replace" else None, inverse=True)  # the set's own space
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
                    new = _float_uv(stored(UV[vrow[changed]]))
                    buf = doc.buffers[bv["buffer"]]
                    for v, val in zip(np.flatnonzero(changed), new):
                        buf[start + stride * v:start + stride * v + 8] = val.tobytes()
                    if "min" in acc or "max" in acc:  # declared bounds must stay true (the validator checks them)
                        vals = read_accessor(doc, acc_i)
                        acc["min"], acc["max"] = vals.min(0).tolist(), vals.max(0).tolist()
                    shared["in place"] = True
                info["texcoord"].append(layout.texcoord)
                _tangents(doc, b, prim, layout, np.flatnonzero(changed), info, shared)
                return
            if "in place" in shared or _requantized(doc, acc_i, UV, vrow, changed, local, b.get("transform")):
                shared["in place"] = True  # a 16-bit quantized set: the changed rows on its grid, the rest as they were
                info["texcoord"].append(layout.texcoord)
                _tangents(doc, b, prim, layout, np.flatnonzero(changed), info, shared)
                return
            # a normalized 8-bit (or odd) accessor, a grid the repair does not fit, or none (read untextured): a float
            # accessor in its place
            if "uv" not in shared:
                shared["uv"] = new_accessor(doc, _float_uv(stored(UV[vrow])))
            put(b, prim, shared["uv"], layout.texcoord)
            _tangents(doc, b, prim, layout, np.flatnonzero(changed), info, shared)
            return
        if "uv" not in shared:
            shared["uv"] = new_accessor(doc, _float_uv(UV[vrow]))
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
            gathered[ai] = new_accessor(doc, read_accessor(doc, ai, raw=True)[src_v], like=ai)
        prim["attributes"][name] = gathered[ai]
    for t in prim.get("targets", []):
        for name, ai in list(t.items()):
            if ai not in gathered:
                gathered[ai] = new_accessor(doc, read_accessor(doc, ai, raw=True)[src_v], like=ai)
            t[name] = gathered[ai]
    values = UV[uniq[:, 1]]
    moved = (np.ascontiguousarray(values).view(np.int64)
             != np.ascontiguousarray(layout.UV[r0 + src_v]).view(np.int64)).any(1)
    if "split uv" not in shared:
        tri = inv.reshape(-1).astype(np.uint32 if len(uniq) > 65535 else np.uint16)
        acc_i = b["uv_accessor"] if mode == "replace" else None
        q = _on_grid(doc, acc_i, values, moved, tri.reshape(-1, 3).astype(np.int64), src_v,
                     b.get("transform"))  # a quantized set stays quantized, its unmoved vertices' integers copied
        shared["split uv"] = new_accessor(doc, q, like=acc_i) if q is not None else \
            new_accessor(doc, _float_uv(stored(values)))
        shared["indices"] = new_accessor(doc, tri.reshape(-1, 1), target=34963)
    put(b, prim, shared["split uv"], layout.texcoord if mode == "replace" else None)
    prim["indices"] = shared["indices"]
    prim["mode"] = 4
    if mode == "replace":
        _tangents(doc, b, prim, layout, np.flatnonzero(moved), info, shared)


def _tangents(doc, b, prim, layout, verts, info, shared):
    """The ``TANGENT`` rows of the moved vertices recomputed (:func:`~neuraluv.io.gltf_tangents.retangent`),
    once per tangent accessor; counted in ``info["tangents"]`` (``info["tangents_kept"]``: primitives whose
    quantized tangents could not be rewritten)."""
    ti = prim["attributes"].get("TANGENT")
    if ti is None or ("tangent", ti) in shared:
        return
    shared[("tangent", ti)] = True
    before = (layout.doc, layout.doc.json["meshes"][b["mesh"]]["primitives"][b["primitive"]])
    n = retangent(doc, prim, verts, layout.texcoord, before)
    if n is None:
        info.setdefault("tangents_kept", []).append((b["mesh"], b["primitive"]))
    else:
        info["tangents"] = info.get("tangents", 0) + n


def _on_grid(doc, acc_i, values, changed, faces, src, transform):
    """A normalized 16-bit UV accessor's integers (KHR_mesh_quantization) for vertices with the layout ``values``
    ((k,2), as read through ``transform``: sampled, OBJ convention): the accessor's own integers at vertices ``src``
    (k,) where not ``changed``, the changed ones on the grid
    (rounded; a vertex of a face the rounding broke tries the grid points around it); None when the grid cannot
    hold the layout: a value off its range, or a face of ``faces`` ((t,3) into the k vertices) touching a changed
    vertex that loses its orientation or nine tenths of its UV area. (A float accessor in its place would move
    every vertex the repair left alone by float32 rounding.)"""
    acc = doc.json["accessors"][acc_i] if acc_i is not None else {}
    comp = acc.get("componentType")
    if comp not in (5122, 5123) or not acc.get("normalized") or "bufferView" not in acc or "sparse" in acc:
        return None
    top = float(np.iinfo(COMPONENT_DTYPE[comp]).max)
    g = transform_map(transform, inverse=True)(values[changed])  # where the set stores them
    q = np.rint(np.c_[g[:, 0], 1.0 - g[:, 1]] * top)
    if not np.isfinite(q).all() or (len(q) and (q.min() < (-top if comp == 5122 else 0.0) or q.max() > top)):
        return None
    lo, tf = (-top if comp == 5122 else 0.0), transform_map(transform)

    def sampled(qv):  # grid integers (k,2) as read back (read_accessor), then where the texture samples them
        back = np.maximum(qv / top, -1.0)
        return tf(np.c_[back[:, 0], 1.0 - back[:, 1]])

    def holds(fs):  # (t,) bool: faces keep their orientation and a tenth of their UV area on the grid
        def area(U):
            a, b, c = U[fs[:, 0]], U[fs[:, 1]], U[fs[:, 2]]
            return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        a0, a1 = area(values), area(snapped)
        return (a0 == 0) | ((np.sign(a1) == np.sign(a0)) & (np.abs(a1) >= 0.1 * np.abs(a0)))

    qall = np.zeros((len(values), 2))
    qall[changed] = q
    snapped = values.copy()
    snapped[changed] = sampled(q)
    touch = faces[changed[faces].any(1)]
    for _ in range(3):  # a vertex of a face the rounding broke tries the grid points around it
        broken = touch[~holds(touch)]
        if not len(broken):
            break
        for v in np.unique(broken[changed[broken]]):
            around = faces[(faces == v).any(1)]
            for step in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)):
                trial = qall[v] + step
                if trial.min() < lo or trial.max() > top:
                    continue
                keep = snapped[v].copy()
                snapped[v] = sampled(trial[None])[0]
                if holds(around).all():
                    qall[v] = trial
                    break
                snapped[v] = keep
    if not holds(touch).all():
        return None
    out = read_accessor(doc, acc_i, raw=True)[src]
    out[changed] = qall[changed]
    return out.astype(COMPONENT_DTYPE[comp])


def _requantized(doc, acc_i, UV, vrow, changed, local, transform):
    """The changed vertices of a 16-bit quantized UV accessor written in place on its grid (:func:`_on_grid`);
    False (nothing written) when the grid does not hold the layout."""
    q = _on_grid(doc, acc_i, UV[vrow], changed, local, np.arange(len(vrow)), transform)
    if q is None:
        return False
    acc = doc.json["accessors"][acc_i]
    bv = doc.json["bufferViews"][acc["bufferView"]]
    start = bv.get("byteOffset", 0) + acc.get("byteOffset", 0)
    width = 2 * q.dtype.itemsize
    stride = bv.get("byteStride") or width
    buf = doc.buffers[bv["buffer"]]
    for v in np.flatnonzero(changed):
        buf[start + stride * v:start + stride * v + width] = q[v].astype(q.dtype.newbyteorder("<")).tobytes()
    if "min" in acc or "max" in acc:
        vals = read_accessor(doc, acc_i, raw=True)
        acc["min"], acc["max"] = vals.min(0).tolist(), vals.max(0).tolist()
    return True


def _clear_left_behind(doc, replaced):
    """Zero the non-finite values of the float accessors of ``replaced`` that no primitive reads any longer (a UV
    set with NaN rows a repair gave a new accessor): the file keeps no value the glTF validator calls invalid."""
    live = set()
    for mesh in doc.json.get("meshes", []):
        for p in mesh.get("primitives", []):
            live |= set(p.get("attributes", {}).values()) | {x for t in p.get("targets", []) for x in t.values()}
    for ai in sorted(set(replaced) - live):
        acc = doc.json["accessors"][ai]
        if acc.get("componentType") != 5126 or "bufferView" not in acc or "sparse" in acc:
            continue
        vals = read_accessor(doc, ai)
        bad = np.argwhere(~np.isfinite(vals))
        if not len(bad):
            continue
        bv = doc.json["bufferViews"][acc["bufferView"]]
        start = bv.get("byteOffset", 0) + acc.get("byteOffset", 0)
        stride = bv.get("byteStride") or 4 * vals.shape[1]
        for r, c in bad:
            doc.buffers[bv["buffer"]][start + stride * r + 4 * c:start + stride * r + 4 * c + 4] = bytes(4)
        if "min" in acc or "max" in acc:
            vals = read_accessor(doc, ai)
            acc["min"], acc["max"] = vals.min(0).tolist(), vals.max(0).tolist()


def _free_set(prim):
    k = 0
    while f"TEXCOORD_{k}" in prim["attributes"]:
        k += 1
    return k


def write_gltf(doc, dst, *, keep_json=False, base=None, update=False):
    """Write ``doc`` in the format ``dst`` ends in: ``.glb`` or ``.gltf``.

    ``.glb``: one binary chunk; a document read from a ``.gltf`` (or with several or external buffers) has its
    buffers joined into it (each bufferView moved with its buffer) and, read from a ``.gltf``, its images
    stored inside.
    ``.gltf``: the JSON, with each buffer that differs from the file it was read from (or that was a GLB's
    binary chunk) written as ``<stem>.bin`` (``<stem>_<i>.bin``) beside it, a changed data URI re-encoded,
    and every other relative URI (unchanged buffers, images) pointing from ``base`` at the file it names.

    Parameters
    ----------
    doc : GltfDoc
    dst : path
    keep_json : bool
        The JSON did not change: its bytes as read are written where the format and the URIs allow.
    base : path, optional
        The folder the file ends up in (default: ``dst``'s), when ``dst`` is written into a staging folder
        first: relative URIs must resolve from there.
    update : bool
        ``dst`` is the file ``doc`` was read from, being updated: a changed buffer held in a file beside it
        (its own ``.bin``) is rewritten under its name; otherwise a changed buffer never replaces a file the
        document refers to.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> doc = GltfDoc(d / "a.glb", {"asset": {"version": "2.0"}, "buffers": [{"byteLength": 4}]}, [bytearray(4)], True)
    >>> write_gltf(doc, d / "b.gltf")
    >>> sorted(p.name for p in d.iterdir()), load_gltf(d / "b.gltf").json["buffers"]
    (['b.bin', 'b.gltf'], [{'byteLength': 4, 'uri': 'b.bin'}])
    >>> write_gltf(load_gltf(d / "b.gltf"), d / "c.glb")
    >>> load_gltf(d / "c.glb").buffers == [bytearray(4)]
    True
    """
    dst = Path(dst)
    base = Path(base) if base is not None else dst.parent
    if dst.suffix.lower() == ".gltf":
        return _write_json_gltf(doc, dst, keep_json, base, update)
    if not doc.glb or len(doc.buffers) > 1 or any("uri" in b for b in doc.json.get("buffers", [])):
        doc, keep_json = _inside(doc, base), False
    elif any("uri" in im for im in doc.json.get("images", [])):  # a GLB's own image references: re-pointed
        js = copy.deepcopy(doc.json)
        for im in js["images"]:
            if "uri" in im:
                im["uri"] = _relocated(im["uri"], doc, base)
        if js != doc.json:
            doc, keep_json = GltfDoc(doc.path, js, doc.buffers, True, b"", doc.base), False
    write_glb(doc, dst, keep_json)


def _relocated(uri, doc, base):
    """A relative file ``uri`` of ``doc`` pointed from ``base`` at the file it names (the same string when it
    resolves there already; data and absolute URIs as they are)."""
    if uri.startswith("data:") or "://" in uri or uri.startswith("/"):
        return uri
    try:
        p = external_file(uri, doc.folders())
    except FileNotFoundError:  # missing already: left as broken as it was, from the new folder
        p = doc.path.parent / unquote(uri)
    if (base / unquote(uri)).resolve() == p.resolve():
        return uri
    try:
        return quote(Path(os.path.relpath(p.resolve(), base.resolve())).as_posix())
    except ValueError:  # another drive: an absolute file URI
        return p.resolve().as_uri()


def _inside(doc, base):
    """``doc`` with its buffers joined into buffer 0 and its images stored in it (a GLB's one binary chunk)."""
    out = GltfDoc(doc.path, copy.deepcopy(doc.json), [bytearray()], True, b"", doc.base)
    buf, starts = out.buffers[0], []
    for b in doc.buffers:
        buf.extend(b"\0" * ((-len(buf)) % 16))   # every bufferView keeps its alignment
        starts.append(len(buf))
        buf.extend(b)
    for bv in out.json.get("bufferViews", []):
        bv["byteOffset"] = bv.get("byteOffset", 0) + starts[bv.get("buffer", 0)]
        bv["buffer"] = 0
    for i, im in enumerate(out.json.get("images", [])):
        uri = im.get("uri")
        if uri is None:
            continue
        if doc.glb:  # a GLB's references to images beside it stay references
            im["uri"] = _relocated(uri, doc, base)
            continue
        try:
            data = image_bytes(doc, i)
        except (NeuralUVError, OSError, ValueError):  # an image missing beside a .gltf stays a reference to it
            im["uri"] = _relocated(uri, doc, base)
            continue
        mime = im.get("mimeType") or (uri[5:].split(";", 1)[0] if uri.startswith("data:") else
                                      IMAGE_MIME.get(Path(unquote(uri)).suffix.lower(), "image/png"))
        del im["uri"]
        im["bufferView"], im["mimeType"] = _append(out, data), mime
    out.json["buffers"] = [{"byteLength": len(buf)}] if len(buf) or doc.json.get("buffers") else []
    return out


def _write_json_gltf(doc, dst, keep_json, base, update):
    import base64

    js = copy.deepcopy(doc.json)
    taken = {doc.path.resolve()}  # the files the document was read from: a new .bin never replaces one
    for x in js.get("buffers", []) + js.get("images", []):
        try:
            p = external_file(x.get("uri", "data:"), doc.folders())
        except FileNotFoundError:
            continue
        if p is not None:
            taken.add(p.resolve())
    for i, b in enumerate(js.get("buffers", [])):
        data, uri = bytes(doc.buffers[i]), b.get("uri")
        if uri is not None and uri.startswith("data:"):
            if base64.b64decode(uri.split(",", 1)[1]) != data:
                b["uri"] = "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")
            continue
        own = None
        if uri is not None:
            try:
                own = external_file(uri, doc.folders())
            except FileNotFoundError:
                pass
            if own is not None and own.stat().st_size == len(data) and own.read_bytes() == data:
                b["uri"] = _relocated(uri, doc, base)
                continue
        if update and own is not None and own.parent.resolve() == dst.parent.resolve():
            name = own.name  # the file's own .bin, rewritten
        else:
            name = f"{dst.stem}.bin" if i == 0 else f"{dst.stem}_{i}.bin"
            while (base / name).resolve() in taken or (dst.parent / name).resolve() in taken:
                name = f"{Path(name).stem}_new.bin"
        taken.add((base / name).resolve())
        with atomic_write(dst.parent / name, "wb") as fh:
            fh.write(data)
        b["uri"] = quote(name)
    for im in js.get("images", []):
        if "uri" in im:
            im["uri"] = _relocated(im["uri"], doc, base)
    if keep_json and not doc.glb and doc.json_chunk and js == doc.json:
        body = doc.json_chunk  # the JSON's bytes as read
    else:
        body = (json.dumps(js, indent=2, ensure_ascii=False) + "\n").encode("utf-8")
    with atomic_write(dst, "wb") as fh:
        fh.write(body)


def write_glb(doc, dst, keep_json=False):
    body = doc.json_chunk if keep_json and doc.json_chunk else json.dumps(doc.json, separators=(",", ":")).encode()
    body += b" " * ((-len(body)) % 4)
    binary = bytes(doc.buffers[0]) + b"\0" * ((-len(doc.buffers[0])) % 4)
    chunks = struct.pack("<II", len(body), CHUNK_JSON) + body
    if doc.json.get("buffers"):
        chunks += struct.pack("<II", len(binary), CHUNK_BIN) + binary
    with atomic_write(dst, "wb") as fh:
        fh.write(struct.pack("<III", GLB_MAGIC, 2, 12 + len(chunks)) + chunks)


def replace_images(src, dst, images, *, base=None):
    """Write a copy of ``src`` whose images ``{index: PNG bytes}`` are replaced (appended to buffer 0; the old
    data stays, unused); every other byte of the document is kept. ``dst`` and ``base`` as :func:`write_gltf`'s
    (``base`` is also where ``src``'s relative URIs resolve when they are not beside it)."""
    doc = load_gltf(src, base)
    if not doc.buffers:
        doc.buffers.append(bytearray())
        doc.json["buffers"] = [{"byteLength": 0}]
    for i, data in images.items():
        im = doc.json["images"][i]
        im.pop("uri", None)
        im["bufferView"] = _append(doc, data)
        im["mimeType"] = "image/png"
    doc.json["buffers"][0]["byteLength"] = len(doc.buffers[0])
    write_gltf(doc, dst, base=base, update=Path(src).resolve() == Path(dst).resolve())
