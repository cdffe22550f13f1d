"""matplotlib figures: UV layouts (flips in red), heatmaps, checkerboard transfers, traces, films, saving.

matplotlib is imported inside the functions (through
:func:`~neuraluv.plot.style.pyplot`: Agg when there is no display); 3D panels
are pyvista renders (:mod:`~neuraluv.plot.surface`) shown as images.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from neuraluv.io import atomic_write
from neuraluv.jacobian import signed_areas_2d
from neuraluv.metrics import face_dets
from neuraluv.plot.style import (DETJ_TICKS, checker_count, checker_square, checkerboard_texture, face_detj,
                                 frame_title, pyplot, scalar_colors)
from neuraluv.plot.surface import render_checkerboard, render_surface

__all__ = [
    "add_colorbar", "plot_uv_layout", "add_zoom_inset", "plot_checkerboard_transfer", "plot_face_heatmap", "plot_surface_and_uv",
    "plot_trace", "plot_alignment_curves", "solve_filmstrip", "save_figure", "save_uv_layout",
    "save_checkerboard_transfer",
]

#: The colourbar label of det J panels.
_DETJ_LABEL = "det J  (red: ≤ 0, folded)"


def add_colorbar(ax, mappable, label, *, detj=False):
    """A colourbar beside ``ax`` in the package's style (small ticks; det J: fixed ticks, red *under* end).

    Parameters
    ----------
    ax : matplotlib Axes
    mappable : matplotlib.cm.ScalarMappable
        From :func:`~neuraluv.plot.style.scalar_colors`.
    label : str
    detj : bool
        ``mappable`` uses the det J convention (``scalar_colors(..., "detj")``).

    Returns
    -------
    matplotlib.colorbar.Colorbar

    Examples
    --------
    >>> plt = pyplot()
    >>> fig, ax = plt.subplots()
    >>> _, sm = scalar_colors(np.array([0.5, 1.0, 2.0]), "detj")
    >>> cb = add_colorbar(ax, sm, "det J", detj=True)
    >>> len(fig.axes), cb.get_ticks().tolist()
    (2, [0.0, 0.5, 1.0, 2.0, 3.0])
    >>> plt.close(fig)
    """
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
        cb.set_ticks([t for t in DETJ_TICKS if t <= vmax])
    return cb


def _flipped(V, F, UV, FUV):
    """Flipped faces: det J ≤ 0 with 3D positions, reversed UV winding without."""
    if V is None:
        return signed_areas_2d(UV, FUV) <= 0
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
    title : str, optional
        Default: the count of flipped faces (red when there are any).
    FUV : (m,3) int array, optional
        Per-corner UV indices (default ``F``).
    face_colors : (m,) or (m,3|4) array, optional
        Colours instead of the default light grey.
    show_box : bool
        Outline the unit square.

    Returns
    -------
    ax : matplotlib Axes

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2], [0, 2, 1]])
    >>> ax = plot_uv_layout(V, F, V[:, :2])
    >>> ax.get_title()
    'UV layout: 1 flipped / 2 faces'
    >>> pyplot().close(ax.figure)
    """
    plt = pyplot()
    from matplotlib.collections import PolyCollection

    F = np.asarray(F)
    UV = np.asarray(UV, float)
    FUV = F if FUV is None else np.asarray(FUV)
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 5))
    flipped = _flipped(V, F, UV, FUV)
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


