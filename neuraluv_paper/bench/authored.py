"""``neuraluv bench authored``: check and repair on real authored assets, as a user runs them.

For every cached asset of :data:`neuraluv.datasets.AUTHORED` with a UV layout (OBJ, GLB),
through the command line (``neuraluv check --uv``, ``neuraluv repair``; the verdict is
the written file read back):

* **as made**: the default purpose and why, problems and intentional features found,
  and what repair did — byte-identical when only intent was found;
* **added damage** (:mod:`neuraluv_paper.damage`, seeded, on the asset's largest
  island): a local fold (2 rings; 1 when the island is too small), vertex noise (1% of
  the island's rows, 0.8 median edge lengths), NaN texture coordinates (3 rows). Each
  damaged copy is written in the asset's own format (the OBJ patched, the GLB's UV
  accessor rewritten; material and texture files beside it) and repaired with the
  default purpose: read-back validity, faces bit-identical to the damaged input, whole
  command time, and the re-baked textures' colour change (surface and changed faces);
* **lightmap** (GLB only): ``--purpose lightmap`` — TEXCOORD_0 kept, the new UV set
  read back: flips, overlaps, mirrored islands, padding.
"""
from __future__ import annotations

import contextlib
import io
import json
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from neuraluv import datasets
from neuraluv.cli import main as cli
from neuraluv.errors import NeuralUVError
from neuraluv.io import patch_obj, read_gltf_layout, read_layout, write_gltf_uvs
from neuraluv.layout.facts import layout_facts
from neuraluv_paper import damage
from neuraluv_paper.bench.provenance import BenchOutput, command_line, machine_info, markdown_table, write_csv, write_markdown
from neuraluv_paper.gltf_validator import gltf_validate, validator_missing

__all__ = ["bench", "add_arguments", "run", "largest_island_rows"]

#: Companion files an asset needs beside it (its materials and images).
_COMPANIONS = {"capsule.obj": ["capsule.mtl", "capsule0.jpg"], "fuze.obj": ["fuze.obj.mtl", "fuze uv.jpg"],
               "ico4uv.obj": ["ico4uv.mtl"]}


def add_arguments(p):
    p.add_argument("--no-damage", action="store_true", help="only the assets as made (no added damage, no lightmaps)")


def _cli(argv):
    """Run the command line in-process: ``(exit code, stdout, stderr, seconds)``."""
    out, err = io.StringIO(), io.StringIO()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli([str(a) for a in argv])
        except SystemExit as exc:
            code = exc.code
    return code, out.getvalue(), err.getvalue(), time.perf_counter() - t0


def largest_island_rows(V, F, UV, FUV):
    """The ``vt`` rows of the layout's largest island (by faces), where the damage goes."""
    f = layout_facts(V, F, UV, FUV)
    if not f.n_islands:
        raise ValueError("no usable island")
    return np.unique(FUV[f.island_faces(int(np.argmax(np.bincount(f.label[f.label >= 0]))))])


def _damaged(kind, V, F, UV, FUV, seed):
    rows = largest_island_rows(V, F, UV, FUV)
    if kind == "local fold":
        for rings in (2, 1):
            try:
                return damage.local_fold(V, F, UV, FUV, rings=rings, seed=seed, rows=rows)[0]
            except ValueError:
                continue
        raise ValueError("the largest island is too small for a fold")
    if kind == "vertex noise":
        return damage.vertex_noise(V, F, UV, FUV, fraction=0.01, seed=seed, rows=rows)[0]
    out = np.asarray(UV, float).copy()
    out[np.random.default_rng(seed).choice(rows, size=min(3, len(rows)), replace=False)] = np.nan
    return out


