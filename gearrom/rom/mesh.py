"""Gear mesh element: line-of-action geometry, force law and the non-periodic kinematic error terms.

Force law (transverse line of action, positive = pinion pushes the wheel)::

    F = F_nom + k(theta1) (delta - e(theta1))          drive flank in contact (F > 0)
    F = 0                                              contact loss: e0 - b < delta < e0
    F = k(theta1) (delta - e0 + b)  (< 0)              back flank, b = backlash along the LOA

with ``e0 = e - F_nom / k`` (the separation point), ``delta = w . q`` the mesh deflection and a damping
force ``c d(delta)/dt`` while in contact, ``c = 2 zeta sqrt(k_mean m_eq)``. ``k`` and ``e`` come from a
:class:`~gearrom.excitation.table.MeshExcitation` at the nominal torque; the form is the same for a
secant and a tangent table. In quasi-static motion ``F = F_nom`` so ``delta = e``: the ROM reproduces
the table's STE exactly.

Non-periodic kinematic error terms (:class:`Effects`), added to ``e``; angles in each gear's drive sense:

* :class:`Runout`: eccentricity ``ecc`` of gear ``i`` (= F_r / 2): TE term ``ecc sin(theta_i + phase)``.
  The radial component ``ecc cos(theta_i + phase)`` changes the centre distance and modulates the mesh:
  ``k -> k (1 + kappa da)`` and the fluctuating part of ``e`` by ``(1 - kappa da)``, with
  ``kappa = 0.75 d(eps_alpha)/da / (0.75 eps_alpha + 0.25)`` (ISO c_gamma shape) and
  ``d(eps_alpha)/da = -1 / (p_bt sin alpha_wt)``.
* :class:`PitchDeviations`: single pitch deviations ``f_p`` of every tooth (positive = tooth ahead in its
  gear's rotation). The cumulative deviation (mean ``f_p`` removed so that it closes) displaces each
  tooth (sign -1 for the input, +1 for the output gear), and each displaced tooth is followed through its
  engagement by the thin slices at the nominal load (:func:`pitch_curve`).
* :class:`ExtraTE`: any callable ``fn(theta1, theta2) -> m``.
* :class:`LoadRipple`: brake torque ripple ``A sin(order theta2 + phase)`` [N m].
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gearrom.errors import ModelError
from gearrom.geometry.pair import GearPair


@dataclass(frozen=True)
class Runout:
    """Eccentricity [m] (= F_r / 2) and phase [rad] of gear ``gear`` (0 input, 1 output)."""

    gear: int
    eccentricity: float
    phase: float = 0.0
    modulation: bool = True


@dataclass(frozen=True)
class PitchDeviations:
    """Single pitch deviation of every tooth of gear ``gear`` [m] (one per tooth)."""

    gear: int
    deviations: tuple[float, ...]


@dataclass(frozen=True)
class ExtraTE:
    """A user kinematic error term ``fn(theta1, theta2) -> m`` (drive-sense absolute angles [rad])."""

    fn: Callable[[float, float], float]
    label: str = "extra"


@dataclass(frozen=True)
class LoadRipple:
    """Brake torque ripple ``amplitude sin(order theta2 + phase)`` [N m], order per output revolution."""

    order: float
    amplitude: float
    phase: float = 0.0


@dataclass(frozen=True)
class Effects:
    """Non-periodic error terms of one run (all optional)."""

    runout: tuple[Runout, ...] = ()
    pitch: tuple[PitchDeviations, ...] = ()
    extra: tuple[ExtraTE, ...] = ()
    load_ripple: tuple[LoadRipple, ...] = ()

    @classmethod
    def from_pair(cls, pair: GearPair) -> "Effects":
        """Runout and pitch deviations recorded in the gears' enabled micro-geometry."""
        run, pit = [], []
        for i, g in enumerate(pair.gears):
            m = g.micro
            if not m.enabled:
                continue
            if m.runout > 0:
                run.append(Runout(i, m.eccentricity, m.runout_phase))
            if m.pitch_deviations:
                pit.append(PitchDeviations(i, tuple(m.pitch_deviations)))
        return cls(runout=tuple(run), pitch=tuple(pit))

    @property
    def empty(self) -> bool:
        return not (self.runout or self.pitch or self.extra or self.load_ripple)


