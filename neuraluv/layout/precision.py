"""UVs as the files carry them: float32 values, without a flipped triangle."""
from __future__ import annotations

import numpy as np

from neuraluv.jacobian import signed_areas_2d

__all__ = ["float32_uvs", "uv_lattice"]


def float32_uvs(UV, F, rounds=24):
    """UVs rounded to float32 values (OBJ and GLB carry the same layout) without flipping a triangle.

    A triangle thinner than float32's resolution at its place in the texture (a
    needle the solver kept positive in float64) can round to zero or negative area.
    Each such triangle's corner opposite its longest edge is pushed away from that
    edge, 2^r float32 steps in round ``r``, until every triangle that was positive
    before rounding is positive after it (or ``rounds`` run out: the validation then
    reports the flip).

    Parameters
    ----------
    UV : (n,2) float array
    F : (m,3) int array

    Returns
    -------
    (n,2) float64 array of float32-representable values

    Examples
    --------
    >>> UV = np.array([[0.5, 0.5], [0.50001, 0.5], [0.500005, 0.5 + 1e-9]])
    >>> F = np.array([[0, 1, 2]])
    >>> bool(signed_areas_2d(UV.astype(np.float32).astype(float), F)[0] > 0)  # plain rounding: flat
    False
    >>> U = float32_uvs(UV, F); bool(signed_areas_2d(U, F)[0] > 0), bool((U == U.astype(np.float32)).all())
    (True, True)
    """
    UV = np.asarray(UV, float)
    F = np.asarray(F, np.int64)
    U = UV.astype(np.float32).astype(np.float64)
    if not len(F):
        return U
    keep = signed_areas_2d(UV, F) > 0
    for r in range(int(rounds)):
        bad = np.flatnonzero(keep & (signed_areas_2d(U, F) <= 0))
        if not len(bad):
            break
        for f in bad:
            P = U[F[f]]
            i = int(np.argmax(np.linalg.norm(P[[2, 0, 1]] - P[[1, 2, 0]], axis=1)))  # corner opposite the longest edge
            p, q = P[(i + 1) % 3], P[(i + 2) % 3]
            d = q - p
            n = np.array([-d[1], d[0]]) / max(np.linalg.norm(d), 1e-300)  # left of p->q: the positive side
            step = float(np.spacing(np.float32(np.abs(P[i]).max() or 1.0))) * 2.0 ** r
            U[F[f, i]] = (P[i] + n * step).astype(np.float32)
    return U


def uv_lattice(U, *, least=5e-5, most=1 / 200, slack=0.1, share=0.9):
    """The grid a set of UVs was quantized to (a glTF accessor of 8 to 16-bit integers, read through its
    ``KHR_texture_transform``): ``(origin, step)`` per axis, or None for values on no grid that coarse.

    Each axis' step starts as a small gap between its distinct values that recurs (gaps within 7% of it:
    values moved off the grid make gaps of their own, which recur less): the four that recur most, then the
    four least, each tried from its own lower value; then a line is fitted to the
    values on it against their step counts over a span widened fourfold at a time (a grid stored again on a
    finer one, gltf-transform's 12 bits in a 16-bit accessor, has gaps of 16 and 17 units: a step of 16.0037).
    The values are on the grid when ``share`` of them (counted as often as they occur) lie within ``slack``
    steps of ``origin + k · step``.
    Steps under ``least`` of the values' extent are not looked for (float32 data, or a grid finer than what
    rounds a projection's faces over), nor steps over ``most`` in UV units (an 8-bit grid over the unit square
    is 1/255: coarser ones are a layout's own regular spacing, a floor's grid of quads).

    Parameters
    ----------
    U : (k,2) float array

    Returns
    -------
    ((2,) float array, (2,) float array) or None

    Examples
    --------
    >>> g = np.random.default_rng(0).integers(0, 4096, size=(300, 2)) / 4095.0
    >>> origin, step = uv_lattice(0.25 + 0.5 * g)
    >>> bool(np.allclose(step, 0.5 / 4095))
    True
    >>> twice = np.rint(g * 4095 * 65535 / 4095) / 65535        # 12 bits stored in 16
    >>> bool(np.allclose(uv_lattice(twice)[1], 1 / 4095, rtol=1e-3))
    True
    >>> moved = g.copy(); moved[:10] += 0.3e-4                  # a few values moved off it
    >>> bool(np.allclose(uv_lattice(moved)[1], 1 / 4095))
    True
    >>> uv_lattice(np.random.default_rng(0).random((300, 2))) is None
    True
    """
    U = np.asarray(U, float)
    U = U[np.isfinite(U).all(1)]
    if len(U) < 16:
        return None
    origin, step = np.zeros(2), np.zeros(2)
    for a in range(2):
        v, count = np.unique(U[:, a], return_counts=True)
        ext = v[-1] - v[0] if len(v) else 0.0
        if len(v) < 8 or ext <= 0:
            return None
        gaps = np.diff(v)
        first = np.flatnonzero(gaps >= least * ext)
        first = first[np.argsort(gaps[first], kind="stable")]
        d = gaps[first]
        first, d = first[:256][d[:256] <= most], d[:256][d[:256] <= most]
        support = np.searchsorted(d, 1.07 * d, "right") - np.searchsorted(d, 0.93 * d, "left")  # d is sorted
        found = None
        tries = [j for j in np.lexsort((d, -support))[:4] if support[j] >= 3]  # the gaps that recur most, and
        tries += [j for j in np.flatnonzero(support >= 3)[:4] if j not in tries]  # the least that recur
        for j in tries:  # each from its own start
            found = _grid_through(v, count, v[first[j]], float(d[j]), ext, slack, share)
            if found is not None:
                break
        if found is None:
            return None
        origin[a], step[a] = found
    return origin, step


def _grid_through(v, count, o, h, ext, slack, share):
    """``(origin, step)`` of the grid through value ``o`` with about step ``h`` that ``share`` of the sorted values
    ``v`` (held ``count`` times each) lie on (within ``slack`` steps), fitted over a span around ``o`` widened
    fourfold at a time; or None."""
    span = 8 * h
    while True:
        sel = np.abs(v - o) <= span
        x = (v[sel] - o) / h
        k = np.rint(x)
        on = np.abs(x - k) <= slack
        if on.sum() < 2 or np.ptp(k[on]) < 1:
            return None
        h, o = np.polyfit(k[on], v[sel][on], 1)
        if h <= 0:
            return None
        if span >= ext:
            break
        span *= 4
    x = (v - o) / h
    r = np.abs(x - np.rint(x))
    if count[r <= slack].sum() < share * count.sum():
        return None
    tight = r <= slack / 2  # the last fit on the values nearest the grid: a value moved just off it weighs nothing
    return tuple(np.polyfit(np.rint(x[tight]), v[tight], 1)[::-1]) if tight.sum() >= 2 else (o, h)
