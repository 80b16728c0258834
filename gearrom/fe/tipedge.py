"""Tip edge rounding of the loaded flank: effective radius, the flank arc coordinate, involute frames.

Real tooth tips are never sharp. A sharp tip corner that touches the mating flank (premature
contact at the start of mesh, prolonged contact at its end) is a singular contact: its pressure
grows without bound with mesh refinement and the static TE does not converge. The FE models
therefore round the tip edge with an arc of radius ``rho`` tangent to the involute and to the tip
circle (:func:`gearrom.geometry.profile.tooth_profile` draws the same arc):

* ``rho`` is the gear's ``tip_edge_radius`` (config key ``tip_edge_radius_mm``) when it is set;
  otherwise :data:`DEFAULT_TIP_EDGE_RADIUS_MODULES` ``* m_n`` (0.15 mm at m_n = 1.5 mm). Drawings
  ask for tip edges broken or rounded by about 0.1-0.2 mm (or 0.1-0.2 m_n) at these modules; the
  default sits in that band. It is logged and recorded in the compliance metadata.
* The loaded flank is one curve: the involute from the base circle to the roll length ``L_t``
  where the rounding starts, then the arc. Its coordinate ``u`` is the involute arc length
  ``L^2 / (2 r_b)`` up to ``u_t = L_t^2 / (2 r_b)`` and ``u_t + rho phi`` on the arc (``phi`` the
  arc angle from the involute end).

Geometry used (all exact): with ``u_hat`` the unit vector from the gear centre to the base-circle
tangent point of the involute normal and ``e_hat`` the outward flank normal (along the string),
an involute point is ``r_b u_hat + L e_hat``; its tangent (increasing ``L``) is ``u_hat``. The
rounding centre is ``r_b u_hat + (L_t - rho) e_hat`` and the arc point at angle ``phi`` is
``(r_b + rho sin phi) u_hat + (L_t - rho (1 - cos phi)) e_hat``. Tangency with the tip circle gives
``r_b^2 + (L_t - rho)^2 = (r_a - rho)^2``.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from gearrom.errors import GeometryError

log = logging.getLogger(__name__)

DEFAULT_TIP_EDGE_RADIUS_MODULES = 0.1
"""Default tip edge rounding radius in normal modules when the config gives none (0.15 mm at m_n = 1.5)."""


def tip_edge_radius(pair, i: int) -> tuple[float, str]:
    """Effective tip edge radius [m] of gear ``i`` and where it comes from (``"config"``/``"default"``)."""
    r = float(getattr(pair.gears[i], "tip_edge_radius", 0.0) or 0.0)
    if r > 0:
        return r, "config"
    return DEFAULT_TIP_EDGE_RADIUS_MODULES * pair.mn, "default"


@dataclass(frozen=True)
class FlankArc:
    """Loaded flank of one gear as a single curve: involute up to ``L_t``, then the tip edge arc.

    Attributes
    ----------
    rb, ra : float
        Base and tip radius [m].
    rho : float
        Tip edge radius [m] (0: sharp edge, no arc).
    L_t : float
        Roll length where the involute ends [m].
    phi_full : float
        Arc angle from the involute end to the tip circle [rad].
    """

    rb: float
    ra: float
    rho: float
    L_t: float
    phi_full: float

    @classmethod
    def of(cls, pair, i: int, rho: float) -> "FlankArc":
        rb, ra = pair.rb[i], 0.5 * pair.da[i]
        if rho <= 0:
            return cls(rb, ra, 0.0, math.sqrt(ra**2 - rb**2), 0.0)
        if ra - rho <= rb:
            raise GeometryError(f"{pair.gears[i].name}: tip edge radius {rho * 1e3:.4f} mm does not fit above the base circle")
        L_t = rho + math.sqrt((ra - rho) ** 2 - rb**2)
        return cls(rb, ra, rho, L_t, math.atan2(rb, L_t - rho))

    @property
    def u_t(self) -> float:
        """Flank coordinate where the arc starts [m]."""
        return self.L_t**2 / (2 * self.rb)

    @property
    def u_end(self) -> float:
        """Flank coordinate of the tip circle (end of the arc) [m]."""
        return self.u_t + self.rho * self.phi_full

    def arc_xy(self, phi) -> tuple[np.ndarray, np.ndarray]:
        """Arc point components along (u_hat, e_hat) [m] at arc angles ``phi`` [rad]."""
        phi = np.asarray(phi, float)
        return self.rb + self.rho * np.sin(phi), self.L_t - self.rho * (1 - np.cos(phi))

    def radius(self, u) -> np.ndarray:
        """Distance from the gear centre [m] of the flank point at coordinate ``u`` [m]."""
        u = np.asarray(u, float)
        inv = np.sqrt(self.rb**2 + 2 * self.rb * np.minimum(u, self.u_t))
        if self.rho <= 0:
            return inv
        a, b = self.arc_xy(np.clip((u - self.u_t) / self.rho, 0.0, self.phi_full))
        return np.where(u <= self.u_t, inv, np.hypot(a, b))

    def u_of_radius(self, r) -> np.ndarray:
        """Inverse of :meth:`radius` [m]."""
        r = np.asarray(r, float)
        u_inv = (np.maximum(r**2 - self.rb**2, 0.0)) / (2 * self.rb)
        if self.rho <= 0:
            return u_inv
        phi = np.linspace(0.0, self.phi_full, 2001)
        rr = self.radius(self.u_t + self.rho * phi)
        u_arc = self.u_t + self.rho * np.interp(r, rr, phi)
        return np.where(u_inv <= self.u_t, u_inv, u_arc)


class InvoluteFrame:
    """One gear's loaded involute placed in a plane frame (vectorised point and projection).

    Parameters
    ----------
    centre : (2,) array
        Gear centre [m].
    rb : float
        Base radius [m].
    u0, e0 : (2,) arrays
        At the reference roll ``L_ref``: unit vector centre -> base tangent point, and the outward
        flank normal (perpendicular to ``u0``).
    L_ref : float
        Roll length of the reference point ``centre + rb u0 + L_ref e0`` [m].
    """

    def __init__(self, centre, rb: float, u0, e0, L_ref: float) -> None:
        self.o = np.asarray(centre, float)
        self.rb = rb
        self.u0, self.e0 = np.asarray(u0, float), np.asarray(e0, float)
        self.sigma = float(np.sign(-self.u0[1] * self.e0[0] + self.u0[0] * self.e0[1]))  # (ez x u0) . e0
        self.b0 = math.atan2(self.u0[1], self.u0[0])
        self.L_ref = L_ref

    def basis(self, L) -> tuple[np.ndarray, np.ndarray]:
        """(u_hat, e_hat) at roll lengths ``L`` (arrays (n, 2))."""
        beta = (self.L_ref - np.asarray(L, float)) / (self.rb * self.sigma)
        ang = self.b0 + beta
        u = np.column_stack([np.cos(ang), np.sin(ang)])
        e = self.sigma * np.column_stack([-u[:, 1], u[:, 0]])
        return u, e

    def arc_points(self, arc: FlankArc, phi) -> np.ndarray:
        """Points [m] of the tip edge arc at angles ``phi`` [rad] (the arc continues the involute at ``L_t``)."""
        u, e = self.basis(np.array([arc.L_t]))
        a, b = arc.arc_xy(phi)
        return self.o + np.outer(a, u[0]) + np.outer(b, e[0])

    def project(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Signed normal distance of points ``q`` (n, 2) from the involute (positive outside the
        material), the roll length of the foot and the outward normal there."""
        d = np.asarray(q, float) - self.o
        rho = np.hypot(d[:, 0], d[:, 1])
        s = np.sqrt(np.maximum(rho**2 - self.rb**2, 0.0))
        a = np.arctan2(d[:, 1], d[:, 0])
        beta = a - self.b0 - self.sigma * np.arccos(np.clip(self.rb / rho, -1.0, 1.0))
        beta = (beta + math.pi) % (2 * math.pi) - math.pi
        L = self.L_ref - self.rb * self.sigma * beta
        ang = self.b0 + beta
        e = self.sigma * np.column_stack([-np.sin(ang), np.cos(ang)])
        return s - L, L, e
