"""Candidates acting on the mesh excitation or the rig: flank modifications and mis-tuned modes.

* :class:`Micro` (``tip_relief``, ``lead_crowning``, ``helix_slope``): the STE change of the GMF
  harmonics from the micro-geometry model (the quasi-static FE tables without a new FE solve by
  default), through the run's sensitivity ``H(h z1)``, plus the response to the change of the mean
  mesh stiffness (one re-simulation per run with the stiffness x0.9). When the nominal model has no
  GMF content to align, the mesh phase is estimated together with the modification (the nominal
  GMF lines rotated consistently); else the estimate from the nominal lines may move by +-5 % of a
  mesh period (a flank change moves the GMF phases that estimate was made from). The leading
  candidates are refined by re-simulation.
* :class:`RigMode` (``torsional_mode``): one rig parameter scaled, by re-simulation; the mesh phase
  is re-estimated from the re-tuned model's own GMF lines, as for the nominal model.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize, minimize_scalar

from gearrom.calibrate.fit import N_MESH_HARMONICS, UM, Candidate, Context, Trial, detrend_like_data
from gearrom.excitation.slices import MicroMods
from gearrom.calibrate.model import RunModel, realigned
from gearrom.calibrate.residual import fit_lines, map_to_run
from gearrom.calibrate.simulator import ModelChanges


DPSI_SHARE = 0.05  # the mesh phase estimated from the nominal GMF lines may move by +-5 % of a mesh period


def _phase(m: RunModel, psi: float | None) -> float:
    """Mesh phase of run ``m``: ``psi`` is absolute for runs without alignable GMF content, an offset
    from the run's estimate otherwise (None: the estimate)."""
    if psi is None:
        return m.psi
    return m.psi + psi if m.psi_identifiable else psi


def _stiffness_lines(ctx: Context) -> list:
    """Per run: GMF lines (3, N) of the response to a change of ln(mean mesh stiffness), psi = 0 frame.

    One re-simulation per run with the mesh stiffness x0.9 (when the simulator can scale it): the
    dynamic effect of the stiffness change a flank modification brings along (crowning, tip relief
    at low load), which the STE change alone misses. Zeros when the simulator cannot scale it.
    """
    key = ("stiffness_lines",)
    if key not in ctx._ste:
        out = []
        tun = ctx.sim.tunable() if hasattr(ctx.sim, "tunable") else {}
        for m in ctx.models:
            s0 = np.zeros((3, N_MESH_HARMONICS), complex)
            if "mesh_stiffness" in tun:
                h = ctx.sim.simulate(m.cond, ModelChanges(rig_scale=(("mesh_stiffness", 0.9),), mesh_phase_rad=m.psi))
                d = map_to_run(h, m.run) - m.nominal
                z1 = m.run.mesh.z1
                hs = np.arange(1, N_MESH_HARMONICS + 1)
                ok = hs * z1 * m.run.rpm_in / 60.0 < 0.35 * m.run.fs_hz
                lines = np.column_stack([hs[ok] * z1, np.zeros(ok.sum())])
                c = fit_lines(d, m.run.theta_in_rad, m.run.theta_out_rad, lines)
                s0[:, ok] = c * np.exp(-1j * hs[ok] * z1 * m.psi)[None, :] / math.log(0.9)
            out.append(s0)
        ctx._ste[key] = out
    return ctx._ste[key]


