"""Every path a command touches, checked before any work starts.

A command that would overwrite its own input, write its report over its
output, write into a missing or read-only folder, or produce a format it
cannot write stops at once with one line — not after a long solve, and never
with a half-written file.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from neuraluv.errors import NeuralUVError
from neuraluv.io import MESH_EXTENSIONS

__all__ = ["check_input", "check_output", "check_distinct", "check_paths"]


def check_input(path, exts=MESH_EXTENSIONS, what="input"):
    """The input: an existing, readable regular file with a known extension."""
    p = Path(path)
    if not p.exists():
        raise NeuralUVError(f"{what} {p}: no such file")
    if p.is_dir():
        raise NeuralUVError(f"{what} {p}: is a folder, expected a file")
    if not p.is_file():
        raise NeuralUVError(f"{what} {p}: not a regular file (a pipe or device?); save it to a file first")
    if exts and p.suffix.lower() not in exts:
        raise NeuralUVError(f"{what} {p.name}: unknown format {p.suffix or '(no extension)'!r}; use one of {', '.join(exts)}")
    if not os.access(p, os.R_OK):
        raise NeuralUVError(f"{what} {p}: not readable (permissions)")
    return p


def check_output(path, exts=None, what="output", folder=False):
    """An output file (or folder): a known extension, an existing writable parent, not a folder (file)."""
    p = Path(path)
    if folder:
        if p.exists() and not p.is_dir():
            raise NeuralUVError(f"{what} {p}: exists and is not a folder")
        parent = p if p.exists() else p.parent
    else:
        if exts and p.suffix.lower() not in exts:
            raise NeuralUVError(f"{what} {p.name}: must end in {' or '.join(exts)}")
        if p.is_dir():
            raise NeuralUVError(f"{what} {p}: is a folder, expected a file name")
        if p.exists() and not p.is_file():
            raise NeuralUVError(f"{what} {p}: exists and is not a regular file")
        parent = p.parent
    parent = parent if str(parent) else Path(".")
    if not parent.exists():
        raise NeuralUVError(f"{what} folder {parent} does not exist; create it first")
    if not parent.is_dir():
        raise NeuralUVError(f"{what} folder {parent} is not a folder")
    try:  # probe: the only reliable test (ACLs, read-only mounts, quotas)
        with tempfile.NamedTemporaryFile(dir=parent, prefix=".neuraluv-probe-"):
            pass
    except OSError as exc:
        raise NeuralUVError(f"cannot write to the {what} folder {parent}: {exc.strerror or exc}") from None
    return p


def check_distinct(**paths):
    """Refuse when two of the named paths are the same file (``--report IN``, ``-o X --report X``, ...)."""
    seen = {}
    for name, p in paths.items():
        if p is None:
            continue
        key = os.path.realpath(p)
        for other, okey in seen.items():
            same = key == okey
            if not same and os.path.exists(key) and os.path.exists(okey):
                same = os.path.samefile(key, okey)
            if same:
                raise NeuralUVError(f"{name} and {other} are the same file ({p}); give them different names")
        seen[name] = key


def check_paths(input=None, output=None, report=None, *, input_exts=MESH_EXTENSIONS, output_exts=None,
                output_folder=False, figure=None):
    """All of the above for one command; returns the checked ``Path`` objects (None where not given).

    ``figure`` (a ``.png``) is checked like an output and must differ from the others too.
    """
    check_distinct(input=input, output=output, report=report, figure=figure)  # the gravest mistake is named first
    inp = check_input(input, input_exts) if input is not None else None
    out = check_output(output, output_exts, folder=output_folder) if output is not None else None
    rep = check_output(report, (".json",), what="report") if report is not None else None
    if figure is not None:
        check_output(figure, (".png",), what="figure")
    return inp, out, rep
