"""The runners that reproduce the paper's tables: ``neuraluv bench NAME``.

Each runner lives in its own module ``neuraluv_paper.bench.<name>`` (``-``
becomes ``_``) exposing ``add_arguments(parser)`` (its own options) and
``run(args) -> int``. This module registers them under the library's command
line (:mod:`neuraluv.cli.bench` forwards here) with the shared options and
dispatches; a runner's module is imported only when that runner is named on
the command line, so ``neuraluv --help`` imports none.

Shared options (``args`` attributes every runner can rely on): ``output``
(folder, default ``results/<name>``), ``quick`` (tiny budgets, seconds),
``preset`` (solver preset or None for the runner's default), ``meshes`` (list
of names or None), ``resume`` (skip rows already in ``rows.jsonl``), ``seed``,
``device``, ``threads`` (torch CPU threads), ``quiet`` (no progress bars).

=================  ================================================================
``common``         what runners share: names, mesh loading, the run's start and report
``provenance``     tables, numbers, machine line, commit, resumable row logs, findings
``paper_values``   the paper's numbers, one place
=================  ================================================================
"""
from __future__ import annotations

import importlib

from neuraluv.cli.options import EPILOG, add_solver_options
from neuraluv.errors import NeuralUVError

__all__ = ["BENCHMARKS", "register", "module_for", "add_common_arguments"]

#: Benchmark name -> one-line description (the module is ``neuraluv_paper.bench.<name>``); tables and
#: figures are numbered as in the paper's LaTeX.
BENCHMARKS = {
    "compact": "Table 1: compact pre-cut charts (Hand, Bob, Camel) against the classical solvers",
    "failure-modes": "Table 2: components/boundaries and how SLIM, BFF and OptCuts fail",
    "ablation": "Table 3: spectral rank k, SIREN bandwidth omega0, absolute initialisations",
    "ntk": "Table 4: NTK-LBO subspace alignment (Figures 7 and 8)",
    "charts": "Table 5: xatlas-cut charts of closed meshes, stratified by face count",
    "pareto": "Table 6: iteration budget vs median E_SD and time (Figure 9)",
    "speed": "solver speed: network floor, cost split, presets vs libigl SLIM (and --pareto: the fast preset's study)",
    "atlas-quality": "atlas packing, chart count, seams and texel density beside xatlas on the same meshes",
    "repair": "UV repair with minimal change: generated damage and broken layouts, against mouette's untangler",
    "authored": "check and repair on real authored assets: intent kept, added damage fixed, textures re-baked, lightmaps",
    "generated": "Tables 7-9 (Amara) on the generated set: ours vs Blender's unwraps; --sweep N",
    "baselines": "external baselines (make baselines): our BFF vs the BFF v1.6 binary; OptCuts on 1K-40K xatlas charts",
}

_HINT = "pip install \"neuraluv[paper]\""


def module_for(name):
    """Import ``neuraluv_paper.bench.<name>``; a one-line user error when it (or what it needs) is missing."""
    mod = f"neuraluv_paper.bench.{name.replace('-', '_')}"
    try:
        return importlib.import_module(mod)
    except ModuleNotFoundError as exc:
        if exc.name == mod:
            raise NeuralUVError(f"benchmark {name!r} is not available in this installation ({mod} missing)") from None
        raise NeuralUVError(f"neuraluv bench {name} needs the {exc.name!r} package: {_HINT}") from None


def add_common_arguments(p, name):
    """The options shared by every runner (see the module docstring)."""
    p.add_argument("-o", "--output", default=f"results/{name}", help=f"output folder (default: results/{name})")
    p.add_argument("--quick", action="store_true", help="tiny budgets and small inputs: finishes in seconds (CI, notebooks)")
    p.add_argument("--meshes", nargs="+", default=None, metavar="NAME",
                   help="meshes to run (compact charts, registry or procedural names)")
    p.add_argument("--resume", action="store_true", help="keep rows already finished in OUTPUT/rows.jsonl and skip them")
    add_solver_options(p, default_preset="the runner's own", preset_default_none=True)


def _dispatch(args):
    from neuraluv.solver.device import resolve_device

    resolve_device(args.device)
    if args.threads == "auto":  # a benchmark runs as it says: torch's own thread count unless one is given
        args.threads = None
    threads = args.threads or (1 if args.quick else None)
    if threads:
        import torch

        torch.set_num_threads(int(threads))
    try:
        return module_for(args.bench).run(args)
    except ModuleNotFoundError as exc:  # an optional package a runner reaches for mid-run
        raise NeuralUVError(f"neuraluv bench {args.bench} needs the {exc.name!r} package: {_HINT}") from None


def register(subparsers, argv=None):
    """Add ``bench NAME [options]``; the runner named in ``argv`` (if any) adds its own options."""
    b = subparsers.add_parser("bench", help="run a benchmark that reproduces one of the paper's tables",
                              description="Reproduce the paper's tables; each writes CSV, Markdown and figures to --output.",
                              epilog=EPILOG)
    sub = b.add_subparsers(dest="bench", required=True, metavar="NAME")
    argv = list(argv or [])
    chosen = None
    if "bench" in argv:
        rest = [a for a in argv[argv.index("bench") + 1:] if not a.startswith("-")]
        chosen = rest[0] if rest else None
    for name, help_ in BENCHMARKS.items():
        p = sub.add_parser(name, help=help_, description=help_, epilog=EPILOG)
        add_common_arguments(p, name)
        if name == chosen:
            mod = module_for(name)
            if hasattr(mod, "add_arguments"):
                mod.add_arguments(p)
        p.set_defaults(func=_dispatch)
