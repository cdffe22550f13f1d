"""Interactive figures with plotly: the solve film with an iteration slider, linked surface/UV views.

plotly is imported inside the functions. :func:`show_plotly` embeds plotly.js
in the output, so the figures also work offline and in the static book.
"""
from __future__ import annotations

import numpy as np

from neuraluv.plot.style import DETJ_CMAP, DETJ_FOLD_COLOR, DETJ_TICKS, camera_view, detj_norm, face_detj, frame_title

__all__ = ["plotly_solve_slider", "plotly_linked_views", "LINKED_HOVER_JS", "show_plotly"]


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
    ticks = [t for t in DETJ_TICKS if t <= vmax]
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
        Add the 3D surface (camera: :func:`~neuraluv.plot.style.camera_view`), recoloured per frame.

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
                           traces=list(range(cols)), layout=dict(title_text=f"{film.label}: " + frame_title(f)))
                  for nm, f in zip(names, frames)]
    anim = dict(mode="immediate", frame=dict(duration=0, redraw=True), transition=dict(duration=0))
    slider = dict(active=0, pad=dict(t=10, b=6), currentvalue=dict(prefix="iteration ", font=dict(size=13)),
                  steps=[dict(label=nm, value=nm, method="animate", args=[[nm], anim]) for nm in names])
    play = dict(type="buttons", showactive=False, x=0.0, y=0.0, xanchor="right", yanchor="top", pad=dict(t=40, r=10),
                buttons=[dict(label="▶ play", method="animate",
                              args=[None, dict(mode="immediate", fromcurrent=True, frame=dict(duration=350, redraw=True),
                                               transition=dict(duration=0))])])
    fig.update_layout(title_text=f"{film.label}: " + frame_title(f0), height=height, sliders=[slider],
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

    Parameters
    ----------
    fig : plotly.graph_objects.Figure
        A figure marked ``layout.meta["linked_hover"]`` (:func:`plotly_linked_views`)
        gets :data:`LINKED_HOVER_JS`.
    include_plotlyjs : bool or str
        Passed to ``fig.to_html`` (``True``: embedded).

    Returns
    -------
    IPython.display.HTML
        Displayed when IPython is running; without IPython, the HTML string.
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
