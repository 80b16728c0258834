"""Hertz impact: an elastic sphere (Hex8) striking a rigid wall, contact duration vs Hertz theory.

Reference: quasi-static Hertz impact (Johnson, Contact Mechanics, 1985, eq. 11.24):
    t_c = 2.87 (m^2 / (R E*^2 V))^(1/5),   E* = E / (1 - nu^2) against a rigid frictionless wall,
which by symmetry is also the head-on impact of two identical spheres at relative speed 2 V. The
restitution is 1 (quasi-static, elastic). Here R = 10 mm, V = 3 m/s: contact radius a = 0.65 mm,
t_c = 42 us, about 12 times the wave transit time 2R/c, so the quasi-static assumption holds to ~1 %.

The quarter ball (symmetry planes x = 0 and y = 0) is meshed by a cube-to-sphere map graded to the
pole, the wall is a layer of fixed Hex8 elements, node-to-facet penalty contact (scale 3).
Refinement study (same set-up): t_FE / t_c = 1.040 at a/h = 3 (this test), 1.025 at a/h = 4.1,
converging from above (the faceted surface and the penalty compliance make the contact softer,
and a softer contact lasts longer). Tolerance: t_FE / t_c within [0.98, 1.06]; restitution > 0.99.
"""
from __future__ import annotations

import numpy as np

from gearrom.fe.explicit import ContactPair, ExplicitModel, Material, boundary_segments, prepare, solve
from gearrom.fe.explicit.meshes import grid_hex8, quarter_ball_hex8

R, V, H_POLE = 0.01, 3.0, 2.2e-4


def test_sphere_wall_impact_duration_vs_hertz():
    mat = Material()
    e_star = mat.E / (1 - mat.nu ** 2)
    gap = 1e-6
    ball, bel, surf = quarter_ball_hex8(R, 12, 18, H_POLE)
    m_full = mat.rho * 4 / 3 * np.pi * R ** 3
    delta = (15 * m_full * V ** 2 / (16 * e_star * np.sqrt(R))) ** 0.4
    a = np.sqrt(R * delta)
    wx = np.linspace(0, 3 * a, int(3 * a / H_POLE) + 1)
    wall, wel = grid_hex8(wx, wx, np.linspace(-R - gap - 4 * H_POLE, -R - gap, 3))
    nb = ball.shape[0]
    nodes = np.vstack([ball, wall])
    elements = np.vstack([bel, wel + nb])
    segs = boundary_segments(wel + nb)
    master = segs[np.abs(nodes[segs].mean(axis=1)[:, 2] + R + gap) < 1e-12]
    slave = surf[np.hypot(ball[surf, 0], ball[surf, 1]) < 2.5 * a]
    vel = np.zeros_like(nodes)
    vel[:nb, 2] = -V
    sym_x = np.nonzero(np.abs(nodes[:, 0]) < 1e-12)[0]
    sym_y = np.nonzero(np.abs(nodes[:, 1]) < 1e-12)[0]
    model = ExplicitModel(nodes, elements, mat,
                          node_sets={"slave": slave, "wall": nb + np.arange(wall.shape[0]),
                                     "sym_x": sym_x, "sym_y": sym_y},
                          surfaces={"wall": master}, contacts=(ContactPair("slave", "wall", penalty_scale=3.0),),
                          fixed={"wall": (0, 1, 2), "sym_x": (0,), "sym_y": (1,)}, initial_velocity=vel)
    d = prepare(model)
    mass = d["mass"][:nb]
    m = 4 * mass.sum()                      # the FE ball's own mass (quarter model)
    t_hertz = 2.87 * (m ** 2 / (R * e_star ** 2 * V)) ** 0.2
    res = solve(model, gap / V + 1.3 * t_hertz, sample_period=t_hertz / 400, prepared=d)
    touching = res.energy("contact") > 1e-9 * res.energy("kinetic")[0]
    duration = np.ptp(res.t[touching]) + (res.t[1] - res.t[0])
    rebound = (mass * res.v_final[:nb, 2]).sum() / mass.sum()
    assert 0.98 < duration / t_hertz < 1.06, duration / t_hertz
    assert rebound / V > 0.99
    assert res.energy_error < 1e-3
