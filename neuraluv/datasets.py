"""Data: procedural charts, a registry of real meshes, and the paper's compact charts.

Procedural charts are generated in code (no download) and used by the tests,
the demo and the notebooks. Real meshes are listed in :data:`REGISTRY` with their
upstream URL and sha256; :func:`fetch` downloads them with pooch, or imports them
from a local mirror after checking the hash. They are cached under
``$NEURALUV_DATA`` (default: the user cache directory), never in the repository.
"""
from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import numpy as np

from .errors import NeuralUVError

__all__ = [
    "disk", "spherical_cap", "saddle", "bumpy_disk", "glove", "several_components", "sphere",
    "PROCEDURAL", "procedural", "REGISTRY", "COMPACT", "data_dir", "fetch", "fetch_all", "available",
    "load", "load_raw", "DataMissing",
]


class DataMissing(NeuralUVError):
    """A registry mesh is not in the cache (fetch it first)."""


# ---------------------------------------------------------------- procedural


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


# ---------------------------------------------------------------- registry

_LIBIGL = "https://github.com/libigl/libigl-tutorial-data/raw/c1f9ede366d02e3531ecbaec5e3769312f31cccd/"
_CRANE = "https://github.com/NVlabs/nvdiffrec/raw/a3e73909a01887c8a135235ff860dd23a045cc1b/data/"

#: Real meshes: name -> (file name, upstream URL, sha256, licence note).
REGISTRY = {
    name: (fname, url, sha, lic)
    for name, fname, url, sha, lic in [
        ("3holes", "3holes.off", _LIBIGL + "3holes.off", "e8b1038cc70d11f393d8894ac08a5106293c50e95a5a60f0d5a8c8a7e884d106", "libigl tutorial data"),
        ("arm", "arm.obj", _LIBIGL + "arm.obj", "b7493c060434374a443501b2b5acb71288cbcaf6a3c42a52fcfc09f4dc5ef57c", "libigl tutorial data"),
        ("beetle", "beetle.off", _LIBIGL + "beetle.off", "aaddee826c2ebec84ab5da51e3fbec47def4909db18cdfd7000d7b5d9c635cf1", "libigl tutorial data"),
        ("bob_tri", "bob_tri.obj", _CRANE + "bob/bob_tri.obj", "2b15031b59c79c5e48a68dba17a13ec081bc62e359fb808a768312a6f41be406", "Keenan Crane, CC0 1.0"),
        ("bunny", "bunny.off", _LIBIGL + "bunny.off", "dda85ca6dc03ed83a0b754611d5c0b1a3c8ba5234e690479ac4a04063e6a7d4d", "libigl tutorial data"),
        ("camel_b", "camel_b.obj", _LIBIGL + "camel_b.obj", "91f7a9a22a273e3dc4c9eab85674ac2a04355f21699a18032f2d5f1f7a7f62c4", "libigl tutorial data"),
        ("camelhead", "camelhead.off", _LIBIGL + "camelhead.off", "bdafbd6330d698483b7b12945bbeee689a1bf998882e7baa61e00de963afd301", "libigl tutorial data"),
        ("cheburashka", "cheburashka.off", _LIBIGL + "cheburashka.off", "f9b087181fbc0c407ab1ae0df4441cc83f31717ab98a0c99e436d35cef8151b1", "libigl tutorial data"),
        ("cow", "cow.off", _LIBIGL + "cow.off", "8834713b505f9bf78c7f7c8b719d51d885d7d059952698da006813d292d84e95", "libigl tutorial data"),
        ("decimated-knight", "decimated-knight.off", _LIBIGL + "decimated-knight.off", "40aa1c53a81d6ad3b0f42023b1d78144488ff0a42afe3821e034d890ad9cffe2", "libigl tutorial data"),
        ("decimated-max", "decimated-max.obj", _LIBIGL + "decimated-max.obj", "e7489f9987a384f582c632ba19d8e6185e749909ef197215eb0c768597678532", "libigl tutorial data"),
        ("elephant", "elephant.obj", _LIBIGL + "elephant.obj", "f1038147fa61efd8b3213d119c682279ffea3cf06cc1713ae2a8ff81e68ba671", "libigl tutorial data"),
        ("face", "face.obj", _LIBIGL + "face.obj", "4817c60799fb7f5ae7f46d27fc48e8c6cbd6b5c7dec7f8197fb794802665a826", "libigl tutorial data"),
        ("fertility", "fertility.off", _LIBIGL + "fertility.off", "145fdfb007c8d5d09ba60943f14f4ddc9edd4327c7956fe379c624adeb59dc5b", "libigl tutorial data"),
        ("hand", "hand.mesh", _LIBIGL + "hand.mesh", "7178db13e578ce00983eef71674879463e5c9dc532d39dfabf84fbd809b983ea", "libigl tutorial data"),
        ("horse_quad", "horse_quad.obj", _LIBIGL + "horse_quad.obj", "f266409b006dd339125dab91c3ca6aefe7289a03c7cf5848b985fcb19ae3de93", "libigl tutorial data"),
        ("lion", "lion.off", _LIBIGL + "lion.off", "eff3b6021044aeae2d64c147cc0ad4ee16042e16c2c5d336efa86031cc815df4", "libigl tutorial data"),
        ("spot", "spot.obj", _CRANE + "spot/spot.obj", "54a49192005e4310dceeb5e5bc6c869fd801998a2cfa930674b60ca00a2fe54d", "Keenan Crane, CC0 1.0"),
    ]
}

