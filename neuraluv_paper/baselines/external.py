"""External tools as baselines: xatlas, Blender (``bpy`` in its own environment), OptCuts and the BFF binary."""
from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from neuraluv.io import atomic_write, read_obj
from neuraluv.topology import topology_scan
from neuraluv_paper.baselines.common import InitFail, Unavailable, weld_corners

__all__ = ["xatlas_map", "BLENDER_MODES", "blender_python", "blender_map", "optcuts_binary", "optcuts_map",
           "blender_run", "BPY_MISSING", "bff_binary", "bff_cli_map", "built_binary", "TRIANGLE_NOTE"]

#: Where ``make baselines`` (data_scripts/build_baselines.sh) puts the binaries, relative to the repository root.
BUILT_DIR = Path(".cache") / "third_party" / "bin"
#: The licence caveat of the OptCuts build (printed by the build script, stated in the README).
TRIANGLE_NOTE = ("OptCuts bundles Shewchuk's Triangle, which is free for research use only "
                 "(no commercial use without the author's permission)")
_BUILD_HINT = "run `make baselines` in the repository (builds it into .cache/third_party/bin/)"


def built_binary(name):
    """``.cache/third_party/bin/NAME`` as built by ``make baselines``, or None.

    Looked up under the repository that holds this package (an editable
    install or a checkout) and under the current directory.
    """
    roots = [Path(__file__).resolve().parents[2], Path.cwd()]
    for root in roots:
        p = root / BUILT_DIR / name
        if p.is_file() and os.access(p, os.X_OK):
            return str(p)
    return None


def _tool(env_var, name):
    env = os.environ.get(env_var)
    if env:
        return env if Path(env).exists() else None
    return built_binary(name) or shutil.which(name)


def _write_obj(path, V, F):
    with atomic_write(path) as fh:
        fh.write("".join(f"v {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in np.asarray(V, float)))
        fh.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in np.asarray(F, np.int64)))


def _tail(proc):
    return ((proc.stderr or "") + (proc.stdout or "")).strip().splitlines()[-1:] or ["no output"]



def xatlas_map(V, F):
    """xatlas charting and packing of the whole mesh.

    Returns
    -------
    (UV, V_cut, F_cut) : the atlas UVs in [0,1]² on the cut mesh
        ``V_cut = V[vmapping]``; ``F_cut`` has the input's face order.
    """
    try:
        import xatlas
    except ImportError as e:  # pragma: no cover - xatlas is a core dependency
        raise Unavailable(f"xatlas is not installed ({e}): pip install xatlas") from None
    vmapping, indices, uvs = xatlas.parametrize(np.ascontiguousarray(V, np.float32), np.ascontiguousarray(F, np.uint32))
    Vc = np.asarray(V, float)[np.asarray(vmapping, np.int64)]
    Fc = np.asarray(indices, np.int64)
    if len(Fc) != len(F):
        raise RuntimeError(f"xatlas returned {len(Fc)} faces for {len(F)} input faces")
    return np.asarray(uvs, float), Vc, Fc



BLENDER_MODES = {
    "blender-smart": "SMART",
    "blender-angle": "ANGLE_BASED",
    "blender-conformal": "CONFORMAL",
    "blender-minstretch": "MINIMUM_STRETCH",
}


def blender_python():
    """The Python interpreter that can ``import bpy``, or None.

    ``$NEURALUV_BPY_PYTHON`` when set, else the current interpreter when it has
    ``bpy`` installed, else the ``.venv-bpy`` that ``make blender-env`` creates
    in the repository holding this package.
    """
    env = os.environ.get("NEURALUV_BPY_PYTHON")
    if env:
        return env if Path(env).exists() else None

    if importlib.util.find_spec("bpy") is not None:
        return sys.executable
    venv = Path(__file__).resolve().parents[2] / ".venv-bpy" / "bin" / "python"
    return str(venv) if venv.exists() else None


BPY_MISSING = ("Blender's bpy module not found: run `make blender-env` in the repository (bpy 4.5 in .venv-bpy, found "
               "automatically), or set NEURALUV_BPY_PYTHON to a Python that has `pip install 'bpy==4.5.*' numpy`")


