"""Islands on a grid of cells, and where on a page a shape still fits.

The one rasteriser and the one free-spot search of the package: the packer
places islands on empty pages with them, and repair moves an island into the
free space of a layout with them. The raster only proposes places; whether a
place keeps the padding is always decided exactly on the float64 UVs.

Where a mask fits is decided two ways, with the same answer: an FFT correlation
of the page with the mask (:meth:`Page.free`, every spot at once), and, with numba
installed (:data:`SCAN`), a compiled scan of the page's free runs that stops at the
spot a placement rule wants (:meth:`Page.spot`; without numba it reads that spot
off :meth:`Page.free`).

Cells are indexed ``[row, col]`` = ``[v, u]``; a shape at ``cells`` cells per UV
unit covers cell ``(r, c)`` of its mask when it covers UV cell
``(lo[1] + r, lo[0] + c)``.
"""
from __future__ import annotations

import functools
import math

import numpy as np
from PIL import Image, ImageDraw
from scipy import fft

from neuraluv.lazy import HAS_NUMBA, jit

__all__ = ["rasterise", "disk", "dilate", "room", "Page", "SCAN"]

#: :meth:`Page.spot` scans the page's free runs with a numba kernel (when numba is installed; imported and
#: compiled on first use) instead of reading the spot off :meth:`Page.free`'s FFT correlation: the same
#: spot, found without correlating the whole page (packing real atlases: several times faster).
SCAN = HAS_NUMBA


def rasterise(rings, cells, *, lo=None, shape=None):
    """Cells covered by outline rings: the interior and every cell the outline crosses.

    Parameters
    ----------
    rings : list of ``(exterior (k,2), [interiors])``
        Polygons in UV units (:func:`~neuraluv.layout.overlap.outline_rings`); a
        polygon inside another's hole is kept when it comes later in the list
        (larger shapes first).
    cells : float
        Cells per UV unit.
    lo : (2,) float array, optional
        The UV cell ``(u, v)`` of mask cell ``(0, 0)`` (default: one cell below the shapes).
    shape : (int, int), optional
        Mask shape ``(rows, cols)`` (default: just large enough, one cell of margin).

    Returns
    -------
    mask : (h,w) bool array
    lo : (2,) float array

    Examples
    --------
    >>> sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]])
    >>> m, lo = rasterise([(sq, [])], 4)
    >>> m.shape, int(m.sum()), lo.tolist()
    ((7, 7), 25, [-1.0, -1.0])
    """
    pts = np.vstack([e for e, _ in rings]) if rings else np.zeros((1, 2))
    lo = np.floor(pts.min(0) * cells) - 1.0 if lo is None else np.asarray(lo, float)
    if shape is None:
        w, h = (np.ceil(pts.max(0) * cells - lo) + 2).astype(int)
    else:
        h, w = shape
    img = Image.new("1", (int(w), int(h)), 0)
    draw = ImageDraw.Draw(img)
    for ext, holes in rings:  # fill and outline: every cell the outline crosses is (about) marked
        draw.polygon((ext * cells - lo).ravel().tolist(), fill=1, outline=1)
        for hole in holes:
            draw.polygon((hole * cells - lo).ravel().tolist(), fill=0, outline=1)
    return np.array(img, bool), lo


def disk(r):
    """A disk of radius ``r`` cells as a ``(2r+1, 2r+1)`` bool array.

    Examples
    --------
    >>> disk(1).astype(int).tolist()
    [[0, 1, 0], [1, 1, 1], [0, 1, 0]]
    """
    y, x = np.mgrid[-r:r + 1, -r:r + 1]
    return x * x + y * y <= r * r


def dilate(mask, r, *, grow=True):
    """``mask`` grown by a disk of ``r`` cells (with ``grow``, padded by ``r`` on every side first).

    Exactly the binary dilation by :func:`disk` (``scipy.ndimage.binary_dilation(mask, disk(r))``),
    computed as the union of the disk's horizontal chords: each row is dilated by the chord's
    half-width with a running sum, then shifted by the chord's row offset — a few array
    operations per row offset instead of one per cell of the disk.

    Examples
    --------
    >>> dilate(np.ones((1, 1), bool), 1).astype(int).tolist()
    [[0, 1, 0], [1, 1, 1], [0, 1, 0]]
    """
    r = int(r)
    if r <= 0:
        return mask.copy()
    m = np.pad(mask, r) if grow else np.asarray(mask, bool)
    H, W = m.shape
    run = np.zeros((H, W + 2 * r + 1), np.int32)  # running sums over the rows, r zero cells beyond each end
    np.cumsum(m, axis=1, out=run[:, r + 1:W + r + 1])
    run[:, W + r + 1:] = run[:, W + r:W + r + 1]
    out = np.zeros((H, W), bool)
    rows = {}
    for dy in range(-r, r + 1):
        w = math.isqrt(r * r - dy * dy)  # the chord's half-width: |dx| <= w  <=>  dx² + dy² <= r²
        if w not in rows:
            rows[w] = run[:, r + w + 1:r + w + 1 + W] > run[:, r - w:r - w + W]
        if dy >= 0:
            out[dy:] |= rows[w][:H - dy]
        else:
            out[:H + dy] |= rows[w][-dy:]
    return out


