"""``neuraluv bench speed --atlas``: ``neuraluv atlas`` with its defaults, one process per asset, timed end to end,
per stage (from the command's own report), beside xatlas's own atlas and Blender's (Smart UV Project + Pack Islands,
:mod:`~neuraluv_paper.bench.pack_reference`) of the same mesh in the same run, one asset run as two concurrent
processes (the busy-machine case), the islands of our atlas of each real mesh packed afresh by our, xatlas's and
Blender's packers, and ``neuraluv unwrap`` of Camel beside libigl SLIM-1k."""
from __future__ import annotations

import inspect
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from neuraluv import datasets
from neuraluv.atlas.build import build_atlas
from neuraluv.datasets.generated import generated_asset
from neuraluv.io import load_mesh, read_obj, write_obj
from neuraluv.jacobian import signed_areas_2d
from neuraluv_paper.bench.pack_reference import blender_atlas, packer_reference, packers_markdown
from neuraluv_paper.bench.provenance import (
    BenchOutput,
    command_line,
    fmt_num,
    fmt_pct,
    machine_info,
    markdown_table,
    write_csv,
    write_markdown,
)

__all__ = ["atlas_timing", "blender_markdown", "ATLAS_MESHES", "RESOLUTION", "PADDING"]


ATLAS_MESHES = ["cow", "spot", "fertility", "nefertiti"]

#: The stages of the atlas report's ``info["timings"]``, in order (I/O is the rest of the process's wall time:
#: imports, reading, writing, the read-back validation).
STAGES = ("repair", "candidates", "routing", "packing", "validation")

#: ``neuraluv atlas``'s texture resolution and padding (texels) by default: the xatlas and Blender atlases and the
#: packer references are made at the same.
RESOLUTION, PADDING = (inspect.signature(build_atlas).parameters[k].default for k in ("resolution", "padding"))

#: The Blender columns' keys in a row: ``blender_`` + a key of
#: :func:`~neuraluv_paper.bench.pack_reference.blender_atlas`.
BLENDER_KEYS = ("status", "reason", "version", "unwrap_s", "pack_s", "process_s", "islands", "utilisation", "flips",
                "overlapping_pairs", "self_overlapping_islands", "padding_violations", "min_gap_texels", "valid")


def _xatlas(V, F):
    """xatlas's own atlas (charts + pack, in process): (seconds, utilisation), NaN without xatlas."""
    try:
        from neuraluv_paper.bench.atlas_quality import xatlas_atlas
    except ImportError:
        return float("nan"), float("nan")
    _, ind, uv, secs, _ = xatlas_atlas(V, F, RESOLUTION, PADDING)
    return float(secs), float(np.abs(signed_areas_2d(uv, ind)).sum())


def _blender(V, F):
    """:func:`blender_atlas` as ``blender_*`` row fields."""
    b = blender_atlas(V, F, RESOLUTION, PADDING)
    return {f"blender_{k}": b[k] for k in BLENDER_KEYS if k in b}


def _atlas_cmd(path, out, rep, extra):
    return [sys.executable, "-m", "neuraluv", "atlas", str(path), "-o", str(out), "--report", str(rep), "--quiet",
            *extra]


