"""Unwrap a whole input mesh: repair, split into charts, solve each, lay out.

An input with several connected components (like Bob) is solved chart by chart;
the charts are then laid side by side in ``[0,1]²`` by the shelf packer. Every
component must be disk-like; for closed or higher-genus inputs use the atlas
pipeline, which cuts seams first.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from neuraluv import __version__
from neuraluv.errors import TopologyError
from neuraluv.io import check_mesh_arrays, jsonable
from neuraluv.layout.pack.shelf import shelf_pack
from neuraluv.meshfix import RepairReport, is_triangle_soup, repair_mesh
from neuraluv.metrics import distortion_metrics
from neuraluv.solver.chart import ChartResult, solve_charts
from neuraluv.solver.config import get_config
from neuraluv.solver.device import resolve_device
from neuraluv.topology import TopologyReport, components, is_disk_like, topology_scan

__all__ = ["UnwrapResult", "unwrap"]


@dataclass
class UnwrapResult:
    """A solved input mesh.

    Attributes
    ----------
    V : (n,3) float array, the repaired input positions.
    F : (m,3) int array.
    UV : (n,2) float array in ``[0,1]²`` (charts laid side by side).
    charts : list of ChartResult, one per component (UVs at 3D scale).
    chart_vertices, chart_faces : lists of index arrays into ``V`` and ``F``.
    metrics : metrics of the packed layout over all faces (flips etc.).
    """

    V: np.ndarray
    F: np.ndarray
    UV: np.ndarray
    charts: list
    chart_vertices: list
    chart_faces: list
    metrics: dict
    repair: RepairReport
    topology: TopologyReport
    preset: str
    device: str
    time: float
    utilisation: float = float("nan")
    extra: dict = field(default_factory=dict)

    @property
    def valid(self):
        return bool(self.metrics.get("valid", False))

    def report(self):
        """The JSON report: per chart metrics at the chart's 3D scale, status, time."""
        charts = []
        for i, (c, vi, fi) in enumerate(zip(self.charts, self.chart_vertices, self.chart_faces)):
            d = c.summary()
            d.update({"chart": i, "vertices": int(len(vi)), "faces": int(len(fi))})
            charts.append(d)
        flips = sum(c.metrics["flips"] for c in self.charts)
        return jsonable({
            "neuraluv": __version__,
            "preset": self.preset,
            "device": self.device,
            "time": self.time,
            "vertices": int(len(self.V)),
            "faces": int(len(self.F)),
            "repair": self.repair.as_dict(),
            "topology": self.topology.as_dict(),
            "charts": charts,
            "totals": {
                "charts": len(self.charts),
                "neural": sum(c.status == "neural" for c in self.charts),
                "fallback": sum(c.status != "neural" for c in self.charts),
                "flips": flips,
                "layout_flips": self.metrics["flips"],
                "uv_in_unit_square": bool(np.all((self.UV >= 0) & (self.UV <= 1))),
                "utilisation": self.utilisation,
            },
        })


#: After welding, more charts than this (and than 2% of the faces) are "fragments": `atlas` is the tool.
MAX_CHARTS = 64


def unwrap(V, F, preset="fast", *, seed=0, device="auto", progress=False, padding=2.0, resolution=1024,
           time_budget=None, **overrides):
    """Unwrap every connected component of a mesh and pack the charts.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    preset : str or SolverConfig
        Solver preset (``"fast"``, ``"paper"``, ...).
    seed : int
    device : str
    progress : bool
    padding, resolution : float, int
        Gap between packed charts in texels at ``resolution``.
    time_budget : float, optional
        Seconds after which every solve stops with its best valid map.
    **overrides
        SolverConfig field overrides.

    Returns
    -------
    UnwrapResult

    Raises
    ------
    TopologyError
        When a component is not disk-like (the message names it and says why),
        or the input falls apart into many small pieces (then ``atlas`` is the tool).

    Notes
    -----
    Seams are kept: coincident but distinct vertices are the seams of a supplied
    chart (Bob's three charts touch along their seams). Only a *triangle soup*
    (:func:`neuraluv.meshfix.is_triangle_soup`: many components, as in an STL
    file) is welded first (``repair.merged_vertices`` counts it).

    Examples
    --------
    >>> from neuraluv.datasets import several_components
    >>> res = unwrap(*several_components(4), "test", device="cpu")
    >>> len(res.charts), res.metrics["flips"], bool(res.UV.min() >= 0 and res.UV.max() <= 1)
    (3, 0, True)
    """
    t0 = time.perf_counter()
    V, F = check_mesh_arrays(V, F)
    weld = is_triangle_soup(len(components(V, F)), len(F))
    V, F, rep, _ = repair_mesh(V, F, weld=weld)
    if len(F) == 0:
        raise TopologyError("no usable faces left after removing degenerate ones")
    topo = topology_scan(V, F)
    parts = components(V, F)
    if len(parts) > max(MAX_CHARTS, len(F) // 50):
        raise TopologyError(f"the input falls apart into {len(parts)} pieces{' even after welding' if weld else ''} "
                            f"(a triangle soup or fragments): use `neuraluv atlas`, which repairs, cuts, routes and packs them")
    for i, (vi, fi, Fc) in enumerate(parts):
        ok, why = is_disk_like(V[vi], Fc)
        if not ok:
            what = "input" if len(parts) == 1 else f"component {i} ({len(fi)} faces)"
            hint = "" if "atlas" in why else "; `neuraluv atlas` cuts such meshes into charts"
            raise TopologyError(f"{what} is not disk-like: {why}{hint}")
    cfg = get_config(preset, **overrides)
    deadline = None if not time_budget else t0 + float(time_budget)
    charts: list[ChartResult] = solve_charts([(V[vi], Fc) for vi, _, Fc in parts], cfg, seed=seed, device=device,
                                             progress=progress, labels=[f"chart {i}" for i in range(len(parts))],
                                             check=False, deadline=deadline)
    packed = shelf_pack([c.uv for c in charts], [p[2] for p in parts], padding=padding, resolution=resolution)
    UV = np.zeros((len(V), 2))
    for (vi, _, _), uv in zip(parts, packed.uvs):
        UV[vi] = uv
    UV = np.clip(UV, 0.0, 1.0)  # guards only round-off at the border
    return UnwrapResult(
        V=V, F=F, UV=UV, charts=charts,
        chart_vertices=[p[0] for p in parts], chart_faces=[p[1] for p in parts],
        metrics=distortion_metrics(V, F, UV), repair=rep, topology=topo,
        preset=preset if isinstance(preset, str) else "custom", device=str(resolve_device(device)),
        time=time.perf_counter() - t0, utilisation=packed.utilisation,
    )
