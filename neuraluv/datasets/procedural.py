"""Procedural charts, generated in code (no download): the tests', the demo's and the notebooks' inputs."""
from __future__ import annotations

import numpy as np

from neuraluv.errors import NeuralUVError

__all__ = ["disk", "spherical_cap", "saddle", "bumpy_disk", "glove", "several_components", "sphere", "PROCEDURAL", "procedural"]



def disk(n_rings=8):
    """A flat triangulated unit disk (hexagonal rings).

    Parameters
    ----------
    n_rings : int
        Ring ``r`` has ``6 r`` vertices; ``1 + 3 n (n + 1)`` vertices in total.

    Returns
    -------
    V : (n,3) float array (z = 0)
    F : (m,3) int array, counter-clockwise seen from +z

    Examples
    --------
    >>> V, F = disk(2)
    >>> V.shape, F.shape
    ((19, 3), (24, 3))
    """
    pts = [np.zeros(2)]
    rings = [np.array([0])]
    start = 1
    for r in range(1, n_rings + 1):
        m = 6 * r
        ang = 2 * np.pi * np.arange(m) / m
        pts.extend(np.column_stack([np.cos(ang), np.sin(ang)]) * r / n_rings)
        rings.append(np.arange(start, start + m))
        start += m
    P = np.array(pts)
    F = []
    for r in range(n_rings):
        inner, outer = rings[r], rings[r + 1]
        ni, no = len(inner), len(outer)
        if ni == 1:
            for j in range(no):
                F.append([inner[0], outer[j], outer[(j + 1) % no]])
            continue
        i = j = 0
        while i < ni or j < no:
            ai = (i + 1) / ni
            aj = (j + 1) / no
            if j < no and (i >= ni or aj <= ai):
                F.append([inner[i % ni], outer[j], outer[(j + 1) % no]])
                j += 1
            else:
                F.append([inner[i % ni], outer[(j) % no], inner[(i + 1) % ni]])
                i += 1
    V = np.column_stack([P, np.zeros(len(P))])
    return V, np.array(F, dtype=np.int64)


def spherical_cap(n_rings=10, angle=0.6 * np.pi):
    """A spherical cap of polar half-angle ``angle`` on the unit sphere.

    Examples
    --------
    >>> V, F = spherical_cap(4)
    >>> bool(np.allclose(np.linalg.norm(V, axis=1), 1))
    True
    """
    D, F = disk(n_rings)
    rho = np.linalg.norm(D[:, :2], axis=1)
    phi = np.arctan2(D[:, 1], D[:, 0])
    th = rho * angle
    V = np.column_stack([np.sin(th) * np.cos(phi), np.sin(th) * np.sin(phi), np.cos(th)])
    return V, F


def saddle(n_rings=10, height=0.6):
    """The hyperbolic paraboloid ``z = h (x² − y²)`` over the unit disk."""
    V, F = disk(n_rings)
    V[:, 2] = height * (V[:, 0] ** 2 - V[:, 1] ** 2)
    return V, F


def bumpy_disk(n_rings=12, n_bumps=6, height=0.25, seed=0):
    """A disk with random Gaussian bumps (fixed seed)."""
    rng = np.random.default_rng(seed)
    V, F = disk(n_rings)
    c = rng.uniform(-0.6, 0.6, (n_bumps, 2))
    h = rng.uniform(-height, height, n_bumps)
    w = rng.uniform(0.15, 0.3, n_bumps)
    d2 = ((V[:, None, :2] - c[None]) ** 2).sum(-1)
    V[:, 2] = (h * np.exp(-d2 / (2 * w**2))).sum(1)
    return V, F


def _grid_mask_mesh(mask):
    """Triangulate the cells of a boolean grid ``mask[ix, iy]`` (2 triangles each)."""
    nx, ny = mask.shape
    vid = -np.ones((nx + 1, ny + 1), np.int64)
    cells = np.argwhere(mask)
    corners = np.concatenate([cells, cells + [1, 0], cells + [1, 1], cells + [0, 1]])
    uniq = np.unique(corners, axis=0)
    vid[uniq[:, 0], uniq[:, 1]] = np.arange(len(uniq))
    F = []
    for ix, iy in cells:
        a, b, c, d = vid[ix, iy], vid[ix + 1, iy], vid[ix + 1, iy + 1], vid[ix, iy + 1]
        if (ix + iy) % 2:
            F += [[a, b, c], [a, c, d]]
        else:
            F += [[a, b, d], [b, c, d]]
    return uniq.astype(float), np.array(F, np.int64)


