"""Subcommands ``check``, ``atlas``, ``repair`` and ``sweep`` (a :mod:`neuraluv.cli` plugin).

``neuraluv check IN`` explains what is wrong with a mesh (``--uv``: with its UV
layout); ``neuraluv atlas IN -o OUT.obj|glb`` builds a validated atlas;
``neuraluv repair IN -o OUT.obj`` repairs a supplied layout with minimal change; ``neuraluv sweep DIR
-o OUT`` atlases many assets on a dask cluster. User errors are one line
(exit 2); an atlas or repair that fails validation exits 3.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from neuraluv.cli.options import (EPILOG, EXIT_INVALID, EXIT_OK, add_solver_options, nonneg_float, positive_float,
                                  positive_int, time_budget_option)
from neuraluv.cli.paths import check_paths
from neuraluv.errors import NeuralUVError, require
from neuraluv.layout import DEFECT_TEXELS, PURPOSES
from neuraluv.layout.pack import ORDER_MAX_ISLANDS, PACK_TRIALS, PACKERS

__all__ = ["register"]


def _pct(x):
    return f"{100 * x:.1f}%"


def cmd_check(args):
    from neuraluv.check import check_mesh, format_report
    from neuraluv.io import load_mesh

    check_paths(args.input)
    V, F = load_mesh(args.input)
    r = check_mesh(V, F)
    if args.json:
        print(json.dumps(r.as_dict(), indent=2))
    else:
        print(format_report(r, Path(args.input).name))
    return 0


def _packing_options(a):
    a.add_argument("--packer", default="tight", choices=list(PACKERS),
                   help="tight (default: chart shapes at the largest common density that fits), shelf (the paper's "
                        "bounding-box shelves) or xatlas (xatlas's packer on bounding boxes)")
    a.add_argument("--texel-density", type=positive_float, default=None,
                   help="texels per unit length of the input mesh instead of the largest density that fits "
                        "one texture; islands that do not fit go to further UDIM tiles (u+1, u+2, ...)")
    a.add_argument("--orient", default="compact", choices=["compact", "upright"],
                   help="compact (default: each island turned to its smallest box) or upright (its main axis along U)")
    a.add_argument("--no-merge", action="store_true",
                   help="keep xatlas's small charts instead of merging them into neighbours (more, smaller islands)")
    a.add_argument("--pack-trials", type=positive_int, default=PACK_TRIALS,
                   help="packings the tight packer tries (two raster settings, then, for up to "
                        f"{ORDER_MAX_ISLANDS} islands, the "
                        "first with the islands' placement order perturbed); the fullest is kept; more trials pack "
                        f"fuller on average (default {PACK_TRIALS}; 1 is fastest)")
    a.add_argument("--whole-islands", action="store_true",
                   help="never cut an island to pack fuller (by default the tight packer may cut islands holding more "
                        "than 1/10 of the UV area in parts when that fills the texture at least 1 point more; "
                        "cuts add seams, never flips)")
    a.add_argument("--stack", action="store_true",
                   help="identical islands (same triangulation, congruent in 3D, e.g. instanced parts) share one place "
                        "in the texture; validation counts them as stacked, not as overlaps")


def cmd_atlas(args):
    from neuraluv.atlas.export import atlas_file
    from neuraluv.solver.device import resolve_device

    _, out, _ = check_paths(args.input, args.output, args.report, output_exts=(".obj", ".glb", ".gltf"))
    if args.renders:
        check_paths(output=args.renders, output_folder=True)
        require("pyvista")  # the renders need the render extra: say so before any work
    if args.resolution < 16 or args.padding < 0 or 2 * args.padding >= args.resolution / 2:
        raise NeuralUVError("need --resolution >= 16 and 0 <= --padding < resolution/4")
    resolve_device(args.device)
    res, rep = atlas_file(args.input, out, report=args.report, renders=args.renders, replace_uvs=args.replace_uvs,
                          rebake=not args.no_rebake, preset=args.preset,
                          resolution=args.resolution, padding=args.padding, packer=args.packer, seed=args.seed,
                          device=args.device, **_overrides(args), texel_density=args.texel_density,
                          orient=args.orient, merge=not args.no_merge, stack=args.stack,
                          pack_trials=args.pack_trials, cut_islands=not args.whole_islands,
                          time_budget=args.time_budget or None, threads=args.threads, progress=not args.quiet,
                          min_height=args.min_height)
    t = res.totals()
    b = rep["readback"]
    rinfo = res.info["repair"]
    fixed = [f"{n} {what}" for n, what in ((rinfo["repair"].get("duplicate_faces", 0), "duplicate faces"),
                                           (rinfo["repair"].get("degenerate_faces", 0), "degenerate faces"),
                                           (rinfo.get("sliver_faces", 0), "slivers"),
                                           (rinfo["repair"].get("merged_vertices", 0), "welded vertices"),
                                           (rinfo.get("reoriented_faces", 0), "re-oriented faces")) if n]
    print(f"wrote {out}: {t['charts']} charts ({t['neural_charts']} neural, {t['exact_charts']} exact, "
          f"{t['fallback_charts']} fallback), {t['islands']} islands; faces neural {_pct(t['neural_share'])} / "
          f"exact {_pct(t['exact_share'])} / fallback {_pct(t['fallback_share'])}; "
          f"coverage {_pct(b['covered_faces'] / max(b['faces'], 1))}, flips {b['flips']}, overlaps {b['overlapping_pairs']}, "
          f"padding violations {b['padding_violations']}; utilisation {_pct(t['utilisation'])}"
          + (f" over {res.info['pages']} UDIM tiles" if res.info.get("pages", 1) > 1 else "")
          + f", texel-density spread {_pct(b['density_spread'] or 0.0)}"
          + (f", {b['stacked_islands']} islands stacked on identical ones" if args.stack else "")
          + (f", {res.info['cut_islands']} islands added by cutting large ones to pack fuller"
             if res.info.get("cut_islands") else "")
          + f"; {res.info['time']:.1f}s"
          + (f"; input repaired: {', '.join(fixed)}" if fixed else ""))
    _print_fallbacks(t, args, rep["info"].get("threads"))
    _print_carried(rep)
    _print_textures(rep["textures"])
    for note in rep["notes"]:
        print(f"  note: {note}")
    if not rep["ok"]:
        print("neuraluv: atlas failed validation after reading it back (see the report)", file=sys.stderr)
        return EXIT_INVALID
    return EXIT_OK


def _print_fallbacks(totals, args, threads=None):
    """One line per reason charts fell back, and what to do when the time budget was the reason."""
    reasons = totals.get("fallback_faces_by_reason") or {}
    if not reasons:
        return
    print("fallback faces by reason: " + "; ".join(f"{why} {n:,}" for why, n in sorted(reasons.items(),
                                                                                   key=lambda kv: -kv[1])))
    if any("budget" in why for why in reasons):
        print(f"  the --time-budget ({args.time_budget:g} s) ran out before every chart was solved (a busy "
              f"machine, or a large mesh): those charts have a valid but more distorted map; a larger "
              f"--time-budget (0: none) solves them all")
        if threads and threads.get("n"):
            print(f"  solved with {threads['n']} torch thread(s): {threads['why']}")


def _print_carried(rep):
    """Faces in and out, and where the atlas's written UV set went."""
    fc, w = rep["faces"], rep["written"]
    extra = [f"{fc['twin_faces']:,} duplicate / double-sided faces given their twin's UVs" if fc["twin_faces"] else "",
             f"{fc['collapsed_faces']:,} faces the mesh repair removed (no area, repeated corners, slivers) "
             "mapped to a point" if fc["collapsed_faces"] else ""]
    print(f"  faces: {fc['in']:,} in, {fc['out']:,} out" + "".join(f"; {e}" for e in extra if e))
    if "texcoord" in w:
        sets = sorted(set(w["texcoord"]))
        print(f"  {'replaced' if w['mode'] == 'replace' else 'added'} UV set "
              + ", ".join(f"TEXCOORD_{k}" for k in sets)
              + ("" if w["mode"] == "replace" else " (the atlas; the file's other UV sets untouched, --replace-uvs "
                 "to write it into TEXCOORD_0)")
              + "; every other part of the scene kept"
              + (f"; {w['primitives_split']} primitive(s) had vertices split along the atlas's seams (attributes "
                 "copied)" if w["primitives_split"] else "")
              + (f"; {len(w['filled'])} primitive(s) without the lower UV sets got the atlas there too (glTF "
                 "numbers UV sets from 0 without gaps)" if w.get("filled") else ""))
    elif "f_lines_changed" in w:
        print(f"  OBJ: every line kept but {w['vt_lines_changed']:,} vt lines changed, {w['vt_lines_added']:,} added, "
              f"{w['f_lines_changed']:,} f lines given new vt indices"
              + (f"; {w['polygons_split']:,} polygons written as their triangles (the atlas's seams cross them)"
                 if w.get("polygons_split") else ""))


