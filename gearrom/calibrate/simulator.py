"""The simulator interface the diagnosis talks to, and the adapter to the exudyn ROM.

The diagnosis needs one thing from a dynamic model: shaft angle histories at the encoders for a
run condition, with optional *model changes* (the effects of the library). :class:`Simulator` is
that contract. Two implementations:

* :class:`gearrom.calibrate.rig.TorsionalRig`: a small torsional drivetrain (numba RK4), always
  available, fast; the default when the exudyn ROM is not importable.
* :class:`RomSimulator`: adapter to ``gearrom.rom.simulate_run`` (issue 4), used when present.

Conventions of :class:`ModelChanges`
------------------------------------
* ``kinematic_in`` / ``kinematic_out``: a kinematic error of the input / output gear (runout,
  pitch deviations) as its *transmission-error equivalent* along the transverse line of action,
  in m, sampled on a uniform grid over one revolution of that gear (angle 0 = the angle at which
  the record starts, i.e. the encoder's first edge). Positive values make the output lag.
  Quasi-statically the TE grows by exactly this amount; dynamically the drivetrain filters it.
* ``micro``: flank modifications (:class:`~gearrom.calibrate.microgeom.MicroMods`), turned into a
  mesh excitation table by the micro-geometry model (analytical slices now, FE tables later).
* ``rig_scale``: multiplicative changes of named rig parameters (``Simulator.tunable()``).
* ``load_ripple``: ``(relative amplitude, order of the output shaft, phase_rad)`` of the brake
  torque: not a library effect, used to make out-of-library test data.
* ``mesh_phase_rad``: where the teeth stand at encoder zero: the mesh table is evaluated at
  ``theta_1 + mesh_phase_rad`` (estimated per run by the diagnosis, never fitted to the residual).
"""
from __future__ import annotations

import inspect
import logging
import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from gearrom.calibrate.microgeom import MicroMods
from gearrom.errors import CalibrationError

log = logging.getLogger(__name__)


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


def periodic_lookup(table: np.ndarray | None):
    """A callable ``f(theta)`` interpolating a one-revolution table periodically (zero if None)."""
    if table is None:
        return lambda th: 0.0 * np.asarray(th, float)
    tab = np.asarray(table, float)
    n = tab.size
    grid = np.arange(n + 1) * (2 * math.pi / n)
    ext = np.append(tab, tab[0])
    return lambda th: np.interp(np.mod(th, 2 * math.pi), grid, ext)


class RomSimulator:
    """Adapter to the exudyn ROM of issue 4 (``gearrom.rom.simulate_run``).

    The ROM's API was not final when this was written; the adapter inspects the signature and
    passes what it accepts: ``e_extra(theta1, theta2)`` for the kinematic errors, ``excitation``
    for micro-geometry tables, ``load_ripple`` and ``rig`` overrides. Missing hooks raise
    :class:`CalibrationError` naming them, so the gap is visible rather than silently ignored.
    """

    name = "gearrom.rom"

    def __init__(self, config, micro_model=None):
        import gearrom.rom as rom  # noqa: F401  (ImportError tells the caller the ROM is absent)

        if not hasattr(rom, "simulate_run"):
            raise ImportError("gearrom.rom has no simulate_run yet")
        from gearrom.calibrate.microgeom import SliceMicroModel

        self._rom = rom
        self.config = config
        self.micro_model = micro_model or SliceMicroModel()
        self._params = set(inspect.signature(rom.simulate_run).parameters)

    def tunable(self) -> dict[str, str]:
        return {}

    def modes_hz(self, rig_scale=()) -> list[tuple[float, float]]:
        return []

    def simulate(self, run: RunConditions, changes: ModelChanges | None = None) -> SimHistory:
        ch = changes or ModelChanges()
        kw = {}
        if ch.kinematic_in is not None or ch.kinematic_out is not None:
            if "e_extra" not in self._params:
                raise CalibrationError("gearrom.rom.simulate_run has no 'e_extra' hook: kinematic-error effects "
                                       "(eccentricity, pitch_error) cannot be simulated with the ROM")
            f1, f2 = periodic_lookup(ch.kinematic_in), periodic_lookup(ch.kinematic_out)
            kw["e_extra"] = lambda th1, th2: f1(th1) + f2(th2)
        if ch.micro is not None:
            if "excitation" not in self._params:
                raise CalibrationError("gearrom.rom.simulate_run has no 'excitation' argument for micro-geometry")
            from gearrom.config import load_config

            pair = load_config(self.config, check=False).pair
            kw["excitation"] = self.micro_model.excitation(pair, [0.5 * run.torque_out_Nm, run.torque_out_Nm,
                                                                  1.5 * run.torque_out_Nm], ch.micro)
        if ch.mesh_phase_rad and "mesh_phase_rad" in self._params:
            kw["mesh_phase_rad"] = ch.mesh_phase_rad
        elif ch.mesh_phase_rad:
            raise CalibrationError("gearrom.rom.simulate_run has no 'mesh_phase_rad': the measured mesh phase "
                                   "cannot be imposed")
        if ch.load_ripple is not None or ch.rig_scale:
            raise CalibrationError("RomSimulator: load ripple and rig-parameter scaling are not wired to the ROM yet")
        res = self._rom.simulate_run(self.config, run.rpm_in, run.torque_out_Nm, run.duration_s, **kw)
        t = np.asarray(getattr(res, "t_s"), float)
        th1 = np.asarray(getattr(res, "theta_in_rad"), float)
        th2 = np.asarray(getattr(res, "theta_out_rad"), float)
        return SimHistory(t - t[0], th1 - th1[0], th2 - th2[0], info={"simulator": self.name})


def default_simulator(config, prefer: str = "auto") -> Simulator:
    """The simulator the diagnosis uses for ``config``.

    Parameters
    ----------
    config : str or Path
        Gear configuration name or file.
    prefer : {"auto", "rom", "torsional"}
        ``"auto"``: the exudyn ROM when it exposes the hooks the library needs, else the torsional rig.
    """
    from gearrom.calibrate.rig import TorsionalRig

    if prefer in ("auto", "rom"):
        try:
            sim = RomSimulator(config)
            if {"e_extra", "excitation"} <= sim._params:
                return sim
            if prefer == "rom":
                return sim
            log.info("gearrom.rom lacks e_extra/excitation hooks; using the torsional rig model")
        except ImportError as exc:
            if prefer == "rom":
                raise CalibrationError(f"the exudyn ROM is not available: {exc}") from exc
    return TorsionalRig.from_config(config)
