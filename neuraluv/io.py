"""Reading meshes and writing UV-mapped meshes.

Reading goes through trimesh (OBJ, OFF, PLY, STL, GLB, ...) and libigl for
tetrahedral ``.mesh`` files (whose boundary surface is returned). Writing is
atomic: a file is first written next to its destination and then renamed, so an
interrupted run never leaves a half-written output behind.
"""
from __future__ import annotations

import csv
import json
import math
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from neuraluv.errors import MeshLoadError

__all__ = [
    "load_mesh", "write_obj", "read_obj", "atomic_write", "check_mesh_arrays", "jsonable", "write_json", "write_csv",
]


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
    import igl

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
    trimesh is called with ``process=False`` so that vertices sharing a position
    but not a UV (texture seams) stay separate: a supplied chart keeps its seams.
    """
    path = Path(path)
    if not path.exists():
        raise MeshLoadError(f"{path}: no such file")
    if path.is_dir():
        raise MeshLoadError(f"{path}: is a directory, expected a mesh file")
    if path.stat().st_size == 0:
        raise MeshLoadError(f"{path}: file is empty")
    if path.suffix.lower() == ".mesh":
        try:
            V, F = _load_tet_surface(path)
        except MeshLoadError:
            raise
        except Exception as exc:  # libigl raises RuntimeError on bad files
            raise MeshLoadError(f"{path.name}: could not read .mesh file ({exc})") from None
        return check_mesh_arrays(V, F, name=path.name)
    import trimesh

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


@contextmanager
def atomic_write(path, mode="w"):
    """Open a temporary file that replaces ``path`` only if the block succeeds.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> with atomic_write(os.path.join(d, "x.txt")) as fh:
    ...     _ = fh.write("hello")
    >>> open(os.path.join(d, "x.txt")).read()
    'hello'
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, mode) as fh:
            yield fh
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual file mode
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def write_obj(path, V, F, UV, FUV=None):
    """Write an OBJ with per-corner texture coordinates, atomically.

    Parameters
    ----------
    path : str or path-like
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array
        Texture coordinates (``vt`` lines).
    FUV : (m,3) int array, optional
        Per-corner indices into ``UV``; defaults to ``F`` (one UV per vertex).

    Notes
    -----
    Coordinates are written with 17 significant digits so that a UV layout that
    is flip-free in memory is flip-free when read back.
    """
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    UV = np.asarray(UV, float)
    FUV = F if FUV is None else np.asarray(FUV, np.int64)
    if not np.all(np.isfinite(UV)):
        raise ValueError("refusing to write non-finite UV coordinates")
    lines = ["# written by neuraluv"]
    lines += [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in V]
    lines += [f"vt {u:.17g} {v:.17g}" for u, v in UV]
    lines += [f"f {a + 1}/{ta + 1} {b + 1}/{tb + 1} {c + 1}/{tc + 1}" for (a, b, c), (ta, tb, tc) in zip(F, FUV)]
    with atomic_write(path) as fh:
        fh.write("\n".join(lines) + "\n")


def read_obj(path):
    """Read an OBJ's positions, faces and per-corner texture coordinates.

    A small exact parser (no vertex merging or splitting), used to read back
    what :func:`write_obj` wrote and to split textured meshes along seams.

    Returns
    -------
    V : (n,3) float array
    F : (m,3) int array
    UV : (p,2) float array (empty if the file has no ``vt``)
    FUV : (m,3) int array or None
        Per-corner ``vt`` indices, or None when faces carry none.
    """
    V, UV, F, FUV = [], [], [], []
    has_vt = True
    with open(path) as fh:
        for line in fh:
            if line.startswith("v "):
                V.append([float(t) for t in line.split()[1:4]])
            elif line.startswith("vt "):
                UV.append([float(t) for t in line.split()[1:3]])
            elif line.startswith("f "):
                corners = line.split()[1:]
                vi, ti = [], []
                for c in corners:
                    parts = c.split("/")
                    vi.append(int(parts[0]))
                    if len(parts) > 1 and parts[1]:
                        ti.append(int(parts[1]))
                    else:
                        has_vt = False
                # fan-triangulate polygons
                for k in range(1, len(vi) - 1):
                    F.append([vi[0], vi[k], vi[k + 1]])
                    if has_vt and len(ti) == len(vi):
                        FUV.append([ti[0], ti[k], ti[k + 1]])
    V = np.asarray(V, float).reshape(-1, 3)
    F = np.asarray(F, np.int64).reshape(-1, 3)
    F = np.where(F < 0, F + len(V), F - 1)
    UV = np.asarray(UV, float).reshape(-1, 2)
    if has_vt and len(FUV) == len(F) and len(F):
        FUV = np.asarray(FUV, np.int64)
        FUV = np.where(FUV < 0, FUV + len(UV), FUV - 1)
    else:
        FUV = None
    return V, F, UV, FUV


def jsonable(obj):
    """Convert numpy scalars and non-finite floats for ``json.dump``.

    Non-finite numbers become strings (``"inf"``, ``"-inf"``, ``"nan"``) so a
    report stays valid JSON.

    Examples
    --------
    >>> jsonable({"a": np.float64(1.5), "b": [float("inf"), np.int64(2)]})
    {'a': 1.5, 'b': ['inf', 2]}
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (float, np.floating)):
        f = float(obj)
        return f if math.isfinite(f) else str(f)
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path, obj):
    """Write ``jsonable(obj)`` as indented JSON, atomically; returns the path."""
    with atomic_write(path) as fh:
        json.dump(jsonable(obj), fh, indent=2)
    return Path(path)


def _csv_value(v):
    if isinstance(v, (float, np.floating)):
        v = float(v)
        return repr(v) if math.isfinite(v) else str(v)
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(jsonable(v))
    return "" if v is None else v


def write_csv(path, rows, columns=None):
    """Write a list of dicts as CSV, atomically (raw values, one column per key).

    Parameters
    ----------
    path : str or path-like
    rows : list of dict
    columns : list of str, optional
        Column order (default: keys in order of first appearance); other keys are dropped.

    Returns
    -------
    path : Path

    Examples
    --------
    >>> import tempfile, os
    >>> p = write_csv(os.path.join(tempfile.mkdtemp(), "t.csv"), [{"a": 1, "b": 0.5}, {"a": 2, "c": [1]}])
    >>> open(p).read().splitlines()
    ['a,b,c', '1,0.5,', '2,,[1]']
    """
    columns = columns or list(dict.fromkeys(k for r in rows for k in r))
    with atomic_write(path) as fh:
        w = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: _csv_value(r.get(k)) for k in columns})
    return Path(path)
