"""Feasibility checks of a gear pair. Each failure names the config field and the value.

Raises :class:`gearrom.errors.GeometryError`; marginal cases warn with
:class:`gearrom.geometry.pair.GeometryWarning`.
"""
from __future__ import annotations

import math
import warnings

from gearrom.errors import GeometryError
from gearrom.geometry.pair import GearPair, GeometryWarning

#: Involute interference smaller than this fraction of m_n (roll length) only warns.
MARGINAL_INTERFERENCE = 0.1


def check_pair(pair: GearPair) -> None:
    """Run every feasibility check on ``pair``; raise on the first failure.

    Checks, in order: working centre distance against the profile shifts, diameters
    ordering (bore < root < base/tip), undercut, pointed tip, tip interference, involute
    (fillet) interference with the mating tip, contact ratio >= 1, tip relief start.
    """
    _check_center_distance(pair)
    for i, g in enumerate(pair.gears):
        _check_diameters(pair, i)
        _check_undercut(pair, i)
        _check_tip_thickness(pair, i)
    _check_interference(pair)
    _check_contact_ratio(pair)
    for i in range(2):
        _check_relief(pair, i)


def _check_center_distance(pair: GearPair) -> None:
    if pair.center_distance is None:
        return
    diff = pair.center_distance - pair.aw_from_shift
    if abs(diff) > pair.center_distance_tolerance:
        raise GeometryError(
            f"pair.center_distance_mm = {pair.center_distance * 1e3:.4f} is inconsistent with the profile shifts "
            f"x1 + x2 = {pair.gears[0].x + pair.gears[1].x:+.4f}, which give a_w = {pair.aw_from_shift * 1e3:.4f} mm "
            f"(difference {diff * 1e6:+.1f} um, tolerance {pair.center_distance_tolerance * 1e6:.1f} um)"
        )


def _check_diameters(pair: GearPair, i: int) -> None:
    g = pair.gears[i]
    da, df, d = pair.da[i], pair.df[i], pair.d[i]
    if not df < d < da:
        raise GeometryError(
            f"{g.name}: diameters must satisfy d_f < d < d_a, got root_diameter_mm = {df * 1e3:.4f}, "
            f"d = {d * 1e3:.4f}, tip_diameter_mm = {da * 1e3:.4f}"
        )
    if da <= pair.db[i]:
        raise GeometryError(f"{g.name}.tip_diameter_mm = {da * 1e3:.4f} lies inside the base circle {pair.db[i] * 1e3:.4f} mm")
    rim = 0.5 * (df - g.bore_diameter)
    if rim < pair.mn:
        raise GeometryError(
            f"{g.name}.bore_diameter_mm = {g.bore_diameter * 1e3:.3f} leaves a rim of {rim * 1e3:.3f} mm under the "
            f"root circle d_f = {df * 1e3:.3f} mm; at least one module ({pair.mn * 1e3:.3f} mm) is required"
        )


def _check_undercut(pair: GearPair, i: int) -> None:
    g = pair.gears[i]
    h_lin = pair.tool_addendum[i] - pair.tool_tip_radius[i] * (1 - math.sin(pair.alpha_n))
    limit = 0.5 * pair.d[i] * math.sin(pair.alpha_t) ** 2
    if h_lin - g.x * pair.mn > limit + 1e-12:
        x_min = (h_lin - limit) / pair.mn
        raise GeometryError(
            f"{g.name}: undercut; profile_shift = {g.x:+.4f} is below the minimum {x_min:+.4f} for "
            f"teeth = {g.z} with this rack tool (h_aP0 = {pair.tool_addendum[i] * 1e3:.3f} mm, "
            f"rho_aP0 = {pair.tool_tip_radius[i] * 1e3:.3f} mm)"
        )


def _check_tip_thickness(pair: GearPair, i: int) -> None:
    g = pair.gears[i]
    s_an = pair.s_an[i]
    limit = pair.min_tip_thickness_factor * pair.mn
    if s_an < limit:
        raise GeometryError(
            f"{g.name}: pointed tip; normal tip thickness {s_an * 1e3:.4f} mm at tip_diameter_mm = {pair.da[i] * 1e3:.4f} "
            f"(profile_shift = {g.x:+.4f}) is below {pair.min_tip_thickness_factor} m_n = {limit * 1e3:.4f} mm"
        )


def _check_interference(pair: GearPair) -> None:
    for i in range(2):
        g, mate = pair.gears[i], pair.gears[1 - i]
        roll_needed = pair.roll_start_active[i]
        if roll_needed <= 0:
            raise GeometryError(
                f"tip interference: {mate.name} tip (d_a = {pair.effective_tip_diameter[1 - i] * 1e3:.4f} mm) reaches "
                f"{-roll_needed * 1e3:.4f} mm beyond the interference point of {g.name} (below its base circle)"
            )
        roll_form = math.sqrt(max((0.5 * pair.dff[i]) ** 2 - pair.rb[i] ** 2, 0.0))
        overlap = roll_form - roll_needed
        if overlap <= 0:
            continue
        msg = (
            f"involute interference: {mate.name} tip (d_a = {pair.effective_tip_diameter[1 - i] * 1e3:.4f} mm) needs "
            f"{g.name}'s involute down to d = {pair.d_start_active[i] * 1e3:.4f} mm, but its root form circle is "
            f"d_Ff = {pair.dff[i] * 1e3:.4f} mm ({overlap * 1e3:.4f} mm of roll length in the fillet)"
        )
        if overlap > MARGINAL_INTERFERENCE * pair.mn:
            raise GeometryError(msg)
        warnings.warn(msg + "; marginal: a tip chamfer (tip_form_diameter_mm) or a root_form_diameter_mm "
                      "from the drawing usually resolves it", GeometryWarning, stacklevel=3)


def _check_contact_ratio(pair: GearPair) -> None:
    if pair.eps_gamma < 1.0 or pair.eps_alpha <= 0:
        raise GeometryError(
            f"contact ratio below 1: eps_alpha = {pair.eps_alpha:.4f}, eps_beta = {pair.eps_beta:.4f}, "
            f"eps_gamma = {pair.eps_gamma:.4f} (check tip_diameter_mm, addendum_coefficient, center_distance_mm)"
        )


def _check_relief(pair: GearPair, i: int) -> None:
    m = pair.gears[i].micro
    if m.tip_relief > 0 and m.tip_relief_start_diameter is not None:
        d0 = m.tip_relief_start_diameter
        if not pair.d_start_active[i] < d0 < pair.da[i]:
            raise GeometryError(
                f"{pair.gears[i].name}.microgeometry.tip_relief_start_diameter_mm = {d0 * 1e3:.3f} must lie between "
                f"the start of active profile {pair.d_start_active[i] * 1e3:.3f} mm and the tip {pair.da[i] * 1e3:.3f} mm"
            )
