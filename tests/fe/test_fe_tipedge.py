"""Geometry of the rounded tip edge contact (gearrom.fe.tipedge and the LTCA's edge candidates).

References: the tip edge arc of gearrom.geometry.profile.tooth_profile (found there by root finding,
here in closed form), brute-force distances to a densely sampled involute, and a finite difference
of the exact gap under an explicit rigid rotation of the output gear (for the lever-arm factor).
No FE solve.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.fe.tipedge import DEFAULT_TIP_EDGE_RADIUS_MODULES, FlankArc, InvoluteFrame, tip_edge_radius
from gearrom.geometry.profile import tooth_profile

RHO = 0.15e-3


@pytest.fixture(scope="module")
def pair():
    return load_config("thesis-spur").pair


def test_default_radius_is_documented_fraction_of_module(pair):
    assert pair.gears[0].tip_edge_radius == 0  # the config gives none
    rho, source = tip_edge_radius(pair, 0)
    assert source == "default" and rho == pytest.approx(DEFAULT_TIP_EDGE_RADIUS_MODULES * 1.5e-3)
    assert 0.1e-3 <= rho <= 0.2e-3  # drawing practice band


@pytest.mark.parametrize("i", [0, 1])
def test_arc_matches_profile_generator(pair, i):
    arc = FlankArc.of(pair, i, RHO)
    prof = tooth_profile(pair, i, tip_edge_radius=RHO, n_tip=400)
    assert arc.L_t == pytest.approx(np.nanmax(prof.roll), rel=1e-8)  # profile: brentq on the tangency
    left = prof.side < 0
    ra = 0.5 * pair.da[i]
    tip = prof.points[left & (prof.segment == 3)]  # the rounding, then the tip circle arc
    last = int(np.argmax(np.hypot(*tip.T) >= ra * (1 - 1e-9)))  # where the rounding meets the tip circle
    edge = tip[:last + 1]
    start = prof.points[left & (prof.segment == 2)][-1]
    poly = np.vstack([start, edge])
    length = np.hypot(*np.diff(poly, axis=0).T).sum()
    assert arc.u_end - arc.u_t == pytest.approx(length, rel=2e-4)  # arc length rho * phi_full
    assert float(arc.radius(arc.u_end)) == pytest.approx(ra, rel=1e-12)
    r = np.hypot(*edge[:-1].T)
    np.testing.assert_allclose(arc.radius(arc.u_of_radius(r)), r, rtol=1e-9)


def test_involute_projection_matches_brute_force(pair):
    rb = pair.rb[0]
    frame = InvoluteFrame((0.0, -rb), rb, (0.0, 1.0), (1.0, 0.0), 6e-3)
    L = np.linspace(2e-3, 11e-3, 200001)
    u, e = frame.basis(L)
    curve = frame.o + rb * u + L[:, None] * e
    assert np.allclose(np.hypot(*(curve - frame.o).T), np.hypot(rb, L))  # involute radius
    u0, e0 = frame.basis(np.array([6e-3]))
    np.testing.assert_allclose(frame.o + rb * u0[0] + 6e-3 * e0[0], [6e-3, 0.0], atol=1e-15)
    rng = np.random.default_rng(1)
    q = np.column_stack([rng.uniform(4e-3, 8e-3, 20), rng.uniform(-0.3e-3, 0.3e-3, 20)])
    d, Lf, n = frame.project(q)
    for k in range(q.shape[0]):
        dist = np.hypot(*(curve - q[k]).T)
        j = np.argmin(dist)
        side = np.sign((q[k] - curve[j]) @ e[j])
        assert d[k] == pytest.approx(side * dist[j], abs=2e-10)
        assert Lf[k] == pytest.approx(L[j], abs=1e-7)


def test_lever_arm_factor_is_the_gap_rate_under_output_rotation(pair):
    """lambda = d(gap)/d(approach): rotate the output gear's rounding about its centre by -delta/r_b2."""
    from gearrom.fe.ltca import SpurLTCA

    ltca = object.__new__(SpurLTCA)  # geometry only: no compliances needed for _frames
    ltca.c = tuple(type("C", (), {"rb": rb})() for rb in pair.rb)
    ltca.T = pair.aw * math.sin(pair.alpha_wt)
    arc = FlankArc.of(pair, 1, RHO)
    L1P = pair.roll_start_active[0] - 0.15e-3  # before the nominal start: the rounding meets the flank
    f1, f2 = ltca._frames(L1P, ltca.T - L1P)
    phi = np.linspace(0.02, 0.5, 9)
    q = f2.arc_points(arc, phi)
    d0, _, n = f1.project(q)
    r = q - f2.o
    lam = (-r[:, 1] * n[:, 0] + r[:, 0] * n[:, 1]) / pair.rb[1]
    delta = 1e-9
    eps = -delta / pair.rb[1]
    R = np.array([[math.cos(eps), -math.sin(eps)], [math.sin(eps), math.cos(eps)]])
    d1, _, _ = f1.project(f2.o + r @ R.T)
    np.testing.assert_allclose((d0 - d1) / delta, lam, rtol=1e-4)
    assert np.all(lam < 1.0) and np.all(lam > 0.5)  # off the line of action: a shorter lever arm
