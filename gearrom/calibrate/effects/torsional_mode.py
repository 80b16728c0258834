"""``torsional_mode``: a mis-tuned rig parameter and the drivetrain mode it moves.

Model: one tunable parameter of the simulator (``parameter``) scaled by ``scale``, by re-simulation; the
mesh phase is re-estimated from the re-tuned model's own GMF lines, as for the nominal model. The report
gives the mode it moves (``frequency_hz``, ``damping_ratio``, ``nominal_frequency_hz``). Config: the rig
key of the parameter (:data:`gearrom.calibrate.simulator.ROM_TUNABLE`), scaled.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize_scalar

from gearrom.calibrate.fit import Candidate, Context, Trial
from gearrom.calibrate.fit_mesh import explains_gmf
from gearrom.calibrate.model import realigned
from gearrom.calibrate.registry import EffectPlugin, EffectSpec, register
from gearrom.calibrate.simulator import ROM_TUNABLE, ModelChanges

SPEC = EffectSpec(
    "torsional_mode", ("",), "rig", {}, {},
    "response at a fixed frequency across speeds; GMF and shaft-order lines amplified near it",
    group="torsional_mode",
    separation="runs at more speeds, so that GMF harmonics and shaft orders pass the mode at different frequencies, "
               "or an impact test of the rig")

PROBE_SHARE = 0.02  # share of the residual energy a rig parameter must explain at x0.8 or x1.25 to be searched


class RigMode(Candidate):
    """One rig parameter scaled, by re-simulation (one per diagnosis; dropped once it explains nothing)."""

    exclusive = True
    expensive = True

    def __init__(self, param: str):
        super().__init__("torsional_mode", "")
        self.param = param

    def __repr__(self):
        return f"torsional_mode[{self.param}]"

    def _contrib(self, ctx: Context, scale: float) -> tuple[list, list]:
        out, psis = [], []
        for m in ctx.models:
            h = ctx.sim.simulate(m.cond, ModelChanges(rig_scale=((self.param, scale),)))
            mapped, psi = realigned(m, h)
            out.append(mapped - m.nominal)
            psis.append(psi)
        return out, psis

    def fit(self, ctx, R, x0: float | None = None):
        """Bounded search of the scale in log space: two probes (x0.8, x1.25) screen the parameter, then the
        search walks towards the better probe on a x1.25 ladder (0.4..2.5) and refines between the
        neighbours of the best step. ``x0``: refine around a previous estimate only (joint refit)."""
        cache = {}

        def dss(logs):
            s = round(math.exp(logs), 6)
            if s not in cache:
                c, psis = self._contrib(ctx, s)
                v = ctx.stack(c)
                cache[s] = (float(2 * v @ R - v @ v), c, psis)
            return cache[s][0]

        step = math.log(1.25)
        if x0 is not None:
            g0 = math.log(x0)
            lo, hi = g0 - step, g0 + step
        else:
            probes = {math.log(0.8): dss(math.log(0.8)), math.log(1.25): dss(math.log(1.25))}
            if max(probes.values()) < PROBE_SHARE * float(R @ R):
                s = round(0.8 if probes[math.log(0.8)] >= probes[math.log(1.25)] else 1.25, 6)
                return Trial(self, np.array([s]), cache[s][1], max(probes.values()), 1,
                             {"parameter": self.param, "psi_runs": cache[s][2], "screened": True})
            best = max(probes, key=probes.get)
            direction = -1.0 if best < 0 else 1.0
            g = best
            while abs(g + direction * step) <= math.log(2.5) + 1e-9 and dss(g + direction * step) > dss(g):
                g += direction * step
            lo, hi = g - step, g + step
            if lo < 0 < hi and direction > 0:  # the ladder jumps over 1 (0.8 -> 1.25): search from 0.8
                lo = math.log(0.8)
            if lo < 0 < hi and direction < 0:
                hi = math.log(1.25)
        r = minimize_scalar(lambda q: -dss(q), bounds=(lo, hi), method="bounded", options={"xatol": 0.004, "maxiter": 8})
        s = max(cache, key=lambda k: cache[k][0])
        if -r.fun > cache[s][0]:
            s = round(math.exp(float(r.x)), 6)
        return Trial(self, np.array([s]), cache[s][1], cache[s][0], 1, {"parameter": self.param, "psi_runs": cache[s][2]})

    def refit(self, ctx, R, previous):
        return self.fit(ctx, R, x0=float(previous.x[0]))

    def report(self, x, info):
        s = float(x[0])
        out = {"parameter": self.param, "scale": s}
        modes0 = getattr(self.sim_ref, "modes_hz", lambda *_: [])() if hasattr(self, "sim_ref") else []
        modes1 = self.sim_ref.modes_hz(((self.param, s),)) if modes0 else []
        if modes0 and modes1 and len(modes0) == len(modes1):
            j = int(np.argmax([abs(b[0] / a[0] - 1) for a, b in zip(modes0, modes1)]))
            out.update(frequency_hz=modes1[j][0], damping_ratio=modes1[j][1], nominal_frequency_hz=modes0[j][0])
        return out

    def changes(self, x, info, ctx, run: int = 0):
        return {"rig_scale": ((self.param, float(x[0])),)}

class Plugin(EffectPlugin):
    spec = SPEC
    candidate = RigMode
    not_evaluated = "the simulator exposes no tunable rig parameters"

    def candidates(self, ctx) -> list:
        """One candidate per tunable parameter the settings name and the simulator can scale."""
        tun = ctx.sim.tunable() if hasattr(ctx.sim, "tunable") else {}
        out = []
        for p in ctx.s.rig_parameters:
            if p in tun:
                c = RigMode(p)
                c.sim_ref = ctx.sim
                out.append(c)
        return out

    def evidence(self, ctx, trial, D):
        rep = trial.cand.report(trial.x, trial.info)
        txt = f"; the residual follows a re-tuned rig ({trial.info.get('parameter')} x{rep['scale']:.3g})"
        if "frequency_hz" in rep:
            txt += (f", which moves a mode from {rep['nominal_frequency_hz']:.0f} to {rep['frequency_hz']:.0f} Hz "
                    "and changes the response of the lines near it")
        return txt

    def explains_line(self, target, label):
        return explains_gmf(label)

    def write_config(self, draft, target, params):
        param, scale = params.get("parameter"), float(params["scale"])
        path = ROM_TUNABLE.get(param, (None,))[0]
        if path is None:
            draft.notes.append(f"torsional_mode: {param} x{scale:.4g} has no config key; not written")
            return
        *heads, leaf = path.split(".")
        node, src = draft.doc, draft.raw
        for h in heads:
            node = node.setdefault(h, {})
            src = src.get(h, {})
        if leaf not in src:
            draft.notes.append(f"torsional_mode: {path} is not in the config; not written")
            return
        node[leaf] = float(src[leaf]) * scale


register(Plugin())
