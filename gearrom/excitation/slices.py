"""Thin-slice mesh model: flank modifications and single-tooth deviations to static transmission error.

An analytical model of the mesh at ISO 6336-1 level, fast enough to be evaluated for many
parameter values: the diagnosis fits flank modifications with it (:class:`SliceMicroModel`, where
the quasi-static FE tables are not available) and every model follows a displaced tooth through
its engagement with it (:func:`tooth_te`, :func:`pitch_te`).

Model (:class:`SliceMicroModel`)
--------------------------------
* Each tooth pair in contact is cut into ``n_slices`` thin slices across the face width. A slice
  at face position ``y`` of the pair whose contact line sits at roll position ``s0`` (face end
  ``y = 0``) touches at ``s = s0 - y tan(beta_b)`` on the path of contact ``[0, g_alpha]``
  (the convention and the theta origin of :mod:`gearrom.excitation.analytical`). ``y`` runs from
  the face end that enters contact first (:func:`gearrom.geometry.profile.entry_face_end`: z = -b/2
  for a right-hand input gear, z = +b/2 for a left-hand one), so the slice lies at the pair's axial
  position ``z = z_e (1 - 2 y / b)`` (``z_e`` that end) and ``s`` follows from the shift of
  :func:`gearrom.geometry.profile.contact_shift` as in the FE models.
* Slice stiffness: ``c' f(s) dy``, with the ISO 6336-1 single stiffness ``c'`` and the parabolic
  pair shape ``f`` of the analytical excitation (so perfect gears reproduce it).
* Initial gap of a slice: the material removed from both flanks, summed over the modifications, in
  the transverse plane along the base tangent (the transverse line of action), as ISO 1328-1
  measures profile and helix deviations and as the FE models take them
  (:mod:`gearrom.fe.flankgaps`); every value of :class:`MicroMods` is in that convention (along the
  flank normal of a helical pair the removal is ``cos(beta_b)`` times the value):

  - tip relief of gear i, linear from the roll length at ``d_Ca`` to the tip, ``C_a`` at the tip;
  - lead crowning, ``C_b (2 z/b)^2`` (both flanks together, parabolic over the face);
  - helix slope (misalignment), ``f_Hbeta z / b`` (signed, linear over the face: ``f_Hbeta / 2``
    removed at z = +b/2 whatever the hand, the convention of :func:`gearrom.fe.flankgaps.lead_removal`).

* Static equilibrium at each mesh angle: ``sum_i k_i max(delta - g_i, 0) = F_t`` with
  ``F_t = T_out / r_b2`` (the slices are independent springs: no load spreading between slices,
  a stated simplification of the thin-slice method). The STE is ``delta``; the stiffness is the
  tangent ``sum of k_i`` of the loaded slices.

Limits: no Hertzian non-linearity, no coupling between slices, no corner contact outside the path.
Good for the *change* of STE harmonics with modification size, which is what the diagnosis fits.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gearrom.errors import CalibrationError
from gearrom.excitation.analytical import shape_min, iso_single_stiffness
from gearrom.excitation.table import MeshExcitation
from gearrom.geometry.pair import GearPair
from gearrom.geometry.profile import contact_shift, entry_face_end

UM = 1e-6
#: revision of the results of this module's slice model (part of the reuse keys of results computed with it,
#: e.g. :func:`gearrom.study.scatter.study_key`)
MODEL_REVISION = "slices-micro-transverse-hand-2"


@dataclass(frozen=True)
class MicroMods:
    """Flank modifications of the pair as the diagnosis parametrizes them (SI, m).

    Every amount is material removed from the flank, measured in the transverse plane along the base
    tangent (the transverse line of action), as ISO 1328-1 measures profile and helix deviations: the
    convention of the config's micro-geometry (:class:`gearrom.geometry.gear.MicroGeometry`) and of
    the FE models (:mod:`gearrom.fe.flankgaps`). Along the flank normal of a helical pair the removal
    is ``cos(beta_b)`` times the value.

    Parameters
    ----------
    tip_relief : (float, float)
        Linear tip relief C_a of the input and output gear at the tip, m (transverse).
    tip_relief_start_diameter : (float or None, float or None)
        Diameters d_Ca where the reliefs start, m (None: 2/3 of the way from the start of active
        profile to the tip, a common design rule).
    lead_crowning : float
        Lead crowning C_b of the pair (the sum over both gears), m (transverse): removal ``C_b`` at
        both ends of the face width, zero in the middle, parabolic.
    helix_slope : float
        Helix slope f_Hbeta of the pair (misalignment) over the face width, m (transverse, signed):
        linear removal ``f_Hbeta z / b``, zero in the middle, ``f_Hbeta / 2`` at the face end z = +b/2 of
        the pair's axial coordinate (:func:`gearrom.fe.flankgaps.lead_removal`). That end enters contact
        last for a right-hand input gear and first for a left-hand one
        (:func:`gearrom.geometry.profile.entry_face_end`).
    """

    tip_relief: tuple[float, float] = (0.0, 0.0)
    tip_relief_start_diameter: tuple[float | None, float | None] = (None, None)
    lead_crowning: float = 0.0
    helix_slope: float = 0.0

    @property
    def is_zero(self) -> bool:
        """True when no modification is set."""
        return not (any(self.tip_relief) or self.lead_crowning or self.helix_slope)

    @classmethod
    def from_pair(cls, pair: GearPair) -> MicroMods:
        """The modifications written in the gear configuration (only where ``enabled``)."""
        g = pair.gears
        tr = tuple(x.micro.tip_relief if x.micro.enabled else 0.0 for x in g)
        sd = tuple(x.micro.tip_relief_start_diameter for x in g)
        cb = sum(x.micro.lead_crowning for x in g if x.micro.enabled)
        hs = sum(x.micro.helix_slope for x in g if x.micro.enabled)
        return cls(tip_relief=tr, tip_relief_start_diameter=sd, lead_crowning=cb, helix_slope=hs)


@dataclass(frozen=True)
class SliceMicroModel:
    """Analytical thin-slice STE model (see module docstring).

    Parameters
    ----------
    n_theta : int
        Mesh angles per mesh period.
    n_slices : int
        Slices across the face width.
    """

    n_theta: int = 128
    n_slices: int = 32

    def excitation(self, pair: GearPair, torques_Nm, mods: MicroMods) -> MeshExcitation:
        """Mesh excitation table (tangent stiffness, loaded STE) with the modifications ``mods``.

        Parameters
        ----------
        pair : GearPair
        torques_Nm : float or sequence of float
            Output torques, N m, positive and increasing.
        mods : MicroMods

        Returns
        -------
        MeshExcitation
        """
        tq = np.atleast_1d(np.asarray(torques_Nm, float))
        if tq.ndim != 1 or np.any(tq <= 0) or np.any(np.diff(tq) <= 0):
            raise CalibrationError(f"SliceMicroModel: torques_Nm must be positive and increasing, got {tq}")
        z1 = pair.z[0]
        theta, k_sl, gap = self.slices(pair, mods)
        n_pairs = k_sl.shape[1]
        k_tab = np.empty((tq.size, self.n_theta))
        e_tab = np.empty_like(k_tab)
        share = np.zeros((tq.size, self.n_theta, n_pairs))
        for it, T in enumerate(tq):
            ft = T / pair.rb[1]
            for i in range(self.n_theta):
                kk, gg = k_sl[i].ravel(), gap[i].ravel()
                m = kk > 0
                d = equilibrium(kk[m], gg[m], ft)
                load = kk * np.maximum(d - gg, 0.0) * m
                k_tab[it, i] = kk[m & (gg < d)].sum()
                e_tab[it, i] = d
                share[it, i] = load.reshape(n_pairs, -1).sum(axis=1) / ft
        meta = {"source": "gearrom.calibrate.micromodel.SliceMicroModel (thin slices, ISO 6336-1 level)",
                "theta_origin": "pair 0 enters contact (start of the path of contact, face end y=0) at theta = 0",
                "tip_relief_um": [x / UM for x in mods.tip_relief], "lead_crowning_um": mods.lead_crowning / UM,
                "helix_slope_um": mods.helix_slope / UM, "n_slices": self.n_slices,
                "micro_geometry": "removals along the transverse line of action (ISO 1328-1)",
                "revision": MODEL_REVISION}
        return MeshExcitation(z1=z1, theta=theta, torque=tq, k=k_tab, e=e_tab, load_share=share,
                              definition="tangent; transverse line of action; thin-slice ISO 6336-1 level; no shaft/bearing",
                              metadata=meta)


    def slices(self, pair: GearPair, mods: MicroMods) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mesh angles, slice stiffnesses and gaps over one mesh period.

        Returns
        -------
        theta : ndarray, shape (n_theta,)
            Input angle within the mesh period, rad (pair 0 enters at 0).
        k : ndarray, shape (n_theta, n_pairs, n_slices)
            Stiffness of each slice of each pair, N/m (0 outside the path of contact). Pair ``p`` entered
            ``p`` mesh periods before pair 0.
        gap : ndarray, same shape
            Initial separation on the transverse line of action, m: the removals of ``mods``, taken as
            transverse values (see :class:`MicroMods`).
        """
        g = pair.g_alpha
        b = pair.face_width
        theta = np.arange(self.n_theta) * (2 * math.pi / pair.z[0]) / self.n_theta
        n_pairs = int(math.ceil(pair.eps_alpha + pair.eps_beta)) + 1
        y = (np.arange(self.n_slices) + 0.5) * b / self.n_slices
        z_e = entry_face_end(pair)
        z = z_e * (1 - 2 * y / b)  # axial position of each slice (the pair's z, face width centred on 0)
        # roll lag of each slice behind the entering end: -y tan(beta_b)
        lag = pair.rb[0] * (np.asarray(contact_shift(pair, z), float) - float(contact_shift(pair, z_e)))
        s = (pair.rb[0] * theta[:, None, None] + pair.pb_t * np.arange(n_pairs)[None, :, None]
             + lag[None, None, :])  # (n_theta, n_pairs, n_slices)
        inside = (s >= 0) & (s <= g)
        f_min = shape_min(pair.eps_alpha)
        u = np.clip(s / g, 0, 1)
        k_sl = np.where(inside, iso_single_stiffness(pair) * (f_min + (1 - f_min) * 4 * u * (1 - u)) * (b / self.n_slices),
                        0.0)
        return theta, k_sl, _gaps(pair, s, z, mods)