def atlas_timing(meshes=None, n_generated=50, *, output="results/speed", quick=False, argv=None, show_progress=True,
                 extra=(), packers=True):
    """``neuraluv atlas`` with its defaults, one process per asset, timed end to end (``atlas.{csv,md}``).

    Each asset is written to an OBJ first (the generated set as
    :func:`neuraluv.datasets.generated.generated_set` makes it); the verdict is
    the command's own read-back validation of the file it wrote (coverage,
    flips, overlaps, padding), taken from its JSON report. Beside each: xatlas's
    own atlas and Blender's (:func:`~neuraluv_paper.bench.pack_reference.blender_atlas`;
    one line says why where Blender is missing). With ``packers``, the islands of
    our atlas of each registry mesh are packed again by ours, xatlas's and
    Blender's packers (:func:`~neuraluv_paper.bench.pack_reference.packer_reference`).
    Unless ``quick``, one more line: ``neuraluv unwrap`` of the paper's Camel chart,
    whole process, beside libigl SLIM-1k in process (issue 28's unwrap target).
    """
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    machine = machine_info("cpu")
    meshes = list((["cow"] if quick else ATLAS_MESHES) if meshes is None else meshes)
    n_generated = min(n_generated, 3) if quick else n_generated
    rows, packed = [], {}
    with tempfile.TemporaryDirectory(prefix="neuraluv_atlas_timing_") as tmp:
        tmp = Path(tmp)
        inputs = []
        missing = [m for m in meshes if not datasets.available(m)]
        if missing:  # a missing input is an error, never a shorter table
            raise datasets.DataMissing(f"the real mesh(es) {', '.join(missing)} not in {datasets.data_dir()}: "
                                       f"{datasets.FETCH_HINT}")
        for m in meshes:
            inputs.append((m, "registry", datasets.fetch(m, download=False)))
        for i in range(n_generated):
            V, F, _ = generated_asset(i)
            p = tmp / f"generated_{i:03d}.obj"
            write_obj(p, V, F, np.zeros((len(V), 2)))
            inputs.append((p.stem, "generated", p))
        for name, kind, path in inputs:
            res_obj, rep = tmp / f"{name}_atlas.obj", tmp / f"{name}_report.json"
            cmd = _atlas_cmd(path, res_obj, rep, extra)
            t = time.perf_counter()
            pr = subprocess.run(cmd, capture_output=True, text=True)
            out_text, err_text = pr.stdout, pr.stderr
            wall = time.perf_counter() - t
            row = {"asset": name, "kind": kind, "exit": pr.returncode, "wall_s": wall, "peak_rss_mb": float("nan")}
            if rep.exists():
                r = json.loads(rep.read_text())
                b, t_ = r["readback"], r["totals"]
                row["peak_rss_mb"] = float(r.get("peak_memory_mb", float("nan")))
                row.update({"faces": b["faces"], "covered": b["covered_faces"], "flips": b["flips"],
                            "overlaps": b["overlapping_pairs"], "padding_violations": b["padding_violations"],
                            "ok": r["ok"], "charts": t_["charts"], "neural_share": t_["neural_share"],
                            "exact_share": t_["exact_share"], "fallback_share": t_["fallback_share"],
                            "atlas_s": r["info"]["time"], **{f"t_{k}": v for k, v in r["info"]["timings"].items()}})
                row["t_io"] = wall - r["info"]["time"]
            else:
                row.update({"ok": False, "error": (err_text or out_text).strip()[-200:]})
            V, F = load_mesh(path)
            row["xatlas_s"], row["xatlas_utilisation"] = _xatlas(V, F)
            if res_obj.exists():
                Vo, Fo, UVo, FUVo = read_obj(res_obj)
                row["utilisation"] = float(np.abs(signed_areas_2d(UVo, FUVo)).sum())  # as measured on the others
                if packers and kind == "registry":
                    packed[name] = packer_reference(Vo, Fo, UVo, FUVo, RESOLUTION, PADDING)
            row.update(_blender(V, F))
            rows.append(row)
            if show_progress:
                print(f"atlas {name:16s} {row.get('faces', 0):7d} faces {wall:7.1f}s ok={row.get('ok')} "
                      f"flips={row.get('flips')} overlaps={row.get('overlaps')} peak {row['peak_rss_mb']:.0f} MB", flush=True)
        concurrent = _concurrent(inputs[0], tmp, extra, rows[0]) if inputs else None
        unwrap = None if quick else _unwrap(tmp, extra)
    md = _markdown(rows, concurrent, packed) + ("\n\n" + _unwrap_line(unwrap) if unwrap else "")
    cmd = command_line("speed") if argv is None else "neuraluv " + " ".join(argv)
    if unwrap:
        rows.append({"asset": "camel unwrap", "kind": "unwrap", **unwrap})
    if concurrent:
        rows.append({"asset": f"{concurrent['asset']} x2 concurrent", "kind": "concurrent",
                     "wall_s": max(concurrent["walls"]), "ok": all(concurrent["ok"]), "alone_s": concurrent["alone"]})
    rows += [{"asset": m, "kind": "packer", **{k: v for k, v in r.items() if k != "seam"}}
             for m, rs in packed.items() for r in rs]
    files = [write_csv(out / "atlas.csv", rows),
             write_markdown(out / "atlas.md", "Atlas throughput: `neuraluv atlas` with defaults", md, command=cmd,
                            machine=machine)]
    return BenchOutput(name="atlas-speed", rows=rows, markdown=md, files=files)


