"""``encoder_eccentricity``: a once-per-revolution angle error of one encoder alone (measurement only).

Model: ``amplitude_um cos(theta + phase_deg)`` in the TE and in that encoder's channel: no mesh
modulation, no motion of the other shaft, no speed or load dependence. Not part of the gear model, so
it is not written into a config.
"""
from __future__ import annotations

from gearrom.calibrate.effects.eccentricity import SPEC as GEAR_RUNOUT
from gearrom.calibrate.evidence import ShaftOrderPlugin
from gearrom.calibrate.fit import ShaftOrder
from gearrom.calibrate.registry import ENCODERS, EffectSpec, register

SPEC = EffectSpec(
    "encoder_eccentricity", ENCODERS, "measurement", {e: 20.0 for e in ENCODERS}, {e: 150.0 for e in ENCODERS},
    "pure once-per-revolution of one channel, no sidebands, no motion of the other shaft, "
    "independent of speed and load",
    size_key="amplitude_um", group=GEAR_RUNOUT.group, separation=GEAR_RUNOUT.separation)


class EncoderEccentricity(ShaftOrder):
    """Order 1 of the encoder's shaft in the TE and its own channel only."""

    measurement_only = True


class Plugin(ShaftOrderPlugin):
    spec = SPEC
    candidate = EncoderEccentricity

    def write_config(self, draft, target, params):
        draft.notes.append(f"{target}: eccentricity {params['amplitude_um']:.3g} um at {params['phase_deg']:.1f} deg "
                           "is a measurement error, not part of the gear model; not written")


register(Plugin())