def add_zoom_inset(ax, V, F, UV, faces, *, FUV=None, face_colors=None, bounds=(0.6, 0.6, 0.38, 0.38), context=2.0,
                   title="zoom", into=None, min_window=0.02):
    """An inset on ``ax`` that zooms on ``faces`` of the layout drawn there, with the zoomed box marked on ``ax``.

    Parameters
    ----------
    ax : matplotlib Axes
        The panel with the whole layout (e.g. from :func:`plot_uv_layout`).
    V, F, UV, FUV, face_colors : as in :func:`plot_uv_layout`
    faces : (k,) int or bool array
        The faces to zoom on (flipped faces, changed faces).
    bounds : (x0, y0, w, h)
        The inset's place in ``ax``'s axes coordinates.
    context : float
        The zoomed square is ``1 + context`` times the faces' bounding box.
    min_window : float
        ... but at least this fraction of the layout's size (lower it to zoom on a sliver).
    title : str
        The inset's title; the zoom factor is appended.
    into : matplotlib Axes, optional
        Draw the zoom in this panel (e.g. the one below ``ax``) instead of an inset; the box on ``ax`` is
        joined to it the same way.

    Returns
    -------
    inset : matplotlib Axes (``into`` when given), or None when ``faces`` is empty

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]); F = np.array([[0, 1, 2], [1, 3, 2]])
    >>> ax = plot_uv_layout(V, F, V[:, :2]); ins = add_zoom_inset(ax, V, F, V[:, :2], [0], context=0.0)
    >>> np.allclose(ins.get_xlim(), (0, 1)), ins.get_title()
    (True, 'zoom ×1')
    >>> pyplot().close(ax.figure)
    """
    UV = np.asarray(UV, float)
    FUV = np.asarray(F if FUV is None else FUV)
    faces = np.asarray(faces)
    faces = np.flatnonzero(faces) if faces.dtype == bool else faces.astype(int)
    if not len(faces):
        return None
    pts = UV[FUV[faces]].reshape(-1, 2)
    lo, hi = pts.min(0), pts.max(0)
    full = UV[FUV].reshape(-1, 2)
    size = float((full.max(0) - full.min(0)).max())
    c, h = 0.5 * (lo + hi), 0.5 * max((1 + context) * float((hi - lo).max()), min_window * size)
    ins = ax.inset_axes(bounds) if into is None else into
    plot_uv_layout(V, F, UV, ax=ins, FUV=FUV, face_colors=face_colors, show_box=False)
    ins.set_xlim(c[0] - h, c[0] + h)
    ins.set_ylim(c[1] - h, c[1] + h)
    ins.set_title(f"{title} ×{size / (2 * h):.0f}".strip(), fontsize=8 if into is None else 9, color="black")
    for side in ins.spines.values():
        side.set_edgecolor("0.2")
        side.set_linewidth(1.2)
    ax.indicate_inset_zoom(ins, edgecolor="0.2", alpha=0.9)
    return ins