def equilibrium(k: np.ndarray, gap: np.ndarray, force: float) -> float:
    """Deflection ``d`` with ``sum k max(d - gap, 0) = force`` (piecewise linear, increasing in d)."""
    order = np.argsort(gap)
    gs, ks = gap[order], k[order]
    ck = np.cumsum(ks)
    ckg = np.cumsum(ks * gs)
    # with the first j+1 slices loaded: d = (force + sum k g) / sum k, valid if d <= gap[j+1]
    d = (force + ckg) / ck
    nxt = np.append(gs[1:], np.inf)
    j = int(np.argmax(d <= nxt))
    return float(d[j])


def _gaps(pair: GearPair, s: np.ndarray, z: np.ndarray, mods: MicroMods) -> np.ndarray:
    """Initial separation at roll position ``s`` and axial position ``z`` (from the middle of the face
    width), m: the material removed by ``mods`` along the transverse line of action (the convention of
    :class:`MicroMods`)."""
    gap = np.zeros_like(s)
    rb1, rb2 = pair.rb
    rho_start1 = pair.roll_start_active[0]
    tan_len = pair.aw * math.sin(pair.alpha_wt)
    rho1 = rho_start1 + s
    rho = (rho1, tan_len - rho1)  # roll length on gear 1 and gear 2
    for i in range(2):
        ca = mods.tip_relief[i]
        if ca == 0:
            continue
        tip = pair.roll_tip[i]
        d_ca = mods.tip_relief_start_diameter[i]
        if d_ca is None:
            rho_ca = pair.roll_start_active[i] + 2.0 / 3.0 * (tip - pair.roll_start_active[i])
        else:
            rb = (rb1, rb2)[i]
            if d_ca / 2 <= rb:
                raise CalibrationError(f"tip relief start diameter {d_ca * 1e3:.3f} mm of gear {i + 1} lies inside "
                                       f"its base circle ({2 * rb * 1e3:.3f} mm)")
            rho_ca = math.sqrt((d_ca / 2) ** 2 - rb**2)
        span = max(tip - rho_ca, 1e-9)
        gap += ca * np.clip((rho[i] - rho_ca) / span, 0.0, None)
    b = pair.face_width
    zz = np.broadcast_to(z, s.shape)
    if mods.lead_crowning:
        gap += mods.lead_crowning * (2 * zz / b) ** 2
    if mods.helix_slope:
        gap += mods.helix_slope * zz / b
    return gap


