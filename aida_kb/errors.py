"""The exception hierarchy: every error aida-kb raises on purpose derives from `AidaError`.

The command line turns an `AidaError` into a one-line message and a non-zero exit code;
anything else reaching the top is a bug.
"""

from __future__ import annotations


class AidaError(Exception):
    """Root of all errors raised by aida-kb on bad input or impossible requests."""


class KbError(AidaError):
    """A knowledge base cannot be read or compiled (the diagnostics say why)."""


class GeometryError(AidaError):
    """Degenerate geometry: parallel planes that should meet, vertices at infinity, and so on."""


class SolveError(AidaError):
    """A least-squares problem is malformed or the solver failed."""


class FormatError(AidaError):
    """A file on disk (scene directory, calibration, evidence, model) is missing or malformed."""


class VisionError(AidaError):
    """The vision front end cannot produce evidence from its input images."""


class InterpretError(AidaError):
    """The interpreter was asked something it cannot do (unknown goal, malformed fixture)."""
