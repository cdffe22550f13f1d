"""``neuraluv bench NAME``: the runners that reproduce the paper's tables.

Each benchmark lives in its own module ``neuraluv.bench_<name>`` (``-`` becomes
``_``) exposing ``add_arguments(parser)`` and ``run(args) -> int``. This module
only adds the common options and dispatches:

======================  ==========================================================
``compact``             Table 2: Hand, Bob, Camel vs LSCM, ARAP, SLIM-1k, BFF
``failure-modes``       Table 3: C/B, SLIM-20, SLIM-1k, BFF, OptCuts
``ablation``            Table 4: spectral rank, SIREN bandwidth, initialisation
``ntk``                 Table 5: NTK–LBO subspace alignment
``charts``              Table 6: xatlas-cut charts, stratified by size
``pareto``              Table 7: iteration budget vs quality and time
======================  ==========================================================

Common options (``args`` attributes every runner can rely on): ``output``
(folder, default ``results/<name>``), ``quick`` (tiny budgets, seconds),
``preset`` (solver preset or None for the runner's default), ``meshes`` (list
of names or None), ``resume`` (skip rows already in ``rows.jsonl``), ``seed``,
``device``, ``threads`` (torch CPU threads), ``quiet`` (no progress bars).
"""
from __future__ import annotations

import importlib

__all__ = ["BENCHMARKS", "register", "module_for", "add_common_arguments"]

#: Benchmark name -> one-line description (the module is ``bench_<name>``).
BENCHMARKS = {
    "compact": "Table 2: compact pre-cut charts (Hand, Bob, Camel) against the classical solvers",
    "failure-modes": "Table 3: components/boundaries and how SLIM, BFF and OptCuts fail",
    "ablation": "Table 4: spectral rank k, SIREN bandwidth omega0, absolute initialisations",
    "ntk": "Table 5: NTK-LBO subspace alignment",
    "charts": "Table 6: xatlas-cut charts of closed meshes, stratified by face count",
    "pareto": "Table 7: iteration budget vs median E_SD and time",
}


def module_for(name):
    """Import ``neuraluv.bench_<name>``; a one-line user error when it is missing."""
    from .errors import NeuralUVError

    mod = f"neuraluv.bench_{name.replace('-', '_')}"
    try:
        return importlib.import_module(mod)
    except ModuleNotFoundError as exc:
        if exc.name != mod:
            raise
        raise NeuralUVError(f"benchmark {name!r} is not available in this installation ({mod} missing)") from None


def add_common_arguments(p, name):
    """The options shared by every runner (see the module docstring)."""
    p.add_argument("-o", "--output", default=f"results/{name}", help=f"output folder (default: results/{name})")
    p.add_argument("--quick", action="store_true", help="tiny budgets and small inputs: finishes in seconds (CI, notebooks)")
    p.add_argument("--preset", choices=["paper", "fast", "literal", "test"], default=None,
                   help="neural solver preset (default: the runner's; 'test' under --quick)")
    p.add_argument("--meshes", nargs="+", default=None, metavar="NAME",
                   help="meshes to run (compact charts, registry or procedural names)")
    p.add_argument("--resume", action="store_true", help="keep rows already finished in OUTPUT/rows.jsonl and skip them")
    p.add_argument("--seed", type=int, default=0, help="first seed of the solver's retry schedule")
    p.add_argument("--device", default="auto", help="auto (CUDA when available), cpu or cuda")
    p.add_argument("--threads", type=int, default=None,
                   help="torch CPU threads (default: 1 under --quick, else torch's default)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")


def _dispatch(args):
    import torch

    threads = getattr(args, "threads", None) or (1 if getattr(args, "quick", False) else None)
    if threads:
        torch.set_num_threads(int(threads))
    return module_for(args.bench).run(args)


def register(subparsers):
    """Add ``bench NAME [options]`` to the ``neuraluv`` command line."""
    b = subparsers.add_parser("bench", help="run a benchmark that reproduces one of the paper's tables",
                              description="Reproduce the paper's tables; each writes CSV, Markdown and figures to --output.")
    sub = b.add_subparsers(dest="bench", required=True, metavar="NAME")
    for name, help_ in BENCHMARKS.items():
        # "resolve": a runner may redefine a common option (its own definition wins)
        p = sub.add_parser(name, help=help_, description=help_, conflict_handler="resolve")
        add_common_arguments(p, name)
        try:
            mod = importlib.import_module(f"neuraluv.bench_{name.replace('-', '_')}")
        except ModuleNotFoundError as exc:
            if exc.name != f"neuraluv.bench_{name.replace('-', '_')}":
                raise
            mod = None
        if mod is not None and hasattr(mod, "add_arguments"):
            mod.add_arguments(p)
        p.set_defaults(func=_dispatch)