class Micro(Candidate):
    """tip_relief / lead_crowning / helix_slope through the STE change at the GMF harmonics."""

    def _mods(self, ctx: Context, value_um: float) -> MicroMods:
        base = ctx.micro_nominal
        v = value_um * UM
        if self.name == "tip_relief":
            tr = list(base.tip_relief)
            i = 0 if self.target == "input_gear" else 1
            tr[i] = tr[i] + v
            return MicroMods(tuple(tr), base.tip_relief_start_diameter, base.lead_crowning, base.helix_slope)
        if self.name == "lead_crowning":
            return MicroMods(base.tip_relief, base.tip_relief_start_diameter, base.lead_crowning + v, base.helix_slope)
        return MicroMods(base.tip_relief, base.tip_relief_start_diameter, base.lead_crowning, base.helix_slope + v)

    def _lo(self):
        return -self.bound if self.name == "helix_slope" else 0.0

    def _delta_ste(self, ctx: Context, torque: float, value: float) -> np.ndarray:
        """STE change of the GMF harmonics at ``value`` um: the micro-geometry model on a grid of 11 values
        over the plausible range, cubic interpolation in between (the lines vary smoothly with size)."""
        key = ("delta", self.name, self.target, round(torque, 6))
        if key not in ctx._ste:
            grid = np.linspace(self._lo(), self.bound, 11)
            base = ctx.ste_lines(torque, ctx.micro_nominal)
            vals = np.array([ctx.ste_lines(torque, self._mods(ctx, v)) - base for v in grid])
            ctx._ste[key] = CubicSpline(grid, vals, axis=0)
        return ctx._ste[key](value)

    def _waves(self, ctx: Context):
        """Per run: e^{i h z1 theta_in} (h = 1..N_MESH_HARMONICS) on the run's grid, and H(h z1) (3, N) or 0."""
        out = []
        for m in ctx.models:
            z1 = m.run.mesh.z1
            orders, H = m.H["input"]
            idx = {int(q): j for j, q in enumerate(orders)}
            hs = np.arange(1, N_MESH_HARMONICS + 1)
            W = np.exp(1j * np.outer(hs * z1, m.run.theta_in_rad))  # (N, n)
            Hh = np.stack([H[:, idx[h * z1]] if h * z1 in idx else np.zeros(3, complex) for h in hs], axis=1)
            out.append((W, Hh))
        return out

    def _coeffs(self, ctx: Context, m: RunModel, Hh: np.ndarray, value: float, psi: float | None) -> np.ndarray:
        """Complex line coefficients (3, N) of the contribution: the nominal lines plus the STE change
        through H, at mesh phase psi, minus the nominal lines at the run's own mesh phase."""
        z1 = m.run.mesh.z1
        hs = np.arange(1, N_MESH_HARMONICS + 1)
        d = self._delta_ste(ctx, m.run.torque_out_Nm, value)
        nom = np.zeros((3, N_MESH_HARMONICS), complex)
        k = min(N_MESH_HARMONICS, m.gmf_model3.shape[1])
        nom[:, :k] = m.gmf_model3[:, :k]
        p = _phase(m, psi)
        s0 = _stiffness_lines(ctx)[ctx.models.index(m)]  # response to the mean-stiffness change, psi = 0 frame
        lnk = self._delta_lnk(ctx, m.run.torque_out_Nm, value)
        return ((nom + Hh * d[None, :] + s0 * lnk) * np.exp(1j * hs * z1 * p)[None, :]
                - nom * np.exp(1j * hs * z1 * m.psi)[None, :])

    def _delta_lnk(self, ctx: Context, torque: float, value: float) -> float:
        """ln of the mean-stiffness ratio (modified / nominal) from the micro-geometry model (spline in size)."""
        key = ("lnk", self.name, self.target, round(torque, 6))
        if key not in ctx._ste:
            grid = np.linspace(self._lo(), self.bound, 11)
            k0 = ctx.micro_model.excitation(ctx.pair, [torque], ctx.micro_nominal).mean_stiffness(torque)
            vals = np.array([math.log(ctx.micro_model.excitation(ctx.pair, [torque], self._mods(ctx, v))
                                      .mean_stiffness(torque) / k0) for v in grid])
            ctx._ste[key] = CubicSpline(grid, vals)
        return float(ctx._ste[key](value))

    def _contrib(self, ctx, waves, value, psi_free):
        out = []
        for m, (W, Hh) in zip(ctx.models, waves):
            c = self._coeffs(ctx, m, Hh, value, psi_free)
            out.append(detrend_like_data((c @ W).real))
        return out

    def fit(self, ctx, R):
        waves = self._waves(ctx)
        free = not all(m.psi_identifiable for m in ctx.models)
        z1 = ctx.models[0].run.mesh.z1
        period = 2 * math.pi / z1
        # mesh phase: free (absolute) when the nominal model has no GMF content to align; else the estimate
        # from the nominal lines may be moved by DPSI_SHARE of a mesh period (a flank change also moves the
        # phases of the GMF lines the estimate was made from)
        psis = np.linspace(0, period, 61)[:-1] if free else np.linspace(-DPSI_SHARE * period, DPSI_SHARE * period, 9)
        lo, hi = self._lo(), self.bound
        nr = len(ctx.models)
        # the contribution is linear in the (3 x N) complex line coefficients per run: Gram system
        cols = []
        for r, (W, _) in enumerate(waves):
            for part in ("re", "im"):
                for row in range(3):
                    for h in range(N_MESH_HARMONICS):
                        per = [np.zeros((3, m.run.t_s.size)) for m in ctx.models]
                        per[r][row] = detrend_like_data(W[h].real if part == "re" else -W[h].imag)
                        cols.append(ctx.stack(per))
        Phi = np.column_stack(cols)
        G, b = Phi.T @ Phi, Phi.T @ R

        def coeffs(v, psi):
            c = []
            for m, (_, Hh) in zip(ctx.models, waves):
                cc = self._coeffs(ctx, m, Hh, v, psi)
                c.extend([*cc.real.ravel(), *cc.imag.ravel()])
            return np.array(c)

        def dss_of(v, psi):
            c = coeffs(v, psi)
            return float(2 * c @ b - c @ G @ c)

        grid = np.linspace(lo, hi, 13)
        best = (-np.inf, 0.0, None)
        for v in grid:
            for psi in psis:
                d = dss_of(v, psi)
                if d > best[0]:
                    best = (d, v, psi)
        _, v0, psi0 = best
        step = (hi - lo) / 12
        dpsi = psis[1] - psis[0]
        plo, phi = (psi0 - dpsi, psi0 + dpsi) if free else (max(psis[0], psi0 - dpsi), min(psis[-1], psi0 + dpsi))
        r = minimize(lambda p: -dss_of(p[0], p[1]), [v0, psi0], method="Nelder-Mead",
                     bounds=[(max(lo, v0 - step), min(hi, v0 + step)), (plo, phi)],
                     options={"xatol": 1e-4 * (hi - lo), "fatol": 1e-6 * abs(best[0]) + 1e-30, "maxiter": 60})
        if -r.fun > best[0]:
            v, psi0 = float(r.x[0]), float(r.x[1]) % period if free else float(r.x[1])
        else:
            v = v0
        d = dss_of(v, psi0)
        contrib = self._contrib(ctx, waves, v, psi0)
        assert nr == len(contrib)
        info = {"psi_rad": psi0} if free else {"dpsi_rad": psi0}
        if self.name == "tip_relief":
            dca = ctx.micro_nominal.tip_relief_start_diameter[0 if self.target == "input_gear" else 1]
            info["start_diameter_mm"] = None if dca is None else dca * 1e3  # from the config (not fitted)
        return Trial(self, np.array([v]), contrib, d, 2, info)

    def resimulated(self, ctx: Context, value: float, psi_free, realign: bool = False) -> tuple[list, list | None]:
        """Contribution by re-simulation (the flank modification also changes the stiffness variation,
        which the linear ``H x STE change`` misses near the mesh resonance).

        ``realign``: the mesh phase of every run is re-estimated from the modified model's own GMF
        lines (:func:`~gearrom.calibrate.model.realigned`, as for the nominal model and the rig
        parameters) instead of the linearized fit's phase offset ``psi_free``. Returns the
        contributions per run and the re-estimated phases (None without ``realign``).
        """
        out, psis = [], []
        for m in ctx.models:
            if realign:
                mapped, psi = realigned(m, ctx.sim.simulate(m.cond, ModelChanges(micro=self._mods(ctx, value))))
                out.append(mapped - m.nominal)
                psis.append(psi)
                continue
            h = ctx.sim.simulate(m.cond, ModelChanges(micro=self._mods(ctx, value), mesh_phase_rad=_phase(m, psi_free)))
            out.append(map_to_run(h, m.run) - m.nominal)
        return out, (psis if realign else None)

    def refine(self, ctx: Context, R: np.ndarray, t: Trial, n_eval: int = 8) -> Trial:
        """Re-simulated bounded search of the size around the linearized estimate. When every run's mesh
        phase is identifiable from its GMF lines, each trial size is re-aligned from the modified
        model's own GMF lines (an estimate, not a fit of the residual: the phase of the GMF lines is
        so sensitive that a linearized offset of 1e-4 rad decides between look-alike modifications);
        otherwise the linearized fit's mesh phase is kept."""
        psi = t.info.get("psi_rad", t.info.get("dpsi_rad"))
        realign = all(m.psi_identifiable for m in ctx.models)
        cache = {}

        def dss(v):
            v = float(np.clip(v, self._lo(), self.bound))
            if v not in cache:
                c, psis = self.resimulated(ctx, v, psi, realign)
                x = ctx.stack(c)
                cache[v] = (float(2 * x @ R - x @ x), c, psis)
            return cache[v][0]

        v0 = float(t.x[0])
        span = 0.25 * (self.bound - self._lo())
        minimize_scalar(lambda v: -dss(v), bounds=(max(self._lo(), v0 - span), min(self.bound, v0 + span)),
                            method="bounded", options={"maxiter": n_eval, "xatol": 1e-3 * span})
        best = max(cache, key=lambda k: cache[k][0])
        dss(v0)
        if cache[v0][0] >= cache[best][0]:
            best = v0
        info = {**t.info, "resimulated": True}
        if realign:
            info["psi_runs_realigned"] = cache[best][2]
        return Trial(self, np.array([best]), cache[best][1], cache[best][0], t.n_par, info)

    def report(self, x, info):
        out = {"amount_um": float(x[0])}
        if self.name == "tip_relief":
            out["start_diameter_mm"] = info.get("start_diameter_mm")
        return out

    def changes(self, x, info, ctx, run: int = 0):
        return {"micro": self._mods(ctx, float(x[0]))}


PROBE_SHARE = 0.02  # share of the residual energy a rig parameter must explain at x0.8 or x1.25 to be searched


class RigMode(Candidate):
    """torsional_mode: one rig parameter scaled, by re-simulation."""

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