def _write_damaged(src, dst, data, UV):
    if src.suffix.lower() == ".obj":
        patch_obj(src, dst, np.where(np.isfinite(UV), UV, 0.0), data[3], data=data)
        if not np.isfinite(UV).all():  # NaN rows: written as the text "nan", which the OBJ reader takes
            lines = dst.read_bytes().splitlines(keepends=True)
            bad = set(np.flatnonzero(~np.isfinite(UV).all(1)).tolist())
            for r, L in enumerate(data.notes["vt_line"]):
                if r in bad:
                    end = lines[L][len(lines[L].rstrip(b"\r\n")):]
                    lines[L] = b"vt nan nan" + end
            dst.write_bytes(b"".join(lines))
    else:
        fin = np.where(np.isfinite(UV), UV, np.nan)
        write_gltf_uvs(data, np.where(np.isfinite(fin), fin, 0.0), data.FUV, dst)
        if not np.isfinite(UV).all():  # a NaN in a float accessor: write the bits directly
            from neuraluv.io.gltf import load_gltf, read_accessor
            from neuraluv.io.gltf_write import new_accessor, write_glb

            doc = load_gltf(dst)
            same_json = True
            for b in data.blocks:  # each primitive's own UV accessor holds its rows
                prim = doc.json["meshes"][b["mesh"]]["primitives"][b["primitive"]]
                if doc.json["accessors"][prim["attributes"]["TEXCOORD_0"]]["componentType"] != 5126:
                    # a quantized set holds no NaN: its values go to a float accessor (as a repair would write it)
                    vals = read_accessor(doc, prim["attributes"]["TEXCOORD_0"]).astype("<f4")
                    prim["attributes"]["TEXCOORD_0"] = new_accessor(doc, vals)
                    doc.json["buffers"][0]["byteLength"] = len(doc.buffers[0])
                    same_json = False
                acc = doc.json["accessors"][prim["attributes"]["TEXCOORD_0"]]
                bv = doc.json["bufferViews"][acc["bufferView"]]
                start = bv.get("byteOffset", 0) + acc.get("byteOffset", 0)
                stride = bv.get("byteStride") or 8
                r0, nr = b["rows"]
                for r in np.flatnonzero(~np.isfinite(UV[r0:r0 + nr]).all(1)):
                    doc.buffers[0][start + stride * r:start + stride * r + 8] = np.full(2, np.nan, "<f4").tobytes()
            write_glb(doc, dst, keep_json=same_json)


def _kept_outside(a, b, untouched):
    """Share of the faces the damage left alone (``untouched``) whose corners the repair kept bit for bit, between
    the layouts ``a`` and ``b`` read from the damaged and the repaired file (None where their faces do not line
    up)."""
    if len(a[1]) != len(b[1]) or not untouched.any():
        return None
    ua, ub = a[2][np.maximum(a[3], 0)], b[2][np.maximum(b[3], 0)]
    same = (ua.view(np.int64) == ub.view(np.int64)).all(axis=(1, 2)) & ((a[3] < 0) == (b[3] < 0)).all(1)
    return float(same[untouched].mean())


def _damage_left(made, damaged, out):
    """:func:`neuraluv_paper.damage.damage_left` of the three layouts read from the files, faces with 3D area:
    ``(left, hit)`` counts, or None where their faces do not line up."""
    got = (made, damaged, out)
    if len({len(g[1]) for g in got}) != 1:
        return None
    left, hit = damage.damage_left(*((g[2], g[3]) for g in got), judged=~layout_facts(*made[:4]).degenerate3d)
    return int(left.sum()), int(hit.sum())


def _validator_errors(path):
    """The Khronos glTF validator's error count for ``path`` (None where it cannot run: node or the package missing)."""
    v = gltf_validate(path)
    if v is None:
        return None
    return int(v["errors"]) if "fatal" not in v else max(1, int(v.get("errors", 1)))  # unreadable: an error


