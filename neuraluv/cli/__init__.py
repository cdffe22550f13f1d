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
from neuraluv.cli.options import EPILOG, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_TERMINATED, EXIT_USER

__all__ = ["main", "console", "build_parser"]


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage block): ``neuraluv: error: ...`` and exit 2."""

    def error(self, message):
        self.exit(EXIT_USER, f"neuraluv: error: {message} (see `{self.prog} --help`)\n")


def build_parser(argv=None):
    """The full ``argparse`` parser (``argv`` lets ``bench`` add only the named runner's options)."""
    from neuraluv.cli import atlas, bench, chart

    p = _Parser(prog="neuraluv", epilog=EPILOG,
                                description="Neural fixed-chart UV unwrapping, atlases and UV repair "
                                            "(the executable companion to the paper).")
    p.add_argument("--version", action="version", version=f"neuraluv {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    chart.register(sub)
    atlas.register(sub)
    bench.register(sub, argv)
    return p


class _Terminated(KeyboardInterrupt):
    """SIGTERM, turned into an exception so outputs in progress are discarded like on Ctrl-C."""


def _importing_other_package(frame):
    """The name of the module from another package that ``frame`` runs inside the import of, else None."""
    while frame is not None:
        if frame.f_code.co_name == "_find_and_load" and frame.f_code.co_filename.startswith("<frozen importlib"):
            name = frame.f_locals.get("name")
            if isinstance(name, str) and name.split(".")[0] != "neuraluv":
                return name
        frame = frame.f_back
    return None


def _on_signal(signum, frame):
    """Ctrl-C (SIGINT) or SIGTERM as an exception, but never inside another package's import.

    Imports swallow the exception (trimesh imports its optional dependencies under ``except BaseException``, so the
    run goes on and exits 0) or garble it (libigl's ``ImportError: std::bad_cast``; a process dying of the signal
    after the message). Inside another package's import the signal is sent again 50 ms later, until it lands in our
    own code; a Ctrl-C during torch's import waits for that import to finish.
    """
    import signal

    if _importing_other_package(frame):
        import os
        import threading

        again = threading.Timer(0.05, os.kill, (os.getpid(), signum))
        again.daemon = True
        again.start()
        return
    raise KeyboardInterrupt() if signum == signal.SIGINT else _Terminated()


def main(argv=None):
    """Entry point; returns the exit status."""
    import signal
    import threading

    from neuraluv.errors import NeuralUVError, missing_extra

    argv = sys.argv[1:] if argv is None else list(argv)
    previous = {}
    if threading.current_thread() is threading.main_thread():
        previous[signal.SIGTERM] = signal.signal(signal.SIGTERM, _on_signal)
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # not where Ctrl-C is ignored (`cmd &`)
            previous[signal.SIGINT] = signal.signal(signal.SIGINT, _on_signal)
    try:
        try:
            args = build_parser(argv).parse_args(argv)
        except SystemExit as exc:  # --help, --version, or a one-line usage error
            return exc.code if isinstance(exc.code, int) else EXIT_USER
        return args.func(args)
    except NeuralUVError as exc:
        print(f"neuraluv: error: {exc}", file=sys.stderr)
        return EXIT_USER
    except ModuleNotFoundError as exc:  # an optional extra that is not installed
        if not exc.name or exc.name.split(".")[0] in ("neuraluv", "neuraluv_paper"):
            raise
        print(f"neuraluv: error: {missing_extra(exc)}", file=sys.stderr)
        return EXIT_USER
    except _Terminated:
        print("neuraluv: terminated; no partial output was written", file=sys.stderr)
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        print("neuraluv: interrupted; no partial output was written", file=sys.stderr)
        return EXIT_INTERRUPTED
    except OSError as exc:  # a disk full, a file removed under us, a permission changed mid-run
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        print(f"neuraluv: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_USER
    except Exception as exc:  # never show a traceback to a user
        msg = str(exc).splitlines()[0] if str(exc) else ""
        print(f"neuraluv: internal error: {type(exc).__name__}: {msg} (please report this)", file=sys.stderr)
        return EXIT_INTERNAL
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def console():
    """The ``neuraluv`` command (console script and ``python -m neuraluv``): :func:`main`, then a quick exit.

    The exit handlers run (``atexit``) and the output streams are flushed, and then the process ends without the
    interpreter's teardown of every module: with torch loaded that teardown alone took about 0.7 s of each
    command (``import torch, numba, scipy.sparse``, then exit: 3.0-3.1 s, with this exit 2.3-2.4 s, on the 2-core
    CI machine). Where a thread that is not a daemon or a child process still runs, or a profiler or debugger
    watches (``python -m cProfile -m neuraluv ...`` writes its statistics after the command), the usual exit.
    """
    import os
    import threading

    code = main()
    others = [t for t in threading.enumerate() if t is not threading.main_thread() and not t.daemon and t.is_alive()]
    children = "multiprocessing" in sys.modules and sys.modules["multiprocessing"].active_children()
    watched = sys.getprofile() is not None or sys.gettrace() is not None  # cProfile, a debugger: they write at exit
    if not isinstance(code, int) or others or children or watched:
        sys.exit(code)
    import atexit

    try:
        atexit._run_exitfuncs()
        sys.stdout.flush()
        sys.stderr.flush()
    except Exception:  # a closed pipe (`neuraluv ... | head`): nothing more can be said there
        pass
    os._exit(code)


if __name__ == "__main__":
    console()
