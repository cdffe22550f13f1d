"""Atlas quality (issue 16): packing, chart count, seams and texel density beside xatlas on the same meshes.

For every mesh: xatlas's own atlas (``xatlas.Atlas.generate`` with the same
resolution and padding), and our atlas built once (default options: small
xatlas charts merged, the ``fast`` solver) and then packed by each packer from
the same islands — ``shelf`` (the paper's bounding-box shelves), ``xatlas``
(xatlas's packer on bounding boxes), ``tight`` (the default: the islands' shapes
at the largest common texel density that fits, exact padding). Every number is
measured on the UV layout as written (float32), with
:func:`~neuraluv.layout.validate_layout`:

* utilisation — summed UV triangle area / texture area (the true area; xatlas's
  own ``utilization`` counts rasterised texels and is reported beside it);
* islands, mirrored islands (islands whose faces have det J < 0), overlaps, the
  smallest gap in texels and padding violations;
* seam length — 3D length of the cut edges, relative to xatlas's on the same mesh;
* texel-density spread across islands (``max/min − 1``).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import xatlas

from neuraluv import datasets
from neuraluv.atlas.build import build_atlas, repack
from neuraluv.datasets.generated import generated_asset
from neuraluv.jacobian import signed_areas_2d
from neuraluv.layout.validate import validate_layout
from neuraluv.meshfix import normalize_unit_box
from neuraluv_paper.bench.provenance import (BenchOutput, command_line, fmt_num, fmt_pct, machine_info, markdown_table,
                                             print_report, write_csv, write_markdown)

__all__ = ["add_arguments", "bench", "measure_layout", "run", "seam_length", "xatlas_atlas"]

DEFAULT_MESHES = ["cow", "spot", "stanford-bunny", "fertility", "nefertiti"]


def add_arguments(p):
    p.add_argument("--generated", type=int, default=5, help="generated assets to add (default 5)")
    p.add_argument("--generated-from", type=int, default=0, metavar="SEED",
                   help="seed of the first generated asset (default 0: generated-0, generated-1, ...)")
    p.add_argument("--resolution", type=int, default=1024, help="texture resolution (default 1024)")
    p.add_argument("--padding", type=float, default=4.0, help="padding in texels (default 4)")


def seam_length(V, F, FUV):
    """3D length of the interior edges whose two faces do not share the edge's UVs (the cuts).

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]); F = np.array([[0, 1, 2], [0, 2, 3]])
    >>> seam_length(V, F, F), round(seam_length(V, F, np.array([[0, 1, 2], [3, 4, 5]])), 6)
    (0.0, 1.414214)
    """
    F = np.asarray(F, np.int64)
    FUV = np.asarray(FUV, np.int64)
    a, b = F[:, [0, 1, 2]].ravel(), F[:, [1, 2, 0]].ravel()
    ua, ub = FUV[:, [0, 1, 2]].ravel(), FUV[:, [1, 2, 0]].ravel()
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    ulo, uhi = np.where(a < b, ua, ub), np.where(a < b, ub, ua)
    key = lo * (int(F.max()) + 1) + hi
    order = np.argsort(key, kind="stable")
    key, ulo, uhi, lo, hi = key[order], ulo[order], uhi[order], lo[order], hi[order]
    pair = np.flatnonzero((key[1:] == key[:-1]) & np.r_[key[2:] != key[1:-1], True] & np.r_[True, key[1:-1] != key[:-2]])
    cut = (ulo[pair] != ulo[pair + 1]) | (uhi[pair] != uhi[pair + 1])
    e = pair[cut]
    V = np.asarray(V, float)
    return float(np.linalg.norm(V[lo[e]] - V[hi[e]], axis=1).sum())


def xatlas_atlas(V, F, resolution, padding):
    """xatlas's own atlas: (V_cut, F_orig, UV, FUV, seconds, xatlas's raster utilisation)."""
    t = time.perf_counter()
    at = xatlas.Atlas()
    at.add_mesh(np.asarray(V, np.float32), np.asarray(F, np.uint32))
    po = xatlas.PackOptions()
    po.padding = int(np.ceil(padding))
    po.resolution = int(resolution)
    po.bilinear = True
    at.generate(xatlas.ChartOptions(), po)
    vmap, ind, uv = at[0]
    secs = time.perf_counter() - t
    ind = np.asarray(ind, np.int64).reshape(-1, 3)
    return np.asarray(vmap, np.int64), ind, np.asarray(uv, np.float32).astype(float), secs, float(at.utilization)


def measure_layout(V, F, UV, FUV, resolution, padding):
    """One UV layout measured as every atlas row of the benchmarks is (see the module's list).

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
        Faces of the uncut mesh (so the seams are the cut edges).
    UV : (p,2) float array
    FUV : (m,3) int array
    resolution : int
    padding : float
        Texels at ``resolution``.

    Returns
    -------
    dict
        ``islands``, ``flips``, ``mirrored_islands``, ``overlapping_pairs``,
        ``self_overlapping_islands``, ``padding_violations``, ``min_gap_texels`` (None where
        there is no pair), ``utilisation`` (summed UV triangle area over the texture),
        ``density_spread``, ``seam`` (on the unit-box mesh) and ``valid``
        (:func:`~neuraluv.layout.validate_layout`).
    """
    Vn = normalize_unit_box(V)[0]
    val = validate_layout(V, F, UV, FUV, padding=padding, resolution=resolution, tiles=bool(UV.max() > 1))
    return {
        "islands": val["islands"], "flips": val["flips"], "mirrored_islands": val["mirrored_islands"],
        "overlapping_pairs": val["overlapping_pairs"], "self_overlapping_islands": val["self_overlapping_islands"],
        "padding_violations": val["padding_violations"],
        "min_gap_texels": val["min_gap_texels"] if isinstance(val["min_gap_texels"], float) else None,
        "utilisation": float(np.abs(signed_areas_2d(UV, FUV)).sum()), "density_spread": val["density_spread"],
        "seam": seam_length(Vn, F, FUV), "valid": val["valid"],
    }


def _assets(args):
    names = args.meshes or (["spot"] if args.quick else DEFAULT_MESHES)
    out = []
    for name in names:
        try:
            V, F = datasets.load(name)[:2]
        except datasets.DataMissing as exc:
            out.append((name, None, None, str(exc)))
            continue
        out.append((name, V, F, ""))
    first = getattr(args, "generated_from", 0)
    for i in range(first, first + (0 if args.quick else args.generated)):
        V, F = generated_asset(i)[:2]
        out.append((f"generated-{i}", V, F, ""))
    return out


def bench(args):
    """Run the comparison for parsed ``args`` (see :func:`add_arguments`); returns the BenchOutput."""
    out_dir = Path(args.output)
    out_dir.mkdir(parents=True, exist_ok=True)
    machine = machine_info("cpu")
    res_, pad = args.resolution, args.padding
    preset = args.preset or ("test" if args.quick else "fast")
    rows, notes = [], []
    for name, V, F, why in _assets(args):
        if V is None:
            notes.append(f"- {name}: not run ({why})")
            continue
        vmap, Fx, UVx, tx, xutil = xatlas_atlas(V, F, res_, pad)
        mx = measure_layout(V, vmap[Fx], UVx, Fx, res_, pad)  # on the uncut mesh, so seams are cut edges
        base = {"mesh": name, "faces": int(len(F))}
        rows.append({**base, "method": "xatlas (own charts + packer)", **mx, "pack_seconds": tx, "xatlas_raster_util": xutil,
                     "fallback_share": 0.0, "charts": mx["islands"]})
        t0 = time.perf_counter()
        res = build_atlas(V, F, preset, resolution=res_, padding=pad, device="cpu")
        t_build = time.perf_counter() - t0
        T = res.totals()
        packers = ["shelf", "xatlas", "tight"] + (["tight, whole islands"] if res.info.get("cut_islands") else [])
        for packer in packers:
            t = time.perf_counter()
            try:
                r = (res if packer == res.info["packer"] else
                     repack(res, "tight", cut_islands=False) if packer.startswith("tight,") else repack(res, packer))
            except Exception as exc:  # noqa: BLE001 - e.g. xatlas needs two pages: a row that says so
                rows.append({**base, "method": f"ours + {packer}", "error": f"{type(exc).__name__}: {exc}"})
                continue
            tp = r.info["timings"]["packing"] if r is res else time.perf_counter() - t
            m = measure_layout(r.V, r.F, r.UV, r.FUV, res_, pad)
            used = r.info["packer"]
            label = (f"ours + {packer}" if used == packer.split(",")[0] else
                     f"ours + {packer} → {used.split(' ')[0]} (fell back)")
            rows.append({**base, "method": label, "packer_used": used, **m, "pack_seconds": tp, "charts": T["charts"],
                         "fallback_share": T["fallback_share"], "atlas_seconds": t_build,
                         "candidates": res.info["candidates"]["xatlas_and_splits"],
                         "after_merge": res.info["candidates"]["after_merge"]})
    for r in rows:
        x = next((q for q in rows if q["mesh"] == r["mesh"] and q["method"].startswith("xatlas")), None)
        if x and "islands" in r and x.get("islands"):
            r["islands_vs_xatlas"] = r["islands"] / x["islands"]
            r["util_vs_xatlas"] = r["utilisation"] / x["utilisation"]
            if x.get("seam"):  # 0 on a triangle soup: every edge is a boundary, none is cut
                r["seam_vs_xatlas"] = r["seam"] / x["seam"]
    files = [write_csv(out_dir / "atlas_quality.csv", rows)]
    md = _markdown(rows, notes, res_, pad)
    files.append(write_markdown(out_dir / "atlas_quality.md", "Atlas quality beside xatlas", md,
                                command=command_line("atlas-quality", args), machine=machine))
    return BenchOutput(name="atlas-quality", rows=rows, markdown=md, files=files)


def run(args):
    """``neuraluv bench atlas-quality``: print the table, list the files, exit 0."""
    return print_report(bench(args))


def _pct(x):
    return fmt_pct(None if x is None else 100 * x)


def _markdown(rows, notes, res_, pad):
    head = ["mesh", "faces", "method", "islands (× xatlas)", "fallback faces", "utilisation (× xatlas)", "min gap (tx)",
            "padding viol.", "flips", "mirrored", "overlaps", "seam (× xatlas)", "density spread", "pack s", "atlas s"]
    body = []
    for r in rows:
        if "error" in r:
            body.append([r["mesh"], r["faces"], r["method"], r["error"]] + [""] * (len(head) - 4))
            continue
        rel = (lambda k: f" ({r[k]:.2f})" if k in r and not r["method"].startswith("xatlas") else "")
        body.append([r["mesh"], r["faces"], r["method"], f"{r['islands']}{rel('islands_vs_xatlas')}",
                     _pct(r.get("fallback_share")), f"{_pct(r['utilisation'])}{rel('util_vs_xatlas')}",
                     fmt_num(r["min_gap_texels"]), r["padding_violations"], r["flips"], r["mirrored_islands"],
                     r["overlapping_pairs"], f"{fmt_num(r['seam'], 3)}{rel('seam_vs_xatlas')}",
                     _pct(r["density_spread"]), fmt_num(r["pack_seconds"]),
                     fmt_num(r.get("atlas_seconds", r["pack_seconds"] if r["method"].startswith("xatlas") else None))])
    text = [f"Resolution {res_}, padding {pad:g} texels; every number measured on the layout as written (float32 UVs).",
            "Utilisation is the true UV area over the texture; xatlas's own `utilization` (rasterised texels, "
            "padding included) is in the CSV as `xatlas_raster_util`. xatlas's padding is what it achieves at its own "
            "atlas size (it may exceed the resolution); its mirrored islands come from its 90° \"rotation\", a transpose. "
            "`atlas s`: our whole pipeline (repair, charts, neural solves, packing, validation; one per mesh, the "
            "packers then re-pack the same islands) and xatlas's `generate`. `ours + tight` may cut islands that hold "
            "more than a tenth of the UV area to pack fuller (`build_atlas(cut_islands=True)`, the default; each part "
            "at its own texel density); where it did, `ours + tight, whole islands` packs the same islands uncut.",
            "", markdown_table(head, body), ""]
    checks = []
    for r in rows:
        if not r["method"].startswith("ours + tight") or "whole islands" in r["method"] or "error" in r:
            continue
        ok = (r["method"] == "ours + tight" and r["util_vs_xatlas"] >= 1 and r["islands_vs_xatlas"] <= 1.1 and r["flips"] == 0 and r["overlapping_pairs"] == 0
              and r["mirrored_islands"] == 0 and r["padding_violations"] == 0 and (r["density_spread"] or 0) <= 0.05)
        checks.append(f"- {r['mesh']}: utilisation ×{r['util_vs_xatlas']:.2f}, islands ×{r['islands_vs_xatlas']:.2f}, "
                      f"density spread {_pct(r['density_spread'])} — {'holds' if ok else 'does not hold'}"
                      + ("" if r["method"] == "ours + tight" else " (the tight packer fell back to the shelf packer)"))
    text += ["Acceptance (utilisation ≥ xatlas, islands ≤ 1.1× xatlas, 0 flips / overlaps / mirrored, padding kept, "
             "density spread ≤ 5%):", "", *checks, "", *notes]
    return "\n".join(text)
