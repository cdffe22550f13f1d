"""3D surfaces with pyvista: off-screen renders (RGB arrays) and the live view.

pyvista is imported inside the functions, so ``import neuraluv.plot`` does not
load it. A render is returned as an image array, to be placed in a matplotlib
figure (:mod:`~neuraluv.plot.mpl`).
"""
from __future__ import annotations

import importlib.util
import os

import numpy as np

from neuraluv.plot.style import (CAMERA_VIEWS, camera_view, checker_count, checker_square, checkerboard_texture, pyplot,
                                 scalar_colors)

__all__ = ["render_surface", "render_checkerboard", "live_view", "trame_available"]


def _polydata(V, F):
    import pyvista as pv

    faces = np.hstack([np.full((len(F), 1), 3), np.asarray(F)]).ravel()
    return pv.PolyData(np.asarray(V, float), faces)


def render_surface(V, F, *, scalars=None, cmap="viridis", clim=None, uv=None, FUV=None, texture=None,
                   window_size=(800, 800), view="plane", scalar_bar=None, face_colors=None, n_checks="auto"):
    """Render a surface off screen with pyvista; returns an RGB image array.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    scalars : (m,) float array, optional
        Per-face values for a heatmap (colours from ``cmap``/``clim``, or
        ``cmap="detj"``; see :func:`~neuraluv.plot.style.scalar_colors`). Heatmaps
        and ``face_colors`` are drawn unlit, so every face shows exactly its colour
        bar's colour (a textured or plain surface is shaded). The
        image has no colour bar: :func:`~neuraluv.plot.mpl.plot_face_heatmap` and
        :func:`~neuraluv.plot.mpl.plot_surface_and_uv` add a matplotlib one
        (``scalar_bar="title"`` adds pyvista's instead).
    face_colors : (m,3|4) float array in [0, 1], optional
        Exact per-face colours (wins over ``scalars``).
    uv : (p,2) float array, optional
        Texture coordinates: the surface is textured with a checkerboard laid
        over the layout's bounding square (``n_checks`` checks across, by default
        :func:`~neuraluv.plot.style.checker_count`), or with ``texture`` at the
        raw coordinates.
    FUV : (m,3) int array, optional
        Per-corner UV indices (default ``F``).
    texture : (h,w,3) uint8 array, optional
    view : str or camera position
        ``"plane"`` (default, :func:`~neuraluv.plot.style.camera_view`: onto the
        best-fit plane), ``"iso"``, ``"+x"`` … ``"-z"``, or a pyvista camera
        position ``[position, focal point, view up]``. The picture is fitted tightly.

    Returns
    -------
    img : (h,w,3) uint8 array
    """
    import pyvista as pv

    _quiet_vtk()
    pv.OFF_SCREEN = True
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    _add_surface(pl, V, F, scalars=scalars, cmap=cmap, clim=clim, uv=uv, FUV=FUV, texture=texture,
                 scalar_bar=scalar_bar, face_colors=face_colors, n_checks=n_checks)
    _set_camera(pl, np.asarray(V, float), np.asarray(F), view, window_size)
    img = pl.screenshot(return_img=True)
    pl.close()
    return np.asarray(img)


def _quiet_vtk():
    """VTK's log to stderr at errors only: without a display it warns "bad X server connection" on every
    off-screen window although the render works (it falls back to an off-screen context)."""
    try:
        from vtkmodules.vtkCommonCore import vtkLogger
    except ImportError:  # an older VTK without the logger: nothing to quiet
        return
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)


def _add_surface(pl, V, F, *, scalars=None, cmap="viridis", clim=None, uv=None, FUV=None, texture=None,
                 scalar_bar=None, face_colors=None, n_checks="auto"):
    """Add the surface to a pyvista plotter: checker-textured, per-face coloured, a heatmap or plain."""
    import pyvista as pv

    F = np.asarray(F)
    V = np.asarray(V, float)
    if uv is not None:
        FUV = F if FUV is None else np.asarray(FUV)
        Vx = V[F.reshape(-1)]
        mesh = _polydata(Vx, np.arange(3 * len(F)).reshape(-1, 3))
        tc = np.asarray(uv, float)[FUV.reshape(-1)]
        if texture is None:
            lo, span = checker_square(uv, FUV)
            tc = (tc - lo) / span
            texture = checkerboard_texture(checker_count(uv, F, FUV) if n_checks == "auto" else int(n_checks))
        mesh.active_texture_coordinates = np.nan_to_num(tc)
    else:
        mesh = _polydata(V, F)
    pl.set_background("white")
    if uv is not None:
        pl.add_mesh(mesh, texture=pv.Texture(texture), smooth_shading=False)
    elif face_colors is not None or (scalars is not None and scalar_bar is None):
        if face_colors is None:
            face_colors = scalar_colors(scalars, cmap, clim)[0]
        fc = np.asarray(face_colors, float)
        fc = fc[:, :3] if fc.max() <= 1.0 else fc[:, :3] / 255.0
        mesh.cell_data["rgb"] = (np.clip(fc, 0, 1) * 255).astype(np.uint8)
        # unlit: shading would darken each face's colour, and the picture would no longer match its colour bar
        pl.add_mesh(mesh, scalars="rgb", rgb=True, show_scalar_bar=False, lighting=False)
    elif scalars is not None:
        mesh.cell_data["value"] = np.asarray(scalars, float)
        pl.add_mesh(mesh, scalars="value", cmap=cmap, clim=clim, show_scalar_bar=True, lighting=False,
                    scalar_bar_args={"title": scalar_bar})
    else:
        pl.add_mesh(mesh, color="lightsteelblue")


