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


@pytest.fixture
def tri():
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    F = np.array([[0, 1, 2]])
    return V, F


def write_mesh(path, V, F):
    """Write ``(V, F)`` with trimesh in the format of ``path``'s extension (test input files)."""
    import trimesh

    trimesh.Trimesh(V, F, process=False).export(path)