def _repair_row(asset, case, path, out, tmp, untouched=None, made=None):
    """One repair through the command line and what it did; with ``untouched`` (faces the damage left alone), also
    the faces kept outside the damage and the damage left against ``made`` (the layout as made, as
    :func:`~neuraluv.io.read_layout` returns it)."""
    rep = tmp / "r.json"
    code, so, se, secs = _cli(["repair", path, "-o", out, "--report", rep, "--device", "cpu"])
    row = {"asset": asset, "case": case, "exit": code, "time_s": secs}
    if untouched is not None and Path(out).exists():
        damaged, repaired = read_layout(path), read_layout(out)   # each file read once for both measures
        row["kept_outside_damage"] = _kept_outside(damaged, repaired, untouched)
        row["damaged_faces"] = int((~untouched).sum())
        left = _damage_left(made, damaged, repaired)
        if left is not None:
            row["damage_left"], row["damage_faces"] = left
    if Path(out).suffix.lower() == ".glb" and Path(out).exists():
        row["validator_errors"] = _validator_errors(out)
    if rep.exists():
        r = json.loads(rep.read_text())
        b = r["readback"]
        row.update({"purpose": r["purpose"]["purpose"], "faces": r["faces"], "problems_before": len(r["before"]["problems"]),
                    "features": len(r["before"].get("features", [])), "valid_read_back": b["valid"],
                    "folded_after": b.get("folded_faces", b.get("flips")),
                    "bit_identical": r["faces_bit_identical"], "unchanged": r["unchanged"],
                    "byte_identical": Path(out).read_bytes() == Path(path).read_bytes()})
        tex = [t for t in r.get("textures", []) if "appearance" in t]
        if tex:
            row["rebake_surface_mean"] = max(t["appearance"]["surface"]["mean"] for t in tex)
            row["rebake_surface_p99"] = max(t["appearance"]["surface"]["p99"] for t in tex)
            row["rebake_changed_mean"] = max(t["appearance"]["changed_faces"]["mean"] for t in tex)
        rep.unlink()
    else:
        row["error"] = (se.strip().splitlines() or ["no report"])[-1][:160]
    return row


def bench(*, output="results/authored", seed=0, damaged=True, meshes=None, argv=None, show_progress=True):
    """Run the authored-asset benchmark; writes ``authored.{csv,md}``; returns :class:`BenchOutput`.

    ``meshes``: only these assets (file names, with or without their suffix); default all.
    """
    names = sorted(f for f in datasets.AUTHORED if Path(f).suffix.lower() in (".obj", ".glb"))
    if meshes:
        unknown = [m for m in meshes if not any(m in (f, Path(f).stem) for f in names)]
        if unknown:
            raise NeuralUVError(f"not an authored asset: {', '.join(unknown)} (they are: "
                                f"{', '.join(Path(f).stem for f in names)})")
        names = [f for f in names if f in meshes or Path(f).stem in meshes]
    out_dir = Path(output)
    out_dir.mkdir(parents=True, exist_ok=True)
    machine = machine_info("cpu")
    assets, notes = [], []
    for fname in names:
        try:
            assets.append((fname, datasets.authored_path(fname)))
            for c in _COMPANIONS.get(fname, []):
                datasets.authored_path(c)
        except datasets.DataMissing as exc:
            notes.append(f"{fname}: not cached ({exc})")
    if not assets:
        raise datasets.DataMissing("no authored asset is cached: run `python data_scripts/fetch.py --authored --from DIR`")
    rows = []
    for fname, src in assets:
        scratch = tempfile.TemporaryDirectory(prefix="neuraluv_authored_")  # removed at the asset's end (or when dropped)
        tmp = Path(scratch.name)
        work = tmp / fname
        shutil.copyfile(src, work)
        for c in _COMPANIONS.get(fname, []):
            shutil.copyfile(datasets.authored_path(c), tmp / c)
        code, so, se, secs = _cli(["check", "--uv", work])
        purpose_line = so.splitlines()[0] if so else se.strip()
        row = _repair_row(fname, "as made", work, tmp / ("out" + work.suffix), tmp)
        row["check_exit"] = code
        row["check"] = purpose_line[:120]
        rows.append(row)
        if show_progress:
            print(_line(row), flush=True)
        if not damaged:
            continue
        V, F, UV, FUV, data = read_layout(work)
        for k, case in enumerate(("local fold", "vertex noise", "NaN UVs")):
            try:
                bad = _damaged(case, V, F, UV, FUV, seed + k)
            except ValueError as exc:
                rows.append({"asset": fname, "case": case, "error": str(exc)})
                continue
            dmg = tmp / ("damaged" + work.suffix)
            _write_damaged(work, dmg, data, bad)
            moved = ~((bad == UV) | (np.isnan(bad) & np.isnan(UV))).all(1)  # rows the damage changed
            untouched = ~moved[np.maximum(FUV, 0)].any(1)
            row = _repair_row(fname, case, dmg, tmp / ("fixed" + work.suffix), tmp, untouched,
                              made=(V, F, UV, FUV, data))
            rows.append(row)
            if show_progress:
                print(_line(row), flush=True)
        if work.suffix.lower() == ".glb":
            code, so, se, secs = _cli(["repair", work, "-o", tmp / "lm.glb", "--purpose", "lightmap", "--device", "cpu",
                                       "--report", tmp / "lm.json"])
            row = {"asset": fname, "case": "lightmap (TEXCOORD_1)", "exit": code, "time_s": secs}
            if (tmp / "lm.glb").exists():
                row["validator_errors"] = _validator_errors(tmp / "lm.glb")
            if (tmp / "lm.json").exists():
                b = json.loads((tmp / "lm.json").read_text())["readback"]
                t0a = read_gltf_layout(work)  # TEXCOORD_0 of the primitives that had it (the others may get it filled)
                t0b = read_gltf_layout(tmp / "lm.glb", {(q["mesh"], q["primitive"]): 0 for q in t0a.blocks})
                row.update({"valid_read_back": b["valid"], "folded_after": b["flips"], "overlaps_after": b["overlapping_pairs"],
                            "mirrored_after": b["mirrored_islands"], "padding_violations": b["padding_violations"],
                            "min_gap_texels": b["min_gap_texels"],
                            "texcoord0_kept": bool(np.array_equal(t0a.UV[t0a.FUV], t0b.UV[t0b.FUV]))})
            else:
                row["error"] = (se.strip().splitlines() or ["no report"])[-1][:160]
            rows.append(row)
            if show_progress:
                print(_line(row), flush=True)
        scratch.cleanup()
    files = [write_csv(out_dir / "authored.csv", rows)]
    md = _markdown(rows, notes)
    files.append(write_markdown(out_dir / "authored.md", "Check and repair on real authored assets", md,
                                command=command_line("authored", argv), machine=machine))
    return BenchOutput(name="authored", rows=rows, markdown=md, files=files)


