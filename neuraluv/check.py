"""Pre-flight check: what is wrong with a mesh, what it means for unwrapping,
and which repair the atlas pipeline will apply.

The counts come from :func:`neuraluv.topology.topology_scan` (on the raw
arrays) and :func:`neuraluv.meshfix.repair_mesh` (with welding, as the atlas
pipeline runs it); nothing is modified.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from neuraluv.io import check_mesh_arrays
from neuraluv.meshfix import is_triangle_soup, repair_mesh
from neuraluv.topology import components, is_disk_like, topology_scan

__all__ = ["Finding", "CheckReport", "check_mesh", "format_report"]


@dataclass
class Finding:
    """One issue: how many, what it means for unwrapping, what the pipeline does."""

    kind: str
    count: int
    meaning: str
    repair: str
    severity: str = "warning"  # "info", "warning" or "error"

    def as_dict(self):
        return {"kind": self.kind, "count": int(self.count), "severity": self.severity,
                "meaning": self.meaning, "repair": self.repair}


@dataclass
class CheckReport:
    """Result of :func:`check_mesh`."""

    vertices: int
    faces: int
    components: int
    boundary_loops: int
    genus: int | None
    euler_characteristic: int
    disk_like: bool
    disk_reason: str
    findings: list = field(default_factory=list)
    raw_components: int = 0
    unwrap_charts: list = field(default_factory=list)
    unwrap_welds: bool = False

    @property
    def ok_for_unwrap(self):
        """True when ``neuraluv unwrap`` accepts the mesh: every component it sees is a disk."""
        return bool(self.unwrap_charts) and all(c["disk"] for c in self.unwrap_charts)

    def as_dict(self):
        return {
            "vertices": self.vertices, "faces": self.faces, "components": self.components,
            "boundary_loops": self.boundary_loops, "genus": self.genus,
            "euler_characteristic": self.euler_characteristic, "disk_like": self.disk_like,
            "disk_reason": self.disk_reason, "ok_for_unwrap": self.ok_for_unwrap,
            "raw_components": self.raw_components,
            "unwrap_view": {"welded": self.unwrap_welds, "charts": self.unwrap_charts},
            "findings": [f.as_dict() for f in self.findings],
        }


def check_mesh(V, F):
    """Scan a mesh and explain each finding.

    Raw-array problems (degenerate, duplicate, unwelded, unreferenced) are
    counted on the input; structural ones (components, boundary loops, genus,
    non-manifold, winding) on the welded, degenerate-free mesh that the atlas
    pipeline charts, so a triangle soup reports the surface it encodes.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array

    Returns
    -------
    CheckReport

    Raises
    ------
    MeshLoadError
        Empty arrays, non-triangles, NaN coordinates, indices out of range.

    Examples
    --------
    >>> from neuraluv.datasets import sphere
    >>> r = check_mesh(*sphere(1))
    >>> r.components, r.boundary_loops, r.genus, [f.kind for f in r.findings]
    (1, 0, 0, ['closed surface'])
    """
    V, F = check_mesh_arrays(V, F)
    raw = topology_scan(V, F)
    Vw, Fw, rep, _ = repair_mesh(V, F, weld=True)
    Vn, Fn, rep_nw, _ = repair_mesh(V, F, weld=False)
    # structural findings refer to the welded, degenerate-free mesh the atlas pipeline charts
    topo = topology_scan(Vw, Fw) if len(Fw) else raw
    # the charts `unwrap` sees: seams kept, unless the input is a triangle soup (then welded, as unwrap does)
    welds = is_triangle_soup(raw.components, len(F))
    Vu, Fu = (Vw, Fw) if welds else (Vn, Fn)
    charts = []
    for vi, fi, Fc in (components(Vu, Fu) if len(Fu) else []):
        ok_c, why_c = is_disk_like(Vu[vi], Fc)
        charts.append({"faces": int(len(fi)), "disk": bool(ok_c), "reason": why_c})
    ok = bool(charts) and all(c["disk"] for c in charts)
    why = "disk" if ok else (next((c["reason"] for c in charts if not c["disk"]), "no faces"))
    out = []

    def add(kind, count, meaning, repair, severity="warning"):
        if count:
            out.append(Finding(kind, int(count), meaning, repair, severity))

    add("degenerate faces", rep_nw.degenerate_faces,
        "zero-area or repeated-corner triangles have no well-defined Jacobian (det J = 0): they would count as flips",
        "removed before charting (coverage is measured on the repaired faces)")
    add("duplicate faces", rep_nw.duplicate_faces,
        "the same triangle twice (either winding) makes its edges non-manifold and overlaps itself in UV",
        "the first copy is kept, the others removed")
    add("unwelded vertices", rep.merged_vertices,
        "coincident but distinct vertices cut the surface into a triangle soup: every face would become its own chart",
        "welded (tolerance 1e-10 of the bounding-box diagonal) before charting; `unwrap` keeps them as seams")
    if len(Fw):
        P = Vw[Fw]
        edge = np.linalg.norm(P[:, [1, 2, 0]] - P, axis=2).max(1)
        area2 = np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
        diag = float(np.linalg.norm(Vw.max(0) - Vw.min(0))) or 1.0
        add("sliver faces", int((~(area2 >= 1e-6 * diag * edge)).sum()),
            "needles thinner than 1e-6 of the diagonal: float32 UVs (GLB, GPUs) cannot keep them flip-free",
            "removed like degenerate faces (atlas --min-height)")
    add("non-manifold edges", topo.nonmanifold_edges,
        "edges shared by more than two faces cannot be flattened as one sheet",
        "split apart with igl.split_nonmanifold (faces on a non-manifold edge end up in different charts)", "error")
    add("non-manifold vertices", topo.nonmanifold_vertices,
        "bow-tie vertices join fans that only touch at a point; a disk chart cannot contain them",
        "the vertex is duplicated per fan (igl.split_nonmanifold)", "error")
    add("inconsistent winding", topo.inconsistent_edges,
        "neighbouring faces wound in opposite directions: a flip-free map would need det J > 0 and < 0 at once",
        "each component re-oriented by BFS (igl.bfs_orient), keeping the majority winding", "error")
    add("unreferenced vertices", raw.unreferenced_vertices,
        "vertices used by no face carry no UV", "dropped", "info")
    if topo.components > 1:
        small = sum(1 for c in topo.component_faces if c < 3)
        add("multiple components", topo.components,
            f"each component becomes at least one chart ({small} with fewer than 3 faces: floating fragments)",
            "charted separately; fragments below 3 faces get an exact per-face/PCA unfold (marked fallback)", "info")
    if topo.boundary_loops == 0 and topo.n_faces:
        add("closed surface", max(topo.components, 1),
            "a closed surface has no boundary to pin: it must be cut into disks before flattening",
            "seams from xatlas charting; pieces that are still not disks are bisected", "info")
    if topo.genus:
        add("handles (genus)", topo.genus,
            "each handle needs two seams through it before the surface is a disk",
            "seams from xatlas charting", "info")
    if topo.boundary_loops > 1:
        add("extra boundary loops", topo.boundary_loops - topo.components,
            "holes: a chart with several boundary loops is an annulus, not a disk",
            "seams from xatlas charting join or separate the holes", "info")
    return CheckReport(
        vertices=int(len(V)), faces=int(len(F)), components=topo.components, boundary_loops=topo.boundary_loops,
        genus=topo.genus, euler_characteristic=topo.euler_characteristic, disk_like=bool(ok), disk_reason=why,
        findings=out, raw_components=raw.components, unwrap_charts=charts, unwrap_welds=welds,
    )


def format_report(r, name="mesh"):
    """Human-readable text of a :class:`CheckReport`."""
    g = "n/a (non-manifold or unoriented)" if r.genus is None else str(r.genus)
    ch = r.unwrap_charts
    n_disk = sum(c["disk"] for c in ch)
    lines = [
        f"{name}: {r.vertices} vertices, {r.faces} faces",
        f"as `unwrap` sees it ({'welded: a triangle soup' if r.unwrap_welds else 'seams kept'}): {len(ch)} chart(s), "
        f"{n_disk} disk-like" + ("" if n_disk == len(ch) else "; " + "; ".join(
            f"chart {i} ({c['faces']} faces) is not a disk: {c['reason']}" for i, c in enumerate(ch) if not c["disk"])[:300]),
        f"as `atlas` sees it (welded): {r.components} component(s), {r.boundary_loops} boundary loop(s), genus {g}, "
        f"Euler characteristic {r.euler_characteristic}",
    ]
    if not r.findings:
        lines.append("no issues found")
    else:
        lines.append("findings (counts on the input; topology on the welded mesh `atlas` charts):")
    for f in r.findings:
        lines.append(f"[{f.severity}] {f.kind}: {f.count}")
        lines.append(f"    means:  {f.meaning}")
        lines.append(f"    repair: {f.repair}")
    lines.append("next: `neuraluv unwrap` (every chart is a disk, kept as it is) or `neuraluv atlas` (its own seams)"
                 if r.ok_for_unwrap else "next: `neuraluv atlas` repairs, cuts seams and routes charts")
    return "\n".join(lines)
