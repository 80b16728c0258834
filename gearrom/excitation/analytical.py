"""A simple analytical mesh excitation with the ISO 6336-1 (method B) stiffness level.

Model
-----
* ISO 6336-1:2006 section 9 gives the *single stiffness* ``c'`` (maximum stiffness of one tooth
  pair per unit face width) and the *mesh stiffness* ``c_gamma_alpha = c' (0.75 eps_alpha + 0.25)``
  (mean over the mesh cycle) [N/(mm um)]:
  ``q' = C1 + C2/zn1 + C3/zn2 + C4 x1 + C5 x1/zn1 + C6 x2 + C7 x2/zn2 + C8 x1^2 + C9 x2^2``,
  ``c'th = 1/q'``, ``c' = c'th C_M C_R C_B cos(beta)`` with ``C_M = 0.8`` and ``C_R = 1`` (solid blank),
  ``C_B = [1 + 0.5 (1.2 - h_fP/m_n)] [1 - 0.02 (20 - alpha_n[deg])]``, ``zn = z / (cos^2 beta_b cos beta)``.
* One tooth pair's stiffness per unit contact-line length along the path of contact
  (roll coordinate ``s in [0, g_alpha]``) is taken parabolic, ``c' f(s)`` with
  ``f = f_min + (1 - f_min) 4 u (1 - u)``, ``u = s / g_alpha``: 1 (= c') mid-path and ``f_min`` where
  the pair enters and leaves contact. ``f_min`` is chosen so that the mesh-cycle mean equals ISO's
  ``c_gamma_alpha``, i.e. ``mean(f) = (0.75 eps_alpha + 0.25) / eps_alpha``.
* Helical gears: the contact line of a pair crosses the plane of action obliquely; in the face
  section ``y`` the roll position is ``s = s0 - y tan(beta_b)``. The pair stiffness is the integral
  of ``c' f(s)`` over the face width (done in closed form), so with ``eps_beta`` close to an integer
  the total stiffness is nearly constant, as it should be.
* Static TE: ``e = F_t / k(theta)`` with ``F_t = T_out / rb2`` (perfect involutes, no micro-geometry);
  the stiffness is therefore secant and independent of the load.

All stiffness values are transverse line-of-action values (see :mod:`gearrom.excitation.table`).
The model is an anchor of about +-20 % (ISO's own accuracy), not a substitute for the FE LTCA.
"""
from __future__ import annotations

import logging
import math
import warnings

import numpy as np

from gearrom.errors import ModelError
from gearrom.excitation.table import MeshExcitation
from gearrom.geometry.pair import GearPair

log = logging.getLogger(__name__)

ISO_C = (0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188, 0.00529, 0.00182)
C_M = 0.8  # ISO 6336-1 theoretical-to-measured correction
C_R = 1.0  # solid gear blank
N_MM_UM = 1e9  # 1 N/(mm um) in N/m^2


def iso_single_stiffness(pair: GearPair) -> float:
    """ISO 6336-1 method B single stiffness c' per unit face width [N/m^2] (1 N/(mm um) = 1e9 N/m^2)."""
    g1, g2 = pair.gears
    cb = math.cos(pair.beta_b) ** 2 * math.cos(pair.beta)
    zn1, zn2 = g1.z / cb, g2.z / cb
    x1, x2 = g1.x, g2.x
    c = ISO_C
    q = (c[0] + c[1] / zn1 + c[2] / zn2 + c[3] * x1 + c[4] * x1 / zn1 + c[5] * x2 + c[6] * x2 / zn2
         + c[7] * x1**2 + c[8] * x2**2)
    c_th = 1.0 / q
    alpha_n_deg = math.degrees(pair.alpha_n)
    c_b = []
    for i in range(2):
        h_fp = pair.tool_addendum[i] / pair.mn
        c_b.append((1 + 0.5 * (1.2 - h_fp)) * (1 - 0.02 * (20.0 - alpha_n_deg)))
    return c_th * C_M * C_R * 0.5 * (c_b[0] + c_b[1]) * math.cos(pair.beta) * N_MM_UM


def iso_mesh_stiffness(pair: GearPair) -> float:
    """ISO 6336-1 mean mesh stiffness c_gamma_alpha = c' (0.75 eps_alpha + 0.25) [N/m^2]."""
    return iso_single_stiffness(pair) * (0.75 * pair.eps_alpha + 0.25)


def shape_min(eps_alpha: float) -> float:
    """Minimum of the parabolic pair-stiffness shape (relative to the single-pair stiffness) whose mean
    over a mesh cycle equals the ISO 6336 mesh stiffness at the transverse contact ratio ``eps_alpha``."""
    mean_f = (0.75 * eps_alpha + 0.25) / eps_alpha
    f_min = 3.0 * mean_f - 2.0
    if f_min < 0.0:
        warnings.warn(f"eps_alpha = {eps_alpha:.3f} is too large for the parabolic pair-stiffness shape; "
                      "f_min clipped to 0 (mean stiffness then exceeds ISO's)", stacklevel=3)
        f_min = 0.0
    return min(f_min, 1.0)


