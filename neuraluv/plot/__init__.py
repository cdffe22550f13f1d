"""Figures: UV layouts (flips in red), surface heatmaps, checkerboard transfers, solve films, atlas routes.

Everything renders without a display: matplotlib with the Agg backend when no
display is present (:func:`pyplot`), pyvista off screen. 3D surface images come
from pyvista; they are returned as RGB arrays so they can be placed in
matplotlib figures.

=================  ==========================================================
``style``          the shared conventions: :func:`pyplot`, camera, det J
                   colours, scalar colours, checkerboard (numpy; matplotlib's
                   colours when called)
``surface``        pyvista: off-screen renders, :func:`live_view`
``mpl``            matplotlib figures: UV layouts, heatmaps, checkerboard
                   transfer, traces, alignment curves, film strip, saving
``interactive``    plotly: the solve slider, linked surface/UV views,
                   :func:`show_plotly`
``figures``        domain figures: atlas routes, texel density, UV repair
=================  ==========================================================

Every public name is re-exported here (``from neuraluv import plot;
plot.plot_uv_layout(...)``). Importing the package loads numpy only:
matplotlib, pyvista and plotly are imported by the functions that draw.

Conventions shared by every figure:

- the 3D camera looks onto the chart's best-fit plane (:func:`camera_view`,
  PCA of the vertices) unless a side is chosen;
- a scalar is drawn with the same colours on the surface and on the UV layout
  (:func:`scalar_colors`), with a colourbar (:func:`add_colorbar`);
- det J uses a diverging map centred on 1 (an isometry's area ratio) and red
  for det J ≤ 0 (:func:`detj_norm`, :data:`DETJ_CMAP`);
- the checkerboard's frequency follows the mesh (:func:`checker_count`: about
  four mean UV edge lengths per check).

The interactive film of a solve (:func:`plotly_solve_slider`) and the linked
surface/UV views (:func:`plotly_linked_views`: hover a face, it is outlined in
both) need plotly; :func:`show_plotly` embeds plotly.js in the output, so it
also works offline and in the static book.
"""
from __future__ import annotations

from neuraluv.plot.figures import ROUTE_COLORS, plot_density, plot_repair, plot_routes
from neuraluv.plot.interactive import LINKED_HOVER_JS, plotly_linked_views, plotly_solve_slider, show_plotly
from neuraluv.plot.mpl import (add_colorbar, add_zoom_inset, plot_alignment_curves, plot_checkerboard_transfer, plot_face_heatmap,
                               plot_surface_and_uv, plot_trace, plot_uv_layout, save_checkerboard_transfer, save_figure,
                               save_uv_layout, solve_filmstrip)
from neuraluv.plot.style import (CAMERA_VIEWS, DETJ_CMAP, DETJ_FOLD_COLOR, DETJ_TICKS, camera_view, checker_count,
                                 checker_square, checkerboard_texture, detj_cmap, detj_norm, face_detj, pyplot,
                                 scalar_colors)
from neuraluv.plot.surface import live_view, render_checkerboard, render_surface, trame_available

__all__ = [
    # style
    "pyplot", "camera_view", "CAMERA_VIEWS", "checker_count", "checker_square", "checkerboard_texture",
    "DETJ_CMAP", "DETJ_FOLD_COLOR", "DETJ_TICKS", "detj_norm", "detj_cmap", "scalar_colors", "face_detj",
    # surface (pyvista)
    "render_surface", "render_checkerboard", "live_view", "trame_available",
    # matplotlib
    "add_colorbar", "plot_uv_layout", "add_zoom_inset", "plot_checkerboard_transfer", "plot_face_heatmap", "plot_surface_and_uv",
    "plot_trace", "plot_alignment_curves", "solve_filmstrip", "save_figure", "save_uv_layout",
    "save_checkerboard_transfer",
    # plotly
    "plotly_solve_slider", "plotly_linked_views", "LINKED_HOVER_JS", "show_plotly",
    # domain figures
    "ROUTE_COLORS", "plot_routes", "plot_density", "plot_repair",
]
