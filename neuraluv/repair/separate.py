"""Step 5 of repair: islands that overlap each other, leave the square or are new, moved into free space.

:func:`separate` moves the fewest islands (translated and turned by quarter turns, never
mirrored, scaled down only when they fit nowhere); under the ``texture`` purpose only new
islands are placed, in free space or else in an empty unit tile. :func:`repack_all` packs
every island afresh: the last resort, or a layout of its own (a lightmap in a new UV set).
"""
from __future__ import annotations

import time

import numpy as np

from neuraluv.layout.facts import layout_facts
from neuraluv.layout.overlap import triangles_union
from neuraluv.layout.pack import shelf_pack
from neuraluv.layout.place import FreeSpace
from neuraluv.layout.rigid import rotate_to_min_box

__all__ = ["SHRINK_SCALES", "input_islands", "separate", "repack_all"]

#: Uniform scales tried, in order, for an island that fits nowhere at its own size.
SHRINK_SCALES = (1.0, 0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3)


def input_islands(facts0, facts):
    """The island of ``facts0`` (the input's) holding most faces of each island of ``facts``; -1 for an island
    whose faces had no input island (a new chart).

    Examples
    --------
    >>> from neuraluv.layout.facts import layout_facts
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]); F = np.array([[0, 1, 2], [1, 3, 2]])
    >>> f0 = layout_facts(V, F, V[:, :2], F)
    >>> f1 = layout_facts(V, F, np.vstack([V[:, :2], V[:, :2]]), np.array([[0, 1, 2], [5, 7, 6]]))
    >>> f0.n_islands, input_islands(f0, f1).tolist()
    (1, [0, 0])
    """
    origin = -np.ones(facts.n_islands, np.int64)
    for j in range(facts.n_islands):
        lab = facts0.label[facts.island_faces(j)]
        lab = lab[lab >= 0]
        if len(lab):
            origin[j] = np.bincount(lab).argmax()
    return origin


def separate(Vn, F, UV, FUV, facts0, prefer, resolution, padding, *, only_new=False, deadline=None):
    """Move the fewest islands so that none overlaps another or leaves [0,1]²; new islands are placed too.

    ``only_new``: place the new islands in free space and move nothing else (the ``texture`` purpose).
    ``deadline`` (a ``time.perf_counter()`` value): once it has passed, the islands not yet placed are not
    searched for one by one; the layout is repacked (or, with ``only_new``, the new islands go to an empty
    tile) — a valid layout within the time budget, reported as ``repacked`` with the reason.

    ``Vn`` is the unit-box mesh. Returns ``UV, FUV, placements {input island (or -1 - k for new ones): action},
    repacked``.
    """
    f = layout_facts(Vn, F, UV, FUV, normalized=True, min_overlap=facts0.min_overlap)
    origin = input_islands(facts0, f)  # current islands -> input islands (-1: new)
    if only_new:  # the user's islands stay where they are: their overlaps do not matter here
        edges = set()
    else:
        ii, jj, _ = f.overlaps()
        li, lj = f.label[ii], f.label[jj]
        cross = li != lj
        edges = {(int(min(a, b)), int(max(a, b))) for a, b in zip(li[cross], lj[cross])}
    area = np.bincount(f.label[f.usable], weights=np.abs(np.nan_to_num(f.signed_uv[f.usable])), minlength=f.n_islands)
    must = set()
    for j in range(f.n_islands):
        rows = np.unique(f.FUV[f.island_faces(j)])
        if origin[j] < 0 or (not only_new and (UV[rows].min() < 0 or UV[rows].max() > 1)):
            must.add(j)
    edges = set() if only_new else {e for e in edges if e[0] not in must and e[1] not in must}
    movers = set(must)
    while edges:
        deg = {}
        for a, b in edges:
            deg[a] = deg.get(a, 0) + 1
            deg[b] = deg.get(b, 0) + 1
        pick = max(deg, key=lambda j: (deg[j], origin[j] in prefer, -area[j]))
        movers.add(pick)
        edges = {e for e in edges if pick not in e}
    if not movers:
        return UV, FUV, {}, False
    space = FreeSpace([triangles_union(UV, f.FUV[f.island_faces(j)])[0] for j in range(f.n_islands) if j not in movers],
                      resolution=resolution, padding=padding)
    UVo = UV.copy()
    FUVo = FUV.copy()
    placements = {}
    order = sorted(movers, key=lambda j: -area[j])
    failed = False
    why = "an island fits nowhere at any scale tried"
    for j in order:
        if deadline is not None and time.perf_counter() > deadline:
            failed, why = True, "the time budget ran out while moving islands one by one"
            break
        fj = f.island_faces(j)
        rows = np.unique(f.FUV[fj])
        T = np.searchsorted(rows, f.FUV[fj])
        pl = None
        for scales in ((1.0,), SHRINK_SCALES[1:]):
            pl = space.place(UVo[rows], T, scales=scales)
            if pl.uv is not None:
                break
        if pl is None or pl.uv is None:
            failed = True
            break
        UVo[rows] = pl.uv
        space.add(triangles_union(UVo, f.FUV[fj])[0])
        key = int(origin[j]) if origin[j] >= 0 else -1 - len([k for k in placements if k < 0])
        placements[key] = {"step": "moved", "quarter_turns": pl.turns, "scale": pl.scale,
                           "shift": [float(x) for x in pl.shift], "distance": pl.distance,
                           "why": ("new" if origin[j] < 0 else "outside [0,1]²" if j in must else "overlap")}
    if not failed:
        return UVo, FUVo, placements, False
    if only_new:  # the user's islands never move: the new ones go to a unit tile no island touches
        return (*_new_islands_in_empty_tile(UV, FUV, f, [j for j in order if origin[j] < 0], padding, resolution),
                False)
    # nothing else fits: repack every island at a common scale (reported)
    UVr, FUVo = repack_all(Vn, F, UV, FUVo, f, padding, resolution, tight=False)
    placements = {int(origin[j]) if origin[j] >= 0 else -1 - j: {"step": "repacked", "why": why}
                  for j in range(f.n_islands)}
    return UVr, FUVo, placements, True


