"""``tip_relief``: a tip relief of one gear beyond the drawing's, through the change of the mesh table.

Model: the amount ``amount_um`` is added to the gear's tip relief (its start diameter from the config,
not fitted); the micro-geometry model gives the STE change of the GMF harmonics (the quasi-static FE
tables, no FE solve). Drawing (seed annex 11): C_a = 8 +- 4 um (pinion), 15 +- 5 um (wheel). Config:
``<gear>.microgeometry.tip_relief_um``.
"""
from __future__ import annotations

from gearrom.calibrate.fit_mesh import FlankModification, FlankPlugin
from gearrom.calibrate.registry import GEARS, EffectSpec, register
from gearrom.excitation.slices import MicroMods

SPEC = EffectSpec(
    "tip_relief", GEARS, "micro", {"input_gear": 12.0, "output_gear": 20.0}, {"input_gear": 60.0, "output_gear": 100.0},
    "GMF harmonics (load dependent) from the tooth entry/exit of the relieved gear",
    size_key="amount_um", group="tip_relief",
    separation="repeat at a second load (e.g. half and double torque): tip relief of the driving and driven gear "
               "changes the GMF harmonics differently with load")


class TipRelief(FlankModification):
    """Tip relief of the target gear."""

    def modified(self, base: MicroMods, value_m: float) -> MicroMods:
        tr = list(base.tip_relief)
        i = GEARS.index(self.target)
        tr[i] += value_m
        return MicroMods(tuple(tr), base.tip_relief_start_diameter, base.lead_crowning, base.helix_slope)

    def fixed_parameters(self, ctx) -> dict:
        dca = ctx.micro_nominal.tip_relief_start_diameter[GEARS.index(self.target)]
        return {"start_diameter_mm": None if dca is None else dca * 1e3}


class Plugin(FlankPlugin):
    spec = SPEC
    candidate = TipRelief

    def write_config(self, draft, target, params):
        s = draft.micro_section(target)
        s["tip_relief_um"] = s.get("tip_relief_um", 0.0) + float(params["amount_um"])
        if params.get("start_diameter_mm") and "tip_relief_start_diameter_mm" not in s:
            s["tip_relief_start_diameter_mm"] = float(params["start_diameter_mm"])


register(Plugin())
