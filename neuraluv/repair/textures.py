"""The textures of a repaired file carried over to its new layout (``neuraluv repair``; ``--no-rebake`` skips).

:func:`carry_textures` finds the images the repaired UVs are read with — an OBJ's
material maps (``map_Kd``, ``map_Ks``, ``map_Bump``, …, in the ``mtllib`` files beside
it), a glTF's base colour, metallic-roughness, normal, occlusion and emissive textures
of the repaired primitives' materials on that UV set — re-bakes each from the old
layout to the new one (:func:`~neuraluv.repair.rebake.rebake_image`), writes them, and
measures the appearance change (:func:`~neuraluv.repair.rebake.appearance_change`).
Normal maps (a glTF material's ``normalTexture``; an OBJ's ``norm`` map, and a ``bump``
map that looks like one rather than a grey height map) are re-baked with their vectors
turned with each face (and compared in the old frame); the report marks them
``normal_map``. A glTF primitive's ``TANGENT`` rows of the moved vertices are recomputed
from the new UVs when it is written (:mod:`neuraluv.io.gltf_tangents`). A glTF
texture sampled through ``KHR_texture_transform`` is re-baked where it is sampled (the
transform applied to both layouts); one image sampled through two transforms is skipped, and
said so.

Where they go: an OBJ ``OUT.obj`` gets ``OUT.mtl`` (a copy of its material file with
the map lines pointing at the re-baked ``OUT.<image>.png``; every other line kept) and
its ``mtllib`` line points there — the input's files are never touched. A GLB gets the
re-baked PNGs inside it, in place of the images they replace.
"""
from __future__ import annotations

import copy
import io
import json
from pathlib import Path

import numpy as np

from neuraluv.io import atomic_write, obj_material_maps
from neuraluv.repair.rebake import appearance_change, rebake_image, uv_turns

__all__ = ["carry_textures", "looks_like_normal_map", "APPEARANCE_LIMIT"]

#: OBJ material keys of normal maps (``norm``) and of maps that hold one or a height map (``bump``): the latter
#: are re-baked as normal maps when they look like one (:func:`looks_like_normal_map`).
NORMAL_KEYS, BUMP_KEYS = (b"norm",), (b"map_bump", b"bump")

#: The appearance change a re-bake is held to: mean colour difference over the whole textured surface, in
#: 8-bit RGB units (one level of 255 is below what a viewer can see). The figures over the changed faces
#: alone are reported beside it: a fold's faces shared texels with their neighbours, and after repair
#: they can only take the texels no unchanged face uses, so they may differ more where the fold was.
APPEARANCE_LIMIT = 1.0

def _load(path):
    from PIL import Image

    with Image.open(path) as im:
        im.load()
        return np.asarray(im)


def _png(arr):
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(arr).save(buf, format="PNG")
    return buf.getvalue()


def _measure(res, img0, img1, normal_map=False):
    ch = res.changed_faces
    turn = uv_turns(res.UV_in, res.FUV_in, res.UV, res.FUV) if normal_map else None
    whole = appearance_change(res.V, res.F, img0, res.UV_in, res.FUV_in, img1, res.UV, res.FUV, turn=turn)
    part = appearance_change(res.V, res.F[ch], img0, res.UV_in, res.FUV_in[ch], img1, res.UV, res.FUV[ch],
                             turn=None if turn is None else turn[ch]) if ch.any() else whole
    return {"surface": whole, "changed_faces": part}


