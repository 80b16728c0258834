"""The effect library: what can be missing from the nominal model, its parameters, limits and signature.

Canonical names: ``eccentricity``, ``pitch_error``, ``tip_relief``, ``lead_crowning``,
``helix_slope``, ``encoder_eccentricity``, ``torsional_mode``.

Conventions (all amplitudes are transmission-error equivalents along the transverse line of
action, um, positive = output lags; angles refer to the encoder zero of the record, i.e. each
channel's first edge):

* ``eccentricity`` (target ``input_gear`` / ``output_gear``): geometric runout of the gear as the
  once-per-rev kinematic error ``amplitude_um cos(theta_gear + phase_deg)`` it puts into the mesh
  (``amplitude_um`` = eccentricity e = F_r/2 projected on the line of action). The drivetrain
  responds to it: real shaft motion on both channels, dynamic amplification near the modes.
* ``pitch_error`` (target gear): one tooth displaced by ``deviation_um`` (single pitch deviations
  +f and -f on its two flanks' pitches; cumulative deviation f at that tooth). While the tooth
  is in mesh it changes the TE as the static equilibrium of all pairs in contact gives
  (:mod:`gearrom.excitation.slices`: about ``deviation_um`` times its load share when small,
  saturating when the tooth leaves contact). ``tooth_index`` counts teeth from the gear angle 0
  of the record.
* ``encoder_eccentricity`` (target ``input_encoder`` / ``output_encoder``): a once-per-rev angle
  error of the encoder alone, ``amplitude_um cos(theta + phase_deg)`` in the TE; measurement-only:
  no mesh modulation, no motion of the other shaft, no speed or load dependence.
* ``tip_relief`` (target gear, ``amount_um``, ``start_diameter_mm``), ``lead_crowning``
  (``amount_um``), ``helix_slope`` (``amount_um`` over the face width): flank modifications acting
  through the change of the mesh excitation table (quasi-static FE tables, no FE solve): mesh harmonics.
* ``torsional_mode``: a mis-tuned rig parameter (``parameter``, ``scale``) and the mode it moves
  (``frequency_hz``, ``damping_ratio``).

Plausibility limits come from the helical rig drawings (seed annex 11): F_r = 22 um, f_p = 5 um,
F_p = 16 um, C_a = 8+-4 / 15+-5 um, C_b = 4+-3 um, f_Hbeta = +-11 um. Fits are bounded by the
``bound`` below (at least five times the tolerance: real parts are out of tolerance or damaged,
so the fit is not capped at the drawing) and flagged when they exceed the drawing ``tolerance``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field


from gearrom.errors import CalibrationError

UM = 1e-6


@dataclass(frozen=True)
class EffectSpec:
    """One library entry.

    Attributes
    ----------
    name : str
    targets : tuple of str
        Allowed targets (``("",)`` for pair-level effects).
    kind : {"kinematic", "measurement", "micro", "rig"}
        How it enters: kinematic error through the dynamics, measurement-only, mesh table, rig parameter.
    tolerance : dict
        Drawing tolerance of the size parameter per target, um.
    bound : dict
        Plausibility bound used in the fit per target, um.
    signature : str
        The physical signature, for the report.
    """

    name: str
    targets: tuple[str, ...]
    kind: str
    tolerance: dict
    bound: dict
    signature: str


GEARS = ("input_gear", "output_gear")
ENCODERS = ("input_encoder", "output_encoder")

LIBRARY: dict[str, EffectSpec] = {
    "eccentricity": EffectSpec(
        "eccentricity", GEARS, "kinematic", {g: 11.0 for g in GEARS}, {g: 100.0 for g in GEARS},
        "once per revolution of the gear in the TE, with real motion of both shafts (mesh excitation) and "
        "GMF sidebands at that shaft's order; dynamically amplified near the drivetrain modes"),
    "pitch_error": EffectSpec(
        "pitch_error", GEARS, "kinematic", {g: 16.0 for g in GEARS}, {g: 150.0 for g in GEARS},
        "impulsive once-per-revolution content of one gear: a broad comb of that shaft's orders"),
    "encoder_eccentricity": EffectSpec(
        "encoder_eccentricity", ENCODERS, "measurement", {e: 20.0 for e in ENCODERS}, {e: 150.0 for e in ENCODERS},
        "pure once-per-revolution of one channel, no sidebands, no motion of the other shaft, "
        "independent of speed and load"),
    "tip_relief": EffectSpec(
        "tip_relief", GEARS, "micro", {"input_gear": 12.0, "output_gear": 20.0},
        {"input_gear": 60.0, "output_gear": 100.0},
        "GMF harmonics (load dependent) from the tooth entry/exit of the relieved gear"),
    "lead_crowning": EffectSpec(
        "lead_crowning", ("",), "micro", {"": 7.0}, {"": 35.0},
        "GMF harmonics, weak for helical pairs with overlap ratio near an integer"),
    "helix_slope": EffectSpec(
        "helix_slope", ("",), "micro", {"": 11.0}, {"": 55.0},
        "GMF harmonics from the load concentrated at one face end"),
    "torsional_mode": EffectSpec(
        "torsional_mode", ("",), "rig", {}, {},
        "response at a fixed frequency across speeds; GMF and shaft-order lines amplified near it"),
}


@dataclass(frozen=True)
class Effect:
    """An effect with fitted parameters, as reported.

    Attributes
    ----------
    effect : str
        Canonical name (a key of :data:`LIBRARY`).
    target : str or None
    parameters : dict
        In report units (um, deg, mm, Hz).
    evidence : str
    rms_reduction_um : float
    extra : dict
        Uncertainty, tolerance flags, alternatives.
    """

    effect: str
    target: str | None
    parameters: dict
    evidence: str = ""
    rms_reduction_um: float = 0.0
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"effect": self.effect, "target": self.target, "parameters": dict(self.parameters),
                "evidence": self.evidence, "rms_reduction_um": self.rms_reduction_um, **self.extra}


def check_name(name: str, target: str | None = None) -> EffectSpec:
    """The library entry ``name``, checking ``target``."""
    if name not in LIBRARY:
        raise CalibrationError(f"effect {name!r} is not in the library; choose from {sorted(LIBRARY)}")
    spec = LIBRARY[name]
    if target is not None and target not in spec.targets and not (target == "" and spec.targets == ("",)):
        raise CalibrationError(f"effect {name!r}: target {target!r} not allowed; choose from {spec.targets}")
    return spec


# ---------------------------------------------------------------- kinematic error patterns
def amp_phase(x_cos: float, x_sin: float) -> tuple[float, float]:
    """Amplitude and phase (deg) of ``x_cos cos(theta) - x_sin sin(theta)``."""
    return math.hypot(x_cos, x_sin), math.degrees(math.atan2(x_sin, x_cos))
