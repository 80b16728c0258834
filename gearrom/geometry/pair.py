"""Cylindrical gear pair geometry per ISO 21771 / DIN 3960 (external, spur or helical).

All quantities are SI (m, rad). Index 0 is the input (driving) gear, index 1 the output gear.
The references are ISO 21771:2007 sections 4-5 and DIN 3960:1987; formula numbers in the
comments refer to the seed thesis (eqs. 5-36) where it uses the same ones.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from gearrom.errors import ConfigError, GeometryError
from gearrom.geometry.gear import Gear


class GeometryWarning(UserWarning):
    """A geometry is feasible but marginal (for example a near-interference)."""


def inv(alpha: float | np.ndarray) -> float | np.ndarray:
    """Involute function inv(alpha) = tan(alpha) - alpha."""
    return np.tan(alpha) - alpha


def inv_inverse(value: float) -> float:
    """Solve inv(alpha) = value for alpha in [0, pi/2) (Newton, 1e-15 rad)."""
    if value < 0:
        raise GeometryError(f"involute function value {value!r} is negative: no pressure angle exists")
    alpha = (3.0 * value) ** (1.0 / 3.0) if value < 0.3 else 1.0
    for _ in range(60):
        t = math.tan(alpha)
        step = (t - alpha - value) / (t * t)
        alpha -= step
        alpha = min(max(alpha, 1e-12), math.pi / 2 - 1e-9)
        if abs(step) < 1e-15:
            break
    return alpha


@dataclass(frozen=True)
class GearPair:
    """An external cylindrical gear pair and its derived geometry.

    Parameters
    ----------
    normal_module : float
        m_n [m].
    normal_pressure_angle : float
        alpha_n [rad].
    helix_angle : float
        beta [rad], 0 for spur gears.
    gears : tuple of Gear
        (input gear, output gear).
    center_distance : float or None
        Given working centre distance a_w [m]; checked against the profile shifts.
    center_distance_tolerance : float
        Allowed |a_w(given) - a_w(from x1 + x2)| [m].
    min_tip_thickness_factor : float
        Smallest normal tip thickness as a multiple of m_n (pointed-tip check).
    """

    normal_module: float
    normal_pressure_angle: float
    helix_angle: float
    gears: tuple[Gear, Gear]
    center_distance: float | None = None
    center_distance_tolerance: float = 10e-6
    min_tip_thickness_factor: float = 0.2

    def __post_init__(self) -> None:
        if not (self.normal_module > 0 and math.isfinite(self.normal_module)):
            raise ConfigError(f"pair.normal_module_mm must be positive, got {self.normal_module * 1e3!r}")
        if not 0 < self.normal_pressure_angle < math.radians(45):
            raise ConfigError(
                f"pair.normal_pressure_angle_deg must lie in (0, 45), got {math.degrees(self.normal_pressure_angle)!r}"
            )
        if not 0 <= self.helix_angle < math.radians(60):
            raise ConfigError(f"pair.helix_angle_deg must lie in [0, 60), got {math.degrees(self.helix_angle)!r}")
        g1, g2 = self.gears
        if self.helix_angle == 0:
            if g1.hand != "spur" or g2.hand != "spur":
                raise ConfigError("pair.helix_angle_deg is 0 but a gear hand is not 'spur'")
        else:
            if {g1.hand, g2.hand} != {"right", "left"}:
                raise ConfigError(
                    f"external helical gears need opposite hands: input_gear.hand={g1.hand!r}, "
                    f"output_gear.hand={g2.hand!r}"
                )
        if self.center_distance is not None and not self.center_distance > 0:
            raise ConfigError(f"pair.center_distance_mm must be positive, got {self.center_distance * 1e3!r}")

    # ------------------------------------------------------------------ basic
    @property
    def is_helical(self) -> bool:
        return self.helix_angle > 0

    @property
    def z(self) -> tuple[int, int]:
        return (self.gears[0].z, self.gears[1].z)

    @property
    def ratio(self) -> float:
        """Gear ratio u = z2 / z1 (eq. 5)."""
        return self.gears[1].z / self.gears[0].z

    @property
    def mn(self) -> float:
        return self.normal_module

    @property
    def alpha_n(self) -> float:
        return self.normal_pressure_angle

    @property
    def beta(self) -> float:
        return self.helix_angle

    @cached_property
    def mt(self) -> float:
        """Transverse module m_t = m_n / cos(beta) [m]."""
        return self.mn / math.cos(self.beta)

    @cached_property
    def alpha_t(self) -> float:
        """Transverse pressure angle, tan(alpha_t) = tan(alpha_n)/cos(beta) (eq. 33) [rad]."""
        return math.atan(math.tan(self.alpha_n) / math.cos(self.beta))

    @cached_property
    def beta_b(self) -> float:
        """Base helix angle, sin(beta_b) = sin(beta) cos(alpha_n) [rad]."""
        return math.asin(math.sin(self.beta) * math.cos(self.alpha_n))

    @cached_property
    def d(self) -> tuple[float, float]:
        """Reference (pitch) diameters d = z m_t (eq. 6) [m]."""
        return tuple(g.z * self.mt for g in self.gears)

    @cached_property
    def db(self) -> tuple[float, float]:
        """Base diameters d_b = d cos(alpha_t) (eq. 7) [m]."""
        return tuple(d * math.cos(self.alpha_t) for d in self.d)

    @property
    def rb(self) -> tuple[float, float]:
        """Base radii [m]."""
        return tuple(0.5 * v for v in self.db)

    @cached_property
    def a(self) -> float:
        """Reference centre distance a = (d1 + d2)/2 (eq. 8) [m]."""
        return 0.5 * (self.d[0] + self.d[1])

    @cached_property
    def alpha_wt_from_shift(self) -> float:
        """Working transverse pressure angle from the profile shifts (eq. 34) [rad]."""
        x1, x2 = (g.x for g in self.gears)
        z1, z2 = self.z
        return inv_inverse(float(inv(self.alpha_t)) + 2.0 * math.tan(self.alpha_n) * (x1 + x2) / (z1 + z2))

    @cached_property
    def aw_from_shift(self) -> float:
        """Zero-backlash working centre distance from the profile shifts (eq. 11) [m]."""
        return self.a * math.cos(self.alpha_t) / math.cos(self.alpha_wt_from_shift)

    @cached_property
    def aw(self) -> float:
        """Working centre distance [m]: the given one, else the zero-backlash one."""
        return self.center_distance if self.center_distance is not None else self.aw_from_shift

    @cached_property
    def alpha_wt(self) -> float:
        """Working transverse pressure angle at a_w [rad]."""
        c = self.a * math.cos(self.alpha_t) / self.aw
        if not -1 < c < 1:
            raise GeometryError(f"pair.center_distance_mm={self.aw * 1e3:.4f} is smaller than the base radii allow")
        return math.acos(c)

    @cached_property
    def y(self) -> float:
        """Centre distance modification coefficient y = (a_w - a)/m_n (eq. 35) [-]."""
        return (self.aw - self.a) / self.mn

    @cached_property
    def dw(self) -> tuple[float, float]:
        """Working pitch diameters d_w = 2 a_w z_i/(z1 + z2) (eq. 10) [m]."""
        z1, z2 = self.z
        return (2 * self.aw * z1 / (z1 + z2), 2 * self.aw * z2 / (z1 + z2))

    # -------------------------------------------------------------- diameters
    @cached_property
    def tip_shortening(self) -> float:
        """Tip alteration k m_n = a_w - a - (x1 + x2) m_n when negative, else 0 [m] (DIN 3960)."""
        k = self.aw - self.a - (self.gears[0].x + self.gears[1].x) * self.mn
        return min(k, 0.0)

    @cached_property
    def da(self) -> tuple[float, float]:
        """Tip diameters [m]: as given, else d + 2 m_n (h_a* + x) + 2 k m_n (eqs. 13-17)."""
        out = []
        for g, d in zip(self.gears, self.d):
            if g.tip_diameter is not None:
                out.append(g.tip_diameter)
            else:
                out.append(d + 2 * self.mn * (g.addendum_coefficient + g.x) + 2 * self.tip_shortening)
        return tuple(out)

    @cached_property
    def df(self) -> tuple[float, float]:
        """Root diameters [m]: as given, else from the tool addendum, else d - 2 m_n (h_f* - x) (eq. 18)."""
        out = []
        for g, d in zip(self.gears, self.d):
            if g.root_diameter is not None:
                out.append(g.root_diameter)
            elif g.tool.addendum is not None:
                out.append(d - 2 * (g.tool.addendum - g.x * self.mn))
            else:
                out.append(d - 2 * self.mn * (g.dedendum_coefficient - g.x))
        return tuple(out)

    @cached_property
    def tool_addendum(self) -> tuple[float, float]:
        """Effective generating tool addendum h_aP0 [m] that cuts d_f at the profile shift x."""
        return tuple(0.5 * (d - df) + g.x * self.mn for g, d, df in zip(self.gears, self.d, self.df))

    @cached_property
    def tool_tip_radius(self) -> tuple[float, float]:
        """Generating tool tip radius rho_aP0 [m] (default 0.38 m_n)."""
        return tuple(g.tool.tip_radius if g.tool.tip_radius is not None else 0.38 * self.mn for g in self.gears)

    @cached_property
    def dff(self) -> tuple[float, float]:
        """Root form diameters d_Ff [m]: where the generated involute begins."""
        out = []
        for i, g in enumerate(self.gears):
            if g.root_form_diameter is not None:
                out.append(g.root_form_diameter)
                continue
            r = 0.5 * self.d[i]
            h_lin = self.tool_addendum[i] - self.tool_tip_radius[i] * (1 - math.sin(self.alpha_n)) - g.x * self.mn
            roll = r * math.sin(self.alpha_t) - h_lin / math.sin(self.alpha_t)
            out.append(2 * math.hypot(self.rb[i], max(roll, 0.0)))
        return tuple(out)

    @property
    def effective_tip_diameter(self) -> tuple[float, float]:
        """Tip diameter that limits contact [m]: d_Na when an enabled micro-geometry gives it, else d_a."""
        out = []
        for g, da in zip(self.gears, self.da):
            m = g.micro
            out.append(m.tip_form_diameter if (m.enabled and m.tip_form_diameter) else da)
        return tuple(out)

    # --------------------------------------------------------- pitches, lead
    @property
    def p_t(self) -> float:
        """Transverse pitch p_t = pi m_t [m] (eq. 19)."""
        return math.pi * self.mt

    @cached_property
    def pb_t(self) -> float:
        """Transverse base pitch p_bt = pi m_t cos(alpha_t) (eq. 20) [m]."""
        return math.pi * self.mt * math.cos(self.alpha_t)

    @cached_property
    def pb_n(self) -> float:
        """Normal base pitch p_bn = pi m_n cos(alpha_n) [m]."""
        return math.pi * self.mn * math.cos(self.alpha_n)

    @cached_property
    def lead(self) -> tuple[float | None, float | None]:
        """Leads p_z = pi d / tan(beta) [m]; None for spur gears."""
        if not self.is_helical:
            return (None, None)
        return tuple(math.pi * d / math.tan(self.beta) for d in self.d)

    # ------------------------------------------------------- path of contact
    @cached_property
    def roll_tip(self) -> tuple[float, float]:
        """Roll lengths sqrt(r_a^2 - r_b^2) of the effective tips [m]."""
        return tuple(math.sqrt(max((0.5 * da) ** 2 - rb**2, 0.0)) for da, rb in zip(self.effective_tip_diameter, self.rb))

    @cached_property
    def g_alpha(self) -> float:
        """Length of path of contact (eq. 24) [m]."""
        return self.roll_tip[0] + self.roll_tip[1] - self.aw * math.sin(self.alpha_wt)

    @cached_property
    def eps_alpha(self) -> float:
        """Transverse contact ratio g_alpha / p_bt (eq. 25) [-]."""
        return self.g_alpha / self.pb_t

    @cached_property
    def face_width(self) -> float:
        """Common face width b = min(b1, b2) [m]."""
        return min(g.face_width for g in self.gears)

    @cached_property
    def eps_beta(self) -> float:
        """Overlap ratio b sin(beta) / (pi m_n) [-]."""
        return self.face_width * math.sin(self.beta) / (math.pi * self.mn)

    @property
    def eps_gamma(self) -> float:
        """Total contact ratio [-]."""
        return self.eps_alpha + self.eps_beta

    @cached_property
    def roll_start_active(self) -> tuple[float, float]:
        """Roll length at the start of active profile of each gear (set by the mate's tip) [m]."""
        t = self.aw * math.sin(self.alpha_wt)
        return (t - self.roll_tip[1], t - self.roll_tip[0])

    @cached_property
    def d_start_active(self) -> tuple[float, float]:
        """Start of active profile diameters d_Nf (required usable root) [m]."""
        return tuple(2 * math.hypot(rb, max(L, 0.0)) for rb, L in zip(self.rb, self.roll_start_active))

    # -------------------------------------------------------- tooth thickness
    @cached_property
    def s_n(self) -> tuple[float, float]:
        """Normal tooth thickness at the reference circle, m_n(pi/2 + 2 x tan(alpha_n)) (eq. 22) [m]."""
        return tuple(self.mn * (math.pi / 2 + 2 * g.x * math.tan(self.alpha_n)) for g in self.gears)

    @cached_property
    def s_t(self) -> tuple[float, float]:
        """Transverse tooth thickness at the reference circle [m]."""
        return tuple(self.mt * (math.pi / 2 + 2 * g.x * math.tan(self.alpha_n)) for g in self.gears)

    def thickness_at(self, i: int, diameter: float) -> float:
        """Transverse tooth thickness of gear ``i`` on the circle of ``diameter`` [m]."""
        rb = self.rb[i]
        if diameter < 2 * rb:
            raise GeometryError(f"diameter {diameter * 1e3:.4f} mm lies inside the base circle of gear {i}")
        alpha_y = math.acos(2 * rb / diameter)
        return diameter * (self.s_t[i] / self.d[i] + float(inv(self.alpha_t)) - float(inv(alpha_y)))

    def normal_thickness_at(self, i: int, diameter: float) -> float:
        """Normal tooth thickness on the circle of ``diameter`` [m]."""
        beta_y = math.atan(math.tan(self.beta) * diameter / self.d[i])
        return self.thickness_at(i, diameter) * math.cos(beta_y)

    @cached_property
    def s_an(self) -> tuple[float, float]:
        """Normal tooth thickness at the tip [m]."""
        return tuple(self.normal_thickness_at(i, self.da[i]) for i in range(2))

    def span_teeth(self, i: int) -> int:
        """Number of teeth spanned k for the base tangent length (ISO 21771 eq. 5.x) [-]."""
        g = self.gears[i]
        alpha_x = math.acos(self.d[i] * math.cos(self.alpha_t) / (self.d[i] + 2 * g.x * self.mn))
        k = g.z / math.pi * (
            math.tan(alpha_x) / math.cos(self.beta_b) ** 2 - 2 * g.x * math.tan(self.alpha_n) / g.z - float(inv(self.alpha_t))
        ) + 0.5
        return max(int(round(k)), 1)

    def base_tangent_length(self, i: int, k: int | None = None) -> float:
        """Base tangent length W_k over ``k`` teeth [m] (ISO 21771; seed eq. 26 with integer k)."""
        g = self.gears[i]
        k = self.span_teeth(i) if k is None else k
        return self.mn * math.cos(self.alpha_n) * (math.pi * (k - 0.5) + g.z * float(inv(self.alpha_t))) + (
            2 * g.x * self.mn * math.sin(self.alpha_n)
        )

    # ------------------------------------------------------------ mass props
    def blank_inertia(self, i: int) -> tuple[float, float]:
        """Mass [kg] and polar inertia [kg m^2] of gear ``i``.

        Solid ring from the bore to the root circle plus the tooth annulus (root to tip)
        counted half full (teeth and spaces have about equal area).
        """
        g = self.gears[i]
        ri, rf, ra = 0.5 * g.bore_diameter, 0.5 * self.df[i], 0.5 * self.da[i]
        c = g.material.density * math.pi * g.face_width
        m = c * ((rf**2 - ri**2) + 0.5 * (ra**2 - rf**2))
        j = 0.5 * c * ((rf**4 - ri**4) + 0.5 * (ra**4 - rf**4))
        return m, j
