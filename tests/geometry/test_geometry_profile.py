"""Generated tooth profiles: involute flank, trochoid fillet, tooth thickness, helical twist."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearrom.geometry.gear import Gear
from gearrom.geometry.pair import GearPair
from gearrom.geometry.profile import generated_points, sector_outline, tooth_profile, twist

MM = 1e-3


def _pairs(spur, helical):
    shifted = GearPair(  # positive and negative profile shift (x = +0.5 / -0.3), alpha = 20 deg
        2 * MM, math.radians(20), 0.0,
        (Gear("input_gear", 19, 20 * MM, 10 * MM, x=0.5), Gear("output_gear", 47, 20 * MM, 30 * MM, x=-0.3)),
    )
    return [spur.pair, helical.pair, shifted]


def _parametric_involute_angle(rb, r):
    """Polar angle of the classic parametric involute x = rb (sin t - t cos t), y = rb (cos t + t sin t)."""
    t = np.sqrt((r / rb) ** 2 - 1.0)
    return np.arctan2(rb * (np.cos(t) + t * np.sin(t)), rb * (np.sin(t) - t * np.cos(t)))


def test_generated_flank_lies_on_involute(spur, helical):
    """Envelope points of the straight tool flank vs the analytic involute (< 0.1 um)."""
    for p in _pairs(spur, helical):
        for i in range(2):
            pts, lab = generated_points(p, i)
            fl = pts[lab == 2]
            r = np.hypot(fl[:, 0], fl[:, 1])
            sel = (r > p.rb[i] * 1.0001) & (r < 0.5 * p.da[i])
            fl, r = fl[sel], r[sel]
            ang = np.arctan2(fl[:, 1], fl[:, 0])
            # the involute through the reference-circle point of this flank, shifted in angle
            inv_ang = _parametric_involute_angle(p.rb[i], r)
            off = ang - inv_ang
            dev = np.abs(off - np.median(off)) * r
            assert dev.max() < 0.1e-6


def test_profile_flank_points_on_involute(spur, helical):
    """The flank points of ToothProfile (both flanks) lie on the involute (< 0.1 um)."""
    for p in _pairs(spur, helical):
        for i in range(2):
            prof = tooth_profile(p, i)
            for side in (-1, 1):
                fl = prof.flank(side) * np.array([side * -1.0, 1.0])  # mirror right flank onto the left
                r = np.hypot(fl[:, 0], fl[:, 1])
                ang = np.arctan2(fl[:, 1], fl[:, 0]) - _parametric_involute_angle(p.rb[i], r)
                assert np.max(np.abs(ang - ang.mean()) * r) < 0.1e-6


def test_tooth_thickness_on_reference_circle(spur, helical):
    """Arc thickness at d equals s = m_t (pi/2 + 2 x tan alpha_n) (seed eq. 22, ISO 21771)."""
    for p in _pairs(spur, helical):
        for i in range(2):
            prof = tooth_profile(p, i, n_involute=2000)
            fl = prof.flank(-1)
            r = np.hypot(fl[:, 0], fl[:, 1])
            ang = np.arctan2(fl[:, 1], fl[:, 0])
            half = np.interp(0.5 * p.d[i], r, ang) - math.pi / 2
            s = 2 * half * 0.5 * p.d[i]
            x = p.gears[i].x
            expected = p.mt * (math.pi / 2 + 2 * x * math.tan(p.alpha_n))
            assert s == pytest.approx(expected, abs=1e-9)


def test_fillet_tangent_to_flank_and_reaches_root(spur, helical):
    """The trochoid joins the involute with a kink that vanishes with refinement (tangent
    continuity: first-order convergence of the polyline angle), and touches the root circle."""
    for p in _pairs(spur, helical):
        for i in range(2):
            kinks = []
            for n in (40, 400):
                prof = tooth_profile(p, i, n_fillet=n, n_involute=4 * n)
                left = prof.points[prof.side == -1]
                seg = prof.segment[prof.side == -1]
                k = int(np.where(seg == 2)[0][0])
                t1, t2 = left[k] - left[k - 1], left[k + 1] - left[k]
                kinks.append(math.degrees(math.acos(np.clip(t1 @ t2 / np.linalg.norm(t1) / np.linalg.norm(t2), -1, 1))))
            assert kinks[1] < 0.5 and kinks[1] < kinks[0] / 5
            r = np.hypot(*prof.points.T)
            assert r.min() == pytest.approx(0.5 * p.df[i], abs=1e-6)
            assert r.max() == pytest.approx(0.5 * p.da[i], abs=1e-9)


def test_form_circle_matches_pair_formula(spur):
    """Where the generated fillet meets the involute equals the analytic root form circle d_Ff."""
    p = spur.pair
    for i in range(2):
        assert 2 * tooth_profile(p, i).form_radius == pytest.approx(p.dff[i], abs=1e-9)


def test_outline_is_simple_and_symmetric(spur):
    p = spur.pair
    prof = tooth_profile(p, 0)
    pts = prof.points
    mirrored = pts[::-1] * np.array([-1.0, 1.0])
    assert np.allclose(pts, mirrored, atol=1e-12)
    sec = sector_outline(p, 0, 3)
    ang = np.unwrap(np.arctan2(sec[:, 1], sec[:, 0]))
    # the sector spans three pitches between the middles of the outer spaces, without repeated points
    assert ang[0] - ang[-1] == pytest.approx(3 * 2 * math.pi / p.z[0], rel=1e-9)
    assert np.min(np.hypot(*np.diff(sec, axis=0).T)) > 1e-9
    # polygon area of the sector (closed through the centre) = tooth material + root disk sector;
    # it must lie between the root-circle sector and the tip-circle sector
    closed = np.vstack([sec, [[0.0, 0.0]]])
    area = 0.5 * abs(np.dot(closed[:, 0], np.roll(closed[:, 1], 1)) - np.dot(closed[:, 1], np.roll(closed[:, 0], 1)))
    span = 3 * 2 * math.pi / p.z[0]
    assert 0.5 * span * (p.df[0] / 2) ** 2 < area < 0.5 * span * (p.da[0] / 2) ** 2


def test_helical_twist_follows_lead(helical):
    p = helical.pair
    zeta = 0.018
    assert twist(p, 0, zeta) == pytest.approx(2 * math.pi * zeta / p.lead[0])
    assert twist(p, 1, zeta) == pytest.approx(-2 * math.pi * zeta / p.lead[1])
    # arc at the reference circle per unit width = tan(beta) for both (opposite senses)
    assert abs(twist(p, 0, 1.0)) * p.d[0] / 2 == pytest.approx(math.tan(p.beta))
    assert abs(twist(p, 1, 1.0)) * p.d[1] / 2 == pytest.approx(math.tan(p.beta))


def test_tip_edge_rounding_is_tangent_to_flank_and_tip(spur, helical):
    """A 0.2 mm tip edge radius: the arc points lie at that radius from one centre, the outline stays
    inside the tip circle, and the polyline kinks at both junctions vanish with refinement."""
    for p in (spur.pair, helical.pair):
        kinks = []
        for n in (8, 80):
            prof = tooth_profile(p, 0, tip_edge_radius=0.2e-3, n_tip=n)
            left = prof.points[prof.side == -1]
            seg = prof.segment[prof.side == -1]
            k = int(np.where(seg == 3)[0][0])
            ang = []
            for j in range(k - 1, len(left) - 1):
                t1, t2 = left[j] - left[j - 1], left[j + 1] - left[j]
                ang.append(math.degrees(math.acos(np.clip(t1 @ t2 / np.linalg.norm(t1) / np.linalg.norm(t2), -1, 1))))
            kinks.append(max(ang))
            assert np.hypot(*prof.points.T).max() <= 0.5 * p.da[0] * (1 + 1e-9)
        assert kinks[1] < 1.0 and kinks[1] < kinks[0] / 5