#: The paper's compact charts: name -> registry mesh they are derived from.
COMPACT = {"camel": "camel_b", "hand": "hand", "bob": "bob_tri"}

#: Registry meshes that are closed surfaces (atlas and chart-cutting inputs).
CLOSED = ["bunny", "cow", "spot", "elephant", "arm", "fertility", "cheburashka", "decimated-knight", "lion", "beetle", "3holes"]


def data_dir():
    """The cache folder: ``$NEURALUV_DATA`` or the user cache (pooch.os_cache)."""
    env = os.environ.get("NEURALUV_DATA")
    if env:
        return Path(env).expanduser()
    import pooch

    return Path(pooch.os_cache("neuraluv"))


def _sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _entry(name):
    if name not in REGISTRY:
        raise NeuralUVError(f"unknown registry mesh {name!r}; known: {', '.join(sorted(REGISTRY))}")
    return REGISTRY[name]


def available(name):
    """True when registry mesh ``name`` is in the cache with the right hash."""
    fname, _, sha, _ = _entry(name)
    p = data_dir() / fname
    return p.exists() and _sha256(p) == sha


def fetch(name, source=None, *, download=True):
    """Put registry mesh ``name`` in the cache and return its path.

    Parameters
    ----------
    name : str
        A key of :data:`REGISTRY`.
    source : path-like, optional
        A local mirror folder: the file is copied from there after its sha256 is
        checked (no network needed).
    download : bool
        Without a ``source``, download from the upstream URL with pooch.

    Raises
    ------
    NeuralUVError
        On a hash mismatch; :class:`DataMissing` when the file cannot be had.
    """
    fname, url, sha, _ = _entry(name)
    dest = data_dir() / fname
    if dest.exists() and _sha256(dest) == sha:
        return dest
    dest.parent.mkdir(parents=True, exist_ok=True)
    if source is not None:
        src = Path(source) / fname
        if not src.exists():
            raise DataMissing(f"{fname} not found in {source}")
        got = _sha256(src)
        if got != sha:
            raise NeuralUVError(f"{src}: sha256 {got[:12]}… does not match the registry ({sha[:12]}…); refusing to import")
        tmp = dest.with_suffix(dest.suffix + ".part")
        shutil.copyfile(src, tmp)
        os.replace(tmp, dest)
        return dest
    if not download:
        raise DataMissing(f"registry mesh {name!r} is not cached; run `python data_scripts/fetch.py {name}` (or `--from DIR`)")
    import pooch

    try:
        return Path(pooch.retrieve(url, known_hash=f"sha256:{sha}", fname=fname, path=dest.parent, progressbar=False))
    except Exception as exc:  # network errors, hash mismatch
        raise DataMissing(f"could not download {name!r} ({type(exc).__name__}); use `--from DIR` with a local mirror") from None


def fetch_all(source=None, names=None, download=True):
    """Fetch several registry meshes; returns ``{name: path or error message}``."""
    out = {}
    for name in names or sorted(REGISTRY):
        try:
            out[name] = fetch(name, source, download=download)
        except NeuralUVError as exc:
            out[name] = str(exc)
    return out


def load_raw(name):
    """Load a cached registry mesh as ``(V, F)`` (no download)."""
    from .io import load_mesh

    return load_mesh(fetch(name, download=False))


def _derive_hand():
    from .repair import repair_mesh

    V, F = load_raw("hand")  # boundary surface of the tet mesh, unreferenced removed
    y = V[:, 1]
    cy = V[F, 1].mean(axis=1)
    cut = y.min() + 0.04 * (y.max() - y.min())
    F = F[cy > cut]
    V, F, _, _ = repair_mesh(V, F)
    return V, F


def _derive_bob():
    from .io import read_obj

    V, F, UV, FUV = read_obj(fetch("bob_tri", download=False))
    if FUV is None:
        raise NeuralUVError("bob_tri.obj has no texture coordinates to split along")
    Vc = np.zeros((len(UV), 3))
    Vc[FUV.reshape(-1)] = V[F.reshape(-1)]
    used = np.unique(FUV)
    remap = -np.ones(len(UV), np.int64)
    remap[used] = np.arange(len(used))
    return Vc[used], remap[FUV]


def load(name):
    """Load a chart by name: a procedural one, a compact chart or a registry mesh.

    Parameters
    ----------
    name : str
        ``"camel"``, ``"hand"``, ``"bob"`` (the paper's compact charts, derived
        as in ``SOURCES.md``), a :data:`REGISTRY` key, or a :data:`PROCEDURAL` key.

    Returns
    -------
    V : (n,3) float array
    F : (m,3) int array

    Raises
    ------
    DataMissing
        When a real mesh is not cached yet.
    """
    if name in PROCEDURAL:
        return procedural(name)
    if name == "camel":
        return load_raw("camel_b")
    if name == "hand":
        return _derive_hand()
    if name == "bob":
        return _derive_bob()
    return load_raw(name)
