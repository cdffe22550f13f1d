"""The command line's shared option set, argument types and exit codes."""
from __future__ import annotations

import argparse
import math

from neuraluv.solver.config import PRESET_HELP, PRESETS

__all__ = ["EXIT_OK", "EXIT_INTERNAL", "EXIT_USER", "EXIT_INVALID", "EXIT_INTERRUPTED", "EXIT_TERMINATED", "EPILOG",
           "add_solver_options", "time_budget_option", "positive_int", "nonneg_float", "positive_float", "seed_int",
           "preset_help"]

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_USER = 2
EXIT_INVALID = 3
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143

#: Printed under every command's ``--help``.
EPILOG = ("exit codes: 0 success; 2 bad input or options (one line on stderr says what to fix); "
          "3 the output was written but failed validation (flips or overlaps: see the report); "
          "1 internal error (please report it); 130 interrupted (Ctrl-C), 143 terminated (SIGTERM): "
          "no partial output is left.")


def preset_help(default="fast"):
    """``--preset`` help text: every preset explained, the default named."""
    lines = "; ".join(f"{name}: {PRESET_HELP.get(name, '')}" for name in PRESETS)
    return f"solver preset (default: {default}). {lines}"


def positive_int(text):
    """argparse type: an integer ≥ 1."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {v}")
    return v


def threads_arg(text):
    """argparse type: ``auto`` or an integer ≥ 1."""
    return "auto" if str(text).strip().lower() == "auto" else positive_int(text)


def _finite(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return v


def nonneg_float(text):
    """argparse type: a finite number ≥ 0."""
    v = _finite(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return v


def positive_float(text):
    """argparse type: a finite number > 0."""
    v = _finite(text)
    if not v > 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return v


def seed_int(text):
    """argparse type: a seed in ``0 .. 2**63 - 1``."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer seed, got {text!r}") from None
    if not 0 <= v < 2**63:
        raise argparse.ArgumentTypeError(f"seed must be in 0 .. 2**63-1, got {v}")
    return v


def add_solver_options(p, *, default_preset="fast", preset_default_none=False):
    """``--preset --seed --device --threads --quiet``, the same on every command that solves charts."""
    p.add_argument("--preset", default=None if preset_default_none else default_preset, choices=list(PRESETS),
                   metavar="{" + ",".join(PRESETS) + "}", help=preset_help(default_preset))
    p.add_argument("--iterations", type=positive_int, default=None, help="override the preset's iteration budget")
    p.add_argument("--seed", type=seed_int, default=0, help="first seed of the solver's retry schedule (default 0)")
    p.add_argument("--device", default="auto",
                   help="auto (CUDA when available, else CPU; default), cpu, cuda or cuda:N; an unavailable device is an error")
    p.add_argument("--threads", type=threads_arg, default="auto",
                   help="torch CPU threads, or auto (default: the CPUs nothing else is busy on, at least one: "
                        "two runs at once on two cores would each slow down x3 with two threads; give a number where runs must "
                        "repeat bit for bit)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")


def time_budget_option(p, default):
    """``--time-budget SECONDS``: bounded work (0: no limit)."""
    p.add_argument("--time-budget", type=nonneg_float, default=float(default), metavar="SECONDS",
                   help=f"stop optimising after this many seconds (default {default:g}; 0: no limit); a chart still "
                        "running keeps its best valid map, a chart not yet solved becomes a marked fallback")
