"""Coarse but real explicit run of the seed's spur pair (2000 rpm, 120 Nm) and the mesh helpers.

References:
* kinematics (law of gearing): the base circles of meshing involute gears have equal line-of-action
  speeds, rb1 w1 = -rb2 w2; the elastic TE rate is small against it (checked within 3 %);
* statics of the output rotor: the torque is ramped over 0.3 ms, two periods of the torsional
  mesh mode (~6.7 kHz), so after the ramp the tooth torque on the output reference balances the
  applied 120 Nm (checked within 10 %, the residual oscillation);
* mean TE vs the ISO 6336-1 method B mesh stiffness (reference-values.md: c_gamma_alpha ~ 20.6
  N/(mm um), i.e. ~370 N/um for b = 18 mm), TE ~ F_bt / (c_gamma_alpha b) ~ 11 um. ISO is a
  +-20 % anchor and this mesh is coarse (0.3 mm flank elements against a 0.1 mm Hertz half-width,
  plus the penalty compliance), which makes the pair softer: accepted band 0.8 ... 1.6 x ISO;
* no initial overclosure (Abaqus/Explicit check): zero contact energy at t = 0;
* splitting triangles into quads preserves the area exactly and yields counter-clockwise quads.
"""
from __future__ import annotations

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.fe.explicit.gearmesh import gear_quad_mesh
from gearrom.fe.explicit.gearpair import GearPairSetup, run_gear_pair, triangles_to_quads
from gearrom.fe.explicit.geometry import element_geometry


def _iso_c_gamma_alpha(z1: int, z2: int, eps_alpha: float, hfp_over_mn: float = 1.25,
                       alpha_n_deg: float = 17.0) -> float:
    """ISO 6336-1 method B c_gamma_alpha for x1 = x2 = 0, spur, solid blanks [N/(mm um)]."""
    q = 0.04723 + 0.15551 / z1 + 0.25791 / z2
    c_b = (1 + 0.5 * (1.2 - hfp_over_mn)) * (1 - 0.02 * (20 - alpha_n_deg))
    c_prime = 1 / q * 0.8 * 1.0 * c_b
    return c_prime * (0.75 * eps_alpha + 0.25)


@pytest.fixture(scope="module")
def run():
    pair = load_config("thesis-spur").pair
    meshes = [gear_quad_mesh(pair, i, 0.3e-3, 2e-3) for i in (0, 1)]
    setup = GearPairSetup(rpm_in=2000.0, torque_out=120.0, torque_ramp_time=0.3e-3)
    res, te, info = run_gear_pair(pair, meshes, setup, t_end=0.4e-3, sample_period=2e-6)
    return pair, res, te, info


def test_gear_pair_kinematics_and_load(run):
    pair, res, te, info = run
    assert res.energy("contact")[0] == 0.0
    rb1, rb2 = pair.rb
    mismatch = (rb1 * res.omega[:, 0] + rb2 * res.omega[:, 1]) / (rb1 * res.omega[:, 0])
    assert np.abs(mismatch).max() < 0.03
    loaded = res.t >= 0.3e-3
    assert abs(np.mean(res.torque_body[loaded, 1]) / -120.0 - 1) < 0.10


def test_gear_pair_mean_te_vs_iso_stiffness(run):
    pair, res, te, info = run
    c_ga = _iso_c_gamma_alpha(*pair.z, pair.eps_alpha)          # N/(mm um)
    k_mesh = c_ga * pair.gears[0].face_width * 1e3 * 1e6          # N/m
    te_iso = 120.0 / pair.rb[1] / k_mesh
    loaded = res.t >= 0.3e-3
    ratio = np.mean(te[loaded]) / te_iso
    assert 0.8 < ratio < 1.6, ratio


def test_triangles_to_quads_area_and_orientation():
    rng = np.random.default_rng(0)
    pts = rng.random((40, 2))
    from scipy.spatial import Delaunay

    tri = Delaunay(pts).simplices
    p = pts[tri]
    area = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                  - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    tri[area < 0] = tri[area < 0][:, ::-1]
    nodes, quads, _ = triangles_to_quads(pts, tri)
    _, vol, _, _ = element_geometry(nodes, quads)       # raises on inverted quads
    assert abs(vol.sum() - np.abs(area).sum()) < 1e-12
    assert quads.shape[0] == 3 * tri.shape[0]