def glove(res=3, finger_length=5, curl=0.9):
    """A fingered, curled "glove" chart: hard for convex-boundary maps.

    A palm with four fingers and a thumb, triangulated on a grid with ``res``
    cells per unit, then lifted to 3D by curling the fingers. Tutte's map
    squashes the long fingers, so the solver has real work to do.

    Parameters
    ----------
    res : int
        Grid cells per unit length.
    finger_length : float
        Finger length in palm-width units (the palm is 5 x 4 units).
    curl : float
        Curl angle of a finger tip in radians per unit of finger length / 4.

    Examples
    --------
    >>> from neuraluv.topology import is_disk_like
    >>> is_disk_like(*glove(res=2))
    (True, 'disk')
    """
    W, H = 7, 4  # palm (units)
    L = finger_length
    nx, ny = W * res, int((H + L) * res)
    mask = np.zeros((nx + 4 * res, ny), bool)
    off = 0
    mask[off: off + W * res, : H * res] = True  # palm
    for f in range(4):  # fingers: 1 unit wide, 1 unit gaps (x = 0,2,4,6)
        x0 = off + 2 * f * res
        length = int((L - (0.8 if f in (0, 3) else 0.0)) * res)
        mask[x0: x0 + res, H * res: H * res + length] = True
    # thumb: sticks out to the right from the palm's lower half
    mask[off + W * res: off + W * res + 3 * res, res: 2 * res] = True
    P, F = _grid_mask_mesh(mask)
    P /= res
    x, y = P[:, 0], P[:, 1]
    z = np.zeros_like(x)
    # curl fingers about the x axis beyond the palm, thumb about the y axis
    fy = y > H
    R = L / max(curl, 1e-6) / 2
    t = (y[fy] - H) / R
    y2, z2 = y.copy(), z.copy()
    y2[fy] = H + R * np.sin(t)
    z2[fy] = R * (1 - np.cos(t))
    tx = x > W
    t2 = (x[tx] - W) / R
    x2 = x.copy()
    x2[tx] = W + R * np.sin(t2)
    z2[tx] = R * (1 - np.cos(t2))
    z2 += 0.15 * np.sin(0.9 * x) * np.cos(0.7 * y)  # a little palm relief
    V = np.column_stack([x2, y2, z2])
    return V - V.mean(0), F


def several_components(n_rings=6):
    """Three disjoint charts (a cap, a saddle and a bumpy disk) in one mesh.

    Examples
    --------
    >>> from neuraluv.topology import topology_scan
    >>> topology_scan(*several_components(4)).components
    3
    """
    parts = [spherical_cap(n_rings), saddle(n_rings), bumpy_disk(n_rings)]
    Vs, Fs, off = [], [], 0
    for i, (V, F) in enumerate(parts):
        Vs.append(V + [3.0 * i, 0, 0])
        Fs.append(F + off)
        off += len(V)
    return np.vstack(Vs), np.vstack(Fs)


def sphere(subdivisions=2):
    """A closed icosphere (not disk-like; for error paths and atlas tests)."""
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    return np.asarray(m.vertices, float), np.asarray(m.faces, np.int64)


#: Procedural charts by name (built-in inputs, no download).
PROCEDURAL = {
    "disk": disk,
    "cap": spherical_cap,
    "saddle": saddle,
    "bumpy": bumpy_disk,
    "glove": glove,
    "components": several_components,
}


def procedural(name, **kwargs):
    """Build a procedural chart by name (see :data:`PROCEDURAL`)."""
    if name not in PROCEDURAL:
        raise NeuralUVError(f"unknown procedural mesh {name!r}; choose one of {sorted(PROCEDURAL)}")
    return PROCEDURAL[name](**kwargs)
