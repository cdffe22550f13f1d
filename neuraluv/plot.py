"""Figures: UV layouts (flips in red), surface heatmaps, checkerboard transfers, solve films.

Everything renders without a display: matplotlib with the Agg backend when no
display is present, pyvista off screen. 3D surface images come from pyvista;
they are returned as RGB arrays so they can be placed in matplotlib figures.

Conventions shared by every figure:

- the 3D camera looks onto the chart's best-fit plane (:func:`camera_view`,
  PCA of the vertices) unless a side is chosen;
- a scalar is drawn with the same colours on the surface and on the UV layout
  (:func:`scalar_colors`), with a colourbar;
- det J uses a diverging map centred on 1 (an isometry's area ratio) and red
  for det J ≤ 0 (:func:`detj_norm`, :data:`DETJ_CMAP`);
- the checkerboard's frequency follows the mesh (:func:`checker_count`: about
  four mean UV edge lengths per check).

The interactive film of a solve (:func:`plotly_solve_slider`) and the linked
surface/UV views (:func:`plotly_linked_views`: hover a face, it is outlined in both) need plotly;
:func:`show_plotly` embeds plotly.js in the output, so it also works offline
and in the static book.
"""
from __future__ import annotations

import os

import numpy as np

__all__ = [
    "checkerboard_texture", "plot_uv_layout", "render_surface", "render_checkerboard",
    "plot_checkerboard_transfer", "plot_face_heatmap", "plot_trace",
    "save_uv_layout", "save_checkerboard_transfer", "plot_alignment_curves", "plot_routes", "plot_repair", "ROUTE_COLORS",
    "camera_view", "checker_count", "detj_norm", "DETJ_CMAP", "DETJ_FOLD_COLOR", "scalar_colors", "face_detj",
    "plot_surface_and_uv", "solve_filmstrip", "plotly_solve_slider", "plotly_linked_views", "LINKED_HOVER_JS",
    "show_plotly", "live_view",
]


def _mpl():
    import matplotlib

    if not os.environ.get("DISPLAY") and "ipykernel" not in __import__("sys").modules:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def checkerboard_texture(n_checks=16, res=512):
    """A procedural checkerboard image ``(res, res, 3) uint8`` (the paper's diagnostic texture)."""
    i = (np.arange(res) * n_checks // res) % 2
    board = (i[:, None] ^ i[None, :]).astype(bool)
    img = np.where(board[..., None], np.array([235, 235, 235]), np.array([40, 90, 160]))
    return img.astype(np.uint8)


# --------------------------------------------------------------------------- cameras, colours, checks

_SIDES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1), "-z": (0, 0, -1)}


def _principal_axes(V, F=None):
    """Centre and principal axes of a point set, largest variance first; the last axis faces the front.

    The front is the side the area-weighted face normals point to (with faces),
    otherwise the side of the positive largest component.
    """
    V = np.asarray(V, float)
    c = V.mean(axis=0)
    X = V - c
    _, _, Vt = np.linalg.svd(X, full_matrices=False) if len(V) >= 3 else (None, None, np.eye(3))
    axes = np.array(Vt[:3], float)
    if len(axes) < 3:
        axes = np.eye(3)
    n = axes[2]
    if F is not None and len(F):
        F = np.asarray(F)
        nsum = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]).sum(axis=0)
        s = float(nsum @ n)
    else:
        s = float(n[np.argmax(np.abs(n))])
    if s < 0:
        axes[2] = -n
        axes[1] = -axes[1]  # keep a right-handed frame
    return c, axes


def camera_view(V, side="plane", *, F=None, distance=3.0):
    """A pyvista camera position ``[position, focal point, view up]`` for a chart.

    Parameters
    ----------
    V : (n,3) float array
    side : str
        ``"plane"`` (default): look along the normal of the best-fit plane (the
        smallest principal axis of the vertices), from the side the faces point
        to when ``F`` is given, with the world's y axis up (z when y is nearly
        along the view). ``"+x"``, ``"-x"``, ``"+y"``,
        ``"-y"``, ``"+z"``, ``"-z"``: look from that side onto the centre.
        ``"iso"``: from the (1, 1, 1) diagonal.
    F : (m,3) int array, optional
        Faces, to pick the front side of the plane.
    distance : float
        Camera distance in units of the bounding-sphere radius.

    Returns
    -------
    list of three 3-tuples

    Examples
    --------
    >>> g = np.linspace(0, 1, 5)
    >>> V = np.array([(x, 2 * y, 0.0) for x in g for y in g])
    >>> pos, focal, up = camera_view(V)
    >>> d = np.subtract(pos, focal); d = d / np.linalg.norm(d)
    >>> bool(abs(abs(d[2]) - 1) < 1e-9), bool(abs(np.dot(up, d)) < 1e-9)
    (True, True)
    """
    V = np.asarray(V, float)
    c, axes = _principal_axes(V, F)
    r = float(np.linalg.norm(V - c, axis=1).max()) if len(V) else 1.0
    r = r if r > 0 else 1.0
    if side in (None, "plane", "pca"):
        d = axes[2]
        # up: the world's y (else z) axis seen in the plane, so an upright model stays upright;
        # the middle principal axis when both are nearly along the view
        up = next((w for w in (np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])) if abs(w @ d) < 0.9), axes[1])
    elif side == "iso":
        d = np.ones(3) / np.sqrt(3.0)
        up = np.array([0.0, 0.0, 1.0]) - d / np.sqrt(3.0)
    elif side in _SIDES:
        d = np.array(_SIDES[side], float)
        up = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.5 else np.array([0.0, 1.0, 0.0])
    else:
        raise ValueError(f"unknown side {side!r}: 'plane', 'iso' or one of {sorted(_SIDES)}")
    up = up - (up @ d) * d
    up = up / np.linalg.norm(up)
    pos = c + distance * r * d
    return [tuple(map(float, pos)), tuple(map(float, c)), tuple(map(float, up))]


