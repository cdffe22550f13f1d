"""External tools as baselines: xatlas, Blender (``bpy`` in its own environment), OptCuts and the BFF binary."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from neuraluv.baselines.common import InitFail, Unavailable, weld_corners
from neuraluv.topology import topology_scan

__all__ = ["xatlas_map", "BLENDER_MODES", "blender_python", "blender_map", "optcuts_binary", "optcuts_map"]



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
    ``bpy`` installed.
    """
    env = os.environ.get("NEURALUV_BPY_PYTHON")
    if env:
        return env if Path(env).exists() else None
    import importlib.util

    return sys.executable if importlib.util.find_spec("bpy") is not None else None


def blender_map(V, F, mode="SMART", *, timeout=600, **params):
    """Blender's UV unwrap in a subprocess; per-corner UVs on the exploded mesh.

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

    Notes
    -----
    The script :mod:`neuraluv.baselines._blender_unwrap` runs under the interpreter
    returned by :func:`blender_python` (``bpy`` is ~370 MB and kept out of the
    main environment).
    """
    import json

    py = blender_python()
    if py is None:
        raise Unavailable("Blender's bpy module not found: `python -m venv /tmp/bpyvenv && /tmp/bpyvenv/bin/pip install "
                          "'bpy==4.5.*' numpy`, then set NEURALUV_BPY_PYTHON=/tmp/bpyvenv/bin/python")
    script = Path(__file__).with_name("_blender_unwrap.py")
    with tempfile.TemporaryDirectory(prefix="neuraluv_bpy_") as tmp:
        src, dst = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        np.savez(src, V=np.asarray(V, float), F=np.asarray(F, np.int64))
        cmd = [py, str(script), str(src), str(dst), mode, json.dumps(params)]
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"Blender {mode} timed out after {timeout} s") from None
        if proc.returncode != 0 or not dst.exists():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["no output"]
            raise RuntimeError(f"Blender {mode} failed (exit {proc.returncode}): {tail[0]}")
        out = np.load(dst)
        UV, secs = np.asarray(out["uv"], float), float(out["seconds"])
    m = len(F)
    if UV.shape != (3 * m, 2):
        raise RuntimeError(f"Blender returned {UV.shape} loop UVs for {m} faces")
    vidx, F_cut, UV_cut = weld_corners(F, UV)
    return UV_cut, np.asarray(V, float)[vidx], F_cut, secs



def optcuts_binary():
    """Path of the OptCuts binary: ``$NEURALUV_OPTCUTS`` or ``OptCuts_bin`` on PATH, or None."""
    env = os.environ.get("NEURALUV_OPTCUTS")
    if env:
        return env if Path(env).exists() else None
    return shutil.which("OptCuts_bin")


def optcuts_map(V, F, *, lambda_init=0.999, distortion_bound=4.1, bijective=1, method_type=0, timeout=600):
    """OptCuts (Li et al. 2018) through its command-line binary; it re-cuts the chart.

    Runs, in a temporary working directory (OptCuts writes ``output/<run>/``)::

        OptCuts_bin 100 mesh.obj <lambda_init> 0 <method_type> <distortion_bound> <bijective> 0

    i.e. the README's ``progName mode inputMeshPath lambda_init testID
    methodType distortionBound useBijectivity initialCutOption`` with mode 100
    (headless), lambda_init 0.999 (joint optimisation, updated automatically),
    methodType 0 (OptCuts), bound 4.1 on E_SD, bijectivity on; then reads
    ``finalResult_mesh.obj`` ("input model with output UV in the original
    scale"). OptCuts accepts one connected component only, so several
    components are an ``"init fail"`` (use ``per_component=True``).

    Returns
    -------
    (UV, V_cut, F_cut)
    """
    binary = optcuts_binary()
    if binary is None:
        raise Unavailable("OptCuts binary not found: install OptCuts (github.com/liminchen/OptCuts) and set "
                          "NEURALUV_OPTCUTS=/path/to/OptCuts_bin")
    from neuraluv.io import atomic_write, read_obj

    ncomp = topology_scan(V, F).components
    if ncomp != 1:
        raise InitFail(f"OptCuts takes one connected component, the input has {ncomp}")
    with tempfile.TemporaryDirectory(prefix="neuraluv_optcuts_") as tmp:
        tmp = Path(tmp)
        (tmp / "input").mkdir()
        src = tmp / "input" / "mesh.obj"
        with atomic_write(src) as fh:
            fh.write("".join(f"v {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in np.asarray(V, float)))
            fh.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in np.asarray(F, np.int64)))
        cmd = [binary, "100", str(src), str(lambda_init), "0", str(int(method_type)), str(distortion_bound),
               str(int(bijective)), "0"]
        try:
            proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"OptCuts timed out after {timeout} s") from None
        found = sorted(tmp.glob("output/**/finalResult_mesh.obj"))
        if proc.returncode != 0 or not found:
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["no output"]
            raise RuntimeError(f"OptCuts failed (exit {proc.returncode}, no finalResult_mesh.obj): {tail[0]}")
        Vo, Fo, UVo, FUV = read_obj(found[0])
    if UVo is None or len(UVo) == 0:
        raise RuntimeError("OptCuts output has no texture coordinates")
    if FUV is None:
        FUV = Fo
    vidx, F_cut, UV_cut = weld_corners(Fo, np.asarray(UVo, float)[np.asarray(FUV).reshape(-1)])
    return UV_cut, np.asarray(Vo, float)[vidx], F_cut