def blender_run(V, F, mode="SMART", *, uv=None, pack=None, timeout=600, **params):
    """Run Blender's unwrap and/or ``uv.pack_islands`` on a mesh in a subprocess; its loop UVs and timings.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    mode : {"SMART", "ANGLE_BASED", "CONFORMAL", "MINIMUM_STRETCH", "NONE"}
        The unwrap; ``"NONE"`` keeps ``uv``.
    uv : (3m,2) float array, optional
        Loop UVs to start from (row ``3t+j``: corner ``j`` of face ``t``), for ``mode="NONE"``.
    pack : dict, optional
        Keyword arguments of ``bpy.ops.uv.pack_islands``, run after the unwrap on every face.
    timeout : float
        Seconds before the Blender process is killed.
    **params
        Passed to the unwrap operator (e.g. ``angle_limit``, ``island_margin``, ``margin``).

    Returns
    -------
    dict
        ``uv`` (3m,2) loop UVs, ``seconds`` (the unwrap operator's own time), ``pack_seconds``
        (the pack operator's, NaN without ``pack``) and ``wall`` (the whole process: start,
        ``import bpy``, the mesh built, the operators, the UVs written) and ``version`` (Blender's).

    Raises
    ------
    Unavailable
        Without an interpreter that has ``bpy`` (:func:`blender_python`).
    RuntimeError
        When Blender fails, times out or changes the face corners.

    Notes
    -----
    The script :mod:`neuraluv_paper.baselines._blender_unwrap` runs under the interpreter
    returned by :func:`blender_python` (``bpy`` is ~370 MB and kept out of the
    main environment).
    """
    py = blender_python()
    if py is None:
        raise Unavailable(BPY_MISSING)
    script = Path(__file__).with_name("_blender_unwrap.py")
    what = f"Blender {mode}" + (" + pack_islands" if pack is not None else "")
    with tempfile.TemporaryDirectory(prefix="neuraluv_bpy_") as tmp:
        src, dst = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        arrays = dict(V=np.asarray(V, float), F=np.asarray(F, np.int64))
        if uv is not None:
            arrays["uv"] = np.asarray(uv, float)
        np.savez(src, **arrays)
        cmd = [py, str(script), str(src), str(dst), mode, json.dumps(dict(params, **({"pack": pack} if pack else {})))]
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"{what} timed out after {timeout} s") from None
        wall = time.perf_counter() - t0
        if proc.returncode != 0 or not dst.exists():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["no output"]
            raise RuntimeError(f"{what} failed (exit {proc.returncode}): {tail[0]}")
        out = np.load(dst)
        UV = np.asarray(out["uv"], float)
        res = {"uv": UV, "seconds": float(out["seconds"]), "wall": wall,
               "pack_seconds": float(out["pack_seconds"]), "version": str(out["version"])}
    m = len(F)
    if UV.shape != (3 * m, 2):
        raise RuntimeError(f"{what} returned {UV.shape} loop UVs for {m} faces")
    return res


def blender_map(V, F, mode="SMART", *, timeout=600, **params):
    """Blender's UV unwrap in a subprocess (:func:`blender_run`); per-corner UVs on the exploded mesh.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    mode : {"SMART", "ANGLE_BASED", "CONFORMAL", "MINIMUM_STRETCH"}
    timeout : float
        Seconds before the Blender process is killed.
    **params
        Passed to the operator (e.g. ``angle_limit``, ``island_margin``, ``margin``).

    Returns
    -------
    (UV, V_cut, F_cut, seconds)
        The loop UVs welded into a cut mesh (:func:`weld_corners`: corners
        sharing a vertex and a UV become one vertex) and Blender's own
        operator time.
    """
    r = blender_run(V, F, mode, timeout=timeout, **params)
    vidx, F_cut, UV_cut = weld_corners(F, r["uv"])
    return UV_cut, np.asarray(V, float)[vidx], F_cut, r["seconds"]



def optcuts_binary():
    """Path of the OptCuts binary, or None.

    ``$NEURALUV_OPTCUTS`` when set (None if that file does not exist), else the
    one ``make baselines`` built (``.cache/third_party/bin/OptCuts_bin``), else
    ``OptCuts_bin`` on PATH.
    """
    return _tool("NEURALUV_OPTCUTS", "OptCuts_bin")


