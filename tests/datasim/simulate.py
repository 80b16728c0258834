"""One simulated test-rig run: static loaded start, RK4 dynamics, encoder edges.

Time line: the rig starts at static equilibrium under the load at t = 0 with gear 1 at body angle
``-Omega (settle_s + lead_s)``; both encoder indexes (body angle ~0, where tooth 0 of each gear enters
contact) pass at about ``settle_s + lead_s``; each channel records from its index for at
least ``output_revs`` output revolutions.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np

from .effects import Case, EncoderEccentricity, LoadRipple, TorsionalMode
from .encoder import EncoderErrors, edge_times, latch
from .geometry import PairGeometry, geometry_from_config
from .mesh import build_mesh, mean_stiffness
from .rig import RigParams, integrate, lumped, mesh_damping, modes_hz, rig_from_config, static_start

log = logging.getLogger(__name__)

VERSION = "1"
CLOCK_HZ = 80e6
EDGES_PER_REV = 40000
#: node of each encoder and gear in the state vector
NODE = {"input_gear": 2, "input_encoder": 3, "output_gear": 4, "output_encoder": 5}


@dataclass
class SimResult:
    """Histories of one run (every integration step) and the recorded edges.

    Attributes
    ----------
    t : ndarray
        Simulation time [s].
    phi, omega : ndarray, shape (n, 8)
        Node angles [rad] and speeds [rad/s] (nodes: motor, input hub, input gear, input encoder,
        output gear, output encoder, output hub, load).
    te_true_um : ndarray
        ``rb1 phi_gear1 - rb2 phi_gear2`` [um]: TE at the mesh, positive = output lags, including
        the static deflection and the kinematic errors (absolute: 0 = unloaded perfect pair).
    te_sensor_um : ndarray
        The same with the encoder-node angles (what ideal encoders would give) [um].
    mesh_force_N : ndarray
        Elastic mesh force [N].
    edges : dict
        ``"input"``/``"output"`` -> edge time stamps [s] relative to ``t0`` (counter-quantized).
    t0 : float
        Simulation time of the counter start (the earliest first edge) [s].
    first_edge_phi : dict
        Body angle of the shaft at each channel's first edge (its encoder zero) [rad].
    record : tuple of float
        Simulation-time window of the record (first edge of either channel, end) [s].
    truth : dict
        JSON-ready truth of the run (effects, rig changes, speeds, modes, conventions).
    geometry : PairGeometry
    rig : RigParams
    runtime_s : float
        Wall time of the integration (after compilation) [s].
    """

    t: np.ndarray
    phi: np.ndarray
    omega: np.ndarray
    te_true_um: np.ndarray
    te_sensor_um: np.ndarray
    mesh_force_N: np.ndarray
    edges: dict
    t0: float
    first_edge_phi: dict
    record: tuple
    geometry: PairGeometry
    rig: RigParams
    truth: dict = field(default_factory=dict)
    runtime_s: float = 0.0

    def in_record(self) -> np.ndarray:
        """Mask of the samples inside the record window."""
        return (self.t >= self.record[0]) & (self.t <= self.record[1])


def _encoder_errors(case: Case, g: PairGeometry, seed: int, rpm_in: float) -> dict[str, EncoderErrors]:
    seeds = np.random.SeedSequence(seed).generate_state(2)  # the discs: the same in every run of a case
    jitter = np.random.SeedSequence([seed, int(round(rpm_in * 1000))]).generate_state(2)
    out = {}
    for i, (ch, rb, sign) in enumerate((("input", g.rb1, 1.0), ("output", g.rb2, -1.0))):
        ecc, ph = 0.0, 0.0
        for e in case.of(EncoderEccentricity):
            if e.target == f"{ch}_encoder":  # TE = rb1 theta1 - rb2 theta2: the output error enters negated
                ecc, ph = sign * e.amplitude_um * 1e-6 / rb, math.radians(e.phase_deg)
        out[ch] = EncoderErrors(ecc, ph, case.line_error_rad, case.jitter_s, int(seeds[i]), int(jitter[i]))
    return out


def simulate(case: Case, rpm_in: float, torque_out_Nm: float = 120.0, output_revs: float = 6.0,
             pair: str = "helical", seed: int = 0, *, n_slices: int = 40, h: float = 4e-6,
             settle_s: float = 0.1, lead_s: float = 2e-3, encoders: bool = True) -> SimResult:
    """Simulate ``case`` at nominal input speed ``rpm_in`` and brake torque ``torque_out_Nm``.

    Parameters
    ----------
    case : Case
        Effects and record imperfections; the motor runs at ``rpm_in * case.speed_factor``.
    rpm_in : float
        Nominal input speed [rpm].
    torque_out_Nm : float
        Mean brake torque on the load rotor [N m].
    output_revs : float
        Output revolutions to record (from the output index).
    pair : {"helical", "spur"}
    seed : int
        Seed of the encoder line errors (the discs; the jitter also depends on ``rpm_in``).
    n_slices : int
        Slices of the mesh law.
    h : float
        RK4 step [s].
    settle_s : float
        Time discarded after the static start [s].
    lead_s : float
        Time from the end of the settle time to the index of the input encoder [s].
    encoders : bool
        Compute the edges (False: histories only).
    """
    g = geometry_from_config(pair)
    changes = {e.parameter: e.scale for e in case.of(TorsionalMode)}
    rig = rig_from_config(g).scaled(changes)
    mesh = build_mesh(g, case, n_slices=n_slices, stiffness_scale=rig.mesh_stiffness)
    f0 = torque_out_Nm / g.rb2
    k_mean = mean_stiffness(g, mesh, f0)
    J, sp = lumped(rig)
    omega_in = rpm_in * case.speed_factor * 2 * math.pi / 60
    omega_out = omega_in * g.z1 / g.z2
    ripple = case.of(LoadRipple)
    r_amp, r_order, r_phase = ((ripple[0].amplitude_Nm, ripple[0].order_out, math.radians(ripple[0].phase_deg))
                               if ripple else (0.0, 0.0, 0.0))
    drive = np.array([g.rb1, g.rb2, torque_out_Nm * g.rb1 / g.rb2, omega_in, rig.c_speed, torque_out_Nm,
                      r_amp, r_order, r_phase, mesh_damping(rig, g, k_mean), k_mean])
    t_start_rec = settle_s + lead_s
    y0 = static_start(rig, g, mesh, -omega_in * t_start_rec, omega_in, torque_out_Nm)
    t_end = t_start_rec + output_revs * 2 * math.pi / omega_out * 1.002 + 5 * h + 1e-4
    n_steps = int(math.ceil(t_end / h))
    integrate(y0, h, 1, J, sp, drive, *mesh.args())  # compile / load the cache outside the timing
    tic = time.perf_counter()
    states, fm = integrate(y0, h, n_steps, J, sp, drive, *mesh.args())
    runtime = time.perf_counter() - tic
    log.info("datasim: %s %.0f rpm, %d RK4 steps of %.1f us in %.2f s", pair, rpm_in, n_steps, h * 1e6, runtime)
    t = np.arange(n_steps + 1) * h
    phi, omega = states[:, :8], states[:, 8:]
    te = (g.rb1 * phi[:, 2] - g.rb2 * phi[:, 4]) * 1e6
    te_s = (g.rb1 * phi[:, 3] - g.rb2 * phi[:, 5]) * 1e6
    edges, first_phi, t0, rec = {}, {}, 0.0, (t_start_rec, t[-1])
    if encoders:
        errs = _encoder_errors(case, g, seed, rpm_in)
        raw = {}
        for ch, node in (("input", 3), ("output", 5)):
            raw[ch] = edge_times(t, phi[:, node], omega[:, node], settle_s, t[-1] - 2 * h, EDGES_PER_REV, errs[ch])
            first_phi[ch] = float(np.interp(raw[ch][0], t, phi[:, node]))
        t0 = min(raw["input"][0], raw["output"][0])
        edges = {ch: latch(v, t0, CLOCK_HZ) / CLOCK_HZ for ch, v in raw.items()}
        rec = (t0, t[-1])
    res = SimResult(t, phi, omega, te, te_s, fm, edges, t0, first_phi, rec, g, rig, runtime_s=runtime)
    res.truth = _truth(case, res, rpm_in, torque_out_Nm, pair, seed, changes, k_mean, mesh.c_prime, output_revs, h)
    return res


def _truth(case, res, rpm_in, torque, pair, seed, changes, k_mean, c_prime, output_revs, h) -> dict:
    g = res.geometry
    nominal = rig_from_config(g)
    sel = res.in_record()
    te = res.te_true_um[sel]
    truth = {
        "simulator": "tests/datasim (independent of gearrom)", "version": VERSION, "pair": pair, "seed": seed,
        "effects": [e.to_dict() for e in case.effects if e.name != "torsional_mode"],
        "rig_changes": [e.to_dict() for e in case.effects if e.name == "torsional_mode"],
        "rpm_in_nominal": rpm_in, "speed_factor": case.speed_factor, "rpm_in_actual": rpm_in * case.speed_factor,
        "rpm_out_actual": rpm_in * case.speed_factor * g.z1 / g.z2, "torque_out_Nm": torque,
        "output_revs": output_revs, "rk4_step_s": h,
        "encoders": {"edges_per_rev": EDGES_PER_REV, "clock_hz": CLOCK_HZ, "line_error_rad_rms": case.line_error_rad,
                     "jitter_s_rms": case.jitter_s,
                     "zero": "first edge = encoder index, at shaft body angle 0 (tooth 0 enters contact: "
                             "leading face end at A) minus the encoder's own error there"},
        "first_edge_body_angle_rad": res.first_edge_phi,
        "mesh": {"law": "thin-slice, parabolic single-pair stiffness (s_end 0.65)",
                 "c_prime_N_per_mm_um": c_prime / 1e9, "k_mean_N_per_um": k_mean / 1e6,
                 "eps_alpha": g.eps_alpha, "eps_beta": g.eps_beta, "rb1_mm": g.rb1 * 1e3, "rb2_mm": g.rb2 * 1e3},
        "te_true_um": {"mean": float(np.mean(te)), "rms_ac": float(np.std(te)), "ptp": float(np.ptp(te))},
        "modes_hz": [[f, z] for f, z in modes_hz(res.rig, g, k_mean)],
        "conventions": "TE = rb1 theta_in - rb2 theta_out on the transverse line of action, um, positive = output "
                       "lags; tooth k of a gear enters contact (leading face end at A) at record angle 2 pi k / z; "
                       "deviations are minus material (positive = flank set back = output lags)",
    }
    if changes:
        truth["modes_hz_nominal"] = [[f, z] for f, z in modes_hz(nominal, g, k_mean / res.rig.mesh_stiffness)]
    return truth
