"""Flexible gear bodies (rim on hub) of the validation ROM: the body model against the analytic in-plane torsion
of an annulus, the table with the bodies' compliance taken out, and the pair Drivetrain with bodies against the
rigid one in the limits where they must agree."""
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.special import jv, yv

from gearrom.errors import ModelError
from gearrom.excitation.analytical import analytical_excitation
from gearrom.fe.bodies import GearBody, gear_body, without_body_compliance
from gearrom.fe.explicit.meshes import annulus_q4
from gearrom.validation.compare import steady_window, te_metrics
from gearrom.validation.pair_exudyn import mesh_mode, pair_drivetrain, simulate_pair_exudyn
from gearrom.validation.pair_rom import PairRomSetup

R_IN, R_OUT, WIDTH, E, NU, RHO = 0.01, 0.04, 0.02, 210e9, 0.3, 7850.0


def annulus_torsion():
    """First in-plane torsional mode of an annulus clamped at R_IN, free at R_OUT (u_theta only, shear wave
    speed c_s = sqrt(G / rho)): u = J1(k r) + B Y1(k r) with u(R_IN) = 0 and the free-edge shear stress
    G (u' - u / r) = -G k (J2 + B Y2) = 0 at R_OUT. Returns the frequency [Hz] and the mode's effective inertia
    (int rho b u r dA)^2 / int rho b u^2 dA [kg m^2]."""
    cs = math.sqrt(E / (2 * (1 + NU)) / RHO)

    def det(k):
        return jv(1, k * R_IN) * yv(2, k * R_OUT) - yv(1, k * R_IN) * jv(2, k * R_OUT)

    ks = np.linspace(1.0, 400.0, 4000)
    v = det(ks)
    i = int(np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:]))[0])
    k = brentq(det, ks[i], ks[i + 1])

    def u(r):
        return jv(1, k * r) - jv(1, k * R_IN) / yv(1, k * R_IN) * yv(1, k * r)

    num = quad(lambda r: RHO * WIDTH * u(r) * r * 2 * math.pi * r, R_IN, R_OUT)[0]
    den = quad(lambda r: RHO * WIDTH * u(r) ** 2 * 2 * math.pi * r, R_IN, R_OUT)[0]
    return k * cs / (2 * math.pi), num ** 2 / den


def test_gear_body_of_an_annulus_against_bessel_solution():
    """The body model's mode and rim inertia converge to the analytic annulus torsion at second order (Q4): within
    0.3 % at 12 x 96 elements and four times closer at twice the density; the inertia is the mesh's exactly."""
    f_ref, j_ref = annulus_torsion()
    err = []
    for nr, nt in ((12, 96), (24, 192)):
        nodes, quads, inner, _ = annulus_q4(R_IN, R_OUT, nr, nt)
        body = gear_body(nodes, quads, inner, WIDTH, E=E, nu=NU, density=RHO)
        err.append((body.frequency / f_ref - 1, body.rim_inertia / j_ref - 1))
        phi = 2 * math.pi / nt      # the mesh is two regular nt-gons: a triangle of legs R and apex angle phi
        j_mesh = RHO * WIDTH * nt * math.sin(phi) * (2 + math.cos(phi)) / 12 * (R_OUT ** 4 - R_IN ** 4)
        assert body.inertia == pytest.approx(j_mesh, rel=1e-9)
    assert abs(err[0][0]) < 3e-3 and abs(err[0][1]) < 3e-3
    assert 3.5 < err[0][0] / err[1][0] < 4.5 and 3.5 < err[0][1] / err[1][1] < 4.5


def test_table_without_body_compliance(spur):
    """Taking the bodies out keeps the kinematic TE and lowers each torque's static TE by F c, c = sum rb^2 / k."""
    pair = spur.pair
    ex = analytical_excitation(pair, [60.0, 120.0, 180.0])
    bodies = (GearBody(5e-5, 4e-5, 1.5e7, 9.7e4), GearBody(1.8e-4, 1.65e-4, 1.0e7, 4.0e4))
    out = without_body_compliance(ex, bodies, pair.rb)
    c = pair.rb[0] ** 2 / 1.5e7 + pair.rb[1] ** 2 / 1.0e7
    F = ex.torque[:, None] / pair.rb[1]
    assert np.allclose(out.e, ex.e - F * c, rtol=0, atol=1e-15)
    assert np.allclose(out.e - F / out.k, ex.e - F / ex.k, rtol=0, atol=1e-15)
    with pytest.raises(ModelError, match="exceeds the mesh table"):
        without_body_compliance(ex, (GearBody(5e-5, 4e-5, 1.0, 1.0), bodies[1]), pair.rb)


def test_body_drivetrain_limits(spur):
    """With very stiff bodies the Drivetrain with bodies has the rigid model's mesh mode (within 0.1 %), its
    mesh-mode damping ratio is the target, and its steady TE between the hubs is the rigid model's; with the
    measured-size bodies of the thesis spur gears the mesh mode rises above the rigid model's (the rim inertia
    sits in front of the body compliance the table counts)."""
    pair = spur.pair
    torque, rpm, zeta = 120.0, 2000.0, 0.02
    ex = analytical_excitation(pair, [torque])
    j2 = pair.blank_inertia(1)[1]
    j1 = pair.blank_inertia(0)[1]
    setup = PairRomSetup(rpm_in=rpm, torque_out=torque, inertia_out=j2, damping_ratio=zeta)
    rigid = pair_drivetrain(pair, ex, setup)
    _, f_rigid = mesh_mode(rigid, torque)
    stiff = (GearBody(j1, 0.8 * j1, 1e12, 1e6), GearBody(j2, 0.93 * j2, 1e12, 1e6))
    model = pair_drivetrain(pair, ex, setup, bodies=stiff)
    ratio, f_stiff = mesh_mode(model, torque)
    assert f_stiff == pytest.approx(f_rigid, rel=1e-3) and ratio == pytest.approx(zeta, rel=1e-3)
    f_mesh = rpm / 60 * pair.z[0]
    t_end, sp = 0.02, 1.0 / (128 * f_mesh)
    runs = [simulate_pair_exudyn(pair, ex, setup, t_end, sp, model=m) for m in (rigid, model)]
    metrics = []
    for r in runs:
        w = steady_window(r.theta_in, r.t, t_end - 8 / f_mesh - 0.5 * sp, pair.z[0])
        metrics.append(te_metrics(r.theta_in[w], r.te[w], pair.z[0]))
    assert metrics[1]["te_mean_um"] == pytest.approx(metrics[0]["te_mean_um"], rel=1e-4)
    assert metrics[1]["gmf1_amplitude_um"] == pytest.approx(metrics[0]["gmf1_amplitude_um"], rel=2e-2)
    soft = (GearBody(j1, 0.8 * j1, 1.5e7, 9.7e4), GearBody(j2, 0.93 * j2, 1.0e7, 4.0e4))
    _, f_soft = mesh_mode(pair_drivetrain(pair, ex, setup, bodies=soft), torque)
    assert f_soft > 1.005 * f_rigid
