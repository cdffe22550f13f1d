"""Subcommands ``check``, ``atlas``, ``repair`` and ``sweep`` (a :mod:`neuraluv.cli` plugin).

``neuraluv check IN`` explains what is wrong with a mesh; ``neuraluv atlas IN
-o OUT.obj|glb`` builds a validated atlas; ``neuraluv repair IN -o OUT.obj``
re-solves only the flipped charts of an existing layout; ``neuraluv sweep DIR
-o OUT`` atlases many assets on a dask cluster. User errors are one line
(exit 2); an atlas or repair that fails validation exits 3.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from neuraluv.cli.options import (EPILOG, EXIT_INVALID, EXIT_OK, add_solver_options, nonneg_float, positive_float,
                                  positive_int)
from neuraluv.errors import NeuralUVError

__all__ = ["register"]


def _pct(x):
    return f"{100 * x:.1f}%"


def cmd_check(args):
    from neuraluv.check import check_mesh, format_report
    from neuraluv.io import load_mesh

    V, F = load_mesh(args.input)
    r = check_mesh(V, F)
    if args.json:
        print(json.dumps(r.as_dict(), indent=2))
    else:
        print(format_report(r, Path(args.input).name))
    return 0


def cmd_atlas(args):
    from neuraluv.atlas.export import atlas_file
    from neuraluv.solver.device import resolve_device

    out = Path(args.output)
    if out.suffix.lower() not in (".obj", ".glb"):
        raise NeuralUVError(f"output must be .obj or .glb, got {out.name}")
    if args.resolution < 16 or args.padding < 0 or 2 * args.padding >= args.resolution / 2:
        raise NeuralUVError("need --resolution >= 16 and 0 <= --padding < resolution/4")
    resolve_device(args.device)
    res, rep = atlas_file(args.input, out, report=args.report, renders=args.renders, preset=args.preset,
                          resolution=args.resolution, padding=args.padding, packer=args.packer, seed=args.seed,
                          device=args.device, **_overrides(args),
                          time_budget=args.time_budget, threads=args.threads, progress=not args.quiet,
                          min_height=args.min_height)
    t = res.totals()
    b = rep["readback"]
    print(f"wrote {out}: {t['charts']} charts ({t['neural_charts']} neural, {t['fallback_charts']} fallback), "
          f"{t['islands']} islands; faces neural {_pct(t['neural_share'])} / fallback {_pct(t['fallback_share'])}; "
          f"coverage {_pct(b['covered_faces'] / max(b['faces'], 1))}, flips {b['flips']}, overlaps {b['overlapping_pairs']}, "
          f"padding violations {b['padding_violations']}; utilisation {_pct(t['utilisation'])}; {res.info['time']:.1f}s")
    if not rep["ok"]:
        print("neuraluv: atlas failed validation after reading it back (see the report)", file=sys.stderr)
        return EXIT_INVALID
    return EXIT_OK


def cmd_repair(args):
    from neuraluv.atlas.export import read_atlas, write_atlas
    from neuraluv.atlas.uvrepair import repair_uvs
    from neuraluv.io import load_mesh, read_obj, write_json
    from neuraluv.solver.device import resolve_device

    inp = Path(args.input)
    out = Path(args.output)
    if out.suffix.lower() not in (".obj", ".glb"):
        raise NeuralUVError(f"output must be .obj or .glb, got {out.name}")
    resolve_device(args.device)
    load_mesh(inp)  # one-line errors for missing, empty or garbage files
    if inp.suffix.lower() == ".obj":
        V, F, UV, FUV = read_obj(inp)
        if FUV is None or len(UV) == 0:
            raise NeuralUVError(f"{inp.name} has no per-corner texture coordinates (vt) to repair; use `neuraluv atlas`")
    elif inp.suffix.lower() in (".glb", ".gltf"):
        try:
            V, F, UV, FUV = read_atlas(inp)
        except NeuralUVError:
            raise
        except Exception as exc:
            raise NeuralUVError(f"{inp.name}: could not read texture coordinates ({type(exc).__name__})") from None
    else:
        raise NeuralUVError(f"{inp.name}: repair needs an OBJ (vt) or GLB (TEXCOORD_0) input")
    res = repair_uvs(V, F, UV, FUV, args.preset, seed=args.seed, device=args.device,
                     threads=args.threads, **_overrides(args))
    write_atlas(out, res.V, res.F, res.UV, res.FUV)
    # verdict on the written file
    from neuraluv.metrics import face_dets
    from neuraluv.meshfix import normalize_unit_box

    V2, F2, UV2, FUV2 = read_atlas(out)
    flips_back = int((~(face_dets(normalize_unit_box(V2)[0], F2, UV2, FUV2) > 0)).sum())
    rep = res.report()
    rep["readback_flips"] = flips_back
    if args.report:
        write_json(args.report, rep)
    print(f"wrote {out}: {rep['charts']} charts, {rep['changed_charts']} re-solved, {rep['kept_charts']} unchanged; "
          f"flips {rep['flips_before']} -> {flips_back}; repacked: {'yes' if res.repacked else 'no'}; {res.time:.1f}s")
    return EXIT_OK if flips_back == 0 else EXIT_INVALID


def cmd_sweep(args):
    from neuraluv.atlas.sweep import sweep

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


def register(sub):
    """Add ``check``, ``atlas``, ``repair`` and ``sweep`` to the ``neuraluv`` parser."""
    c = sub.add_parser("check", help="explain a mesh's problems and the repairs the atlas pipeline applies",
                       description="Diagnose a mesh: components, boundaries, genus, non-manifold and degenerate "
                                   "elements, and what `atlas` will do about each.", epilog=EPILOG)
    c.add_argument("input", help="mesh file")
    c.add_argument("--json", action="store_true", help="machine-readable output")
    c.set_defaults(func=cmd_check)

    a = sub.add_parser("atlas", help="repair, cut, route (neural / marked fallback), pack and validate a whole mesh",
                       description="Build a validated UV atlas of any triangle mesh: repair, cut into disk-like "
                                   "charts, solve each with the neural solver (or a marked fallback), pack, write, "
                                   "read back and validate (0 flips, 0 overlaps, padding).", epilog=EPILOG)
    a.add_argument("input", help="mesh file")
    a.add_argument("-o", "--output", required=True, help="output .obj (per-corner vt) or .glb (TEXCOORD_0)")
    a.add_argument("--report", help="JSON report")
    a.add_argument("--resolution", type=positive_int, default=1024, help="texture resolution for the padding (default 1024)")
    a.add_argument("--padding", type=nonneg_float, default=4.0, help="gap between islands in texels (default 4)")
    a.add_argument("--packer", default="shelf", choices=["shelf", "xatlas"], help="shelf (paper) or xatlas")
    a.add_argument("--renders", help="folder for checkerboard and route-coloured PNGs")
    a.add_argument("--time-budget", type=positive_float, default=None, help="seconds after which remaining charts become fallbacks")
    a.add_argument("--min-height", type=nonneg_float, default=1e-6, help="faces thinner than this fraction of the diagonal are removed as slivers (default 1e-6)")
    _atlas_options(a)
    a.set_defaults(func=cmd_atlas)

    r = sub.add_parser("repair", help="repair a supplied UV layout, keeping its valid charts bit-identical",
                       description="Re-solve only the UV charts of an existing layout that contain flipped faces; "
                                   "every valid chart passes through unchanged.", epilog=EPILOG)
    r.add_argument("input", help="OBJ with vt (or GLB with TEXCOORD_0)")
    r.add_argument("-o", "--output", required=True, help="output .obj or .glb")
    r.add_argument("--report", help="JSON report of what changed")
    _atlas_options(r)
    r.set_defaults(func=cmd_repair)

    s = sub.add_parser("sweep", help="atlas many assets on a dask cluster; Table 9-style summary",
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
    s.add_argument("--packer", default="shelf", choices=["shelf", "xatlas"], help="shelf (paper, default) or xatlas")
    _atlas_options(s)
    s.set_defaults(func=cmd_sweep)
