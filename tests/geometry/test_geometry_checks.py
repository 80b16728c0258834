"""Each feasibility error is triggered by a real (mis)design and names the field and value."""
from __future__ import annotations

import math
import warnings

import pytest

from gearrom.errors import ConfigError, GeometryError
from gearrom.geometry.checks import check_pair
from gearrom.geometry.gear import Gear, MicroGeometry, RackTool
from gearrom.geometry.pair import GearPair, GeometryWarning

MM = 1e-3


def pair(z1, z2, x1=0.0, x2=0.0, alpha=20.0, g1=None, g2=None, **kw):
    a = dict(face_width=20 * MM, bore_diameter=5 * MM, x=x1)
    a.update(g1 or {})
    b = dict(face_width=20 * MM, bore_diameter=10 * MM, x=x2)
    b.update(g2 or {})
    return GearPair(2 * MM, math.radians(alpha), 0.0, (Gear("input_gear", z1, **a), Gear("output_gear", z2, **b)), **kw)


def test_undercut_small_pinion_without_shift():
    """z = 10 at 20 deg with the standard rack undercuts (classic limit z_min ~ 17; x_min = 0.415
    with the 0.38 m tip radius)."""
    with pytest.raises(GeometryError, match=r"input_gear: undercut; profile_shift = \+0.0000 .* minimum \+0.41"):
        check_pair(pair(10, 40))


def test_pointed_tip_from_large_positive_shift():
    with pytest.raises(GeometryError, match=r"input_gear: pointed tip; .*profile_shift = \+1.2000"):
        check_pair(pair(14, 40, x1=1.2))


def test_tip_interference_wheel_tip_beyond_interference_point():
    """Stub-dedendum pinion z = 10 (no undercut) against a positively shifted 120-tooth wheel:
    the wheel tip passes the pinion's interference point T1."""
    with pytest.raises(GeometryError, match=r"tip interference: output_gear tip \(d_a = 245.9\d+ mm\) reaches"):
        check_pair(pair(10, 120, alpha=25, x2=0.5, g1=dict(dedendum_coefficient=1.0)))


def test_involute_interference_with_short_tool():
    """A short tool (h_f* = 1.1) with a large tip radius ends the pinion involute above the start of
    active profile needed by the mating tip: the wheel tip would run in the fillet."""
    p = pair(20, 60, g1=dict(dedendum_coefficient=1.1, tool=RackTool(tip_radius=0.8 * MM)))
    with pytest.raises(GeometryError, match=r"involute interference: output_gear tip .* d_Ff = 37.78\d+ mm"):
        check_pair(p)


def test_marginal_interference_only_warns(helical):
    """The drawing pair without its tip chamfer is marginal by < 0.1 mm of roll: a warning, not an error."""
    with pytest.warns(GeometryWarning, match="involute interference: output_gear tip"):
        check_pair(helical.pair)


def test_contact_ratio_below_one():
    p = pair(30, 40, g1=dict(tip_diameter=61.0 * MM), g2=dict(tip_diameter=81.0 * MM))
    with pytest.raises(GeometryError, match=r"contact ratio below 1: eps_alpha = 0.47"):
        check_pair(p)


def test_center_distance_inconsistent_with_shifts():
    with pytest.raises(GeometryError, match=r"pair.center_distance_mm = 70.3000 .* a_w = 70.0000 mm"):
        check_pair(pair(30, 40, center_distance=70.3 * MM))


def test_bore_too_large_for_rim():
    with pytest.raises(GeometryError, match=r"input_gear.bore_diameter_mm = 54.000 leaves a rim of 0.500 mm"):
        check_pair(pair(30, 40, g1=dict(bore_diameter=54 * MM)))


def test_tip_relief_start_outside_active_profile():
    micro = MicroGeometry(tip_relief=10e-6, tip_relief_start_diameter=50 * MM)
    with pytest.raises(GeometryError, match=r"input_gear.microgeometry.tip_relief_start_diameter_mm = 50.000"):
        check_pair(pair(30, 40, g1=dict(micro=micro)))


@pytest.mark.parametrize(
    "field, kwargs, pattern",
    [
        ("face_width", dict(face_width=0.0), r"input_gear.face_width_mm must be a positive"),
        ("bore", dict(bore_diameter=-1 * MM), r"input_gear.bore_diameter_mm must be a positive"),
        ("teeth", dict(), r"input_gear.teeth must be an integer in \[5, 1000\], got 3"),
    ],
)
def test_non_positive_sizes(field, kwargs, pattern):
    base = dict(face_width=20 * MM, bore_diameter=5 * MM)
    base.update(kwargs)
    with pytest.raises(ConfigError, match=pattern):
        Gear("input_gear", 3 if field == "teeth" else 20, **base)


def test_clean_pair_passes_silently(spur):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_pair(spur.pair)
