"""Reading meshes: trimesh (OBJ, OFF, PLY, STL, GLB, ...) and libigl for tetrahedral ``.mesh`` files
(whose boundary surface is returned); every array checked before use."""
from __future__ import annotations

import os
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from neuraluv.errors import MeshLoadError
from neuraluv.io import MESH_EXTENSIONS
from neuraluv.io.obj import read_obj

__all__ = ["check_mesh_arrays", "check_mesh_file", "load_mesh"]


def check_mesh_arrays(V, F, *, name="mesh"):
    """Validate and convert ``(V, F)`` to ``float64 (n,3)`` and ``int64 (m,3)``.

    Parameters
    ----------
    V : (n,3) array_like
        Vertex positions.
    F : (m,3) array_like of int
        Triangle indices into ``V``.

    Returns
    -------
    V : (n,3) numpy float64 array
    F : (m,3) numpy int64 array

    Raises
    ------
    MeshLoadError
        If the arrays are empty, not triangles, contain NaN/inf, or index out of range.

    Examples
    --------
    >>> V, F = check_mesh_arrays([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> V.dtype, F.dtype, F.shape
    (dtype('float64'), dtype('int64'), (1, 3))
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[0] == 0:
        raise MeshLoadError(f"{name} has no vertices")
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    if V.shape[1] != 3:
        raise MeshLoadError(f"{name}: vertices must have 3 coordinates, got {V.shape[1]}")
    if F.ndim != 2 or F.shape[0] == 0:
        raise MeshLoadError(f"{name} has no faces (a point cloud or empty file?)")
    if F.shape[1] != 3:
        raise MeshLoadError(f"{name} is not a triangle mesh (faces have {F.shape[1]} corners); triangulate it first")
    if not np.all(np.isfinite(V)):
        bad = int((~np.isfinite(V)).any(axis=1).sum())
        raise MeshLoadError(f"{name} has {bad} vertices with NaN or infinite coordinates; fix or remove them")
    F = F.astype(np.int64)
    if F.min() < 0 or F.max() >= len(V):
        raise MeshLoadError(f"{name} has face indices outside 0..{len(V) - 1}")
    return V, F


def _load_tet_surface(path: Path):
    with path.open("rb") as fh:  # libigl prints its own complaint to stderr on bad files: check the header first
        head = fh.read(256)
    if b"MeshVersionFormatted" not in head:
        raise MeshLoadError(f"{path.name}: not a MEDIT .mesh file (no 'MeshVersionFormatted' header)")
    import igl

    with _quiet_stderr():
        Vt, T, Fs = igl.readMESH(str(path))
    if T.size:
        F = igl.boundary_facets(T)
        if isinstance(F, tuple):
            F = F[0]
    else:
        F = Fs
    if F.size == 0:
        raise MeshLoadError(f"{path.name}: .mesh file has no tetrahedra or triangles")
    F = np.asarray(F, dtype=np.int64)
    # keep only referenced vertices
    used = np.unique(F)
    remap = -np.ones(len(Vt), dtype=np.int64)
    remap[used] = np.arange(len(used))
    return np.asarray(Vt, float)[used], remap[F]


@contextmanager
def _quiet_stderr():
    """Silence file descriptor 2 (C++ libraries that print their errors) for the block."""
    try:
        sys.stderr.flush()
        fd = os.dup(2)
    except (OSError, ValueError):
        yield
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(fd, 2)
        os.close(fd)
        os.close(devnull)


def check_mesh_file(path) -> Path:
    """``path`` as a Path when it names a non-empty regular file of a known mesh format; else a one-line error.

    Raises
    ------
    MeshLoadError
        Missing, a directory, not a regular file, empty, or an unknown extension.

    Examples
    --------
    >>> check_mesh_file("no/such/mesh.obj")
    Traceback (most recent call last):
    ...
    neuraluv.errors.MeshLoadError: no/such/mesh.obj: no such file
    """
    path = Path(path)
    if not path.exists():
        raise MeshLoadError(f"{path}: no such file")
    if path.is_dir():
        raise MeshLoadError(f"{path}: is a directory, expected a mesh file")
    if not path.is_file():
        raise MeshLoadError(f"{path}: not a regular file (a pipe or device?); save the mesh to a file first")
    if path.stat().st_size == 0:
        raise MeshLoadError(f"{path}: file is empty")
    suffix = path.suffix.lower()
    if suffix not in MESH_EXTENSIONS:
        raise MeshLoadError(f"{path.name}: unknown mesh format {suffix or '(no extension)'!r}; "
                            f"use one of {', '.join(MESH_EXTENSIONS)}")
    return path


def load_mesh(path) -> tuple[np.ndarray, np.ndarray]:
    """Load a triangle mesh from disk without merging or reordering vertices.

    Parameters
    ----------
    path : str or path-like
        OBJ, OFF, PLY, STL, GLB/GLTF (via trimesh) or tetrahedral ``.mesh``
        (via libigl; its boundary surface is returned).

    Returns
    -------
    V : (n,3) numpy float64 array
    F : (m,3) numpy int64 array

    Raises
    ------
    MeshLoadError
        Missing, empty, unreadable or non-triangle files and NaN coordinates.

    Notes
    -----
    OBJ files go through :func:`read_obj` (indices checked line by line, tabs
    and comments accepted, polygons fan-triangulated). Other formats go through
    trimesh with ``process=False``, so that vertices sharing a position but not
    a UV (texture seams) stay separate: a supplied chart keeps its seams.
    """
    path = check_mesh_file(path)
    suffix = path.suffix.lower()
    if suffix == ".obj":  # our exact parser: indices checked, nothing merged or guessed
        V, F, _, _ = read_obj(path)
        return check_mesh_arrays(V, F, name=path.name)
    if suffix == ".mesh":
        try:
            V, F = _load_tet_surface(path)
        except MeshLoadError:
            raise
        except Exception as exc:  # libigl raises RuntimeError on bad files
            raise MeshLoadError(f"{path.name}: could not read .mesh file ({exc})") from None
        return check_mesh_arrays(V, F, name=path.name)

    import trimesh  # imported here: an OBJ run need not pay for it (about a second)

    try:
        loaded = trimesh.load(str(path), process=False, force=None)
    except Exception as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise MeshLoadError(f"{path.name}: could not read mesh ({msg})") from None
    if isinstance(loaded, trimesh.Scene):
        geoms = [g for g in loaded.dump() if isinstance(g, trimesh.Trimesh)] if loaded.geometry else []
        if not geoms:
            raise MeshLoadError(f"{path.name}: file contains no triangle geometry")
        loaded = trimesh.util.concatenate(geoms)
    if not isinstance(loaded, trimesh.Trimesh):
        raise MeshLoadError(f"{path.name}: file contains no triangle faces (got {type(loaded).__name__})")
    with np.errstate(all="ignore"):
        V = np.asarray(loaded.vertices, dtype=np.float64)
        F = np.asarray(loaded.faces)
    return check_mesh_arrays(V, F, name=path.name)

