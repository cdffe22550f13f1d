"""Blender 4.5 and xatlas beside ``neuraluv atlas`` in ``bench speed --atlas`` (issue 28, items 1 and 4).

* :func:`blender_atlas` — Blender's whole-mesh atlas: Smart UV Project with the
  operator's defaults (as the ``blender-smart`` baseline runs it) and then
  ``uv.pack_islands`` with our padding, both timed inside the Blender process.
* :func:`packer_reference` — the islands of one of our atlases (as read from its
  OBJ) packed afresh by our packer, by xatlas's packer and by Blender's
  ``uv.pack_islands``, at one resolution and padding.

Every layout is measured by :func:`~neuraluv_paper.bench.atlas_quality.measure_layout`
(utilisation = summed UV triangle area over the texture; flips, overlaps and gaps by
:func:`~neuraluv.layout.validate_layout`, as our command validates what it wrote).

Padding: ours is the smallest gap between two islands (and to the border), in texels at
the resolution. Blender's ``margin_method="FRACTION"`` margin is a fraction of the
output kept around each island, so two islands end ``2 × margin`` apart: it is asked
for ``padding / (2 · resolution)`` (the border then gets half our padding), plus a hundredth
of a texel for its float32 UVs (:func:`blender_pack_options`). xatlas's
``padding`` (texels) dilates every chart, so it is asked for half the padding too.
"""
from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np

from neuraluv.layout.facts import uv_islands
from neuraluv.layout.pack import FLOAT32_SLACK, tight_pack
from neuraluv_paper.baselines.common import Unavailable, weld_corners
from neuraluv_paper.baselines.external import blender_run
from neuraluv_paper.bench.atlas_quality import measure_layout
from neuraluv_paper.bench.generated import chart_mesh_of
from neuraluv_paper.bench.provenance import fmt_num, fmt_pct, markdown_table

__all__ = ["blender_pack_options", "blender_atlas", "island_list", "packer_reference", "packers_markdown",
           "PACKER_LABELS"]

#: Row labels of :func:`packer_reference`, with the moves each packer may make.
PACKER_LABELS = {"ours": "ours (`tight_pack`: shapes, quarter/eighth turns)",
                 "xatlas": "xatlas packer (`add_uv_mesh` + `generate`, no transpose)",
                 "blender": "Blender `uv.pack_islands` (concave shapes, 90° steps)"}


def blender_pack_options(resolution, padding):
    """``bpy.ops.uv.pack_islands`` keywords for our padding: gaps of ``padding`` texels at ``resolution``
    (and :data:`~neuraluv.layout.pack.FLOAT32_SLACK`: Blender places gaps at its margin exactly, and its
    float32 UVs then fall ~1e-4 texel short), rotations by 90° steps only (``CARDINAL``; the operator never
    mirrors), islands' shapes (``CONCAVE``).

    Examples
    --------
    >>> round(blender_pack_options(1024, 4)["margin"] * 2 * 1024, 6)
    4.01
    """
    return dict(margin=(padding + FLOAT32_SLACK) / (2.0 * resolution), margin_method="FRACTION", rotate=True,
                rotate_method="CARDINAL", scale=True, shape_method="CONCAVE")


def _unavailable(exc):
    return {"status": "unavailable", "reason": str(exc).splitlines()[0][:200]}


def _failed(exc):
    return {"status": "failed", "reason": (str(exc).splitlines() or [type(exc).__name__])[0][:200]}


