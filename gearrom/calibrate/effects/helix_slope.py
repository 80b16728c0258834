"""``helix_slope``: a helix slope deviation of the pair (misalignment), through the change of the mesh table.

Model: ``amount_um`` (either sign) over the face width added to the pair's helix slope; the micro-geometry
model gives the STE change of the GMF harmonics. Drawing (seed annex 11): f_Hbeta = +-11 um. Config: the
input gear's ``helix_slope_um``.
"""
from __future__ import annotations

from gearrom.calibrate.effects.lead_crowning import LEAD_SEPARATION
from gearrom.calibrate.fit_mesh import FlankModification, FlankPlugin
from gearrom.calibrate.registry import EffectSpec, register
from gearrom.excitation.slices import MicroMods

SPEC = EffectSpec(
    "helix_slope", ("",), "micro", {"": 11.0}, {"": 55.0},
    "GMF harmonics from the load concentrated at one face end",
    size_key="amount_um", group="lead", separation=LEAD_SEPARATION)


class HelixSlope(FlankModification):
    """Helix slope of the pair (signed)."""

    signed = True

    def modified(self, base: MicroMods, value_m: float) -> MicroMods:
        return MicroMods(base.tip_relief, base.tip_relief_start_diameter, base.lead_crowning, base.helix_slope + value_m)


class Plugin(FlankPlugin):
    spec = SPEC
    candidate = HelixSlope


register(Plugin())
