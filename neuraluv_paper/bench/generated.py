"""The paper's generated-mesh (Amara Spatial) tables, on the seeded generated-like set.

Three reports in ``--output`` (default ``results/generated``):

* ``amara_coverage_validity.{md,csv}`` (``tab:amara_coverage_validity``): our
  atlas (:func:`~neuraluv.atlas.build_atlas`, default packer, the solver preset of
  ``--preset``, default ``fast``) — coverage of the repaired faces, the neural /
  exact (unfold or isometric start) / fallback face shares, neural charts with zero flips, flips and
  overlaps of the packed atlas — beside Blender's Smart UV Project on the same raw
  meshes (coverage and flipped loop-UV triangles);
* ``amara_blender_methods.{md,csv}`` (``tab:amara_blender_methods``, "chart-level"):
  Blender's Angle Based and Conformal unwraps of **our charts** (the repaired mesh cut
  along our atlas's seams, each chart a separate island: the same charts, Blender's
  solver) and Smart UV Project on the raw mesh (it cuts its own charts) — assets
  unwrapped, assets with zero flips, flipped loop-UV triangles, mean conformal
  distortion;
* ``amara_large_sweep.{md,csv}`` (``tab:amara_large_sweep``, with ``--sweep N``):
  ``neuraluv sweep`` (dask, one subprocess per asset, per-asset timeout) over the
  first N generated assets — tried / OK / faces / flips / routed shares / median time.

The assets are :func:`neuraluv.datasets.generated.generated_asset` ``0 .. N-1`` (seeded
marching-cubes shapes with the defects of generated meshes: holes, handles, floating
fragments, slivers, flipped windings, duplicated and non-manifold faces), not the
paper's Amara Spatial assets, which are not public; registry meshes can be added with
``--meshes``. Blender's loop UVs are counted per raw triangle as the paper does; a
triangle with zero 3D area has no orientation and is left out of the flip count
(reported as ``degenerate``).

Python API: :func:`bench`; command line: ``neuraluv bench generated``.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import trimesh

from neuraluv.atlas import build_atlas
from neuraluv.atlas.sweep import sweep
from neuraluv.datasets.generated import generated_asset
from neuraluv.io import atomic_write
from neuraluv.meshfix import face_areas
from neuraluv.metrics import corner_jacobians, face_metrics
from neuraluv_paper.baselines import Unavailable
from neuraluv_paper.baselines.external import blender_map
from neuraluv_paper.bench import paper_values as PV
from neuraluv_paper.bench.common import load_meshes
from neuraluv_paper.bench.provenance import (PAPER_NOTE, BenchOutput, command_line, findings_markdown, fmt_num, fmt_pct,
                                             fmt_time, fraction, markdown_table, print_report, progress, start_run,
                                             with_paper, write_csv, write_markdown)
from neuraluv_paper.claims import heading

__all__ = ["bench", "ours_row", "blender_row", "add_arguments", "run", "BLENDER"]

#: Blender unwrappers compared (our method name -> bpy mode), as in the paper.
BLENDER = {"blender-angle": "ANGLE_BASED", "blender-conformal": "CONFORMAL", "blender-smart": "SMART"}
LABELS = {"blender-angle": "Angle Based", "blender-conformal": "Conformal", "blender-smart": "Smart UV"}
#: Blender methods run on our charts (the same islands, Blender's solver); the others on the raw mesh.
CHART_LEVEL = ("blender-angle", "blender-conformal")


def ours_row(V, F, preset="fast", *, threads=1, device="auto", charts_path=None):
    """Our atlas of one raw mesh: coverage, routed shares, chart validity, flips (a flat dict).

    With ``charts_path`` the atlas's chart mesh (:func:`chart_mesh_of`) is saved there
    (``.npz``: ``V``, ``F``) for the chart-level Blender rows.

    Examples
    --------
    >>> from neuraluv.datasets import sphere
    >>> r = ours_row(*sphere(1), "test", device="cpu")
    >>> r["status"], r["coverage"], r["flips"], r["overlaps"]
    ('ok', 1.0, 0, 0)
    """
    t0 = time.perf_counter()
    try:
        res = build_atlas(V, F, preset, threads=threads, device=device)
    except Exception as exc:  # an asset the pipeline rejects is a row, not a crash of the table
        return {"status": "failed", "reason": str(exc).splitlines()[0][:200], "time": time.perf_counter() - t0,
                "raw_faces": int(len(F))}
    if charts_path is not None:
        Vc, Fc = chart_mesh_of(res)
        np.savez(charts_path, V=Vc, F=Fc)
    m = len(res.F)
    route = np.asarray(res.face_route)
    neural = [c for c in res.charts if c.route == "neural"]
    val = res.validation
    return {"status": "ok", "raw_faces": int(len(F)), "faces": int(m),
            "coverage": float((np.asarray(res.FUV) >= 0).all(axis=1).mean()) if m else 0.0,
            "neural_share": float((route == 1).mean()) if m else 0.0,
            "exact_share": float((route == 2).mean()) if m else 0.0,
            "fallback_share": float((route == 0).mean()) if m else 0.0,
            "neural_charts": len(neural),
            "neural_zero_flip": sum(int(c.metrics.get("flips", 1)) == 0 for c in neural),
            "fallback_charts": sum(c.route == "fallback" for c in res.charts),
            "flips": int(val.get("flips", -1)), "overlaps": int(val.get("overlapping_pairs", -1)),
            "valid": bool(res.valid), "utilisation": float(res.info.get("utilisation", float("nan"))),
            "time": time.perf_counter() - t0}


def chart_mesh_of(res):
    """The repaired mesh cut along an atlas's seams: one vertex per UV vertex, each island its own component.

    Returns
    -------
    V : (p,3) float array, ``res.V`` at each UV vertex
    F : (m,3) int array, ``res.FUV``

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> r = SimpleNamespace(V=np.eye(3), F=np.array([[0, 1, 2]]), FUV=np.array([[2, 0, 1]]))
    >>> chart_mesh_of(r)[0][[2, 0, 1]].tolist() == np.eye(3).tolist()
    True
    """
    FUV = np.asarray(res.FUV, np.int64)
    Vc = np.zeros((int(FUV.max()) + 1, 3))
    Vc[FUV.ravel()] = np.asarray(res.V, float)[np.asarray(res.F, np.int64).ravel()]
    return Vc, FUV


def blender_row(V, F, method):
    """Blender's unwrap of one raw mesh, counted on its loop UVs (a flat dict; ``status`` ``unavailable``
    without ``bpy``)."""
    F = np.asarray(F, np.int64)
    t0 = time.perf_counter()
    try:
        UV, Vc, Fc, secs = blender_map(V, F, BLENDER[method])
    except Unavailable as exc:
        return {"status": "unavailable", "reason": str(exc)[:200], "raw_faces": int(len(F))}
    except Exception as exc:
        return {"status": "failed", "reason": str(exc).splitlines()[0][:200], "raw_faces": int(len(F)),
                "time": time.perf_counter() - t0}
    area = face_areas(np.asarray(Vc, float), Fc)
    live = area > 1e-14 * max(float(area.max()), 1e-300)  # a zero-area triangle has no orientation
    J, A = corner_jacobians(Vc, Fc[live], UV)
    fm = face_metrics(J)
    det = fm["det"]
    e1, e2 = UV[Fc[:, 1]] - UV[Fc[:, 0]], UV[Fc[:, 2]] - UV[Fc[:, 0]]
    uv_area = np.abs(0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]))
    covered = np.isfinite(uv_area) & ((uv_area > 0) | ~live)  # a UV for every corner, not collapsed
    ok = det > 0
    conf = float(np.sum(A[ok] * fm["conformal"][ok]) / max(float(np.sum(A[ok])), 1e-300)) if ok.any() else float("nan")
    return {"status": "ok", "raw_faces": int(len(F)), "degenerate": int((~live).sum()),
            "coverage": float(covered.mean()),
            "flips": int((det <= 0).sum()), "conformal": conf, "time": float(secs)}


def _assets(n, meshes, quick):
    out = []
    for i in range(n):
        V, F, info = generated_asset(i, res=16 if quick else None)
        out.append((info["name"], V, F))
    if meshes:
        loaded = load_meshes(list(meshes), quick)
        out += loaded
    return out


def bench(n_assets=25, meshes=None, *, preset=None, quick=False, output="results/generated", resume=False,
          sweep_assets=0, workers=2, device="auto", threads=1, show_progress=True, args=None):
    """Run the generated-mesh tables; write their Markdown/CSV reports into ``output``.

    Parameters
    ----------
    n_assets : int
        Generated assets ``0 .. n_assets-1`` for the coverage and Blender tables (paper: 25).
    meshes : list of str, optional
        Registry meshes added to those two tables.
    preset : str, optional
        Our solver preset (default ``fast``; ``test`` under ``quick``).
    sweep_assets : int
        Assets of the larger sweep (``neuraluv sweep`` on dask); 0 skips it.

    Returns
    -------
    BenchOutput
        ``extra``: ``{"coverage": [...], "blender": [...], "sweep": summary or None}``.
    """
    preset = preset or ("test" if quick else "fast")
    out, machine, log = start_run(output, resume=resume, device=device)
    assets = _assets(n_assets, meshes, quick)
    rows = []
    cache = out / "cache"
    cache.mkdir(exist_ok=True)
    jobs = [(n, V, F, meth) for n, V, F in assets for meth in ["ours", *BLENDER]]
    for n, V, F, meth in progress(jobs, desc="generated", disable=not show_progress):
        charts = cache / f"{n}_{preset}_charts.npz"
        if meth == "ours":
            cfg = {"preset": preset}
            fn = lambda: ours_row(V, F, preset, threads=threads, device=device, charts_path=charts)  # noqa: E731
        elif meth in CHART_LEVEL:
            cfg = {"on": "our charts", "preset": preset, "v": 2}

            def fn():
                if not charts.exists():  # the atlas row came from the resume log: build the charts again
                    ours_row(V, F, preset, threads=threads, device=device, charts_path=charts)
                if not charts.exists():
                    return {"status": "failed", "reason": "our atlas failed: no charts", "raw_faces": int(len(F))}
                with np.load(charts) as z:
                    return blender_row(z["V"], z["F"], meth)
        else:
            cfg = {"on": "raw mesh", "v": 2}
            fn = lambda: blender_row(V, F, meth)  # noqa: E731
        row = dict(log.run((n, meth, cfg), fn))
        row.update({"asset": n, "method": meth})
        rows.append(row)

    ours = [r for r in rows if r["method"] == "ours"]
    okd = [r for r in ours if r["status"] == "ok"]
    faces = sum(r["faces"] for r in okd)
    share = {k: sum(r["faces"] * r[k] for r in okd) / faces if faces else float("nan")
             for k in ("coverage", "neural_share", "exact_share", "fallback_share")}
    n_neural = sum(r["neural_charts"] for r in okd)
    n_neural_ok = sum(r["neural_zero_flip"] for r in okd)
    flips = sum(max(r["flips"], 0) for r in okd)
    overlaps = sum(max(r["overlaps"], 0) for r in okd)
    blender = {m: [r for r in rows if r["method"] == m] for m in BLENDER}
    have_blender = any(r["status"] != "unavailable" for rs in blender.values() for r in rs)
    n = len(assets)

    def bl_sum(m):
        rs = [r for r in blender[m] if r["status"] == "ok"]
        tri = sum(r["raw_faces"] for r in rs)
        fl = sum(r["flips"] for r in rs)
        conf = [r["conformal"] for r in rs if np.isfinite(r["conformal"])]
        return {"method": m, "ok": len(rs), "n": n, "zero_flip": sum(r["flips"] == 0 for r in rs), "flips": fl,
                "triangles": tri, "degenerate": sum(r["degenerate"] for r in rs),
                "coverage": sum(r["coverage"] * r["raw_faces"] for r in rs) / tri if tri else float("nan"),
                "conformal": float(np.mean(conf)) if conf else float("nan"),
                "status": "ok" if rs else (blender[m][0]["status"] if blender[m] else "not run")}

    bsum = {m: bl_sum(m) for m in BLENDER}
    P = PV.AMARA_COVERAGE
    smart = bsum["blender-smart"]
    cov_rows = [
        ["Ours neural-only", with_paper(fmt_pct(100 * share["neural_share"], 1), fmt_pct(P["neural-only"]["coverage"], 1)),
         "neural", with_paper(f"{fraction(n_neural_ok, n_neural)} charts zero-flip",
                              fraction(*P["neural-only"]["charts_valid"]) + " charts")],
        ["Ours full fallback", with_paper(fmt_pct(100 * share["coverage"], 1), fmt_pct(P["full"]["coverage"], 1)),
         with_paper(f"{100 * share['neural_share']:.1f} / {100 * share['exact_share']:.1f} / "
                    f"{100 * share['fallback_share']:.1f}%", f"{P['full']['neural_share']} / — / {P['full']['fallback_share']}%"),
         with_paper(f"{flips} flips, {overlaps} overlaps on {faces:,} faces", "0 local flips")],
        ["Blender Smart UV", with_paper(fmt_pct(100 * smart["coverage"], 1) if smart["ok"] else smart["status"],
                                        fmt_pct(P["blender-smart"]["coverage"], 1)), "n/a",
         with_paper(f"{smart['flips']:,}/{smart['triangles']:,} ({fmt_pct(100 * smart['flips'] / smart['triangles'], 3)}), "
                    f"{n - smart['zero_flip'] - (n - smart['ok'])}/{smart['ok']} assets with flips" if smart["ok"] else "—",
                    f"{P['blender-smart']['flips']}/{P['blender-smart']['triangles']:,} "
                    f"({P['blender-smart']['flip_percent']:.3f}%), {fraction(*P['blender-smart']['assets_with_flips'])} assets")],
    ]
    bl_rows = []
    for m in BLENDER:
        s, p = bsum[m], PV.AMARA_BLENDER[m]
        bl_rows.append([LABELS[m], with_paper(fraction(s["ok"], n), fraction(*p["ok"])),
                        with_paper(fraction(s["zero_flip"], n) if s["ok"] else "—", fraction(*p["zero_flip"])),
                        with_paper(f"{s['flips']:,}" if s["ok"] else s["status"], f"{p['flips']}"),
                        with_paper(fmt_num(s["conformal"]) if s["ok"] else "—", fmt_num(p["conformal"]))])
    findings = [
        ("the full atlas path covers every repaired face with zero local flips", share["coverage"] == 1.0 and flips == 0
         and len(okd) == n, f"{fraction(len(okd), n)} assets atlased, coverage {100 * share['coverage']:.1f}% of "
         f"{faces:,} repaired faces, {flips} flips, {overlaps} overlapping island pairs"),
        ("every accepted neural chart is zero-flip", n_neural_ok == n_neural, f"{fraction(n_neural_ok, n_neural)}"),
        ("about half of the repaired faces are neural-routed (paper 52.1% / 47.9% fallback)", None,
         f"ours {100 * share['neural_share']:.1f}% neural, "
         f"{100 * share['exact_share']:.1f}% exact (unfold, isometric start), "
         f"{100 * share['fallback_share']:.1f}% fallback — different assets (seeded generated-like shapes, not "
         "Amara Spatial), so the split is not comparable"),
    ]
    if have_blender:
        findings.append(("Blender Smart UV covers the assets but leaves flipped UV triangles on some of them",
                         smart["ok"] > 0 and smart["flips"] > 0 and smart["coverage"] > 0.999,
                         f"coverage {100 * smart['coverage']:.2f}%, {smart['flips']} flipped loop-UV triangles, "
                         f"{smart['ok'] - smart['zero_flip']}/{smart['ok']} assets with flips"))
        for m in ("blender-angle", "blender-conformal"):
            s = bsum[m]
            findings.append((f"Blender {LABELS[m]} leaves flips on some assets", s["ok"] > 0 and s["zero_flip"] < s["ok"],
                             f"{s['ok'] - s['zero_flip']}/{s['ok']} assets with flips, {s['flips']} flipped triangles"))
    else:
        findings.append(("Blender's unwraps flip UV triangles on some assets", None,
                         "not run: Blender's bpy is not installed (`make blender-env`)"))

    names = ", ".join(a[0] for a in assets[:3]) + (f", … ({n} assets)" if n > 3 else "")
    body = [f"Assets: {names}; {sum(len(a[2]) for a in assets):,} raw triangles. Ours: `build_atlas` with the "
            f"`{preset}` preset and the default packer; coverage and shares over the {faces:,} repaired faces of the "
            f"{len(okd)} assets atlased. Blender Smart UV (bpy, `make blender-env`) on the raw meshes: loop UVs per "
            "raw triangle (covered: a UV triangle that is not collapsed, or whose 3D triangle has zero area).", "",
            markdown_table(["Method", "Coverage", "Routed faces (neural / exact / fallback)", "Validity / flips"], cov_rows),
            "", findings_markdown(findings)]
    notes = [PAPER_NOTE, "Paper values in brackets are for 25 Amara Spatial assets (1,219,074 repaired faces), ours "
             "for the seeded generated-like set: the denominators differ; compare shares and signs, not counts.",
             "A flip is det J ≤ 0 of a raw triangle with non-zero 3D area (Blender's degenerate triangles: "
             + ", ".join(f"{LABELS[m]} {bsum[m]['degenerate']}" for m in BLENDER) + ", not counted)."]
    if log.skipped:
        notes.append(f"{log.skipped} row(s) taken from the resume log.")
    cmd = command_line("generated", args)
    files = [write_csv(out / "amara_runs.csv", rows),
             write_markdown(out / "amara_coverage_validity.md", heading("tab:amara_coverage_validity", "generated meshes: coverage and validity"), "\n".join(body), command=cmd, machine=machine, notes=notes,
                            findings=findings)]
    bbody = [f"Blender's unwraps of the same {n} assets (bpy 4.5, each operator's defaults), counted on loop UVs: "
             "Angle Based and Conformal on **our charts** (the repaired mesh cut along our atlas's seams, each chart "
             "its own island: the same charts, Blender's solver; chart-level, as in the paper's table), Smart UV "
             "Project on the raw mesh (it cuts its own charts). Conf.: mean over assets of the area-weighted "
             "σ1/σ2 of the unflipped triangles.", "",
             markdown_table(["Method", "OK", "Zero-flip", "Flips", "Conf."], bl_rows)]
    files.append(write_csv(out / "amara_blender_methods.csv", list(bsum.values())))
    files.append(write_markdown(out / "amara_blender_methods.md", heading("tab:amara_blender_methods", "generated meshes: Blender's unwraps"), "\n".join(bbody), command=cmd, machine=machine,
                                notes=notes[:3]))
    summary = None
    if sweep_assets:
        summary = _sweep(out, int(sweep_assets), preset, workers, quick, resume)
        s, p = summary, PV.AMARA_SWEEP
        srow = [[f"neuraluv sweep, generated {s['tried']}", f"{s['tried']:,}", f"{s['ok']:,}", f"{s['faces']:,}",
                 f"{s['flips']}", f"{100 * s['neural_share']:.1f} / {100 * s['exact_share']:.1f} / "
                 f"{100 * s['fallback_share']:.1f}%", fmt_time(s["median_time"]) + "s"]]
        srow += [[f"[paper: {k}]", f"{v['tried']:,}", f"{v['ok']:,}", f"{v['faces'] / 1e6:.2f}M", f"{v['flips']}",
                  f"{v['neural_share']} / — / {v['fallback_share']}%", f"{v['median_time']}s"] for k, v in p.items()]
        files.append(write_csv(out / "amara_large_sweep.csv", [s]))
        files.append(write_markdown(
            out / "amara_large_sweep.md", heading("tab:amara_large_sweep", "generated meshes: larger sweep"),
            f"`neuraluv sweep` (dask LocalCluster, {workers} workers, one subprocess per asset) over generated assets "
            f"0–{sweep_assets - 1}, `{preset}` preset, default packer. The paper's rows ran its Rust implementation "
            "on Amara Spatial GLB assets (routing, validation and packing; neural optimisation only in the "
            "paper-native row).\n\n" + markdown_table(["Run", "Tried", "OK", "Faces", "Flips",
                                                       "Neural / exact / fallback", "Med. time"], srow),
            command=cmd, machine=machine, notes=[PAPER_NOTE]))
    text = "\n\n".join(Path(f).read_text() for f in files if str(f).endswith(".md"))
    return BenchOutput("generated", rows, text, files, findings, log.skipped,
                       {"coverage": cov_rows, "blender": list(bsum.values()), "sweep": summary})


def _sweep(out, n, preset, workers, quick, resume):
    src = out / "cache" / "assets"
    src.mkdir(parents=True, exist_ok=True)
    paths = [src / f"gen_{i:04d}.obj" for i in range(n)]  # these n: the folder may hold more from a larger run
    for i, path in enumerate(paths):
        if not path.exists():
            V, F, _ = generated_asset(i, res=16 if quick else None)
            with atomic_write(path) as fh:  # every defect kept: no merging, no cleanup (as data_scripts/make_generated.py)
                fh.write(trimesh.Trimesh(V, F, process=False).export(file_type="obj"))
    res = sweep([str(p) for p in paths], out / "cache" / "sweep", n_workers=workers, resume=resume, progress=False,
                label=f"generated {n}", preset=preset)
    return res.summary


# ------------------------------------------------------------------ CLI

def add_arguments(p):
    p.add_argument("--assets", type=int, default=25, help="generated assets of the coverage and Blender tables (default 25)")
    p.add_argument("--sweep", type=int, default=0, metavar="N",
                   help="also run the larger sweep (neuraluv sweep on dask) over N generated assets; 0 = skip (default)")
    p.add_argument("--workers", type=int, default=2, help="dask workers of the sweep (default 2)")


def run(args):
    n = 2 if args.quick else args.assets
    res = bench(n, args.meshes, preset=args.preset, quick=args.quick, output=args.output, resume=args.resume,
                sweep_assets=min(args.sweep, 3) if args.quick and args.sweep else args.sweep, workers=args.workers,
                device=args.device, threads=args.threads or 1, show_progress=not args.quiet, args=args)
    return print_report(res)
