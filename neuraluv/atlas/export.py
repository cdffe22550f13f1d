"""Atlas export: OBJ/GLB writing and reading back, the figures as PNGs, and the file-to-file :func:`atlas_file`."""
from __future__ import annotations

import json
import resource
import sys
from pathlib import Path

import numpy as np

from neuraluv import plot
from neuraluv.atlas.build import build_atlas
from neuraluv.errors import NeuralUVError
from neuraluv.io import atomic_write, jsonable, load_mesh, read_obj, write_obj
from neuraluv.layout.facts import face_texel_density
from neuraluv.layout.validate import validate_layout

__all__ = ["write_atlas", "read_atlas", "save_renders", "atlas_file"]


def write_atlas(path, V, F, UV, FUV):
    """Write an atlas as OBJ (per-corner ``vt``), GLB or glTF (``TEXCOORD_0``; ``.gltf`` with its ``.bin``
    beside it), atomically.

    For glTF, one vertex is written per distinct (position, UV) pair.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".obj":
        write_obj(path, V, F, UV, FUV)
    elif ext in (".glb", ".gltf"):
        import trimesh
        from trimesh.visual import TextureVisuals

        pairs = np.stack([np.asarray(F).reshape(-1), np.asarray(FUV).reshape(-1)], 1)
        uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
        mesh = trimesh.Trimesh(vertices=np.asarray(V, float)[uniq[:, 0]], faces=inv.reshape(-1, 3),
                               visual=TextureVisuals(uv=np.asarray(UV, float)[uniq[:, 1]]), process=False)
        data = mesh.export(file_type="glb")
        if ext == ".gltf":  # the same document as JSON, its buffer beside it
            import tempfile

            from neuraluv.io.gltf import load_gltf
            from neuraluv.io.gltf_write import write_gltf

            with tempfile.TemporaryDirectory() as d:
                (Path(d) / "atlas.glb").write_bytes(data)
                write_gltf(load_gltf(Path(d) / "atlas.glb"), path)
            return
        with atomic_write(path, "wb") as fh:
            fh.write(data)
    else:
        raise NeuralUVError(f"output must be .obj, .glb or .gltf, got {path.name}")


def read_atlas(path):
    """Read an atlas written by :func:`write_atlas`: ``(V, F, UV, FUV)``."""
    path = Path(path)
    if path.suffix.lower() == ".obj":
        V, F, UV, FUV = read_obj(path)
        if FUV is None:
            raise NeuralUVError(f"{path.name} has no per-corner texture coordinates")
        return V, F, UV, FUV

    import trimesh

    sc = trimesh.load(str(path), process=False)
    geoms = list(sc.geometry.values()) if isinstance(sc, trimesh.Scene) else [sc]
    Vs, Fs, Us, off = [], [], [], 0
    for g in geoms:
        uv = getattr(g.visual, "uv", None)
        if uv is None:
            raise NeuralUVError(f"{path.name} has no TEXCOORD_0")
        Vs.append(np.asarray(g.vertices, float))
        Fs.append(np.asarray(g.faces, np.int64) + off)
        Us.append(np.asarray(uv, float))
        off += len(g.vertices)
    F = np.vstack(Fs)
    return np.vstack(Vs), F, np.vstack(Us), F.copy()


def save_renders(res, outdir, stem="atlas"):
    """Write the checkerboard transfer, the route figure (the paper's Figure 11) and the texel-density figure as PNGs.

    Parameters
    ----------
    res : AtlasResult
    outdir : folder (created when missing)
    stem : str
        File names are ``{stem}_checkerboard.png``, ``{stem}_routes.png``, ``{stem}_density.png``.

    Returns
    -------
    list of Path
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in (("checkerboard", lambda: plot.plot_checkerboard_transfer(res.V, res.F, res.UV, res.FUV)),
                       ("routes", lambda: plot.plot_routes(res)),
                       ("density", lambda: plot.plot_density(res.V, res.F, res.UV, res.FUV,
                                                             face_texel_density(res.V, res.F, res.UV, res.FUV)))):
        paths.append(plot.save_figure(make(), outdir / f"{stem}_{name}.png"))
    return paths


def _peak_memory_mb():
    """Peak resident memory of this process so far, in MB."""
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kb / (1024.0 * 1024.0) if sys.platform == "darwin" else kb / 1024.0  # bytes on macOS, KiB on Linux


def _read_input(inp, replace_uvs):
    """The mesh to atlas and the reader's data to write back into: ``(V, F, data)``."""
    from neuraluv.io import check_mesh_arrays, read_gltf_layout

    ext = inp.suffix.lower()
    if ext == ".obj":
        load_mesh(inp)  # one-line errors for empty or garbage files
        data = read_obj(inp, keep_lines=True)
        return (*check_mesh_arrays(data[0], data[1], name=inp.name), data)
    if ext in (".glb", ".gltf"):
        data = read_gltf_layout(inp, 0 if replace_uvs else None)
        if replace_uvs and data.skipped:
            raise NeuralUVError(f"{inp.name}: --replace-uvs needs TEXCOORD_0 on every triangle primitive "
                                f"({data.skipped[0]})")
        return (*check_mesh_arrays(data.V, data.F, name=inp.name), data)
    return (*load_mesh(inp), None)


def _write_output(inp, out, data, V, F, UV, FUV, *, replace_uvs, rebake, base=None):
    """Write the atlas into a copy of the input (OBJ lines / glTF scene kept), else as a new file (``base``: the
    folder a glTF ``out`` written into a staging folder ends up in).

    Returns ``written`` (what was written, ``texcoord`` per primitive for a GLB), ``textures`` (re-bakes)
    and ``notes`` (one line each: what the output does not keep).
    """
    from neuraluv.io import GltfLayout, patch_obj, write_gltf_uvs

    ext = out.suffix.lower()
    notes, textures = [], []
    had_uvs = data is not None and not isinstance(data, GltfLayout) and data[3] is not None and len(data[2])
    if data is not None and not isinstance(data, GltfLayout) and ext == ".obj":
        p0 = len(data[2])
        # the new rows take the old vt lines' places (old rows past the new ones stay, unused) when every
        # face then still finds its rows defined above it; else (vt and f lines interleaved) they are added
        vt_line, face_line = data.notes["vt_line"], data.notes["face_line"]
        above = (FUV >= p0) | (np.asarray(vt_line)[np.minimum(FUV, max(p0 - 1, 0))] < face_line[:, None]) \
            if p0 else np.ones(FUV.shape, bool)
        if above.all():
            UVw, FUVw = (UV if len(UV) >= p0 else np.vstack([UV, data[2][len(UV):]])), FUV
        else:
            UVw, FUVw = np.vstack([data[2], UV]), FUV + p0
            notes.append(f"the input's {p0:,} vt lines are interleaved with its faces: kept as they were (no "
                         "longer used), the atlas's rows added")
        written = {"format": ".obj", **patch_obj(inp, out, UVw, FUVw, data=data)}
        if had_uvs and rebake and (data[3] >= 0).all():
            textures = _rebake(inp, out, data, V, F, data[2], data[3], UVw, FUVw)
        elif had_uvs:
            notes.append("the new vt replace the old ones: textures made for the old layout no longer fit"
                         + (" (--no-rebake)" if not rebake else " (some faces had no vt: not re-baked)"))
        return written, textures, notes
    if isinstance(data, GltfLayout) and ext in (".glb", ".gltf"):
        p0 = len(data.UV)
        mode = "replace" if replace_uvs else "add"
        written = {"format": ext, **write_gltf_uvs(data, np.vstack([data.UV, UV]), FUV + p0, out, mode=mode,
                                                   base=base)}
        written["sets"] = dict(zip([key for b in data.blocks for key in data.primitives(b)], written["texcoord"]))
        if replace_uvs and rebake:
            textures = _rebake(inp, out, data, V, F, data.UV, data.FUV, np.vstack([data.UV, UV]), FUV + p0, base)
        return written, textures, notes
    write_atlas(out, V, F, UV, FUV)
    if data is not None:
        keep = ".obj" if inp.suffix.lower() == ".obj" else ".glb or .gltf"
        notes.append(f"{out.suffix} output from a {inp.suffix} input keeps positions, faces and the new UVs only "
                     f"(write {keep} to keep normals, materials and the rest)")
    return {"format": ext}, textures, notes


def _rebake(inp, out, data, V, F, UV0, FUV0, UV1, FUV1, base=None):
    """Redraw the input's textures for the new layout (the repair's re-bake, every face changed)."""
    from types import SimpleNamespace

    from neuraluv.repair.textures import carry_textures

    res = SimpleNamespace(unchanged=False, V=V, F=F, UV_in=UV0, FUV_in=FUV0, UV=UV1, FUV=FUV1,
                          changed_faces=np.ones(len(F), bool))
    return carry_textures(inp, out, data, res, uv_set=0, base=base)


def _read_back(out, written, base=None):
    """``(V, F, UV, FUV)`` of the written file, as the written UV sets."""
    from neuraluv.io import read_gltf_layout

    if "sets" in written:
        lay = read_gltf_layout(out, written["sets"], base=base)
        return lay.V, lay.F, lay.UV, lay.FUV
    return read_atlas(out)


def atlas_file(inp, out, *, report=None, renders=None, replace_uvs=False, rebake=True, **kw):
    """Load a mesh, build its atlas, write it into the output, read the file back and validate it.

    What the input holds besides the faces is kept: an OBJ written as OBJ keeps every line (normals,
    groups, materials, polygons) but the ``vt`` rows and the ``f`` lines' ``vt`` indices; a GLB written
    as GLB keeps the whole scene and gets the atlas as a UV set of its own (``TEXCOORD_k``, the first ``k``
    free on every primitive), or in place of ``TEXCOORD_0`` with ``replace_uvs``. Every input face is in the
    output: a face the atlas's mesh repair dropped (a double-sided twin, a degenerate face, a sliver) is written with
    its twin's UVs or at one UV point, and counted. Textures that read replaced UVs are re-baked. The
    output, the re-baked textures and the report are written as one (all or none).

    Parameters
    ----------
    inp : path of the input mesh.
    out : path of the output ``.obj`` or ``.glb``.
    report : path, optional
        JSON report (with the read-back validation under ``"readback"``).
    renders : folder, optional
        Checkerboard transfer and route figure PNGs.
    replace_uvs : bool
        glTF: write the atlas into ``TEXCOORD_0`` instead of adding a UV set.
    rebake : bool
        Re-bake the textures that read UVs the atlas replaced (OBJ with ``vt``, or ``replace_uvs``).
    **kw
        Passed to :func:`build_atlas`.

    Returns
    -------
    res : AtlasResult
    rep : dict, the report (``rep["readback"]["valid"]`` is the verdict on the file; ``rep["faces"]``
        the faces in and out, twins and faces mapped to a point; ``rep["notes"]`` what was not kept).
    """
    from neuraluv.atlas.prepare import input_layout, surface_view
    from neuraluv.io import staged_outputs

    inp, out = Path(inp), Path(out)
    if out.suffix.lower() not in (".obj", ".glb", ".gltf"):
        raise NeuralUVError(f"output must be .obj, .glb or .gltf, got {out.name}")
    V, F, data = _read_input(inp, replace_uvs)
    res = build_atlas(V, F, **kw)
    FUV_in, carried = input_layout(V, F, res.source, res.F, res.UV, res.FUV)
    with staged_outputs() as stage:
        tmp = stage(out)
        written, textures, notes = _write_output(inp, tmp, data, V, F, res.UV, FUV_in, replace_uvs=replace_uvs,
                                                 rebake=rebake, base=out.parent)
        try:
            V2, F2, UV2, FUV2 = _read_back(tmp, written, out.parent)
        except NeuralUVError as exc:
            raise NeuralUVError(f"the atlas could not be read back ({exc}); nothing written") from None
        # the map of the surface: a double-sided face's back side and a face wound against its neighbours
        # are the same map; faces the atlas put at one UV point on purpose (no area) are counted, not judged
        rev = carried.pop("reversed")
        Fv, UVv, FUVv, view = surface_view(V2, F2, UV2, FUV2, rev if len(rev) == len(F2) else None)
        C = UVv[FUVv]
        point = (C[:, 0] == C[:, 1]).all(1) & (C[:, 1] == C[:, 2]).all(1)
        back = validate_layout(V2, Fv[~point], UVv, FUVv[~point], padding=res.info["padding"],
                               resolution=res.info["resolution"], tiles=res.info.get("pages", 1) > 1,
                               stacked=res.info.get("stack", False))
        rep = res.report()
        rep["input"] = str(inp)
        rep["output"] = str(out)
        rep["written"] = {k: v for k, v in written.items() if k != "sets"}
        rep["textures"] = [{**t, "written": str(out.parent / Path(t["written"]).name)} if "written" in t else t
                           for t in textures]
        rep["notes"] = notes
        rep["faces"] = {"in": int(len(F)), "out": int(len(F2)), **carried, "wound_against_the_map": int(rev.sum()),
                        "point_faces_read_back": int(point.sum()), "twin_faces_read_back": view["twin_faces"]}
        rep["readback"] = jsonable(back)
        rep["ok"] = bool(back["valid"] and back["covered_faces"] == int((~point).sum())
                         and len(F2) == len(F) and int(point.sum()) <= carried["collapsed_faces"])
        if renders:
            staged = save_renders(res, stage(Path(renders) / "_").parent, stem=out.stem)
            rep["renders"] = [str(Path(renders) / p.name) for p in staged]
        rep["peak_memory_mb"] = _peak_memory_mb()
        if report:
            with open(stage(report), "w") as fh:
                json.dump(jsonable(rep), fh, indent=2)
    return res, rep
