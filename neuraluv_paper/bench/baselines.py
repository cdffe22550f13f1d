"""The external baselines checked against the paper: the BFF v1.6 binary and OptCuts.

Two reports, both built from the binaries of ``make baselines``:

* ``bff_agreement.{md,csv}`` (always): our Python BFF (:mod:`neuraluv_paper.baselines.bff`)
  against the BFF v1.6 command-line tool on the compact charts (Camel, Hand,
  Bob): E_SD, conformal and area distortion, flips, min det J and time, the
  paper's BFF value beside them, and how far the two maps are apart after a
  best similarity alignment. The tool is run as documented (``--normalizeUVs``,
  UVs printed with six decimals) and once more with full precision in the file
  (input scaled by 10⁴, no normalisation), which separates what BFF computes
  from what rounding the file does to near-degenerate triangles.
* ``optcuts_sample.{md,csv}`` (``--optcuts-sample N``): OptCuts on N xatlas-cut,
  disk-like charts of 1,000–40,000 faces taken evenly over that size range from
  the cached closed registry meshes (:func:`neuraluv_paper.bench.charts.chart_pool`),
  for the paper's "OptCuts is valid on 9/10 of a 1K–40K Thingi-style sample".

Python API: :func:`bff_agreement`, :func:`optcuts_sample`; command line:
``neuraluv bench baselines [--optcuts-sample 10]``.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from neuraluv.errors import NeuralUVError
from neuraluv.layout.rigid import rigid_fit
from neuraluv.topology import vertex_components
from neuraluv_paper.baselines import bff_binary, optcuts_binary, run_baseline
from neuraluv_paper.bench import paper_values as PV
from neuraluv_paper.bench.charts import chart_pool, default_sources, select_charts
from neuraluv_paper.bench.common import MESH_LABELS, load_meshes
from neuraluv_paper.bench.provenance import (PAPER_NOTE, BenchOutput, RowLog, command_line, fmt_num, fmt_pct, fmt_time,
                                             fraction, machine_info, markdown_table, print_report, progress, with_paper,
                                             write_csv, write_markdown)

__all__ = ["bff_agreement", "optcuts_sample", "map_distance", "add_arguments", "run", "BFF_VARIANTS"]

#: (label, method, options) of the BFF runs compared.
BFF_VARIANTS = [
    ("ours (Python BFF)", "bff", {}),
    ("BFF v1.6 binary, --normalizeUVs", "bff-cli", {}),
    ("BFF v1.6 binary, full precision", "bff-cli", {"normalize": False, "prescale": 1e4}),
]
#: Face-count range of the OptCuts sample (the paper's "1K–40K").
SAMPLE_RANGE = (1000, 40000)


def map_distance(F, uv_a, F_b, uv_b):
    """How far two maps of the same faces are apart, after the best similarity alignment.

    Both maps give every face corner a UV (``uv_a[F]`` and ``uv_b[F_b]``, same
    face order); each connected component of ``F`` is aligned on its own
    (Procrustes with scaling, reflection allowed), and the RMS and largest
    corner distance are returned relative to the component's UV extent (the
    worst component).

    Examples
    --------
    >>> F = np.array([[0, 1, 2], [0, 2, 3]])
    >>> uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1.]])
    >>> rot = uv @ np.array([[0, -2], [2, 0.]]) + 5      # rotated, scaled, moved: the same map
    >>> [round(x, 12) for x in map_distance(F, uv, F, rot)]
    [0.0, 0.0]
    """
    F = np.asarray(F, np.int64)
    _, lab = vertex_components(int(F.max()) + 1, F)
    flab = lab[F[:, 0]]
    rms = worst = 0.0
    for c in np.unique(flab):
        sel = flab == c
        a = np.asarray(uv_a, float)[F[sel]].reshape(-1, 2)
        b = np.asarray(uv_b, float)[np.asarray(F_b, np.int64)[sel]].reshape(-1, 2)
        R, sc, t = rigid_fit(b, a, proper=False, scale=True)
        d = np.linalg.norm(sc * b @ R + t - a, axis=1)
        ext = max(np.ptp(a, axis=0).max(), 1e-300)
        rms = max(rms, float(np.sqrt((d ** 2).mean()) / ext))
        worst = max(worst, float(d.max() / ext))
    return rms, worst


def _row(res):
    m = res.metrics
    return {k: m.get(k) for k in ("esd", "conformal", "area", "flips", "flip_percent", "min_det", "n_faces", "valid")} | {
        "status": res.status, "reason": res.reason, "time": float(res.time)}


def bff_agreement(meshes=None, *, output="results/baselines", repeats=3, show_progress=True, args=None):
    """Our Python BFF against the BFF v1.6 binary; writes ``bff_agreement.{md,csv}``.

    Parameters
    ----------
    meshes : list of str, optional
        Default Camel, Hand, Bob.
    repeats : int
        Each run is repeated and the fastest time kept (the maps are deterministic).

    Returns
    -------
    BenchOutput
    """
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    names = list(meshes or ["camel", "hand", "bob"])
    loaded = load_meshes(names)
    machine = machine_info("cpu")
    binary = bff_binary()
    rows = []
    jobs = [(n, V, F, v) for n, V, F in loaded for v in BFF_VARIANTS]
    ref = {}
    for name, V, F, (label, meth, opts) in progress(jobs, desc="bff-agreement", disable=not show_progress):
        runs = [run_baseline(meth, V, F, **opts) for _ in range(max(1, int(repeats)))]
        res = runs[0]
        row = {"mesh": name, "variant": label, "method": meth, "options": str(opts or ""), **_row(res)}
        row["time"] = min(r.time for r in runs)
        if meth == "bff":
            ref[name] = res
        elif res.produced and name in ref and ref[name].produced:
            rms, worst = map_distance(ref[name].F, ref[name].uv, res.F, res.uv)
            row["rms_distance"], row["max_distance"] = rms, worst
            e0 = ref[name].metrics["esd"]
            row["esd_rel_diff"] = (res.metrics["esd"] - e0) / e0 if math.isfinite(e0) and math.isfinite(res.metrics["esd"]) else None
        pv = PV.COMPACT_PRELIM.get((name, "bff"))
        row["paper_esd"] = pv["esd"] if pv else None
        row["paper_flip_percent"] = pv["flip_percent"] if pv else None
        rows.append(row)

    table = []
    for r in rows:
        ok = r["status"] == "ok"
        pv = PV.COMPACT_PRELIM.get((r["mesh"], "bff"))
        table.append([MESH_LABELS.get(r["mesh"], r["mesh"]), r["variant"],
                      with_paper(fmt_num(r["esd"]) if ok else r["status"], fmt_num(pv["esd"]) if pv else None),
                      fmt_num(r["conformal"]) if ok else "—", fmt_num(r["area"]) if ok else "—",
                      with_paper(f"{int(r['flips'])} ({fmt_pct(r['flip_percent'])})" if ok else "—",
                                 fmt_pct(pv["flip_percent"]) if pv else None),
                      fmt_num(r["min_det"], 3) if ok else "—",
                      f"{100 * r['esd_rel_diff']:+.2f}%" if r.get("esd_rel_diff") is not None else "—",
                      f"{r['rms_distance']:.1e} / {r['max_distance']:.1e}" if r.get("rms_distance") is not None else "—",
                      fmt_time(r["time"]) if ok else "—"])
    header = ["Mesh", "Run", "E_SD", "Conf.", "Area", "Flips (%)", "min det J", "ΔE_SD vs ours",
              "map distance RMS / max", "Time (s)"]
    body = [f"BFF binary: `{binary or 'not built'}` (Boundary First Flattening v1.6, commit 6924b2f, built by "
            "`make baselines`), no cones, free boundary (BFF's minimal-area-distortion boundary, `flatten(u = 0)`), "
            "the setting of the paper's BFF baseline on a disk chart. Ours: `neuraluv_paper.baselines.bff.bff_map`, "
            "the same algorithm in scipy. Both maps are rescaled to the 3D area before the metrics (BFF has no "
            "intrinsic scale) and measured by `neuraluv.metrics.distortion_metrics`.", "",
            markdown_table(header, table, "llrrrrrrrr"), "",
            "*map distance*: after the best similarity alignment (per component), RMS and largest distance between "
            "the two maps' face corners, relative to the layout's extent. Time: fastest of "
            f"{max(1, int(repeats))} runs; the binary's includes process start and writing/reading the OBJ."]
    body += ["", "## What the rows say", ""] + _agreement_findings(rows)
    notes = [PAPER_NOTE + " The paper's BFF column is shown beside all three runs.",
             "Flips count faces with det J ≤ 0 (a face whose UV area rounds to zero counts)."]
    files = [write_csv(out / "bff_agreement.csv", rows)]
    files.append(write_markdown(out / "bff_agreement.md", "BFF: our Python implementation vs the v1.6 binary",
                                "\n".join(body), command=command_line("baselines", args), machine=machine, notes=notes))
    return BenchOutput("baselines", rows, files[-1].read_text(), files)


def _agreement_findings(rows):
    def get(mesh, label):
        return next((r for r in rows if r["mesh"] == mesh and r["variant"] == label), None)

    lines = []
    for mesh in dict.fromkeys(r["mesh"] for r in rows):
        ours, std, full = (get(mesh, v[0]) for v in BFF_VARIANTS)
        lab = MESH_LABELS.get(mesh, mesh)
        if std is None or std["status"] != "ok":
            lines.append(f"- {lab}: the binary did not run ({std['status'] if std else 'no row'}: "
                         f"{std['reason'] if std else ''}).")
            continue
        d = std.get("esd_rel_diff")
        parts = [f"- {lab}: binary (as documented) E_SD {fmt_num(std['esd'])}, {int(std['flips'])} flipped or "
                 f"zero-area faces; ours {fmt_num(ours['esd'])}, {int(ours['flips'])}"
                 + (f" (ΔE_SD {100 * d:+.2f}%)" if d is not None else "")]
        if full is not None and full["status"] == "ok":
            dist = full.get("rms_distance")
            parts.append(f"full precision: E_SD {fmt_num(full['esd'])}, {int(full['flips'])} flips"
                         + (f", map distance to ours {dist:.1e} of the extent (RMS)" if dist is not None else ""))
        pv = PV.COMPACT_PRELIM.get((mesh, "bff"))
        if pv:
            parts.append(f"paper: E_SD {fmt_num(pv['esd'])}, {fmt_pct(pv['flip_percent'])} flips")
        lines.append("; ".join(p for p in parts if p) + ".")
    return lines


# ------------------------------------------------------------------ OptCuts on xatlas charts

def optcuts_sample(n_charts=10, *, sources=None, output="results/baselines", resume=False, timeout=600,
                   face_range=SAMPLE_RANGE, show_progress=True, args=None):
    """OptCuts on ``n_charts`` xatlas-cut disk-like charts of 1K–40K faces; writes ``optcuts_sample.{md,csv}``.

    Valid = OptCuts returned a map with finite UVs and no flipped face
    (OptCuts recuts, so E_SD is that of its own cut).

    Returns
    -------
    BenchOutput
    """
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    machine = machine_info("cpu")
    sources = list(sources or default_sources())
    pool, failed = chart_pool(sources, out / "cache", show_progress)
    lo, hi = face_range
    label = f"{lo // 1000}K–{hi // 1000}K"
    chosen = select_charts(pool, n_charts, [(lo, hi + 1, label)])
    in_range = [c for c in pool if lo <= c["faces"] <= hi]
    log = RowLog(out / "optcuts_rows.jsonl", resume=resume)
    rows = []
    for c in progress(chosen, desc="optcuts", disable=not show_progress):
        key = (f"{c['source']}#{c['chart']}", "optcuts", {"timeout": timeout})

        def compute():
            res = run_baseline("optcuts", c["V"], c["F"], timeout=timeout)
            row = _row(res)
            row["finite"] = bool(res.uv is not None and np.isfinite(res.uv).all())
            row["valid"] = bool(res.status == "ok" and res.metrics.get("valid"))
            row["cut_vertices"] = None if res.V is None else int(len(res.V))
            return row

        row = dict(log.run(key, compute))
        row.update({"source": c["source"], "chart": c["chart"], "faces": c["faces"], "vertices": int(len(c["V"]))})
        rows.append(row)

    n_valid = sum(bool(r["valid"]) for r in rows)
    table = [[f"{r['source']} #{r['chart']}", f"{r['faces']:,}", r["status"],
              "yes" if r["valid"] else "no", fmt_num(r["esd"]) if r["status"] == "ok" else "—",
              f"{fmt_pct(r['flip_percent'])}" if r["status"] == "ok" else "—",
              fmt_num(r["min_det"], 3) if r["status"] == "ok" else "—", fmt_time(r["time"]),
              (r.get("reason") or "")[:90]] for r in rows]
    body = [f"OptCuts binary: `{optcuts_binary() or 'not built'}` (OptCuts @ cd23026, built by `make baselines`), "
            "run headless as `OptCuts_bin 100 mesh.obj 0.999 0 0 4.1 1 0` (joint cut + distortion optimisation, "
            f"E_SD bound 4.1, bijectivity on), at most {timeout} s per chart.",
            f"Charts: xatlas cut of {len(sources)} sources ({', '.join(sources)}): {len(pool)} charts, "
            f"{len(in_range)} of {lo:,}–{hi:,} faces ({sum(c['disk'] for c in in_range)} disk-like); "
            f"{len(chosen)} taken evenly over that size range (`neuraluv_paper.bench.charts.select_charts`).", "",
            f"**OptCuts valid on {fraction(n_valid, len(rows))}** (paper: 9/10 on a 1K–40K Thingi-style sample).", "",
            markdown_table(["Chart", "Faces", "Status", "Valid", "E_SD", "%Flip", "min det J", "Time (s)", "Reason"],
                           table, "lrlcrrrrl")]
    esd = [float(r["esd"]) for r in rows if r["valid"]]
    notes = ["Valid: OptCuts returned a map with finite UVs and zero flipped faces (on its own cut mesh).",
             "These charts come from the registry's closed meshes, not Thingi10K: fewer and more regular "
             "charts than the paper's sample. xatlas cuts charts that are nearly developable"
             + (f" (median E_SD of OptCuts' maps here: {fmt_num(float(np.median(esd)), 3)})" if esd else "")
             + ", so this sample hardly stresses OptCuts; Table 1's (tab:compact_prelim) Hand and Camel are harder tests of it."]
    if failed:
        notes.append("Sources that could not be used: " + "; ".join(f"{s} ({r})" for s, r in failed))
    if log.skipped:
        notes.append(f"{log.skipped} row(s) taken from the resume log ({out / 'optcuts_rows.jsonl'}).")
    files = [write_csv(out / "optcuts_sample.csv", rows)]
    files.append(write_markdown(out / "optcuts_sample.md", f"OptCuts on {len(rows)} xatlas charts of {label} faces",
                                "\n".join(body), command=command_line("baselines", args), machine=machine, notes=notes))
    return BenchOutput("baselines", rows, files[-1].read_text(), files, skipped=log.skipped,
                       extra={"valid": n_valid, "pool": len(pool)})


# ------------------------------------------------------------------ CLI

def add_arguments(p):
    p.add_argument("--repeats", type=int, default=3, help="runs per BFF variant; the fastest time is kept (default 3)")
    p.add_argument("--optcuts-sample", type=int, default=0, metavar="N",
                   help="also run OptCuts on N xatlas charts of 1K-40K faces (the paper: 10); 0 = skip (default)")
    p.add_argument("--optcuts-timeout", type=int, default=600, help="seconds per OptCuts run (default 600)")
    p.add_argument("--no-bff", action="store_true", help="skip the BFF agreement report")


def run(args):
    if getattr(args, "quick", False):
        args.meshes = args.meshes or ["camel"]
    outs = []
    if not args.no_bff:
        outs.append(bff_agreement(args.meshes, output=args.output, repeats=1 if args.quick else args.repeats,
                                  show_progress=not args.quiet, args=args))
    if args.optcuts_sample:
        if optcuts_binary() is None:
            raise NeuralUVError("OptCuts binary not found: run `make baselines` (or set NEURALUV_OPTCUTS)")
        outs.append(optcuts_sample(args.optcuts_sample, output=args.output, resume=args.resume,
                                   timeout=args.optcuts_timeout, show_progress=not args.quiet, args=args))
    return print_report(*outs)