def _print_textures(textures):
    """One line per re-baked (or skipped) image, with the measured colour change."""
    for t in textures:
        if "skipped" in t:
            print(f"  texture {t['image']}: not re-baked, {t['skipped']}")
        else:
            a, c = t["appearance"]["surface"], t["appearance"]["changed_faces"]
            print(f"  re-baked {t['image']}{' (a normal map: its vectors turned with each face)' if t.get('normal_map') else ''}"
                  f" -> {Path(t['written']).name}: colour change over the surface mean "
                  f"{a['mean']:.3f}, p99 {a['p99']:.2f}; over the changed faces mean {c['mean']:.2f}, p99 "
                  f"{c['p99']:.1f} (8-bit RGB distance, {a['samples']:,} samples each)"
                  + ("" if t["ok"] else " — above the 1-level mean we hold a re-bake to: inspect it"))


def _read_for(args, inp):
    """The layout check and repair read: under ``--purpose bake`` / ``lightmap`` a glTF's triangle primitives
    without the UV set too (a layout to bake into covers the whole mesh; their faces get charts of their own),
    one row per vertex; under ``texture`` the rows of vertices split only for their normals joined (the map's
    islands and folds, as an OBJ's shared ``vt`` gives them)."""
    from neuraluv.io import read_layout

    whole = args.purpose in ("bake", "lightmap")
    return read_layout(inp, args.uv_set, untextured=whole, weld=not whole)


