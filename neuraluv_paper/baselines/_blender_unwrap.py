"""Blender UV unwrap (and pack) worker: run under an interpreter that has ``bpy``.

Usage::

    python _blender_unwrap.py IN.npz OUT.npz MODE [PARAMS_JSON]

``IN.npz`` holds ``V (n,3)`` and ``F (m,3)``, and for ``MODE`` ``NONE`` also
``uv (3m,2)``, the loop UVs to start from; ``MODE`` is ``SMART`` (Smart UV
Project), an Unwrap method (``ANGLE_BASED``, ``CONFORMAL``,
``MINIMUM_STRETCH``) or ``NONE`` (no unwrap: the given UVs). ``PARAMS_JSON``
holds optional operator keyword arguments; its key ``"pack"``, when present,
holds the keyword arguments of ``bpy.ops.uv.pack_islands``, run after the
unwrap on every face. Writes ``uv (3m,2)`` — the loop (face-corner) UVs, loop
``3t+j`` being corner ``j`` of face ``t`` — ``loop_vertex (3m,)``, ``seconds``
(unwrap operator time) and ``pack_seconds`` (pack operator time, NaN without
``"pack"``) and ``version`` (Blender's) to ``OUT.npz``. Called by :func:`neuraluv_paper.baselines.external.blender_run`;
it imports only numpy and bpy, so it is never imported by the package itself.
"""
import json
import sys
import time

import numpy as np


def unwrap(V, F, mode, params, uv=None, pack=None):
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
    if uv is not None:
        mesh.uv_layers.active.data.foreach_set("uv", np.asarray(uv, np.float32).ravel())
    bpy.context.scene.tool_settings.use_uv_select_sync = True  # every selected face's UVs are selected
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    t0 = time.perf_counter()
    if mode == "SMART":
        bpy.ops.uv.smart_project(**params)
    elif mode != "NONE":
        bpy.ops.uv.unwrap(method=mode, **params)
    seconds = time.perf_counter() - t0
    pack_seconds = float("nan")
    if pack is not None:
        t0 = time.perf_counter()
        bpy.ops.uv.pack_islands(**pack)
        pack_seconds = time.perf_counter() - t0
    bpy.ops.object.mode_set(mode="OBJECT")
    n_loops = len(mesh.loops)
    out = np.zeros(2 * n_loops)
    mesh.uv_layers.active.data.foreach_get("uv", out)
    lv = np.zeros(n_loops, dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", lv)
    return out.reshape(-1, 2), lv, seconds, pack_seconds


def main(argv):
    src, dst, mode = argv[1], argv[2], argv[3]
    params = json.loads(argv[4]) if len(argv) > 4 else {}
    pack = params.pop("pack", None)
    data = np.load(src)
    V, F = data["V"], data["F"]
    uv, lv, seconds, pack_seconds = unwrap(V, F, mode, params, data["uv"] if "uv" in data else None, pack)
    if len(lv) != F.size or not np.array_equal(lv, F.reshape(-1)):
        sys.exit(f"Blender changed the face corners ({len(lv)} loops for {F.size} corners)")
    import bpy

    np.savez(dst, uv=uv, loop_vertex=lv, seconds=seconds, pack_seconds=pack_seconds, version=bpy.app.version_string)


if __name__ == "__main__":
    main(sys.argv)
