"""Distortion and validity metrics: one definition, used everywhere.

The solver's trace, the baselines, the benchmark tables, the CLI report and the
notebooks all call :func:`distortion_metrics` (or :func:`face_metrics`), so a
number means the same thing wherever it is printed.
"""
from __future__ import annotations

import numpy as np

from neuraluv.jacobian import jacobians, local_frames

__all__ = ["face_metrics", "distortion_metrics", "metrics_from_jacobians", "match_area", "is_valid", "corner_jacobians",
           "face_dets", "ESD_ISOMETRY"]

#: The smallest area-weighted symmetric Dirichlet energy, reached exactly at an isometry:
#: per face ``σ₁² + σ₂² + σ₁⁻² + σ₂⁻² ≥ 4``, and the weights sum to 1.
ESD_ISOMETRY = 4.0


def face_metrics(J):
    """Per-face distortion quantities of 2x2 Jacobians.

    Parameters
    ----------
    J : (m,2,2) float array

    Returns
    -------
    dict of (m,) float arrays
        ``det`` (det J), ``sd`` (‖J‖²_F + ‖J⁻¹‖²_F), ``conformal`` (σ_max/σ_min,
        1 when conformal), ``area`` (|log|det J||, 0 when area-preserving),
        ``smax`` and ``smin`` (singular values).

    Notes
    -----
    For 2x2 matrices ‖J⁻¹‖²_F = ‖J‖²_F / det(J)², so
    ``sd = ‖J‖²_F (1 + det⁻²)``, which is 4 at a rotation. A zero determinant
    gives ``inf``; a negative one (a flipped triangle) stays finite, as in the
    paper's greyed entries.

    Examples
    --------
    >>> m = face_metrics(np.array([[[2.0, 0.0], [0.0, 2.0]]]))
    >>> float(m["sd"][0]), float(m["conformal"][0]), round(float(m["area"][0]), 4)
    (8.5, 1.0, 1.3863)
    """
    J = np.asarray(J, float)
    a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
    det = a * d - b * c
    fro2 = a * a + b * b + c * c + d * d
    with np.errstate(divide="ignore", invalid="ignore"):
        sd = np.where(det != 0, fro2 * (1.0 + 1.0 / det**2), np.inf)
        disc = np.sqrt(np.maximum(fro2**2 - 4 * det**2, 0.0))
        smax = np.sqrt(0.5 * (fro2 + disc))
        smin = np.sqrt(np.maximum(0.5 * (fro2 - disc), 0.0))
        # smin from |det|/smax is more accurate than the subtraction above
        smin = np.where(smax > 0, np.abs(det) / smax, 0.0)
        conformal = np.where(smin > 0, smax / smin, np.inf)
        area = np.where(det != 0, np.abs(np.log(np.abs(det))), np.inf)
    bad = ~np.isfinite(J).all(axis=(1, 2))
    for arr in (sd, conformal, area):
        arr[bad] = np.inf
    det = np.where(bad, -np.inf, det)
    return {"det": det, "sd": sd, "conformal": conformal, "area": area, "smax": smax, "smin": smin}


def metrics_from_jacobians(J, A):
    """Summary metrics from per-face Jacobians ``J (m,2,2)`` and areas ``A (m,)``.

    See :func:`distortion_metrics` for the returned keys.
    """
    fm = face_metrics(J)
    A = np.asarray(A, float)
    det = fm["det"]
    flipped = ~(det > 0)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):  # no 3D area at all: NaN, not valid
        w = A / A.sum()
        out = {
            "esd": float(np.sum(w * fm["sd"])),
            "conformal": float(np.sum(w * fm["conformal"])),
            "area": float(np.sum(w * fm["area"])),
            "flips": int(flipped.sum()),
            "flip_percent": float(100.0 * flipped.mean()),
            "min_det": float(det.min()),
            "n_faces": int(len(det)),
        }
    out["valid"] = bool(out["flips"] == 0 and np.isfinite(out["esd"]) and out["min_det"] > 0)
    return out


