"""Atlas export: OBJ/GLB writing and reading back, figures, and the file-to-file :func:`atlas_file`."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from neuraluv.atlas.build import build_atlas
from neuraluv.layout.validate import validate_layout
from neuraluv.errors import NeuralUVError
from neuraluv.io import atomic_write, jsonable, load_mesh, read_obj, write_obj

__all__ = ["write_atlas", "read_atlas", "plot_routes", "save_renders", "atlas_file"]


def write_atlas(path, V, F, UV, FUV):
    """Write an atlas as OBJ (per-corner ``vt``) or GLB (``TEXCOORD_0``), atomically.

    For GLB, one vertex is written per distinct (position, UV) pair.
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


def plot_routes(res, *, zoom=True, view=None):
    """The routing figure (the paper's Figure 11) of an :class:`~neuraluv.atlas.build.AtlasResult` (see :func:`neuraluv.plot.plot_routes`)."""
    from neuraluv.plot import plot_routes as _plot

    t = res.totals()
    return _plot(res.V, res.F, res.UV, res.FUV, res.face_route, islands=t["islands"], flips=t["flips"], zoom=zoom,
                 view=view)


def plot_density(V, F, UV, FUV, *, title=None, view="plane", axes=None):
    """The texel-density figure of a layout: each face coloured by its island's density over the median island.

    White is the median density; blue islands get fewer texels per unit length
    (blurrier), red ones more. One texel density (``build_atlas``) is white
    everywhere; xatlas's own atlas is not.

    Parameters
    ----------
    V, F, UV, FUV : the mesh and its layout
    title : str, optional
    view : camera (see :func:`neuraluv.plot.render_surface`)
    axes : two matplotlib Axes, optional

    Returns
    -------
    fig : matplotlib Figure
    """
    from neuraluv.layout.facts import face_texel_density
    from neuraluv.plot import plot_surface_and_uv

    d = face_texel_density(V, F, UV, FUV)
    spread = float(np.nanmax(d) / np.nanmin(d) - 1) if np.isfinite(d).any() else float("nan")
    return plot_surface_and_uv(V, F, UV, d, FUV=FUV, cmap="coolwarm", clim=(0.5, 1.5), view=view, axes=axes,
                               label="texel density / median island",
                               title=(title + "; " if title else "") + f"density spread {100 * spread:.2g}%")


def save_renders(res, outdir, stem="atlas"):
    """Write the checkerboard transfer, the route figure and the texel-density figure as PNGs; returns the paths."""
    import matplotlib.pyplot as plt

    from neuraluv.plot import plot_checkerboard_transfer

    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in (("checkerboard", lambda: plot_checkerboard_transfer(res.V, res.F, res.UV, res.FUV)),
                       ("routes", lambda: plot_routes(res)),
                       ("density", lambda: plot_density(res.V, res.F, res.UV, res.FUV))):
        fig = make()
        p = outdir / f"{stem}_{name}.png"
        with atomic_write(p, "wb") as fh:
            fig.savefig(fh, format="png", dpi=110)
        plt.close(fig)
        paths.append(p)
    return paths


def _peak_memory_mb():
    """Peak resident memory of this process so far, in MB."""
    import resource
    import sys

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
