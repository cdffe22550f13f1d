"""The paper's packer: islands' bounding boxes on shelves, at one common scale.

The paper packs its charts "with an area-scaled shelf packer" (Sec. 4): every
chart keeps its own 3D scale (so texel density is uniform across charts), charts
are placed left to right on shelves sorted by height, and the whole layout is
scaled uniformly into ``[0,1]²``. Charts are only translated and uniformly
scaled, never mirrored, so orientation (det J > 0) is preserved.
"""
from __future__ import annotations

import numpy as np

from neuraluv.layout.pack.result import PackResult, uv_area

__all__ = ["shelf_pack"]


def _layout(sizes, gap, width):
    order = np.argsort(-sizes[:, 1], kind="stable")
    pos = np.zeros_like(sizes)
    x = y = shelf_h = 0.0
    used_w = 0.0
    for i in order:
        w, h = sizes[i]
        if x > 0 and x + w > width:
            y += shelf_h + gap
            x = shelf_h = 0.0
        pos[i] = (x, y)
        x += w + gap
        used_w = max(used_w, x - gap)
        shelf_h = max(shelf_h, h)
    return pos, used_w, y + shelf_h




def shelf_pack(uvs, faces=None, *, padding=2.0, resolution=1024, margin=None):
    """Pack charts (at a common scale) into the unit square with a shelf packer.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays
        Each chart's UVs in 3D units (e.g. :class:`~neuraluv.solver.ChartResult.uv`).
    faces : list of (m_i,3) int arrays, optional
        Chart faces, used only to report utilisation.
    padding : float
        Gap between charts, and between charts and the border, in texels.
    resolution : int or None
        Texture resolution the padding refers to. ``None`` packs with no gap.
    margin : float, optional
        Border margin in unit-square units; defaults to the padding.

    Returns
    -------
    PackResult (``packer="shelf"``)

    Examples
    --------
    >>> sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]])
    >>> res = shelf_pack([sq, 2 * sq], padding=4, resolution=64)
    >>> all(((u >= 0) & (u <= 1)).all() for u in res.uvs), res.padding_texels >= 4
    (True, True)
    """
    uvs = [np.asarray(u, float) for u in uvs]
    lo = np.array([u.min(0) for u in uvs])
    sizes = np.array([u.max(0) - u.min(0) for u in uvs])
    sizes = np.maximum(sizes, 1e-12 * max(sizes.max(), 1e-300))
    width = max(np.sqrt((sizes[:, 0] * sizes[:, 1]).sum()) * 1.15, sizes[:, 0].max())
    pad_uv = 0.0 if resolution is None else float(padding) / float(resolution)
    mg = pad_uv if margin is None else float(margin)
    if 2 * mg >= 0.5:
        raise ValueError("padding/margin too large for the resolution")
    gap = 0.0
    for _ in range(20):
        pos, W, H = _layout(sizes, gap, width)
        scale = (1.0 - 2 * mg) / max(W, H)
        need = pad_uv / scale
        if gap >= need * (1 - 1e-9):
            break
        gap = need * 1.01
    out = [((u - l) + p) * scale + mg for u, l, p in zip(uvs, lo, pos)]
    area = sum(uv_area(u, f) for u, f in zip(out, faces)) if faces is not None else float("nan")
    ptex = None
    if resolution is not None:
        ptex = float("inf") if len(uvs) == 1 else float(gap * scale * resolution)
    return PackResult(uvs=out, scale=float(scale), offsets=pos * scale + mg, utilisation=area, padding_texels=ptex,
                      packer="shelf")

