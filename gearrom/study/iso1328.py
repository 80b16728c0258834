"""ISO 1328-1:2013 tolerances of cylindrical gears by flank tolerance class (grade) A = 1..11.

Formulas (ISO 1328-1:2013, clause 5.3; d reference diameter, m_n normal module, b face width, all in
mm; tolerances in um; the step factor between neighbouring classes is sqrt(2))::

    f_pT   = (0.001 d + 0.4 m_n + 5)                    sqrt(2)^(A - 5)   single pitch
    F_pT   = (0.002 d + 0.55 sqrt(d) + 0.7 m_n + 12)   sqrt(2)^(A - 5)   cumulative (total) pitch
    f_HbT  = (0.05 sqrt(d) + 0.35 sqrt(b) + 4)         sqrt(2)^(A - 5)   helix slope
    F_bT   = (0.07 sqrt(d) + 0.45 sqrt(b) + 4)         sqrt(2)^(A - 5)   total helix
    F_rT   = 0.9 F_pT                                                     runout (before rounding)

Rounding (ISO 1328-1:2013, 5.2.3): above 10 um to the nearest 1 um, from 5 to 10 um to the nearest
0.5 um, below 5 um to the nearest 0.1 um. The formulas hold for 5 <= d <= 15000 mm,
0.5 <= m_n <= 70 mm and 4 <= b <= 1200 mm; outside, a :class:`~gearrom.errors.ConfigError` is raised.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from gearrom.errors import ConfigError

GRADES = range(1, 12)


def round_iso(value_um: float) -> float:
    """Round a tolerance [um] by the ISO 1328-1:2013 rule (1 / 0.5 / 0.1 um steps)."""
    if value_um > 10.0:
        return float(math.floor(value_um + 0.5))
    if value_um >= 5.0:
        return math.floor(2.0 * value_um + 0.5) / 2.0
    return math.floor(10.0 * value_um + 0.5) / 10.0


def _check(grade: int, d_mm: float, mn_mm: float, b_mm: float) -> float:
    if isinstance(grade, bool) or not isinstance(grade, int) or grade not in GRADES:
        raise ConfigError(f"ISO 1328-1 grade must be an integer in 1..11, got {grade!r}")
    for name, v, lo, hi in (("reference diameter", d_mm, 5.0, 15000.0), ("normal module", mn_mm, 0.5, 70.0),
                            ("face width", b_mm, 4.0, 1200.0)):
        if not (math.isfinite(v) and lo <= v <= hi):
            raise ConfigError(f"ISO 1328-1:2013 tolerances need a {name} in [{lo:g}, {hi:g}] mm, got {v:g} mm")
    return math.sqrt(2.0) ** (grade - 5)


@dataclass(frozen=True)
class IsoTolerances:
    """Tolerances of one gear [m] (rounded as the standard says).

    Attributes
    ----------
    f_pT : float
        Single pitch tolerance (each tooth's pitch deviation lies within +-f_pT).
    F_pT : float
        Cumulative (total) pitch tolerance (range of the cumulative deviation over the gear).
    F_rT : float
        Runout tolerance (twice the largest eccentricity).
    f_HbT : float
        Helix slope tolerance (the slope deviation lies within +-f_HbT).
    F_bT : float
        Total helix tolerance.
    grade : int
        Flank tolerance class A.
    """

    f_pT: float
    F_pT: float
    F_rT: float
    f_HbT: float
    F_bT: float
    grade: int


def iso1328_tolerances(grade: int, d_mm: float, mn_mm: float, b_mm: float) -> IsoTolerances:
    """ISO 1328-1:2013 tolerances [m] for flank tolerance class ``grade``.

    Parameters
    ----------
    grade : int
        Flank tolerance class A, 1 (finest) to 11.
    d_mm : float
        Reference diameter [mm].
    mn_mm : float
        Normal module [mm].
    b_mm : float
        Face width [mm].

    Returns
    -------
    IsoTolerances
    """
    s = _check(grade, d_mm, mn_mm, b_mm)
    f_pt = (0.001 * d_mm + 0.4 * mn_mm + 5.0) * s
    f_p = (0.002 * d_mm + 0.55 * math.sqrt(d_mm) + 0.7 * mn_mm + 12.0) * s
    f_hb = (0.05 * math.sqrt(d_mm) + 0.35 * math.sqrt(b_mm) + 4.0) * s
    f_b = (0.07 * math.sqrt(d_mm) + 0.45 * math.sqrt(b_mm) + 4.0) * s
    um = 1e-6
    return IsoTolerances(f_pT=round_iso(f_pt) * um, F_pT=round_iso(f_p) * um, F_rT=round_iso(0.9 * f_p) * um,
                         f_HbT=round_iso(f_hb) * um, F_bT=round_iso(f_b) * um, grade=int(grade))


def pair_tolerances(pair, grade: int) -> tuple[IsoTolerances, IsoTolerances]:
    """Tolerances of both gears of ``pair`` (reference diameters, normal module, face widths) [m]."""
    return tuple(iso1328_tolerances(grade, pair.d[i] * 1e3, pair.mn * 1e3, pair.gears[i].face_width * 1e3)
                 for i in range(2))
