"""Reading meshes and writing UV-mapped meshes and reports.

===========  =====================================================================
``mesh``     :func:`load_mesh` (trimesh; libigl for ``.mesh``), :func:`check_mesh_arrays`
``layout_file`` :func:`read_layout` (a UV layout from an OBJ or glTF, as the CLI reads it),
             :func:`layout_materials`, :func:`obj_material_maps`
``obj``      :func:`read_obj` (strict), :func:`write_obj`, :func:`patch_obj` (only changed lines)
``gltf``     :func:`read_gltf_layout` (a UV set of every textured primitive, where its textures sample it)
``gltf_write`` :func:`write_gltf_uvs` (a ``.glb`` / ``.gltf`` copy that differs only in that UV set, or in an
             added one), :func:`write_gltf` (a document as ``.glb`` or as ``.gltf`` with its ``.bin``)
``gltf_extensions`` :func:`texture_transform` (``KHR_texture_transform`` as a map of UVs); compressed
             geometry (Draco, meshopt) refused by name
``files``    :func:`atomic_write`, :func:`staged_outputs` (several outputs as one), :func:`jsonable`, :func:`write_json`, :func:`write_csv`
===========  =====================================================================

Every writer is atomic: a file is first written next to its destination and then
renamed, so an interrupted run never leaves a half-written output behind.
"""
from __future__ import annotations

from neuraluv.lazy import lazy_exports

#: File extensions :func:`~neuraluv.io.mesh.load_mesh` reads.
MESH_EXTENSIONS = (".obj", ".off", ".ply", ".stl", ".glb", ".gltf", ".mesh")

#: name -> module of this package that defines it (imported on first use: the command line checks paths
#: against :data:`MESH_EXTENSIONS` without loading numpy).
_WHERE = {"atomic_write": "files", "staged_outputs": "files", "jsonable": "files", "write_json": "files", "write_csv": "files",
          "check_mesh_arrays": "mesh", "load_mesh": "mesh",
          "read_layout": "layout_file", "layout_materials": "layout_file", "obj_material_maps": "layout_file",
          "ObjData": "obj", "read_obj": "obj", "write_obj": "obj", "patch_obj": "obj",
          "GltfLayout": "gltf", "read_gltf_layout": "gltf", "write_gltf_uvs": "gltf_write", "write_gltf": "gltf_write",
          "load_gltf": "gltf",
          "texture_transform": "gltf_extensions"}

__all__ = ["MESH_EXTENSIONS", *_WHERE]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, globals())