def _markdown(rows, concurrent, packed):
    """The report: the validity table, the per-stage table beside xatlas and Blender, the atlases' utilisation,
    the two-at-once line and the packer table."""
    gen = [r for r in rows if r["kind"] == "generated"]
    head = ["asset", "faces", "wall s", "peak MB", "charts", "neural / exact / fallback faces", "flips", "overlaps",
            "coverage", "ok"]
    body = [[r["asset"], f"{r.get('faces', 0):,}", f"{r['wall_s']:.1f}", f"{r['peak_rss_mb']:.0f}", r.get("charts", "—"),
             f"{100 * r.get('neural_share', 0):.1f} / {100 * r.get('exact_share', 0):.1f} / {100 * r.get('fallback_share', 0):.1f}%",
             r.get("flips", "—"), r.get("overlaps", "—"),
             f"{r.get('covered', 0)}/{r.get('faces', 0)}", "yes" if r.get("ok") else "**no**"]
            for r in rows if r["kind"] != "generated"]
    if gen:
        w = [r["wall_s"] for r in gen]
        body.append([f"{len(gen)} generated assets (median)", f"{int(np.median([r.get('faces', 0) for r in gen])):,}",
                     f"{np.median(w):.1f} (max {max(w):.1f})", f"{max(r['peak_rss_mb'] for r in gen):.0f} (max)",
                     int(np.median([r.get("charts", 0) for r in gen])),
                     f"{100 * np.median([r.get('neural_share', 0) for r in gen]):.1f} / "
                     f"{100 * np.median([r.get('exact_share', 0) for r in gen]):.1f} / "
                     f"{100 * np.median([r.get('fallback_share', 0) for r in gen]):.1f}%",
                     sum(r.get("flips", 0) or 0 for r in gen), sum(r.get("overlaps", 0) or 0 for r in gen),
                     f"{sum(r.get('covered', 0) for r in gen)}/{sum(r.get('faces', 0) for r in gen)}",
                     f"{sum(bool(r.get('ok')) for r in gen)}/{len(gen)}"])
    stage_head = ["asset", "wall s", *STAGES, "I/O", "xatlas s (charts + pack)", "wall / xatlas",
                  "Blender s (unwrap + pack; process)", "wall / Blender process"]
    stage_body = [[r["asset"], f"{r['wall_s']:.1f}", *[f"{r.get('t_' + k, float('nan')):.1f}" for k in STAGES],
                   f"{r.get('t_io', float('nan')):.1f}", f"{r['xatlas_s']:.2f}", _ratio(r["wall_s"], r["xatlas_s"]),
                   *_blender_seconds(r)] for r in rows if r["kind"] != "generated"]
    if gen:
        med = {k: float(np.median([r.get("t_" + k, np.nan) for r in gen])) for k in (*STAGES, "io")}
        xs = float(np.median([r["xatlas_s"] for r in gen]))
        stage_body.append([f"{len(gen)} generated (median)", f"{np.median(w):.1f}", *[f"{med[k]:.1f}" for k in STAGES],
                           f"{med['io']:.1f}", f"{xs:.2f}", _ratio(np.median(w), xs), *_blender_seconds(_median(gen))])
    conc = ([f"**Two at once** ({concurrent['asset']}, two `neuraluv atlas` processes started together on the same "
             f"cores): {concurrent['walls'][0]:.1f} s and {concurrent['walls'][1]:.1f} s against {concurrent['alone']:.1f} s "
             f"alone (×{max(concurrent['walls']) / concurrent['alone']:.2f}); both valid: "
             f"{'yes' if all(concurrent['ok']) else '**no**'}; faces routed to fallbacks: "
             f"{', '.join(f'{100 * x:.1f}%' for x in concurrent['fallback'])} (alone "
             f"{100 * concurrent['fallback_alone']:.1f}%).", ""] if concurrent else [])
    stages = ("Per stage (seconds, from each command's report; I/O = the rest of the process: imports, reading, "
              "writing, the read-back validation), beside xatlas's own atlas of the same mesh (its charts and packer, "
              "in process) and Blender's, timed in the same run:")
    each = ("Each row is one `neuraluv atlas IN -o OUT.obj --report R.json` process with default options (preset "
            "`fast`), timed from start to exit; *peak MB* is the process's peak resident memory; flips, overlaps, "
            "coverage and padding are the command's validation of the OBJ it wrote, read back.")
    return "\n".join([markdown_table(head, body), "", stages, "", markdown_table(stage_head, stage_body), "",
                      *blender_markdown(rows), *conc, each,
                      *(["", packers_markdown(packed, RESOLUTION, PADDING)] if packed else [])])


