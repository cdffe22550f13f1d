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