def room(cells):
    """The largest chessboard distance from a true cell of ``cells`` to a false cell or the border (0: none).

    Examples
    --------
    >>> room(np.ones((5, 5), bool)), room(np.ones((5, 4), bool)), room(np.zeros((3, 3), bool))
    (3, 2, 0)
    """
    from scipy import ndimage

    if not cells.any():
        return 0
    return int(ndimage.distance_transform_cdt(np.pad(cells, 1), metric="chessboard").max())


class Page:
    """A page of cells, some taken, and where a mask still fits on it.

    ``free(mask)`` is one correlation of the page with the mask, computed by FFT:
    :math:`(O \\star D)(y, x) = \\sum_{i,j} O(y+i, x+j)\\,D(i, j)`, zero exactly where
    ``D`` placed with its cell ``(0, 0)`` at ``(y, x)`` covers no taken cell. The
    page's transform is kept until the next :meth:`add`.

    Parameters
    ----------
    shape : (int, int)

    Examples
    --------
    >>> p = Page((4, 4)); p.add(np.ones((2, 2), bool), 0, 0)
    >>> p.free(np.ones((2, 2), bool)).astype(int).tolist()
    [[0, 0, 1], [0, 0, 1], [1, 1, 1]]
    """

    def __init__(self, shape):
        self.shape = (int(shape[0]), int(shape[1]))
        # float32 transforms are exact enough (error well below 0.5) up to 1024² pages; larger ones use float64
        self.dtype = np.float32 if max(self.shape) <= 1024 else np.float64
        self.taken = np.zeros(self.shape, self.dtype)
        self._fshape = tuple(fft.next_fast_len(s, real=True) for s in self.shape)
        self._spec = None
        self._room = None  # the largest free square's half side (chessboard distance), kept until the next add
        self.empty = True
        self._runs = None  # Page.spot's runs of free (or taken) cells rightwards; rows from _stale on outdated
        self._stale = [0, self.shape[0]]

    def free(self, mask):
        """(H−h+1, W−w+1) bool: ``free[y, x]`` when ``mask`` at ``(y, x)`` covers no taken cell (empty if too large)."""
        h, w = mask.shape
        H, W = self.shape
        if h > H or w > W:
            return np.zeros((max(H - h + 1, 0), max(W - w + 1, 0)), bool)
        if self.empty:
            return np.ones((H - h + 1, W - w + 1), bool)
        if self._spec is None:
            self._spec = fft.rfft2(self.taken, self._fshape)
        spec = fft.rfft2(mask.astype(self.dtype), self._fshape)
        np.conjugate(spec, out=spec)
        spec *= self._spec
        hit = fft.irfft2(spec, self._fshape, overwrite_x=True)
        return hit[:H - h + 1, :W - w + 1] < 0.5

    def room(self):
        """The half side ``d`` of the largest square of free cells, ``2d - 1`` cells (chessboard distance).

        A mask whose :func:`room` is larger fits nowhere on the page (a necessary condition, never a guess):
        a caller can skip its correlation.
        """
        if self._room is None:
            self._room = room(self.taken < 0.5)
        return self._room

    def add(self, mask, y, x):
        """Mark ``mask`` taken with its cell ``(0, 0)`` at ``(y, x)`` (clipped to the page)."""
        h, w = mask.shape
        y0, x0 = max(int(y), 0), max(int(x), 0)
        y1, x1 = min(int(y) + h, self.shape[0]), min(int(x) + w, self.shape[1])
        if y1 <= y0 or x1 <= x0:
            return
        sub = mask[y0 - int(y):y1 - int(y), x0 - int(x):x1 - int(x)]
        self.taken[y0:y1, x0:x1] = np.maximum(self.taken[y0:y1, x0:x1], sub)
        self._spec = self._room = None
        self._stale = [min(self._stale[0], y0), max(self._stale[1], y1)]
        self.empty = self.empty and not sub.any()

    def spot(self, mask, lo, hi, box=None):
        """The free spot of ``mask`` a placement rule takes, among cells ``lo`` to ``hi`` (both included).

        Parameters
        ----------
        mask : (h,w) bool array
        lo, hi : (int, int)
            The first and last ``(row, col)`` tried for the mask's cell ``(0, 0)``.
        box : (int, int), optional
            ``(W, H)``, the extent (columns, rows) of a layout from cell ``(0, 0)``: the spot that keeps
            ``max(W, H, col + w, row + h)`` smallest, then ``row + col``, then ``row`` (None: the first
            free spot in reading order).

        Returns
        -------
        ``(row, col)``, or None when no spot is free

        Examples
        --------
        >>> p = Page((6, 6)); p.add(np.ones((3, 2), bool), 0, 0)
        >>> p.spot(np.ones((2, 2), bool), (0, 0), (4, 4)), p.spot(np.ones((2, 2), bool), (0, 0), (4, 4), box=(2, 3))
        ((0, 2), (0, 2))
        """
        h, w = mask.shape
        (y0, x0), (y1, x1) = lo, hi
        y0, x0 = max(int(y0), 0), max(int(x0), 0)
        y1, x1 = min(int(y1), self.shape[0] - h), min(int(x1), self.shape[1] - w)
        if y1 < y0 or x1 < x0:
            return None
        if not SCAN:
            free = self.free(mask)[y0:y1 + 1, x0:x1 + 1]
            ys, xs = np.nonzero(free)
            if not len(ys):
                return None
            ys, xs = ys + y0, xs + x0
            if box is None:
                return int(ys[0]), int(xs[0])  # nonzero lists the spots in reading order
            side = np.maximum(np.maximum(box[0], xs + w), np.maximum(box[1], ys + h)).astype(np.int64)
            n = self.shape[0] + self.shape[1]
            j = int(np.argmin((side * 2 * n + ys + xs) * n + ys))
            return int(ys[j]), int(xs[j])
        if self._runs is None:
            self._runs = np.zeros(self.shape, np.int32)
        free_runs, scan = _kernels()
        if self._stale[1] > self._stale[0]:
            free_runs(self.taken, self._runs, self._stale[0], self._stale[1])
            self._stale = [self.shape[0], 0]
        b = (-1, -1) if box is None else box
        y, x = scan(self._runs, np.asarray(mask, bool), y0, y1, x0, x1, int(b[0]), int(b[1]), box is not None)
        return None if y < 0 else (int(y), int(x))


