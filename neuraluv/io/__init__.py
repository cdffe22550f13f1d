"""Reading meshes and writing UV-mapped meshes and reports.

===========  =====================================================================
``mesh``     :func:`load_mesh` (trimesh; libigl for ``.mesh``), :func:`check_mesh_arrays`
``obj``      :func:`read_obj` (strict), :func:`write_obj`, :func:`patch_obj` (only changed lines)
``files``    :func:`atomic_write`, :func:`jsonable`, :func:`write_json`, :func:`write_csv`
===========  =====================================================================

Every writer is atomic: a file is first written next to its destination and then
renamed, so an interrupted run never leaves a half-written output behind.
"""
from neuraluv.io.files import atomic_write, jsonable, write_csv, write_json
from neuraluv.io.mesh import MESH_EXTENSIONS, check_mesh_arrays, load_mesh
from neuraluv.io.obj import ObjData, patch_obj, read_obj, write_obj

__all__ = ["MESH_EXTENSIONS", "ObjData", "load_mesh", "write_obj", "read_obj", "patch_obj", "atomic_write",
           "check_mesh_arrays", "jsonable", "write_json", "write_csv"]