def blender_atlas(V, F, resolution, padding, *, timeout=1800):
    """Blender's atlas of a mesh: Smart UV Project (operator defaults) + ``uv.pack_islands`` with our padding.

    Returns
    -------
    dict
        ``status`` (``ok``, ``unavailable`` or ``failed`` with a one-line ``reason``); when ``ok``:
        ``version`` (Blender's), ``unwrap_s`` and ``pack_s`` (each operator's time inside Blender),
        ``process_s`` (the whole Blender process, from start to exit) and
        :func:`~neuraluv_paper.bench.atlas_quality.measure_layout`'s numbers of the layout read back (on
        the input mesh, the loop UVs welded per vertex).
    """
    F = np.asarray(F, np.int64)
    try:
        r = blender_run(V, F, "SMART", pack=blender_pack_options(resolution, padding), timeout=timeout)
    except Unavailable as exc:
        return _unavailable(exc)
    except RuntimeError as exc:
        return _failed(exc)
    vidx, Fc, UV = weld_corners(F, r["uv"])
    return {"status": "ok", "version": r["version"], "unwrap_s": r["seconds"], "pack_s": r["pack_seconds"],
            "process_s": r["wall"],
            **measure_layout(V, vidx[Fc], UV, Fc, resolution, padding)}


def island_list(UV, FUV):
    """A layout's UV islands (faces joined through shared ``vt`` rows) as the packers take them.

    Returns
    -------
    uvs : list of (n_i,2) float arrays
        Each island's ``vt`` rows.
    tris : list of (m_i,3) int arrays
        Its faces, indexing its own rows.
    rows : list of (n_i,) int arrays
        The rows of ``UV`` each island holds.

    Examples
    --------
    >>> uvs, tris, rows = island_list(np.eye(3)[:, :2].repeat(2, 0), np.array([[0, 2, 4], [1, 3, 5]]))
    >>> [t.tolist() for t in tris], [r.tolist() for r in rows]
    ([[[0, 1, 2]], [[0, 1, 2]]], [[0, 2, 4], [1, 3, 5]])
    """
    FUV = np.asarray(FUV, np.int64)
    n, lab = uv_islands(FUV)
    uvs, tris, rows = [], [], []
    for j in range(n):
        fj = np.flatnonzero(lab == j)
        r = np.unique(FUV[fj])
        uvs.append(np.asarray(UV, float)[r])
        tris.append(np.searchsorted(r, FUV[fj]))
        rows.append(r)
    return uvs, tris, rows


def _xatlas_pack_as_is(UV, FUV, resolution, padding):
    """xatlas's packer on the islands as laid out (one call): (UV, FUV, seconds, page width × height)."""
    import xatlas

    t = time.perf_counter()
    at = xatlas.Atlas()
    at.add_uv_mesh(np.asarray(UV, np.float32), np.asarray(FUV, np.uint32))
    po = xatlas.PackOptions()
    po.padding = int(np.ceil(padding / 2))  # xatlas dilates both neighbours
    po.resolution = int(resolution)
    po.bilinear = True
    po.rotate_charts = False  # xatlas's 90° "rotation" is a transpose: a mirror image
    at.generate(xatlas.ChartOptions(), po)
    secs = time.perf_counter() - t
    if at.atlas_count != 1:
        raise ValueError(f"xatlas needed {at.atlas_count} pages")
    _, ind, uv = at[0]
    side = max(at.width, at.height)  # the square texture of the larger side (> resolution: padding shrinks)
    return np.asarray(uv, float) * [at.width / side, at.height / side], np.asarray(ind, np.int64), secs, \
        (int(at.width), int(at.height))


