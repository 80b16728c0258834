"""gearrom: gear transmission error from FE stiffness to reduced-order dynamics and measurements.

Pipeline (data flows one way)::

    geometry -> fe -> excitation tables -> rom -> signal -> calibrate

SI units are used everywhere inside the package (m, rad, N, Pa, s). Units other
than SI appear only at the edges (configs, CLI, JSON) and carry their unit in the
key name (``module_mm``, ``te_um``).
"""
from __future__ import annotations

import logging

from gearrom.errors import GearromError

__all__ = ["GearromError", "__version__"]
__version__ = "0.1.0"

logging.getLogger(__name__).addHandler(logging.NullHandler())