def checker_count(UV, F, FUV=None, *, edges_per_check=4.0, lo=4, hi=96):
    """Checks across the UV bounding square so that one check spans about ``edges_per_check`` mean UV edges.

    The checkerboard is laid over the layout's bounding square (see
    :func:`render_surface`); a fixed count would make the checks sub-triangle
    on a fine mesh and invisible on a coarse one.

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> from neuraluv.tutte import tutte
    >>> V, F = disk(4); coarse = checker_count(tutte(V, F), F)
    >>> V, F = disk(16); fine = checker_count(tutte(V, F), F)
    >>> lo_ok = 4 <= coarse < fine <= 96
    >>> lo_ok
    True
    """
    UV = np.asarray(UV, float)
    FUV = np.asarray(F if FUV is None else FUV)
    ok = np.isfinite(UV[FUV]).all(axis=(1, 2))
    T = UV[FUV[ok]]
    if not len(T):
        return lo
    span = float(np.ptp(T.reshape(-1, 2), axis=0).max())
    e = np.linalg.norm(T - np.roll(T, 1, axis=1), axis=2)
    mean_edge = float(np.median(e)) if e.size else 0.0
    if not (span > 0 and mean_edge > 0):
        return lo
    return int(np.clip(round(span / (edges_per_check * mean_edge)), lo, hi))


#: det J colour map: diverging around 1 (purple: compressed, green: stretched); det J ≤ 0 is red.
DETJ_CMAP = "PRGn"
#: The colour of folded faces (det J ≤ 0), here and in :func:`plot_uv_layout`.
DETJ_FOLD_COLOR = (0.9, 0.05, 0.05, 1.0)


def detj_norm(vmax=3.0):
    """A matplotlib norm for det J: 0 → 0, 1 → 0.5 (the colour map's centre), ``vmax`` → 1, ≤ 0 → under (red).

    Use with :func:`detj_cmap` (``DETJ_CMAP`` with red as its *under* colour).

    Examples
    --------
    >>> n = detj_norm(3.0)
    >>> float(n(1.0)), float(n(3.0)), bool(n(0.0) < 0), bool(n(-2.0) < 0)
    (0.5, 1.0, True, True)
    """
    from matplotlib.colors import TwoSlopeNorm

    class DetJNorm(TwoSlopeNorm):
        def __call__(self, value, clip=None):
            out = super().__call__(value, clip)
            v = np.ma.asarray(value, float)
            if np.ndim(out) == 0:
                return -np.inf if float(v) <= 0 else out
            return np.ma.where(np.ma.filled(v, 1.0) <= 0, -np.inf, out)

    return DetJNorm(vcenter=1.0, vmin=0.0, vmax=max(float(vmax), 1.0 + 1e-6))


def detj_cmap():
    """``DETJ_CMAP`` with :data:`DETJ_FOLD_COLOR` as its under colour (det J ≤ 0)."""
    import matplotlib

    return matplotlib.colormaps[DETJ_CMAP].with_extremes(under=DETJ_FOLD_COLOR, bad=(0.5, 0.5, 0.5, 1.0))


def scalar_colors(values, cmap="viridis", clim=None, *, norm=None):
    """Per-face RGBA colours of a scalar and the ScalarMappable for its colourbar.

    ``cmap="detj"`` selects the det J convention (:func:`detj_norm`,
    :func:`detj_cmap`; ``clim=(_, vmax)`` sets its top). The same colours are
    given to the 3D render and the UV layout, so the two panels read alike.

    Returns
    -------
    rgba : (m,4) float array
    mappable : matplotlib.cm.ScalarMappable
    """
    import matplotlib
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    v = np.asarray(values, float)
    if isinstance(cmap, str) and cmap == "detj":
        vmax = 3.0 if clim is None else float(clim[1])
        cm, norm = detj_cmap(), detj_norm(vmax)
    else:
        cm = matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap
        if norm is None:
            fin = v[np.isfinite(v)]
            lo, hi = clim if clim is not None else ((fin.min(), fin.max()) if fin.size else (0.0, 1.0))
            if not hi > lo:
                hi = lo + 1.0
            norm = Normalize(lo, hi)
    rgba = np.asarray(cm(norm(v)), float).reshape(len(v), 4)
    return rgba, ScalarMappable(norm=norm, cmap=cm)


def face_detj(V, F, UV, FUV=None):
    """det J of every face at the chart's 3D scale (1: area preserved; ≤ 0: folded)."""
    from neuraluv.metrics import face_dets

    return face_dets(V, F, UV, FUV)


def _colorbar(ax, mappable, label, *, detj=False):
    fig = ax.figure
    extend = "both" if detj else "neither"
    if detj:  # the colourbar needs finite boundaries: draw it with the plain two-slope norm (≤ 0 is its red 'under' end)
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import TwoSlopeNorm

        n = mappable.norm
        mappable = ScalarMappable(norm=TwoSlopeNorm(vcenter=n.vcenter, vmin=n.vmin, vmax=n.vmax), cmap=mappable.cmap)
    cb = fig.colorbar(mappable, ax=ax, shrink=0.75, pad=0.02, extend=extend)
    cb.set_label(label, fontsize=8)
    cb.ax.tick_params(labelsize=7)
    if detj:
        vmax = mappable.norm.vmax
        cb.set_ticks([t for t in (0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0) if t <= vmax])
    return cb


def _flipped(V, F, UV, FUV=None):
    if V is None:  # no 3D positions: the UV winding decides
        from neuraluv.jacobian import signed_areas_2d

        return signed_areas_2d(UV, F if FUV is None else FUV) <= 0
    from neuraluv.metrics import face_dets

    return ~(face_dets(V, F, UV, FUV) > 0)