def looks_like_normal_map(img):
    """An image that reads as a tangent-space normal map: RGB, blue high (Z off the surface) and red and green
    about mid-range on average, and not grey (a height map under ``bump`` is grey).

    Examples
    --------
    >>> flat = np.zeros((4, 4, 3), np.uint8) + np.array([128, 128, 255], np.uint8)
    >>> looks_like_normal_map(flat), looks_like_normal_map(np.full((4, 4, 3), 200, np.uint8))
    (True, False)
    """
    img = np.asarray(img)
    if img.ndim != 3 or img.shape[2] < 3:
        return False
    top = float(np.iinfo(img.dtype).max) if np.issubdtype(img.dtype, np.integer) else 1.0
    r, g, b = (img[..., c].astype(float).mean() / top for c in range(3))
    return bool(b > 0.7 and abs(r - 0.5) < 0.15 and abs(g - 0.5) < 0.15)


def carry_textures(inp, out, data, res, *, uv_set=0, base=None):
    """Re-bake the images that read the repaired UVs; write them beside / into ``out``; measure the change.

    Parameters
    ----------
    inp, out : paths of the input and of the repaired file (already written)
    data : the reader's data (:class:`~neuraluv.io.ObjData` with its lines, or :class:`~neuraluv.io.GltfLayout`)
    res : :class:`~neuraluv.repair.repair.RepairResult`
    uv_set : int, the glTF UV set that was repaired
    base : path, optional
        The folder a glTF ``out`` written into a staging folder ends up in (its relative URIs resolve there).

    Returns
    -------
    list of dict, one per re-baked image: ``image``, ``written``, ``texels_written``, ``appearance``
    (``surface`` and ``changed_faces``: :func:`~neuraluv.repair.rebake.appearance_change`), ``ok`` (mean over
    the surface within :data:`APPEARANCE_LIMIT`); and ``skipped`` entries for images that could not be read.
    """
    if res.unchanged:
        return []
    inp, out = Path(inp), Path(out)
    if out.suffix.lower() == ".obj" and hasattr(data, "notes"):
        return _carry_obj(inp, out, data, res)
    if out.suffix.lower() in (".glb", ".gltf") and hasattr(data, "doc"):
        return _carry_glb(out, data, res, uv_set, base)
    return []


def _carry_obj(inp, out, data, res):
    report = []
    libs = obj_material_maps(inp, data.notes["raw"])[1]
    if not any(maps for _, maps in libs):
        return report
    new_lib_names = {}
    for lib, maps in libs:
        lines = lib.read_bytes().splitlines(keepends=True)
        baked = {}
        for k, key, name in maps:
            src = lib.parent / name
            if name not in baked:
                try:
                    img0 = _load(src)
                except Exception as exc:  # noqa: BLE001 - an unreadable image: say so, carry on
                    report.append({"image": name, "skipped": f"could not read ({type(exc).__name__})"})
                    baked[name] = None
                    continue
                normal = key.lower() in NORMAL_KEYS or (key.lower() in BUMP_KEYS and looks_like_normal_map(img0))
                img1, info = rebake_image(img0, res.UV_in, res.FUV_in, res.UV, res.FUV, res.changed_faces,
                                          normal_map=normal)
                dst = out.parent / f"{out.stem}.{Path(name).stem}.png".replace(" ", "_")
                with atomic_write(dst, "wb") as fh:
                    fh.write(_png(img1))
                app = _measure(res, img0, img1, normal)
                baked[name] = dst.name
                report.append({"image": name, "written": str(dst), "texels_written": info["texels_written"],
                               "appearance": app, "ok": app["surface"]["mean"] <= APPEARANCE_LIMIT,
                               **({"normal_map": True} if normal else {})})
            if baked.get(name):
                ending = lines[k][len(lines[k].rstrip(b"\r\n")):]
                lines[k] = lines[k][: len(lines[k]) - len(lines[k].lstrip())] + key + b" " \
                    + baked[name].encode("utf-8") + ending
        new_name = f"{out.stem}.mtl" if len(libs) == 1 else f"{out.stem}.{lib.stem}.mtl"
        with atomic_write(out.parent / new_name, "wb") as fh:
            fh.write(b"".join(lines))
        new_lib_names[lib.name] = new_name
    # the output's mtllib lines point at the new material files (the only other lines that change)
    text = out.read_bytes().splitlines(keepends=True)
    for i, line in enumerate(text):
        p = line.split(None, 1)
        if len(p) == 2 and p[0] == b"mtllib":
            old = p[1].strip().decode("utf-8", "replace")
            if Path(old).name in new_lib_names:
                ending = line[len(line.rstrip(b"\r\n")):]
                text[i] = b"mtllib " + new_lib_names[Path(old).name].encode("utf-8") + ending
    with atomic_write(out, "wb") as fh:
        fh.write(b"".join(text))
    return report