def _f_antiderivative(s: np.ndarray, g: float, f_min: float) -> np.ndarray:
    """Integral of f(s) = f_min + (1 - f_min) 4 (s/g)(1 - s/g) from 0 to s."""
    u = s / g
    return g * (f_min * u + (1 - f_min) * 4 * (u**2 / 2 - u**3 / 3))


def pair_stiffness(s0: np.ndarray, pair: GearPair, c_single: float, f_min: float) -> np.ndarray:
    """Stiffness [N/m] of a tooth pair whose contact line is at roll position ``s0`` [m] on face end y = 0."""
    g = pair.g_alpha
    b = pair.face_width
    t = math.tan(pair.beta_b)
    s0 = np.asarray(s0, dtype=float)
    if t * b < 1e-12 * g:  # spur: the whole face at s0
        u = s0 / g
        inside = (s0 >= 0) & (s0 <= g)
        return np.where(inside, c_single * b * (f_min + (1 - f_min) * 4 * u * (1 - u)), 0.0)
    lo = np.clip(s0 - b * t, 0.0, g)
    hi = np.clip(s0, 0.0, g)
    integral = _f_antiderivative(hi, g, f_min) - _f_antiderivative(lo, g, f_min)
    return c_single * np.maximum(integral, 0.0) / t


def analytical_excitation(pair: GearPair, torques_Nm, n_theta: int = 256, *, config_name: str = "",
                          config_digest: str = "") -> MeshExcitation:
    """Mesh excitation table from the ISO 6336-1 shaped analytical model (see module docstring).

    Parameters
    ----------
    pair : GearPair
        The gear pair (SI).
    torques_Nm : float or sequence of float
        Output torques [N m] (positive, increasing).
    n_theta : int
        Points per mesh period (>= 16).
    config_name, config_digest : str
        Provenance written to the metadata.

    Returns
    -------
    MeshExcitation
        Secant transverse stiffness (independent of torque) and STE = F_t / k.

    Raises
    ------
    ModelError
        Bad torques or n_theta.
    """
    tq = np.atleast_1d(np.asarray(torques_Nm, dtype=float))
    if tq.ndim != 1 or np.any(~np.isfinite(tq)) or np.any(tq <= 0) or np.any(np.diff(tq) <= 0):
        raise ModelError(f"analytical_excitation: torques_Nm must be positive and increasing, got {tq}")
    if not isinstance(n_theta, (int, np.integer)) or n_theta < 16:
        raise ModelError(f"analytical_excitation: n_theta must be an integer >= 16, got {n_theta!r}")
    if any(g.micro.enabled for g in pair.gears):
        warnings.warn("analytical_excitation ignores the micro-geometry (perfect involutes)", stacklevel=2)
    z1 = pair.z[0]
    period = 2 * math.pi / z1
    theta = np.arange(n_theta) * period / n_theta
    c_single = iso_single_stiffness(pair)
    f_min = shape_min(pair.eps_alpha)
    n_pairs = int(math.ceil(pair.eps_alpha + pair.eps_beta)) + 1
    s0 = pair.rb[0] * theta[:, None] + pair.pb_t * np.arange(n_pairs)[None, :]
    kp = pair_stiffness(s0, pair, c_single, f_min)  # (n_theta, n_pairs)
    k = kp.sum(axis=1)
    share = kp / k[:, None]
    ft = tq / pair.rb[1]
    k_tab = np.broadcast_to(k, (tq.size, n_theta)).copy()
    e_tab = ft[:, None] / k[None, :]
    meta = {
        "source": "gearrom.excitation.analytical (ISO 6336-1 method B level, parabolic pair shape)",
        "config": config_name, "config_digest": config_digest,
        "theta_origin": "pair 0 enters contact (start of the path of contact, face end y=0) at theta = 0",
        "c_single_N_per_mm_um": c_single / N_MM_UM, "c_gamma_N_per_mm_um": iso_mesh_stiffness(pair) / N_MM_UM,
        "f_min": f_min, "eps_alpha": pair.eps_alpha, "eps_beta": pair.eps_beta,
    }
    return MeshExcitation(
        z1=z1, theta=theta, torque=tq, k=k_tab, e=e_tab,
        load_share=np.broadcast_to(share, (tq.size, n_theta, n_pairs)).copy(),
        definition="secant; transverse line of action; ISO 6336-1 level (tooth + blank, C_M=0.8); no shaft/bearing",
        metadata=meta,
    )