def _line(r):
    if "error" in r and "exit" not in r:
        return f"authored {r['asset']:>30} {r['case']:<22} skipped: {r['error']}"
    return (f"authored {r['asset']:>30} {r['case']:<22} exit {r.get('exit')} valid {r.get('valid_read_back')} "
            f"bit-identical {100 * r.get('bit_identical', float('nan')):.1f}% {r['time_s']:.1f}s"
            + (f" rebake {r['rebake_surface_mean']:.3f}" if "rebake_surface_mean" in r else ""))


def _pct(x):
    return "—" if x is None or (isinstance(x, float) and not np.isfinite(x)) else f"{100 * x:.1f}%"


def _markdown(rows, notes):
    made = [r for r in rows if r["case"] == "as made" and "exit" in r]
    intent = [r for r in made if r.get("problems_before") == 0]
    dam = [r for r in rows if r["case"] in ("local fold", "vertex noise", "NaN UVs") and "exit" in r]
    ok = [r for r in dam if r.get("valid_read_back") and r.get("damage_left") == 0]
    unmeasured = sum("damage_left" not in r for r in dam)
    small = [r for r in dam if r.get("faces", 0) <= 20000]
    lm = [r for r in rows if r["case"].startswith("lightmap")]
    reb = [r for r in rows if "rebake_surface_mean" in r]
    kept = [r["kept_outside_damage"] for r in dam if r.get("kept_outside_damage") is not None]
    summary = [
        f"- Assets as made: **{len(made)}**; internal errors (exit 1): **{sum(r.get('exit') == 1 for r in rows)}**; "
        f"with only intentional features: {len(intent)}, of which written back byte-identical: "
        f"**{sum(bool(r.get('byte_identical')) for r in intent)}/{len(intent)}**.",
        f"- Added damage: **{len(ok)}/{len(dam)}** fixed (read back valid under the default purpose, and not one of "
        f"the faces the damage reversed or left without UVs still so, against the asset as made"
        + (f"; {unmeasured} not measured: faces that do not line up" if unmeasured else "") + "); faces "
        f"bit-identical to the damaged input: median {_pct(np.median([r['bit_identical'] for r in dam if 'bit_identical' in r]) if dam else None)}, "
        f"lowest {_pct(min([r['bit_identical'] for r in dam if 'bit_identical' in r], default=None))}; of the faces the "
        f"damage left alone: median {_pct(np.median(kept) if kept else None)}, lowest {_pct(min(kept, default=None))}; "
        f"time (whole command, ≤ 20k faces): median {np.median([r['time_s'] for r in small]) if small else float('nan'):.1f} s, "
        f"max {max([r['time_s'] for r in small], default=float('nan')):.1f} s.",
    ]
    if reb:
        summary.append(f"- Re-baked textures: {len(reb)} repairs; colour change over the surface (mean, 8-bit RGB) at most "
                       f"**{max(r['rebake_surface_mean'] for r in reb):.3f}** (held to ≤ 1), p99 at most "
                       f"{max(r['rebake_surface_p99'] for r in reb):.2f}; over the changed faces alone, mean at most "
                       f"{max(r['rebake_changed_mean'] for r in reb):.2f}.")
    if lm:
        summary.append(f"- Lightmaps (GLB, `--purpose lightmap`): **{sum(bool(r.get('valid_read_back')) for r in lm)}/{len(lm)}** "
                       f"valid with padding held; TEXCOORD_0 kept in {sum(bool(r.get('texcoord0_kept')) for r in lm)}/{len(lm)}.")
    glb = [r for r in rows if "validator_errors" in r]
    ran = [r for r in glb if r["validator_errors"] is not None]
    if glb:
        summary.append(f"- Khronos glTF validator on every GLB written: **{sum(r['validator_errors'] == 0 for r in ran)}/"
                       f"{len(ran)}** with no error." if ran else
                       f"- Khronos glTF validator: not run ({validator_missing()}).")
    head = ["asset", "case", "exit", "purpose", "faces", "problems", "features", "valid", "folded after", "damage left",
            "bit-identical", "kept outside the damage", "byte-identical", "rebake mean (surface / changed)",
            "validator errors", "time (s)"]
    body = []
    for r in rows:
        if "exit" not in r:
            body.append([r["asset"], r["case"], "—", "", "", "", "", "skipped: " + r.get("error", ""), "", "", "", "", "",
                         "", "", ""])
            continue
        body.append([r["asset"], r["case"], r["exit"], r.get("purpose", ""), r.get("faces", ""), r.get("problems_before", ""),
                     r.get("features", ""), "yes" if r.get("valid_read_back") else ("no" if "valid_read_back" in r else "—"),
                     r.get("folded_after", ""),
                     f"{r['damage_left']} of {r['damage_faces']}" if "damage_left" in r else "",
                     _pct(r.get("bit_identical")),
                     (f"{_pct(r['kept_outside_damage'])} ({r['damaged_faces']} damaged)"
                      if r.get("kept_outside_damage") is not None else ""),
                     {True: "yes", False: "no"}.get(r.get("byte_identical"), ""),
                     (f"{r['rebake_surface_mean']:.3f} / {r['rebake_changed_mean']:.2f}" if "rebake_surface_mean" in r else ""),
                     "" if r.get("validator_errors") is None else r["validator_errors"], f"{r['time_s']:.1f}"])
    text = [*summary, "", markdown_table(head, body), "",
            "*exit*: 0 valid, 3 written but read back not valid (the report says which faces), 2 refused with a "
            "one-line reason, 1 internal error. *bit-identical*: faces whose corners keep the input's UV bits and "
            "indices. *damage left*: of the faces the added damage reversed or left without finite UVs (each face's "
            "UV orientation in the damaged file against the asset's file as made), those the repaired file still has "
            "so — the damage's own verdict, where *valid* and *folded after* are the tool's reading of its output. "
            "*kept outside the damage*: of the faces whose UVs the added damage did not change, the share the "
            "repair kept bit for bit (the faces an asset's own problems need are among them). *rebake*: colour difference of the textured surface before and after at 100,000 area-uniform "
            "points (Euclidean over RGB, 8-bit levels), over the whole surface and over the changed faces alone. "
            "Lightmap rows: *folded after* is flips of the new UV set; the padding is the command's default (2 texels at 1024). "
            "*validator errors*: the Khronos glTF validator (npm `gltf-validator`) on the GLB written (blank: an OBJ, or "
            "the validator not installed)."]
    text += [f"- {n}" for n in notes]
    return "\n".join(text)


def run(args):
    out = bench(output=args.output, seed=args.seed, damaged=not args.no_damage, meshes=args.meshes,
                show_progress=not args.quiet)
    print(f"wrote {', '.join(str(f) for f in out.files)}")
    return 0