def _purpose(args, inp, data):
    """The purpose asked for, or the default for this file, and a one-line reason."""
    from neuraluv.io import layout_materials
    from neuraluv.layout.purpose import default_purpose

    if args.purpose != "auto":
        return args.purpose, "asked for"
    purpose, why = default_purpose(**layout_materials(inp, data))
    return purpose, f"default: {why}; --purpose bake for a unique layout to bake into"


def cmd_check_uv(args):
    from neuraluv.repair.diagnose import diagnose_layout

    inp, _, _ = check_paths(args.input, input_exts=(".obj", ".glb", ".gltf"))
    V, F, UV, FUV, data = _read_for(args, inp)
    purpose, why = _purpose(args, inp, data)
    d = diagnose_layout(V, F, UV, FUV, resolution=args.resolution, padding=args.padding, purpose=purpose,
                        min_defect=args.min_defect)
    d.info["purpose_reason"] = why
    left_out = list(getattr(data, "skipped", []))
    d.info["left_out"] = left_out
    if args.json:
        print(json.dumps(d.as_dict(), indent=2))
    else:
        print(f"purpose: {purpose} ({why})")
        for line in left_out[:5]:
            print(f"  left out: {line}")
        if len(left_out) > 5:
            print(f"  … and {len(left_out) - 5} more primitives left out (--json lists every one)")
        print(d.format(inp.name, limit=None if args.all else 5))
    return EXIT_OK


