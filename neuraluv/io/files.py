"""Writing files atomically, and the JSON / CSV the reports are made of.

A file is first written next to its destination and then renamed, so an
interrupted run never leaves a half-written output behind.
"""
from __future__ import annotations

import csv
import glob
import json
import math
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

__all__ = ["atomic_write", "staged_outputs", "jsonable", "write_json", "write_csv"]


def _pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):  # someone else's process, or not a pid
        return pid > 0
    return True


def _remove_stale_temporaries(path):
    """Delete the temporary files an earlier, killed write to ``path`` left (their writer is gone)."""
    for tmp in path.parent.glob(f".{glob.escape(path.name)}.*.tmp"):
        pid = tmp.name[len(path.name) + 2:].split(".", 1)[0]
        if pid.isdigit() and not _pid_alive(int(pid)):
            try:
                tmp.unlink()
            except OSError:
                pass


@contextmanager
def atomic_write(path, mode="w"):
    """Open a temporary file that replaces ``path`` only if the block succeeds.

    The temporary file (``.NAME.PID.XXXX.tmp`` beside ``path``) is deleted when the
    block fails; one left by a killed process (no handler runs then) is deleted by
    the next write to the same path once its process is gone.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> with atomic_write(os.path.join(d, "x.txt")) as fh:
    ...     _ = fh.write("hello")
    >>> open(os.path.join(d, "x.txt")).read()
    'hello'
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _remove_stale_temporaries(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp")
    try:
        with os.fdopen(fd, mode) as fh:
            yield fh
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual file mode
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


_STAGE = ".neuraluv-stage-"


def _remove_stale_stages(folder):
    """Delete the staging folders a killed run left in ``folder`` (their process is gone)."""
    for d in Path(folder).glob(_STAGE + "*"):
        pid = d.name[len(_STAGE):].split(".", 1)[0]
        if d.is_dir() and pid.isdigit() and not _pid_alive(int(pid)):
            shutil.rmtree(d, ignore_errors=True)


@contextmanager
def staged_outputs():
    """Write several output files as one: all of them replace their destinations, or none does.

    The block gets ``stage(path)``, the path to write ``path``'s new content to: a file in a private
    folder beside ``path`` (``.neuraluv-stage-PID.XXXX``). Anything else written into that folder (a
    re-baked texture beside an OBJ) is an output too. When the block succeeds every staged file is moved
    onto its destination, the old files kept aside until all moves succeeded (and put back if one
    fails); when it fails, nothing is moved. Staging folders left by a killed run are removed later.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> with staged_outputs() as stage:
    ...     for name in ("a.obj", "a.json"):
    ...         _ = open(stage(os.path.join(d, name)), "w").write(name)
    >>> sorted(os.listdir(d))
    ['a.json', 'a.obj']
    >>> try:
    ...     with staged_outputs() as stage:
    ...         _ = open(stage(os.path.join(d, "a.obj")), "w").write("new")
    ...         raise OSError("disk full")
    ... except OSError:
    ...     pass
    >>> open(os.path.join(d, "a.obj")).read(), sorted(os.listdir(d))
    ('a.obj', ['a.json', 'a.obj'])
    """
    folders = {}

    def stage(path):
        path = Path(path)
        parent = path.parent.resolve()
        if parent not in folders:
            parent.mkdir(parents=True, exist_ok=True)
            _remove_stale_stages(parent)
            folders[parent] = Path(tempfile.mkdtemp(dir=parent, prefix=f"{_STAGE}{os.getpid()}."))
        return folders[parent] / path.name

    try:
        yield stage
        moved, kept = [], []
        try:
            for parent, d in folders.items():
                for f in sorted(d.iterdir()):
                    if f.name.endswith(".neuraluv-old") or not f.is_file():
                        continue
                    dst = parent / f.name
                    if dst.exists():
                        old = d / (f.name + ".neuraluv-old")
                        os.replace(dst, old)
                        kept.append((old, dst))
                    os.replace(f, dst)
                    moved.append(dst)
        except BaseException:
            for dst in moved:
                try:
                    dst.unlink()
                except OSError:
                    pass
            for old, dst in kept:
                os.replace(old, dst)
            raise
    finally:
        for d in folders.values():
            shutil.rmtree(d, ignore_errors=True)


def jsonable(obj):
    """Convert numpy scalars and non-finite floats for ``json.dump``.

    Non-finite numbers become strings (``"inf"``, ``"-inf"``, ``"nan"``) so a
    report stays valid JSON.

    Examples
    --------
    >>> jsonable({"a": np.float64(1.5), "b": [float("inf"), np.int64(2)]})
    {'a': 1.5, 'b': ['inf', 2]}
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (float, np.floating)):
        f = float(obj)
        return f if math.isfinite(f) else str(f)
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path, obj):
    """Write ``jsonable(obj)`` as indented JSON, atomically; returns the path."""
    with atomic_write(path) as fh:
        json.dump(jsonable(obj), fh, indent=2)
    return Path(path)


def _csv_value(v):
    if isinstance(v, (float, np.floating)):
        v = float(v)
        return repr(v) if math.isfinite(v) else str(v)
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(jsonable(v))
    return "" if v is None else v


def write_csv(path, rows, columns=None):
    """Write a list of dicts as CSV, atomically (raw values, one column per key).

    Parameters
    ----------
    path : str or path-like
    rows : list of dict
    columns : list of str, optional
        Column order (default: keys in order of first appearance); other keys are dropped.

    Returns
    -------
    path : Path

    Examples
    --------
    >>> import tempfile, os
    >>> p = write_csv(os.path.join(tempfile.mkdtemp(), "t.csv"), [{"a": 1, "b": 0.5}, {"a": 2, "c": [1]}])
    >>> open(p).read().splitlines()
    ['a,b,c', '1,0.5,', '2,,[1]']
    """
    columns = columns or list(dict.fromkeys(k for r in rows for k in r))
    with atomic_write(path) as fh:
        w = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: _csv_value(r.get(k)) for k in columns})
    return Path(path)