# ---------------------------------------------------------------- displaced teeth
# Tooth-local transmission error: one tooth out of place, followed through its whole engagement.
# 
# A tooth that stands behind (or ahead of) its nominal position changes the static TE only while it
# is in mesh, i.e. over about ``eps_gamma`` mesh periods per revolution of its gear. Its contact lines
# cross the face like those of every other tooth; while it is in mesh it shares the load with the
# other pairs through their stiffnesses. The thin-slice model of
# :class:`~gearrom.calibrate.micromodel.SliceMicroModel` gives the slices of every pair in contact; the
# displaced tooth adds its deviation to the gap of each of its slices and the static equilibrium
# ``sum k max(delta - gap, 0) = F_t`` is solved again. The result is non-linear in the deviation:
# a tooth set back by more than the static deflection of its neighbours leaves contact (the TE change
# saturates), a tooth set forward takes the load of the others.
# 
# Convention: ``deviation`` > 0 raises the TE (output lags more) while the tooth is in mesh, for
# either gear; tooth 0 enters contact (start of the path, face end ``y = 0``) at angle 0 of its gear.


def stiffness_scale(pair: GearPair, torque_Nm: float, k_mean: float, mods: MicroMods | None = None) -> float:
    """Factor on the slice stiffness that gives the mean mesh stiffness ``k_mean`` (N/m) of another model
    (e.g. the FE table) at ``torque_Nm``; 1 when either mean is not positive and finite."""
    k_sl = float(np.mean(SliceMicroModel().excitation(pair, [max(float(torque_Nm), 1e-9)], mods or MicroMods()).k[0]))
    return float(k_mean) / k_sl if k_sl > 0 and np.isfinite(k_mean) and k_mean > 0 else 1.0