def corner_jacobians(V, F, UV, FUV=None):
    """Per-face Jacobians and areas of a layout with per-vertex or per-corner UVs.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
    FUV : (m,3) int array, optional
        Per-corner indices into ``UV`` (an atlas with seams); ``None`` means
        ``UV`` is per vertex (``FUV = F``).

    Returns
    -------
    J : (m,2,2) float array
    A : (m,) float array

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> J, A = corner_jacobians(V, F, np.array([[9., 9], [0, 0], [1, 0], [0, 1]]), np.array([[1, 2, 3]]))
    >>> J[0].tolist(), A.tolist()
    ([[1.0, 0.0], [0.0, 1.0]], [0.5])
    """
    F = np.asarray(F, np.int64)
    if FUV is None:
        dC_inv, A = local_frames(V, F)
        return jacobians(UV, F, dC_inv), A
    # a per-corner layout: evaluate on an exploded copy (one vertex per corner)
    Fx = np.arange(3 * len(F)).reshape(-1, 3)
    dC_inv, A = local_frames(np.asarray(V, float)[F.reshape(-1)], Fx)
    return jacobians(np.asarray(UV, float)[np.asarray(FUV, np.int64).reshape(-1)], Fx, dC_inv), A


def face_dets(V, F, UV, FUV=None):
    """det J of every face (≤ 0: flipped or degenerate; ``-inf`` when not finite).

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> face_dets(V, F, V[:, [1, 0]]).tolist()
    [-1.0]
    """
    return face_metrics(corner_jacobians(V, F, UV, FUV)[0])["det"]


def distortion_metrics(V, F, UV, FUV=None):
    """Distortion and validity of a UV map of a triangle mesh.

    Parameters
    ----------
    V : (n,3) float array
        3D positions (the chart's own scale: E_SD is not scale invariant).
    F : (m,3) int array
    UV : (n,2) float array, or (p,2) with ``FUV``
    FUV : (m,3) int array, optional
        Per-corner indices into ``UV`` for layouts with seams.

    Returns
    -------
    dict
        ``esd``: area-weighted mean symmetric Dirichlet energy (4 at an isometry);
        ``conformal``: area-weighted mean of σ_max/σ_min (1 when conformal);
        ``area``: area-weighted mean of |log det J| (0 when area-preserving);
        ``flips``, ``flip_percent``: faces with det J ≤ 0 (count, percentage);
        ``min_det``: smallest det J; ``n_faces``; ``valid``: zero flips,
        finite E_SD and positive minimum determinant.

    Notes
    -----
    The paper's Eq. (1) with the area normalisation that makes an isometry score 4:

    .. math:: E_{SD} = \\frac{1}{\\sum_t A_t}\\sum_t A_t (\\|J_t\\|_F^2 + \\|J_t^{-1}\\|_F^2).

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> m = distortion_metrics(V, F, V[:, :2])
    >>> m["esd"], m["flips"], m["valid"]
    (4.0, 0, True)
    >>> distortion_metrics(V, F, V[:, [1, 0]])["flips"]  # mirrored
    1
    """
    return metrics_from_jacobians(*corner_jacobians(V, F, UV, FUV))


def match_area(V, F, UV):
    """Rescale ``UV`` uniformly so its total unsigned area equals the 3D area.

    Classical maps such as LSCM have an arbitrary global scale; E_SD and area
    distortion are only comparable after this normalisation.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    UV : (n,2) float array

    Returns
    -------
    UV : (n,2) float array

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
    >>> bool(np.allclose(match_area(V, F, 10 * V[:, :2]), V[:, :2]))
    True
    """
    UV = np.asarray(UV, float)
    dC_inv, A = local_frames(V, F)
    det = np.linalg.det(jacobians(UV, F, dC_inv))
    uv_area = float(np.sum(np.abs(det) * A))
    if not (uv_area > 0 and np.isfinite(uv_area)):
        return UV
    s = np.sqrt(A.sum() / uv_area)
    return UV * s


def is_valid(V, F, UV):
    """True when the map is finite with no flipped or degenerate triangle."""
    UV = np.asarray(UV, float)
    return bool(np.all(np.isfinite(UV)) and distortion_metrics(V, F, UV)["valid"])