def bff_binary():
    """Path of the Boundary First Flattening command-line tool, or None.

    ``$NEURALUV_BFF`` when set (None if that file does not exist), else the one
    ``make baselines`` built (``.cache/third_party/bin/bff-command-line``),
    else ``bff-command-line`` on PATH.
    """
    return _tool("NEURALUV_BFF", "bff-command-line")


def bff_cli_map(V, F, *, n_cones=0, flatten_to_disk=False, normalize=True, prescale=1.0, timeout=600):
    """Boundary First Flattening (Sawhney & Crane 2018) through its v1.6 command-line tool.

    Runs, in a temporary directory::

        bff-command-line in.obj out.obj --normalizeUVs [--nCones=N] [--flattenToDisk]

    The default (no cones, free boundary: BFF's ``flatten(u = 0)``, the
    minimal-area-distortion boundary) is the paper's BFF baseline for a disk
    chart and what :func:`neuraluv_paper.baselines.bff.bff_map` implements in
    Python. Several components are flattened one by one and packed by the tool
    (a closed component gets 8 cones, as the tool decides).

    The tool writes ``v`` in the input's order (positions printed with six
    decimals) and faces per component, each starting at another corner; the
    faces are matched back to the input's by their vertex triple, so the
    result has the input's face order, and the per-corner UVs are welded like
    :func:`optcuts_map`'s.

    The tool prints UVs with ``%f`` (six decimals). With ``--normalizeUVs``
    (``normalize=True``, the tool's documented use) they are rounded to 1e-6 of
    the layout's extent, which collapses near-degenerate triangles to zero area
    (on Hand's crushed fingers, 13% of the faces). ``normalize=False,
    prescale=1e4`` keeps the tool's own scale (the mesh's, times BFF's length
    ratio) on an input scaled by 10⁴, so ten or more significant digits reach
    the file; the map itself is the same (the tool normalises its input).

    Parameters
    ----------
    n_cones : int
        ``--nCones=N`` (0: none, the free-boundary flattening).
    flatten_to_disk : bool
        ``--flattenToDisk`` (a circular boundary instead of the free one).
    normalize : bool
        ``--normalizeUVs``.
    prescale : float
        The input is written multiplied by this factor (the returned mesh is
        the input's, unscaled).

    Returns
    -------
    (UV, V_cut, F_cut)
    """
    binary = bff_binary()
    if binary is None:
        raise Unavailable("BFF command-line tool (bff-command-line) not found: " + _BUILD_HINT
                          + ", or set NEURALUV_BFF=/path/to/bff-command-line")

    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    with tempfile.TemporaryDirectory(prefix="neuraluv_bff_") as tmp:
        tmp = Path(tmp)
        src, dst = tmp / "in.obj", tmp / "out.obj"
        _write_obj(src, V * float(prescale), F)
        cmd = [binary, str(src), str(dst)]
        if normalize:
            cmd.append("--normalizeUVs")
        if n_cones:
            cmd.append(f"--nCones={int(n_cones)}")
        if flatten_to_disk:
            cmd.append("--flattenToDisk")
        try:
            proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"bff-command-line timed out after {timeout} s") from None
        if proc.returncode != 0 or not dst.exists():
            raise RuntimeError(f"bff-command-line failed (exit {proc.returncode}): {_tail(proc)[0]}")
        Vo, Fo, UVo, FUV = read_obj(dst)
    if UVo is None or len(UVo) == 0 or FUV is None:
        raise RuntimeError("bff-command-line output has no texture coordinates")
    corner_uv = np.asarray(UVo, float)[np.asarray(FUV, np.int64)]  # (m',3,2)
    Fo = np.asarray(Fo, np.int64)
    order = _match_faces(F, Fo) if len(Vo) == len(V) else None
    if order is None:  # vertices were removed or split (non-manifold input): keep the tool's mesh
        vidx, F_cut, UV_cut = weld_corners(Fo, corner_uv.reshape(-1, 2))
        return UV_cut, np.asarray(Vo, float)[vidx], F_cut
    src_face, shift = order
    cu = np.empty((len(F), 3, 2))
    rows = np.arange(len(Fo))
    for j in range(3):  # corner j of input face src_face[t] is corner (j + shift) % 3 of output face t
        cu[src_face, j] = corner_uv[rows, (j + shift) % 3]
    vidx, F_cut, UV_cut = weld_corners(F, cu.reshape(-1, 2))
    return UV_cut, V[vidx], F_cut