def plot_checkerboard_transfer(V, F, UV, FUV=None, *, title=None, view="plane", n_checks="auto"):
    """The paper's standard figure: checkerboard on the 3D mesh beside the UV layout with the same checks.

    The checks are laid over the layout's bounding square, ``n_checks`` across
    (default :func:`~neuraluv.plot.style.checker_count`: about two mean UV
    edges per check), so the UV panel shows exactly the texture the surface
    carries; flipped faces are red in the UV panel.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional (default ``F``)
    title : str, optional
    view : camera (see :func:`~neuraluv.plot.surface.render_surface`)
    n_checks : int or ``"auto"``

    Returns
    -------
    fig : matplotlib Figure
    """
    plt = pyplot()
    F = np.asarray(F)
    FUV = F if FUV is None else np.asarray(FUV)
    UV = np.asarray(UV, float)
    n = checker_count(UV, F, FUV) if n_checks == "auto" else int(n_checks)
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 6))
    a.imshow(render_checkerboard(V, F, UV, FUV, view=view, n_checks=n))
    a.set_axis_off()
    a.set_title(f"checkerboard transfer ({n} checks across the layout)", fontsize=9)
    lo, span = checker_square(UV, FUV)
    b.imshow(checkerboard_texture(n), extent=(lo[0], lo[0] + span, lo[1], lo[1] + span), origin="lower", alpha=0.55,
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

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    values : (m,) float array
    ax : matplotlib Axes, optional
    cmap, clim : see :func:`~neuraluv.plot.style.scalar_colors`
        ``cmap="detj"`` uses the det J convention (diverging around 1, red for ≤ 0).
    view : camera (see :func:`~neuraluv.plot.surface.render_surface`)
    label : str, optional
        Colourbar label.

    Returns
    -------
    ax : matplotlib Axes
    """
    plt = pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 6))
    rgba, sm = scalar_colors(values, cmap, clim)
    ax.imshow(render_surface(V, F, face_colors=rgba, view=view, window_size=window_size))
    ax.set_axis_off()
    ax.set_title(title, fontsize=9)
    is_detj = isinstance(cmap, str) and cmap == "detj"
    add_colorbar(ax, sm, label or (_DETJ_LABEL if is_detj else "value"), detj=is_detj)
    return ax


def plot_surface_and_uv(V, F, UV, values=None, *, FUV=None, cmap="detj", clim=None, label=None, title=None,
                        view="plane", axes=None, window_size=(800, 800)):
    """A per-face scalar on the surface and on the UV layout in the same colours, with one colourbar.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    values : (m,) float array, optional
        Default: det J of the layout (:func:`~neuraluv.plot.style.face_detj`) with ``cmap="detj"``.
    FUV : (m,3) int array, optional (default ``F``)
    cmap, clim : see :func:`~neuraluv.plot.style.scalar_colors`
    label, title : str, optional
    view : camera (see :func:`~neuraluv.plot.surface.render_surface`)
    axes : two matplotlib Axes, optional

    Returns
    -------
    fig : matplotlib Figure
    """
    plt = pyplot()
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
    add_colorbar(axes[1], sm, label or (_DETJ_LABEL if is_detj else "value"), detj=is_detj)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def plot_trace(trace, axes=None, *, label=None):
    """Solver trace: E_SD, min det J and cumulative rejected steps per iteration.

    Parameters
    ----------
    trace : dict with ``"iter"``, ``"esd"``, ``"min_det"``, ``"rejected"`` (each (T,))
    axes : three matplotlib Axes, optional
    label : str, optional
        Legend entry (to overlay several traces on the same axes).

    Returns
    -------
    axes : three matplotlib Axes

    Examples
    --------
    >>> axes = plot_trace({"iter": [1, 2], "esd": [5.0, 4.5], "min_det": [0.1, 0.2], "rejected": [0, 1]})
    >>> [a.get_title() for a in axes]
    ['E_SD (true)', 'min det J', 'rejected steps (cumulative)']
    >>> pyplot().close(axes[0].figure)
    """
    plt = pyplot()
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


def plot_alignment_curves(curves, ax=None, *, title=None):
    """Alignment curves ``s_r`` against ``r`` (the NTK–LBO probes).

    Parameters
    ----------
    curves : dict label -> (R,) array
    ax : matplotlib Axes, optional
    title : str, optional

    Returns
    -------
    ax : matplotlib Axes

    Examples
    --------
    >>> ax = plot_alignment_curves({"lbo": [0.2, 0.5, 0.7], "xyz": [0.1, 0.2, 0.4]})
    >>> len(ax.get_lines()), [float(y) for y in ax.get_ylim()]
    (2, [0.0, 1.02])
    >>> pyplot().close(ax.figure)
    """
    plt = pyplot()
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


def solve_filmstrip(film, n=6, *, vmax=3.0, title=None):
    """A film strip of a recorded solve: the UV layout at ``n`` steps, faces coloured by det J.

    Parameters
    ----------
    film : :class:`neuraluv.solver.film.SolveFilm` (from :func:`neuraluv.solver.film.record_solve`)
    n : int
        Number of panels (first and last always included).
    vmax : float
        Top of the det J colour scale (1 is its centre, ≤ 0 red).
    title : str, optional

    Returns
    -------
    fig : matplotlib Figure
    """
    plt = pyplot()
    frames = film.pick(n)
    fig, axes = plt.subplots(1, len(frames), figsize=(2.9 * len(frames) + 0.8, 3.4), squeeze=False)
    axes = axes[0]
    allp = np.concatenate([f["uv"] for f in frames])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.03 * float((hi - lo).max())
    sm = None
    for ax, f in zip(axes, frames):
        rgba, sm = scalar_colors(f["det"], "detj", (0, vmax))
        plot_uv_layout(None, film.F, f["uv"], ax=ax, face_colors=rgba, show_box=False, title=frame_title(f))
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
    if sm is not None:
        add_colorbar(axes[-1], sm, "det J  (red: ≤ 0)", detj=True)
    fig.suptitle(title or f"{film.label}: the solve, {len(film.frames)} snapshots recorded", fontsize=10)
    fig.tight_layout()
    return fig


def save_figure(fig, path, *, dpi=110):
    """Write a figure as PNG, atomically, and close it.

    Parameters
    ----------
    fig : matplotlib Figure
    path : str or Path
    dpi : int

    Returns
    -------
    path : the path written

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.png"
    >>> fig, _ = pyplot().subplots()
    >>> save_figure(fig, p).read_bytes()[:4]
    b'\\x89PNG'
    """
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, dpi=dpi, format="png")
    pyplot().close(fig)
    return Path(path)


def save_uv_layout(path, V, F, UV, FUV=None):
    """Write the UV layout PNG (flipped faces in red; see :func:`plot_uv_layout`)."""
    fig, ax = pyplot().subplots(figsize=(6, 6))
    plot_uv_layout(V, F, UV, ax=ax, FUV=FUV)
    save_figure(fig, path)


def save_checkerboard_transfer(path, V, F, UV, FUV=None):
    """Write the checkerboard-transfer PNG (3D render beside the UV layout; see :func:`plot_checkerboard_transfer`)."""
    save_figure(plot_checkerboard_transfer(V, F, UV, FUV), path)
