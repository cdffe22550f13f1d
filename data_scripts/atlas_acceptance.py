"""Acceptance run for atlas construction, UV repair and bad inputs.

    NEURALUV_DATA=/tmp/nuvdata nice -n 10 .venv/bin/python data_scripts/atlas_acceptance.py \
        [-o /tmp/atlas_acceptance] [--workers 2] [--preset fast] [--n-generated 50]

1. Atlases (via `neuraluv.atlas.sweep` on a dask LocalCluster, one subprocess per
   asset) every cached closed registry mesh (datasets.CLOSED), pyvista's bundled
   ant/airplane/nut, and the seeded generated-like set; every verdict is on the
   written OBJ read back: 100% coverage, 0 flips, 0 island overlaps, UVs in
   [0,1]², padding respected. A few assets are also written as GLB.
2. UV repair: an LSCM layout of the camel chart (real flips) next to Bob's own
   valid charts goes through `neuraluv repair`; flips must drop to 0 and every
   valid chart must stay bit-identical.
3. Bad inputs (empty, garbage, NaN, points, degenerate, non-manifold, huge
   coordinates) must give a one-line error (exit 2) or a valid atlas.
Prints one table per group and the totals (the quantities of Tables 7 and 9, tab:amara_coverage_validity and tab:amara_large_sweep).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def _write_inputs(root, n_generated):
    import trimesh

    from neuraluv import datasets
    from neuraluv.datasets.generated import generated_asset

    groups = {"closed": [], "pyvista": [], "generated": []}
    for name in datasets.CLOSED:
        if datasets.available(name):
            groups["closed"].append(datasets.fetch(name, download=False))
        else:
            print(f"skip {name}: not cached", file=sys.stderr)
    try:
        from pyvista import examples

        for attr in ("antfile", "planefile", "nutfile"):
            p = Path(getattr(examples, attr))
            if p.exists():
                groups["pyvista"].append(p)
    except Exception as exc:  # pragma: no cover
        print(f"pyvista examples unavailable: {exc}", file=sys.stderr)
    gdir = Path(root) / "inputs_generated"
    gdir.mkdir(parents=True, exist_ok=True)
    for i in range(n_generated):
        p = gdir / f"gen_{i:03d}.obj"
        if not p.exists():
            V, F, _ = generated_asset(i)
            p.write_text(trimesh.Trimesh(V, F, process=False).export(file_type="obj"))
        groups["generated"].append(p)
    return groups


def _table(label, rows):
    from neuraluv.atlas.sweep import summarize

    s = summarize(rows, label)
    ok = [r for r in rows if r.get("ok")]
    cov = all(r.get("ok") for r in rows)
    return (f"| {label} | {s['tried']} | {s['ok']} | {s['faces']:,} | {s['flips']} | "
            f"{sum(max(int(r['overlaps']), 0) for r in ok)} | {'100%' if cov else 'FAIL'} | "
            f"{100 * s['neural_share']:.1f}/{100 * s['exact_share']:.1f}/{100 * s['fallback_share']:.1f}% | "
            f"{s['median_time']:.1f}s |"), s


def run_atlases(groups, out, args):
    from neuraluv.atlas.sweep import sweep

    kw = dict(preset=args.preset, resolution=1024, padding=4)
    all_rows = {}
    for g, paths in groups.items():
        if not paths:
            continue
        res = sweep(paths, out / g, n_workers=args.workers, timeout=args.timeout, progress=False, label=g, **kw)
        all_rows[g] = res.rows
        bad = [r for r in res.rows if not r.get("ok")]
        for r in bad:
            print(f"NOT OK {g}/{r['name']}: {r['status']} {r.get('error', '')}", file=sys.stderr)
    glb = groups["pyvista"] + groups["generated"][:5]
    if glb:
        res = sweep(glb, out / "glb", n_workers=args.workers, timeout=args.timeout, progress=False,
                    out_format="glb", label="glb", **kw)
        all_rows["glb (read back)"] = res.rows
    print("\n| Set | Tried | OK | Faces | Flips | Overlaps | Coverage | Neural/exact/fallback faces | Med. time |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    every = []
    for g, rows in all_rows.items():
        line, _ = _table(g, rows)
        print(line)
        if not g.startswith("glb"):
            every += rows
    line, s = _table("all (OBJ)", every)
    print(line)
    glb_rows = all_rows.get("glb (read back)", [])
    s["glb_ok"] = sum(bool(r.get("ok")) for r in glb_rows)
    s["glb_tried"] = len(glb_rows)
    return s


def _lscm(V, F):
    import igl

    from neuraluv.metrics import distortion_metrics

    b = igl.boundary_loop(F)
    uv, _ = igl.lscm(V, F, np.array([b[0], b[len(b) // 2]]), np.array([[0.0, 0.0], [1.0, 0.0]]))
    if distortion_metrics(V, F, uv)["flips"] * 2 > len(F):
        uv[:, 0] *= -1  # LSCM's pinning can mirror the whole map
    return uv


def run_repair(out, args):
    """LSCM camel (real flips) + Bob's own valid charts in one layout → neuraluv repair."""
    from neuraluv import datasets
    from neuraluv.io import read_obj, write_obj
    from neuraluv.metrics import distortion_metrics
    from neuraluv.layout import uv_islands
    from neuraluv.metrics import face_dets

    if not (datasets.available("camel_b") and datasets.available("bob_tri")):
        print("repair: camel_b/bob_tri not cached, skipped")
        return None
    Vc, Fc = datasets.load("camel")
    uv = _lscm(Vc, Fc)
    m = distortion_metrics(Vc, Fc, uv)
    uv = (uv - uv.min(0)) / np.ptp(uv, axis=0).max() * 0.48 + 0.01
    Vb, Fb, UVb, FUVb = read_obj(datasets.fetch("bob_tri", download=False))
    UVb = UVb * 0.48 + [0.51, 0.01]
    V = np.vstack([Vc, Vb])
    F = np.vstack([Fc, Fb + len(Vc)])
    UV = np.vstack([uv, UVb])
    FUV = np.vstack([Fc, FUVb + len(uv)])
    inp = out / "repair_in.obj"
    outp = out / "repair_out.obj"
    write_obj(inp, V, F, UV, FUV)
    cmd = [sys.executable, "-m", "neuraluv.cli", "repair", str(inp), "-o", str(outp), "--report", str(out / "repair.json"),
           "--preset", args.preset, "--quiet", "--threads", "1"]
    pr = subprocess.run(cmd, capture_output=True, text=True)
    print(pr.stdout.strip() or pr.stderr.strip())
    V1, F1, UV1, FUV1 = read_obj(inp)
    V2, F2, UV2, FUV2 = read_obj(outp)
    det1 = face_dets(V1, F1, UV1, FUV1)
    n, lab = uv_islands(FUV1)
    valid_charts = [c for c in range(n) if (det1[lab == c] > 0).all()]
    vf = np.isin(lab, valid_charts)
    identical = bool(np.array_equal(FUV1[vf], FUV2[vf]) and np.array_equal(UV1[FUV1[vf]], UV2[FUV2[vf]]))
    flips_after = int((~(face_dets(V2, F2, UV2, FUV2) > 0)).sum())
    print(f"\nrepair: LSCM camel flips {m['flips']} ({m['flip_percent']:.2f}%) + Bob; charts {n} "
          f"({len(valid_charts)} valid); flips before {int((~(det1 > 0)).sum())} -> after {flips_after} (read back); "
          f"valid charts bit-identical: {identical}")
    return {"flips_after": flips_after, "identical": identical}


