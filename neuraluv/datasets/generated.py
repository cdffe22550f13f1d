"""Reproducible "generated-like" messy meshes for the atlas study.

The paper's Amara Spatial study (Sec. 5) runs the atlas pipeline on meshes made
by generative 3D models: marching-cubes surfaces with noise, floating
fragments, thin slivers, inconsistent winding, unwelded triangle soups and
non-manifold fans. Those assets are not redistributable, so this module builds
a seeded stand-in set with the same failure modes: a noisy implicit surface
(metaballs plus smooth noise, optionally a torus handle) meshed with
``igl.marching_cubes``, followed by a recipe of defects.

Every asset is a pure function of ``(index, seed)``.
"""
from __future__ import annotations

import igl
import numpy as np
from scipy.ndimage import zoom

from neuraluv.datasets.procedural import sphere

__all__ = [
    "noisy_implicit", "unweld", "add_fragments", "add_slivers", "flip_windings", "add_nonmanifold",
    "punch_holes", "duplicate_faces", "generated_asset", "generated_set", "DEFECTS",
]

#: The defects a recipe can apply, in the order they are applied.
DEFECTS = ("holes", "fragments", "slivers", "nonmanifold", "duplicates", "flips", "unweld")


def _smooth_noise(rng, res, cells=5):
    coarse = rng.standard_normal((cells, cells, cells))
    return zoom(coarse, res / cells, order=3)[:res, :res, :res]