def cmd_repair(args):
    from neuraluv.atlas.export import read_atlas, write_atlas
    from neuraluv.io import (GltfLayout, patch_obj, read_gltf_layout, staged_outputs, write_gltf, write_gltf_uvs,
                             write_json)
    from neuraluv.layout.validate import validate_layout
    from neuraluv.repair.repair import repair_layout
    from neuraluv.solver.device import resolve_device

    import time

    t_start = time.perf_counter()
    inp, out, _ = check_paths(args.input, args.output, args.report, input_exts=(".obj", ".glb", ".gltf"),
                              output_exts=(".obj", ".glb", ".gltf"), figure=args.figure)
    if args.resolution < 16 or 2 * args.padding >= args.resolution / 2:
        raise NeuralUVError("need --resolution >= 16 and 0 <= --padding < resolution/4")
    if not args.no_neural:
        resolve_device(args.device)
    V, F, UV, FUV, data = _read_for(args, inp)
    purpose, why = _purpose(args, inp, data)
    print(f"purpose: {purpose} ({why})")
    gltf = isinstance(data, GltfLayout)
    # a glTF / GLB is written back (as .glb or .gltf) with every byte of its data but its UVs
    patchable = gltf and out.suffix.lower() in (".glb", ".gltf")
    if out.suffix.lower() == ".gltf" and not gltf:
        raise NeuralUVError(f"output {out.name}: a .gltf output needs a .glb or .gltf input (write .obj)")
    add = patchable and purpose != "texture" and not args.replace_uvs  # a lightmap goes to a UV set of its own
    res = repair_layout(V, F, UV, FUV, args.preset, seed=args.seed, device=args.device, threads=args.threads,
                        resolution=args.resolution, padding=args.padding,
                        time_budget=max(args.time_budget - (time.perf_counter() - t_start), 1e-3)  # the file read
                        if args.time_budget else None,
                        neural=not args.no_neural, purpose=purpose, repack=add, min_defect=args.min_defect,
                        **_overrides(args))
    # the output, its re-baked textures, the report and the figure are written as one: all or none
    with staged_outputs() as stage:
        tmp = stage(out)
        read_set = args.uv_set
        if data is not None and not gltf and out.suffix.lower() == ".obj":
            written = patch_obj(inp, tmp, res.UV, res.FUV, data=data)  # every other line of the input kept byte for byte
        elif patchable and (add or not res.unchanged):
            try:  # every byte but the UV set kept: nodes, transforms, normals, materials, other UV sets
                written = write_gltf_uvs(data, res.UV, res.FUV, tmp, mode="add" if add else "replace",
                                         base=out.parent)
            except NeuralUVError as exc:
                raise NeuralUVError(f"{inp.name}: {exc}") from None
            read_set = written["texcoord"][0]  # one set index on every primitive written
        elif res.unchanged and out.suffix.lower() == inp.suffix.lower() != ".gltf":
            tmp.write_bytes(inp.read_bytes())  # nothing changed: the input's bytes, not a re-export
            written = {"format": out.suffix.lower(), "copied": True}
        elif res.unchanged and patchable:  # the document as read, its URIs pointing from the output's folder
            write_gltf(data.doc, tmp, keep_json=True, base=out.parent)
            same = out.suffix.lower() == inp.suffix.lower() and tmp.read_bytes() == inp.read_bytes()
            written = {"format": out.suffix.lower(), "copied": same}
            if not same and out.suffix.lower() == ".glb":
                written["note"] = "the same glTF document, converted to .glb (buffers and images inside)"
            elif not same and inp.suffix.lower() == ".gltf":
                written["note"] = ("the same glTF document; its URIs point from the output's folder at the input's "
                                   ".bin and image files")
            elif not same:
                written["note"] = "the same glTF document as .gltf, its buffer in a .bin beside it"
        else:
            write_atlas(tmp, res.V, res.F, res.UV, res.FUV)
            written = {"format": out.suffix.lower()}
        textures = []
        kept_asset = patchable or (data is not None and not gltf and out.suffix.lower() == ".obj")
        if not res.unchanged and not args.no_rebake and not add and kept_asset:  # the set the textures read changed
            from neuraluv.repair.textures import carry_textures

            textures = carry_textures(inp, tmp, data, res, uv_set=args.uv_set, base=out.parent)
            textures = [{**t, "written": str(out.parent / Path(t["written"]).name)} if "written" in t else t
                        for t in textures]
        # the verdict is taken on the written file, by the same purpose's rules as the check
        try:
            if patchable:
                lay2 = read_gltf_layout(tmp, read_set, weld=purpose == "texture", base=out.parent)  # as read in
                V2, F2, UV2, FUV2 = lay2.V, lay2.F, lay2.UV, lay2.FUV
            else:
                V2, F2, UV2, FUV2 = read_atlas(tmp)
        except NeuralUVError as exc:  # a written file our own reader refuses must not be left behind as a result
            raise NeuralUVError(f"the repaired file could not be read back ({exc}); nothing written") from None
        back = validate_layout(V2, F2, UV2, FUV2, check_padding=add, padding=args.padding, resolution=args.resolution,
                               purpose=purpose, min_defect=args.min_defect)
        if args.report:  # the per-island report of a large asset takes a second to build: only when asked for
            rep = res.report()
            rep["purpose"] = {"purpose": purpose, "reason": why}
            rep["written"] = written
            rep["textures"] = textures
            rep["readback"] = back
            write_json(stage(args.report), rep)
        if args.figure:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt

            fig = res.figure(title=inp.name)
            fig.savefig(stage(args.figure), format="png", dpi=110)
            plt.close(fig)
    print(f"wrote {out}: {res.summary()}")
    if written.get("note"):
        print(f"  note: {written['note']}")
    _print_textures(textures)
    if gltf and isinstance(written, dict) and "texcoord" in written:
        print(f"  {'added' if add else 'replaced'} UV set TEXCOORD_{read_set}"
              + (f"; TEXCOORD_{args.uv_set} untouched" + (" where the file had it" if written.get("filled") else "")
                 if add else "")
              + (f"; {written['primitives_split']} primitive(s) had vertices split (attributes copied)"
                 if written["primitives_split"] else "")
              + (f"; TANGENT recomputed on the {written['tangents']} moved vertices (the normal map's frame)"
                 if written.get("tangents") else "")
              + (f"; {len(written['filled'])} primitive(s) without the lower UV sets (faces without texture "
                 "coordinates, given charts) got the new layout there too (glTF numbers UV sets from 0)"
                 if written.get("filled") else ""))
    if not back["valid"]:
        what = (f"{back['folded_faces']} folded and {back['degenerate_faces']} UV-degenerate faces inside shells, "
                f"{back['faces'] - back['covered_faces'] + back['non_finite_faces']} faces without usable UVs"
                if purpose == "texture" else
                f"{back['flips']} flips, {back['overlapping_pairs']} overlapping island pairs, "
                f"{back['self_overlapping_islands']} self-overlapping islands")
        print(f"neuraluv: the repaired layout read back from {out.name} is not valid as a {purpose} layout: {what} "
              "(see the report)", file=sys.stderr)
        return EXIT_INVALID
    return EXIT_OK