def run_bad(out):
    d = out / "bad"
    d.mkdir(parents=True, exist_ok=True)
    cases = {
        "empty.obj": "", "garbage.obj": None, "nan.obj": "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n",
        "points.obj": "v 0 0 0\nv 1 0 0\n", "degenerate.obj": "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
        "nonmanifold.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 2 5\n",
        "huge.obj": "v 0 0 0\nv 1e300 0 0\nv 0 1e300 0\nv 1e300 1e300 1e-300\nf 1 2 3\nf 2 4 3\n",
        "quads.off": "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
        "outofrange.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
    }
    rng = np.random.default_rng(0)
    ok_all = True
    print("\n| Bad input | exit | result |\n|---|---:|---|")
    for name, text in cases.items():
        p = d / name
        if text is None:
            p.write_bytes(rng.integers(0, 256, 400, dtype=np.uint8).tobytes())
        else:
            p.write_text(text)
        pr = subprocess.run([sys.executable, "-m", "neuraluv.cli", "atlas", str(p), "-o", str(d / (p.stem + "_out.obj")),
                             "--quiet"], capture_output=True, text=True)
        err = pr.stderr.strip().splitlines()
        good = (pr.returncode == 2 and len(err) == 1 and err[0].startswith("neuraluv: error:")) or pr.returncode == 0
        ok_all &= good
        msg = err[0] if err else pr.stdout.strip()[:110]
        print(f"| {name} | {pr.returncode} | {msg} |")
    return ok_all


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", default=os.path.join(tempfile.gettempdir(), "atlas_acceptance"))
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--preset", default="fast")
    p.add_argument("--timeout", type=float, default=900)
    p.add_argument("--n-generated", type=int, default=50)
    p.add_argument("--skip-atlas", action="store_true")
    args = p.parse_args(argv)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    s = None
    if not args.skip_atlas:
        s = run_atlases(_write_inputs(out, args.n_generated), out, args)
    r = run_repair(out, args)
    bad = run_bad(out)
    ok = (s is None or (s["ok"] == s["tried"] and s["flips"] == 0 and s["glb_ok"] == s["glb_tried"])) and (r is None or (r["flips_after"] == 0 and r["identical"])) and bad
    print(f"\nACCEPTANCE {'PASSED' if ok else 'FAILED'}")
    with open(out / "acceptance.json", "w") as fh:
        json.dump({"atlas": s, "repair": r, "bad_inputs_ok": bad}, fh, indent=1, default=str)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
