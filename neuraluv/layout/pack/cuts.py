"""Cutting large islands into parts that nest: a few large islands leave gaps no placement can fill."""
from __future__ import annotations

import numpy as np

from neuraluv.layout.pack import SPLIT_SHARE
from neuraluv.layout.pack.result import uv_area
from neuraluv.topology import bisect_faces

__all__ = ["granular_islands"]

def granular_islands(uvs, faces, max_share=SPLIT_SHARE):
    """Halve every island holding more than ``max_share`` of the total UV area, until none does.

    A few large islands leave gaps no packer can fill; smaller pieces nest. Each cut is
    straight, across the piece's length (:func:`~neuraluv.topology.bisect_faces` on the UVs),
    and each half is split into its edge-connected parts. The parts keep the island's UVs,
    so they are as flip-free and overlap-free as the island was: only seams are added.

    Parameters
    ----------
    uvs : list of (n_i,2) float arrays
        Islands at a common scale.
    faces : list of (m_i,3) int arrays
    max_share : float

    Returns
    -------
    list of (int, (k,) int array)
        ``(island, face indices)`` per piece, in island order; an island left whole is one piece.

    Examples
    --------
    >>> sq = np.array([[0., 0], [1, 0], [1, 1], [0, 1]]); q = np.array([[0, 1, 2], [0, 2, 3]])
    >>> [(i, f.tolist()) for i, f in granular_islands([sq, 0.1 * sq], [q, q], max_share=0.6)]
    [(0, [1]), (0, [0]), (1, [0, 1])]
    """
    areas = [uv_area(np.asarray(u, float), np.asarray(f)) for u, f in zip(uvs, faces)]
    limit = max_share * sum(areas)
    out = []
    for i, (u, f) in enumerate(zip(uvs, faces)):
        todo, f = [np.arange(len(f))], np.asarray(f)
        while todo:
            idx = todo.pop()
            if len(idx) > 1 and uv_area(u, f[idx]) > limit:
                parts = bisect_faces(u, f, idx)
                if len(parts) > 1:
                    todo += parts
                    continue
            out.append((i, idx))
    return out

