import os

import numpy as np
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")


def real_mesh(name):
    """Load a compact chart or registry mesh, skipping with a reason when absent."""
    from neuraluv import datasets

    src = datasets.COMPACT.get(name, name)
    if not datasets.available(src):
        pytest.skip(f"real mesh '{src}' not cached: run `python data_scripts/fetch.py --from ../shared/data/meshes` (make test does this when the mirror exists)")
    return datasets.load(name)


def grid(nx=6, ny=2):
    """A flat ``nx`` × ``ny`` quad grid split into triangles: ``V (n,3), F (m,3)``."""
    x, y = np.meshgrid(np.arange(nx + 1.0), np.arange(ny + 1.0))
    V = np.c_[x.ravel(), y.ravel(), 0 * x.ravel()]
    w = nx + 1
    q = np.array([[i + w * j, i + 1 + w * j, i + 1 + w * (j + 1), i + w * (j + 1)] for j in range(ny) for i in range(nx)])
    return V, np.r_[q[:, [0, 1, 2]], q[:, [0, 2, 3]]]


def rolled(V, width):
    """A flat grid (``z = 0``) rolled along ``x`` onto a quarter of a cylinder of the grid's ``width``: the same
    lengths, no longer flat, so that no planar projection makes its map (a fold on a projection's map is put
    back onto it, which tests of the local repair must not take for theirs)."""
    r = 2 * width / np.pi
    return np.c_[r * np.sin(V[:, 0] / r), V[:, 1], r * (1 - np.cos(V[:, 0] / r))]


@pytest.fixture
def tri():
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    F = np.array([[0, 1, 2]])
    return V, F


def write_mesh(path, V, F):
    """Write ``(V, F)`` with trimesh in the format of ``path``'s extension (test input files)."""
    import trimesh

    trimesh.Trimesh(V, F, process=False).export(path)


def l_shaped_islands(k=12, seed=0):
    """``k`` L-shaped islands of random sizes (UVs, faces): boxes waste space around them, shapes do not."""
    rng = np.random.default_rng(seed)
    uvs, fs = [], []
    for _ in range(k):  # L-shaped charts of random sizes: boxes waste space, shapes do not
        s = rng.uniform(0.5, 2.0)
        P = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float) * s
        uvs.append(P)
        fs.append(np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]))
    return uvs, fs


def strip_island(n, width=1.0):
    """A long (n,1) strip of 2n triangles in the plane: its own UVs and 3D positions."""
    x = np.repeat(np.arange(n + 1, dtype=float), 2)
    y = np.tile([0.0, width], n + 1)
    uv = np.column_stack([x, y])
    F = np.array([[2 * i, 2 * i + 2, 2 * i + 3] for i in range(n)] + [[2 * i, 2 * i + 3, 2 * i + 1] for i in range(n)])
    return uv, F


def three_copies():
    """A sphere and two copies of it (one turned, one moved): ``V, F, faces per copy``."""
    from scipy.spatial.transform import Rotation

    from neuraluv.datasets import sphere

    V, F = sphere(1)
    R = Rotation.from_euler("xyz", [0.3, 1.0, -0.5]).as_matrix()
    return np.vstack([V, V @ R.T + [3, 0.5, 0], V + [0, 3, 0]]), np.vstack([F, F + len(V), F + 2 * len(V)]), len(F)


def two_islands():
    """Two disks side by side in the unit square (one layout, two islands)."""
    from neuraluv import datasets
    from neuraluv.tutte import tutte

    V, F = datasets.spherical_cap(5)
    UV = tutte(V, F)
    UV = (UV - UV.min(0)) / np.ptp(UV, axis=0).max() * 0.4
    V2 = np.vstack([V, V + [3.0, 0, 0]])
    F2 = np.vstack([F, F + len(V)])
    UV2 = np.vstack([UV + [0.05, 0.3], UV + [0.55, 0.3]])
    return V2, F2, UV2, F2.copy(), np.arange(len(F)), np.arange(len(F), 2 * len(F))


def write_layout(path, V, F, UV, FUV):
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in V] + [f"vt {u:.17g} {v:.17g}" for u, v in UV]
    lines += [f"f {a + 1}/{ta + 1} {b + 1}/{tb + 1} {c + 1}/{tc + 1}" for (a, b, c), (ta, tb, tc) in zip(F, FUV)]
    path.write_text("\n".join(lines) + "\n")


def gltf_validator_missing():
    """Why the Khronos glTF validator cannot run here, or None (:mod:`neuraluv_paper.gltf_validator`)."""
    from neuraluv_paper.gltf_validator import validator_missing

    return validator_missing()


def gltf_validate(path):
    """The Khronos glTF validator's summary of ``path`` (``errors``, ``warnings``, ``messages``), or None
    when it cannot run here (:func:`gltf_validator_missing` says why; a test of its own skips with it)."""
    from neuraluv_paper.gltf_validator import gltf_validate as validate

    out = validate(path)
    assert out is None or "fatal" not in out, out
    return out