def line_of_action(pair: GearPair) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Transverse mesh vectors ``(w1, w2)`` over ``(ux, uy, uz, rx, ry, rz)`` of each gear and the normal ``n``.

    Gear 1 at the origin, gear 2 at ``(a_w, 0, 0)``, axes along +z, pinion turning about +z. The
    contact point is the pitch point at mid-face; ``delta_t = w1 . q1 + w2 . q2`` with
    ``delta_t = rb1 rz1 + rb2 rz2`` for pure rotation (``rz2 = -theta2``).
    """
    a = pair.alpha_wt
    bb = pair.beta_b
    hand = 1.0 if pair.gears[0].hand in ("right", "spur") else -1.0
    n = np.array([math.sin(a) * math.cos(bb), math.cos(a) * math.cos(bb), hand * math.sin(bb)])
    rw1, rw2 = 0.5 * pair.dw[0], 0.5 * pair.dw[1]
    r1, r2 = np.array([rw1, 0.0, 0.0]), np.array([-rw2, 0.0, 0.0])
    w1 = np.concatenate([n, np.cross(r1, n)]) / math.cos(bb)
    w2 = -np.concatenate([n, np.cross(r2, n)]) / math.cos(bb)
    return w1, w2, n


def centre_distance_sensitivity(pair: GearPair) -> float:
    """kappa = d ln(c_gamma) / d a_w [1/m] (ISO c_gamma shape, see module docstring)."""
    de = -1.0 / (pair.pb_t * math.sin(pair.alpha_wt))
    return 0.75 * de / (0.75 * pair.eps_alpha + 0.25)


_PITCH_CACHE: dict = {}


def pitch_curve(pair: GearPair, gear: int, deviations, torque_Nm: float, stiffness_scale: float = 1.0,
                mods=None) -> np.ndarray:
    """TE change [m] over one revolution of ``gear`` from the single pitch deviations of its teeth.

    The cumulative deviation of each tooth (mean removed, positive = ahead in its gear's rotation)
    displaces it along the line of action: by ``-cum`` on the input gear (the output is pushed ahead,
    the TE drops) and ``+cum`` on the output gear. Each displaced tooth is followed through its
    engagement by the thin slices (:func:`gearrom.excitation.slices.pitch_te`: load shared with the
    other pairs, contact lost or load taken over when the deviation exceeds the deflection); the
    curve's mean is removed. Cached per pair, deviations, torque and stiffness scale.

    Parameters
    ----------
    pair : GearPair
    gear : {0, 1}
    deviations : sequence of float
        Single pitch deviation of every tooth, m (z values).
    torque_Nm : float
        Output torque of the static state, N m.
    stiffness_scale : float
        Factor on the slice stiffness (the mesh table's mean stiffness over the slices').
    mods : MicroMods, optional
        Flank modifications of the pair (:class:`gearrom.excitation.slices.MicroMods`; default none).
    """
    from gearrom.excitation.slices import pitch_te

    z = pair.z[gear]
    fp = np.asarray(deviations, dtype=float)
    if fp.size != z:
        raise ModelError(f"pitch deviations of gear {gear} need {z} values, got {fp.size}")
    key = (pair.z, pair.rb, pair.face_width, pair.beta_b, gear, tuple(fp), round(float(torque_Nm), 9),
           round(float(stiffness_scale), 9), mods)
    if key not in _PITCH_CACHE:
        cum = np.cumsum(fp - fp.mean())
        cum -= cum.mean()
        curve = pitch_te(pair, max(float(torque_Nm), 1e-9), gear, (-1.0 if gear == 0 else 1.0) * cum,
                         mods, stiffness_scale=stiffness_scale)
        _PITCH_CACHE[key] = curve - curve.mean()
    return _PITCH_CACHE[key]


def _call_vectorised(fn, th1: np.ndarray, th2: np.ndarray) -> np.ndarray:
    """``fn`` on arrays when it supports them (numpy ufuncs), else element by element."""
    try:
        v = np.asarray(fn(th1, th2), dtype=float)
        if v.shape == th1.shape:
            return v
    except (TypeError, ValueError):
        pass
    return np.array([float(fn(a, b)) for a, b in zip(th1, th2)])


@dataclass(frozen=True)
class ForceMap:
    """Static force-deflection map of the mesh over one mesh period (load-dependent mesh law).

    At each mesh angle the transmitted force is piecewise linear in the deflection through the
    knots ``(e[j](theta), f[j])``: row 0 is the kinematic TE (``f[0] = 0``, the separation point),
    rows 1..m the static TE of the table's torques (``f[j] = T_j / r_b2``). Between knots the law has
    the tangent stiffness of the FE force-deflection curve; beyond the last knot its last segment
    continues. A one-torque table gives the secant law at that torque.

    Attributes
    ----------
    theta : ndarray (n,)
        Uniform input angles over one mesh period [rad].
    e : ndarray (m + 1, n)
        Deflection at the knot forces [m] (strictly increasing in ``j`` at every angle).
    f : ndarray (m + 1,)
        Knot forces on the transverse line of action [N].
    """

    theta: np.ndarray
    e: np.ndarray
    f: np.ndarray

    @classmethod
    def from_table(cls, excitation, rb2: float, torque_ref: float, n: int = 512) -> "ForceMap":
        """The map of a :class:`~gearrom.excitation.table.MeshExcitation` on ``n`` angles per mesh period.

        Knot forces ``F_j = T_j / rb2``; knot deflections ``e_kin + F_j / k_j`` from the table's secant
        stiffness ``k_j``, with the kinematic TE ``e_kin = e - F / k`` at the run's torque
        ``torque_ref`` [N m]. For a table of the quasi-static FE (``k`` the secant of ``e``) the knots
        are the static TE of each torque; a table whose stiffness was changed alone keeps its static
        TE at ``torque_ref`` and scales the map's stiffness, as the secant law does.
        """
        th, k_ref, e_ref = excitation.sampled(float(torque_ref), n)
        kin = e_ref - float(torque_ref) / rb2 / k_ref
        rows, forces = [kin], [0.0]
        for T in np.sort(np.asarray(excitation.torque, dtype=float)):
            _, k, _ = excitation.sampled(float(T), n)
            rows.append(kin + float(T) / rb2 / k)
            forces.append(float(T) / rb2)
        e = np.vstack(rows)
        # the deflection grows with the load; round-off of nearly equal rows must not reverse it
        gap = 1e-12 * max(float(np.ptp(e)), 1e-9)
        for j in range(1, e.shape[0]):
            e[j] = np.maximum(e[j], e[j - 1] + gap)
        return cls(th, e, np.array(forces))

    @property
    def n_torques(self) -> int:
        return self.f.size - 1

    def tangent(self, force: float) -> np.ndarray:
        """Tangent stiffness dF/d(delta) [N/m] at each angle, at the static state under ``force`` [N]
        (a knot: the slope of the chord over its two neighbours; between knots: the segment's)."""
        f, e = self.f, self.e
        m = self.n_torques
        j = int(np.searchsorted(f, force, side="left"))
        if j <= m and math.isclose(f[min(j, m)], force, rel_tol=1e-9, abs_tol=1e-12) and 0 < j < m:
            return (f[j + 1] - f[j - 1]) / (e[j + 1] - e[j - 1])
        s = min(max(j - 1, 0), m - 1)  # segment containing the force (the last one beyond the map)
        return (f[s + 1] - f[s]) / (e[s + 1] - e[s])

    def static_te(self, force: float) -> np.ndarray:
        """Deflection at each angle under the static ``force`` [N] (the map's inverse) [m]."""
        f, e = self.f, self.e
        s = int(np.clip(np.searchsorted(f, force) - 1, 0, self.n_torques - 1))
        return e[s] + (force - f[s]) * (e[s + 1] - e[s]) / (f[s + 1] - f[s])

    def force(self, knots: np.ndarray, delta: np.ndarray, scale: np.ndarray | float = 1.0) -> np.ndarray:
        """Elastic force [N] at deflections ``delta`` (N,) given the knot deflections ``knots`` (N, m + 1)
        of each sample; 0 below the separation point; forces times ``scale`` (mesh stiffness modulation)."""
        m = self.n_torques
        s = np.clip((knots <= delta[:, None]).sum(axis=1) - 1, 0, m - 1)
        rows = np.arange(delta.size)
        e0, e1 = knots[rows, s], knots[rows, s + 1]
        f0, f1 = self.f[s], self.f[s + 1]
        out = f0 + (delta - e0) * (f1 - f0) / (e1 - e0)
        return np.where(delta > knots[:, 0], out, 0.0) * scale


def periodic_interp(rows: np.ndarray, theta: np.ndarray, period: float) -> np.ndarray:
    """Rows ``(m, n)`` sampled at ``j * period / n`` (one period), interpolated linearly and
    periodically at the angles ``theta`` [rad]: ``(m, len(theta))``.

    The same values as ``np.interp`` on the closed grid, found by index arithmetic on the uniform
    grid (no search), one index computation for all rows.
    """
    n = rows.shape[1]
    x = np.mod(theta, period) * (n / period)
    i = np.minimum(x.astype(np.intp), n - 1)
    f = x - i
    ext = np.concatenate([rows, rows[:, :1]], axis=1)
    a = ext[:, i]
    return a + f * (ext[:, i + 1] - a)


@dataclass
class MeshLaw:
    """Evaluates ``k`` and ``e`` (with effects) at given drive-sense angles; fast scalar path for the solver."""

    pair: GearPair
    theta_grid: np.ndarray  # one mesh period, uniform
    k_grid: np.ndarray
    e_grid: np.ndarray
    f_nom: float
    effects: Effects = field(default_factory=Effects)
    force_map: ForceMap | None = None  # load-dependent law (tables with a torque map), else the secant law

    @property
    def load_dependent(self) -> bool:
        return self.force_map is not None and self.force_map.n_torques > 1

    def __post_init__(self) -> None:
        self.z1 = self.pair.z[0]
        self.n = self.theta_grid.size
        self.kl = self.k_grid.tolist() + [float(self.k_grid[0])]
        self.el = self.e_grid.tolist() + [float(self.e_grid[0])]
        self.e_mean = float(np.mean(self.e_grid))
        self.scale = self.n * self.z1 / (2 * math.pi)
        self.kappa = centre_distance_sensitivity(self.pair)
        self.pitch = []
        if self.effects.pitch:
            from gearrom.excitation.slices import MicroMods, stiffness_scale

            # the slices carry the pair's flank modifications and the table's mean stiffness, as the
            # diagnosis' tooth model does (gearrom.calibrate.effects.pitch_error)
            torque = self.f_nom * self.pair.rb[1]
            mods = MicroMods.from_pair(self.pair)
            scale = stiffness_scale(self.pair, torque, float(np.mean(self.k_grid)), mods)
        for p in self.effects.pitch:
            curve = pitch_curve(self.pair, p.gear, p.deviations, torque, scale, mods)
            self.pitch.append((p.gear, curve.tolist() + [float(curve[0])], curve.size / (2 * math.pi)))

    def base(self, th1: float) -> tuple[float, float]:
        """``(k, e)`` of the table alone (no effects) at input angle ``th1`` [rad]."""
        x = th1 * self.scale
        i = math.floor(x)
        f = x - i
        i %= self.n
        return (self.kl[i] + f * (self.kl[i + 1] - self.kl[i]), self.el[i] + f * (self.el[i + 1] - self.el[i]))

    def evaluate(self, th1: float, th2: float) -> tuple[float, float]:
        """``(k [N/m], e [m])`` at drive-sense angles ``th1``, ``th2`` [rad], all effects included."""
        k, e = self.base(th1)
        eff = self.effects
        if eff.empty:
            return k, e
        mod = 0.0
        ths = (th1, th2)
        for r in eff.runout:
            if r.modulation:
                mod += self.kappa * r.eccentricity * math.cos(ths[r.gear] + r.phase)
        if mod:
            e = e - mod * (e - self.e_mean)
            k *= 1.0 + mod
        for r in eff.runout:
            e += r.eccentricity * math.sin(ths[r.gear] + r.phase)
        for gear, curve, sc in self.pitch:
            x = ths[gear] * sc
            i = math.floor(x)
            f = x - i
            i %= len(curve) - 1
            e += curve[i] + f * (curve[i + 1] - curve[i])
        for ex in eff.extra:
            e += float(ex.fn(th1, th2))
        return k, e

    def evaluate_array(self, th1: np.ndarray, th2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised :meth:`evaluate` for post-processing (same formulas)."""
        th1, th2 = np.asarray(th1, dtype=float), np.asarray(th2, dtype=float)
        k, e = periodic_interp(np.vstack([self.k_grid, self.e_grid]), th1, 2 * math.pi / self.z1)
        mod, add = self.effect_terms(th1, th2)
        return k * (1.0 + mod), e - mod * (e - self.e_mean) + add

    def effect_terms(self, th1: np.ndarray, th2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(mod, add)`` of the effects at the angles: the relative mesh stiffness modulation of runout
        (its fluctuating TE shrinks by ``1 - mod``) and the additive kinematic error [m]."""
        eff = self.effects
        mod = np.zeros_like(th1)
        add = np.zeros_like(th1)
        ths = (th1, th2)
        for r in eff.runout:
            if r.modulation:
                mod = mod + self.kappa * r.eccentricity * np.cos(ths[r.gear] + r.phase)
            add = add + r.eccentricity * np.sin(ths[r.gear] + r.phase)
        for gear, curve, sc in self.pitch:
            n = len(curve) - 1
            x = np.mod(ths[gear] * sc, n)
            add = add + np.interp(x, np.arange(n + 1), curve)
        for ex in eff.extra:
            add = add + _call_vectorised(ex.fn, th1, th2)
        return mod, add

    def knots_array(self, th1: np.ndarray, th2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Knot deflections (N, m + 1) [m] of the load-dependent law at the angles, effects included,
        and the force scale (N,) (ones: the modulation acts on the deflections).

        The additive error shifts every knot. Runout modulation acts as in the secant law: the
        deflection at the nominal force ``e_nom`` keeps ``e_nom - mod (e_nom - mean(e_nom))`` and the
        map's stiffness is scaled by ``1 + mod`` about it (knot deflections relative to ``e_nom``
        divided by ``1 + mod``); with one torque this is the secant law itself.
        """
        fm = self.force_map
        th1, th2 = np.asarray(th1, dtype=float), np.asarray(th2, dtype=float)
        mod, add = self.effect_terms(th1, th2)
        nom = fm.static_te(self.f_nom)
        v = periodic_interp(np.vstack([nom, fm.e]), th1, 2 * math.pi / self.z1)
        v_nom = v[0]
        base = v_nom - mod * (v_nom - nom.mean()) + add
        knots = (base[:, None] + (v[1:].T - v_nom[:, None]) / (1.0 + mod)[:, None])
        return knots, np.ones_like(th1)

    def ripple(self, th2: float) -> float:
        """Brake torque ripple [N m] at output angle ``th2``."""
        return sum(r.amplitude * math.sin(r.order * th2 + r.phase) for r in self.effects.load_ripple)
