"""Involute gear-pair geometry (ISO 21771 / DIN 3960) and the ISO 6336-1 single stiffness, SI units.

Conventions: the transverse line of action runs from T1 (tangent point on base circle 1) to T2.
Roll distances ``rho`` are measured from T1 along it. Contact of one tooth pair runs from A
(start of active contact, tip of gear 2) to E (end, tip of gear 1) when gear 1 drives.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .data import pair_config

MM = 1e-3


def inv(a: float) -> float:
    """Involute function ``tan(a) - a`` of an angle in rad."""
    return math.tan(a) - a


def inv_solve(value: float) -> float:
    """Angle (rad) whose involute is ``value`` (Newton iteration)."""
    a = (3.0 * value) ** (1.0 / 3.0)
    for _ in range(50):
        step = (inv(a) - value) / math.tan(a) ** 2
        a -= step
        if abs(step) < 1e-15:
            break
    return a


@dataclass(frozen=True)
class PairGeometry:
    """Geometry of an external involute (helical) pair, lengths in m, angles in rad.

    Attributes
    ----------
    z1, z2 : int
        Teeth of the input (driving) and output gear.
    mn, alpha_n, beta : float
        Normal module [m], normal pressure angle, helix angle at the reference circle [rad].
    x1, x2 : float
        Profile shift coefficients [-].
    b : float
        Common (contacting) face width [m].
    r1, r2, rb1, rb2, ra1, ra2 : float
        Reference, base and tip radii [m].
    alpha_t, alpha_wt, beta_b : float
        Transverse pressure angle, working transverse pressure angle, base helix angle [rad].
    a_w : float
        Centre distance [m].
    pbt : float
        Transverse base pitch [m].
    t1t2 : float
        Length T1-T2 of the line of action, ``a_w sin(alpha_wt)`` [m].
    rho_a, rho_e : float
        Roll distances from T1 of A (start of contact) and E (end of contact) [m].
    g_alpha : float
        Length of the path of contact ``rho_e - rho_a`` [m].
    eps_alpha, eps_beta, eps_gamma : float
        Transverse, overlap and total contact ratio [-].
    d_sap1, d_sap2 : float
        Start-of-active-profile diameters of gear 1 and 2 [m].
    b1, b2 : float
        Face widths of the two gears [m].
    """

    z1: int
    z2: int
    mn: float
    alpha_n: float
    beta: float
    x1: float
    x2: float
    b: float
    b1: float
    b2: float
    r1: float
    r2: float
    rb1: float
    rb2: float
    ra1: float
    ra2: float
    alpha_t: float
    alpha_wt: float
    beta_b: float
    a_w: float
    pbt: float
    t1t2: float
    rho_a: float
    rho_e: float
    g_alpha: float
    eps_alpha: float
    eps_beta: float
    eps_gamma: float
    d_sap1: float
    d_sap2: float


def pair_geometry(*, z1: int, z2: int, mn: float, alpha_n_deg: float, beta_deg: float, x1: float = 0.0,
                  x2: float = 0.0, b1: float, b2: float, da1: float | None = None, da2: float | None = None,
                  a_w: float | None = None, ha: float = 1.0) -> PairGeometry:
    """Geometry from the basic data (ISO 21771), SI units in and out.

    Parameters
    ----------
    z1, z2 : int
        Numbers of teeth.
    mn : float
        Normal module [m].
    alpha_n_deg, beta_deg : float
        Normal pressure angle and helix angle [deg].
    x1, x2 : float
        Profile shift coefficients.
    b1, b2 : float
        Face widths [m]; the contact width is the smaller one.
    da1, da2 : float, optional
        Tip diameters [m]; default ``d + 2 mn (ha + x)``.
    a_w : float, optional
        Centre distance [m]; default the zero-backlash distance from ``x1 + x2``.
    ha : float
        Addendum coefficient of the default tip diameters.
    """
    an, beta = math.radians(alpha_n_deg), math.radians(beta_deg)
    at = math.atan(math.tan(an) / math.cos(beta))
    r1, r2 = z1 * mn / math.cos(beta) / 2, z2 * mn / math.cos(beta) / 2
    rb1, rb2 = r1 * math.cos(at), r2 * math.cos(at)
    beta_b = math.atan(math.tan(beta) * math.cos(at))
    a0 = r1 + r2
    if a_w is None:
        awt = inv_solve(inv(at) + 2 * (x1 + x2) * math.tan(an) / (z1 + z2))
        a_w = a0 * math.cos(at) / math.cos(awt)
    else:
        awt = math.acos(a0 * math.cos(at) / a_w)
    ra1 = (da1 / 2) if da1 is not None else r1 + mn * (ha + x1)
    ra2 = (da2 / 2) if da2 is not None else r2 + mn * (ha + x2)
    t1t2 = a_w * math.sin(awt)
    rho_e = math.sqrt(ra1 ** 2 - rb1 ** 2)
    rho_a = t1t2 - math.sqrt(ra2 ** 2 - rb2 ** 2)
    g_alpha = rho_e - rho_a
    pbt = 2 * math.pi * rb1 / z1
    b = min(b1, b2)
    eps_a = g_alpha / pbt
    eps_b = b * math.sin(beta) / (math.pi * mn)
    d_sap1 = 2 * math.hypot(rb1, rho_a)
    d_sap2 = 2 * math.hypot(rb2, t1t2 - rho_e)
    return PairGeometry(z1=z1, z2=z2, mn=mn, alpha_n=an, beta=beta, x1=x1, x2=x2, b=b, b1=b1, b2=b2,
                        r1=r1, r2=r2, rb1=rb1, rb2=rb2, ra1=ra1, ra2=ra2, alpha_t=at, alpha_wt=awt,
                        beta_b=beta_b, a_w=a_w, pbt=pbt, t1t2=t1t2, rho_a=rho_a, rho_e=rho_e,
                        g_alpha=g_alpha, eps_alpha=eps_a, eps_beta=eps_b, eps_gamma=eps_a + eps_b,
                        d_sap1=d_sap1, d_sap2=d_sap2)


def geometry_from_config(pair: str = "helical") -> PairGeometry:
    """:class:`PairGeometry` of the bundled ``"helical"`` (thesis-rig) or ``"spur"`` (thesis-spur) pair."""
    cfg = pair_config(pair)
    p, g1, g2 = cfg["pair"], cfg["input_gear"], cfg["output_gear"]

    def opt(tab: dict, key: str) -> float | None:
        return tab[key] * MM if key in tab else None

    return pair_geometry(z1=int(g1["teeth"]), z2=int(g2["teeth"]), mn=p["normal_module_mm"] * MM,
                         alpha_n_deg=p["normal_pressure_angle_deg"], beta_deg=p.get("helix_angle_deg", 0.0),
                         x1=g1.get("profile_shift", 0.0), x2=g2.get("profile_shift", 0.0),
                         b1=g1["face_width_mm"] * MM, b2=g2["face_width_mm"] * MM,
                         da1=opt(g1, "tip_diameter_mm"), da2=opt(g2, "tip_diameter_mm"),
                         a_w=opt(p, "center_distance_mm"), ha=g1.get("addendum_coefficient", 1.0))


def iso_single_stiffness(g: PairGeometry, hfp_over_mn: float = 1.25, c_m: float = 0.8, c_r: float = 1.0) -> float:
    """Single stiffness c' of ISO 6336-1 method B, in N/m per m of face width (1 N/(mm um) = 1e9).

    ``q' = C1 + C2/zn1 + C3/zn2 + C4 x1 + C5 x1/zn1 + C6 x2 + C7 x2/zn2 + C8 x1^2 + C9 x2^2`` [mm um/N],
    ``c' = C_M C_R C_B cos(beta) / q'``, ``C_B = [1 + 0.5 (1.2 - h_fP/mn)] [1 - 0.02 (20 deg - alpha_n)]``,
    virtual numbers of teeth ``zn = z / (cos^2(beta_b) cos(beta))``.

    Parameters
    ----------
    g : PairGeometry
    hfp_over_mn : float
        Dedendum of the basic rack over the module.
    c_m, c_r : float
        ISO correction factors (C_M = 0.8 theoretical-to-measured, C_R = 1 solid blank).
    """
    c = (0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188, 0.00529, 0.00182)
    f = math.cos(g.beta_b) ** 2 * math.cos(g.beta)
    zn1, zn2 = g.z1 / f, g.z2 / f
    q = (c[0] + c[1] / zn1 + c[2] / zn2 + c[3] * g.x1 + c[4] * g.x1 / zn1 + c[5] * g.x2 + c[6] * g.x2 / zn2
         + c[7] * g.x1 ** 2 + c[8] * g.x2 ** 2)
    c_b = (1 + 0.5 * (1.2 - hfp_over_mn)) * (1 - 0.02 * (20.0 - math.degrees(g.alpha_n)))
    return c_m * c_r * c_b * math.cos(g.beta) / q * 1e9