def plot_uv_layout(V, F, UV, ax=None, *, title=None, FUV=None, face_colors=None, show_box=True):
    """Draw a UV layout; flipped triangles (det J ≤ 0) are filled red.

    Parameters
    ----------
    V : (n,3) float array or None
        3D positions (used to decide flips by det J; without them the UV
        winding decides).
    F : (m,3) int array
    UV : (p,2) float array
    ax : matplotlib Axes, optional
    FUV : (m,3) int array, optional
        Per-corner UV indices (default ``F``).
    face_colors : (m,) or (m,3|4) array, optional
        Colours instead of the default light grey.

    Returns
    -------
    ax : matplotlib Axes
    """
    plt = _mpl()
    from matplotlib.collections import PolyCollection

    F = np.asarray(F)
    UV = np.asarray(UV, float)
    FUV = F if FUV is None else np.asarray(FUV)
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 5))
    flipped = _flipped(V, F, UV, FUV) if V is not None else _flipped(None, FUV, UV)
    tris = UV[FUV]
    fc = np.tile([0.85, 0.87, 0.9, 1.0], (len(F), 1)) if face_colors is None else face_colors
    pc = PolyCollection(tris, facecolors=fc, edgecolors=(0.2, 0.2, 0.25, 0.5), linewidths=0.15)
    ax.add_collection(pc)
    if flipped.any():
        ax.add_collection(PolyCollection(tris[flipped], facecolors="red", edgecolors="darkred", linewidths=0.4))
    if show_box:
        ax.plot([0, 1, 1, 0, 0], [0, 0, 1, 1, 0], lw=0.5, color="0.6")
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xticks([])
    ax.set_yticks([])
    n = int(flipped.sum())
    ax.set_title(title or f"UV layout: {n} flipped / {len(F)} faces", fontsize=9, color="red" if n else "black")
    return ax


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
        ``cmap="detj"``; see :func:`scalar_colors`). The image has no colour
        bar: :func:`plot_face_heatmap` and :func:`plot_surface_and_uv` add a
        matplotlib one (``scalar_bar="title"`` adds pyvista's instead).
    face_colors : (m,3|4) float array in [0, 1], optional
        Exact per-face colours (wins over ``scalars``).
    uv : (p,2) float array, optional
        Texture coordinates: the surface is textured with a checkerboard laid
        over the layout's bounding square (``n_checks`` checks across, by default
        :func:`checker_count`), or with ``texture`` at the raw coordinates.
    FUV : (m,3) int array, optional
        Per-corner UV indices (default ``F``).
    texture : (h,w,3) uint8 array, optional
    view : str or camera position
        ``"plane"`` (default, :func:`camera_view`: onto the best-fit plane),
        ``"iso"``, ``"+x"`` … ``"-z"``, or a pyvista camera position
        ``[position, focal point, view up]``. The picture is fitted tightly.

    Returns
    -------
    img : (h,w,3) uint8 array
    """
    import pyvista as pv

    pv.OFF_SCREEN = True
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    _add_surface(pl, V, F, scalars=scalars, cmap=cmap, clim=clim, uv=uv, FUV=FUV, texture=texture,
                 scalar_bar=scalar_bar, face_colors=face_colors, n_checks=n_checks)
    _set_camera(pl, np.asarray(V, float), np.asarray(F), view, window_size)
    img = pl.screenshot(return_img=True)
    pl.close()
    return np.asarray(img)


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
            fin = np.isfinite(tc).all(axis=1)
            lo = tc[fin].min(axis=0) if fin.any() else np.zeros(2)
            span = float(np.ptp(tc[fin], axis=0).max()) if fin.any() else 1.0
            tc = (tc - lo) / (span if span > 0 else 1.0)
            n = checker_count(uv, F, FUV) if n_checks == "auto" else int(n_checks)
            texture = checkerboard_texture(n, res=int(min(2048, max(512, 16 * n))))
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
        pl.add_mesh(mesh, scalars="rgb", rgb=True, show_scalar_bar=False)
    elif scalars is not None:
        mesh.cell_data["value"] = np.asarray(scalars, float)
        pl.add_mesh(mesh, scalars="value", cmap=cmap, clim=clim, show_scalar_bar=True,
                    scalar_bar_args={"title": scalar_bar})
    else:
        pl.add_mesh(mesh, color="lightsteelblue")


def _trame_available():
    import importlib.util

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
    V, F, UV, FUV : the mesh and (optionally) its layout
    scalars : (m,) float array, optional; per-face values (``cmap``, ``clim``; ``cmap="detj"``)
    backend : ``"auto"``, ``"trame"`` (live; an error without the extra) or ``"static"``
    view : the initial camera (see :func:`render_surface`)

    Returns
    -------
    The trame viewer widget (live) or a matplotlib Figure (static).
    """
    live = backend == "trame" or (backend == "auto" and _trame_available()
                                  and os.environ.get("PYVISTA_OFF_SCREEN", "").lower() not in ("1", "true"))
    if backend not in ("auto", "trame", "static"):
        raise ValueError(f"backend must be 'auto', 'trame' or 'static', not {backend!r}")
    if not live:
        plt = _mpl()
        img = render_surface(V, F, uv=UV, FUV=FUV, scalars=scalars, cmap=cmap, clim=clim, view=view)
        fig, ax = plt.subplots(figsize=(6, 6))
        ax.imshow(img)
        ax.set_axis_off()
        ax.set_title("static view (live: pip install neuraluv[viewer], JupyterLab)", fontsize=9)
        return fig
    if not _trame_available():
        raise ImportError("the live view needs pyvista's trame backend: pip install 'neuraluv[viewer]'")
    import pyvista as pv

    pl = pv.Plotter(notebook=True)
    _add_surface(pl, V, F, scalars=scalars, cmap=cmap, clim=clim, uv=UV, FUV=FUV)
    _set_camera(pl, np.asarray(V, float), np.asarray(F), view, pl.window_size)
    return pl.show(jupyter_backend="trame", return_viewer=True)