def _match_faces(F, Fo):
    """For each output face: the input face with the same vertices and the corner shift, or None.

    Returns ``(src, shift)`` with ``Fo[t, (j + shift[t]) % 3] == F[src[t], j]``; None
    when the faces are not a re-ordering of the input's (same orientation).
    """
    if len(F) != len(Fo):
        return None
    key = {tuple(sorted(f)): i for i, f in enumerate(F.tolist())}
    src = np.empty(len(Fo), np.int64)
    shift = np.empty(len(Fo), np.int64)
    for t, f in enumerate(Fo.tolist()):
        i = key.get(tuple(sorted(f)))
        if i is None:
            return None
        g = F[i]
        for s in range(3):
            if f[s] == g[0] and f[(s + 1) % 3] == g[1]:
                break
        else:  # reversed orientation
            return None
        src[t], shift[t] = i, s
    if len(np.unique(src)) != len(F):
        return None
    return src, shift


def optcuts_map(V, F, *, lambda_init=0.999, distortion_bound=4.1, bijective=1, method_type=0, single_component=True,
                timeout=600):
    """OptCuts (Li et al. 2018) through its command-line binary; it re-cuts the chart.

    Runs, in a temporary working directory (OptCuts writes ``output/<run>/``)::

        OptCuts_bin 100 mesh.obj <lambda_init> 0 <method_type> <distortion_bound> <bijective> 0

    i.e. the README's ``progName mode inputMeshPath lambda_init testID
    methodType distortionBound useBijectivity initialCutOption`` with mode 100
    (headless), lambda_init 0.999 (joint optimisation, updated automatically),
    methodType 0 (OptCuts), bound 4.1 on E_SD, bijectivity on; then reads
    ``finalResult_mesh.obj`` ("input model with output UV in the original
    scale"). OptCuts' README: "OptCuts takes input meshes with only one
    connected component", so several components are an ``"init fail"``
    (``per_component=True`` runs it on each); ``single_component=False``
    hands them to the binary anyway (on Bob's three disks it converges to a
    valid map).

    Returns
    -------
    (UV, V_cut, F_cut)
    """
    binary = optcuts_binary()
    if binary is None:
        raise Unavailable("OptCuts binary (OptCuts_bin) not found: " + _BUILD_HINT
                          + ", or set NEURALUV_OPTCUTS=/path/to/OptCuts_bin; " + TRIANGLE_NOTE)

    ncomp = topology_scan(V, F).components
    if ncomp != 1 and single_component:
        raise InitFail(f"OptCuts takes one connected component (its README), the input has {ncomp}")
    with tempfile.TemporaryDirectory(prefix="neuraluv_optcuts_") as tmp:
        tmp = Path(tmp)
        (tmp / "input").mkdir()
        src = tmp / "input" / "mesh.obj"
        _write_obj(src, V, F)
        cmd = [binary, "100", str(src), str(lambda_init), "0", str(int(method_type)), str(distortion_bound),
               str(int(bijective)), "0"]
        try:
            proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"OptCuts timed out after {timeout} s") from None
        found = sorted(tmp.glob("output/**/finalResult_mesh.obj"))
        if proc.returncode != 0 or not found:
            raise RuntimeError(f"OptCuts failed (exit {proc.returncode}, no finalResult_mesh.obj): {_tail(proc)[0]}")
        Vo, Fo, UVo, FUV = read_obj(found[0])
    if UVo is None or len(UVo) == 0:
        raise RuntimeError("OptCuts output has no texture coordinates")
    if FUV is None:
        FUV = Fo
    vidx, F_cut, UV_cut = weld_corners(Fo, np.asarray(UVo, float)[np.asarray(FUV).reshape(-1)])
    return UV_cut, np.asarray(Vo, float)[vidx], F_cut
