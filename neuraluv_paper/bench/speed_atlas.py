"""``neuraluv bench speed --atlas``: ``neuraluv atlas`` with its defaults, one process per asset, timed end to end."""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from neuraluv import datasets
from neuraluv.datasets.generated import generated_asset
from neuraluv.io import write_obj
from neuraluv_paper.bench.provenance import (BenchOutput, command_line, machine_info, markdown_table, write_csv,
                                             write_markdown)

__all__ = ["atlas_timing", "ATLAS_MESHES"]


ATLAS_MESHES = ["cow", "nefertiti", "ogre"]


def atlas_timing(meshes=None, n_generated=50, *, output="results/speed", quick=False, argv=None, show_progress=True,
                 extra=()):
    """``neuraluv atlas`` with its defaults, one process per asset, timed end to end (``atlas.{csv,md}``).

    Each asset is written to an OBJ first (the generated set as
    :func:`neuraluv.datasets.generated.generated_set` makes it); the verdict is
    the command's own read-back validation of the file it wrote (coverage,
    flips, overlaps, padding), taken from its JSON report.
    """
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    machine = machine_info("cpu")
    meshes = list(meshes or (["cow"] if quick else ATLAS_MESHES))
    n_generated = min(n_generated, 3) if quick else n_generated
    rows = []
    with tempfile.TemporaryDirectory(prefix="neuraluv_atlas_timing_") as tmp:
        tmp = Path(tmp)
        inputs = []
        for m in meshes:
            if datasets.available(m):
                inputs.append((m, "registry", datasets.fetch(m, download=False)))
        for i in range(n_generated):
            V, F, _ = generated_asset(i)
            p = tmp / f"generated_{i:03d}.obj"
            write_obj(p, V, F, np.zeros((len(V), 2)))
            inputs.append((p.stem, "generated", p))
        for name, kind, path in inputs:
            res_obj, rep = tmp / f"{name}_atlas.obj", tmp / f"{name}_report.json"
            cmd = [sys.executable, "-m", "neuraluv", "atlas", str(path), "-o", str(res_obj), "--report", str(rep), "--quiet",
                   *extra]
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
            else:
                row.update({"ok": False, "error": (err_text or out_text).strip()[-200:]})
            rows.append(row)
            if show_progress:
                print(f"atlas {name:16s} {row.get('faces', 0):7d} faces {wall:7.1f}s ok={row.get('ok')} "
                      f"flips={row.get('flips')} overlaps={row.get('overlaps')} peak {row['peak_rss_mb']:.0f} MB", flush=True)
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
    md = "\n".join([markdown_table(head, body), "",
                    "Each row is one `neuraluv atlas IN -o OUT.obj --report R.json` process with default options "
                    "(preset `fast`), timed from start to exit; *peak MB* is the process's peak resident memory; "
                    "flips, overlaps, coverage and padding are the command's validation of the OBJ it wrote, read back."])
    cmd = command_line("speed") if argv is None else "neuraluv " + " ".join(argv)
    files = [write_csv(out / "atlas.csv", rows),
             write_markdown(out / "atlas.md", "Atlas throughput: `neuraluv atlas` with defaults", md, command=cmd,
                            machine=machine)]
    return BenchOutput(name="atlas-speed", rows=rows, markdown=md, files=files)
