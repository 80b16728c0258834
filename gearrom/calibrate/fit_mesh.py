"""The fit shared by flank modifications (:class:`FlankModification`), which act on the mesh excitation.

The STE change of the GMF harmonics from the micro-geometry model (the quasi-static FE tables without
a new FE solve by default), through the run's sensitivity ``H(h z1)``, plus the response to the change of the mean
mesh stiffness (one re-simulation per run with the stiffness x0.9). When the nominal model has no
GMF content to align, the mesh phase is estimated together with the modification (the nominal GMF
lines rotated consistently); else the estimate from the nominal lines may move by +-5 % of a mesh
period (a flank change moves the GMF phases that estimate was made from). The leading candidates
are refined by re-simulation.

The effects that use it (``tip_relief``, ``lead_crowning``, ``helix_slope``) are modules of
:mod:`gearrom.calibrate.effects`.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize, minimize_scalar

from gearrom.calibrate.fit import N_MESH_HARMONICS, UM, Candidate, Context, Trial, detrend_like_data
from gearrom.excitation.slices import MicroMods
from gearrom.calibrate.model import RunModel, realigned
from gearrom.calibrate.registry import EffectPlugin
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


class FlankModification(Candidate):
    """A flank modification (tip relief, lead crowning, helix slope...) through the STE change at the GMF
    harmonics. Subclasses give :meth:`modified` (the micro-geometry with the modification's size added)
    and :attr:`signed` (whether the size may be negative)."""

    signed = False

    def modified(self, base: MicroMods, value_m: float) -> MicroMods:  # pragma: no cover - abstract
        """``base`` with the modification of ``value_m`` [m] added on this candidate's target."""
        raise NotImplementedError

    def _mods(self, ctx: Context, value_um: float) -> MicroMods:
        return self.modified(ctx.micro_nominal, value_um * UM)

    def _lo(self):
        return -self.bound if self.signed else 0.0

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
        info["fixed"] = self.fixed_parameters(ctx)
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

    def refit(self, ctx: Context, R: np.ndarray, previous: Trial) -> Trial:
        t = self.fit(ctx, R)
        return self.refine(ctx, R, t)

    def fixed_parameters(self, ctx: Context) -> dict:
        """Parameters of the modification taken from the config, not fitted (reported with the size)."""
        return {}

    def report(self, x, info):
        return {"amount_um": float(x[0]), **info.get("fixed", {})}

    def changes(self, x, info, ctx, run: int = 0):
        return {"micro": self._mods(ctx, float(x[0]))}


class FlankPlugin(EffectPlugin):
    """The hooks flank modifications share: mesh-phase evidence, GMF lines, and a pair-level amount written
    to the input gear's ``<name>_um`` (the pair's value is the sum over both gears)."""

    def evidence(self, ctx, trial, D):
        return mesh_phase_note(trial.info)

    def explains_line(self, target, label):
        return explains_gmf(label)

    def write_config(self, draft, target, params):
        s = draft.micro_section("input_gear")
        key = f"{self.spec.name}_um"
        s[key] = s.get(key, 0.0) + float(params["amount_um"])


def mesh_phase_note(info: dict) -> str:
    """How the mesh phase of a fitted flank modification was found, for its evidence."""
    if info.get("psi_runs_realigned") is not None:
        ph = "re-estimated from the modified model's own GMF lines, as for the nominal model"
    elif info.get("psi_rad") is None:
        ph = (f"estimated from the nominal GMF, moved by {math.degrees(info.get('dpsi_rad', 0.0)):.2f} deg of "
              "input angle with the modification")
    else:
        ph = "fitted: nominal had no GMF content"
    return f"; GMF harmonics changed as the flank modification predicts (mesh phase {ph})"


def explains_gmf(label: str) -> bool:
    """A residual line at a GMF harmonic (the lines a mesh-table or rig change acts on)."""
    return "GMF" in label
