"""Figures: UV layouts (flips in red), surface heatmaps, checkerboard transfers.

Everything renders without a display: matplotlib with the Agg backend when no
display is present, pyvista off screen. 3D surface images come from pyvista;
they are returned as RGB arrays so they can be placed in matplotlib figures.
"""
from __future__ import annotations

import os

import numpy as np

__all__ = [
    "checkerboard_texture", "plot_uv_layout", "render_surface", "render_checkerboard",
    "plot_checkerboard_transfer", "plot_face_heatmap", "plot_trace",
    "save_uv_layout", "save_checkerboard_transfer", "plot_alignment_curves", "plot_routes", "plot_repair", "ROUTE_COLORS",
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
                   window_size=(600, 600), view=None, scalar_bar=None):
    """Render a surface off screen with pyvista; returns an RGB image array.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    scalars : (m,) float array, optional
        Per-face values for a heatmap.
    uv : (p,2) float array, optional
        Texture coordinates; with ``texture`` renders a textured surface.
    FUV : (m,3) int array, optional
        Per-corner UV indices (default ``F``).
    texture : (h,w,3) uint8 array, optional
    view : tuple, optional
        Camera position as pyvista accepts it (default: isometric).

    Returns
    -------
    img : (h,w,3) uint8 array
    """
    import pyvista as pv

    pv.OFF_SCREEN = True
    F = np.asarray(F)
    if uv is not None:
        FUV = F if FUV is None else np.asarray(FUV)
        Vx = np.asarray(V, float)[F.reshape(-1)]
        mesh = _polydata(Vx, np.arange(3 * len(F)).reshape(-1, 3))
        mesh.active_texture_coordinates = np.asarray(uv, float)[FUV.reshape(-1)]
    else:
        mesh = _polydata(V, F)
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    pl.set_background("white")
    if uv is not None:
        tex = pv.Texture(checkerboard_texture() if texture is None else texture)
        pl.add_mesh(mesh, texture=tex, smooth_shading=False)
    elif scalars is not None:
        mesh.cell_data["value"] = np.asarray(scalars, float)
        pl.add_mesh(mesh, scalars="value", cmap=cmap, clim=clim, show_scalar_bar=scalar_bar is not None,
                    scalar_bar_args={"title": scalar_bar} if scalar_bar else None)
    else:
        pl.add_mesh(mesh, color="lightsteelblue")
    if view is not None:
        pl.camera_position = view
    else:
        pl.view_isometric()
    img = pl.screenshot(return_img=True)
    pl.close()
    return np.asarray(img)


def render_checkerboard(V, F, UV, FUV=None, **kw):
    """The mesh textured with a checkerboard through ``UV`` (RGB image array)."""
    return render_surface(V, F, uv=UV, FUV=FUV, **kw)


def plot_checkerboard_transfer(V, F, UV, FUV=None, *, title=None, view=None):
    """The paper's standard figure: checkerboard on the 3D mesh beside the UV layout.

    Returns
    -------
    fig : matplotlib Figure
    """
    plt = _mpl()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 5))
    a.imshow(render_checkerboard(V, F, UV, FUV, view=view))
    a.set_axis_off()
    a.set_title("checkerboard transfer", fontsize=9)
    plot_uv_layout(V, F, UV, ax=b, FUV=FUV)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_face_heatmap(V, F, values, *, ax=None, title="", cmap="coolwarm", clim=None, view=None, label=None):
    """A per-face scalar (e.g. det J or conformal distortion) on the surface."""
    plt = _mpl()
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 5))
    ax.imshow(render_surface(V, F, scalars=values, cmap=cmap, clim=clim, view=view, scalar_bar=label))
    ax.set_axis_off()
    ax.set_title(title, fontsize=9)
    return ax


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