def repack_all(Vn, F, UV, FUV, f, padding, resolution, *, tight):
    """Every island of ``f`` packed afresh (new rows appended; the old ones stay, unused): at a common scale as
    they are (shelf packer, the fallback of :func:`separate`), or, with ``tight``, each scaled to the
    layout's median texel density and packed by the tight packer (a layout of its own, e.g. a lightmap)."""
    from neuraluv.layout.pack import tight_pack

    uvs, tris, parts = [], [], []
    med = f.median_density or 1.0
    for j in range(f.n_islands):
        fj = f.island_faces(j)
        rows = np.unique(f.FUV[fj])
        d = f.density[j] if tight and np.isfinite(f.density[j]) else med
        uvs.append(rotate_to_min_box(UV[rows] * (med / d)))
        tris.append(np.searchsorted(rows, f.FUV[fj]))
        parts.append(fj)
    pk = tight_pack(uvs, tris, padding=padding, resolution=resolution) if tight else \
        shelf_pack(uvs, tris, padding=padding, resolution=resolution)
    FUVo = FUV.copy()
    base = len(UV)
    new_rows = []
    for fj, Tl, u in zip(parts, tris, pk.uvs):
        FUVo[fj] = Tl + base
        new_rows.append(u)
        base += len(u)
    return np.vstack([UV] + new_rows), FUVo


def _new_islands_in_empty_tile(UV, FUV, f, new, padding, resolution):
    """Shelf-pack the islands ``new`` (labels of ``f``) into the first unit tile ``[k, k+1] × [0, 1]`` to the
    right of every other island's UVs (placements keyed ``-1, -2, …``), moving no other row."""
    others = np.setdiff1d(np.arange(f.n_islands), new)
    used = np.unique(f.FUV[np.isin(f.label, others)]) if len(others) else np.zeros(0, np.int64)
    k = int(np.floor(UV[used, 0].max())) + 1 if len(used) else 0
    uvs, tris, rows_of = [], [], []
    for j in new:
        rows = np.unique(f.FUV[f.island_faces(j)])
        uvs.append(rotate_to_min_box(UV[rows]))
        tris.append(np.searchsorted(rows, f.FUV[f.island_faces(j)]))
        rows_of.append(rows)
    pk = shelf_pack(uvs, tris, padding=padding, resolution=resolution)
    UVo = UV.copy()
    placements = {}
    for n, (rows, u) in enumerate(zip(rows_of, pk.uvs)):
        UVo[rows] = u + [k, 0.0]
        placements[-1 - n] = {"step": "placed in an empty tile", "tile": [k, 0], "scale": float(pk.scale),
                              "why": "new; no free space at the layout's density among the user's islands"}
    return UVo, FUV, placements
