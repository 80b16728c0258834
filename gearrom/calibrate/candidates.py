"""The candidate fit of each library effect: the registry the diagnosis draws its candidates from.

:data:`FITS` maps an effect name of :data:`gearrom.calibrate.effects.LIBRARY` to its candidate class
(:mod:`gearrom.calibrate.fit`, :mod:`~gearrom.calibrate.fit_mesh`, :mod:`~gearrom.calibrate.fit_tooth`);
an effect of kind ``"rig"`` fits as a changed rig parameter (:class:`~gearrom.calibrate.fit_mesh.RigMode`),
any other effect not listed as a flank modification (:class:`~gearrom.calibrate.fit_mesh.Micro`).
"""
from __future__ import annotations

from gearrom.calibrate.effects import LIBRARY
from gearrom.calibrate.fit import Candidate, Context, OncePerRev
from gearrom.calibrate.fit_mesh import Micro, RigMode
from gearrom.calibrate.fit_tooth import PitchError

__all__ = ["FITS", "make_candidates"]

#: candidate class per effect name, called as ``cls(name, target)``
FITS: dict[str, type[Candidate]] = {"eccentricity": OncePerRev, "encoder_eccentricity": OncePerRev,
                                    "pitch_error": PitchError}


def make_candidates(ctx: Context) -> list[Candidate]:
    """All candidates allowed by the settings and the simulator."""
    names = ctx.s.candidates or tuple(LIBRARY)
    out: list[Candidate] = []
    for name in names:
        spec = LIBRARY[name]
        if spec.kind == "rig":
            tun = ctx.sim.tunable() if hasattr(ctx.sim, "tunable") else {}
            for p in ctx.s.rig_parameters:
                if p in tun:
                    c = RigMode(p)
                    c.sim_ref = ctx.sim
                    out.append(c)
            continue
        for t in spec.targets:
            out.append(FITS.get(name, Micro)(name, t))
    return out