def _set_camera(pl, V, F, view, window_size):
    """Point the camera (see :func:`camera_view`) and fit the mesh tightly with a parallel projection."""
    if view is None or isinstance(view, str) and view in ("plane", "pca", "iso", *_SIDES):
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
    """The mesh textured with a checkerboard through ``UV`` (RGB image array)."""
    return render_surface(V, F, uv=UV, FUV=FUV, **kw)


def plot_checkerboard_transfer(V, F, UV, FUV=None, *, title=None, view="plane", n_checks="auto"):
    """The paper's standard figure: checkerboard on the 3D mesh beside the UV layout with the same checks.

    The checks are laid over the layout's bounding square, ``n_checks`` across
    (default :func:`checker_count`: about four mean UV edges per check), so
    the UV panel shows exactly the texture the surface carries; flipped faces
    are red in the UV panel.

    Returns
    -------
    fig : matplotlib Figure
    """
    plt = _mpl()
    F = np.asarray(F)
    FUV = F if FUV is None else np.asarray(FUV)
    UV = np.asarray(UV, float)
    n = checker_count(UV, F, FUV) if n_checks == "auto" else int(n_checks)
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 6))
    a.imshow(render_checkerboard(V, F, UV, FUV, view=view, n_checks=n))
    a.set_axis_off()
    a.set_title(f"checkerboard transfer ({n} checks across the layout)", fontsize=9)
    T = UV[FUV].reshape(-1, 2)
    T = T[np.isfinite(T).all(axis=1)]
    lo = T.min(axis=0) if len(T) else np.zeros(2)
    span = float(np.ptp(T, axis=0).max()) if len(T) else 1.0
    tex = checkerboard_texture(n, res=int(min(2048, max(512, 16 * n))))
    b.imshow(tex, extent=(lo[0], lo[0] + span, lo[1], lo[1] + span), origin="lower", alpha=0.55,
             interpolation="nearest", zorder=0)
    plot_uv_layout(V, F, UV, ax=b, FUV=FUV, face_colors=np.tile([1.0, 1.0, 1.0, 0.0], (len(F), 1)),
                   show_box=False)
    b.set_xlim(lo[0], lo[0] + span)
    b.set_ylim(lo[1], lo[1] + span)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_face_heatmap(V, F, values, *, ax=None, title="", cmap="coolwarm", clim=None, view="plane", label=None,
                      window_size=(800, 800)):
    """A per-face scalar (e.g. det J or conformal distortion) on the surface, with a colourbar.

    ``cmap="detj"`` uses the det J convention (diverging around 1, red for ≤ 0).
    """
    plt = _mpl()
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 6))
    rgba, sm = scalar_colors(values, cmap, clim)
    ax.imshow(render_surface(V, F, face_colors=rgba, view=view, window_size=window_size))
    ax.set_axis_off()
    ax.set_title(title, fontsize=9)
    is_detj = isinstance(cmap, str) and cmap == "detj"
    _colorbar(ax, sm, label or ("det J  (red: ≤ 0, folded)" if is_detj else "value"), detj=is_detj)
    return ax


def plot_surface_and_uv(V, F, UV, values=None, *, FUV=None, cmap="detj", clim=None, label=None, title=None,
                        view="plane", axes=None, window_size=(800, 800)):
    """A per-face scalar on the surface and on the UV layout in the same colours, with one colourbar.

    Parameters
    ----------
    V, F, UV, FUV : the mesh and its layout
    values : (m,) float array, optional
        Default: det J of the layout (:func:`face_detj`) with ``cmap="detj"``.
    cmap, clim : see :func:`scalar_colors`
    axes : two matplotlib Axes, optional

    Returns
    -------
    fig : matplotlib Figure
    """
    plt = _mpl()
    F = np.asarray(F)
    if values is None:
        values = face_detj(V, F, UV, FUV)
    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(12, 5.6))
    else:
        fig = axes[0].figure
    rgba, sm = scalar_colors(values, cmap, clim)
    axes[0].imshow(render_surface(V, F, face_colors=rgba, view=view, window_size=window_size))
    axes[0].set_axis_off()
    axes[0].set_title("surface", fontsize=9)
    plot_uv_layout(V, F, UV, ax=axes[1], FUV=FUV, face_colors=rgba, show_box=False)
    is_detj = isinstance(cmap, str) and cmap == "detj"
    _colorbar(axes[1], sm, label or ("det J  (red: ≤ 0, folded)" if is_detj else "value"), detj=is_detj)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def plot_trace(trace, axes=None, *, label=None):
    """Solver trace: E_SD, min det J and cumulative rejected steps per iteration."""
    plt = _mpl()
    if axes is None:
        _, axes = plt.subplots(1, 3, figsize=(12, 3.2))
    it = trace["iter"]
    axes[0].semilogy(it, trace["esd"], label=label)
    axes[0].set_title("E_SD (true)")
    axes[1].semilogy(it, np.maximum(trace["min_det"], 1e-12), label=label)
    axes[1].set_title("min det J")
    axes[2].plot(it, trace["rejected"], label=label)
    axes[2].set_title("rejected steps (cumulative)")
    for a in axes:
        a.set_xlabel("iteration")
    if label:
        axes[0].legend(fontsize=8)
    return axes


def _save(fig, path):
    from neuraluv.io import atomic_write

    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, dpi=110, format="png")
    _mpl().close(fig)


