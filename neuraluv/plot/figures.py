"""Domain figures: the atlas's routes (the paper's Figure 11), its texel density, a UV repair before / after.

They take plain arrays, or the result objects of :mod:`neuraluv.atlas` and
:mod:`neuraluv.repair` read by their attributes (this module imports neither:
they are below it in the layers).
"""
from __future__ import annotations

import numpy as np

from neuraluv.meshfix import normalize_unit_box
from neuraluv.plot.mpl import plot_surface_and_uv, plot_uv_layout
from neuraluv.plot.style import pyplot
from neuraluv.plot.surface import render_surface

__all__ = ["ROUTE_COLORS", "plot_routes", "plot_density", "plot_repair"]

#: The paper's Figure 11 (fig:amara_fallback_limitation) colours: neural charts blue, exact unfolds green, fallbacks red.
ROUTE_COLORS = {"neural": (0.16, 0.40, 0.80, 1.0), "exact": (0.20, 0.62, 0.35, 1.0), "fallback": (0.86, 0.18, 0.15, 1.0)}
_ROUTE_ORDER = ("fallback", "neural", "exact")  # face_route codes 0, 1, 2


def _route_arrays(V, F, UV, FUV, face_route, islands, flips):
    """``(V, F, UV, FUV, face_route, islands, flips)`` from the arrays, or from an atlas result given as ``V``."""
    if hasattr(V, "face_route"):
        if any(a is not None for a in (F, UV, FUV, face_route)):
            raise TypeError("plot_routes takes an atlas result alone, or the arrays V, F, UV, FUV, face_route")
        res = V
        t = res.totals() if hasattr(res, "totals") else {}
        return (res.V, res.F, res.UV, res.FUV, res.face_route, t.get("islands") if islands is None else islands,
                t.get("flips") if flips is None else flips)
    if any(a is None for a in (F, UV, FUV, face_route)):
        raise TypeError("plot_routes needs V, F, UV, FUV and face_route (or an atlas result)")
    return V, F, UV, FUV, face_route, islands, flips


def plot_routes(V, F=None, UV=None, FUV=None, face_route=None, *, islands=None, flips=None, zoom=True, view=None):
    """The paper's Figure 11: the surface and the packed atlas coloured by route.

    Call it with an atlas result, ``plot_routes(res)``, or with the arrays,
    ``plot_routes(V, F, UV, FUV, face_route)``.

    Parameters
    ----------
    V : (n,3) float array, or an :class:`~neuraluv.atlas.build.AtlasResult`
        A result (anything with ``V``, ``F``, ``UV``, ``FUV``, ``face_route``)
        gives all the arrays, and its ``totals()`` the island and flip counts.
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array
    face_route : (m,) int array
        1 neural, 2 exact (unfold, isometric start), 0 marked fallback.
    islands, flips : int, optional
        Counts printed in the atlas panel's title (default: the result's totals).
    zoom : bool
        Add a third panel zoomed on the fallback islands (when there are any).
    view : optional camera (see :func:`~neuraluv.plot.surface.render_surface`)

    Returns
    -------
    fig : matplotlib Figure

    Raises
    ------
    TypeError
        When neither a result nor all five arrays are given.
    """
    V, F, UV, FUV, face_route, islands, flips = _route_arrays(V, F, UV, FUV, face_route, islands, flips)
    plt = pyplot()
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    UV = np.asarray(UV, float)
    FUV = np.asarray(FUV)
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


