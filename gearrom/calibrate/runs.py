"""What a simulator of the diagnosis takes and gives: run conditions, model changes, angle histories.

:class:`Simulator` is the contract the diagnosis talks to (:mod:`gearrom.calibrate.simulator` has the
exudyn ROM adapter and the choice of simulator, :mod:`gearrom.calibrate.torsional` the torsional rig model).

Conventions of :class:`ModelChanges`
------------------------------------
* ``kinematic_in`` / ``kinematic_out``: a kinematic error of the input / output gear (runout,
  pitch deviations) as its *transmission-error equivalent* along the transverse line of action,
  in m, sampled on a uniform grid over one revolution of that gear (angle 0 = the angle at which
  the record starts, i.e. the encoder's first edge). Positive values make the output lag.
  Quasi-statically the TE grows by exactly this amount; dynamically the drivetrain filters it.
* ``micro``: flank modifications (:class:`~gearrom.excitation.slices.MicroMods`), turned into a
  change of the nominal mesh excitation table by the micro-geometry model (FE tables, no FE solve).
* ``rig_scale``: multiplicative changes of named rig parameters (``Simulator.tunable()``).
* ``load_ripple``: ``(relative amplitude, order of the output shaft, phase_rad)`` of the brake
  torque: not a library effect, used to make out-of-library test data.
* ``mesh_phase_rad``: where the teeth stand at encoder zero: the mesh table is evaluated at
  ``theta_1 + mesh_phase_rad`` (estimated per run by the diagnosis, never fitted to the residual).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from gearrom.errors import CalibrationError
from gearrom.excitation.slices import MicroMods

__all__ = ["ModelChanges", "RunConditions", "SimHistory", "Simulator"]


@dataclass(frozen=True)
class RunConditions:
    """Operating point of one run.

    Parameters
    ----------
    rpm_in : float
        Input speed, rpm.
    torque_out_Nm : float
        Brake torque on the output, N m.
    duration_s : float
        Length of the steady-state record, s.
    """

    rpm_in: float
    torque_out_Nm: float
    duration_s: float

    def __post_init__(self):
        for k in ("rpm_in", "torque_out_Nm", "duration_s"):
            v = getattr(self, k)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise CalibrationError(f"RunConditions.{k}={v!r} must be a positive number")


@dataclass(frozen=True, eq=False)
class ModelChanges:
    """Changes of the nominal model (see the module docstring for the conventions)."""

    kinematic_in: np.ndarray | None = None
    kinematic_out: np.ndarray | None = None
    micro: MicroMods | None = None
    rig_scale: tuple[tuple[str, float], ...] = ()
    load_ripple: tuple[float, float, float] | None = None
    mesh_phase_rad: float = 0.0

    @property
    def is_nominal(self) -> bool:
        return (self.kinematic_in is None and self.kinematic_out is None and self.micro is None
                and not self.rig_scale and self.load_ripple is None and self.mesh_phase_rad == 0.0)


@dataclass(frozen=True, eq=False)
class SimHistory:
    """Shaft angles at the encoders over the steady-state record.

    Attributes
    ----------
    t_s : ndarray
        Time from the start of the record, s.
    theta_in_rad, theta_out_rad : ndarray
        Encoder angles, rad, about zero at ``t = 0`` (the angle reference of ``ModelChanges``).
    """

    t_s: np.ndarray
    theta_in_rad: np.ndarray
    theta_out_rad: np.ndarray
    info: dict = field(default_factory=dict)


class Simulator(Protocol):
    """What the diagnosis needs from a dynamic drivetrain model."""

    name: str

    def simulate(self, run: RunConditions, changes: ModelChanges | None = None) -> SimHistory:  # pragma: no cover
        """Encoder angle histories of the steady state at ``run`` with ``changes``."""
        ...

    def tunable(self) -> dict[str, str]:  # pragma: no cover
        """Rig parameters that ``ModelChanges.rig_scale`` may scale, with a description."""
        ...

    def modes_hz(self, rig_scale: tuple[tuple[str, float], ...] = ()) -> list[tuple[float, float]]:  # pragma: no cover
        """Natural frequencies (Hz) and damping ratios at the mean mesh stiffness; [] if unknown."""
        ...
