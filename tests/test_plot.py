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
    assert 4 <= coarse < fine <= 96
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
    if not plot._trame_available():
        with pytest.raises(ImportError, match=r"neuraluv\[viewer\]"):
            plot.live_view(V, F, backend="trame")
