"""Atlas export: OBJ/GLB writing and reading back, the figures as PNGs, and the file-to-file :func:`atlas_file`."""
from __future__ import annotations

import json
import resource
import sys
from pathlib import Path

import numpy as np
import trimesh
from trimesh.visual import TextureVisuals

from neuraluv import plot
from neuraluv.atlas.build import build_atlas
from neuraluv.errors import NeuralUVError
from neuraluv.io import atomic_write, jsonable, load_mesh, read_obj, write_obj
from neuraluv.layout.facts import face_texel_density
from neuraluv.layout.validate import validate_layout

__all__ = ["write_atlas", "read_atlas", "save_renders", "atlas_file"]


def write_atlas(path, V, F, UV, FUV):
    """Write an atlas as OBJ (per-corner ``vt``) or GLB (``TEXCOORD_0``), atomically.

    For GLB, one vertex is written per distinct (position, UV) pair.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".obj":
        write_obj(path, V, F, UV, FUV)
    elif ext in (".glb", ".gltf"):
        pairs = np.stack([np.asarray(F).reshape(-1), np.asarray(FUV).reshape(-1)], 1)
        uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
        mesh = trimesh.Trimesh(vertices=np.asarray(V, float)[uniq[:, 0]], faces=inv.reshape(-1, 3),
                               visual=TextureVisuals(uv=np.asarray(UV, float)[uniq[:, 1]]), process=False)
        data = mesh.export(file_type="glb")
        with atomic_write(path, "wb") as fh:
            fh.write(data)
    else:
        raise NeuralUVError(f"output must be .obj or .glb, got {path.name}")


def read_atlas(path):
    """Read an atlas written by :func:`write_atlas`: ``(V, F, UV, FUV)``."""
    path = Path(path)
    if path.suffix.lower() == ".obj":
        V, F, UV, FUV = read_obj(path)
        if FUV is None:
            raise NeuralUVError(f"{path.name} has no per-corner texture coordinates")
        return V, F, UV, FUV

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


def atlas_file(inp, out, *, report=None, renders=None, **kw):
    """Load a mesh, build its atlas, write it, read it back and validate the file.

    Parameters
    ----------
    inp : path of the input mesh.
    out : path of the output ``.obj`` or ``.glb``.
    report : path, optional
        JSON report (with the read-back validation under ``"readback"``).
    renders : folder, optional
        Checkerboard transfer and route figure PNGs.
    **kw
        Passed to :func:`build_atlas`.

    Returns
    -------
    res : AtlasResult
    rep : dict, the report (``rep["readback"]["valid"]`` is the verdict on the file).
    """
    out = Path(out)
    if out.suffix.lower() not in (".obj", ".glb"):
        raise NeuralUVError(f"output must be .obj or .glb, got {out.name}")
    V, F = load_mesh(inp)
    res = build_atlas(V, F, **kw)
    write_atlas(out, res.V, res.F, res.UV, res.FUV)
    back = validate_layout(*read_atlas(out), padding=res.info["padding"], resolution=res.info["resolution"],
                           tiles=res.info.get("pages", 1) > 1, stacked=res.info.get("stack", False))
    rep = res.report()
    rep["input"] = str(inp)
    rep["output"] = str(out)
    rep["readback"] = jsonable(back)
    rep["ok"] = bool(back["valid"] and back["covered_faces"] == len(res.F))
    rep["peak_memory_mb"] = _peak_memory_mb()
    if renders:
        rep["renders"] = [str(p) for p in save_renders(res, renders, stem=out.stem)]
    if report:
        with atomic_write(report) as fh:
            json.dump(rep, fh, indent=2)
    return res, rep
