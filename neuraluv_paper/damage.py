"""Generated damage for a UV layout: the cases of ``neuraluv bench repair``.

Each function takes a valid layout ``(V, F, UV, FUV)`` and returns a damaged
copy of ``UV`` (and ``FUV`` where it changes) plus a dict saying what was done,
so a benchmark can check that repair restores validity and measure how much of
the layout it kept. All are seeded and deterministic.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from neuraluv.metrics import face_dets

__all__ = ["row_rings", "boundary_rows", "local_fold", "vertex_noise", "spike", "flip_patch", "mirror_island",
           "overlap_islands", "push_out", "nan_patch", "damage_left", "DAMAGE"]


def _adjacency(FUV, n_rows):
    T = np.asarray(FUV, np.int64)
    T = T[(T >= 0).all(1)]
    e = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    A = sp.coo_matrix((np.ones(2 * len(e)), (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])), shape=(n_rows, n_rows))
    return A.tocsr()


def row_rings(FUV, n_rows, center, rings):
    """Ring distance (0 = ``center``) of every row within ``rings`` rings; -1 beyond."""
    A = _adjacency(FUV, n_rows)
    dist = -np.ones(n_rows, np.int64)
    dist[center] = 0
    front = np.zeros(n_rows, bool)
    front[center] = True
    for r in range(1, rings + 1):
        nxt = (A @ front.astype(float) > 0) & (dist < 0)
        dist[nxt] = r
        front = nxt
    return dist


def boundary_rows(FUV, n_rows):
    """Rows on an edge used by exactly one face (the islands' boundaries)."""
    T = np.asarray(FUV, np.int64)
    e = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), 1)
    u, c = np.unique(e, axis=0, return_counts=True)
    out = np.zeros(n_rows, bool)
    out[u[c == 1].reshape(-1)] = True
    return out


def _edge_length(UV, FUV):
    P = UV[FUV]
    return float(np.median(np.linalg.norm(P[:, 1] - P[:, 0], axis=1)))


def _flipped(V, F, UV, FUV):
    """Faces of the damaged layout that are flipped or degenerate (``det J <= 0``)."""
    return int((~(face_dets(V, F, UV, FUV) > 0)).sum())


def _interior_center(FUV, n_rows, rings, rng, candidates=None):
    bd = boundary_rows(FUV, n_rows)
    A = _adjacency(FUV, n_rows)
    far = ~bd
    front = bd.copy()
    for _ in range(rings + 2):  # rows at least rings+2 rings from any boundary
        front = (A @ front.astype(float) > 0)
        far &= ~front
    used = np.zeros(n_rows, bool)
    used[np.unique(FUV)] = True
    pool = np.flatnonzero(far & used) if candidates is None else np.intersect1d(np.flatnonzero(far & used), candidates)
    if not len(pool):
        raise ValueError(f"no row is {rings + 2} rings away from the boundary: the island is too small for this fold")
    return int(rng.choice(pool))


def local_fold(V, F, UV, FUV, *, rings=3, strength=2.5, seed=0, rows=None):
    """Fold a few rings of the layout over themselves around a random interior row.

    Rows within ``rings`` rings of the centre are pushed in one direction by
    ``strength × rings`` median edge lengths, tapering linearly to 0 at the ring's
    edge, which folds the triangles on the far side over their neighbours.

    Returns
    -------
    UV : (p,2) float array
    info : dict — ``center``, ``rows`` moved, ``faces`` touching a moved row, ``flipped`` faces.
    """
    rng = np.random.default_rng(seed)
    UV = np.asarray(UV, float)
    c = _interior_center(FUV, len(UV), rings, rng, rows)
    dist = row_rings(FUV, len(UV), c, rings)
    inside = dist >= 0
    w = np.where(inside, 1.0 - dist / (rings + 1.0), 0.0)
    ang = rng.uniform(0, 2 * np.pi)
    d = np.array([np.cos(ang), np.sin(ang)]) * strength * rings * _edge_length(UV, FUV)
    out = UV.copy()
    out[inside] += w[inside, None] * d
    flipped = _flipped(V, F, out, FUV)
    touched = int(inside[np.asarray(FUV)].any(1).sum())
    return out, {"center": c, "rows": int(inside.sum()), "faces": touched, "flipped": flipped}


