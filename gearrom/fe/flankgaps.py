"""Initial gaps from micro-geometry and manufacturing errors, along the transverse line of action.

Every function returns the material *removed* from the loaded flank [m] (positive opens the gap),
measured in the transverse plane along the base tangent (the transverse line of action), as
ISO 1328-1 measures profile and helix deviations. The micro-geometry values of a config
(``tip_relief_um``, ``lead_crowning_um``, ``helix_slope_um``, ...) are taken in that convention;
measured along the flank normal of a helical gear, the same removal is ``cos(beta_b)`` times the value.

Conventions
-----------
* Profile modifications are functions of the roll length ``L`` of the gear's own flank:
  linear tip relief ``C_a`` from ``d_Ca`` to the tip (ISO 21771 linear relief), parabolic profile
  crowning ``C_H`` over the active profile (zero in the middle, ``C_H`` at both ends), profile
  slope ``f_Halpha``: material added towards the tip (linear, zero in the middle).
* ``pitch_deviations[j]`` is the single pitch deviation of tooth ``j`` (teeth numbered in the order
  they enter the mesh); the cumulative deviation (mean removed) is material *added* on the loaded
  flank of that tooth.
* Runout ``F_r = 2 e``: the gear centre is displaced by ``e`` towards the largest radius at
  ``runout_phase`` from tooth 0; its projection on the line of action closes the gap.
* Lead crowning and helix slope vary over the face width: the helical LTCAs
  (:mod:`gearrom.fe.ltca_helical`, :mod:`gearrom.fe.ltca_slices`) add them at each axial position;
  the plane model of a spur pair ignores them (:func:`needs_3d`). The axial position ``z`` is the
  pair's (both gears' axes along +z, face width centred on z = 0, :mod:`gearrom.fe.mesh3d`): a
  positive helix slope ``f_Hbeta`` of either gear removes ``f_Hbeta / 2`` at z = +b/2 and adds it at
  z = -b/2, whatever the hand. Which of the two ends enters contact first depends on the hand
  (:func:`gearrom.geometry.profile.entry_face_end`: z = -b/2 for a right-hand input gear), so the
  same ``f_Hbeta`` on a left-hand pair gives the mirror image of the right-hand pair's response to
  ``-f_Hbeta``.
"""
from __future__ import annotations

import math

import numpy as np


def roll_at(pair, i: int, diameter: float) -> float:
    """Roll length sqrt(r^2 - r_b^2) at ``diameter`` [m]."""
    return math.sqrt(max((0.5 * diameter) ** 2 - pair.rb[i] ** 2, 0.0))


def profile_removal(pair, i: int, L: np.ndarray, micro=None) -> np.ndarray:
    """Material removed by the profile modifications of gear ``i`` at roll lengths ``L`` [m], along the
    transverse line of action [m]."""
    m = pair.gears[i].micro if micro is None else micro
    L = np.asarray(L, float)
    out = np.zeros_like(L)
    if not m.enabled:
        return out
    L_tip = roll_at(pair, i, pair.da[i])
    L_sap = pair.roll_start_active[i]
    L_eap = pair.roll_tip[i]
    if m.tip_relief > 0 and m.tip_relief_start_diameter is not None:
        L_ca = roll_at(pair, i, m.tip_relief_start_diameter)
        out += m.tip_relief * np.clip((L - L_ca) / max(L_tip - L_ca, 1e-12), 0.0, None)
    half = 0.5 * (L_eap - L_sap)
    mid = 0.5 * (L_eap + L_sap)
    if m.profile_crowning > 0 and half > 0:
        out += m.profile_crowning * ((L - mid) / half) ** 2
    if m.profile_slope != 0 and half > 0:
        out -= m.profile_slope * (L - mid) / (2 * half)
    return out


def lead_removal(pair, i: int, z) -> np.ndarray:
    """Material removed by the lead modifications of gear ``i`` at axial positions ``z`` [m] from the middle
    of the face width, along the transverse line of action [m]: parabolic lead crowning ``C_b`` (zero in
    the middle, ``C_b`` at both ends of the face width ``b``) and helix slope ``f_Hbeta`` (linear, zero in
    the middle, ``f_Hbeta / 2`` at z = +b/2 of the pair's axial coordinate, for either gear and hand;
    see the module doc)."""
    z = np.asarray(z, float)
    m = pair.gears[i].micro
    if not m.enabled:
        return np.zeros_like(z)
    b = pair.face_width
    return m.lead_crowning * (2 * z / b) ** 2 + m.helix_slope * z / b


def tip_limit(pair, i: int) -> float:
    """Largest roll length that can carry contact: the effective tip (d_Na when enabled) [m]."""
    return roll_at(pair, i, pair.effective_tip_diameter[i])


def pitch_removal(pair, i: int, tooth: int) -> float:
    """Material removed on tooth number ``tooth`` of gear ``i`` by the cumulative pitch deviation [m]."""
    m = pair.gears[i].micro
    if not m.enabled or not m.pitch_deviations:
        return 0.0
    cum = np.cumsum(m.pitch_deviations)
    cum -= cum.mean()
    return -float(cum[tooth % pair.gears[i].z])


def runout_removal(pair, i: int, rotation: float) -> float:
    """Gap opening from the runout of gear ``i`` when it has turned by ``rotation`` [rad] [m].

    ``rotation`` is the gear's turn in its running direction since tooth 0 stood on the
    centre line.
    """
    m = pair.gears[i].micro
    if not m.enabled or m.runout == 0:
        return 0.0
    e = m.eccentricity
    if i == 0:  # turns clockwise; loaded-flank normal along -alpha_wt from +x
        return -e * math.cos(math.pi / 2 + m.runout_phase - rotation + pair.alpha_wt)
    return e * math.cos(-math.pi / 2 + m.runout_phase + rotation + pair.alpha_wt)


def needs_3d(pair) -> list[str]:
    """Enabled micro-geometry fields that a plane model cannot represent."""
    out = []
    for g in pair.gears:
        if g.micro.enabled:
            for name in ("lead_crowning", "helix_slope"):
                if getattr(g.micro, name) != 0:
                    out.append(f"{g.name}.microgeometry.{name}_um")
    return out
