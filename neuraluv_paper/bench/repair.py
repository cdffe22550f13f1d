"""``neuraluv bench repair``: UV repair with minimal change, on generated damage and real broken layouts.

Layouts:

* **camel** — the Camel chart, flattened by the neural solver (``fast``) and scaled
  into the unit square: one island;
* **cow atlas** — ``neuraluv atlas`` of cow (many islands), as written;
* **LSCM / ARAP camel** — libigl's maps of the Camel chart (they fold), scaled into
  the unit square: real broken layouts; **Blender Smart UV** when ``bpy`` is installed.

Generated damage (:mod:`neuraluv_paper.damage`, seeded): a local fold of a few
rings, scattered vertex noise, a mirrored island, two overlapping islands, an
island pushed out of the unit square, NaN UVs. Every repaired layout is written
to OBJ and read back; the verdict is taken on that file.

Columns: fixed (read back: 0 flips, 0 overlapping pairs, 0 self-overlapping and
0 mirrored islands, all UVs in [0,1]², every face covered), faces left
bit-identical (over the damaged island and over the layout), E_SD of the
undamaged layout and of the repaired one (both at the undamaged layout's texel
density, over the damaged island), time; ``mouette``'s Winslow untangler
(Garanzha et al. 2021, boundary locked, per-vertex UVs: the cases on the single
Camel chart) as the classical anchor, when installed.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from neuraluv import datasets
from neuraluv.atlas.build import build_atlas
from neuraluv.atlas.export import read_atlas
from neuraluv.io import write_obj
from neuraluv.jacobian import local_frames
from neuraluv.layout.facts import layout_facts, texel_density
from neuraluv.layout.validate import validate_layout
from neuraluv.meshfix import normalize_unit_box
from neuraluv.metrics import distortion_metrics
from neuraluv.repair.repair import repair_layout
from neuraluv_paper import damage
from neuraluv_paper.baselines.libigl import arap, lscm
from neuraluv_paper.bench.provenance import (BenchOutput, command_line, fmt_num, machine_info, markdown_table,
                                             save_figure, write_csv, write_markdown)
from neuraluv_paper.damage import boundary_rows

__all__ = ["bench", "add_arguments", "run", "mouette_untangle"]


def add_arguments(p):
    p.add_argument("--no-mouette", action="store_true", help="skip the mouette anchor even if it is installed")


def _into_unit_square(UV, margin=0.05):
    lo, hi = UV.min(0), UV.max(0)
    s = (1 - 2 * margin) / (hi - lo).max()
    return (UV - lo) * s + margin


def _layouts(quick, seed, preset):
    """``[(name, V, F, UV, FUV, kind)]``; kind "good" (damage it) or "broken" (repair as is)."""
    from neuraluv.solver.chart import solve_chart

    out, notes = [], []
    name = "glove" if quick else "camel"
    V, F = datasets.load_charts(name)[0] if name == "camel" else datasets.glove()
    r = solve_chart(V, F, preset, seed=seed, device="cpu")
    out.append((name, V, F, _into_unit_square(r.uv), F.copy(), "good"))
    if not quick:
        if datasets.available("cow"):
            Vc, Fc = datasets.load("cow")
            a = build_atlas(Vc, Fc, preset=preset, seed=seed, device="cpu", progress=False)
            out.append(("cow atlas", a.V, a.F, a.UV, a.FUV, "good"))
        else:
            notes.append("cow atlas: skipped (cow not fetched: `neuraluv data fetch cow`)")
    for meth, fn in (("LSCM", lscm), ("ARAP", arap)):
        uv = fn(V, F)
        out.append((f"{meth} {name}", V, F, _into_unit_square(uv), F.copy(), "broken"))
    try:
        from neuraluv_paper.baselines.external import blender_map

        uv, Vb, Fb, _ = blender_map(V, F, "SMART")
        out.append((f"Blender Smart UV {name}", Vb, Fb, uv, Fb.copy(), "broken"))
    except Exception as exc:  # noqa: BLE001 - optional extra
        notes.append(f"Blender Smart UV: not run ({(str(exc).splitlines() or [type(exc).__name__])[0]})")
    return out, notes


def _cases(name, V, F, UV, FUV, seed, quick):
    """Generated damage on one good layout: ``[(case, UV, FUV, island faces, info)]``."""
    f = layout_facts(V, F, UV, FUV)
    sizes = np.bincount(f.label[f.label >= 0], minlength=f.n_islands)
    big = int(np.argmax(sizes))
    fb = f.island_faces(big)
    rows_big = np.unique(FUV[fb])
    cases = []
    for k in range(1 if quick else 5):  # folds at several random places (seeds seed, seed+1, ...)
        for rings in ((2, 1) if quick else (3, 2, 1)):  # the largest fold the largest island holds
            try:
                uv, info = damage.local_fold(V, F, UV, FUV, rings=rings, seed=seed + k, rows=rows_big)
            except ValueError:
                continue
            if not info["flipped"]:  # pushed, but nothing folded: not a fold
                continue
            cases.append(("local fold", uv, FUV, fb, {**info, "rings": rings, "seed": seed + k}))
            break
    uv, info = damage.vertex_noise(V, F, UV, FUV, fraction=0.02, seed=seed, rows=rows_big)
    cases.append(("vertex noise", uv, FUV, fb, info))
    for rings in (2, 1, 0):
        try:
            uv, info = damage.nan_patch(V, F, UV, FUV, rings=rings, seed=seed, rows=rows_big)
        except ValueError:
            continue
        cases.append(("NaN UVs", uv, FUV, fb, {**info, "rings": rings}))
        break
    if f.n_islands > 1:
        order = np.argsort(sizes)[::-1]
        mid = int(order[len(order) // 4])
        second = int(order[1])
        uv, info = damage.mirror_island(UV, FUV, f.island_faces(mid))
        cases.append(("mirrored island", uv, FUV, f.island_faces(mid), info))
        uv, info = damage.overlap_islands(UV, FUV, f.island_faces(mid), f.island_faces(second))
        cases.append(("overlapping islands", uv, FUV, f.island_faces(mid), info))
        uv, info = damage.push_out(UV, FUV, f.island_faces(mid))
        cases.append(("island outside [0,1]²", uv, FUV, f.island_faces(mid), info))
    else:
        uv, info = damage.mirror_island(UV, FUV, fb)
        cases.append(("mirrored island", uv, FUV, fb, info))
        uv, info = damage.push_out(UV, FUV, fb, shift=(0.5, 0.0))
        cases.append(("island outside [0,1]²", uv, FUV, fb, info))
    return cases


def mouette_untangle(V, F, UV, *, scale):
    """mouette's Winslow untangler on a per-vertex disk chart, boundary locked: ``(UV, seconds)``.

    Raises ImportError when mouette is not installed. The first call compiles
    mouette's numba kernels; call once before timing.
    """
    from mouette.processing.parametrization import untangle as m_untangle


    Vn = normalize_unit_box(V)[0]
    K, A = local_frames(Vn, F)
    locked = boundary_rows(F, len(V))
    t = time.perf_counter()
    pts = m_untangle(np.asarray(UV, float).copy(), locked, np.asarray(F, np.int64), K / scale, areas=A)
    return pts.reshape(-1, 2), time.perf_counter() - t


def _verdict(path):
    V, F, UV, FUV = read_atlas(path)
    v = validate_layout(V, F, UV, FUV, check_padding=False)
    mirrored = v["mirrored_islands"]
    fixed = bool(v["valid"] and mirrored == 0 and v["covered_faces"] == v["faces"])
    return fixed, v, mirrored, (UV, FUV)


def _esd(V, F, UV, FUV, faces, scale):
    m = distortion_metrics(normalize_unit_box(V)[0], F[faces], UV / scale, FUV[faces])
    return float(m["esd"]) if m["valid"] else float("inf")


def bench(*, output="results/repair", quick=False, preset="fast", seed=0, mouette=True, argv=None, show_progress=True):
    """Run the repair benchmark; writes ``repair.{csv,md}`` and a figure; returns :class:`BenchOutput`."""
    out_dir = Path(output)
    out_dir.mkdir(parents=True, exist_ok=True)
    machine = machine_info("cpu")
    layouts, notes = _layouts(quick, seed, preset)
    have_mouette = False
    if mouette:
        try:
            import mouette  # noqa: F401

            have_mouette = True
        except ImportError:
            notes.append("mouette: not installed (`pip install -e .[bench]`); its column reads `not installed`")
    rows = []
    figure_case = None
    scratch = tempfile.TemporaryDirectory(prefix="neuraluv_bench_repair_")  # removed after the loop (or when collected)
    tmp = Path(scratch.name)
    warmed = False
    for name, V, F, UV, FUV, kind in layouts:
        f0 = layout_facts(V, F, UV, FUV)
        base_scale = texel_density(f0.Vn, F, UV, FUV)
        if kind == "good":
            cases = _cases(name, V, F, UV, FUV, seed, quick)
        else:
            fb = np.arange(len(F))
            cases = [("as produced", UV, FUV, fb, {"flipped": int(f0.bad.sum())})]
        for case, uvd, fuvd, isl, info in cases:
            t0 = time.perf_counter()
            res = repair_layout(V, F, uvd, fuvd, preset, seed=seed, device="cpu")
            t_rep = time.perf_counter() - t0
            p = tmp / "out.obj"
            write_obj(p, V, F, res.UV, res.FUV)
            fixed, v, mirrored, (UVb, FUVb) = _verdict(p)
            same = (np.ascontiguousarray(UVb[FUVb]).view(np.int64) ==
                    np.ascontiguousarray(np.where(np.isfinite(uvd[fuvd]), uvd[fuvd], 0.0)).view(np.int64)).all(axis=(1, 2))
            same &= (FUVb == fuvd).all(1)
            e_before = _esd(V, F, UV, FUV, isl, base_scale) if kind == "good" else None
            e_after = _esd(V, F, UVb, FUVb, isl, base_scale) if fixed else float("inf")
            kept = isl[same[isl]]  # faces of the island the repair left exactly as supplied
            e_kept = ((_esd(V, F, UV, FUV, kept, base_scale), _esd(V, F, UVb, FUVb, kept, base_scale))
                      if kind == "good" and fixed and len(kept) else (None, None))
            steps = sorted({a["step"] for i in res.islands for a in i["actions"]} | ({"new chart"} if res.new_charts else set()))
            scaled = any(a.get("scale", 1.0) != 1.0 for i in res.islands for a in i["actions"])
            row = {"layout": name, "case": case, "faces": int(len(F)), "islands": int(f0.n_islands),
                   "flips_before": int(res.before.validation["flips"]),
                   "overlaps_before": int(res.before.validation["overlapping_pairs"]),
                   "fixed": fixed, "flips_after": int(v["flips"]), "overlaps_after": int(v["overlapping_pairs"]),
                   "self_overlaps_after": int(v["self_overlapping_islands"]), "mirrored_after": mirrored,
                   "in_unit_square": bool(v["uv_in_unit_square"]),
                   "bit_identical_island": float(same[isl].mean()), "bit_identical_all": float(same.mean()),
                   "esd_undamaged": e_before, "esd_repaired": e_after,
                   "esd_ratio": (e_after / e_before) if (e_before and np.isfinite(e_after)) else None,
                   "esd_kept_undamaged": e_kept[0], "esd_kept_repaired": e_kept[1],
                   "time_s": t_rep, "steps": "; ".join(steps), "scaled": scaled, "repacked": res.repacked,
                   "damage": info}
            if have_mouette and kind in ("good", "broken") and f0.n_islands == 1 and case in ("local fold", "vertex noise", "as produced"):
                try:
                    scale = texel_density(f0.Vn, F, uvd, fuvd)
                    scale = scale if np.isfinite(scale) else base_scale
                    if not warmed:  # numba compiles on the first call: not timed
                        mouette_untangle(V, F, uvd, scale=scale)
                        warmed = True
                    um, tm = mouette_untangle(V, F, uvd, scale=scale)
                    pm = tmp / "mouette.obj"
                    if np.isfinite(um).all():
                        write_obj(pm, V, F, um, F)
                        fm, vm, mm, (UVm, FUVm) = _verdict(pm)
                    else:
                        fm, vm = False, {"flips": None}
                    row.update({"mouette_fixed": fm, "mouette_time_s": tm, "mouette_flips": vm.get("flips"),
                                "mouette_esd": _esd(V, F, um, F, isl, base_scale) if fm else float("inf"),
                                "mouette_bit_identical": float((um[F] == uvd[F]).all(axis=(1, 2))[isl].mean())})
                except Exception as exc:  # noqa: BLE001 - report, do not crash the table
                    row.update({"mouette_fixed": None, "mouette_error": f"{type(exc).__name__}: {exc}"[:120]})
            rows.append(row)
            if show_progress:
                print(f"repair {name:>16} {case:<22} fixed {fixed!s:5} flips {row['flips_before']:>5} -> {row['flips_after']}, "
                      f"bit-identical {100 * row['bit_identical_island']:.1f}% of the island, "
                      f"E_SD {fmt_num(e_before, 4)} -> {fmt_num(e_after, 4)}, {t_rep:.2f}s [{row['steps']}]"
                      + (f" | mouette {row.get('mouette_time_s', 0):.2f}s fixed {row.get('mouette_fixed')}" if "mouette_fixed" in row else ""),
                      flush=True)
            if figure_case is None and case == "local fold":
                figure_case = (name, res)
    scratch.cleanup()
    files = []
    csv_path = write_csv(out_dir / "repair.csv", [{k: v for k, v in r.items() if k != "damage"} for r in rows])
    files.append(csv_path)
    if figure_case is not None:
        fig = figure_case[1].figure(title=f"{figure_case[0]}: local fold, repaired")
        files.append(save_figure(fig, out_dir / "repair_local_fold.png", dpi=90))
        plt.close(fig)
    md = _markdown(rows, notes, mouette_ran=have_mouette)
    cmd = command_line("repair", argv)
    files.append(write_markdown(out_dir / "repair.md", "UV repair with minimal change", md, command=cmd, machine=machine))
    return BenchOutput(name="repair", rows=rows, markdown=md, files=files)


def _markdown(rows, notes, mouette_ran=True):
    def yn(x):
        return "—" if x is None else ("yes" if x else "**no**")

    head = ["layout", "case", "faces", "flips before", "overlaps before", "fixed", "flips / overlaps after",
            "bit-identical (island / all)", "E_SD undamaged → repaired", "time s", "steps", "mouette: fixed, time s, E_SD, bit-identical"]
    body = []
    for r in rows:
        m = ("—" if mouette_ran else "not installed") if "mouette_fixed" not in r else (
            f"error: {r.get('mouette_error')}" if r.get("mouette_fixed") is None else
            f"{yn(r['mouette_fixed'])}, {r['mouette_time_s']:.2f}, {fmt_num(r['mouette_esd'], 3)}, "
            f"{100 * r['mouette_bit_identical']:.1f}%")
        dmg = r.get("damage") or {}
        case = r["case"] + (f" ({dmg['rings']} rings, seed {dmg['seed']})" if "seed" in dmg else
                            f" ({dmg['rings']} rings)" if "rings" in dmg else "")
        body.append([r["layout"], case, f"{r['faces']:,}", r["flips_before"], r["overlaps_before"], yn(r["fixed"]),
                     f"{r['flips_after']} / {r['overlaps_after']}",
                     f"{100 * r['bit_identical_island']:.1f}% / {100 * r['bit_identical_all']:.1f}%",
                     f"{fmt_num(r['esd_undamaged'], 3)} → {fmt_num(r['esd_repaired'], 3)}"
                     + (f" (×{r['esd_ratio']:.3f})" if r.get("esd_ratio") else ""),
                     f"{r['time_s']:.2f}", r["steps"] + (" (scaled)" if r["scaled"] else "") + (" (repacked)" if r["repacked"] else ""),
                     m])
    n_fixed = sum(bool(r["fixed"]) for r in rows)
    folds = [r for r in rows if r["case"] == "local fold"]
    both = [r for r in rows if r.get("mouette_fixed")]
    summary = []
    if folds:
        ratios = [r["esd_ratio"] for r in folds if r.get("esd_ratio")]
        summary.append(f"Local folds: {sum(bool(r['fixed']) for r in folds)}/{len(folds)} fixed; faces of the damaged "
                       f"island bit-identical: min {100 * min(r['bit_identical_island'] for r in folds):.1f}%, "
                       f"median {100 * float(np.median([r['bit_identical_island'] for r in folds])):.1f}%; "
                       + (f"E_SD repaired / undamaged: max ×{max(ratios):.3f}; " if ratios else "")
                       + f"time: max {max(r['time_s'] for r in folds):.2f} s.")
    if both:
        faster = sum(r["time_s"] < r["mouette_time_s"] for r in both)
        summary.append(f"Against mouette (cases both fix): faster on **{faster}/{len(both)}**; time ratio "
                       f"(neuraluv / mouette) median ×{float(np.median([r['time_s'] / r['mouette_time_s'] for r in both])):.2f}, "
                       f"max ×{max(r['time_s'] / r['mouette_time_s'] for r in both):.2f}.")
    worse = [r for r in rows if (r.get("esd_ratio") or 0) > 1.05 and r.get("esd_kept_repaired") is not None]
    if worse:  # E_SD rose: say whether the repair's changes or the damage it kept (valid, stretched faces) did it
        summary.append("E_SD above ×1.05 of the undamaged layout: " + "; ".join(
            f"{r['layout']} {r['case']} ×{r['esd_ratio']:.3f}; over the faces kept as supplied "
            f"({100 * r['bit_identical_island']:.1f}% of the island) {fmt_num(r['esd_kept_undamaged'], 3)} → "
            f"{fmt_num(r['esd_kept_repaired'], 3)}" for r in worse)
            + ". Repair changes only broken faces (flipped, overlapping, mirrored, non-finite, outside the square): "
              "faces the damage stretched without flipping are kept as they were supplied.")
    text = [f"Fixed: **{n_fixed}/{len(rows)}** layouts (verdict on the written OBJ read back).", "", *summary, "",
            markdown_table(head, body), "",
            "*bit-identical*: faces whose three corners have exactly the input's UV bits and `vt` indices "
            "(over the damaged island / over the whole layout; the damaged faces themselves count as changed). "
            "*E_SD*: area-weighted symmetric Dirichlet energy over the damaged island, both layouts measured at the "
            "undamaged layout's texel density (4 = isometry); for real broken layouts there is no undamaged value. "
            "mouette: `mouette.processing.parametrization.untangle` (numba, compiled before timing), boundary locked, "
            "per-vertex UVs — it takes only the single-chart fold and noise cases (—: a case it does not take)."]
    text += [f"- {n}" for n in notes]
    return "\n".join(text)


def run(args):
    out = bench(output=args.output, quick=args.quick, preset=args.preset or "fast", seed=args.seed,
                mouette=not args.no_mouette, argv=None, show_progress=not args.quiet)
    print(f"wrote {', '.join(str(f) for f in out.files)}")
    return 0
