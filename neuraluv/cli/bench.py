"""``neuraluv bench NAME``: the paper's tables, run by the harness in :mod:`neuraluv_paper.bench`.

The library only forwards: when the harness is importable its runners are
registered (:func:`neuraluv_paper.bench.register`); otherwise ``neuraluv
bench`` answers with a one-line hint and exit status 2.
"""
from __future__ import annotations

import argparse

from neuraluv.cli.options import EPILOG, EXIT_USER

__all__ = ["register", "HINT"]

#: What ``neuraluv bench`` says when the harness is missing.
HINT = "neuraluv bench needs the paper's harness (neuraluv_paper): install it with pip install \"neuraluv[paper]\""


def _missing(args):
    import sys

    print(f"neuraluv: error: {HINT}", file=sys.stderr)
    return EXIT_USER


def register(subparsers, argv=None):
    """Add ``bench``: the harness's runners, or the hint when it is not installed."""
    try:
        from neuraluv_paper.bench import register as register_runners
    except ImportError:
        p = subparsers.add_parser("bench", help="run a benchmark that reproduces one of the paper's tables "
                                               "(needs neuraluv[paper])", description=HINT, epilog=EPILOG)
        p.add_argument("args", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
        p.set_defaults(func=_missing)
        return
    register_runners(subparsers, argv)
