"""``pitch_error``: one displaced tooth of a gear, fitted on the pulse train it leaves.

Model: the tooth stands ``deviation_um`` proud of its nominal position (single pitch deviations +f and
-f on its two flanks' pitches; cumulative deviation f at that tooth). While it is in mesh it changes the
TE as the static equilibrium of all pairs in contact gives (about ``deviation_um`` times its load share
when small, saturating when the tooth leaves contact). ``tooth_index`` counts teeth from the gear angle
0 of the record. Drawing (seed annex 11): f_p = 5 um, F_p = 16 um. Config:
``<gear>.microgeometry.pitch_deviations_um``.

The kinematic error pattern is the static TE change of :func:`gearrom.excitation.slices.tooth_te`
(the tooth followed through its whole engagement, load shared with the other pairs, slice
stiffness scaled to the mean stiffness of the simulator's own mesh table, the ROM's FE table when the
diagnosis runs on the ROM: the ROM models the pitch deviations of a written config the same way). It passes through the run's drivetrain response ``H(q)`` at every
order of its shaft the sensitivity holds (6 GMF harmonics of the input, 2 z of the output), so
the prediction is the time-domain pulse train at the shaft period, not a few order lines.

Fit: the position of the tooth (``N_SUB`` trial positions per pitch: the tooth index and the
mesh phase together, so that an unidentifiable mesh phase costs nothing) is found by correlating
the residual with the whole pulse of a small deviation, computed in the order domain. The deviation
is then fitted by a bounded scalar search on the non-linear pattern (a tooth set back leaves
contact, one set forward takes the load of its neighbours), on the shaft orders below
``z / (2 eps_gamma)`` (at least 3): there the pulse is set by its area (deviation x one pitch in
the linear range), whatever model of load sharing made it, while its shape at higher orders
depends on that model. The prediction and the energy it explains use the whole pulse. Runs recorded
from different angle zeros (``FitSettings.shared_shaft_phase`` False) get a position each; the
deviation is common.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize_scalar

import gearrom.calibrate.characterize as chz
from gearrom.calibrate.fit import (Candidate, Context, Trial, detrend_like_data, shaft_angle, shaft_of,
                                   size_uncertainty)
from gearrom.calibrate.model import N_TABLE
from gearrom.calibrate.registry import GEARS, EffectPlugin, EffectSpec, register
from gearrom.errors import GearromError
from gearrom.excitation.slices import periodic_sample, stiffness_scale, tooth_te

UM = 1e-6
N_SUB = 8  # trial tooth positions per pitch
#: pulse area per unit deviation (1 in the linear range) below which the fitted size is a lower bound
LOWER_BOUND_SLOPE = 0.25

SPEC = EffectSpec(
    "pitch_error", GEARS, "kinematic", {g: 16.0 for g in GEARS}, {g: 150.0 for g in GEARS},
    "impulsive once-per-revolution content of one gear: a broad comb of that shaft's orders",
    size_key="deviation_um", group="pitch_error",
    separation="a longer record (a whole hunting-tooth period) separates the two gears' revolution patterns")


class PitchError(Candidate):
    """One displaced tooth of a gear: position (tooth index and sub-pitch phase) and deviation fitted."""

    def __init__(self, name: str, target: str):
        super().__init__(name, target)
        self._patterns: dict = {}
        self._scales: dict = {}
        self._bases: dict = {}

    # ------------------------------------------------------------------ model
    def _gear(self) -> int:
        return 0 if self.target == "input_gear" else 1

    def _scale(self, ctx: Context, torque: float) -> float:
        """Factor on the slice stiffness: to the simulator's own mesh table where it has one (the ROM
        scales the slices of its pitch deviations to that table, so that a written config reproduces
        the fitted pulse), else to the micro-geometry model's table."""
        key = (id(ctx.sim), round(torque, 6))
        if key not in self._scales:
            try:
                if hasattr(ctx.sim, "table_stiffness"):
                    k_ref = ctx.sim.table_stiffness(torque)
                else:
                    k_ref = float(np.mean(ctx.micro_model.excitation(ctx.pair, [torque], ctx.micro_nominal).k[0]))
                self._scales[key] = stiffness_scale(ctx.pair, torque, k_ref, ctx.micro_nominal)
            except (GearromError, AttributeError):
                self._scales[key] = 1.0
        return self._scales[key]

    def pattern(self, ctx: Context, torque: float, deviation_um: float) -> np.ndarray:
        """Static TE change (m) over one revolution of the gear, tooth 0 displaced by ``deviation_um``."""
        scale = self._scale(ctx, torque)
        key = (round(torque, 6), round(deviation_um, 4), round(scale, 9))
        if key not in self._patterns:
            self._patterns[key] = tooth_te(ctx.pair, torque, self._gear(), deviation_um * UM, ctx.micro_nominal,
                                           stiffness_scale=scale)
        return self._patterns[key]

    def _basis(self, r: int, m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Orders, response ``H`` (3, Q) and ``exp(i q theta)`` (n, Q) of run ``r`` of model ``m`` (the
        response is the model's own: a re-tuned rig's models of the same run have theirs; the order basis
        is cached per run)."""
        orders, H = m.H[shaft_of(self.target)]
        key = (r, id(m.run))
        if key not in self._bases:
            self._bases[key] = (m.run, np.exp(1j * np.outer(shaft_angle(m, shaft_of(self.target)), orders)))
        return orders, H, self._bases[key][1]

    def _coeffs(self, r: int, m, pat: np.ndarray) -> np.ndarray:
        """``G`` (3, Q): the signals' complex order amplitudes for the pattern at position 0."""
        orders, H, _ = self._basis(r, m)
        E = 2 * np.fft.rfft(pat) / pat.size
        return H * E[orders][None, :]

    def _predict(self, r: int, m, G: np.ndarray, shift: float) -> np.ndarray:
        orders, _, B = self._basis(r, m)
        return detrend_like_data((B @ (G * np.exp(-1j * orders * shift)[None, :]).T).real.T, axis=1)

    # ------------------------------------------------------------------ fit
    def fit(self, ctx, R):
        z = ctx.pair.z[self._gear()]
        shifts = np.arange(z * N_SUB) * 2 * math.pi / (z * N_SUB)
        pieces, start = [], 0
        for m in ctx.models:  # the stacked residual, back to (3, n) per run (weights kept)
            n = m.run.t_s.size
            pieces.append(R[start:start + 3 * n].reshape(3, n))
            start += 3 * n
        num, den = [], []
        for r, m in enumerate(ctx.models):
            G = self._coeffs(r, m, self.pattern(ctx, m.run.torque_out_Nm, 1.0))
            orders, _, B = self._basis(r, m)
            rho = pieces[r] @ B  # (3, Q)
            c = ((ctx.w[:, None] * G * rho).sum(axis=0))
            num.append((c[None, :] * np.exp(-1j * np.outer(shifts, orders))).real.sum(axis=1))
            p0 = self._predict(r, m, G, 0.0)
            den.append(float(np.sum((ctx.w[:, None] * p0) ** 2)))
        num, den = np.array(num), np.array(den)
        if ctx.s.shared_shaft_phase:
            tot = num.sum(axis=0)
            j = int(np.argmax(np.abs(tot)))
            idx, sign = [j] * len(ctx.models), math.copysign(1.0, tot[j])
        else:  # each run its own position; the sign (and the deviation) common
            best = []
            for sgn in (1.0, -1.0):
                jj = np.argmax(sgn * num, axis=1)
                g = sum(sgn * num[r, j] for r, j in enumerate(jj))
                best.append((g * g / den.sum(), list(map(int, jj)), sgn))
            _, idx, sign = max(best, key=lambda b: b[0])
        d_lin = float(sum(num[r, j] for r, j in enumerate(idx)) / den.sum())
        if not np.isfinite(d_lin) or d_lin == 0.0:
            return None
        pos = [float(shifts[j]) for j in idx]

        q_low = max(3, int(z / (2.0 * ctx.pair.eps_gamma)))

        def contributions(d: float, low: bool = False) -> list[np.ndarray]:
            out = []
            for r, m in enumerate(ctx.models):
                G = self._coeffs(r, m, self.pattern(ctx, m.run.torque_out_Nm, d))
                if low:
                    G = G * (self._basis(r, m)[0] <= q_low)[None, :]
                out.append(self._predict(r, m, G, pos[r]))
            return out

        def cost(d: float) -> float:
            e = R - ctx.stack(contributions(d, low=True))
            return float(e @ e)

        lo, hi = sorted((sign * min(abs(d_lin) / 4, self.bound), sign * min(abs(d_lin) * 4, self.bound)))
        d = float(minimize_scalar(cost, bounds=(lo, hi), method="bounded", options={"xatol": 0.01}).x)
        contrib = contributions(d)
        rest = R - ctx.stack(contrib)
        dss = float(R @ R - rest @ rest)
        eps = max(0.01 * abs(d), 0.05)
        col = (ctx.stack(contributions(d + eps)) - ctx.stack(contributions(d - eps))) / (2 * eps)
        # a tooth set back by more than the static deflection leaves contact: the pulse stops growing with the
        # deviation, which the data then bound from below only
        t0 = ctx.models[0].run.torque_out_Nm
        n_t = self.pattern(ctx, t0, d).size / z
        slope = (self.pattern(ctx, t0, d + eps).sum() - self.pattern(ctx, t0, d - eps).sum()) / (2 * eps * UM * n_t)
        pitch = 2 * math.pi / z
        tooth = [int(round(p / pitch)) % z for p in pos]
        info = {"fitted_deviation_um": d, "tooth_index": tooth[0], "tooth_index_per_run": tooth, "position_rad": pos, "z": z,
                "sigma_size_um": size_uncertainty(ctx, rest, col), "linear_deviation_um": d_lin,
                "lower_bound": bool(abs(slope) < LOWER_BOUND_SLOPE)}
        n_par = 2 if ctx.s.shared_shaft_phase else 1 + len(ctx.models)
        return Trial(self, np.array([d]), contrib, dss, n_par, info)

    def linear_columns(self, ctx, info) -> tuple[list, np.ndarray, np.ndarray]:
        """The secant column of the fitted deviation (per-run list) and bounds for a joint linear refit."""
        d = info.get("fitted_deviation_um")
        cols = [self._predict(r, m, self._coeffs(r, m, self.pattern(ctx, m.run.torque_out_Nm, d)),
                              info["position_rad"][r]) / d for r, m in enumerate(ctx.models)]
        return [cols], np.array([-self.bound]), np.array([self.bound])

    def report(self, x, info):
        out = {"tooth_index": int(info["tooth_index"]), "deviation_um": float(x[0]),
               "tooth_position_pitch": _mean_position(info["position_rad"], info["z"])}
        if info.get("lower_bound"):
            out["deviation_is_lower_bound"] = True  # the tooth leaves contact: any larger setback fits as well
        if len(set(info["tooth_index_per_run"])) > 1:
            out["tooth_index_per_run"] = info["tooth_index_per_run"]
        return out

    def changes(self, x, info, ctx, run: int = 0):
        m = ctx.models[run]
        pat = self.pattern(ctx, m.run.torque_out_Nm, float(x[0]))
        th = np.arange(N_TABLE) * 2 * math.pi / N_TABLE
        tab = periodic_sample(pat, th, info["position_rad"][run])
        return {"kinematic_in" if shaft_of(self.target) == "input" else "kinematic_out": tab - tab.mean()}


def _mean_position(position_rad, z: int) -> float:
    """The fitted tooth position in pitches from the record's angle zero (tooth index and the sub-pitch
    offset between the encoder zero and the teeth): the runs' mean where they agree within a pitch (runs
    from a common index differ only by the drivetrain's lag), else the first run's."""
    p = np.asarray(position_rad, float) * z / (2 * math.pi)
    d = (p - p[0] + z / 2) % z - z / 2
    return float(p[0] + d.mean()) if np.ptp(d) <= 1.0 else float(p[0])


class Plugin(EffectPlugin):
    spec = SPEC
    candidate = PitchError

    def evidence(self, ctx, trial, D):
        shaft = trial.cand.target.split("_")[0]
        crest = chz.impulsiveness(ctx.models[0].run, D[0][0]).get(shaft)
        txt = f"; impulsive once-per-rev pattern of the {shaft} gear (comb of its shaft orders"
        return txt + (f", crest factor of the per-revolution average {crest:.2g})" if crest else ")")

    def report_extra(self, params, info):
        k, z = params["tooth_index"], info["z"]
        return {"single_pitch_deviations_um": {str(k): params["deviation_um"], str((k + 1) % z): -params["deviation_um"]},
                "cumulative_pitch_deviation_um": abs(params["deviation_um"])}

    def explains_line(self, target, label):
        return label.startswith(target.split("_")[0])

    def write_config(self, draft, target, params):
        gi = GEARS.index(target)
        z = draft.pair.z[gi]
        # the ROM follows tooth k from its entry at gear angle 2 pi k / z, as the diagnosis' tooth model
        k = int(round(params.get("tooth_position_pitch", params["tooth_index"]) + draft.shift_deg[target] * z / 360.0)) % z
        a = -float(params["deviation_um"]) if gi == 0 else float(params["deviation_um"])  # TE sign of the ROM
        s = draft.micro_section(target)
        fp = list(map(float, s.get("pitch_deviations_um", [0.0] * z)))
        fp[k] += a
        fp[(k + 1) % z] -= a
        s["pitch_deviations_um"] = fp


register(Plugin())
