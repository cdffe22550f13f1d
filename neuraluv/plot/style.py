"""The conventions every figure shares: matplotlib set-up, camera, colours, checks.

numpy and matplotlib (colours only, imported when needed); no renderer. The
back-end modules (:mod:`~neuraluv.plot.mpl`, :mod:`~neuraluv.plot.surface`,
:mod:`~neuraluv.plot.interactive`) draw with what is defined here, so a scalar
has the same colours in every panel and every back-end.
"""
from __future__ import annotations

import os
import sys

import numpy as np

from neuraluv.metrics import face_dets

__all__ = [
    "pyplot", "checkerboard_texture", "checker_count", "checker_square", "camera_view", "CAMERA_VIEWS",
    "DETJ_CMAP", "DETJ_FOLD_COLOR", "DETJ_TICKS", "detj_norm", "detj_cmap", "scalar_colors", "face_detj", "frame_title",
]


def pyplot():
    """``matplotlib.pyplot``, on the Agg back-end when there is no display and no Jupyter kernel.

    Every figure of the package (and the benchmark runners' own figures) gets
    pyplot from here, so a headless run never tries to open a window.

    Returns
    -------
    module
        ``matplotlib.pyplot``.

    Examples
    --------
    >>> plt = pyplot()
    >>> fig, ax = plt.subplots(); plt.close(fig)
    """
    import matplotlib

    if not os.environ.get("DISPLAY") and "ipykernel" not in sys.modules:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


# --------------------------------------------------------------------------- checks


