"""``neuraluv bench speed``: the solver's speed as a measured property.

For each chart, in one run on one machine:

* **floor** — the bare network's forward + backward pass at that chart size
  (the cost no solver with this network can go below), for each preset's network;
* **per-iteration split** — the solver's time per accepted iteration split into
  network forward (including rejected trials), backward, Jacobian + loss,
  optimiser (the state update and merge) and bookkeeping (host decisions, traces);
  ``rounds / iteration`` counts the forward passes per accepted step;
* **end to end** — each preset's wall time (features, Tutte start, solve), E_SD and
  flips, beside libigl SLIM-100 and SLIM-1k from the **same start**, and the ratio
  preset time / SLIM-1k time;
* **peak memory** of the process while the chart was solved (resident set size).

Charts: Camel, Hand and Bob (the compact charts), xatlas-cut charts of about 100
and 1,000 faces from the registry's closed meshes, and face-ring disks of about
10,000 and 50,000 faces on nefertiti (xatlas makes no chart that large; the disk
is grown ring by ring from a seed face, so it is one boundary loop, no handle).
Where a preset's full budget would take too long on this device (``--max-seconds``),
its end-to-end time is *projected* from the measured iterations and marked so.

``--pareto`` instead runs the Pareto study of the ``fast`` preset's design
(network width and depth, ω₀, optimiser, budget) on the compact charts and
writes ``pareto.{csv,md,png}`` with the paper's Pareto points and SLIM's.

The Pareto study (``--pareto``) is :mod:`~neuraluv_paper.bench.speed_pareto`, the atlas throughput
(``--atlas``) :mod:`~neuraluv_paper.bench.speed_atlas`; this module holds the chart set and the timing
helpers they share.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order

from neuraluv import datasets
from neuraluv.atlas.candidates import seam_charts
from neuraluv.meshfix import repair_mesh
from neuraluv.metrics import distortion_metrics
from neuraluv.solver.config import get_config
from neuraluv.solver.device import resolve_device
from neuraluv.solver.batch import make_batch
from neuraluv.solver.engine import optimise
from neuraluv.solver.siren import flat_grad, forward, init_params, leaves
from neuraluv.topology import face_components, is_disk_like, submesh
from neuraluv_paper.bench.common import combine_metrics, peak_rss_mb, slim_reference
from neuraluv_paper.bench.provenance import (BenchOutput, RowLog, command_line, fmt_num, machine_info,
                                             markdown_table, print_report, save_figure, write_csv, write_markdown)
from neuraluv_paper.bench.speed_atlas import atlas_timing
from neuraluv_paper.bench.speed_pareto import pareto

__all__ = ["bench", "add_arguments", "run", "speed_charts", "grown_disk", "network_floor"]

#: The rows of the speed table: (name, how to build it).
CHARTS = ["camel", "hand", "bob", "xatlas-100", "xatlas-1k", "disk-10k", "disk-50k"]
QUICK_CHARTS = ["glove", "xatlas-100"]
PRESETS_TIMED = ["fast", "paper"]


# --------------------------------------------------------------------------- charts


def grown_disk(V, F, n_faces, seed_face=0):
    """A disk-like face set of about ``n_faces`` grown ring by ring from ``seed_face``.

    The faces reached by breadth-first search over shared edges, stopped with the
    first ring that reaches ``n_faces``; every component of the complement but
    the largest is added back, so on a closed genus-0 surface the result has one
    boundary loop (a topological disk).

    Returns
    -------
    fidx : (k,) int array

    Examples
    --------
    >>> from neuraluv.datasets import sphere
    >>> from neuraluv.topology import is_disk_like, submesh
    >>> V, F = sphere(3)
    >>> f = grown_disk(V, F, 300)
    >>> vi, Fl = submesh(F, f); bool(250 <= len(f) <= 700), is_disk_like(V[vi], Fl)[0]
    (True, True)
    """
    F = np.asarray(F, np.int64)
    m = len(F)
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, inv = np.unique(E, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    A = sp.coo_matrix((np.ones(3 * m), (np.tile(np.arange(m), 3), inv)), shape=(m, inv.max() + 1)).tocsr()
    order, pred = breadth_first_order((A @ A.T).tocsr(), seed_face, directed=False, return_predecessors=True)
    depth = np.zeros(m, np.int64)
    for f in order[1:]:
        depth[f] = depth[pred[f]] + 1
    ring = depth[order[min(n_faces, len(order)) - 1]]
    inside = np.zeros(m, bool)
    inside[order[depth[order] <= ring]] = True
    out = np.flatnonzero(~inside)
    if len(out):
        _, lab = face_components(F[out])
        inside[out[lab != np.argmax(np.bincount(lab))]] = True
    return np.flatnonzero(inside)


def speed_charts(names, quick=False):
    """``[(name, description, [(V, F), ...])]`` for the speed table (missing data skipped with a note)."""
    out, notes = [], []
    for name in names:
        try:
            if name in ("camel", "hand", "bob", "glove"):
                charts = datasets.load_charts(name)
                what = {"bob": "3 charts", "glove": "procedural"}.get(name, "compact chart")
            elif name.startswith("xatlas-"):
                target = 100 if name.endswith("100") else 1000
                best = None
                for src in ("cow", "spot", "fandisk", "bunny"):
                    if not datasets.available(src):
                        continue
                    V, F = datasets.load(src)
                    V, F, _, _ = repair_mesh(V, F)
                    for f in seam_charts(V, F):
                        vi, Fl = submesh(F, f)
                        if is_disk_like(V[vi], Fl)[0]:
                            gap = abs(math.log(len(f) / target))
                            if best is None or gap < best[0]:
                                best = (gap, src, V[vi], Fl)
                if best is None:
                    raise datasets.DataMissing("no cached closed mesh to cut (cow, spot, fandisk, bunny)")
                charts, what = [(best[2], best[3])], f"xatlas chart of {best[1]}"
            elif name.startswith("disk-"):
                target = 10000 if name.endswith("10k") else 50000
                V, F = datasets.load("nefertiti")
                V, F, _, _ = repair_mesh(V, F)
                vi, Fl = submesh(F, grown_disk(V, F, target))
                if not is_disk_like(V[vi], Fl)[0]:
                    raise RuntimeError("the grown region is not a disk")
                charts, what = [(V[vi], Fl)], "face-ring disk on nefertiti"
            else:
                charts, what = [datasets.load(name)], "registry"
        except Exception as exc:  # noqa: BLE001 - a missing mesh is a note, not a failure
            notes.append(f"{name}: skipped ({exc})")
            continue
        out.append((name, what, charts))
    return out, notes


# --------------------------------------------------------------------------- measurements


def network_floor(preps, cfg, device, reps=None):
    """Seconds of one forward + backward pass of the bare chart network(s) at these chart sizes.

    The same SIREN as the solver's (batched as the solver batches these charts),
    a trivial loss (the sum of the outputs), no Jacobians, no checks.
    """
    import torch

    from neuraluv.solver.chart import batch_plan

    total = 0.0
    for group in batch_plan([len(p.X) for p in preps], 60000, 512):
        batch = make_batch([preps[i] for i in group], device=device)
        theta = init_params([0] * batch.B, batch.X.shape[2], cfg, device=device)
        net = dict(width=cfg.width, n_layers=cfg.n_layers, omega0=float(cfg.omega0))

        def once():
            th = leaves(theta, batch.X.shape[2], cfg.width, cfg.n_layers)
            forward(th, batch.X, batch.base, **net).sum().backward()
            flat_grad(th)

        once()
        once()
        t = time.perf_counter()
        once()
        single = time.perf_counter() - t
        n = reps or int(min(50, max(10, 5.0 / max(single, 1e-6))))   # about 5 s of timing, 10-50 passes
        ts = []
        for _ in range(n):
            if device.type == "cuda":
                torch.cuda.synchronize(device)
            t = time.perf_counter()
            once()
            if device.type == "cuda":
                torch.cuda.synchronize(device)
            ts.append(time.perf_counter() - t)
        total += float(np.median(ts))
    return total


def _time_preset(preps, cfg, device, max_seconds):
    """End-to-end solve of these prepared charts with ``cfg`` (projected when over ``max_seconds``)."""
    from neuraluv.solver.chart import batch_plan

    res = {"rounds": 0, "iterations": 0, "timing": {}, "projected": False}
    t0 = time.perf_counter()
    deadline = t0 + max_seconds if max_seconds else None
    metrics, its, stops = [], [], []
    for group in batch_plan([len(p.X) for p in preps], 60000, 512):
        batch = make_batch([preps[i] for i in group], residual=cfg.residual and cfg.init == "tutte", device=device)
        r = optimise(batch, cfg, [0] * batch.B, deadline=deadline, profile=True)
        res["rounds"] += r.rounds
        for k, v in r.timing.items():
            res["timing"][k] = res["timing"].get(k, 0.0) + v

        for k, i in enumerate(group):
            p = preps[i]
            uv = r.best_uv[k, : len(p.X)] * p.scale
            metrics.append((i, distortion_metrics(p.V, p.F, uv)))
            its.append(len(r.traces[k]["iter"]))
            stops.append(r.stop[k].label)
    res["solve"] = time.perf_counter() - t0
    res["iterations"] = int(max(its)) if its else 0
    metrics = [m for _, m in sorted(metrics, key=lambda x: x[0])]
    res["esd"] = combine_metrics(metrics, preps)
    res["flips"] = int(sum(m["flips"] for m in metrics))
    res["stops"] = stops
    if "time" in stops and res["iterations"] > 0:
        res["projected"] = True
        res["solve_projected"] = res["solve"] * cfg.iterations / res["iterations"]
    return res


# --------------------------------------------------------------------------- the table


def bench(charts=None, presets=None, *, quick=False, output="results/speed", device="auto", max_seconds=None,
          show_progress=True, argv=None, resume=False):
    """Run the speed benchmark; returns a :class:`~neuraluv_paper.bench.provenance.BenchOutput`.

    Every finished row goes to ``OUTPUT/rows.jsonl`` at once, so a run stopped part way keeps
    its rows, and ``resume=True`` (``--resume``) continues with the rows not yet there.
    """
    import torch

    from neuraluv.solver.chart import prepare_chart

    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    dev = resolve_device(device)
    names = list(charts or (QUICK_CHARTS if quick else CHARTS))
    presets = list(presets or (["fast", "test"] if quick else PRESETS_TIMED))
    max_seconds = max_seconds if max_seconds is not None else (30.0 if quick else 900.0)
    loaded, notes = speed_charts(names, quick)
    machine = machine_info(dev)
    log = RowLog(out / "rows.jsonl", resume=resume)
    setting = {"device": str(dev), "max_seconds": max_seconds, "quick": bool(quick)}
    rows = []
    for name, what, charts_ in loaded:
        n_faces = sum(len(F) for _, F in charts_)
        n_verts = sum(len(V) for V, _ in charts_)
        base = {"chart": name, "source": what, "faces": n_faces, "vertices": n_verts, "charts": len(charts_),
                "device": str(dev)}
        slim_done = {}
        for preset in presets:
            if log.done((name, preset, setting)):  # non-finite numbers were logged as strings
                rows.append({k: float(v) if v in ("nan", "inf", "-inf") else v
                             for k, v in log.get((name, preset, setting)).items()})
                continue
            cfg = get_config(preset)
            if quick and preset == "paper":
                cfg = get_config(cfg, iterations=20)
            peak_rss_mb(reset=True)
            t = time.perf_counter()
            preps = [prepare_chart(V, F, cfg, check=True) for V, F in charts_]
            t_prep = time.perf_counter() - t
            floor = network_floor(preps, cfg, dev)
            r = _time_preset(preps, cfg, dev, max_seconds)
            peak = peak_rss_mb()
            n_it = max(r["iterations"], 1)
            split = {k: v / n_it for k, v in r["timing"].items()}
            per_it = sum(split.values())
            key = preps[0].start
            if key not in slim_done:
                s100 = slim_reference(preps, 100)
                s1k = slim_reference(preps, 10 if quick else 1000)
                slim_done[key] = (s100, s1k)
            s100, s1k = slim_done[key]
            wall = t_prep + (r["solve_projected"] if r["projected"] else r["solve"])
            row = dict(base, preset=preset, network=f"{cfg.width}x{cfg.n_layers} w0={cfg.omega0:g}",
                       optimizer=cfg.optimizer, budget=cfg.iterations, iterations=r["iterations"],
                       rounds=r["rounds"], rounds_per_it=r["rounds"] / n_it, prep_s=t_prep, floor_ms=1e3 * floor,
                       per_it_ms=1e3 * per_it, ratio_floor=per_it / floor if floor > 0 else float("nan"),
                       **{f"{k}_ms": 1e3 * v for k, v in split.items()},
                       wall_s=wall, projected=r["projected"], esd=r["esd"], flips=r["flips"],
                       slim100_s=s100[0], slim100_esd=s100[1], slim1k_s=s1k[0], slim1k_esd=s1k[1], slim1k_flips=s1k[2],
                       ratio_slim1k=wall / s1k[0] if s1k[0] > 0 else float("nan"), peak_rss_mb=peak,
                       start=key, stops=",".join(sorted(set(r["stops"]))))
            rows.append(row)
            log.add((name, preset, setting), row)
            if show_progress:
                print(f"{name:10s} {preset:6s} {n_faces:6d} faces: floor {1e3 * floor:7.2f} ms, per it {1e3 * per_it:7.2f} ms "
                      f"(x{row['ratio_floor']:.2f}), {row['iterations']} its, wall {wall:7.1f}s{' (projected)' if r['projected'] else ''}, "
                      f"E_SD {r['esd']:.4f}, flips {r['flips']} | SLIM-1k {s1k[0]:.1f}s E_SD {s1k[1]:.4f} | "
                      f"x{row['ratio_slim1k']:.2f} SLIM-1k | peak {peak:.0f} MB", flush=True)
    md = _markdown(rows, machine, notes, quick)
    cmd = command_line("speed") if argv is None else "neuraluv " + " ".join(argv)
    files = [write_csv(out / "speed.csv", rows)]
    files.append(write_markdown(out / "speed.md", "Solver speed: floor, cost split, presets vs SLIM", md,
                                command=cmd, machine=machine, notes=notes))
    if rows:
        files.append(_figure(rows, out / "speed.png"))
    with open(out / "run.json", "w") as fh:
        json.dump({"command": cmd, "machine": machine, "torch": torch.__version__, "rows": len(rows)}, fh, indent=2)
    return BenchOutput(name="speed", rows=rows, markdown=md, files=files)


def _markdown(rows, machine, notes, quick):
    head = ["chart", "faces", "preset", "network", "its", "floor ms", "per it ms", "× floor", "fwd", "bwd", "J+loss",
            "optim", "book", "rounds/it", "wall s", "E_SD", "flips", "SLIM-100 s (E_SD)", "SLIM-1k s (E_SD)", "× SLIM-1k",
            "peak MB"]
    body = []
    for r in rows:
        body.append([r["chart"], f"{r['faces']:,}", r["preset"], r["network"], r["iterations"], f"{r['floor_ms']:.2f}",
                     f"{r['per_it_ms']:.2f}", f"{r['ratio_floor']:.2f}", f"{r.get('forward_ms', 0):.2f}",
                     f"{r.get('backward_ms', 0):.2f}", f"{r.get('objective_ms', 0):.2f}", f"{r.get('optimiser_ms', 0):.2f}",
                     f"{r.get('bookkeeping_ms', 0):.2f}", f"{r['rounds_per_it']:.2f}",
                     f"{r['wall_s']:.1f}" + ("*" if r["projected"] else ""), fmt_num(r["esd"], 3), r["flips"],
                     f"{r['slim100_s']:.1f} ({fmt_num(r['slim100_esd'], 3)})",
                     f"{r['slim1k_s']:.1f} ({fmt_num(r['slim1k_esd'], 3)})", f"{r['ratio_slim1k']:.2f}",
                     f"{r['peak_rss_mb']:.0f}"])
    text = [markdown_table(head, body), "",
            "Columns: *floor* = one forward + backward pass of the bare network at this size; *per it* = the "
            "solver's time per accepted iteration, split into *fwd* (network forward, rejected trials included), "
            "*bwd* (backward), *J+loss* (Jacobians, energy, barrier, per-chart sums), *optim* (Adam / L-BFGS update "
            "and the accepted/trial merge) and *book* (host decisions, traces); *rounds/it* = forward passes per "
            "accepted step; *wall* = features + start + solve, end to end (* projected from the iterations measured "
            "within the time cap); SLIM from the same start as the solver (libigl, 100 and 1,000 iterations); "
            "× SLIM-1k = wall / SLIM-1k time."]
    if quick:
        text.append("\n**Quick run** (CI): tiny budgets; the numbers only show that the benchmark runs.")
    return "\n".join(text)


def _figure(rows, path):
    charts = list(dict.fromkeys(r["chart"] for r in rows))
    presets = list(dict.fromkeys(r["preset"] for r in rows))
    fig, axes = plt.subplots(1, len(presets), figsize=(5.5 * len(presets), 3.8), squeeze=False)
    parts = ["forward", "backward", "objective", "optimiser", "bookkeeping"]
    for ax, preset in zip(axes[0], presets):
        sel = [next((r for r in rows if r["chart"] == c and r["preset"] == preset), None) for c in charts]
        x = np.arange(len(charts))
        bottom = np.zeros(len(charts))
        for part in parts:
            vals = np.array([r.get(f"{part}_ms", 0.0) / r["floor_ms"] if r else 0.0 for r in sel])
            ax.bar(x, vals, bottom=bottom, label=part)
            bottom += vals
        ax.axhline(1.0, color="k", lw=0.8, ls="--", label="floor (bare fwd+bwd)")
        ax.set_xticks(x, [f"{c}\n{r['faces']:,}" if r else c for c, r in zip(charts, sel)], fontsize=7)
        ax.set_ylabel("time per iteration / floor")
        ax.set_title(f"{preset}: cost split per accepted iteration", fontsize=9)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path, dpi=100)


# --------------------------------------------------------------------------- the fast preset's Pareto study


def add_arguments(p):
    """``bench speed`` options beyond the shared ones."""
    p.add_argument("--charts", nargs="+", default=None, metavar="NAME",
                   help=f"rows (default: {' '.join(CHARTS)}; names: compact charts, xatlas-100, xatlas-1k, disk-10k, disk-50k)")
    p.add_argument("--presets", nargs="+", default=None, metavar="P", help="presets to time (default: fast paper)")
    p.add_argument("--max-seconds", type=float, default=None,
                   help="time cap per preset and chart; longer solves are projected from the iterations measured (default 900)")
    p.add_argument("--pareto", action="store_true", help="run the fast preset's Pareto study instead (pareto.*)")
    p.add_argument("--atlas", action="store_true",
                   help="time `neuraluv atlas` with defaults on cow, spot, fertility, nefertiti and the generated set "
                        "instead, beside xatlas's and Blender's atlases of the same meshes, and our islands of each "
                        "real mesh packed by ours, xatlas's and Blender's packers (atlas.*)")
    p.add_argument("--n-generated", type=int, default=50, help="generated assets for --atlas (default 50)")


def run(args):
    """CLI entry point: the speed table, or with ``--atlas`` / ``--pareto`` the atlas throughput / the Pareto study."""
    if args.atlas:
        return print_report(atlas_timing(args.meshes, args.n_generated, output=args.output, quick=args.quick,
                                         show_progress=not args.quiet))
    if args.pareto:
        return print_report(pareto(output=args.output, device=args.device, quick=args.quick,
                                   show_progress=not args.quiet))
    return print_report(bench(args.charts or args.meshes, args.presets, quick=args.quick, output=args.output,
                              device=args.device, max_seconds=args.max_seconds, show_progress=not args.quiet,
                              resume=args.resume))

