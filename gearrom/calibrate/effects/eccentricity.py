"""``eccentricity``: geometric runout of a gear, a once-per-revolution kinematic error through the drivetrain.

Model: the kinematic error ``amplitude_um cos(theta_gear + phase_deg)`` the runout puts into the mesh
(``amplitude_um`` = eccentricity e = F_r / 2 projected on the line of action). The drivetrain responds to
it: real motion of both shafts, dynamic amplification near the modes. Drawing (seed annex 11): F_r = 22 um.
Config: ``<gear>.microgeometry.runout_um`` (= 2 x amplitude) and ``runout_phase_deg``.
"""
from __future__ import annotations

from gearrom.calibrate.evidence import ShaftOrderPlugin
from gearrom.calibrate.fit import ShaftOrder
from gearrom.calibrate.registry import GEARS, EffectSpec, register

SPEC = EffectSpec(
    "eccentricity", GEARS, "kinematic", {g: 11.0 for g in GEARS}, {g: 100.0 for g in GEARS},
    "once per revolution of the gear in the TE, with real motion of both shafts (mesh excitation) and "
    "GMF sidebands at that shaft's order; dynamically amplified near the drivetrain modes",
    size_key="amplitude_um", group="once_per_rev",
    separation="rotate the encoder disc on its shaft (e.g. by 90 deg) and repeat a run: an encoder error moves "
               "with the encoder, gear runout stays; or run where that shaft's order 1 meets the first torsional "
               "mode, where runout is dynamically amplified and an encoder error is not")


class Eccentricity(ShaftOrder):
    """Order 1 of the gear's shaft as a kinematic error, through the run's drivetrain response ``H(1)``."""

    def unit_line(self, m, shaft, basis):
        return m.response(shaft, {1: basis * 1e-6})


class Plugin(ShaftOrderPlugin):
    spec = SPEC
    candidate = Eccentricity

    def write_config(self, draft, target, params):
        s = draft.micro_section(target)
        s["runout_um"] = 2.0 * float(params["amplitude_um"])
        # diagnosis: a cos(theta + phi); ROM runout: e sin(theta + phase)
        s["runout_phase_deg"] = float((params["phase_deg"] + 90.0 - draft.shift_deg[target]) % 360.0)


register(Plugin())
