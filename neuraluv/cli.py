"""The ``neuraluv`` command line.

``neuraluv unwrap IN -o OUT.obj``, ``neuraluv demo``, ``neuraluv data``. Bad
input gives one line on stderr and a non-zero exit, never a traceback; outputs
are written atomically.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

__all__ = ["main"]

EXIT_USER = 2
EXIT_INTERNAL = 1


def _add_solver_args(p):
    p.add_argument("--preset", default="fast", choices=["paper", "fast", "literal", "test"], help="solver preset (default: fast)")
    p.add_argument("--seed", type=int, default=0, help="first seed of the retry schedule")
    p.add_argument("--device", default="auto", help="auto (CUDA when available), cpu or cuda")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _write_report(path, report):
    from .io import atomic_write

    with atomic_write(path) as fh:
        json.dump(report, fh, indent=2)


def _summary_line(res):
    rep = res.report()
    t = rep["totals"]
    esd = ", ".join(f"{c['metrics']['esd']:.4g}" if isinstance(c["metrics"]["esd"], float) else str(c["metrics"]["esd"]) for c in rep["charts"])
    return f"{t['charts']} chart(s): {t['neural']} neural, {t['fallback']} fallback; flips {t['flips']}; E_SD {esd}; {rep['time']:.1f}s on {rep['device']}"


def cmd_unwrap(args):
    from .io import load_mesh, write_obj
    from .unwrap import unwrap

    out = Path(args.output)
    if out.suffix.lower() != ".obj":
        raise _UserError(f"output must be an .obj file, got {out.name}")
    V, F = load_mesh(args.input)
    res = unwrap(V, F, args.preset, seed=args.seed, device=args.device, progress=not args.quiet)
    write_obj(out, res.V, res.F, res.UV)
    if args.report:
        _write_report(args.report, res.report())
    print(f"wrote {out}: " + _summary_line(res))
    return 0 if res.metrics["flips"] == 0 else 3


def cmd_demo(args):
    from . import datasets, plot
    from .io import write_obj
    from .unwrap import unwrap

    outdir = Path(args.output)
    outdir.mkdir(parents=True, exist_ok=True)
    V, F = datasets.procedural(args.mesh)
    print(f"demo: unwrapping the built-in '{args.mesh}' chart ({len(V)} vertices, {len(F)} faces) with preset '{args.preset}'")
    res = unwrap(V, F, args.preset, seed=args.seed, device=args.device, progress=not args.quiet)
    write_obj(outdir / "demo.obj", res.V, res.F, res.UV)
    _write_report(outdir / "demo_report.json", res.report())
    plot.save_checkerboard_transfer(outdir / "demo_checkerboard.png", res.V, res.F, res.UV)
    plot.save_uv_layout(outdir / "demo_uv_layout.png", res.V, res.F, res.UV)
    print("wrote " + ", ".join(str(outdir / n) for n in ("demo.obj", "demo_report.json", "demo_checkerboard.png", "demo_uv_layout.png")))
    print(_summary_line(res))
    return 0 if res.metrics["flips"] == 0 else 3


def cmd_data(args):
    from . import datasets

    if args.action == "list":
        for name, (fname, url, sha, lic) in sorted(datasets.REGISTRY.items()):
            state = "cached" if datasets.available(name) else "missing"
            print(f"{name:18s} {state:8s} {fname:22s} {lic}")
        print(f"cache: {datasets.data_dir()}")
        return 0
    names = args.names or sorted(datasets.REGISTRY)
    res = datasets.fetch_all(args.source, names)
    bad = 0
    for name, v in res.items():
        if isinstance(v, Path):
            print(f"{name}: {v}")
        else:
            bad += 1
            print(f"{name}: FAILED: {v}", file=sys.stderr)
    return 0 if not bad else EXIT_USER


class _UserError(Exception):
    pass


def build_parser():
    p = argparse.ArgumentParser(prog="neuraluv", description="Neural fixed-chart UV unwrapping (SIREN chart solver).")
    sub = p.add_subparsers(dest="command", required=True)

    u = sub.add_parser("unwrap", help="unwrap disk-like chart(s) and write an OBJ with per-corner vt")
    u.add_argument("input", help="mesh file (OBJ, OFF, PLY, STL, GLB, .mesh)")
    u.add_argument("-o", "--output", required=True, help="output .obj")
    u.add_argument("--report", help="write a JSON report here")
    _add_solver_args(u)
    u.set_defaults(func=cmd_unwrap)

    d = sub.add_parser("demo", help="run the main job on a built-in chart (no download)")
    d.add_argument("-o", "--output", default="demo_out", help="output folder (default: demo_out)")
    d.add_argument("--mesh", default="glove", help="built-in chart: glove, cap, saddle, bumpy, disk, components")
    _add_solver_args(d)
    d.set_defaults(func=cmd_demo)

    g = sub.add_parser("data", help="list or fetch the registry meshes")
    g.add_argument("action", choices=["list", "fetch"])
    g.add_argument("names", nargs="*", help="registry names (default: all)")
    g.add_argument("--from", dest="source", help="import from a local mirror folder after the sha256 check")
    g.set_defaults(func=cmd_data)

    # Further subcommands live in their own modules, each exposing
    # ``register(subparsers)`` (e.g. ``bench`` and the atlas commands).
    import importlib

    for mod in PLUGINS:
        try:
            m = importlib.import_module(f"neuraluv.{mod}")
        except ModuleNotFoundError as exc:
            if exc.name != f"neuraluv.{mod}":
                raise
            continue
        m.register(sub)
    return p


#: Modules under ``neuraluv`` that add subcommands through ``register(subparsers)``.
PLUGINS = ("cli_bench", "cli_atlas")


def main(argv=None):
    """Entry point; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    from .errors import NeuralUVError

    try:
        return args.func(args)
    except (NeuralUVError, _UserError) as exc:
        print(f"neuraluv: error: {exc}", file=sys.stderr)
        return EXIT_USER
    except KeyboardInterrupt:
        print("neuraluv: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # never show a traceback to a user
        msg = str(exc).splitlines()[0] if str(exc) else ""
        print(f"neuraluv: internal error: {type(exc).__name__}: {msg} (please report this)", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