def save_uv_layout(path, V, F, UV, FUV=None):
    """Write the UV layout PNG (flipped faces in red)."""
    plt = _mpl()
    fig, ax = plt.subplots(figsize=(6, 6))
    plot_uv_layout(V, F, UV, ax=ax, FUV=FUV)
    _save(fig, path)


def save_checkerboard_transfer(path, V, F, UV, FUV=None):
    """Write the checkerboard-transfer PNG (3D render beside the UV layout)."""
    _save(plot_checkerboard_transfer(V, F, UV, FUV), path)


def plot_alignment_curves(curves, ax=None, *, title=None):
    """Alignment curves ``s_r`` against ``r``.

    Parameters
    ----------
    curves : dict label -> (R,) array
    ax : matplotlib axes, optional
    title : str, optional

    Returns
    -------
    ax
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 3.8))
    for label, c in curves.items():
        c = np.asarray(c)
        ax.plot(np.arange(1, len(c) + 1), c, marker="o", ms=3, label=label)
    R = max(len(np.asarray(c)) for c in curves.values()) if curves else 16
    ax.set_xlabel("rank r")
    ax.set_ylabel("s_r = ||Q_r^T Psi_r||_F^2 / r")
    ax.set_ylim(0, 1.02)
    ax.set_xticks(range(1, R + 1, max(1, R // 8)))
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title)
    ax.legend(fontsize=8)
    return ax


#: Figure 8 colours: neural charts blue, exact unfolds green, fallbacks red.
ROUTE_COLORS = {"neural": (0.16, 0.40, 0.80, 1.0), "exact": (0.20, 0.62, 0.35, 1.0), "fallback": (0.86, 0.18, 0.15, 1.0)}
_ROUTE_ORDER = ("fallback", "neural", "exact")  # face_route codes 0, 1, 2


def plot_routes(V, F, UV, FUV, face_route, *, islands=None, flips=None, zoom=True, view=None):
    """Figure 8: the surface and the packed atlas coloured by route.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array
    face_route : (m,) int array, 1 neural, 2 exact unfold, 0 marked fallback.
    islands, flips : int, optional
        Counts printed in the atlas panel's title.
    zoom : bool
        Add a third panel zoomed on the fallback islands (when there are any).
    view : optional camera (see :func:`render_surface`)

    Returns
    -------
    fig : matplotlib Figure
    """
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    face_route = np.asarray(face_route)
    fb = face_route == 0
    ncol = 3 if (zoom and fb.any()) else 2
    fig, axes = plt.subplots(1, ncol, figsize=(4.2 * ncol, 4.2))
    cmap = ListedColormap([ROUTE_COLORS[r][:3] for r in _ROUTE_ORDER])
    img = render_surface(V, F, scalars=face_route.astype(float), cmap=cmap, clim=(0, 2), view=view)
    axes[0].imshow(img)
    axes[0].axis("off")
    share = [float((face_route == k).mean()) if len(face_route) else 0.0 for k in range(3)]
    axes[0].set_title(f"(a) routes: neural {100 * share[1]:.1f}% / exact {100 * share[2]:.1f}% / "
                      f"fallback {100 * share[0]:.1f}% of faces", fontsize=9)
    from matplotlib.patches import Patch

    axes[0].legend(handles=[Patch(color=ROUTE_COLORS[r], label=r) for r in ("neural", "exact", "fallback")],
                   loc="lower right", fontsize=8, frameon=False)
    colors = np.array([ROUTE_COLORS[r] for r in _ROUTE_ORDER])
    fc = colors[face_route.astype(int)]
    counts = ", ".join(s for s in (f"{islands} islands" if islands is not None else "",
                                   f"{flips} flips" if flips is not None else "") if s)
    plot_uv_layout(V, F, UV, ax=axes[1], FUV=FUV, face_colors=fc, title="(b) atlas" + (f": {counts}" if counts else ""))
    if ncol == 3:
        plot_uv_layout(V, F, UV, ax=axes[2], FUV=FUV, face_colors=fc, show_box=False, title="(c) zoom on fallback islands")
        uvf = UV[FUV[fb]].reshape(-1, 2)
        lo, hi = uvf.min(0), uvf.max(0)
        c, h = 0.5 * (lo + hi), 0.5 * max((hi - lo).max(), 0.02)
        axes[2].set_xlim(c[0] - h, c[0] + h)
        axes[2].set_ylim(c[1] - h, c[1] + h)
    fig.tight_layout()
    return fig


def plot_repair(res, *, title=None, zoom=True):
    """Before / after of a UV repair: flipped faces red, faces the repair changed orange.

    Parameters
    ----------
    res : :class:`~neuraluv.repair.repair.RepairResult`
    title : str, optional
    zoom : bool
        Add a panel zoomed on the changed faces (when they cover a small part of the layout).

    Returns
    -------
    fig : matplotlib Figure
    """
    plt = _mpl()

    from neuraluv.meshfix import normalize_unit_box

    F = np.asarray(res.F)
    Vn = normalize_unit_box(res.V)[0]
    UV0, FUV0 = res.UV_in, res.FUV_in
    ch = np.asarray(res.changed_faces)
    grey = np.array([0.85, 0.87, 0.9, 1.0])
    orange = np.array([1.0, 0.6, 0.1, 1.0])
    small = ch.any() and ch.mean() < 0.5
    ncol = 3 if (zoom and small) else 2
    fig, axes = plt.subplots(1, ncol, figsize=(4.2 * ncol, 4.4))
    if UV0 is not None and FUV0 is not None:
        UV0 = np.asarray(UV0, float)
        ok = (FUV0 >= 0).all(1) & (FUV0 < len(UV0)).all(1)
        ok[ok] = np.isfinite(UV0[FUV0[ok]]).all(axis=(1, 2))
        fc = np.tile(grey, (int(ok.sum()), 1))
        fc[ch[ok]] = [1.0, 0.85, 0.6, 1.0]
        plot_uv_layout(Vn, F[ok], UV0, ax=axes[0], FUV=FUV0[ok], face_colors=fc,
                       title=f"(a) before: {res.before.validation['flips']} flips, "
                             f"{res.before.validation['overlapping_pairs']} overlapping island pairs")
    fc = np.where(ch[:, None], orange, grey)
    plot_uv_layout(Vn, F, res.UV, ax=axes[1], FUV=res.FUV, face_colors=fc,
                   title=f"(b) after: {int(ch.sum())} faces changed (orange), {res.after.validation['flips']} flips")
    if ncol == 3:
        plot_uv_layout(Vn, F, res.UV, ax=axes[2], FUV=res.FUV, face_colors=fc, show_box=False,
                       title="(c) zoom on the changed faces")
        pts = res.UV[res.FUV[ch]].reshape(-1, 2)
        lo, hi = pts.min(0), pts.max(0)
        c, h = 0.5 * (lo + hi), 0.6 * max((hi - lo).max(), 0.02)
        axes[2].set_xlim(c[0] - h, c[0] + h)
        axes[2].set_ylim(c[1] - h, c[1] + h)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


# --------------------------------------------------------------------------- watching a solve


def _frame_title(f):
    return f"it {f['step']}: E_SD {f['esd']:.3f}, {f['flips']} flips"


def solve_filmstrip(film, n=6, *, vmax=3.0, title=None):
    """A film strip of a recorded solve: the UV layout at ``n`` steps, faces coloured by det J.

    Parameters
    ----------
    film : :class:`neuraluv.solver.film.SolveFilm` (from :func:`neuraluv.solver.film.record_solve`)
    n : int
        Number of panels (first and last always included).
    vmax : float
        Top of the det J colour scale (1 is its centre, ≤ 0 red).

    Returns
    -------
    fig : matplotlib Figure
    """
    plt = _mpl()
    frames = film.pick(n)
    fig, axes = plt.subplots(1, len(frames), figsize=(2.9 * len(frames) + 0.8, 3.4), squeeze=False)
    axes = axes[0]
    allp = np.concatenate([f["uv"] for f in frames])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.03 * float((hi - lo).max())
    sm = None
    for ax, f in zip(axes, frames):
        rgba, sm = scalar_colors(f["det"], "detj", (0, vmax))
        plot_uv_layout(None, film.F, f["uv"], ax=ax, face_colors=rgba, show_box=False, title=_frame_title(f))
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
    if sm is not None:
        _colorbar(axes[-1], sm, "det J  (red: ≤ 0)", detj=True)
    fig.suptitle(title or f"{film.label}: the solve, {len(film.frames)} snapshots recorded", fontsize=10)
    fig.tight_layout()
    return fig


def _plotly_detj(det, vmax):
    """det J → a colour value in [0, 1] for :func:`_plotly_detj_scale` (≤ 0 → 0, the red band)."""
    n = detj_norm(vmax)
    t = np.ma.filled(np.ma.asarray(n(np.clip(np.asarray(det, float), -1.0, vmax))), -np.inf)
    t = np.clip(np.asarray(t, float), 0.0, 1.0)
    out = 0.06 + 0.94 * t
    out[~(np.asarray(det) > 0)] = 0.0
    return out.astype(np.float32)


def _plotly_detj_scale(vmax):
    import matplotlib

    cm = matplotlib.colormaps[DETJ_CMAP]
    red = "rgb(%d,%d,%d)" % tuple(int(255 * c) for c in DETJ_FOLD_COLOR[:3])
    scale = [[0.0, red], [0.05, red]]
    for x in np.linspace(0, 1, 11):
        r, g, b, _ = cm(x)
        scale.append([0.06 + 0.94 * float(x), f"rgb({int(255 * r)},{int(255 * g)},{int(255 * b)})"])
    ticks = [t for t in (0.0, 0.5, 1.0, 2.0, 3.0, 5.0) if t <= vmax]
    n = detj_norm(vmax)
    tickvals = [0.025] + [0.06 + 0.94 * float(n(t)) for t in ticks[1:]]
    ticktext = ["≤ 0"] + [f"{t:g}" for t in ticks[1:]]
    return scale, tickvals, ticktext


def plotly_solve_slider(film, *, max_frames=24, vmax=3.0, surface=True, height=520):
    """An interactive film of a solve: an iteration slider (and play button) over the UV layout,
    faces coloured by det J, beside the surface in the same colours.

    Parameters
    ----------
    film : :class:`neuraluv.solver.film.SolveFilm`
    max_frames : int
        Frames kept (spread over the film); the figure's size grows with it.
    vmax : float
        Top of the det J colour scale (1 is its centre, ≤ 0 red).
    surface : bool
        Add the 3D surface (camera: :func:`camera_view`), recoloured per frame.

    Returns
    -------
    plotly.graph_objects.Figure
        Show it with :func:`show_plotly` (self-contained HTML, works offline and
        in the static book).
    """
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    frames = film.pick(max_frames)
    V = np.asarray(film.V, float)
    F = np.asarray(film.F, np.int32)
    scale, tickvals, ticktext = _plotly_detj_scale(vmax)
    ijk = dict(i=F[:, 0], j=F[:, 1], k=F[:, 2])
    flat = dict(flatshading=True, lighting=dict(ambient=1.0, diffuse=0.0, specular=0.0, roughness=1.0, fresnel=0.0),
                intensitymode="cell", colorscale=scale, cmin=0.0, cmax=1.0)
    cbar = dict(title=dict(text="det J"), tickvals=tickvals, ticktext=ticktext, len=0.8)

    def uv_trace(f):
        uv = np.asarray(f["uv"], np.float32)
        return go.Mesh3d(x=uv[:, 0], y=uv[:, 1], z=np.zeros(len(uv), np.float32), intensity=_plotly_detj(f["det"], vmax),
                         showscale=True, colorbar=cbar, hoverinfo="skip", name="UV", **ijk, **flat)

    def surf_trace(f):
        Vf = V.astype(np.float32)
        return go.Mesh3d(x=Vf[:, 0], y=Vf[:, 1], z=Vf[:, 2], intensity=_plotly_detj(f["det"], vmax), showscale=False,
                         hoverinfo="skip", name="surface", **ijk, **flat)

    cols = 2 if surface else 1
    fig = make_subplots(rows=1, cols=cols, specs=[[{"type": "scene"}] * cols],
                        subplot_titles=(["surface (det J)"] if surface else []) + ["UV layout (det J)"],
                        horizontal_spacing=0.02)
    f0 = frames[0]
    if surface:
        fig.add_trace(surf_trace(f0), row=1, col=1)
    fig.add_trace(uv_trace(f0), row=1, col=cols)
    allp = np.concatenate([f["uv"] for f in frames])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.03 * float((hi - lo).max())
    ext = hi - lo + 2 * pad
    hidden = dict(visible=False, showbackground=False)
    uv_scene = dict(xaxis=dict(range=[lo[0] - pad, hi[0] + pad], **hidden),
                    yaxis=dict(range=[lo[1] - pad, hi[1] + pad], **hidden),
                    zaxis=dict(range=[-1, 1], **hidden), aspectmode="manual",
                    aspectratio=dict(x=float(ext[0] / ext.max()), y=float(ext[1] / ext.max()), z=0.01),
                    camera=dict(eye=dict(x=0, y=0, z=2.0), up=dict(x=0, y=1, z=0),
                                projection=dict(type="orthographic")),
                    dragmode="pan")
    layout = {f"scene{cols if cols > 1 else ''}": uv_scene}
    if surface:
        pos, focal, up = (np.asarray(x) for x in camera_view(V, F=F))
        d = (pos - focal) / np.linalg.norm(pos - focal)
        layout["scene"] = dict(xaxis=hidden, yaxis=hidden, zaxis=hidden, aspectmode="data",
                               camera=dict(eye=dict(zip("xyz", map(float, 1.6 * d))), up=dict(zip("xyz", map(float, up))),
                                           projection=dict(type="orthographic")))
    names = [str(f["step"]) for f in frames]
    def uv_update(f):  # a frame only restyles what changes (the faces and the 3D positions are sent once)
        uv = np.asarray(f["uv"], np.float32)
        return go.Mesh3d(x=uv[:, 0], y=uv[:, 1], intensity=_plotly_detj(f["det"], vmax))

    def surf_update(f):
        return go.Mesh3d(intensity=_plotly_detj(f["det"], vmax))

    fig.frames = [go.Frame(name=nm, data=([surf_update(f)] if surface else []) + [uv_update(f)],
                           traces=list(range(cols)), layout=dict(title_text=f"{film.label}: " + _frame_title(f)))
                  for nm, f in zip(names, frames)]
    anim = dict(mode="immediate", frame=dict(duration=0, redraw=True), transition=dict(duration=0))
    slider = dict(active=0, pad=dict(t=10, b=6), currentvalue=dict(prefix="iteration ", font=dict(size=13)),
                  steps=[dict(label=nm, value=nm, method="animate", args=[[nm], anim]) for nm in names])
    play = dict(type="buttons", showactive=False, x=0.0, y=0.0, xanchor="right", yanchor="top", pad=dict(t=40, r=10),
                buttons=[dict(label="▶ play", method="animate",
                              args=[None, dict(mode="immediate", fromcurrent=True, frame=dict(duration=350, redraw=True),
                                               transition=dict(duration=0))])])
    fig.update_layout(title_text=f"{film.label}: " + _frame_title(f0), height=height, sliders=[slider],
                      updatemenus=[play], margin=dict(l=10, r=10, t=60, b=10), **layout)
    return fig


#: JavaScript run after a :func:`plotly_linked_views` figure is drawn (``{plot_id}`` is the
#: figure's div): hovering a face in either view outlines it in both (the two outline
#: traces are the figure's last two).
LINKED_HOVER_JS = """
(function () {
  var gd = document.getElementById('{plot_id}');
  if (!gd || !gd.on) { return; }
  var n = gd.data.length, surf = 0, uv = 1;
  function corners(t, f) {
    var d = gd._fullData[t], x = [], y = [], z = [];
    [d.i[f], d.j[f], d.k[f], d.i[f]].forEach(function (v) {
      x.push(d.x[v]); y.push(d.y[v]); z.push(d.z ? d.z[v] : 0);
    });
    return [x, y, z];
  }
  gd.on('plotly_hover', function (ev) {
    var p = ev.points && ev.points[0];
    if (!p || (p.curveNumber !== surf && p.curveNumber !== uv)) { return; }
    var f = p.pointNumber, a = corners(surf, f), b = corners(uv, f);
    Plotly.restyle(gd, {x: [a[0], b[0]], y: [a[1], b[1]], z: [a[2], b[2]], visible: [true, true]}, [n - 2, n - 1]);
  });
  gd.on('plotly_unhover', function () {
    Plotly.restyle(gd, {visible: [false, false]}, [n - 2, n - 1]);
  });
})();
"""


def plotly_linked_views(V, F, UV, FUV=None, *, values=None, label="det J", hover=None, vmax=3.0, cmap="Viridis",
                        height=480, title=None):
    """The surface and its UV layout side by side; hovering a face outlines it in both views.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional
        Per-corner UV indices (default ``F``).
    values : (m,) float array, optional
        Per-face colour (default det J, on the diverging det J scale with det ≤ 0 red).
    label : str
        Colourbar title of ``values``.
    hover : dict of str -> (m,) array, optional
        Extra per-face quantities listed in the hover label (e.g. ``{"σ1": smax}``).
    vmax : float
        Top of the det J scale (when ``values`` is None).
    cmap : str
        plotly colour scale of ``values``.

    Returns
    -------
    plotly.graph_objects.Figure
        Show it with :func:`show_plotly`, which adds :data:`LINKED_HOVER_JS`
        (marked in ``fig.layout.meta``): the outlines follow the mouse in a
        notebook and in the static book alike.

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> V, F = disk(2)
    >>> fig = plotly_linked_views(V, F, V[:, :2], hover={"area": np.ones(len(F))})
    >>> [t.type for t in fig.data], fig.layout.meta["linked_hover"]
    (['mesh3d', 'mesh3d', 'scatter3d', 'scatter3d'], True)
    """
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    V = np.asarray(V, np.float32)
    F = np.asarray(F, np.int32)
    FUV = F if FUV is None else np.asarray(FUV, np.int32)
    UV = np.asarray(UV, np.float32)
    det = face_detj(V, F, UV, FUV)
    flat = dict(flatshading=True, lighting=dict(ambient=1.0, diffuse=0.0, specular=0.0, roughness=1.0, fresnel=0.0),
                intensitymode="cell")
    if values is None:
        scale, tickvals, ticktext = _plotly_detj_scale(vmax)
        color = dict(intensity=_plotly_detj(det, vmax), colorscale=scale, cmin=0.0, cmax=1.0)
        cbar = dict(title=dict(text="det J"), tickvals=tickvals, ticktext=ticktext, len=0.8)
    else:
        vals = np.asarray(values, np.float32)
        color = dict(intensity=vals, colorscale=cmap, cmin=float(np.nanmin(vals)), cmax=float(np.nanmax(vals)))
        cbar = dict(title=dict(text=label), len=0.8)
    rows = {"det J": det} if values is None else {label: np.asarray(values), "det J": det}
    rows.update(hover or {})
    text = ["face %d<br>" % f + "<br>".join(f"{k} {v[f]:.4g}" for k, v in rows.items()) for f in range(len(F))]
    fig = make_subplots(rows=1, cols=2, specs=[[{"type": "scene"}] * 2], horizontal_spacing=0.02,
                        subplot_titles=("surface", "UV layout"))
    fig.add_trace(go.Mesh3d(x=V[:, 0], y=V[:, 1], z=V[:, 2], i=F[:, 0], j=F[:, 1], k=F[:, 2], hovertext=text,
                            hoverinfo="text", showscale=False, name="surface", **color, **flat), row=1, col=1)
    fig.add_trace(go.Mesh3d(x=UV[:, 0], y=UV[:, 1], z=np.zeros(len(UV), np.float32), i=FUV[:, 0], j=FUV[:, 1],
                            k=FUV[:, 2], hovertext=text, hoverinfo="text", showscale=True, colorbar=cbar, name="UV",
                            **color, **flat), row=1, col=2)
    outline = dict(mode="lines", line=dict(color="#d62728", width=7), hoverinfo="skip", visible=False,
                   showlegend=False)
    fig.add_trace(go.Scatter3d(x=[0.0], y=[0.0], z=[0.0], **outline), row=1, col=1)
    fig.add_trace(go.Scatter3d(x=[0.0], y=[0.0], z=[0.0], **outline), row=1, col=2)
    hidden = dict(visible=False, showbackground=False)
    pos, focal, up = (np.asarray(x) for x in camera_view(V, F=F))
    d = (pos - focal) / np.linalg.norm(pos - focal)
    lo, hi = UV.min(0), UV.max(0)
    ext = np.maximum(hi - lo, 1e-12)
    fig.update_layout(
        height=height, margin=dict(l=10, r=10, t=50, b=10), title_text=title, meta={"linked_hover": True},
        scene=dict(xaxis=hidden, yaxis=hidden, zaxis=hidden, aspectmode="data",
                   camera=dict(eye=dict(zip("xyz", map(float, 1.6 * d))), up=dict(zip("xyz", map(float, up))),
                               projection=dict(type="orthographic"))),
        scene2=dict(xaxis=hidden, yaxis=hidden, zaxis=dict(range=[-1, 1], **hidden), aspectmode="manual",
                    aspectratio=dict(x=float(ext[0] / ext.max()), y=float(ext[1] / ext.max()), z=0.01),
                    camera=dict(eye=dict(x=0, y=0, z=2.0), up=dict(x=0, y=1, z=0),
                                projection=dict(type="orthographic")), dragmode="pan"))
    return fig


def show_plotly(fig, *, include_plotlyjs=True):
    """Display a plotly figure as self-contained HTML (plotly.js embedded: offline, and in the static book).

    ``pio.renderers.default = "notebook_connected"`` would load plotly.js from
    a CDN, which a machine without internet (and the book's offline check)
    cannot reach; embedding it costs about 4.5 MB in the notebook's output.
    Returns the IPython ``HTML`` object (displayed when IPython is running).
    """
    meta = fig.layout.meta if isinstance(fig.layout.meta, dict) else {}
    html = fig.to_html(include_plotlyjs=include_plotlyjs, full_html=False, auto_play=False,
                       config={"displaylogo": False, "responsive": True},
                       post_script=LINKED_HOVER_JS if meta.get("linked_hover") else None)
    try:
        from IPython.display import HTML, display
    except ImportError:  # pragma: no cover - no IPython
        return html
    obj = HTML(html)
    display(obj)
    return obj
