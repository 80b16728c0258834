"""The truth of a test case: frozen effect dataclasses in gearrom's report conventions.

Conventions (as gearrom's effect library, so that sizes compare): amplitudes are transmission-error
(TE) equivalents on the transverse line of action in um, positive = output lags; angles and tooth
indices refer to the encoder zero of the record (each channel's first edge, see README.md);
``tooth_index`` k is the tooth that enters contact (its leading face end reaches point A, the start
of active contact) at the record angle ``2 pi k / z`` of its gear. Flank deviations are *minus material*
along the line of action (positive = the flank is set back, contact comes later, output lags).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

GEARS = ("input_gear", "output_gear")
ENCODERS = ("input_encoder", "output_encoder")


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise ValueError(msg)


@dataclass(frozen=True)
class _Effect:
    """Base: ``to_dict`` gives ``{"effect", "target", "parameters", "in_library"}``."""

    name = ""
    in_library = True

    def to_dict(self) -> dict:
        params = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "target"}
        return {"effect": self.name, "target": getattr(self, "target", ""), "parameters": params,
                "in_library": self.in_library}


@dataclass(frozen=True)
class Eccentricity(_Effect):
    """Runout of a gear: the contact moves along the line of action by ``amplitude cos(theta_gear + phase)``."""

    target: str
    amplitude_um: float
    phase_deg: float = 0.0
    name = "eccentricity"

    def __post_init__(self):
        _check(self.target in GEARS, f"eccentricity target must be one of {GEARS}")


@dataclass(frozen=True)
class PitchError(_Effect):
    """Tooth ``tooth_index`` set back by ``deviation_um`` over its whole flank (all slices, whole profile)."""

    target: str
    tooth_index: int
    deviation_um: float
    name = "pitch_error"

    def __post_init__(self):
        _check(self.target in GEARS, f"pitch_error target must be one of {GEARS}")


@dataclass(frozen=True)
class EncoderEccentricity(_Effect):
    """Once-per-rev disc error putting ``amplitude cos(theta + phase)`` into the measured TE (no motion)."""

    target: str
    amplitude_um: float
    phase_deg: float = 0.0
    name = "encoder_eccentricity"

    def __post_init__(self):
        _check(self.target in ENCODERS, f"encoder_eccentricity target must be one of {ENCODERS}")


@dataclass(frozen=True)
class TipRelief(_Effect):
    """Tip relief of all teeth of a gear: ``amount_um`` at the tip, zero at ``start_diameter_mm``.

    ``shape`` is ``"linear"`` or ``"parabolic"`` in the roll distance.
    """

    target: str
    amount_um: float
    start_diameter_mm: float
    shape: str = "linear"
    name = "tip_relief"

    def __post_init__(self):
        _check(self.target in GEARS, f"tip_relief target must be one of {GEARS}")
        _check(self.shape in ("linear", "parabolic"), "tip_relief shape must be linear or parabolic")


@dataclass(frozen=True)
class LeadCrowning(_Effect):
    """Lead crowning of the pair: ``amount_um (2 y / b)^2`` set back, ``amount_um`` at both face ends."""

    amount_um: float
    target: str = ""
    name = "lead_crowning"


@dataclass(frozen=True)
class HelixSlope(_Effect):
    """Helix slope (misalignment) of the pair: ``amount_um y / b``, ``amount_um`` across the face width."""

    amount_um: float
    target: str = ""
    name = "helix_slope"


@dataclass(frozen=True)
class TorsionalMode(_Effect):
    """A rig parameter scaled by ``scale`` (names: :data:`datasim.rig.TUNABLE`)."""

    parameter: str
    scale: float
    target: str = ""
    name = "torsional_mode"


@dataclass(frozen=True)
class LoadRipple(_Effect):
    """Brake torque ripple ``amplitude_Nm cos(order_out theta_load + phase)``: out of gearrom's library."""

    order_out: float
    amplitude_Nm: float
    phase_deg: float = 0.0
    target: str = ""
    name = "load_ripple"
    in_library = False


@dataclass(frozen=True)
class DamagedTooth(_Effect):
    """A pit on the flank of one tooth, out of gearrom's library.

    Depth profile ``depth_um cos^2(pi (u - center) / width)`` for ``|u - center| < width / 2``, with u the
    position along the active profile as a fraction of the path of contact (0 = start A, 1 = end E),
    over the face from ``face_from`` to ``face_to`` (fractions of the face width, 0 = one end).
    """

    target: str
    tooth_index: int
    depth_um: float
    width: float = 0.2
    center: float = 0.5
    face_from: float = 0.25
    face_to: float = 0.75
    name = "damaged_tooth"
    in_library = False

    def __post_init__(self):
        _check(self.target in GEARS, f"damaged_tooth target must be one of {GEARS}")
        _check(0 < self.width <= 1 and 0 <= self.face_from < self.face_to <= 1, "damaged_tooth extent")


@dataclass(frozen=True)
class Case:
    """A test case: its effects and the non-ideal parts of the record.

    Parameters
    ----------
    name : str
        Used in file names.
    effects : tuple of effects
        The truth.
    speed_factor : float
        Actual motor speed over the nominal ``rpm_in`` (a real drive is off by a little).
    line_error_rad : float
        Rms of the random graduation error of each encoder line [rad].
    jitter_s : float
        Rms time jitter of each edge [s].
    """

    name: str = "nominal"
    effects: tuple = field(default_factory=tuple)
    speed_factor: float = 1.003
    line_error_rad: float = 1e-6
    jitter_s: float = 2e-9

    def of(self, cls) -> list:
        """Effects of type ``cls``."""
        return [e for e in self.effects if isinstance(e, cls)]

    def to_dict(self) -> dict:
        return {"name": self.name, "effects": [e.to_dict() for e in self.effects],
                "speed_factor": self.speed_factor, "line_error_rad": self.line_error_rad,
                "jitter_s": self.jitter_s}
