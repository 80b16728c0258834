"""ISO 6336-1:2006 method B tooth stiffness: the single stiffness c' and the mesh stiffness c_gamma_alpha.

An empirical anchor (about +-20 %) for the FE results. Formulas: ISO 6336-1 eqs. (9.1)-(9.4) and
(9.8); constants C1..C9 from its Table 8 (valid for external gears with a solid blank).
"""
from __future__ import annotations

import math

C = (0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188, 0.00529, 0.00182)


def single_stiffness(pair, C_M: float = 0.8, C_R: float = 1.0) -> float:
    """Single stiffness c' per unit face width [N/(m m)] = N/m^2 (ISO: N/(mm um))."""
    g1, g2 = pair.gears
    cb3 = math.cos(pair.beta_b) ** 2 * math.cos(pair.beta)
    zn1, zn2 = g1.z / cb3, g2.z / cb3
    x1, x2 = g1.x, g2.x
    q = (C[0] + C[1] / zn1 + C[2] / zn2 + C[3] * x1 + C[4] * x1 / zn1 + C[5] * x2 + C[6] * x2 / zn2
         + C[7] * x1**2 + C[8] * x2**2)  # mm um / N
    h_fp = g1.dedendum_coefficient  # basic rack dedendum / m_n
    C_B = (1 + 0.5 * (1.2 - h_fp)) * (1 - 0.02 * (20.0 - math.degrees(pair.alpha_n)))
    c_th = 1.0 / q
    c_prime = c_th * C_M * C_R * C_B * math.cos(pair.beta)  # N/(mm um)
    return c_prime * 1e9  # N/(mm um) -> N/m^2 (per m of face width, per m of deflection)


def mesh_stiffness(pair, **kw) -> float:
    """Mean mesh stiffness c_gamma_alpha = c' (0.75 eps_alpha + 0.25) per unit face width [N/m^2]."""
    return single_stiffness(pair, **kw) * (0.75 * pair.eps_alpha + 0.25)
