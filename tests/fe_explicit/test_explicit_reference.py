"""Rigid reference nodes (kinematic coupling of a bore) with torque, prescribed speed, lumped parts.

References (rigid-body dynamics of the annulus, J = rho t pi (Ro^4 - Ri^4) / 2 for the continuous
ring; the 48-sided polygonal mesh has 0.3 % less inertia, hence the 1 % tolerances):
* a constant torque T on a free ring: theta(t) = T t^2 / (2 J_total), J_total = J_ring + J_extra;
* torque step with a torsional spring k to ground: theta = T/k (1 - cos(w t)), w = sqrt(k / J_total)
  (the ring's own torsional modes are > 10 kHz, far above w / 2 pi ~ 100 Hz);
* prescribed speed through the cosine ramp: the body torque on the reference is the inertia torque
  of the un-tied part of the ring, -J_free * alpha(t), alpha = Omega pi / (2 T_r) sin(pi t / T_r);
* energy balance (kinetic + internal + spring = external work) within 0.1 %.
"""
from __future__ import annotations

import numpy as np
import pytest

from gearrom.fe.explicit import ExplicitModel, Material, RigidReference, solve
from gearrom.fe.explicit.meshes import annulus_q4

RI, RO, THK = 0.02, 0.04, 0.01
MAT = Material()
J_RING = MAT.rho * THK * np.pi * (RO ** 4 - RI ** 4) / 2


def _ring(ref: RigidReference) -> ExplicitModel:
    nodes, elements, inner, _ = annulus_q4(RI, RO, 3, 48)
    return ExplicitModel(nodes, elements, MAT, thickness=THK, node_sets={"bore": inner}, references=(ref,))


@pytest.mark.parametrize("j_extra", [0.0, J_RING])
def test_torque_accelerates_ring_and_extra_inertia(j_extra):
    torque = 50.0
    res = solve(_ring(RigidReference("bore", torque=torque, inertia=j_extra)), 4e-3, sample_period=1e-4)
    expected = torque * res.t[-1] ** 2 / (2 * (J_RING + j_extra))
    assert abs(res.theta[-1, 0] / expected - 1) < 0.01
    assert res.energy_error < 1e-3


def test_torsional_spring_frequency():
    torque, j_extra = 20.0, 20 * J_RING
    j_tot = J_RING + j_extra
    k = j_tot * (2 * np.pi * 100.0) ** 2
    res = solve(_ring(RigidReference("bore", torque=torque, inertia=j_extra, spring_k=k)), 0.025,
                sample_period=2e-5)
    y = res.theta[:, 0] - torque / k
    i = np.nonzero(y[:-1] * y[1:] < 0)[0]
    zc = res.t[i] - y[i] * (res.t[i + 1] - res.t[i]) / (y[i + 1] - y[i])
    f = 0.5 * (len(zc) - 1) / (zc[-1] - zc[0])
    assert abs(f / (np.sqrt(k / j_tot) / (2 * np.pi)) - 1) < 0.01
    assert abs(np.ptp(res.theta[:, 0]) / (2 * torque / k) - 1) < 0.01
    assert res.energy_error < 1e-3


def test_prescribed_speed_ramp_reaction():
    omega, t_ramp = 100.0, 2e-3
    model = _ring(RigidReference("bore", speed=omega, ramp_time=t_ramp))
    res = solve(model, 3e-3, sample_period=2.5e-5)
    t = res.t
    alpha = np.where(t < t_ramp, omega * np.pi / (2 * t_ramp) * np.sin(np.pi * t / t_ramp), 0.0)
    inner = model.node_sets["bore"]
    from gearrom.fe.explicit import prepare

    mass = prepare(model)["mass"]
    j_tied = (mass[inner] * (model.nodes[inner] ** 2).sum(axis=1)).sum()
    expected = -(J_RING - j_tied) * alpha
    peak = np.abs(expected).max()
    assert np.abs(res.torque_body[:, 0] - expected).max() < 0.03 * peak
    assert abs(res.omega[-1, 0] - omega) < 1e-9
    assert abs(res.theta[-1, 0] - omega * (t[-1] - t_ramp / 2)) < 1e-9
    assert res.energy_error < 1e-3


def test_driver_through_torsional_spring():
    """Speed-driven driver + spring-damper + inertia (a drivetrain part): steady state
    omega = Omega and spring wind-up theta - theta_driver = T / k (statics of the spring)."""
    omega, torque, j_extra = 50.0, 10.0, 20 * J_RING
    j_tot = J_RING + j_extra
    k = j_tot * (2 * np.pi * 200.0) ** 2
    c = 2 * 0.7 * np.sqrt(k * j_tot)                        # 70 % of critical damping
    ref = RigidReference("bore", speed=omega, ramp_time=2e-3, torque=torque, inertia=j_extra,
                         spring_k=k, spring_c=c)
    res = solve(_ring(ref), 0.012, sample_period=5e-5)
    t = res.t[-1]
    theta_driver = omega * (t - 2e-3 / 2)
    assert abs(res.omega[-1, 0] / omega - 1) < 1e-3
    assert abs((res.theta[-1, 0] - theta_driver) / (torque / k) - 1) < 0.01
    assert res.energy_error < 1e-3


def test_hex8_ring_torque_about_z():
    """3D: a Hex8 ring (the annulus extruded by 10 mm) tied at the bore to a reference rotating
    about z: theta = T t^2 / (2 J), J = rho h pi (Ro^4 - Ri^4) / 2 (1 %, polygonal mesh)."""
    nodes2, quads, inner, _ = annulus_q4(RI, RO, 3, 48)
    h, nl = 0.01, 2
    n2 = nodes2.shape[0]
    nodes = np.vstack([np.column_stack([nodes2, np.full(n2, z)]) for z in np.linspace(0, h, nl + 1)])
    elements = np.vstack([np.hstack([quads + k * n2, quads + (k + 1) * n2]) for k in range(nl)])
    bore = np.concatenate([inner + k * n2 for k in range(nl + 1)])
    torque = 50.0
    model = ExplicitModel(nodes, elements, MAT, node_sets={"bore": bore},
                          references=(RigidReference("bore", torque=torque),))
    res = solve(model, 4e-3, sample_period=1e-4)
    j = MAT.rho * h * np.pi * (RO ** 4 - RI ** 4) / 2
    assert abs(res.theta[-1, 0] / (torque * res.t[-1] ** 2 / (2 * j)) - 1) < 0.01
    assert res.energy_error < 1e-3
