"""Exceptions raised by neuraluv.

Every error a user can trigger with bad input derives from :class:`NeuralUVError`
(itself a ``ValueError``) and carries a one-line, actionable message. The CLI
prints that line and exits non-zero instead of showing a traceback.
"""


class NeuralUVError(ValueError):
    """Base class for user-facing errors (bad input, unsupported topology)."""


class MeshLoadError(NeuralUVError):
    """A mesh file is missing, empty, unreadable, or not a triangle mesh."""


class TopologyError(NeuralUVError):
    """A chart violates the solver's assumptions (e.g. it is not disk-like)."""


#: Optional packages -> the extra that installs them (``pip install "neuraluv[EXTRA]"``).
EXTRAS = {"pyvista": "render", "vtk": "render", "plotly": "render", "dask": "sweep", "distributed": "sweep",
          "mouette": "paper"}


def missing_extra(exc):
    """The one-line :class:`NeuralUVError` for an optional package that is not installed.

    Parameters
    ----------
    exc : ModuleNotFoundError

    Examples
    --------
    >>> str(missing_extra(ModuleNotFoundError("No module named 'pyvista'", name="pyvista")))
    'this needs the optional package pyvista: pip install "neuraluv[render]"'
    """
    name = (exc.name or "").split(".")[0]
    extra = EXTRAS.get(name)
    hint = f'pip install "neuraluv[{extra}]"' if extra else f"pip install {name}"
    return NeuralUVError(f"this needs the optional package {name}: {hint}")


def require(module):
    """Raise :func:`missing_extra`'s error now, before any work, when ``module`` is not installed.

    Examples
    --------
    >>> require("json")
    >>> require("surely_not_installed_anywhere")
    Traceback (most recent call last):
    ...
    neuraluv.errors.NeuralUVError: this needs the optional package surely_not_installed_anywhere: pip install surely_not_installed_anywhere
    """
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise missing_extra(ModuleNotFoundError(f"No module named {module!r}", name=module))
