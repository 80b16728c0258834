"""Exception hierarchy. Every error raised on purpose by gearrom derives from :class:`GearromError`.

Each subclass also derives from the matching built-in so that generic handlers keep working.
Messages name the field, file or line that is wrong, and why.
"""
from __future__ import annotations


class GearromError(Exception):
    """Root of all gearrom errors."""


class ConfigError(GearromError, ValueError):
    """A configuration file or value is invalid (unknown key, wrong type, non-positive size...)."""


class GeometryError(GearromError, ValueError):
    """The gear geometry is infeasible (undercut, pointed tip, interference, contact ratio < 1...)."""


class MeshError(GearromError, RuntimeError):
    """Meshing failed or produced degenerate elements."""


class SolverError(GearromError, RuntimeError):
    """A solver did not converge or found an inconsistent state (contact not found, penetration...)."""


class MeasurementError(GearromError, ValueError):
    """A measurement file is malformed or inconsistent."""


class ModelError(GearromError, ValueError):
    """A dynamic model is inconsistent (missing component, bad connection, unstable step...)."""


class CalibrationError(GearromError, RuntimeError):
    """The diagnosis / identification could not be carried out."""


class RunInterrupted(GearromError, RuntimeError):
    """A long run stopped at its wall-time limit after writing a checkpoint; run it again to resume."""
