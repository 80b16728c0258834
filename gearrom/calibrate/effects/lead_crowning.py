"""``lead_crowning``: lead crowning of the pair beyond the drawing's, through the change of the mesh table.

Model: ``amount_um`` added to the pair's lead crowning (the sum over both gears); the micro-geometry
model gives the STE change of the GMF harmonics and of the mean mesh stiffness. Drawing (seed annex 11):
C_b = 4 +- 3 um. Config: the input gear's ``lead_crowning_um``.
"""
from __future__ import annotations

from gearrom.calibrate.fit_mesh import FlankModification, FlankPlugin
from gearrom.calibrate.registry import EffectSpec, register
from gearrom.excitation.slices import MicroMods

LEAD_SEPARATION = ("repeat at a second load (e.g. half and double torque) and measure the contact pattern: crowning "
                   "keeps the load centred on the face at every load, a helix slope moves it to one face end and its "
                   "effect on the GMF harmonics fades once the whole face carries load")

SPEC = EffectSpec(
    "lead_crowning", ("",), "micro", {"": 7.0}, {"": 35.0},
    "GMF harmonics, weak for helical pairs with overlap ratio near an integer",
    size_key="amount_um", group="lead", separation=LEAD_SEPARATION)


class LeadCrowning(FlankModification):
    """Lead crowning of the pair."""

    def modified(self, base: MicroMods, value_m: float) -> MicroMods:
        return MicroMods(base.tip_relief, base.tip_relief_start_diameter, base.lead_crowning + value_m, base.helix_slope)


class Plugin(FlankPlugin):
    spec = SPEC
    candidate = LeadCrowning


register(Plugin())
