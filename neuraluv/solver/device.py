"""Where the solver runs: device selection and CPU thread control."""
from __future__ import annotations

import contextlib

from neuraluv.errors import NeuralUVError

__all__ = ["resolve_device", "torch_threads"]


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


@contextlib.contextmanager
def torch_threads(n):
    """Temporarily set ``torch.set_num_threads(n)`` (no-op for ``None`` or 0)."""
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