def packer_reference(V, F, UV, FUV, resolution, padding, *, blender=True):
    """The islands of a layout packed afresh by ours, xatlas's and Blender's packers, measured alike.

    Parameters
    ----------
    V, F : the mesh (as in the layout's file)
    UV, FUV : its layout (e.g. a ``neuraluv atlas`` OBJ): the islands are its ``vt``-connected faces,
        packed whole (never cut) and at their relative scales.
    resolution : int
    padding : float
        Smallest gap between islands, texels at ``resolution``.
    blender : bool
        Also Blender's ``uv.pack_islands`` (a row ``unavailable`` without ``bpy``).

    Returns
    -------
    list of dict
        One per packer (``packer`` a key of :data:`PACKER_LABELS`): ``status``, ``seconds`` (the packer
        alone, in its process), for Blender also ``process_s``, and
        :func:`~neuraluv_paper.bench.atlas_quality.measure_layout`'s numbers of the packed layout.
    """
    F, FUV = np.asarray(F, np.int64), np.asarray(FUV, np.int64)
    uvs, tris, rows = island_list(UV, FUV)
    base = {"islands_in": len(uvs), "faces": int(len(F))}
    out = []
    t = time.perf_counter()
    pk = tight_pack(uvs, tris, padding=padding, resolution=resolution)
    secs = time.perf_counter() - t
    UVo = np.zeros((len(UV), 2))
    for r, u in zip(rows, pk.uvs):
        UVo[r] = u
    out.append({"packer": "ours", **base, "status": "ok", "seconds": secs, "used": pk.packer,
                **measure_layout(V, F, UVo, FUV, resolution, padding)})
    try:
        UVx, FUVx, secs, page = _xatlas_pack_as_is(UV, FUV, resolution, padding)
        if len(FUVx) != len(F):
            raise ValueError(f"xatlas returned {len(FUVx)} faces for {len(F)}")
        out.append({"packer": "xatlas", **base, "status": "ok", "seconds": secs, "page": f"{page[0]}×{page[1]}",
                    **measure_layout(V, F, UVx, FUVx, resolution, padding)})
    except (ImportError, ValueError) as exc:
        out.append({"packer": "xatlas", **base, **_failed(exc)})
    if blender:
        Vc, Fc = chart_mesh_of(SimpleNamespace(V=V, F=F, FUV=FUV))  # one Blender vertex per vt row: our islands
        try:
            r = blender_run(Vc, Fc, "NONE", uv=np.asarray(UV, float)[Fc].reshape(-1, 2),
                            pack=blender_pack_options(resolution, padding))
        except Unavailable as exc:
            out.append({"packer": "blender", **base, **_unavailable(exc)})
        except RuntimeError as exc:
            out.append({"packer": "blender", **base, **_failed(exc)})
        else:
            _, Fb, UVb = weld_corners(Fc, r["uv"])
            out.append({"packer": "blender", **base, "status": "ok", "seconds": r["pack_seconds"],
                        "process_s": r["wall"], **measure_layout(V, F, UVb, Fb, resolution, padding)})
    return out


def packers_markdown(results, resolution, padding):
    """The packer table: ``results`` maps a mesh name to :func:`packer_reference`'s rows."""
    head = ["mesh", "islands", "packer", "seconds", "utilisation", "min gap (tx)", "padding viol.", "flips",
            "mirrored", "overlaps", "density spread"]
    body, notes = [], []
    for mesh, rows in results.items():
        for r in rows:
            label = PACKER_LABELS[r["packer"]]
            if r["status"] != "ok":
                body.append([mesh, r["islands_in"], label, f"{r['status']}: {r['reason']}"] + [""] * (len(head) - 4))
                continue
            secs = fmt_num(r["seconds"]) + (f" (process {r['process_s']:.1f})" if "process_s" in r else "")
            body.append([mesh, r["islands"], label, secs, fmt_pct(100 * r["utilisation"]), fmt_num(r["min_gap_texels"]),
                         r["padding_violations"], r["flips"], r["mirrored_islands"],
                         f"{r['overlapping_pairs']} / {r['self_overlapping_islands']}",
                         fmt_pct(100 * r["density_spread"])])
            if r["packer"] == "xatlas" and r.get("page") != f"{resolution}×{resolution}":
                notes.append(f"xatlas's page for {mesh} was {r['page']} texels, scaled into the {resolution}² square.")
    return "\n".join([
        f"**Packers on our islands** (the `vt`-connected islands of each `neuraluv atlas` OBJ above, packed whole "
        f"and afresh at resolution {resolution} with {padding:g} texels of padding; every layout measured alike: "
        "utilisation = UV area over the texture, overlaps = island pairs / self-overlapping islands). Seconds: the "
        "packer alone (Blender: its operator inside the Blender process; the process, with start-up, in brackets). "
        f"Blender is asked for a `FRACTION` margin of (padding + {FLOAT32_SLACK:g}) / (2 × resolution) per island, "
        "xatlas for half the padding (each dilates both neighbours).", "", markdown_table(head, body), "", *notes])
