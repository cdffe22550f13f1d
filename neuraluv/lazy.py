"""Packages that import their modules on first use (PEP 562 module ``__getattr__``), and kernels compiled on first use.

A package lists where each of its public names is defined; nothing is imported
until a name is asked for, so ``import neuraluv`` and the command line's help
stay light (no torch, no scipy) while ``from neuraluv.layout import rigid_fit``
works as usual.

The few loops profiling asked to compile (a packer's scan, the untangle's energy)
are compiled by numba, the optional extra ``fast``, when it is installed
(:data:`HAS_NUMBA`, :func:`jit`); each has a NumPy path for when it is not.
"""
from __future__ import annotations

import importlib
import importlib.util

__all__ = ["lazy_exports", "HAS_NUMBA", "jit"]

#: numba is installed (the ``fast`` extra): the compiled kernels are used (imported and compiled on first use).
HAS_NUMBA = importlib.util.find_spec("numba") is not None


def jit(f):
    """``f`` compiled by numba in nopython mode, kept in numba's on-disk cache where one is writable.

    Call only where :data:`HAS_NUMBA` (numba is imported here, on first use).
    """
    from numba import njit

    try:
        return njit(cache=True)(f)
    except RuntimeError:  # numba found no writable cache directory: compiled in each process
        return njit(f)


def lazy_exports(package, where, namespace):
    """``__getattr__`` and ``__dir__`` for ``package``, whose name ``n`` lives in its module ``where[n]``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    where : dict
        Public name -> the package's module (relative) that defines it.
    namespace : dict
        The package's ``globals()`` (for ``dir()``).

    Returns
    -------
    (__getattr__, __dir__) functions to bind in the package.

    Examples
    --------
    >>> get, names = lazy_exports("neuraluv", {"MeshLoadError": "errors"}, {})
    >>> get("MeshLoadError").__name__, names()
    ('MeshLoadError', ['MeshLoadError'])
    >>> get("nope")
    Traceback (most recent call last):
    ...
    AttributeError: module 'neuraluv' has no attribute 'nope'
    """
    def __getattr__(name):
        if name in where:
            return getattr(importlib.import_module(f"{package}.{where[name]}"), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__():
        return sorted(set(namespace) | set(where))

    return __getattr__, __dir__
