"""``neuraluv unwrap``, ``neuraluv demo`` and ``neuraluv data``: single charts and the data registry."""
from __future__ import annotations

import sys
from pathlib import Path

from neuraluv.cli.options import EPILOG, EXIT_INVALID, EXIT_OK, EXIT_USER, add_solver_options, time_budget_option
from neuraluv.cli.paths import check_paths

__all__ = ["register"]


def _summary_line(res):
    rep = res.report()
    t = rep["totals"]
    esd = [c["metrics"]["esd"] for c in rep["charts"]]
    esd = ", ".join(f"{e:.4g}" if isinstance(e, float) else str(e) for e in esd[:6]) + (", ..." if len(esd) > 6 else "")
    r = rep["repair"]
    fixed = [f"{r[k]} {k.replace('_', ' ')}" for k in ("duplicate_faces", "degenerate_faces", "merged_vertices") if r.get(k)]
    return (f"{t['charts']} chart(s): {t['neural']} neural, {t['fallback']} fallback; flips {t['flips']}; "
            f"E_SD {esd}; {rep['time']:.1f}s on {rep['device']}"
            + (f"; input repaired: {', '.join(fixed)} (removed/welded)" if fixed else ""))


def cmd_unwrap(args):
    from neuraluv.atlas.unwrap import unwrap
    from neuraluv.io import load_mesh, write_json, write_obj
    from neuraluv.solver.device import resolve_device, torch_threads

    _, out, _ = check_paths(args.input, args.output, args.report, output_exts=(".obj",))
    resolve_device(args.device)
    V, F = load_mesh(args.input)
    with torch_threads(args.threads):
        res = unwrap(V, F, args.preset, seed=args.seed, device=args.device, progress=not args.quiet,
                     time_budget=args.time_budget or None,
                     **({"iterations": args.iterations} if args.iterations else {}))
    write_obj(out, res.V, res.F, res.UV)
    if args.report:
        write_json(args.report, res.report())
    print(f"wrote {out}: " + _summary_line(res))
    return EXIT_OK if res.metrics["flips"] == 0 else EXIT_INVALID


def cmd_demo(args):
    from neuraluv import datasets, plot
    from neuraluv.atlas.unwrap import unwrap
    from neuraluv.errors import missing_extra
    from neuraluv.io import write_json, write_obj
    from neuraluv.solver.device import resolve_device, torch_threads

    check_paths(output=args.output, output_folder=True)
    resolve_device(args.device)
    outdir = Path(args.output)
    outdir.mkdir(exist_ok=True)
    V, F = datasets.procedural(args.mesh)
    print(f"demo: unwrapping the built-in '{args.mesh}' chart ({len(V)} vertices, {len(F)} faces) with preset '{args.preset}'")
    with torch_threads(args.threads):
        res = unwrap(V, F, args.preset, seed=args.seed, device=args.device, progress=not args.quiet,
                     time_budget=args.time_budget or None,
                     **({"iterations": args.iterations} if args.iterations else {}))
    write_obj(outdir / "demo.obj", res.V, res.F, res.UV)
    write_json(outdir / "demo_report.json", res.report())
    names = ["demo.obj", "demo_report.json", "demo_uv_layout.png"]
    plot.save_uv_layout(outdir / "demo_uv_layout.png", res.V, res.F, res.UV)
    try:  # the 3D render needs the render extra (pyvista); the rest of the demo does not
        plot.save_checkerboard_transfer(outdir / "demo_checkerboard.png", res.V, res.F, res.UV)
        names.insert(2, "demo_checkerboard.png")
    except ModuleNotFoundError as exc:
        print(f"demo: checkerboard render skipped: {missing_extra(exc)}")
    print("wrote " + ", ".join(str(outdir / n) for n in names))
    print(_summary_line(res))
    return EXIT_OK if res.metrics["flips"] == 0 else EXIT_INVALID


def cmd_data(args):
    from neuraluv import datasets

    if args.action == "list":
        for name, (fname, url, sha, lic) in sorted(datasets.REGISTRY.items()):
            state = "cached" if datasets.available(name) else "missing"
            print(f"{name:18s} {state:8s} {fname:22s} {lic}")
        print(f"cache: {datasets.data_dir()}")
        return EXIT_OK
    names = args.names or sorted(datasets.REGISTRY)
    res = datasets.fetch_all(args.source, names)
    bad = 0
    for name, v in res.items():
        if isinstance(v, Path):
            print(f"{name}: {v}")
        else:
            bad += 1
            print(f"{name}: FAILED: {v}", file=sys.stderr)
    return EXIT_OK if not bad else EXIT_USER


def register(sub):
    """Add ``unwrap``, ``demo`` and ``data`` to the ``neuraluv`` parser."""
    u = sub.add_parser("unwrap", help="unwrap disk-like chart(s) and write an OBJ with per-corner vt",
                       description="Unwrap every connected component of a mesh with the neural chart solver (each must "
                                   "be a disk: one boundary loop, no handles; use `neuraluv atlas` for closed or "
                                   "messy meshes) and pack the charts side by side in [0,1]^2.",
                       epilog=EPILOG)
    u.add_argument("input", help="mesh file (OBJ, OFF, PLY, STL, GLB, .mesh)")
    u.add_argument("-o", "--output", required=True, help="output .obj (written atomically)")
    u.add_argument("--report", help="write a JSON report here (per chart: metrics, status, reason, time)")
    add_solver_options(u)
    time_budget_option(u, 300)
    u.set_defaults(func=cmd_unwrap)

    d = sub.add_parser("demo", help="unwrap a built-in chart (no download) and write figures",
                       description="Run the main job on a built-in procedural chart: OBJ, JSON report, checkerboard "
                                   "transfer and UV-layout PNGs.", epilog=EPILOG)
    d.add_argument("-o", "--output", default="demo_out", help="output folder (default: demo_out)")
    d.add_argument("--mesh", default="glove", choices=["glove", "cap", "saddle", "bumpy", "disk", "components"],
                   help="built-in chart (default: glove)")
    add_solver_options(d)
    time_budget_option(d, 300)
    d.set_defaults(func=cmd_demo)

    g = sub.add_parser("data", help="list or fetch the registry meshes",
                       description="List the real-mesh registry, or fetch meshes (download, or import from a local "
                                   "mirror after the sha256 check).", epilog=EPILOG)
    g.add_argument("action", choices=["list", "fetch"], help="list: show the registry and what is cached; fetch: get meshes")
    g.add_argument("names", nargs="*", help="registry names (default: all)")
    g.add_argument("--from", dest="source", help="import from a local mirror folder after the sha256 check")
    g.set_defaults(func=cmd_data)
