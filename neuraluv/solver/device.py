"""Where the solver runs: device selection and CPU thread control."""
from __future__ import annotations

import contextlib
import os
import time

from neuraluv.errors import NeuralUVError

__all__ = ["resolve_device", "torch_threads", "auto_threads"]


def resolve_device(device="auto"):
    """``"auto"`` → CUDA when available, else CPU; anything else is checked.

    Parameters
    ----------
    device : str, torch.device or None
        ``"auto"``/None, ``"cpu"``, ``"cuda"`` or ``"cuda:N"``.

    Returns
    -------
    torch.device

    Raises
    ------
    NeuralUVError
        For a string torch cannot parse, or CUDA asked for where none is available.

    Examples
    --------
    >>> str(resolve_device("cpu"))
    'cpu'
    >>> resolve_device("bogus")
    Traceback (most recent call last):
    ...
    neuraluv.errors.NeuralUVError: unknown device 'bogus': use auto, cpu or cuda[:N]
    """
    import torch

    if device in (None, "auto"):
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError, ValueError):
        raise NeuralUVError(f"unknown device {device!r}: use auto, cpu or cuda[:N]") from None
    if dev.type == "cuda":
        if not torch.cuda.is_available():
            raise NeuralUVError(f"device {device!r} asked for, but CUDA is not available here: use --device cpu or auto")
        if dev.index is not None and dev.index >= torch.cuda.device_count():
            raise NeuralUVError(f"device {device!r}: only {torch.cuda.device_count()} CUDA device(s) present")
    elif dev.type != "cpu":
        raise NeuralUVError(f"device {device!r} is not supported: use auto, cpu or cuda[:N]")
    return dev


def _busy_now(cpus, seconds=0.1):
    """CPUs of ``cpus`` busy right now: their non-idle share of the next ``seconds`` (``/proc/stat``), or None."""
    def sample():
        with open("/proc/stat") as fh:
            rows = {ln.split()[0]: [int(x) for x in ln.split()[1:]] for ln in fh if ln.startswith("cpu")}
        return [(sum(r), r[3] + (r[4] if len(r) > 4 else 0)) for c, r in rows.items() if c[3:].isdigit()
                and int(c[3:]) in cpus]
    try:
        a = sample()
        time.sleep(seconds)
        b = sample()
    except (OSError, ValueError, IndexError):
        return None
    if not a or len(a) != len(b):
        return None
    return sum(1.0 - (ib - ia) / (tb - ta) for (ta, ia), (tb, ib) in zip(a, b) if tb > ta)


def auto_threads():
    """Torch CPU threads for a solve: the CPUs this process may use that nothing else is busy on.

    Busy is the larger of the CPUs' non-idle share over the next tenth of a second
    (``/proc/stat``) and the tasks running right now besides this one
    (``/proc/loadavg``'s fourth field: two runs started together see each other
    there, before either has used a CPU). Where ``/proc/stat`` cannot be read,
    the 1-minute load average stands in for the first. At least one thread.

    Returns
    -------
    n : int
    why : str
        How ``n`` was chosen, for the command line's output.

    Notes
    -----
    Measured on a 2-core machine (``neuraluv atlas cow.off``): alone, 2 threads
    15.9 s and 1 thread 20.6 s; two such runs at once, 2 threads each 47.3 s
    (and 89–519 s with other OpenMP spin settings), 1 thread each 21.8 s.
    Oversubscribed torch thread pools slow down by ×3 and more; a thread too few
    costs at most the second core. The load average alone lags a minute behind:
    ``bench speed --atlas`` started nefertiti as the steps before it ended (load
    average 2.0) and the machine then stayed at a load of 1.0–1.3 for minutes:
    one thread on two idle cores.

    Examples
    --------
    >>> n, why = auto_threads(); n >= 1 and "CPU" in why
    True
    """
    try:
        affinity = os.sched_getaffinity(0)
    except (AttributeError, OSError):
        affinity = set(range(os.cpu_count() or 1))
    cpus = len(affinity)
    busy = _busy_now(affinity)
    if busy is None:
        try:
            busy = os.getloadavg()[0]
        except (AttributeError, OSError):
            busy = 0.0
    try:
        with open("/proc/loadavg") as fh:
            running = int(fh.read().split()[3].split("/")[0]) - 1  # this process is one of them
        busy = max(busy, running)
    except (OSError, ValueError, IndexError):
        pass
    n = max(1, min(cpus, int(cpus - busy + 0.5)))
    return n, f"{n} of {cpus} CPUs ({busy:.1f} busy)"


@contextlib.contextmanager
def torch_threads(n):
    """Temporarily set ``torch.set_num_threads(n)`` and the BLAS thread pools of NumPy and SciPy to ``n``
    (no-op for ``None`` or 0; ``"auto"``: :func:`auto_threads`).

    Notes
    -----
    The BLAS pools matter as much as torch's under load: with the other core busy, a texture repair of
    Suzanne's mirrored halves (``neuraluv repair``, a fold on the shared rows; the polish's small dense
    products) took 8.5 s with OpenBLAS's two threads and 0.31 s with one (``threadpoolctl``).
    """
    if n == "auto":
        n = auto_threads()[0]
    if not n:
        yield
        return
    import torch
    from threadpoolctl import threadpool_limits

    old = torch.get_num_threads()
    torch.set_num_threads(int(n))
    try:
        with threadpool_limits(limits=int(n), user_api="blas"):
            yield
    finally:
        torch.set_num_threads(old)