def _ratio(a, b):
    return "—" if not b > 0 else f"{a / b:.1f}×" if a / b < 10 else f"{a / b:.0f}×"


def _median(rows):
    """The generated set's summary row: medians of the seconds and utilisations, sums of the counts."""
    ok = [r for r in rows if r.get("blender_status") == "ok"]
    out = {"asset": f"{len(rows)} generated (median)", "wall_s": float(np.median([r["wall_s"] for r in rows])),
           "blender_status": "ok" if ok else rows[0].get("blender_status"),
           "blender_reason": rows[0].get("blender_reason"),
           "blender_valid": f"{sum(bool(r['blender_valid']) for r in ok)}/{len(rows)}"}
    medians = ("unwrap_s", "pack_s", "process_s", "utilisation", "islands", "min_gap_texels")
    for k in ("utilisation", "xatlas_utilisation", *(f"blender_{k}" for k in medians)):
        out[k] = float(np.median([r.get(k, np.nan) for r in (ok if k.startswith("blender") else rows)] or [np.nan]))
    for k in ("flips", "overlapping_pairs", "self_overlapping_islands", "padding_violations"):
        out[f"blender_{k}"] = sum(r[f"blender_{k}"] for r in ok)
    return out


def _blender_seconds(r):
    if r.get("blender_status") != "ok":
        return ["—", "—"]
    return [f"{r['blender_unwrap_s']:.2f} + {r['blender_pack_s']:.2f}; {r['blender_process_s']:.1f}",
            _ratio(r["wall_s"], r["blender_process_s"])]


