"""Where the solver runs: device selection and CPU thread control."""
from __future__ import annotations

import contextlib
import os

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


def auto_threads():
    """Torch CPU threads for a solve: the CPUs this process may use that nothing else is busy on.

    Busy is the larger of the 1-minute load average and the tasks running right
    now besides this one (``/proc/loadavg``'s fourth field on Linux: the load
    average lags a minute behind, so two runs started together see each other
    only there). At least one thread.

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
    costs at most the second core.

    Examples
    --------
    >>> n, why = auto_threads(); n >= 1 and "CPU" in why
    True
    """
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cpus = os.cpu_count() or 1
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
    """Temporarily set ``torch.set_num_threads(n)`` (no-op for ``None`` or 0; ``"auto"``: :func:`auto_threads`)."""
    if n == "auto":
        n = auto_threads()[0]
    if not n:
        yield
        return
    import torch

    old = torch.get_num_threads()
    torch.set_num_threads(int(n))
    try:
        yield
    finally:
        torch.set_num_threads(old)
