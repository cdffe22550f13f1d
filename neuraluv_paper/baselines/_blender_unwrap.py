"""Blender UV unwrap worker: run under an interpreter that has ``bpy``.

Usage::

    python _blender_unwrap.py IN.npz OUT.npz MODE [PARAMS_JSON]

``IN.npz`` holds ``V (n,3)`` and ``F (m,3)``; ``MODE`` is ``SMART`` (Smart UV
Project) or an Unwrap method (``ANGLE_BASED``, ``CONFORMAL``,
``MINIMUM_STRETCH``); ``PARAMS_JSON`` optional operator keyword arguments.
Writes ``uv (3m,2)`` — the loop (face-corner) UVs, loop ``3t+j`` being corner
``j`` of face ``t`` — ``loop_vertex (3m,)`` and ``seconds`` (operator time) to
``OUT.npz``. Called by :func:`neuraluv_paper.baselines.blender_map`; it imports only
numpy and bpy, so it is never imported by the package itself.
"""
import json
import sys
import time

import numpy as np


def unwrap(V, F, mode, params):
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("chart")
    mesh.from_pydata([tuple(map(float, v)) for v in V], [], [tuple(map(int, f)) for f in F])
    mesh.update()
    obj = bpy.data.objects.new("chart", mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    mesh.uv_layers.new(name="UVMap")
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    t0 = time.perf_counter()
    if mode == "SMART":
        bpy.ops.uv.smart_project(**params)
    else:
        bpy.ops.uv.unwrap(method=mode, **params)
    seconds = time.perf_counter() - t0
    bpy.ops.object.mode_set(mode="OBJECT")
    n_loops = len(mesh.loops)
    uv = np.zeros(2 * n_loops)
    mesh.uv_layers.active.data.foreach_get("uv", uv)
    lv = np.zeros(n_loops, dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", lv)
    return uv.reshape(-1, 2), lv, seconds


def main(argv):
    src, dst, mode = argv[1], argv[2], argv[3]
    params = json.loads(argv[4]) if len(argv) > 4 else {}
    data = np.load(src)
    V, F = data["V"], data["F"]
    uv, lv, seconds = unwrap(V, F, mode, params)
    if len(lv) != F.size or not np.array_equal(lv, F.reshape(-1)):
        sys.exit(f"Blender changed the face corners ({len(lv)} loops for {F.size} corners)")
    np.savez(dst, uv=uv, loop_vertex=lv, seconds=seconds)


if __name__ == "__main__":
    main(sys.argv)