def cmd_sweep(args):
    from neuraluv.atlas.sweep import sweep

    check_paths(output=args.output, output_folder=True)
    require("dask")
    res = sweep(args.inputs, args.output, scheduler=args.scheduler, n_workers=args.workers, timeout=args.timeout,
                resume=not args.no_resume, progress=not args.quiet, preset=args.preset, packer=args.packer,
                resolution=args.resolution, padding=args.padding, iterations=args.iterations,
                isolate=not args.in_process, out_format=args.format, limit=args.limit, seed=args.seed,
                device=args.device, threads=args.threads)
    print(res.markdown)
    print(f"wrote {res.paths['csv']}, {res.paths['summary_csv']}, {res.paths['markdown']}")
    return EXIT_OK if res.summary["ok"] == res.summary["tried"] else EXIT_INVALID


def _overrides(args):
    return {"iterations": args.iterations} if args.iterations else {}


def _atlas_options(p):
    add_solver_options(p)


def _defect_option(p, prefix):
    p.add_argument("--min-defect", type=nonneg_float, default=DEFECT_TEXELS, metavar="TEXELS",
                   help=prefix + "overlaps (of an island with itself, or of two islands) smaller than this many texels "
                   f"of area at --resolution cannot show in the texture: noted and left alone (default {DEFECT_TEXELS:g}; "
                   "0: every overlap is a problem)")


