"""Figures render off screen and show what they claim (flipped faces red, colourbars, traces)."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from neuraluv import datasets, plot  # noqa: E402
from neuraluv.tutte import tutte  # noqa: E402


def test_uv_layout_marks_flipped_faces_red():
    V, F = datasets.disk(3)
    UV = tutte(V, F)
    UV[0] += [0.9, 0.0]  # fold the centre over
    ax = plot.plot_uv_layout(V, F, UV)
    from neuraluv.metrics import face_dets

    red = 0
    for c in ax.collections:
        fc = c.get_facecolor()
        fc = np.repeat(fc, len(c.get_paths()), axis=0) if len(fc) == 1 else fc
        red += int(((fc[:, 0] > 0.7) & (fc[:, 1] < 0.4) & (fc[:, 2] < 0.4)).sum())
    flips = int((face_dets(V, F, UV) <= 0).sum())
    assert red == flips > 0 and f"{flips} flipped" in ax.get_title()
    plt.close("all")


def test_trace_and_heatmap_and_routes_render(tmp_path):
    V, F = datasets.spherical_cap(4)
    UV = tutte(V, F)
    trace = {"iter": [1, 2, 3], "esd": [6.0, 5.0, 4.5], "min_det": [0.1, 0.2, 0.2], "rejected": [0, 1, 1]}
    axes = plot.plot_trace(trace)
    assert [a.get_title() for a in axes] == ["E_SD (true)", "min det J", "rejected steps (cumulative)"]
    assert len(axes[0].get_lines()[0].get_xdata()) == 3
    route = np.zeros(len(F), int)
    route[: len(F) // 2] = 1
    fig = plot.plot_routes(V, F, UV / np.ptp(UV) + 0.5, F, route, islands=1, flips=0)
    assert len(fig.axes) == 3  # surface, atlas, zoom on the fallback faces
    assert "50.0%" in fig.axes[0].get_title() or "49" in fig.axes[0].get_title()
    plot.save_uv_layout(tmp_path / "uv.png", V, F, UV)
    assert (tmp_path / "uv.png").stat().st_size > 1000
    plt.close("all")


@pytest.mark.parametrize("n", [4, 16])
def test_checkerboard_texture(n):
    img = plot.checkerboard_texture(n, res=64)
    assert img.shape == (64, 64, 3) and img.dtype == np.uint8
    row = img[0, :, 0]
    assert (np.diff(row.astype(int)) != 0).sum() == n - 1  # n checks along a row


def test_camera_looks_along_the_normal_of_a_planar_mesh():
    rng = np.random.default_rng(0)
    # a planar grid, tilted: its normal is n
    n = np.array([1.0, 2.0, 2.0]) / 3.0
    a = np.cross(n, [0.0, 0.0, 1.0]); a /= np.linalg.norm(a)
    b = np.cross(n, a)
    V2, F = datasets.disk(5)
    V = V2[:, :1] * a * 3 + V2[:, 1:2] * b + rng.normal(0, 1e-9, (len(V2), 1)) * n + [1.0, -2.0, 0.5]
    pos, focal, up = (np.asarray(x) for x in plot.camera_view(V, F=F))
    d = (pos - focal) / np.linalg.norm(pos - focal)
    assert abs(abs(d @ n) - 1) < 1e-6  # looks along the plane normal
    assert abs(up @ d) < 1e-9 and abs(np.linalg.norm(up) - 1) < 1e-9
    assert np.allclose(focal, V.mean(axis=0))
    # the front: the side the faces' normals point to
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]).sum(axis=0)
    assert d @ fn > 0
    pos2, _, _ = plot.camera_view(V, F=F[:, ::-1])
    assert (np.subtract(pos2, focal) @ d) < 0  # flipped winding: seen from the other side
    # side views look from that side
    pos, focal, up = (np.asarray(x) for x in plot.camera_view(V, "+x"))
    assert np.allclose((pos - focal) / np.linalg.norm(pos - focal), [1, 0, 0])
    with pytest.raises(ValueError):
        plot.camera_view(V, "sideways")


def test_detj_norm_centres_one_and_paints_folds_red():
    norm = plot.detj_norm(3.0)
    assert float(norm(1.0)) == 0.5 and float(norm(3.0)) == 1.0 and float(norm(0.5)) == 0.25
    rgba, sm = plot.scalar_colors(np.array([-1.0, 0.0, 1e-6, 1.0, 3.0, 10.0]), "detj")
    red = np.array(plot.DETJ_FOLD_COLOR)
    assert np.allclose(rgba[0], red) and np.allclose(rgba[1], red)  # det J <= 0: red
    assert not np.allclose(rgba[2], red)  # a tiny positive det J is not a fold
    import matplotlib

    centre = matplotlib.colormaps[plot.DETJ_CMAP](0.5)
    assert np.allclose(rgba[3], centre)  # 1 -> the diverging map's centre
    assert np.allclose(rgba[5], rgba[4])  # clipped at the top
    assert sm.norm is not None and sm.cmap.get_under()[0] > 0.8


def test_checker_count_follows_the_mesh_resolution():
    from neuraluv.tutte import tutte

    V, F = datasets.disk(4)
    coarse = plot.checker_count(tutte(V, F), F)
    V, F = datasets.disk(16)
    UV = tutte(V, F)
    fine = plot.checker_count(UV, F)
    assert 8 <= coarse < fine <= 96  # never the 4x4 board an atlas of a few hundred faces once got
    assert plot.checker_count(UV * 7.0, F) == fine  # scale-free


def test_scalar_figures_have_colourbars_and_matching_uv_colours():
    from neuraluv.tutte import tutte

    V, F = datasets.spherical_cap(5)
    UV = tutte(V, F)
    UV[0] += [0.3, 0.0]
    fig = plot.plot_surface_and_uv(V, F, UV)
    assert len(fig.axes) == 3  # surface, UV layout, colourbar
    det = plot.face_detj(V, F, UV)
    rgba, _ = plot.scalar_colors(det, "detj")
    uv_faces = fig.axes[1].collections[0].get_facecolor()
    assert np.allclose(uv_faces, rgba)  # the UV panel uses the same colours as the surface
    ax = plot.plot_face_heatmap(V, F, det, cmap="detj")
    assert len(ax.figure.axes) == 2  # the heatmap and its colourbar
    fig = plot.plot_checkerboard_transfer(V, F, UV)
    assert "checks across" in fig.axes[0].get_title()
    plt.close("all")


def test_solve_film_strip_and_slider():
    pytest.importorskip("torch")
    from neuraluv.solver.film import record_solve

    V, F = datasets.spherical_cap(4)
    res, film = record_solve(V, F, "test", device="cpu")
    steps = film.steps
    assert steps[0] == 0 and steps == sorted(steps) and film.frames[-1]["event"] == "end"
    assert film.frames[-1]["esd"] == pytest.approx(res.metrics["esd"], rel=1e-6)
    fig = plot.solve_filmstrip(film, n=4)
    assert len(fig.axes) == 5 and fig.axes[0].get_title().startswith("it 0:")
    plt.close("all")
    go = pytest.importorskip("plotly.graph_objects")
    pf = plot.plotly_solve_slider(film, max_frames=5)
    assert isinstance(pf, go.Figure) and len(pf.frames) == len(pf.layout.sliders[0].steps) == min(5, len(steps))
    assert [s.label for s in pf.layout.sliders[0].steps][0] == "0"
    html = pf.to_html(include_plotlyjs=False, full_html=False)
    assert "plotly-graph-div" in html


def test_live_view_falls_back_to_a_static_figure(monkeypatch):
    pytest.importorskip("pyvista")
    import matplotlib.figure

    from neuraluv import plot
    from neuraluv.datasets import disk

    V, F = disk(n_rings=3)
    monkeypatch.setenv("PYVISTA_OFF_SCREEN", "true")  # as in CI and the book build: never a live widget
    fig = plot.live_view(V, F, V[:, :2], scalars=None)
    assert isinstance(fig, matplotlib.figure.Figure) and "static view" in fig.axes[0].get_title()
    with pytest.raises(ValueError, match="backend"):
        plot.live_view(V, F, backend="vtk")
    if not plot.trame_available():
        with pytest.raises(ImportError, match=r"neuraluv\[viewer\]"):
            plot.live_view(V, F, backend="trame")


# --------------------------------------------------------------------------- the package's shape


def test_import_plot_loads_no_renderer():
    import subprocess
    import sys

    code = ("import sys, neuraluv, neuraluv.plot; "
            "print(' '.join(m for m in ('torch', 'scipy', 'matplotlib', 'pyvista', 'plotly', 'vtk') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""  # drawing imports its back-end; importing the package loads numpy only


def test_package_reexports_every_public_name_of_its_modules():
    import importlib

    for name in ("style", "surface", "mpl", "interactive", "figures"):
        mod = importlib.import_module(f"neuraluv.plot.{name}")
        for attr in mod.__all__:
            if attr == "frame_title":  # a helper of the two film figures, not a figure
                continue
            assert getattr(plot, attr) is getattr(mod, attr), (name, attr)
            assert attr in plot.__all__, (name, attr)
    assert not [n for n in plot.__all__ if n.startswith("_")]


def test_no_caller_reaches_into_plot_privates():
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    private = re.compile(r"\bplot\._[a-z]|from neuraluv\.plot(\.\w+)? import [^\n]*\b_[a-z]")
    files = [p for d in ("neuraluv", "tests", "notebooks", "book", "data_scripts") for p in (root / d).rglob("*")
             if p.suffix in (".py", ".ipynb", ".md") and "plot" not in p.relative_to(root).parts[:2]]
    bad = [f"{p.relative_to(root)}:{i + 1}" for p in files
           for i, line in enumerate(p.read_text(encoding="utf-8", errors="replace").splitlines()) if private.search(line)]
    assert bad == []


def test_pyplot_is_matplotlibs_pyplot():
    assert plot.pyplot() is plt


# --------------------------------------------------------------------------- colours


def test_colour_map_endpoints():
    import matplotlib

    cm = matplotlib.colormaps[plot.DETJ_CMAP]
    rgba, sm = plot.scalar_colors(np.array([-5.0, 0.0, 1e-9, 1.0, 2.0, 2.0 + 1e-12]), "detj", (0, 2.0))
    assert np.allclose(rgba[:2], plot.DETJ_FOLD_COLOR)  # folded: red, however folded
    assert np.allclose(rgba[2], cm(0.0), atol=1e-6)  # just above 0: the map's bottom, not red
    assert np.allclose(rgba[3], cm(0.5)) and np.allclose(rgba[4], cm(1.0)) and np.allclose(rgba[5], cm(1.0))
    assert tuple(plot.detj_cmap().get_under()) == plot.DETJ_FOLD_COLOR
    nan = plot.scalar_colors(np.array([np.nan]), "detj")[0][0]
    assert np.allclose(nan, (0.5, 0.5, 0.5, 1.0))  # NaN is grey, not a fold
    # any other map: the values' range onto the map's ends, a constant without dividing by zero
    rgba, sm = plot.scalar_colors(np.array([2.0, 3.0, 4.0]), "viridis")
    v = matplotlib.colormaps["viridis"]
    assert np.allclose(rgba[0], v(0.0)) and np.allclose(rgba[2], v(1.0)) and sm.norm.vmin == 2.0
    rgba, _ = plot.scalar_colors(np.array([7.0, 7.0]), "viridis")
    assert np.isfinite(rgba).all()
    rgba, _ = plot.scalar_colors(np.array([0.0, 10.0]), "viridis", (0.0, 5.0))
    assert np.allclose(rgba[1], v(1.0))  # clipped at clim's top


def test_detj_colorbar_ticks_stop_at_its_top():
    fig, ax = plt.subplots()
    _, sm = plot.scalar_colors(np.ones(3), "detj", (0, 2.0))
    cb = plot.add_colorbar(ax, sm, "det J", detj=True)
    assert cb.get_ticks().tolist() == [0.0, 0.5, 1.0, 2.0] and cb.extend == "both"
    _, sm = plot.scalar_colors(np.arange(3.0), "magma")
    assert plot.add_colorbar(ax, sm, "value").extend == "neither"
    plt.close("all")


# --------------------------------------------------------------------------- domain figures


def _routed_cap():
    V, F = datasets.spherical_cap(4)
    UV = tutte(V, F)
    UV = (UV - UV.min(0)) / np.ptp(UV) * 0.9 + 0.05
    route = np.ones(len(F), int)
    route[: len(F) // 4] = 0
    route[-len(F) // 4:] = 2
    return V, F, UV, route


def test_plot_routes_takes_an_atlas_result_or_the_arrays():
    from types import SimpleNamespace

    V, F, UV, route = _routed_cap()
    res = SimpleNamespace(V=V, F=F, UV=UV, FUV=F, face_route=route, charts=[],
                          totals=lambda: {"islands": 7, "flips": 0})
    a = plot.plot_routes(res)
    b = plot.plot_routes(V, F, UV, F, route, islands=7, flips=0)
    titles = [[ax.get_title() for ax in f.axes] for f in (a, b)]
    assert titles[0] == titles[1] and len(a.axes) == 3 and titles[0][1] == "(b) atlas: 7 islands, 0 flips"
    assert plot.plot_routes(res, islands=3, zoom=False).axes[1].get_title() == "(b) atlas: 3 islands, 0 flips"
    # the atlas panel's faces carry the route colours
    fc = a.axes[1].collections[0].get_facecolor()
    assert np.allclose(fc[0], plot.ROUTE_COLORS["fallback"]) and np.allclose(fc[-1], plot.ROUTE_COLORS["exact"])
    with pytest.raises(TypeError, match="alone"):
        plot.plot_routes(res, F)
    with pytest.raises(TypeError, match="face_route"):
        plot.plot_routes(V, F, UV)
    plt.close("all")


def test_plot_density_colours_faces_by_density():
    V, F, UV, _ = _routed_cap()
    d = np.where(np.arange(len(F)) % 2, 1.25, 1.0)
    fig = plot.plot_density(V, F, UV, F, d, title="cap")
    rgba, _ = plot.scalar_colors(d, "coolwarm", (0.5, 1.5))
    assert np.allclose(fig.axes[1].collections[0].get_facecolor(), rgba)
    assert fig._suptitle.get_text() == "cap; density spread 25%"
    assert "texel density" in fig.axes[2].get_ylabel()
    d[:3] = 0.0  # faces of zero UV area: density 0, which once made the title "spread inf%" (and warned)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = plot.plot_density(V, F, UV, F, d, title="cap")
    assert fig._suptitle.get_text() == "cap; density spread 25% (3 faces of zero UV area left out)"
    plt.close("all")


def test_plot_repair_marks_the_changed_faces():
    from types import SimpleNamespace

    V, F = datasets.disk(4)
    UV = tutte(V, F)
    before = UV.copy()
    before[0] += [0.6, 0.0]  # a fold the repair removed
    changed = np.isin(F, [0]).any(axis=1)
    res = SimpleNamespace(V=V, F=F, UV=UV, FUV=F, UV_in=before, FUV_in=F, changed_faces=changed,
                          before=SimpleNamespace(validation={"flips": 3, "overlapping_pairs": 0}),
                          after=SimpleNamespace(validation={"flips": 0}))
    fig = plot.plot_repair(res, title="disk")
    assert len(fig.axes) == 3  # before, after, zoom on the changed faces
    assert fig.axes[0].get_title().startswith("(a) before: 3 flips")
    assert fig.axes[1].get_title() == f"(b) after: {int(changed.sum())} faces changed (orange), 0 flips"
    after = fig.axes[1].collections[0].get_facecolor()
    assert np.allclose(after[changed], [1.0, 0.6, 0.1, 1.0]) and not np.allclose(after[~changed][:, 0], 1.0)
    assert len(plot.plot_repair(res, zoom=False).axes) == 2
    x0, x1 = fig.axes[2].get_xlim()
    assert fig.axes[2].get_title().startswith("(c) the changed faces, zoom ×") and x1 - x0 < 0.5 * np.ptp(UV[:, 0])
    spread = np.zeros(len(F), bool)
    spread[[0, -1]] = True  # changed faces at two far ends of the layout: a "zoom" would show everything
    res.changed_faces = spread
    assert len(plot.plot_repair(res).axes) == 2
    plt.close("all")


def test_zoom_inset_magnifies_the_faces():
    V, F = datasets.disk(4)
    UV = tutte(V, F)
    ax = plot.plot_uv_layout(V, F, UV)
    ins = plot.add_zoom_inset(ax, V, F, UV, [0], context=1.0)
    (x0, x1), (y0, y1) = ins.get_xlim(), ins.get_ylim()
    tri = UV[F[0]]
    assert x0 <= tri[:, 0].min() and tri[:, 0].max() <= x1 and y0 <= tri[:, 1].min() and tri[:, 1].max() <= y1
    assert x1 - x0 < 0.5 * np.ptp(UV[:, 0]) and ins.get_title().startswith("zoom ×")
    assert plot.add_zoom_inset(ax, V, F, UV, []) is None
    plt.close("all")


def test_saved_figures_and_self_contained_plotly(tmp_path):
    V, F, UV, _ = _routed_cap()
    plot.save_checkerboard_transfer(tmp_path / "c.png", V, F, UV)
    assert (tmp_path / "c.png").read_bytes()[:4] == b"\x89PNG" and not plt.get_fignums()  # written and closed
    pytest.importorskip("plotly")
    pytest.importorskip("IPython")
    shown = plot.show_plotly(plot.plotly_linked_views(V, F, UV))
    html = getattr(shown, "data", shown)
    assert "plotly_hover" in html  # the linked-hover script rides along
    assert 'src="https://cdn.plot.ly' not in html and len(html) > 1_000_000  # plotly.js embedded


def test_surface_heatmap_colours_match_the_colour_bar():
    """det J heatmaps on the surface are unlit: a face shows exactly the colour its value has on the colour bar."""
    pytest.importorskip("pyvista")
    V, F = datasets.spherical_cap(4)  # curved: lighting would shade faces differently
    det = np.full(len(F), 2.0)
    rgba, _ = plot.scalar_colors(det, "detj", (0, 3))
    img = plot.render_surface(V, F, scalars=det, cmap="detj", clim=(0, 3), window_size=(200, 200))
    px = img.reshape(-1, 3).astype(int)
    surface = px[(np.abs(px - 255).sum(1) > 30)]  # not the white background
    want = np.round(rgba[0, :3] * 255).astype(int)
    assert len(surface) > 1000
    assert np.median(np.abs(surface - want).sum(1)) <= 6  # lit, the cap's rim would be far darker