def _carry_glb(out, data, res, uv_set, base=None):
    from neuraluv.io.gltf import load_gltf
    from neuraluv.io.gltf_extensions import texture_refs, transform_map
    from neuraluv.io.gltf_write import replace_images

    doc = load_gltf(out, base)
    # materials whose primitives were read through their textures' shared KHR_texture_transform (the layout
    # is then where those textures sample it already) and the others (each image transformed on its own)
    sampled, mats = set(), set()
    for b in data.blocks:
        for mi, pi in data.primitives(b):
            m = doc.json["meshes"][mi]["primitives"][pi].get("material")
            mats.add(m)
            if b.get("transform"):
                sampled.add(m)
    used = {}  # image -> the KHR_texture_transform (JSON) of every reference to it on this UV set
    normal = {}  # image -> whether it is read as a normal map, per reference
    for m in mats:
        for ti in texture_refs(doc.json, m, uv_set):
            src = doc.json["textures"][ti["index"]].get("source")
            if src is not None:
                ext = None if m in sampled else (ti.get("extensions") or {}).get("KHR_texture_transform")
                used.setdefault(src, {})[json.dumps(ext, sort_keys=True)] = ext
                normal.setdefault(src, set()).add(ti is doc.json["materials"][m].get("normalTexture"))
    report, new = [], {}
    for img_i in sorted(used):
        im = doc.json["images"][img_i]
        if len(used[img_i]) > 1:  # one image sampled through two transforms: no one re-bake serves both
            report.append({"image": im.get("name", f"image {img_i}"),
                           "skipped": "sampled through different KHR_texture_transform transforms"})
            continue
        if len(normal[img_i]) > 1:  # read as normals and as colours: no one re-bake serves both
            report.append({"image": im.get("name", f"image {img_i}"),
                           "skipped": "read both as a normal map and as a colour map"})
            continue
        is_normal = True in normal[img_i]
        ext = next(iter(used[img_i].values()))  # where the texture is sampled (None: at the UVs as read)
        try:
            from PIL import Image

            from neuraluv.io.gltf import image_bytes

            with Image.open(io.BytesIO(image_bytes(doc, img_i))) as pil:
                pil.load()
                img0 = np.asarray(pil)
        except Exception as exc:  # noqa: BLE001 - an unreadable image: say so, carry on
            report.append({"image": im.get("name", f"image {img_i}"), "skipped": f"could not read ({type(exc).__name__})"})
            continue
        view = res
        if ext is not None:  # the layouts as sampled (a copy: a RepairResult, or the atlas's namespace)
            view, tf = copy.copy(res), transform_map(ext)
            view.UV_in, view.UV = tf(res.UV_in), tf(res.UV)
        img1, info = rebake_image(img0, view.UV_in, view.FUV_in, view.UV, view.FUV, view.changed_faces,
                                  normal_map=is_normal)
        new[img_i] = _png(img1)
        app = _measure(view, img0, img1, is_normal)
        report.append({"image": im.get("name", f"image {img_i}"), "written": f"{out.name} (image {img_i}, PNG)",
                       "texels_written": info["texels_written"], "appearance": app,
                       "ok": app["surface"]["mean"] <= APPEARANCE_LIMIT, **({"normal_map": True} if is_normal else {})})
    if new:
        replace_images(out, out, new, base=base)
    return report