def vertex_noise(V, F, UV, FUV, *, fraction=0.02, sigma=0.8, seed=0, rows=None):
    """Move a random ``fraction`` of the rows by Gaussian noise of ``sigma`` median edge lengths."""
    rng = np.random.default_rng(seed)
    UV = np.asarray(UV, float)
    pool = np.unique(FUV) if rows is None else np.asarray(rows)
    k = max(1, int(round(fraction * len(pool))))
    pick = rng.choice(pool, size=k, replace=False)
    out = UV.copy()
    out[pick] += rng.normal(scale=sigma * _edge_length(UV, FUV), size=(k, 2))
    flipped = _flipped(V, F, out, FUV)
    return out, {"rows": int(k), "flipped": flipped}


def spike(V, F, UV, FUV, *, length=6.0, seed=0, rows=None):
    """Drag one random row ``length`` median edge lengths away in a random direction (a mis-click in a UV editor).

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> from neuraluv.tutte import tutte
    >>> V, F = disk(6); UV = tutte(V, F)
    >>> out, info = spike(V, F, UV, F, seed=1)
    >>> int((out != UV).any(1).sum()), info["flipped"]
    (1, 2)
    """
    rng = np.random.default_rng(seed)
    UV = np.asarray(UV, float)
    r = int(rng.choice(np.unique(FUV) if rows is None else np.asarray(rows)))
    ang = rng.uniform(0, 2 * np.pi)
    out = UV.copy()
    out[r] += length * _edge_length(UV, FUV) * np.array([np.cos(ang), np.sin(ang)])
    return out, {"row": r, "flipped": _flipped(V, F, out, FUV)}


def flip_patch(V, F, UV, FUV, *, rings=2, seed=0, rows=None):
    """Mirror the rows within ``rings`` rings of a random interior row about their mean ``u`` (a patch turned over).

    Examples
    --------
    >>> from neuraluv.datasets import disk
    >>> from neuraluv.tutte import tutte
    >>> V, F = disk(8); UV = tutte(V, F)
    >>> out, info = flip_patch(V, F, UV, F, seed=0)
    >>> info["rows"], int((out != UV).any(1).sum()), info["flipped"]
    (19, 19, 28)
    """
    rng = np.random.default_rng(seed)
    UV = np.asarray(UV, float)
    c = _interior_center(FUV, len(UV), rings, rng, rows)
    inside = row_rings(FUV, len(UV), c, rings) >= 0
    out = UV.copy()
    out[inside, 0] = 2.0 * out[inside, 0].mean() - out[inside, 0]
    return out, {"center": c, "rows": int(inside.sum()), "flipped": _flipped(V, F, out, FUV)}


def _island_rows(FUV, faces):
    return np.unique(np.asarray(FUV)[faces])


def mirror_island(UV, FUV, faces):
    """Reflect the island made of ``faces`` about its vertical centre line (u → 2c − u)."""
    out = np.asarray(UV, float).copy()
    r = _island_rows(FUV, faces)
    c = 0.5 * (out[r, 0].min() + out[r, 0].max())
    out[r, 0] = 2 * c - out[r, 0]
    return out, {"rows": int(len(r))}


def overlap_islands(UV, FUV, faces_a, faces_b):
    """Translate island ``a`` so that its centre lands on island ``b``'s (they now overlap)."""
    out = np.asarray(UV, float).copy()
    ra, rb = _island_rows(FUV, faces_a), _island_rows(FUV, faces_b)
    ca = 0.5 * (out[ra].min(0) + out[ra].max(0))
    cb = 0.5 * (out[rb].min(0) + out[rb].max(0))
    out[ra] += cb - ca
    return out, {"rows": int(len(ra)), "shift": (cb - ca).tolist()}


