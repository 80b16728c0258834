"""Lumped torsional test rig (own model) and its fixed-step RK4 integrator (numba).

Nodes (angles in each shaft's direction of rotation, rad)::

    0 motor ==clutch== 1 input hub --shaft-- 2 input gear --shaft-- 3 input encoder
                                               | mesh (rb1, rb2)
    7 load  ==clutch== 6 output hub --shaft-- 4 output gear --shaft-- 5 output encoder

Shaft stiffness ``G J_p / L`` per segment (G = 80 GPa) in series, segment inertia split half/half to
the two nodes of its section. Damping: stiffness-proportional on the shafts (``beta_shaft k``),
the clutch's own damping, and on the mesh ``c_m = 2 zeta_mesh sqrt(k_mean m_eq)`` scaled by the active
mesh stiffness over its mean (vanishes with contact loss). Motor: ``T = T_ff + c_speed (Omega - omega)``,
``T_ff`` = the load torque reflected through the ideal ratio. Load: constant brake torque (+ ripple).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .data import rig_config
from .geometry import PairGeometry
from .mesh import MeshModel, buffers, contacts, force, solve_delta

G_SHEAR = 80e9
RHO = 7850.0
MM = 1e-3

#: rig parameters a ``torsional_mode`` effect may scale (names as gearrom's tunable ones where they exist)
TUNABLE = ("k_clutch", "k_shaft_in", "k_shaft_out", "J_motor", "J_load", "J_encoder", "mesh_stiffness",
           "zeta_mesh", "beta_shaft", "c_speed")


@dataclass(frozen=True)
class RigParams:
    """Torsional rig data, SI.

    Attributes
    ----------
    J_motor, J_load, J_hub, J_encoder : float
        Rotor, hub and encoder inertias [kg m^2] (the encoder value is per encoder).
    J_gear1, J_gear2 : float
        Gear body inertias (disc of the reference diameter minus the bore, face width) [kg m^2].
    shaft_in, shaft_out : dict
        ``k_clutch_side``, ``k_sensor_side`` [N m/rad], ``J_clutch_side``, ``J_sensor_side`` [kg m^2].
    k_clutch, c_clutch : float
        Clutch stiffness [N m/rad] and damping [N m s/rad].
    c_speed : float
        Speed-loop gain [N m s/rad].
    beta_shaft : float
        Stiffness-proportional damping of the shafts [s].
    zeta_mesh, mesh_stiffness, k_shaft_in, k_shaft_out : float
        Mesh damping ratio; scale factors of the mesh and shaft stiffness (1 = nominal).
    """

    J_motor: float
    J_load: float
    J_hub: float
    J_encoder: float
    J_gear1: float
    J_gear2: float
    shaft_in: dict
    shaft_out: dict
    k_clutch: float
    c_clutch: float
    c_speed: float
    beta_shaft: float = 2e-6
    zeta_mesh: float = 0.05
    mesh_stiffness: float = 1.0
    k_shaft_in: float = 1.0
    k_shaft_out: float = 1.0

    def scaled(self, changes: dict[str, float]) -> "RigParams":
        """A copy with parameters multiplied (keys of :data:`TUNABLE`)."""
        kw = {}
        for name, s in changes.items():
            if name not in TUNABLE:
                raise ValueError(f"rig parameter {name!r} is not tunable; choose from {TUNABLE}")
            kw[name] = getattr(self, name) * float(s)
        return dataclasses.replace(self, **kw)


def _shaft(tab: dict) -> dict:
    """Stiffness and inertia of the clutch and sensor side of a shaft from its stations and diameters."""
    x = [tab[k] * MM for k in ("sensor_end_mm", "ball_bearing_mm", "gear_mm", "needle_bearing_mm", "clutch_end_mm")]
    d = [v * MM for v in tab["diameters_mm"]]
    seg = [(x[i + 1] - x[i], math.pi * d[i] ** 4 / 32) for i in range(4)]

    def side(parts):
        flex = sum(L / (G_SHEAR * jp) for L, jp in parts)
        return 1.0 / flex, sum(RHO * jp * L for L, jp in parts)

    ks, js = side(seg[:2])
    kc, jc = side(seg[2:])
    return {"k_sensor_side": ks, "J_sensor_side": js, "k_clutch_side": kc, "J_clutch_side": jc}


def _gear_inertia(r: float, bore_d: float, b: float) -> float:
    return RHO * math.pi * b / 2 * (r ** 4 - (bore_d / 2) ** 4)


def rig_from_config(g: PairGeometry, bores_mm: tuple[float, float] = (35.30, 34.25),
                    encoder_inertia: float = 2e-5) -> RigParams:
    """Rig of thesis-rig.toml ([rig.*]) around pair ``g``.

    Parameters
    ----------
    g : PairGeometry
    bores_mm : tuple of float
        Gear bores [mm] (both bundled pairs: 35.30 / 34.25).
    encoder_inertia : float
        ASSUMPTION: encoder rotor + coupling on each sensor end [kg m^2].
    """
    rc = rig_config()
    return RigParams(J_motor=rc["motor"]["inertia_kg_m2"], J_load=rc["load"]["inertia_kg_m2"],
                     J_hub=rc["clutch"]["hub_inertia_kg_m2"], J_encoder=encoder_inertia,
                     J_gear1=_gear_inertia(g.r1, bores_mm[0] * MM, g.b1),
                     J_gear2=_gear_inertia(g.r2, bores_mm[1] * MM, g.b2),
                     shaft_in=_shaft(rc["input_shaft"]), shaft_out=_shaft(rc["output_shaft"]),
                     k_clutch=rc["clutch"]["stiffness_Nm_per_rad"], c_clutch=rc["clutch"]["damping_Nms_per_rad"],
                     c_speed=rc["motor"]["speed_gain_Nms_per_rad"])


def lumped(p: RigParams) -> tuple[np.ndarray, np.ndarray]:
    """Node inertias ``J`` (8,) and springs ``(a, b, k, c)`` as an array (6, 4)."""
    si, so = p.shaft_in, p.shaft_out
    J = np.array([p.J_motor, p.J_hub + si["J_clutch_side"] / 2,
                  p.J_gear1 + (si["J_clutch_side"] + si["J_sensor_side"]) / 2, p.J_encoder + si["J_sensor_side"] / 2,
                  p.J_gear2 + (so["J_clutch_side"] + so["J_sensor_side"]) / 2, p.J_encoder + so["J_sensor_side"] / 2,
                  p.J_hub + so["J_clutch_side"] / 2, p.J_load])
    kin, kout = p.k_shaft_in, p.k_shaft_out
    springs = [(0, 1, p.k_clutch, p.c_clutch), (1, 2, kin * si["k_clutch_side"], 0.0),
               (2, 3, kin * si["k_sensor_side"], 0.0), (4, 5, kout * so["k_sensor_side"], 0.0),
               (4, 6, kout * so["k_clutch_side"], 0.0), (6, 7, p.k_clutch, p.c_clutch)]
    sp = np.array(springs, float)
    sp[1:5, 3] = p.beta_shaft * sp[1:5, 2]
    return J, sp


def mesh_damping(p: RigParams, g: PairGeometry, k_mean: float) -> float:
    """Mesh damping [N s/m] for ratio ``zeta_mesh`` of the two-gear mesh mode."""
    J, _ = lumped(p)
    m_eq = 1.0 / (g.rb1 ** 2 / J[2] + g.rb2 ** 2 / J[4])
    return 2 * p.zeta_mesh * math.sqrt(k_mean * m_eq)


def modes_hz(p: RigParams, g: PairGeometry, k_mean: float) -> list[tuple[float, float]]:
    """Natural frequencies [Hz] and damping ratios of the rig linearized at the mean mesh stiffness."""
    J, sp = lumped(p)
    K = np.zeros((8, 8))
    C = np.zeros((8, 8))
    for a, b, k, c in sp:
        a, b = int(a), int(b)
        for mat, v in ((K, k), (C, c)):
            mat[a, a] += v
            mat[b, b] += v
            mat[a, b] -= v
            mat[b, a] -= v
    r = np.zeros(8)
    r[2], r[4] = g.rb1, -g.rb2
    K += k_mean * np.outer(r, r)
    C += mesh_damping(p, g, k_mean) * np.outer(r, r)
    C[0, 0] += p.c_speed
    Mi = np.diag(1.0 / J)
    A = np.block([[np.zeros((8, 8)), np.eye(8)], [-Mi @ K, -Mi @ C]])
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 1e-6]
    return sorted((float(abs(x) / (2 * math.pi)), float(-x.real / abs(x))) for x in lam)


@njit(cache=True)
def _rhs(t, y, dy, J, sp, drive, gp, ys, sdev, p1, p2, dmg, bdev, bk):
    """Time derivative of ``y = [phi(8), omega(8)]``; returns the elastic mesh force [N]."""
    rb1, rb2, t_ff, omega_set, c_speed, t_out, r_amp, r_order, r_phase, c_mesh, k_mean = (
        drive[0], drive[1], drive[2], drive[3], drive[4], drive[5], drive[6], drive[7], drive[8], drive[9], drive[10])
    tq = np.zeros(8)
    for i in range(sp.shape[0]):
        a = int(sp[i, 0])
        b = int(sp[i, 1])
        m = sp[i, 2] * (y[a] - y[b]) + sp[i, 3] * (y[8 + a] - y[8 + b])
        tq[a] -= m
        tq[b] += m
    delta = rb1 * y[2] - rb2 * y[4]
    ddot = rb1 * y[10] - rb2 * y[12]
    n = contacts(y[2], y[4], gp, ys, sdev, p1, p2, dmg, bdev, bk)
    f_el, k_act = force(delta, n, bdev, bk)
    f = f_el + c_mesh * (k_act / k_mean) * ddot
    if f < 0.0:
        f = 0.0
    tq[2] -= rb1 * f
    tq[4] += rb2 * f
    tq[0] += t_ff + c_speed * (omega_set - y[8])
    tq[7] -= t_out + r_amp * math.cos(r_order * y[7] + r_phase)
    for i in range(8):
        dy[i] = y[8 + i]
        dy[8 + i] = tq[i] / J[i]
    return f_el


@njit(cache=True)
def integrate(y0, h, n_steps, J, sp, drive, gp, ys, sdev, p1, p2, dmg):
    """Classical RK4 with fixed step ``h`` [s]; returns the states (n_steps+1, 16) and mesh force (n_steps+1,)."""
    nb = ys.size * 6
    bdev = np.empty(nb)
    bk = np.empty(nb)
    out = np.empty((n_steps + 1, 16))
    fm = np.empty(n_steps + 1)
    y = y0.copy()
    k1 = np.empty(16)
    k2 = np.empty(16)
    k3 = np.empty(16)
    k4 = np.empty(16)
    out[0] = y
    fm[0] = _rhs(0.0, y, k1, J, sp, drive, gp, ys, sdev, p1, p2, dmg, bdev, bk)
    for s in range(n_steps):
        t = s * h
        _rhs(t, y, k1, J, sp, drive, gp, ys, sdev, p1, p2, dmg, bdev, bk)
        _rhs(t + h / 2, y + h / 2 * k1, k2, J, sp, drive, gp, ys, sdev, p1, p2, dmg, bdev, bk)
        _rhs(t + h / 2, y + h / 2 * k2, k3, J, sp, drive, gp, ys, sdev, p1, p2, dmg, bdev, bk)
        _rhs(t + h, y + h * k3, k4, J, sp, drive, gp, ys, sdev, p1, p2, dmg, bdev, bk)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[s + 1] = y
        fm[s + 1] = _rhs(t + h, y, k1, J, sp, drive, gp, ys, sdev, p1, p2, dmg, bdev, bk)
    return out, fm


def static_start(p: RigParams, g: PairGeometry, m: MeshModel, phi1: float, omega_in: float,
                 torque_out: float) -> np.ndarray:
    """State at static equilibrium under the load, all nodes at constant speed, gear 1 at ``phi1``."""
    _, sp = lumped(p)
    t_ff = torque_out * g.rb1 / g.rb2
    dev, k = buffers(m)
    phi2_kin = phi1 * g.rb1 / g.rb2
    n = contacts(phi1, phi2_kin, *m.args(), dev, k)
    delta = solve_delta(torque_out / g.rb2, n, dev, k)
    phi2 = (g.rb1 * phi1 - delta) / g.rb2
    y = np.zeros(16)
    y[2], y[3], y[4], y[5] = phi1, phi1, phi2, phi2
    y[1] = phi1 + t_ff / sp[1, 2]
    y[0] = y[1] + t_ff / sp[0, 2]
    y[6] = phi2 - torque_out / sp[4, 2]
    y[7] = y[6] - torque_out / sp[5, 2]
    y[8:12] = omega_in
    y[12:16] = omega_in * g.rb1 / g.rb2
    return y
