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
