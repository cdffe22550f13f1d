"""The ``neuraluv`` command line.

================  ===============================================================
``unwrap``        disk-like chart(s) → OBJ with per-corner ``vt`` (:mod:`.chart`)
``demo``          the main job on a built-in chart, with figures
``data``          the real-mesh registry: list, fetch, import from a mirror
``check``         what is wrong with a mesh, and what ``atlas`` will do (:mod:`.atlas`)
``atlas``         a validated atlas of any mesh (OBJ or GLB)
``repair``        repair a supplied UV layout, keeping what is valid
``sweep``         many assets on a dask cluster
``bench``         the paper's tables (:mod:`.bench`)
================  ===============================================================

Bad input gives one line on stderr and exit status 2, never a traceback;
outputs are written atomically. The shared options live in :mod:`.options`.
Building the parser imports neither torch nor numpy, so ``--help`` is fast.
"""
from __future__ import annotations

import argparse
import sys

from neuraluv import __version__
from neuraluv.cli.options import EPILOG, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_USER

__all__ = ["main", "build_parser"]


def build_parser(argv=None):
    """The full ``argparse`` parser (``argv`` lets ``bench`` add only the named runner's options)."""
    from neuraluv.cli import atlas, bench, chart

    p = argparse.ArgumentParser(prog="neuraluv", epilog=EPILOG,
                                description="Neural fixed-chart UV unwrapping, atlases and UV repair "
                                            "(the executable companion to the paper).")
    p.add_argument("--version", action="version", version=f"neuraluv {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    chart.register(sub)
    atlas.register(sub)
    bench.register(sub, argv)
    return p


def main(argv=None):
    """Entry point; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser(argv).parse_args(argv)
    from neuraluv.errors import NeuralUVError

    try:
        return args.func(args)
    except NeuralUVError as exc:
        print(f"neuraluv: error: {exc}", file=sys.stderr)
        return EXIT_USER
    except KeyboardInterrupt:
        print("neuraluv: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # never show a traceback to a user
        msg = str(exc).splitlines()[0] if str(exc) else ""
        print(f"neuraluv: internal error: {type(exc).__name__}: {msg} (please report this)", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