def checkerboard_texture(n_checks=16, res=None):
    """A procedural checkerboard image (the paper's diagnostic texture).

    Parameters
    ----------
    n_checks : int
        Checks along each side.
    res : int, optional
        Pixels along each side; default ``16 * n_checks`` clipped to [512, 2048].

    Returns
    -------
    (res, res, 3) uint8 array

    Examples
    --------
    >>> img = checkerboard_texture(4, res=8)
    >>> img.shape, img[0, :, 0].tolist()
    ((8, 8, 3), [40, 40, 235, 235, 40, 40, 235, 235])
    >>> checkerboard_texture(64).shape
    (1024, 1024, 3)
    """
    res = int(min(2048, max(512, 16 * n_checks))) if res is None else int(res)
    i = (np.arange(res) * n_checks // res) % 2
    board = (i[:, None] ^ i[None, :]).astype(bool)
    img = np.where(board[..., None], np.array([235, 235, 235]), np.array([40, 90, 160]))
    return img.astype(np.uint8)


def checker_square(UV, FUV):
    """The square the checkerboard is laid over: the bounding square of the finite UV corners.

    Parameters
    ----------
    UV : (p,2) float array
    FUV : (m,3) int array

    Returns
    -------
    lo : (2,) float array, its lower-left corner
    span : float, its side (1 when the corners do not span a square)

    Examples
    --------
    >>> lo, span = checker_square(np.array([[0.0, 1], [2, 1], [0, 1.5], [np.nan, 0]]), np.array([[0, 1, 2]]))
    >>> lo.tolist(), span
    ([0.0, 1.0], 2.0)
    """
    T = np.asarray(UV, float)[np.asarray(FUV).reshape(-1)]
    T = T[np.isfinite(T).all(axis=1)]
    if not len(T):
        return np.zeros(2), 1.0
    span = float(np.ptp(T, axis=0).max())
    return T.min(axis=0), (span if span > 0 else 1.0)


def checker_count(UV, F, FUV=None, *, edges_per_check=2.0, lo=8, hi=96):
    """Checks across the UV bounding square so that one check spans about ``edges_per_check`` mean UV edges.

    At least ``lo``: a coarse mesh or a packed atlas of a few hundred faces would
    otherwise get a board of 4×4 checks, too coarse to show any distortion.

    The checkerboard is laid over the layout's bounding square
    (:func:`checker_square`); a fixed count would make the checks sub-triangle
    on a fine mesh and invisible on a coarse one.

    Parameters
    ----------
    UV : (p,2) float array
    F : (m,3) int array
    FUV : (m,3) int array, optional
        Per-corner UV indices (default ``F``).
    edges_per_check : float
    lo, hi : int
        Bounds of the count.

    Returns
    -------
    int

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> from neuraluv.tutte import tutte
    >>> V, F = disk(4); coarse = checker_count(tutte(V, F), F)
    >>> V, F = disk(16); fine = checker_count(tutte(V, F), F)
    >>> lo_ok = 8 <= coarse < fine <= 96
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


# --------------------------------------------------------------------------- camera

_SIDES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1), "-z": (0, 0, -1)}
#: The named views :func:`camera_view` knows.
CAMERA_VIEWS = ("plane", "pca", "iso", *_SIDES)


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
        ``"plane"`` (default; also ``"pca"``): look along the normal of the
        best-fit plane (the smallest principal axis of the vertices), from the
        side the faces point to when ``F`` is given, with the world's y axis up
        (z when y is nearly along the view). ``"+x"``, ``"-x"``, ``"+y"``,
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


# --------------------------------------------------------------------------- colours

#: det J colour map: diverging around 1 (purple: compressed, green: stretched); det J ≤ 0 is red.
DETJ_CMAP = "PRGn"
#: The colour of folded faces (det J ≤ 0), in every det J figure.
DETJ_FOLD_COLOR = (0.9, 0.05, 0.05, 1.0)
#: The ticks of a det J colourbar (those up to its top).
DETJ_TICKS = (0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0)


def detj_norm(vmax=3.0):
    """A matplotlib norm for det J: 0 → 0, 1 → 0.5 (the colour map's centre), ``vmax`` → 1, ≤ 0 → under (red).

    Use with :func:`detj_cmap` (``DETJ_CMAP`` with red as its *under* colour).

    Parameters
    ----------
    vmax : float
        det J mapped to the top of the colour map (at least just above 1).

    Returns
    -------
    matplotlib.colors.TwoSlopeNorm
        Whose value is ``-inf`` (the *under* colour) for det J ≤ 0.

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
    """``DETJ_CMAP`` with :data:`DETJ_FOLD_COLOR` as its under colour (det J ≤ 0) and grey for NaN.

    Returns
    -------
    matplotlib.colors.Colormap

    Examples
    --------
    >>> cm = detj_cmap()
    >>> tuple(cm.get_under()) == DETJ_FOLD_COLOR, cm.get_bad().tolist()
    (True, [0.5, 0.5, 0.5, 1.0])
    """
    import matplotlib

    return matplotlib.colormaps[DETJ_CMAP].with_extremes(under=DETJ_FOLD_COLOR, bad=(0.5, 0.5, 0.5, 1.0))


def scalar_colors(values, cmap="viridis", clim=None, *, norm=None):
    """Per-face RGBA colours of a scalar and the ScalarMappable for its colourbar.

    ``cmap="detj"`` selects the det J convention (:func:`detj_norm`,
    :func:`detj_cmap`; ``clim=(_, vmax)`` sets its top). The same colours are
    given to the 3D render and the UV layout, so the two panels read alike.

    Parameters
    ----------
    values : (m,) float array
    cmap : str or matplotlib Colormap
        A matplotlib colour map, or ``"detj"``.
    clim : (lo, hi), optional
        Default: the finite values' range.
    norm : matplotlib Normalize, optional
        Wins over ``clim`` (not with ``"detj"``).

    Returns
    -------
    rgba : (m,4) float array
    mappable : matplotlib.cm.ScalarMappable

    Examples
    --------
    >>> rgba, sm = scalar_colors(np.array([0.0, 1.0, 2.0]), "gray")
    >>> rgba[:, 0].round(3).tolist()
    [0.0, 0.502, 1.0]
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
    """det J of every face at the chart's 3D scale (1: area preserved; ≤ 0: folded).

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional (default ``F``)

    Returns
    -------
    (m,) float array

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> face_detj(V, F, 2 * V[:, :2]).round(6).tolist(), face_detj(V, F, V[:, 1::-1]).round(6).tolist()
    ([4.0], [-1.0])
    """
    return face_dets(V, F, UV, FUV)


def frame_title(frame):
    """The title of one snapshot of a recorded solve (:class:`~neuraluv.solver.film.SolveFilm`'s frames).

    Examples
    --------
    >>> frame_title({"step": 40, "esd": 4.1234, "flips": 0})
    'it 40: E_SD 4.123, 0 flips'
    """
    return f"it {frame['step']}: E_SD {frame['esd']:.4g}, {frame['flips']} flips"