def plot_density(V, F, UV, FUV, density, *, title=None, view="plane", axes=None):
    """The texel-density figure of a layout: each face coloured by its island's density over the median island.

    White is the median density; blue islands get fewer texels per unit length
    (blurrier), red ones more. One texel density (``build_atlas``) is white
    everywhere; xatlas's own atlas is not.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array
    density : (m,) float array
        Each face's island density over the median island's, e.g.
        :func:`neuraluv.atlas.face_texel_density` ``(V, F, UV, FUV)``.
    title : str, optional
        Followed by the density spread (largest over smallest, minus 1) over the faces with a finite, positive
        density (:func:`neuraluv.layout.facts.density_spread`, the number :func:`~neuraluv.layout.validate_layout`
        reports); faces of zero UV area (density 0) are counted in the title and left out, never an "inf%".
    view : camera (see :func:`~neuraluv.plot.surface.render_surface`)
    axes : two matplotlib Axes, optional

    Returns
    -------
    fig : matplotlib Figure
    """
    from neuraluv.layout.facts import density_spread  # here: the layout package loads scipy

    d = np.asarray(density, float)
    spread = density_spread(d)  # over the finite, positive densities: validate_layout's number
    zero = int((np.isfinite(d) & (d <= 0)).sum())
    text = "density spread " + ("n/a" if spread is None else f"{100 * spread:.3g}%")
    if zero:
        text += f" ({zero} faces of zero UV area left out)"
    return plot_surface_and_uv(V, F, UV, d, FUV=FUV, cmap="coolwarm", clim=(0.5, 1.5), view=view, axes=axes,
                               label="texel density / median island", title=(title + "; " if title else "") + text)


def _zoom_window(UV, FUV, faces):
    """``(magnification, ((x0, x1), (y0, y1)))``: a square window around ``faces`` (bool mask) with a 20% margin,
    and how many times smaller it is than the whole layout (0 without faces).

    Examples
    --------
    >>> UV = np.array([[0.0, 0], [1, 0], [0, 1], [0.1, 0.1]]); FUV = np.array([[0, 1, 2], [0, 3, 2]])
    >>> _zoom_window(UV, FUV, np.array([False, False]))[0]
    0.0
    >>> round(_zoom_window(UV, FUV, np.array([True, False]))[0], 3)   # the faces span the layout: no zoom
    0.833
    """
    faces = np.asarray(faces, bool)
    if not faces.any():
        return 0.0, None
    UV = np.asarray(UV, float)
    pts = UV[np.asarray(FUV)[faces]].reshape(-1, 2)
    allp = UV[np.asarray(FUV)].reshape(-1, 2)
    size = float((allp.max(0) - allp.min(0)).max())
    lo, hi = pts.min(0), pts.max(0)
    c, h = 0.5 * (lo + hi), 0.6 * max(float((hi - lo).max()), 0.02 * size)
    return size / (2 * h), ((c[0] - h, c[0] + h), (c[1] - h, c[1] + h))


def plot_repair(res, *, title=None, zoom=True):
    """Before / after of a UV repair: flipped faces red, faces the repair changed orange.

    Parameters
    ----------
    res : :class:`~neuraluv.repair.repair.RepairResult`
    title : str, optional
    zoom : bool
        Add a panel zoomed on the changed faces, boxed on the "after" panel, when their window magnifies the
        layout at least twice (changed faces spread over the whole atlas get no "zoom" panel).

    Returns
    -------
    fig : matplotlib Figure
    """
    plt = pyplot()
    F = np.asarray(res.F)
    Vn = normalize_unit_box(res.V)[0]
    UV0, FUV0 = res.UV_in, res.FUV_in
    ch = np.asarray(res.changed_faces)
    grey = np.array([0.85, 0.87, 0.9, 1.0])
    orange = np.array([1.0, 0.6, 0.1, 1.0])
    factor, window = _zoom_window(res.UV, res.FUV, ch)
    ncol = 3 if (zoom and factor >= 2) else 2  # a "zoom" panel only when it magnifies at least twice
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
                       title=f"(c) the changed faces, zoom ×{factor:.0f}")
        (x0, x1), (y0, y1) = window
        axes[2].set_xlim(x0, x1)
        axes[2].set_ylim(y0, y1)
        axes[1].indicate_inset_zoom(axes[2], edgecolor="0.2")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig
