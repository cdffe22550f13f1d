"""A UV layout read from a file as the command line reads it, and the materials the file references.

:func:`read_layout` is the one reader behind ``check --uv``, ``repair`` and the harness: an OBJ through
:func:`~neuraluv.io.obj.read_obj` (its lines kept, for patching), a glTF / GLB through
:func:`~neuraluv.io.gltf.read_gltf_layout`; every failure is one :class:`~neuraluv.errors.NeuralUVError`
line. :func:`obj_material_maps` reads an OBJ's ``usemtl`` names and the map lines of its ``mtllib`` files
(the purpose's default and the texture re-bake both ask it); :func:`layout_materials` counts them.
"""
from __future__ import annotations

import struct
from pathlib import Path

from neuraluv.errors import NeuralUVError

__all__ = ["read_layout", "layout_materials", "obj_material_maps"]

#: The keywords of an MTL file's texture-map lines.
MAP_KEYS = (b"map_ka", b"map_kd", b"map_ks", b"map_ke", b"map_ns", b"map_d", b"map_bump", b"bump", b"norm",
            b"disp", b"decal", b"map_pr", b"map_pm", b"map_ps")


def read_layout(path, uv_set=0, *, untextured=False, weld=True):
    """``(V, F, UV, FUV, data)`` of a textured OBJ (``data``: its :class:`~neuraluv.io.obj.ObjData`, lines kept)
    or glTF / GLB (``data``: its :class:`~neuraluv.io.gltf.GltfLayout`); one-line errors for everything else.

    Parameters
    ----------
    path : str or Path
    uv_set : int
        The glTF UV set ``TEXCOORD_<uv_set>`` (an OBJ has one: 0).
    untextured : bool
        glTF: the triangle primitives without that set too, as faces without texture coordinates
        (:func:`~neuraluv.io.gltf.read_gltf_layout`; an OBJ's faces without ``vt`` are always read).
    weld : bool
        glTF: rows of vertices split only for their normals joined (:func:`~neuraluv.io.gltf.seamless_rows`).
    """
    from neuraluv.io.gltf import read_gltf_layout
    from neuraluv.io.mesh import check_mesh_arrays, check_mesh_file
    from neuraluv.io.obj import read_obj

    path = Path(path)
    if path.suffix.lower() == ".obj":
        if uv_set:
            raise NeuralUVError("an OBJ has one set of texture coordinates (vt): --uv-set must be 0")
        check_mesh_file(path)  # one-line errors for missing, empty or garbage files, as load_mesh gives them
        data = read_obj(path, keep_lines=True)
        V, F, UV, FUV = data
        check_mesh_arrays(V, F, name=path.name)
        if FUV is None or len(UV) == 0:
            raise NeuralUVError(f"{path.name} has no per-corner texture coordinates (vt); use `neuraluv atlas` to "
                                "make a layout")
        return V, F, UV, FUV, data
    try:
        lay = read_gltf_layout(path, uv_set, untextured=untextured, weld=weld)
    except NeuralUVError:
        raise
    except (ValueError, KeyError, IndexError, TypeError, struct.error) as exc:  # malformed JSON structure: one line
        raise NeuralUVError(f"{path.name}: could not read texture coordinates ({type(exc).__name__}: {exc})") from None
    return lay.V, lay.F, lay.UV, lay.FUV, lay


def _map_name(rest):
    """The file name of a map line's remainder (options such as ``-bm 1`` come first)."""
    rest = rest.strip()
    return rest.split()[-1] if rest.startswith(b"-") else rest


def obj_material_maps(obj_path, raw_lines):
    """An OBJ's material names and the map lines of its ``mtllib`` files (those found beside it).

    Parameters
    ----------
    obj_path : path of the OBJ (the ``mtllib`` names are relative to its folder)
    raw_lines : iterable of its lines (str or bytes)

    Returns
    -------
    materials : set of bytes, the ``usemtl`` names
    libs : list of ``(mtl path, [(line index, key, image name), ...])``

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "a.mtl").write_text("newmtl skin\\nmap_Kd -bm 1 skin.png\\n")
    >>> mats, libs = obj_material_maps(d / "a.obj", ["mtllib a.mtl", "usemtl skin"])
    >>> sorted(mats), [(p.name, maps) for p, maps in libs]
    ([b'skin'], [('a.mtl', [(1, b'map_Kd', 'skin.png')])])
    """
    mats, libs = set(), []
    for line in raw_lines:
        tok = (line.encode("utf-8") if isinstance(line, str) else line).split(None, 1)
        if len(tok) == 2 and tok[0] == b"usemtl":
            mats.add(tok[1].strip())
        elif len(tok) == 2 and tok[0] == b"mtllib":
            lib = Path(obj_path).parent / tok[1].strip().decode("utf-8", "replace")
            if not lib.is_file():
                continue
            maps = []
            for k, ml in enumerate(lib.read_bytes().splitlines()):
                p = ml.split(None, 1)
                if len(p) == 2 and p[0].lower() in MAP_KEYS:
                    maps.append((k, p[0], _map_name(p[1]).decode("utf-8", "replace")))
            libs.append((lib, maps))
    return mats, libs


def layout_materials(path, data=None):
    """How many materials and textures a layout's file references: ``{"materials": n, "textures": k}``.

    OBJ: ``usemtl`` names and the map lines of its ``mtllib`` files (:func:`obj_material_maps`); glTF / GLB:
    the ``materials`` and ``textures`` arrays of its JSON. ``data``, what :func:`read_layout` returned, saves
    reading the file again. Unreadable parts count as none. The command line's purpose line says it
    (:func:`~neuraluv.layout.purpose.default_purpose`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "a.mtl").write_text("newmtl skin\\nmap_Kd skin.png\\n")
    >>> _ = (d / "a.obj").write_text("mtllib a.mtl\\nusemtl skin\\nv 0 0 0\\n")
    >>> layout_materials(d / "a.obj")
    {'materials': 1, 'textures': 1}
    """
    import json

    path = Path(path)
    if hasattr(data, "materials") and hasattr(data, "textures"):  # a GltfLayout
        return {"materials": int(data.materials), "textures": int(data.textures)}
    try:
        if path.suffix.lower() == ".obj":
            lines = data.notes["raw"] if hasattr(data, "notes") else path.read_bytes().splitlines()
            mats, libs = obj_material_maps(path, lines)
            return {"materials": len(mats), "textures": sum(len(maps) for _, maps in libs)}
        if path.suffix.lower() == ".glb":
            with open(path, "rb") as fh:
                head = fh.read(20)
                length, kind = struct.unpack("<I4s", head[12:20])
                doc = json.loads(fh.read(length)) if kind == b"JSON" else {}
        elif path.suffix.lower() == ".gltf":
            doc = json.loads(path.read_text(encoding="utf-8"))
        else:
            return {"materials": 0, "textures": 0}
        return {"materials": len(doc.get("materials", [])), "textures": len(doc.get("textures", []))}
    except (OSError, ValueError, struct.error):
        return {"materials": 0, "textures": 0}