def noisy_implicit(seed=0, res=32, n_blobs=4, noise=0.25, torus=False):
    """Marching-cubes surface of a noisy implicit shape.

    Parameters
    ----------
    seed : int
    res : int
        Grid resolution per axis (faces grow like ``res²``).
    n_blobs : int
        Number of metaballs.
    noise : float
        Amplitude of the smooth noise added to the field (creates bumps,
        tunnels and small disconnected blobs).
    torus : bool
        Add a torus term (a handle, genus ≥ 1).

    Returns
    -------
    V : (n,3) float array
    F : (m,3) int array

    Examples
    --------
    >>> V, F = noisy_implicit(0, res=16)
    >>> V.shape[1], F.shape[1], len(F) > 100
    (3, 3, True)
    """
    rng = np.random.default_rng(seed)
    g = np.linspace(-1.0, 1.0, res)
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    field = np.zeros_like(X)
    for _ in range(n_blobs):
        c = rng.uniform(-0.45, 0.45, 3)
        r = rng.uniform(0.25, 0.45)
        field += np.exp(-((X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2) / (r * r))
    if torus:
        R, r = 0.55, 0.16
        q = np.sqrt(X**2 + Y**2) - R
        field += 1.5 * np.exp(-(q**2 + Z**2) / (r * r))
    field += noise * _smooth_noise(rng, res)
    S = (0.5 - field)
    # igl indexes corner (x, y, z) as x + y*nx + z*nx*ny: Fortran order
    GV = np.column_stack([X.ravel(order="F"), Y.ravel(order="F"), Z.ravel(order="F")])
    V, F, _ = igl.marching_cubes(S.ravel(order="F"), GV, res, res, res, 0.0)
    return np.asarray(V, float), np.asarray(F, np.int64)


def unweld(V, F, frac=1.0, rng=None):
    """Give a fraction of the faces their own vertex copies (a triangle soup).

    Examples
    --------
    >>> V, F = unweld(np.eye(3), np.array([[0, 1, 2]]))
    >>> F.tolist()
    [[3, 4, 5]]
    """
    rng = np.random.default_rng(0) if rng is None else rng
    F = np.array(F, np.int64)
    pick = np.flatnonzero(rng.random(len(F)) < frac)
    newv = V[F[pick].reshape(-1)]
    F[pick] = len(V) + np.arange(3 * len(pick)).reshape(-1, 3)
    return np.vstack([V, newv]), F


def add_fragments(V, F, n=5, rng=None, size=0.03):
    """Append ``n`` floating fragments: lone triangles and tiny closed blobs."""
    rng = np.random.default_rng(0) if rng is None else rng
    lo, hi = V.min(0), V.max(0)
    Vs, Fs = [V], [F]
    nv = len(V)
    Sv, Sf = sphere(0)
    for i in range(n):
        c = rng.uniform(lo, hi)
        if i % 2 == 0:
            tri = c + size * rng.standard_normal((3, 3))
            Vs.append(tri)
            Fs.append(np.array([[nv, nv + 1, nv + 2]]))
            nv += 3
        else:
            Vs.append(c + size * Sv)
            Fs.append(Sf + nv)
            nv += len(Sv)
    return np.vstack(Vs), np.vstack(Fs)


def add_slivers(V, F, n=10, rng=None):
    """Add needle faces: exactly degenerate ones and near-degenerate fins on edges."""
    rng = np.random.default_rng(0) if rng is None else rng
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    pick = rng.choice(len(F), size=min(n, len(F)), replace=False)
    newV, newF = [], []
    nv = len(V)
    for k, f in enumerate(pick):
        a, b, c = F[f]
        if k % 3 == 0:
            newF.append([a, a, b])  # repeated corner
        elif k % 3 == 1:
            newV.append(0.5 * (V[a] + V[b]))  # collinear (zero area)
            newF.append([a, b, nv])
            nv += 1
        else:
            p = 0.5 * (V[a] + V[b]) + 1e-6 * diag * rng.standard_normal(3)
            newV.append(p)  # a thin fin on edge ab: non-manifold edge, tiny area
            newF.append([b, a, nv])
            nv += 1
    V2 = np.vstack([V] + ([np.array(newV)] if newV else []))
    return V2, np.vstack([F, np.array(newF, np.int64)])


def flip_windings(F, frac=0.05, rng=None):
    """Reverse the winding of a random fraction of faces.

    Examples
    --------
    >>> flip_windings(np.array([[0, 1, 2]]), frac=1.0).tolist()
    [[0, 2, 1]]
    """
    rng = np.random.default_rng(0) if rng is None else rng
    F = np.array(F, np.int64)
    pick = rng.random(len(F)) < frac
    F[pick] = F[pick][:, [0, 2, 1]]
    return F


def add_nonmanifold(V, F, n=2, rng=None):
    """Add bow-tie fans (non-manifold vertices) and fins (non-manifold edges)."""
    rng = np.random.default_rng(0) if rng is None else rng
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    Vs, Fs = [V], [F]
    nv = len(V)
    for i in range(n):
        f = F[rng.integers(len(F))]
        if i % 2 == 0:  # fan of 4 triangles glued at one vertex
            c = V[f[0]]
            ang = np.linspace(0, 2 * np.pi, 5)[:-1]
            ring = c + 0.04 * diag * np.column_stack([np.cos(ang), np.sin(ang), 0.5 + 0 * ang])
            Vs.append(ring)
            Fs.append(np.array([[f[0], nv + j, nv + (j + 1) % 4] for j in range(4)]))
            nv += 4
        else:  # a fin on an existing edge (third face on that edge)
            p = 0.5 * (V[f[0]] + V[f[1]]) + 0.03 * diag * rng.standard_normal(3)
            Vs.append(p[None])
            Fs.append(np.array([[f[0], f[1], nv]]))
            nv += 1
    return np.vstack(Vs), np.vstack(Fs)


def punch_holes(F, n=3, rng=None, radius=3):
    """Remove ``n`` small face patches (grown ``radius`` rings around a seed face)."""
    rng = np.random.default_rng(0) if rng is None else rng
    F = np.asarray(F, np.int64)
    keep = np.ones(len(F), bool)
    for _ in range(n):
        verts = set(F[rng.integers(len(F))].tolist())
        for _ in range(radius):
            touch = np.isin(F, list(verts)).any(1)
            verts |= set(F[touch].reshape(-1).tolist())
        keep &= ~np.isin(F, list(verts)).all(1)
    return F[keep]


def duplicate_faces(F, frac=0.01, rng=None):
    """Append copies of a fraction of the faces (half of them reversed)."""
    rng = np.random.default_rng(0) if rng is None else rng
    F = np.asarray(F, np.int64)
    pick = np.flatnonzero(rng.random(len(F)) < frac)
    dup = F[pick].copy()
    dup[::2] = dup[::2][:, [0, 2, 1]]
    return np.vstack([F, dup])


def generated_asset(index, seed=0, res=None):
    """One messy generated-like asset, a pure function of ``(index, seed)``.

    Parameters
    ----------
    index : int
    seed : int
    res : int, optional
        Marching-cubes resolution (default drawn between 20 and 34).

    Returns
    -------
    V : (n,3) float array
    F : (m,3) int array
    info : dict
        ``name``, ``res``, ``torus`` and the ``defects`` applied.

    Examples
    --------
    >>> V, F, info = generated_asset(3, res=16)
    >>> info["name"], len(F) > 50
    ('gen_003', True)
    """
    rng = np.random.default_rng([seed, index])
    drawn = int(rng.integers(20, 35))  # always drawn, so ``res`` does not change the recipe
    res = drawn if res is None else int(res)
    torus = bool(rng.random() < 0.3)
    V, F = noisy_implicit(int(rng.integers(2**31)), res=res, n_blobs=int(rng.integers(2, 6)),
                          noise=float(rng.uniform(0.1, 0.4)), torus=torus)
    # each defect is applied with probability 0.6; unweld half the time on all faces
    applied = [d for d in DEFECTS if rng.random() < 0.6]
    if "holes" in applied:
        F = punch_holes(F, int(rng.integers(1, 4)), rng)
    if "fragments" in applied:
        V, F = add_fragments(V, F, int(rng.integers(1, 8)), rng)
    if "slivers" in applied:
        V, F = add_slivers(V, F, int(rng.integers(3, 15)), rng)
    if "nonmanifold" in applied:
        V, F = add_nonmanifold(V, F, int(rng.integers(1, 4)), rng)
    if "duplicates" in applied:
        F = duplicate_faces(F, 0.01, rng)
    if "flips" in applied:
        F = flip_windings(F, float(rng.uniform(0.01, 0.3)), rng)
    if "unweld" in applied:
        V, F = unweld(V, F, float(rng.choice([0.2, 1.0])), rng)
    info = {"name": f"gen_{index:03d}", "index": int(index), "seed": int(seed), "res": res, "torus": torus, "defects": applied}
    return V, F, info


def generated_set(n=50, seed=0, res=None):
    """The first ``n`` assets of :func:`generated_asset` (a generator of triples)."""
    for i in range(n):
        yield generated_asset(i, seed, res)