def push_out(UV, FUV, faces, shift=(0.6, 0.0)):
    """Translate an island by ``shift`` (partly out of the unit square)."""
    out = np.asarray(UV, float).copy()
    r = _island_rows(FUV, faces)
    out[r] += np.asarray(shift, float)
    return out, {"rows": int(len(r)), "shift": list(shift)}


def nan_patch(V, F, UV, FUV, *, rings=2, seed=0, rows=None):
    """Set the rows within ``rings`` rings of a random interior row to NaN."""
    rng = np.random.default_rng(seed)
    UV = np.asarray(UV, float)
    c = _interior_center(FUV, len(UV), rings, rng, rows)
    dist = row_rings(FUV, len(UV), c, rings)
    out = UV.copy()
    out[dist >= 0] = np.nan
    return out, {"center": c, "rows": int((dist >= 0).sum())}


#: Names of the generated cases, in the benchmark's order.
DAMAGE = ("local fold", "vertex noise", "mirrored island", "overlapping islands", "island outside [0,1]²", "NaN UVs")


#: A face thinner than this share of its longest UV edge has an orientation that float32 rounding can turn
#: (a file written again in another precision): not judged by :func:`damage_left`.
THIN = 1e-6


def _orientation(UV, FUV):
    """Each face's UV orientation (+1, -1; 0 without area), whether its corners have finite UVs, and whether it
    is thinner than :data:`THIN`."""
    FUV = np.asarray(FUV, np.int64)
    T = np.where((FUV >= 0)[..., None], np.asarray(UV, float)[np.maximum(FUV, 0)], np.nan)
    d = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    fin = np.isfinite(d)
    with np.errstate(invalid="ignore"):
        longest = np.linalg.norm(T - T[:, [1, 2, 0]], axis=2).max(1)
        thin = fin & (np.abs(d) <= THIN * longest ** 2)
    return np.where(fin, np.sign(d), 0).astype(np.int64), fin, thin


def damage_left(made, damaged, out, judged=None):
    """Of the faces a damage reversed or left without finite UVs, those a repair's output still has so.

    The damage's own verdict on a repair, by each face's UV orientation against the layout as made (a fold
    mended in its shell's orientation gets its faces' orientation back), independent of how the repairing
    tool reads its output.

    Parameters
    ----------
    made, damaged, out : tuple (UV (p,2) float array, FUV (m,3) int array), one face order
    judged : (m,) bool array, optional
        The faces to judge (default all); leave out faces without 3D area, whose orientation means nothing.
        Faces thinner as made than :data:`THIN` of their longest UV edge are never judged: rounding alone
        turns them.

    Returns
    -------
    (left, hit) : (m,) bool arrays, the faces still damaged and the faces the damage hit

    Examples
    --------
    >>> UV = np.array([[0., 0], [1, 0], [0, 1], [1, 1]]); FUV = np.array([[0, 1, 2], [1, 3, 2]])
    >>> bad = UV.copy(); bad[3] = [-0.5, -0.5]                  # the second face turned over
    >>> left, hit = damage_left((UV, FUV), (bad, FUV), (bad, FUV))
    >>> hit.tolist(), left.tolist(), damage_left((UV, FUV), (bad, FUV), (UV, FUV))[0].tolist()
    ([False, True], [False, True], [False, False])
    """
    (s0, f0, thin), (s1, f1, _), (s2, f2, _) = (_orientation(*x) for x in (made, damaged, out))
    judged = (np.ones(len(s0), bool) if judged is None else np.asarray(judged, bool)) & ~thin
    lost = f0 & ~f1 & judged
    turned = f1 & (s0 != 0) & (s1 == -s0) & judged
    return (lost & ~f2) | (turned & (s2 != s0)), lost | turned
