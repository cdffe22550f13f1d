"""Islands on a grid of cells, and where on a page a shape still fits.

The one rasteriser and the one free-spot search of the package: the packer
places islands on empty pages with them, and repair moves an island into the
free space of a layout with them. The raster only proposes places; whether a
place keeps the padding is always decided exactly on the float64 UVs.

Cells are indexed ``[row, col]`` = ``[v, u]``; a shape at ``cells`` cells per UV
unit covers cell ``(r, c)`` of its mask when it covers UV cell
``(lo[1] + r, lo[0] + c)``.
"""
from __future__ import annotations

import math

import numpy as np
from PIL import Image, ImageDraw
from scipy import fft

__all__ = ["rasterise", "disk", "dilate", "Page"]


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
        self.empty = True

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
        hit = fft.irfft2(self._spec * np.conj(fft.rfft2(mask.astype(self.dtype), self._fshape)), self._fshape)
        return hit[:H - h + 1, :W - w + 1] < 0.5

    def add(self, mask, y, x):
        """Mark ``mask`` taken with its cell ``(0, 0)`` at ``(y, x)`` (clipped to the page)."""
        h, w = mask.shape
        y0, x0 = max(int(y), 0), max(int(x), 0)
        y1, x1 = min(int(y) + h, self.shape[0]), min(int(x) + w, self.shape[1])
        if y1 <= y0 or x1 <= x0:
            return
        sub = mask[y0 - int(y):y1 - int(y), x0 - int(x):x1 - int(x)]
        self.taken[y0:y1, x0:x1] = np.maximum(self.taken[y0:y1, x0:x1], sub)
        self._spec = None
        self.empty = self.empty and not sub.any()
