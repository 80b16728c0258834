"""``torsional_mode``: a mis-tuned rig parameter and the drivetrain mode it moves.

Model: one tunable parameter of the simulator (``parameter``) scaled by ``scale``, by re-simulation; the
mesh phase is re-estimated from the re-tuned model's own GMF lines, as for the nominal model. The report
gives the mode it moves (``frequency_hz``, ``damping_ratio``, ``nominal_frequency_hz``). Config: the rig
key of the parameter (:data:`gearrom.calibrate.simulator.ROM_TUNABLE`), scaled.
"""
from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np
from scipy.optimize import minimize_scalar

from gearrom.calibrate.fit import Candidate, Context, Trial, detrend_like_data
from gearrom.calibrate.fit_mesh import explains_gmf
from gearrom.calibrate.model import realigned, shaft_rate_hz
from gearrom.calibrate.registry import EffectPlugin, EffectSpec, register
from gearrom.calibrate.simulator import ROM_TUNABLE, ModelChanges

SPEC = EffectSpec(
    "torsional_mode", ("",), "rig", {}, {},
    "response at a fixed frequency across speeds; GMF and shaft-order lines amplified near it",
    group="torsional_mode",
    separation="runs at more speeds, so that GMF harmonics and shaft orders pass the mode at different frequencies, "
               "or an impact test of the rig")

log = logging.getLogger(__name__)


class _Retuned:
    """A simulator whose rig parameters are scaled in every run (the other attributes are the wrapped one's)."""

    def __init__(self, sim, rig_scale: tuple):
        self._sim, self._rig = sim, tuple(rig_scale)

    def simulate(self, cond, changes: ModelChanges | None = None):
        ch = changes or ModelChanges()
        return self._sim.simulate(cond, dataclasses.replace(ch, rig_scale=tuple(ch.rig_scale) + self._rig))

    def table_stiffness(self, torque_out_Nm: float, rig_scale=()) -> float:
        return self._sim.table_stiffness(torque_out_Nm, tuple(rig_scale) + self._rig)

    def __getattr__(self, name):
        return getattr(self._sim, name)


#: a rig scale whose explained energy is within this share of the best's is not told apart from it (the
#: effect models' own error, as for look-alike flank modifications)
RIG_AMBIGUITY = 0.1
SCAN_STEPS = 6  # a search ladder of at most this many scales (besides 1) is evaluated at every step
PROBE_SHARE = 0.02  # share of the residual energy a rig parameter must explain at x0.8 or x1.25 to be searched
MOVED_SHARE = 0.05  # a mode whose frequency the scale changes by more than this share is reported as moved


def _linear_models(ctx: Context, param: str, scale: float) -> list:
    """The runs' models on a rig with ``param`` scaled, from the linearized drivetrain: each shaft's
    simulated response ``H(q)`` and the nominal model's GMF lines times the ratio of the re-tuned to the
    nominal linear response at their frequencies (the mesh phase kept)."""
    out = []
    for m in ctx.models:
        rig = ((param, scale),)
        H = {}
        for shaft, (orders, h) in m.H.items():
            ratio = ctx.sim.response_ratio(m.run.rpm_in, m.run.torque_out_Nm, rig, orders * shaft_rate_hz(m.run, shaft))
            H[shaft] = (orders, h * ratio)
        nominal, g3 = m.nominal, m.gmf_model3
        if g3 is not None and m.lines is not None and g3.size:
            q = np.asarray(m.lines, float)[: g3.shape[1], 0]  # GMF harmonics as input orders
            ratio = ctx.sim.response_ratio(m.run.rpm_in, m.run.torque_out_Nm, rig, q * shaft_rate_hz(m.run, "input"))
            d = g3 * (ratio - 1.0) * np.exp(1j * q * m.psi)[None, :]
            nominal = m.nominal + detrend_like_data((d @ np.exp(1j * np.outer(q, m.run.theta_in_rad))).real, axis=1)
            g3 = g3 * ratio
        out.append(dataclasses.replace(m, H=H, nominal=nominal, gmf_model3=g3))
    return out


def _refit_each(ctx: Context, trials: list, R0: np.ndarray) -> list:
    """Each effect fitted again on ``ctx`` in its order, on what the ones before it leave of ``R0``; an
    effect that cannot be refitted keeps its fit."""
    refit = []
    for t in trials:
        R = R0 - sum((ctx.stack(u.contrib) for u in refit), np.zeros_like(R0))
        try:
            u = t.cand.fit(ctx, R)
        except Exception as exc:  # noqa: BLE001
            log.warning("%r could not be refitted on the re-tuned rig: %s", t.cand, exc)
            u = None
        refit.append(u if u is not None else t)
    return refit


