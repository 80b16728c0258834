"""A small torsional model of the TE rig, used by the diagnosis when the exudyn ROM is absent.

Degrees of freedom (rotations, rad): motor rotor, input gear (pinion with its shaft stub and the
sensor-side encoder), output gear (wheel, encoder), load (clutch hub, lever and brake).

* Motor: speed-controlled, a torsional spring-damper ``k_ctrl, c_ctrl`` to the reference angle
  ``Omega t`` plus the feed-forward of the load torque (a PD law; stated, not identified).
* Input shaft: spring-damper motor -> pinion. Clutch/coupling: spring-damper wheel -> load.
* Mesh: the secant law of :class:`~gearrom.rom.mesh.MeshLaw` at the run's torque, evaluated by the
  compiled :func:`gearrom.rom.lawkernel.law_force` that the validation's pair model uses too:
  ``F = k(theta_1) (delta - e0(theta_1) - e_x) + c_m (d delta/dt - d e_x/dt)`` while
  ``delta - e_x > e0`` (else 0: contact loss; no back-side contact), ``delta = r_b1 theta_1 -
  r_b2 theta_2``, with ``k, e0`` from the mesh excitation table at the run's torque
  (``e0 = e - F_t/k``) and ``e_x`` the kinematic errors of :class:`~gearrom.calibrate.simulator.ModelChanges`.
* Brake: constant torque on the load, optionally with a ripple ``r cos(order theta_load + phi)``.
* Encoders sit on the gears (sensor side, no torque through the stub: no twist).

Rig values (``RigParams``) are assumed, chosen to put the first torsional mode near the seed's
measured ~200 Hz peak and the mesh mode in its 2-3 kHz band. Integration: classical RK4 with a fixed
step (1/50 kHz by default; the stiffest mode is ~2.8 kHz, ``omega h`` ~ 0.35), started from the static
preload at speed, with a warm-up that is discarded. The mesh tables are band-limited to 0.2/h (10 kHz)
so that the integrator does not alias their sharp contact entry/exit corners.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numba
import numpy as np

from gearrom.calibrate.microfe import FEMicroModel, with_micro
from gearrom.calibrate.runs import ModelChanges, RunConditions, SimHistory
from gearrom.errors import CalibrationError
from gearrom.excitation.slices import MicroMods, SliceMicroModel
from gearrom.rom.lawkernel import LawTables, law_force
from gearrom.rom.mesh import MeshLaw


@dataclass(frozen=True)
class RigParams:
    """Lumped torsional rig parameters (SI). See the module docstring; all values are assumptions.

    Parameters
    ----------
    J_motor, J_in, J_out, J_load : float
        Inertias of motor rotor, input gear + shaft + encoder, output gear + shaft + encoder,
        clutch hub + load lever + brake, kg m^2.
    k_ctrl, c_ctrl : float
        Speed controller as torsional stiffness (N m/rad) and damping (N m s/rad).
    k_shaft_in, k_clutch : float
        Input shaft and clutch torsional stiffness, N m/rad.
    zeta_shaft, zeta_mesh : float
        Damping ratios of the shaft/clutch springs (against the inertias they join) and of the mesh.
    mesh_stiffness : float
        Scale of the mesh stiffness table, -.
    """

    J_motor: float = 0.02
    J_in: float = 1.5e-3
    J_out: float = 3.0e-3
    J_load: float = 0.02
    k_ctrl: float = 2.0e3
    c_ctrl: float = 8.0
    k_shaft_in: float = 3.0e4
    k_clutch: float = 3.0e4
    zeta_shaft: float = 0.03
    zeta_mesh: float = 0.05
    mesh_stiffness: float = 1.0

    def scaled(self, rig_scale) -> RigParams:
        """A copy with parameters multiplied (``(("k_clutch", 1.3), ...)``)."""
        kw = {}
        for name, s in rig_scale:
            if name not in TUNABLE:
                raise CalibrationError(f"rig parameter {name!r} is not tunable; choose from {sorted(TUNABLE)}")
            kw[name] = getattr(self, name) * float(s)
        return dataclasses.replace(self, **kw)


TUNABLE = {"k_clutch": "clutch/coupling torsional stiffness", "k_shaft_in": "input shaft torsional stiffness",
           "mesh_stiffness": "mesh stiffness level", "J_load": "load-side inertia",
           "zeta_shaft": "shaft/clutch damping ratio", "zeta_mesh": "mesh damping ratio"}


@numba.njit(cache=True)
def _lookup(tab, x, period):
    n = tab.size
    u = (x / period) % 1.0 * n
    i = int(u)
    f = u - i
    if i >= n:
        i = 0
    j = i + 1 if i + 1 < n else 0
    return tab[i] * (1.0 - f) + tab[j] * f, (tab[j] - tab[i]) * n / period


@numba.njit(cache=True)
def _rhs(t, y, p, E, fv, mper, ex1, ex2, rip):
    # p: Jm J1 J2 JL kctrl cctrl ks cs kc cc rb1 rb2 cm Omega Tload Tff thm0 mesh_phase
    thm, th1, th2, thl, wm, w1, w2, wl = y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7]
    tc = p[4] * (p[13] * t + p[16] - thm) + p[5] * (p[13] - wm) + p[15]
    ts = p[6] * (thm - th1) + p[7] * (wm - w1)
    x1, d1 = _lookup(ex1, th1, 2 * np.pi)
    x2, d2 = _lookup(ex2, th2, 2 * np.pi)
    # the gears' kinematic errors shift the contact: the mesh law sees the deflection minus them
    delta = p[10] * th1 - p[11] * th2 - x1 - x2
    ddelta = p[10] * w1 - p[11] * w2 - d1 * w1 - d2 * w2
    f = law_force(E, fv, (th1 + p[17]) / mper * E.shape[1], delta, ddelta, p[12])
    tcl = p[8] * (th2 - thl) + p[9] * (w2 - wl)
    tl = p[14] * (1.0 + rip[0] * np.cos(rip[1] * thl + rip[2]))
    out = np.empty(8)
    out[0], out[1], out[2], out[3] = wm, w1, w2, wl
    out[4] = (tc - ts) / p[0]
    out[5] = (ts - p[10] * f) / p[1]
    out[6] = (p[11] * f - tcl) / p[2]
    out[7] = (tcl - tl) / p[3]
    return out


@numba.njit(cache=True)
def _integrate(y0, h, n_steps, n_skip, p, E, fv, mper, ex1, ex2, rip):
    n_out = n_steps - n_skip + 1
    out = np.empty((n_out, 3))
    y = y0.copy()
    t = 0.0
    k = 0
    for i in range(n_steps + 1):
        if i >= n_skip:
            out[k, 0], out[k, 1], out[k, 2] = t, y[1], y[2]
            k += 1
        if i == n_steps:
            break
        a = _rhs(t, y, p, E, fv, mper, ex1, ex2, rip)
        b = _rhs(t + h / 2, y + h / 2 * a, p, E, fv, mper, ex1, ex2, rip)
        c = _rhs(t + h / 2, y + h / 2 * b, p, E, fv, mper, ex1, ex2, rip)
        d = _rhs(t + h, y + h * c, p, E, fv, mper, ex1, ex2, rip)
        y = y + h / 6 * (a + 2 * b + 2 * c + d)
        t += h
    return out


def _band_limit(table: np.ndarray, m_max: int) -> np.ndarray:
    """Keep mesh harmonics 0..m_max of a one-period table (the integrator samples the excitation at
    its stage times: content above about a fifth of the step rate would alias, differently for each
    mesh phase, which would make a mesh-phase shift more than a rotation)."""
    c = np.fft.rfft(table)
    c[m_max + 1:] = 0.0
    return np.fft.irfft(c, table.size)


class TorsionalRig:
    """The torsional rig model as a :class:`~gearrom.calibrate.simulator.Simulator`.

    Parameters
    ----------
    pair : GearPair
    params : RigParams
    micro : MicroMods
        Flank modifications of the nominal model (default: those enabled in the config).
    micro_model : MicroGeometryModel
        Micro-geometry model for flank changes (default: FE tables; the nominal table is the slice model).
    h_s, warmup_s : float
        Integration step and discarded warm-up, s.
    """

    name = "gearrom.calibrate.torsional.TorsionalRig"

    def __init__(self, pair, params: RigParams | None = None, micro: MicroMods | None = None,
                 micro_model=None, h_s: float = 2e-5, warmup_s: float = 0.08):
        self.pair = pair
        self.params = params or RigParams()
        self.micro = micro if micro is not None else MicroMods.from_pair(pair)
        self.micro_model = micro_model or FEMicroModel()
        self.h_s = h_s
        self.warmup_s = warmup_s
        self._tables: dict = {}

    @classmethod
    def from_config(cls, config, **kw) -> TorsionalRig:
        """Rig model for a gear configuration (loaded, bundled name or file)."""
        from gearrom.config import as_config

        return cls(as_config(config).pair, **kw)

    def tunable(self) -> dict[str, str]:
        return dict(TUNABLE)

    def _table(self, torque: float, micro: MicroMods):
        key = (round(torque, 6), micro)
        if key not in self._tables:
            ex = SliceMicroModel().excitation(self.pair, [torque], self.micro)  # the rig's nominal table
            if micro != self.micro:  # a flank change: from the micro-geometry model (FE tables by default)
                ex = with_micro(ex, self.micro_model, self.pair, torque, self.micro, micro)
            _, k, e = ex.sampled(torque, 512)
            self._tables[key] = (k, e)
        return self._tables[key]

    def _mesh_mass(self, p: RigParams) -> float:
        rb1, rb2 = self.pair.rb
        return 1.0 / (rb1**2 / p.J_in + rb2**2 / p.J_out)

    def matrices(self, rig_scale=(), k_mesh: float | None = None):
        """Mass, stiffness and damping matrices at the mean mesh stiffness (DOFs: motor, in, out, load)."""
        p = self.params.scaled(rig_scale)
        rb1, rb2 = self.pair.rb
        if k_mesh is None:
            k_mesh = float(np.mean(self._table(1.0, self.micro)[0]))
        km = k_mesh * p.mesh_stiffness
        M = np.diag([p.J_motor, p.J_in, p.J_out, p.J_load])
        K = np.zeros((4, 4))
        C = np.zeros((4, 4))
        cs = 2 * p.zeta_shaft * math.sqrt(p.k_shaft_in * p.J_in)
        cc = 2 * p.zeta_shaft * math.sqrt(p.k_clutch * p.J_load)
        cm = 2 * p.zeta_mesh * math.sqrt(km * self._mesh_mass(p))
        for (i, j), k, c in (((0, 1), p.k_shaft_in, cs), ((2, 3), p.k_clutch, cc)):
            for A, v in ((K, k), (C, c)):
                A[i, i] += v
                A[j, j] += v
                A[i, j] -= v
                A[j, i] -= v
        g = np.array([0.0, rb1, -rb2, 0.0])
        K += km * np.outer(g, g)
        C += cm * np.outer(g, g)
        K[0, 0] += p.k_ctrl
        C[0, 0] += p.c_ctrl
        return M, K, C, (cs, cc, cm)

    def modes_hz(self, rig_scale=()) -> list[tuple[float, float]]:
        """Damped natural frequencies (Hz) and damping ratios of the linearized rig."""
        M, K, C, _ = self.matrices(rig_scale)
        n = M.shape[0]
        Mi = np.linalg.inv(M)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-Mi @ K, -Mi @ C]])
        lam = np.linalg.eigvals(A)
        lam = lam[lam.imag > 1e-6]
        out = sorted((abs(x) / (2 * math.pi), -x.real / abs(x)) for x in lam)
        return [(float(f), float(z)) for f, z in out]

    def simulate(self, run: RunConditions, changes: ModelChanges | None = None) -> SimHistory:
        """Steady-state encoder angles for ``run`` with ``changes`` (see :class:`ModelChanges`)."""
        ch = changes or ModelChanges()
        p = self.params.scaled(ch.rig_scale)
        rb1, rb2 = self.pair.rb
        z1 = self.pair.z[0]
        micro = ch.micro if ch.micro is not None else self.micro
        k_tab, e_tab = self._table(run.torque_out_Nm, micro)
        k_tab = k_tab * p.mesh_stiffness
        ft = run.torque_out_Nm / rb2
        e0 = e_tab - ft / (k_tab / p.mesh_stiffness)  # tangent linearization about the static point
        gmf = z1 * run.rpm_in / 60.0
        k_tab, e0 = (_band_limit(x, int(max(1, 0.2 / (self.h_s * gmf)))) for x in (k_tab, e0))
        _, _, _, (cs, cc, cm) = self.matrices(ch.rig_scale, k_mesh=float(np.mean(k_tab)) / p.mesh_stiffness)
        om = run.rpm_in * math.pi / 30.0
        ex1 = np.zeros(1) if ch.kinematic_in is None else np.asarray(ch.kinematic_in, float)
        ex2 = np.zeros(1) if ch.kinematic_out is None else np.asarray(ch.kinematic_out, float)
        rip = np.zeros(3) if ch.load_ripple is None else np.asarray(ch.load_ripple, float)
        t_ff = run.torque_out_Nm * rb1 / rb2
        th1 = -om * self.warmup_s
        thm = th1 + t_ff / p.k_shaft_in
        grid = np.arange(512) * 2 * math.pi / z1 / 512
        ph = (th1 + ch.mesh_phase_rad) % (2 * math.pi / z1)
        delta0 = ft / np.interp(ph, grid, k_tab) + np.interp(ph, grid, e0)
        th2 = (rb1 * th1 - delta0) / rb2
        thl = th2 - run.torque_out_Nm / p.k_clutch
        w2 = om * rb1 / rb2
        y0 = np.array([thm, th1, th2, thl, om, om, w2, w2])
        pv = np.array([p.J_motor, p.J_in, p.J_out, p.J_load, p.k_ctrl, p.c_ctrl, p.k_shaft_in, cs, p.k_clutch, cc,
                       rb1, rb2, cm, om, run.torque_out_Nm, t_ff, thm, ch.mesh_phase_rad])
        n_skip = int(round(self.warmup_s / self.h_s))
        n_steps = n_skip + int(math.ceil(run.duration_s / self.h_s))
        law = MeshLaw(self.pair, grid, k_tab, e0 + ft / k_tab, ft)  # the secant law at the run's torque
        tab = LawTables.from_law(law)
        out = _integrate(y0, self.h_s, n_steps, n_skip, pv, tab.E, tab.f, tab.period, ex1, ex2, rip)
        if not np.all(np.isfinite(out)):
            raise CalibrationError(f"torsional rig integration diverged at {run.rpm_in} rpm (step {self.h_s} s)")
        return SimHistory(out[:, 0] - out[0, 0], out[:, 1], out[:, 2],
                          info={"simulator": self.name, "h_s": self.h_s, "warmup_s": self.warmup_s})