def _set_camera(pl, V, F, view, window_size):
    """Point the camera (:func:`~neuraluv.plot.style.camera_view`); fit the mesh tightly, parallel projection."""
    if view is None or isinstance(view, str) and view in CAMERA_VIEWS:
        cam = camera_view(V, "plane" if view is None else view, F=F)
    elif isinstance(view, str):  # pyvista's own names ('xy', 'yz', ...)
        pl.camera_position = view
        pl.reset_camera()
        return
    else:
        cam = view
    pl.camera_position = cam
    pl.enable_parallel_projection()
    pl.reset_camera()
    pos, focal, up = (np.asarray(x, float) for x in pl.camera_position)
    d = (pos - focal) / np.linalg.norm(pos - focal)
    up = up - (up @ d) * d
    up /= np.linalg.norm(up)
    right = np.cross(d, up)
    P = np.asarray(V, float)
    h = float(np.ptp(P @ up)) if len(P) else 1.0
    w = float(np.ptp(P @ right)) if len(P) else 1.0
    aspect = window_size[0] / window_size[1]
    c = focal + right * 0.5 * ((P @ right).max() + (P @ right).min() - 2 * focal @ right) \
        + up * 0.5 * ((P @ up).max() + (P @ up).min() - 2 * focal @ up)
    pl.camera.focal_point = tuple(c)
    pl.camera.position = tuple(c + d * np.linalg.norm(pos - focal))
    pl.camera.parallel_scale = 0.52 * max(h, w / aspect, 1e-12)
    pl.reset_camera_clipping_range()


def render_checkerboard(V, F, UV, FUV=None, **kw):
    """The mesh textured with a checkerboard through ``UV`` (RGB image array).

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional (default ``F``)
    **kw
        Passed to :func:`render_surface` (``view``, ``window_size``, ``n_checks``, ``texture``).

    Returns
    -------
    img : (h,w,3) uint8 array
    """
    return render_surface(V, F, uv=UV, FUV=FUV, **kw)


def trame_available():
    """Whether pyvista's trame back-end (the ``viewer`` extra) is installed, so :func:`live_view` can be live.

    Returns
    -------
    bool

    Examples
    --------
    >>> isinstance(trame_available(), bool)
    True
    """
    return all(importlib.util.find_spec(m) is not None for m in ("trame", "trame_vtk", "trame_vuetify"))


def live_view(V, F, UV=None, FUV=None, *, scalars=None, cmap="viridis", clim=None, backend="auto", view="plane"):
    """An interactive 3D view of a mesh (checker-textured through ``UV`` or a per-face heatmap).

    In JupyterLab with the ``viewer`` extra (``pip install neuraluv[viewer]``:
    pyvista's trame backend) the view can be turned and zoomed live; everywhere
    else — without the extra, off screen (``PYVISTA_OFF_SCREEN=true``, as in CI
    and the book build), or with ``backend="static"`` — the same scene is drawn
    as a static matplotlib figure, so a notebook runs the same cell either way.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array, optional
        The layout: the surface is checker-textured through it.
    FUV : (m,3) int array, optional (default ``F``)
    scalars : (m,) float array, optional
        Per-face values (``cmap``, ``clim``; ``cmap="detj"``).
    backend : ``"auto"``, ``"trame"`` (live; an error without the extra) or ``"static"``
    view : the initial camera (see :func:`render_surface`)

    Returns
    -------
    The trame viewer widget (live) or a matplotlib Figure (static).
    """
    if backend not in ("auto", "trame", "static"):
        raise ValueError(f"backend must be 'auto', 'trame' or 'static', not {backend!r}")
    live = backend == "trame" or (backend == "auto" and trame_available()
                                  and os.environ.get("PYVISTA_OFF_SCREEN", "").lower() not in ("1", "true"))
    if not live:
        plt = pyplot()
        img = render_surface(V, F, uv=UV, FUV=FUV, scalars=scalars, cmap=cmap, clim=clim, view=view)
        fig, ax = plt.subplots(figsize=(6, 6))
        ax.imshow(img)
        ax.set_axis_off()
        ax.set_title("static view (live: pip install neuraluv[viewer], JupyterLab)", fontsize=9)
        return fig
    if not trame_available():
        raise ImportError("the live view needs pyvista's trame backend: pip install 'neuraluv[viewer]'")
    import pyvista as pv

    pl = pv.Plotter(notebook=True)
    _add_surface(pl, V, F, scalars=scalars, cmap=cmap, clim=clim, uv=UV, FUV=FUV)
    _set_camera(pl, np.asarray(V, float), np.asarray(F), view, pl.window_size)
    return pl.show(jupyter_backend="trame", return_viewer=True)