def _purpose_option(p, prefix):
    p.add_argument("--purpose", default="auto", choices=["auto", *PURPOSES],
                   help=prefix + "what the layout is for: texture (an artist's layout: mirrored, stacked, tiled, UDIM "
                   "and palette shells are intentional; only folds, UV-degenerate faces and missing/NaN UVs are "
                   "problems), bake or lightmap (unique, unmirrored, in [0,1]², padded). auto (default): texture, "
                   "which changes the least; the reason is printed")


def register(sub):
    """Add ``check``, ``atlas``, ``repair`` and ``sweep`` to the ``neuraluv`` parser."""
    c = sub.add_parser("check", help="explain a mesh's problems and the repairs the atlas pipeline applies",
                       description="Diagnose a mesh: components, boundaries, genus, non-manifold and degenerate "
                                   "elements, and what `atlas` will do about each.", epilog=EPILOG)
    c.add_argument("input", help="mesh file")
    c.add_argument("--json", action="store_true", help="machine-readable output")
    c.add_argument("--all", action="store_true", help="with --uv: every problem and warning (default: five of each kind)")
    c.add_argument("--uv", action="store_true",
                   help="diagnose the file's UV layout instead (OBJ with vt, or GLB): flips, mirrored islands, "
                        "overlaps, missing/NaN UVs, bounds, texel density, padding; and what `repair` would do")
    _purpose_option(c, "with --uv: ")
    _defect_option(c, "with --uv under --purpose bake/lightmap: ")
    c.add_argument("--uv-set", type=int, default=0, metavar="N", help="with --uv: the glTF UV set TEXCOORD_N to read (default 0)")
    c.add_argument("--resolution", type=positive_int, default=1024, help="with --uv: texture resolution (default 1024)")
    c.add_argument("--padding", type=nonneg_float, default=2.0, help="with --uv: required gap in texels (default 2)")
    c.set_defaults(func=lambda args: (cmd_check_uv if args.uv else cmd_check)(args))

    a = sub.add_parser("atlas", help="repair, cut, route (neural / marked fallback), pack and validate a whole mesh",
                       description="Build a validated UV atlas of any triangle mesh: repair, cut into disk-like "
                                   "charts, solve each with the neural solver (or a marked fallback), pack, write, "
                                   "read back and validate (0 flips, 0 overlaps, padding).", epilog=EPILOG)
    a.add_argument("input", help="mesh file")
    a.add_argument("-o", "--output", required=True,
                   help="output .obj (per-corner vt), .glb or .gltf (its .bin beside it); an OBJ written from an OBJ, "
                        "or a .glb / .gltf from a .glb / .gltf, keeps everything of the input but the new UVs")
    a.add_argument("--report", help="JSON report")
    a.add_argument("--resolution", type=positive_int, default=1024, help="texture resolution for the padding (default 1024)")
    a.add_argument("--padding", type=nonneg_float, default=4.0, help="gap between islands in texels (default 4)")
    _packing_options(a)
    a.add_argument("--renders", help="folder for checkerboard and route-coloured PNGs")
    a.add_argument("--replace-uvs", action="store_true",
                   help="glTF: write the atlas into TEXCOORD_0 (textures re-baked) instead of adding it as a UV set of "
                        "its own (TEXCOORD_k, the first k free on every primitive), which leaves the file's textures as they are")
    a.add_argument("--no-rebake", action="store_true",
                   help="do not re-bake the textures that read UVs the atlas replaced (an OBJ with vt, or "
                        "--replace-uvs)")
    time_budget_option(a, 600)
    a.add_argument("--min-height", type=nonneg_float, default=1e-6, help="faces thinner than this fraction of the diagonal are removed as slivers (default 1e-6)")
    _atlas_options(a)
    a.set_defaults(func=cmd_atlas)

    r = sub.add_parser("repair", help="repair a supplied UV layout with minimal change (everything valid stays bit-identical)",
                       description="Repair what is broken in an existing UV layout and leave the rest alone: mirrored "
                                   "islands are reflected back, folds are untangled in the smallest ring of faces that "
                                   "works, overlapping or out-of-square islands are moved (never mirrored; scaled only if "
                                   "nothing else fits), faces without usable UVs get new charts. An OBJ output keeps every "
                                   "other line of the input byte for byte; a valid layout comes back unchanged. "
                                   "`neuraluv check --uv IN` shows the diagnosis first.", epilog=EPILOG)
    r.add_argument("input", help="OBJ with vt (or GLB with TEXCOORD_0)")
    r.add_argument("-o", "--output", required=True, help="output .obj, .glb or .gltf (glTF JSON, its .bin beside it)")
    r.add_argument("--report", help="JSON report: diagnosis before/after, per-island diff")
    r.add_argument("--figure", help="PNG: the layout before and after, changed faces highlighted")
    r.add_argument("--resolution", type=positive_int, default=1024, help="texture resolution for the padding (default 1024)")
    r.add_argument("--padding", type=nonneg_float, default=2.0, help="gap kept around moved and new islands, in texels (default 2)")
    _purpose_option(r, "")
    _defect_option(r, "under --purpose bake/lightmap: ")
    r.add_argument("--no-rebake", action="store_true",
                   help="do not re-bake the textures whose UVs changed (by default each image is redrawn for the new "
                        "layout, written beside / into the output, and the colour change is measured)")
    r.add_argument("--uv-set", type=int, default=0, metavar="N", help="glTF: the UV set TEXCOORD_N to repair (default 0)")
    r.add_argument("--replace-uvs", action="store_true",
                   help="glTF under --purpose bake/lightmap: overwrite the UV set read instead of adding the new "
                        "layout as a UV set of its own (TEXCOORD_k, the first k free on every primitive)")
    r.add_argument("--no-neural", action="store_true", help="untangle/polish/move only; islands that need a re-solve stay broken")
    _atlas_options(r)
    time_budget_option(r, 300)
    r.set_defaults(func=cmd_repair)

    s = sub.add_parser("sweep", help="atlas many assets on a dask cluster; summary like the paper's larger Amara sweep (Table 9)",
                       description="Atlas a folder (or list) of meshes, one subprocess per asset on a dask cluster, "
                                   "with resume and a per-asset timeout; writes per-asset outputs and summary tables.",
                       epilog=EPILOG)
    s.add_argument("inputs", nargs="+", help="folder(s), mesh files, or a .txt list of paths")
    s.add_argument("-o", "--output", required=True, help="output folder (one subfolder per asset + tables)")
    s.add_argument("--scheduler", help="address of an existing dask scheduler (default: a LocalCluster)")
    s.add_argument("--workers", type=positive_int, default=2, help="LocalCluster workers (default 2)")
    s.add_argument("--timeout", type=positive_float, default=600, help="seconds per asset (default 600)")
    s.add_argument("--no-resume", action="store_true", help="redo assets that already have a valid report")
    s.add_argument("--in-process", action="store_true", help="run atlases inside the workers (no per-asset subprocess; timeout is soft)")
    s.add_argument("--format", default="obj", choices=["obj", "glb"], help="output format (default obj)")
    s.add_argument("--limit", type=positive_int, default=None, help="only the first N assets")
    s.add_argument("--resolution", type=positive_int, default=1024, help="texture resolution for the padding (default 1024)")
    s.add_argument("--padding", type=nonneg_float, default=4.0, help="gap between islands in texels (default 4)")
    s.add_argument("--packer", default="tight", choices=list(PACKERS), help="tight (default), shelf (paper) or xatlas")
    _atlas_options(s)
    s.set_defaults(func=cmd_sweep)
