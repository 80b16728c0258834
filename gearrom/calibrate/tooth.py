"""Tooth-local transmission error: one tooth out of place, followed through its whole engagement.

A tooth that stands behind (or ahead of) its nominal position changes the static TE only while it
is in mesh, i.e. over about ``eps_gamma`` mesh periods per revolution of its gear. Its contact lines
cross the face like those of every other tooth; while it is in mesh it shares the load with the
other pairs through their stiffnesses. The thin-slice model of
:class:`~gearrom.calibrate.microgeom.SliceMicroModel` gives the slices of every pair in contact; the
displaced tooth adds its deviation to the gap of each of its slices and the static equilibrium
``sum k max(delta - gap, 0) = F_t`` is solved again. The result is non-linear in the deviation:
a tooth set back by more than the static deflection of its neighbours leaves contact (the TE change
saturates), a tooth set forward takes the load of the others.

Convention: ``deviation`` > 0 raises the TE (output lags more) while the tooth is in mesh, for
either gear; tooth 0 enters contact (start of the path, face end ``y = 0``) at angle 0 of its gear.
"""
from __future__ import annotations

import numpy as np

from gearrom.calibrate.microgeom import MicroMods, SliceMicroModel, equilibrium
from gearrom.geometry.pair import GearPair


def tooth_te(pair: GearPair, torque_Nm: float, gear: int, deviation_m: float, mods: MicroMods | None = None, *,
             model: SliceMicroModel | None = None, stiffness_scale: float = 1.0) -> np.ndarray:
    """Static TE change over one revolution of ``gear`` from its tooth 0 displaced by ``deviation_m``.

    Parameters
    ----------
    pair : GearPair
    torque_Nm : float
        Output torque, N m (> 0).
    gear : {0, 1}
        Input (0) or output (1) gear.
    deviation_m : float
        Deviation of the tooth on the transverse line of action, m (> 0: TE rises, see module docstring).
    mods : MicroMods, optional
        Flank modifications of all teeth (default none).
    model : SliceMicroModel, optional
        Slices and angles per mesh period (default ``SliceMicroModel()``).
    stiffness_scale : float
        Factor on every slice stiffness (to match the mesh stiffness of another model, e.g. the FE table).

    Returns
    -------
    ndarray, shape (z * n_theta,)
        TE change, m, on the grid ``j 2 pi / (z n_theta)`` of the gear angle; zero while the tooth is
        out of mesh.
    """
    model = model or SliceMicroModel()
    _, k, gap = model.slices(pair, mods or MicroMods())
    k = k * stiffness_scale
    n_t, n_p, _ = k.shape
    z = pair.z[gear]
    force = torque_Nm / pair.rb[1]
    out = np.zeros(z * n_t)
    for i in range(n_t):
        kk = k[i]
        loaded = kk.ravel() > 0
        d0 = equilibrium(kk.ravel()[loaded], gap[i].ravel()[loaded], force)
        for p in range(min(n_p, z)):  # tooth 0 is pair p during mesh period p of its gear
            if not np.any(kk[p] > 0):
                continue
            g = gap[i].copy()
            g[p] += deviation_m
            out[p * n_t + i] = equilibrium(kk.ravel()[loaded], g.ravel()[loaded], force) - d0
    return out


def periodic_sample(pattern: np.ndarray, theta: np.ndarray, shift: float = 0.0) -> np.ndarray:
    """``pattern(theta - shift)`` for a pattern on a uniform one-revolution grid (linear interpolation)."""
    n = pattern.size
    u = np.mod(np.asarray(theta) - shift, 2 * np.pi) * n / (2 * np.pi)
    i0 = np.floor(u).astype(int) % n
    f = u - np.floor(u)
    return pattern[i0] * (1 - f) + pattern[(i0 + 1) % n] * f
