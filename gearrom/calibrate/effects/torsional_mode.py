"""``torsional_mode``: a mis-tuned rig parameter and the drivetrain mode it moves.

Model: one tunable parameter of the simulator (``parameter``) scaled by ``scale``, by re-simulation; the
mesh phase is re-estimated from the re-tuned model's own GMF lines, as for the nominal model. The report
gives the mode it moves (``frequency_hz``, ``damping_ratio``, ``nominal_frequency_hz``). Config: the rig
key of the parameter (:data:`gearrom.calibrate.simulator.ROM_TUNABLE`), scaled.
"""
from __future__ import annotations

import hashlib
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

SCAN_STEPS = 6  # a search ladder of at most this many scales (besides 1) is evaluated at every step
PROBE_SHARE = 0.02  # share of the residual energy a rig parameter must explain at x0.8 or x1.25 to be searched


class RigMode(Candidate):
    """One rig parameter scaled, by re-simulation (one per diagnosis; dropped once it explains nothing)."""

    exclusive = True
    expensive = True

    def __init__(self, param: str, interacts: bool = False):
        super().__init__("torsional_mode", "")
        self.param = param
        self.interacts = interacts

    def __repr__(self):
        return f"torsional_mode[{self.param}]"

    def _contrib(self, ctx: Context, scale: float) -> tuple[list, list, list]:
        """Per run: the change the scaled rig brings (alone, plus its interaction with the accepted
        effects), the mesh phase, and the change alone. The change alone is realigned (mesh phase
        re-estimated from the re-tuned model's own GMF lines); an interacting parameter keeps the
        nominal phase, so that its change alone and its interaction share one simulation."""
        out, psis, alone = [], [], []
        inter = self._interaction(ctx, scale)
        for r, m in enumerate(ctx.models):
            if self.interacts:
                mapped, psi = self._rig_base(ctx, r, scale), m.psi
            else:
                mapped, psi = realigned(m, ctx.sim.simulate(m.cond, ModelChanges(rig_scale=((self.param, scale),))))
            alone.append(mapped - m.nominal)
            out.append(alone[-1] + (inter[r] if inter is not None else 0.0))
            psis.append(psi)
        return out, psis, alone

    def _rig_base(self, ctx: Context, r: int, scale: float) -> np.ndarray:
        """Run ``r`` of the re-tuned rig at the nominal mesh phase, mapped onto the run (cached)."""
        from gearrom.calibrate.residual import map_to_run

        key = ("rig_base", r, self.param, round(scale, 6))
        if key not in ctx._ste:
            m = ctx.models[r]
            ch = ModelChanges(mesh_phase_rad=m.psi, rig_scale=((self.param, scale),))
            ctx._ste[key] = map_to_run(ctx.sim.simulate(m.cond, ch), m.run)
        return ctx._ste[key]

    def response_change(self, ctx: Context, scale: float, kinematic: list) -> list:
        """Per run, the response to kinematic errors ``kinematic[r]`` (dict of ``kinematic_in`` /
        ``kinematic_out`` tables, or None) with the rig scaled, minus the nominal rig's response."""
        from gearrom.calibrate.residual import map_to_run

        rig = ((self.param, scale),)
        out = []
        for r, m in enumerate(ctx.models):
            kin = kinematic[r]
            if not kin or all(v is None or not np.any(v) for v in kin.values()):
                out.append(np.zeros_like(m.nominal))
                continue
            at_s = map_to_run(ctx.sim.simulate(m.cond, ModelChanges(mesh_phase_rad=m.psi, rig_scale=rig, **kin)), m.run)
            key = ("kinematic_nominal", r, hashlib.sha1(b"".join(
                k.encode() + np.ascontiguousarray(v).tobytes() for k, v in sorted(kin.items()))).hexdigest())
            if key not in ctx._ste:   # the nominal rig's response to these errors, the same at every scale
                ctx._ste[key] = map_to_run(ctx.sim.simulate(m.cond, ModelChanges(mesh_phase_rad=m.psi, **kin)), m.run)
            out.append((at_s - self._rig_base(ctx, r, scale)) - (ctx._ste[key] - m.nominal))
        return out

    def _interaction(self, ctx: Context, scale: float) -> list | None:
        """Per run, the change of the response to the accepted effects' kinematic errors (runout, pitch
        deviations) that the scaled rig brings: those effects' contributions are the nominal rig's
        response, and a rig that passes a kinematic error differently (a stiffer support of a helical
        mesh) changes them. None when no accepted effect has a kinematic error."""
        from gearrom.calibrate.select import verification_changes

        acc = [t for t in ctx.accepted if not isinstance(t.cand, RigMode)]
        if not acc or not self.interacts:
            return None
        kin = []
        for r in range(len(ctx.models)):
            ch = verification_changes(ctx, acc, r)[0]["changes"]
            kin.append({k: ch[k] for k in ("kinematic_in", "kinematic_out") if ch[k] is not None} or None)
        if not any(kin):
            return None
        return self.response_change(ctx, scale, kin)

    def moved_columns(self, ctx: Context, trial, blocks: list) -> list:
        """Per linear column of the accepted effects (``blocks``: (trial, columns) pairs), the change the
        fitted rig scale brings to it (per-run list): the joint refit solves the linear sizes with the
        columns of the re-tuned rig. A column's kinematic table is its effect's table for that component
        alone (the fitted size, or 1 when it is zero) per unit."""
        scale = float(trial.x[0])
        out = []
        for t, cols in blocks:
            for j in range(len(cols)):
                xj = np.zeros_like(np.asarray(t.x, float))
                xj[j] = t.x[j] if t.x[j] != 0 else 1.0
                kin = []
                for r in range(len(ctx.models)):
                    ch = t.cand.changes(xj, t.info, ctx, r)
                    kin.append({k: v / xj[j] for k, v in ch.items() if k in ("kinematic_in", "kinematic_out")
                                and v is not None} or None)
                out.append(self.response_change(ctx, scale, kin))
        return out

    def fit(self, ctx, R, x0: float | None = None):
        """Bounded search of the scale in log space: two probes (one ladder step down and up) screen the
        parameter, then the search walks towards the better probe on the simulator's ladder for this
        parameter (default x1.25 steps over 0.4..2.5) and refines between the neighbours of the best step.
        ``x0``: refine around a previous estimate only (joint refit)."""
        lo_s, hi_s, ratio = (ctx.sim.search_range(self.param) if hasattr(ctx.sim, "search_range")
                             else (0.4, 2.5, 1.25))
        cache = {}

        def dss(logs):
            s = round(math.exp(logs), 6)
            if s not in cache:
                c, psis, alone = self._contrib(ctx, s)
                v = ctx.stack(c)
                cache[s] = (float(2 * v @ R - v @ v), c, psis, alone)
            return cache[s][0]

        step = math.log(ratio)
        down, up = round(1.0 / ratio, 6), round(ratio, 6)
        ladder = [k * step for k in range(math.ceil(math.log(lo_s) / step - 1e-9),
                                          math.floor(math.log(hi_s) / step + 1e-9) + 1) if k]
        wide = len(ladder) <= SCAN_STEPS
        if x0 is not None:
            g0 = math.log(x0)
            lo, hi = g0 - step, g0 + step
        else:
            probes = {-step: dss(-step), step: dss(step)}
            if max(probes.values()) < PROBE_SHARE * float(R @ R):
                s = down if probes[-step] >= probes[step] else up
                return Trial(self, np.array([s]), cache[s][1], max(probes.values()), 1,
                             {"parameter": self.param, "psi_runs": cache[s][2], "alone": cache[s][3],
                              "screened": True})
            best = max(probes, key=probes.get)
            direction = -1.0 if best < 0 else 1.0
            g = best
            if wide:  # a short, wide ladder is scanned whole: it can hold two optima
                g = max(ladder, key=dss)
                direction = -1.0 if g < 0 else 1.0
            else:
                while (math.log(lo_s) - 1e-9 <= g + direction * step <= math.log(hi_s) + 1e-9
                       and dss(g + direction * step) > dss(g)):
                    g += direction * step
            lo, hi = g - step, g + step
            if lo < 0 < hi and direction > 0:  # the ladder jumps over 1 (1/ratio -> ratio): search from 1/ratio
                lo = -step
            if lo < 0 < hi and direction < 0:
                hi = step
        lo, hi = max(lo, math.log(lo_s)), min(hi, math.log(hi_s))
        # a wide ladder's scale is refined to a few % (its uncertainty is larger), a fine one's to 0.4 %
        opts = {"xatol": 0.02, "maxiter": 5} if wide else {"xatol": 0.004 * step / math.log(1.25), "maxiter": 8}
        r = minimize_scalar(lambda q: -dss(q), bounds=(lo, hi), method="bounded", options=opts)
        s = max(cache, key=lambda k: cache[k][0])
        if -r.fun > cache[s][0]:
            s = round(math.exp(float(r.x)), 6)
        return Trial(self, np.array([s]), cache[s][1], cache[s][0], 1,
                     {"parameter": self.param, "psi_runs": cache[s][2], "alone": cache[s][3]})

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
                c = RigMode(p, interacts=bool(getattr(ctx.sim, "interacts", lambda _: False)(p)))
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
        keys = ROM_TUNABLE[param].keys if param in ROM_TUNABLE else ()
        if not keys:
            draft.notes.append(f"torsional_mode: {param} x{scale:.4g} has no config key; not written")
            return
        for path in keys:
            *heads, leaf = path.split(".")
            node, src = draft.doc, draft.raw
            for h in heads:
                node = node.setdefault(h, {})
                src = src.get(h, {})
            if leaf not in src:
                draft.notes.append(f"torsional_mode: {path} is not in the config; not written")
                continue
            node[leaf] = float(src[leaf]) * scale


register(Plugin())