def _free_runs(taken, runs, r0, r1):
    """``runs[r, c]``: the free cells of row ``r`` from column ``c`` rightwards, or minus the taken ones when
    cell ``(r, c)`` is taken, for rows ``r0`` to ``r1 - 1``."""
    for r in range(r0, r1):
        run = 0
        for c in range(taken.shape[1] - 1, -1, -1):
            if taken[r, c] > 0.5:
                run = run - 1 if run < 0 else -1
            else:
                run = run + 1 if run > 0 else 1
            runs[r, c] = run


def _mask_runs(mask):
    """The runs of ``mask``'s rows, longest first (they miss soonest): ``(rows, starts, n)``, ``n`` cells each."""
    h, w = mask.shape
    rows, starts, n = np.empty(h * w, np.int64), np.empty(h * w, np.int64), np.empty(h * w, np.int64)
    k = 0
    for i in range(h):
        c = 0
        while c < w:
            if mask[i, c]:
                rows[k], starts[k] = i, c
                while c < w and mask[i, c]:
                    c += 1
                n[k] = c - starts[k]
                k += 1
            c += 1
    by = np.argsort(-n[:k], kind="mergesort")
    return rows[by], starts[by], n[by]


def _scan(runs, mask, y0, y1, x0, x1, W, H, box):
    """The spot :meth:`Page.spot` takes, or ``(-1, -1)``: the mask's row runs tested against the page's ``runs``;
    a run that misses skips every column up to the taken cells it met and past them."""
    h, w = mask.shape
    rows, starts, n = _mask_runs(mask)
    by, bx, bside, bsum = -1, -1, 1 << 62, 1 << 62
    for y in range(y0, y1 + 1):
        if box and (max(W, H, y + h, x0 + w), y + x0) >= (bside, bsum):
            break  # the key grows along rows and down columns: no later spot does better
        x = x0
        while x <= x1:
            side = max(W, H, y + h, x + w)
            if box and (side, y + x) >= (bside, bsum):
                break
            fits = True
            for s in range(rows.shape[0]):
                r = runs[y + rows[s], x + starts[s]]
                if r < n[s]:
                    fits, x = False, x + (r + 1 if r > 0 else -r)
                    break
            if fits:
                if not box:
                    return y, x
                by, bx, bside, bsum = y, x, side, y + x
                break
    return by, bx


@functools.cache
def _kernels():
    """``(_free_runs, _scan)`` compiled by numba (``_scan`` calling ``_mask_runs`` compiled), kept in numba's on-disk
    cache where one is writable."""
    global _mask_runs
    _mask_runs = jit(_mask_runs)  # the global _scan reads, compiled before _scan is
    return jit(_free_runs), jit(_scan)