class RigMode(Candidate):
    """One rig parameter scaled, by re-simulation (one per diagnosis; dropped once it explains nothing)."""

    exclusive = True
    expensive = True

    def __init__(self, param: str, interacts: bool = False, linear: bool = False):
        super().__init__("torsional_mode", "")
        self.param = param
        self.interacts = interacts
        self.linear = linear

    def __repr__(self):
        return f"torsional_mode[{self.param}]"

    def _contrib(self, ctx: Context, scale: float) -> tuple[list, list, list | None]:
        """Per run: the change the scaled rig brings, the mesh phases, and (interacting parameter) the
        accepted effects refitted on the re-tuned rig (:meth:`_profile`). The change alone is realigned:
        the mesh phase re-estimated from the re-tuned model's own GMF lines."""
        if self.interacts and any(not isinstance(t.cand, RigMode) for t in ctx.accepted):
            return self._profile(ctx, scale)
        if self.linear:  # the change of the nominal model's GMF lines through the linearized drivetrain
            models = self._retuned_models(ctx, scale)
            return [ms.nominal - m.nominal for m, ms in zip(ctx.models, models)], [m.psi for m in ctx.models], None
        out, psis = [], []
        for m in ctx.models:
            mapped, psi = realigned(m, ctx.sim.simulate(m.cond, ModelChanges(rig_scale=((self.param, scale),))))
            out.append(mapped - m.nominal)
            psis.append(psi)
        return out, psis, None

    def _profile(self, ctx: Context, scale: float) -> tuple[list, list, list]:
        """The re-tuned rig with the accepted effects fitted again on it.

        A re-tuned support changes how a kinematic error (runout, a displaced tooth) reaches the
        encoders, and the accepted effects' sizes and positions were fitted on the nominal rig. Each
        run's model is rebuilt on the re-tuned rig (nominal run, mesh phase, drivetrain sensitivities;
        cached per scale), the accepted effects are fitted again in their order and jointly, and the
        change is that model minus the nominal one and the accepted effects' contributions. Returns the
        per-run change, the re-tuned models' mesh phases and the refitted effects (which replace the
        accepted ones when the parameter is accepted).
        """
        from gearrom.calibrate.fit import Context
        from gearrom.calibrate.select import joint_refit, linear_refit

        acc = [t for t in ctx.accepted if not isinstance(t.cand, RigMode)]
        sim = _Retuned(ctx.sim, ((self.param, scale),))
        models = self._retuned_models(ctx, scale)
        cs = Context(models, sim, ctx.s, ctx.pair, ctx.micro_model, ctx.micro_nominal)
        R0 = cs.stack([m.run.y - m.nominal for m in models])
        if self.linear:
            # the kinematic errors (fitted in the order domain through each run's H) are refitted, position
            # and size, on the re-tuned responses, then sized jointly; the others keep their fit
            lin = [t for t in acc if hasattr(t.cand, "linear_columns")]
            R = R0 - sum((cs.stack(t.contrib) for t in acc if t not in lin), np.zeros_like(R0))
            new = dict(zip(map(id, lin), linear_refit(cs, _refit_each(cs, lin, R), R))) if lin else {}
            return self._change(ctx, models, acc, [new.get(id(t), t) for t in acc])
        return self._change(ctx, models, acc, joint_refit(cs, _refit_each(cs, acc, R0), R0))

    def _retuned_models(self, ctx: Context, scale: float) -> list:
        """The runs' models on the re-tuned rig (cached per scale): from the linearized drivetrain for a
        linear parameter, else rebuilt by simulation (nominal run, mesh phase, sensitivities)."""
        from gearrom.calibrate.model import build_run_model

        key = ("retuned_models", self.param, round(scale, 6))
        if key not in ctx._ste:
            sim = _Retuned(ctx.sim, ((self.param, scale),))
            ctx._ste[key] = (_linear_models(ctx, self.param, scale) if self.linear else
                             [build_run_model(sim, m.run, psi_default=m.psi) for m in ctx.models])
        return ctx._ste[key]

    @staticmethod
    def _change(ctx, models, acc, refit) -> tuple[list, list, list]:
        """Per run: the re-tuned model with the refitted effects minus the nominal one with the accepted
        effects; the re-tuned models' mesh phases; the refitted effects."""
        out = []
        for r, (m, ms) in enumerate(zip(ctx.models, models)):
            total = ms.nominal - m.nominal + sum(u.contrib[r] for u in refit)
            out.append(total - sum(t.contrib[r] for t in acc))
        return out, [ms.psi for ms in models], refit

    def fit(self, ctx, R, x0: float | None = None):
        """Bounded search of the scale in log space on the simulator's ladder for this parameter (default
        x1.25 steps over 0.4..2.5). A fine ladder is screened by two probes (one step down and up), then
        walked towards the better probe; a short, wide ladder is scored whole. Either way the search then
        refines between the neighbours of the best step. ``x0``: refine around a previous estimate only
        (joint refit)."""
        lo_s, hi_s, ratio = (ctx.sim.search_range(self.param) if hasattr(ctx.sim, "search_range")
                             else (0.4, 2.5, 1.25))
        cache = {}

        def dss(logs):
            s = round(math.exp(logs), 6)
            if s not in cache:
                c, psis, refit = self._contrib(ctx, s)
                v = ctx.stack(c)
                cache[s] = (float(2 * v @ R - v @ v), c, psis, refit)
            return cache[s][0]

        step = math.log(ratio)
        ladder = [k * step for k in range(math.ceil(math.log(lo_s) / step - 1e-9),
                                          math.floor(math.log(hi_s) / step + 1e-9) + 1) if k]
        wide = len(ladder) <= SCAN_STEPS
        if x0 is not None:
            g0 = math.log(x0)
            lo, hi = g0 - step, g0 + step
        else:
            # a wide ladder is scored whole (its response need not grow monotonically from 1), a fine one
            # is screened by its first step either side
            probes = {g: dss(g) for g in (ladder if wide else (-step, step))}
            if max(probes.values()) < PROBE_SHARE * float(R @ R):
                s = round(math.exp(max(probes, key=probes.get)), 6)
                return Trial(self, np.array([s]), cache[s][1], max(probes.values()), 1,
                             {"parameter": self.param, "psi_runs": cache[s][2], "refit": cache[s][3],
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
        # the scales the data do not tell apart from the best: within RIG_AMBIGUITY of its explained energy
        # (the whole search only: a refit around x0 sees a bracket and keeps the selection's range)
        info = {"parameter": self.param, "psi_runs": cache[s][2], "refit": cache[s][3]}
        if x0 is None:
            near = [k for k, v in cache.items() if v[0] >= (1 - RIG_AMBIGUITY) * cache[s][0]] if cache[s][0] > 0 else [s]
            info.update(scale_range=(min(near), max(near)), search_range=(lo_s, hi_s))
        return Trial(self, np.array([s]), cache[s][1], cache[s][0], 1, info)

    def refit(self, ctx, R, previous):
        return self.fit(ctx, R, x0=float(previous.x[0]))

    def report(self, x, info):
        s = float(x[0])
        out = {"parameter": self.param, "scale": s}
        if "scale_range" in info:
            lo, hi = info["scale_range"]
            out["scale_range"] = [float(lo), float(hi)]
            lo_s, hi_s = info.get("search_range", (0.0, math.inf))
            if hi >= hi_s * (1 - 1e-6) and lo > 1:
                out["scale_is_lower_bound"] = True   # as good up to the end of the search: stiffer than lo
            if lo <= lo_s * (1 + 1e-6) and hi < 1:
                out["scale_is_upper_bound"] = True
        modes0 = getattr(self.sim_ref, "modes_hz", lambda *_: [])() if hasattr(self, "sim_ref") else []
        modes1 = self.sim_ref.modes_hz(((self.param, s),)) if modes0 else []
        if modes0 and modes1 and len(modes0) == len(modes1):
            change = [abs(b[0] / a[0] - 1) for a, b in zip(modes0, modes1)]
            j = int(np.argmax(change))
            out.update(frequency_hz=modes1[j][0], damping_ratio=modes1[j][1], nominal_frequency_hz=modes0[j][0])
            # every mode the scale moves by more than MOVED_SHARE: [nominal Hz, re-tuned Hz, re-tuned damping ratio]
            out["moved_modes"] = [[a[0], b[0], b[1]] for a, b, c in zip(modes0, modes1, change) if c > MOVED_SHARE]
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
                c = RigMode(p, interacts=bool(getattr(ctx.sim, "interacts", lambda _: False)(p)),
                            linear=bool(getattr(ctx.sim, "linear_interaction", lambda _: False)(p)))
                c.sim_ref = ctx.sim
                out.append(c)
        return out

    def evidence(self, ctx, trial, D):
        rep = trial.cand.report(trial.x, trial.info)
        txt = f"; the residual follows a re-tuned rig ({trial.info.get('parameter')} x{rep['scale']:.3g}"
        if rep.get("scale_is_lower_bound"):
            txt += f"; at least x{rep['scale_range'][0]:.3g}: larger scales fit as well"
        elif rep.get("scale_is_upper_bound"):
            txt += f"; at most x{rep['scale_range'][1]:.3g}: smaller scales fit as well"
        txt += ")"
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