def pitch_te(pair: GearPair, torque_Nm: float, gear: int, tooth_gaps_m, mods: MicroMods | None = None, *,
             model: SliceMicroModel | None = None, stiffness_scale: float = 1.0) -> np.ndarray:
    """Static TE change over one revolution of ``gear`` from deviations of its individual teeth.

    Parameters
    ----------
    pair : GearPair
    torque_Nm : float
        Output torque, N m (> 0).
    gear : {0, 1}
        Input (0) or output (1) gear.
    tooth_gaps_m : array_like, shape (z,)
        Deviation of each tooth on the transverse line of action, m (> 0: the flank is set back and the
        TE rises while the tooth is in mesh); tooth j enters contact at gear angle ``2 pi j / z``.
    mods : MicroMods, optional
        Flank modifications of all teeth (default none).
    model : SliceMicroModel, optional
        Slices and angles per mesh period (default ``SliceMicroModel()``).
    stiffness_scale : float
        Factor on every slice stiffness (to match the mesh stiffness of another model, e.g. the FE table).

    Returns
    -------
    ndarray, shape (z * n_theta,)
        TE change, m, on the grid ``j 2 pi / (z n_theta)`` of the gear angle.
    """
    model = model or SliceMicroModel()
    _, k, gap = model.slices(pair, mods or MicroMods())
    k = k * stiffness_scale
    n_t, n_p, _ = k.shape
    z = pair.z[gear]
    dev = np.asarray(tooth_gaps_m, float)
    if dev.shape != (z,) or not np.all(np.isfinite(dev)):
        raise CalibrationError(f"tooth deviations of gear {gear}: need {z} finite values, got shape {dev.shape}")
    force = torque_Nm / pair.rb[1]
    out = np.zeros(z * n_t)
    n_eng = min(n_p, z)
    # tooth j is pair p during mesh period j + p of its gear
    periods = sorted({(int(j) + p) % z for j in np.flatnonzero(dev) for p in range(n_eng)})
    for i in range(n_t):
        kk = k[i]
        loaded = kk.ravel() > 0
        d0 = equilibrium(kk.ravel()[loaded], gap[i].ravel()[loaded], force)
        for m in periods:
            g = gap[i] + dev[(m - np.arange(n_p)) % z][:, None] * (np.arange(n_p) < n_eng)[:, None]
            out[m * n_t + i] = equilibrium(kk.ravel()[loaded], g.ravel()[loaded], force) - d0
    return out


def tooth_te(pair: GearPair, torque_Nm: float, gear: int, deviation_m: float, mods: MicroMods | None = None, *,
             model: SliceMicroModel | None = None, stiffness_scale: float = 1.0) -> np.ndarray:
    """:func:`pitch_te` of tooth 0 alone displaced by ``deviation_m`` (m); zero while it is out of mesh."""
    dev = np.zeros(pair.z[gear])
    dev[0] = deviation_m
    return pitch_te(pair, torque_Nm, gear, dev, mods, model=model, stiffness_scale=stiffness_scale)


def periodic_sample(pattern: np.ndarray, theta: np.ndarray, shift: float = 0.0) -> np.ndarray:
    """``pattern(theta - shift)`` for a pattern on a uniform one-revolution grid (linear interpolation)."""
    n = pattern.size
    u = np.mod(np.asarray(theta) - shift, 2 * np.pi) * n / (2 * np.pi)
    i0 = np.floor(u).astype(int) % n
    f = u - np.floor(u)
    return pattern[i0] * (1 - f) + pattern[(i0 + 1) % n] * f