def blender_markdown(rows):
    """The atlases' utilisation (ours, xatlas's, Blender's; one measure) and Blender's validity, or one line saying
    why Blender did not run."""
    runs = [r for r in rows if r["kind"] in ("registry", "generated")]
    down = [r for r in runs if r.get("blender_status") != "ok"]
    gen = [r for r in runs if r["kind"] == "generated"]
    head = ["asset", "utilisation: ours", "xatlas", "Blender", "Blender islands", "Blender flips",
            "Blender overlaps (pairs / self)", "Blender min gap (tx)", "Blender padding viol.", "Blender valid"]
    body = []
    for r in [q for q in runs if q["kind"] != "generated"] + ([_median(gen)] if gen else []):
        b = r.get("blender_status") == "ok"
        body.append([r["asset"], fmt_pct(100 * r.get("utilisation", np.nan)), fmt_pct(100 * r["xatlas_utilisation"]),
                     *([fmt_pct(100 * r["blender_utilisation"]), f"{r['blender_islands']:.0f}", r["blender_flips"],
                        f"{r['blender_overlapping_pairs']} / {r['blender_self_overlapping_islands']}",
                        fmt_num(r["blender_min_gap_texels"]), r["blender_padding_violations"],
                        r["blender_valid"] if isinstance(r["blender_valid"], str)
                        else ("yes" if r["blender_valid"] else "no")]
                       if b else ["—"] * 7)])
    version = next((r["blender_version"] for r in runs if r.get("blender_status") == "ok"), "")
    why = sorted({f"{r['blender_status']}: {r.get('blender_reason', '')}" for r in down})
    return [f"Blender {version}: Smart UV Project with its defaults (as the `blender-smart` baseline), then "
            f"`uv.pack_islands` (concave shapes, 90° steps, margin for {PADDING:g} texels at {RESOLUTION}), each "
            "operator timed inside the Blender process; *process* is that process from start to exit. Utilisation "
            "(UV area over the texture), flips and overlaps are measured on each layout read back, as our command "
            "measures its own:", "", markdown_table(head, body), "",
            *([f"Blender not run on {len(down)} of {len(runs)} assets — {'; '.join(why)}", ""] if down else [])]


def _unwrap(tmp, extra):
    """``neuraluv unwrap`` of the paper's Camel chart, whole process, beside libigl SLIM-1k in process (same run)."""
    from neuraluv_paper.baselines.libigl import slim

    V, F = datasets.load_charts("camel", largest=True)[0]
    path = tmp / "camel_chart.obj"
    write_obj(path, V, F, np.zeros((len(V), 2)))
    rep = tmp / "camel_unwrap.json"
    t = time.perf_counter()
    pr = subprocess.run([sys.executable, "-m", "neuraluv", "unwrap", str(path), "-o", str(tmp / "camel_unwrap.obj"),
                         "--report", str(rep), "--quiet", *extra], capture_output=True, text=True)
    wall = time.perf_counter() - t
    t = time.perf_counter()
    slim(V, F, iterations=1000)
    slim_s = time.perf_counter() - t
    r = json.loads(rep.read_text()) if rep.exists() else {}
    solve = sum(c.get("time", 0.0) for c in r.get("charts", [])) if r else float("nan")
    return {"faces": int(len(F)), "exit": pr.returncode, "wall_s": wall, "solve_s": solve, "slim_1k_s": slim_s,
            "ok": pr.returncode == 0}


def _unwrap_line(u):
    return (f"**Unwrap** (the paper's Camel chart, {u['faces']:,} faces): `neuraluv unwrap` with defaults, whole "
            f"process {u['wall_s']:.1f} s (its charts' solve {u['solve_s']:.1f} s, from its report) against libigl "
            f"SLIM-1k in process {u['slim_1k_s']:.1f} s in the same run: ×{u['wall_s'] / u['slim_1k_s']:.2f} "
            f"(exit {u['exit']}).")


def _concurrent(inp, tmp, extra, alone):
    """Run the first asset as two ``neuraluv atlas`` processes at once: their walls, validity and fallback shares."""
    name, _, path = inp
    procs, reps = [], []
    t = time.perf_counter()
    for k in range(2):
        rep = tmp / f"{name}_concurrent{k}.json"
        reps.append(rep)
        procs.append(subprocess.Popen(_atlas_cmd(path, tmp / f"{name}_concurrent{k}.obj", rep, extra),
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    walls = []
    for p in procs:
        p.wait()
        walls.append(time.perf_counter() - t)
    ok, fallback = [], []
    for rep in reps:
        r = json.loads(rep.read_text()) if rep.exists() else {}
        ok.append(bool(r.get("ok")))
        fallback.append(float(r.get("totals", {}).get("fallback_share", float("nan"))))
    return {"asset": name, "walls": walls, "ok": ok, "fallback": fallback, "alone": alone["wall_s"],
            "fallback_alone": float(alone.get("fallback_share", float("nan")))}
