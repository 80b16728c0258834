"""Per-run model: nominal simulation, honest mesh-phase alignment, and drivetrain sensitivities.

For each measured run the simulator is run at the run's *measured* speed and its load:

1. nominal, to get the model's own GMF lines, from which the mesh phase psi is estimated
   (:func:`~gearrom.calibrate.residual.estimate_mesh_phase`), then nominal again at psi;
2. twice per shaft with a small multisine kinematic error (orders 1..Q of that shaft in two blocks,
   Schroeder phases, 0.1 um each). The difference to the nominal run, regressed on the injected orders,
   gives the drivetrain's response ``H[q]`` (complex, for te, u_in, u_out) to a unit kinematic
   error at shaft order q. It holds every speed-dependent dynamic effect of the model (mode
   amplification, which shaft moves), and turns kinematic effects (runout, pitch errors) and
   micro-geometry (its STE change at the mesh orders) into predictions without one simulation
   per parameter value. The final before/after comparison re-simulates with the fitted effects.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from gearrom.calibrate.residual import (RunData, estimate_mesh_phase, fit_lines, lowpass_gain, map_to_run, mesh_lines,
                                        noise_rms, sim_signals)
from gearrom.calibrate.simulator import ModelChanges, RunConditions, Simulator
from gearrom.errors import CalibrationError

log = logging.getLogger(__name__)

INJECT_UM = 0.1
N_TABLE = 4096


@dataclass(eq=False)
class RunModel:
    """Model side of one run.

    Attributes
    ----------
    run : RunData
    cond : RunConditions
        What was simulated (measured speed, load, record length with margin).
    psi : float
        Mesh phase, rad of input angle; ``psi_identifiable`` False when the nominal model has no GMF
        content to align (then psi = 0 and micro-geometry fits free it).
    nominal : ndarray, shape (3, n)
        Nominal te, u_in, u_out mapped onto the run.
    gmf_model, gmf_meas : ndarray of complex
        GMF harmonics (up to 6, below 0.35 x the working rate) of the nominal model (psi = 0) and of
        the measured TE, m.
    H : dict
        ``"input"``/``"output"`` -> ``(orders, response (3, n_orders))``.
    noise_m : float
        Broadband noise rms of the measured TE on the working grid, m.
    lines : ndarray
        The GMF lines used for the mesh-phase estimate.
    gmf_model3 : ndarray of complex, shape (3, n_lines)
        The nominal model's GMF lines (psi = 0) of te, u_in, u_out.
    """

    run: RunData
    cond: RunConditions
    psi: float
    psi_identifiable: bool
    nominal: np.ndarray
    gmf_model: np.ndarray
    gmf_meas: np.ndarray
    H: dict = field(default_factory=dict)
    noise_m: float = 0.0
    lines: np.ndarray | None = None
    gmf_model3: np.ndarray | None = None

    def response(self, shaft: str, coeffs: dict[int, complex]) -> np.ndarray:
        """Predicted (3, n) signals for a kinematic error ``Re(sum_q coeffs[q] exp(i q theta_shaft))``."""
        orders, H = self.H[shaft]
        th = self.run.theta_in_rad if shaft == "input" else self.run.theta_out_rad
        out = np.zeros((3, th.size))
        idx = {int(q): j for j, q in enumerate(orders)}
        for q, c in coeffs.items():
            if q not in idx:
                continue
            out += (H[:, idx[q]][:, None] * c * np.exp(1j * q * th)[None, :]).real
        return out


def _schroeder(n: int) -> np.ndarray:
    k = np.arange(1, n + 1)
    return -math.pi * k * (k - 1) / n


def multisine_table(orders: np.ndarray, amp: float, phases: np.ndarray, n: int = N_TABLE) -> np.ndarray:
    """One-revolution table of ``sum amp cos(q theta + phase_q)``."""
    th = np.arange(n) * 2 * math.pi / n
    return amp * np.cos(np.outer(th, orders) + phases[None, :]).sum(axis=1)


def conditions(run: RunData) -> RunConditions:
    """Simulation conditions of a run: measured speed, load, record plus a 5 % + 2 ms margin."""
    return RunConditions(rpm_in=run.rpm_in, torque_out_Nm=run.torque_out_Nm, duration_s=run.duration_s * 1.05 + 2e-3)


def build_run_model(sim: Simulator, run: RunData, *, with_sensitivity: bool = True,
                    psi_default: float = 0.0) -> RunModel:
    """Nominal simulation, mesh-phase estimate and sensitivities for one run (see module docstring).

    ``psi_default`` (rad of input angle): the mesh phase where the GMF lines cannot align the model
    (records that start at the encoder index of a rig whose index position a diagnosis found, see
    :func:`index_mesh_phase`)."""
    cond = conditions(run)
    z1 = run.mesh.z1
    noise = noise_rms(run.y[0], run.fs_hz)
    h0 = sim.simulate(cond, ModelChanges())
    th_s, ys = sim_signals(h0, run.mesh)
    n_h = int(max(1, min(6, math.floor(0.35 * run.fs_hz / run.gmf_hz))))
    lines = mesh_lines(z1, n_h)
    gm3 = fit_lines(ys - ys.mean(axis=1, keepdims=True), h0.theta_in_rad, h0.theta_out_rad, lines)
    gm3 = gm3 * lowpass_gain(lines[:, 0] * run.rpm_in / 60.0, run.fs_hz)[None, :]  # the comparison band
    gm = gm3[0]
    gmeas = fit_lines(run.y[0], run.theta_in_rad, run.theta_out_rad, lines)
    psi, ok = estimate_mesh_phase(gmeas, gm, z1, noise / 1e-6 / math.sqrt(max(run.y.shape[1], 1) / 2))
    if not ok:
        psi = float(psi_default)
    hn = sim.simulate(cond, ModelChanges(mesh_phase_rad=psi)) if psi else h0
    nominal = map_to_run(hn, run)
    rm = RunModel(run=run, cond=cond, psi=psi, psi_identifiable=ok, nominal=nominal, gmf_model=gm, gmf_meas=gmeas,
                  noise_m=noise, lines=lines, gmf_model3=gm3)
    if with_sensitivity:
        for shaft in ("input", "output"):
            rm.H[shaft] = _sensitivity(sim, rm, hn, shaft)
    return rm


def index_mesh_phase(cfg) -> float:
    """``[calibrate] index_mesh_phase_deg`` of a config, rad (0 when absent).

    The input gear's angle at the encoder index, from tooth 0's entry into mesh: what a diagnosis finds
    when a tooth-local error fixes where the teeth stand (``gearrom diagnose --write-config`` writes it).
    It applies to records that start at the index and whose GMF lines are too small to align the model.

    Raises
    ------
    CalibrationError
        The key is not a number.
    """
    v = cfg.section("calibrate").get("index_mesh_phase_deg", 0.0)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise CalibrationError(f"{cfg.source or cfg.name}: calibrate.index_mesh_phase_deg must be a finite number "
                               f"of degrees, got {v!r}")
    return math.radians(float(v))


def realigned(rm: RunModel, hist) -> tuple[np.ndarray, float]:
    """A re-tuned model run (simulated at mesh phase 0, no shaft-order effects) mapped onto the run
    with its mesh phase re-estimated from *its own* GMF lines, as for the nominal model."""
    _, ys = sim_signals(hist, rm.run.mesh)
    fs_sim = 1.0 / float(np.median(np.diff(hist.t_s)))
    k = max(1, int(fs_sim // (5 * np.max(rm.lines[:, 0]) * rm.run.rpm_in / 60.0)))
    gm = fit_lines(ys[0, ::k] - ys[0].mean(), hist.theta_in_rad[::k], hist.theta_out_rad[::k], rm.lines)
    gm = gm * lowpass_gain(rm.lines[:, 0] * rm.run.rpm_in / 60.0, rm.run.fs_hz)
    n = rm.run.y.shape[1]
    psi, ok = estimate_mesh_phase(rm.gmf_meas, gm, rm.run.mesh.z1, rm.noise_m / 1e-6 / math.sqrt(max(n, 1) / 2))
    if not ok:
        psi = rm.psi
    return map_to_run(hist, rm.run, angle_shift=psi), psi


def shaft_rate_hz(run: RunData, shaft: str) -> float:
    """Rotation rate of ``shaft`` (``"input"``/``"output"``) in a run, Hz."""
    return run.rpm_in / 60.0 * (1.0 if shaft == "input" else run.mesh.ratio)


def max_order(run: RunData, shaft: str) -> int:
    """Highest shaft order used: 6 GMF harmonics (input) / 2 x teeth (output), below 0.35 fs_work."""
    f_in = run.rpm_in / 60.0
    if shaft == "input":
        f, q = f_in, 6 * run.mesh.z1 + 2
    else:
        f, q = f_in * run.mesh.ratio, 2 * run.mesh.z2
    return int(max(1, min(q, math.floor(0.35 * run.fs_hz / f))))


def _sensitivity(sim: Simulator, rm: RunModel, hnom, shaft: str) -> tuple[np.ndarray, np.ndarray]:
    """Response to unit kinematic errors at orders 1..Q of ``shaft``, from two multisine simulations.

    The low orders (below half the tooth count) go in one multisine and the rest in another: two
    injected orders that differ by a multiple of the mesh order would mix through the mesh
    stiffness variation (parametric excitation) and bias each other's estimate, most of all near
    the mesh resonance; within the low block no difference reaches the mesh order.
    """
    run = rm.run
    Q = max_order(run, shaft)
    z = run.mesh.z1 if shaft == "input" else run.mesh.z2
    split = max(1, min(Q, (z - 1) // 2))
    blocks = [np.arange(1, split + 1)] + ([np.arange(split + 1, Q + 1)] if Q > split else [])
    _, y0 = sim_signals(hnom, run.mesh)
    fs_sim = 1.0 / float(np.median(np.diff(hnom.t_s)))
    f_shaft = shaft_rate_hz(run, shaft)
    orders_all, H_all = [], []
    for orders in blocks:
        ph = _schroeder(orders.size)
        tab = multisine_table(orders, INJECT_UM * 1e-6, ph)
        ch = ModelChanges(kinematic_in=tab if shaft == "input" else None,
                          kinematic_out=tab if shaft == "output" else None, mesh_phase_rad=rm.psi)
        hx = sim.simulate(rm.cond, ch)
        if hx.t_s.size != hnom.t_s.size:
            raise CalibrationError(f"simulator {sim.name} returned different grids for the same run")
        _, y1 = sim_signals(hx, run.mesh)
        d = y1 - y0
        d -= d.mean(axis=1, keepdims=True)
        zeros = np.zeros(orders.size)
        lines = np.column_stack([orders, zeros]) if shaft == "input" else np.column_stack([zeros, orders])
        k = max(1, int(fs_sim // (5 * orders[-1] * f_shaft)))  # rows thinned: the response lives below
        c = fit_lines(d[:, ::k], hnom.theta_in_rad[::k], hnom.theta_out_rad[::k], lines)
        orders_all.append(orders)
        gain = lowpass_gain(orders * f_shaft, run.fs_hz)  # the comparison band of the mapped signals
        H_all.append(c * gain[None, :] / (INJECT_UM * 1e-6 * np.exp(1j * ph))[None, :])
    return np.concatenate(orders_all), np.concatenate(H_all, axis=1)
