"""Loaded tooth contact analysis (LTCA) of a spur pair with FE influence coefficients.

Mesh position: ``theta`` is the input-gear angle within one mesh period; at ``theta = 0`` tooth
pair 0 enters contact at the start of active profile of the input gear (the output gear's tip
meets the line of action). Pair ``p`` entered ``p`` mesh periods earlier; its contact point on the
input flank has roll length ``L1 = L1_SAP + r_b1 theta + p p_bt``, on the output flank
``L2 = a_w sin(alpha_wt) - L1``. Pairs just outside the path of contact are kept, so premature
(extended) contact of a deflected pair is found where the flanks exist.

Per position and torque the contact problem of :mod:`gearrom.fe.contact` is solved with the gap
of the two involutes measured along the line of action (second-order drop from the common
tangent with the involute curvature integrated exactly), plus the micro-geometry of
:mod:`gearrom.fe.flankgaps`. The approach ``delta`` is the loaded static TE along the transverse
line of action (positive when the output lags); the unloaded kinematic TE is the smallest gap.

Tip edges are rounded (:mod:`gearrom.fe.tipedge`): beyond the end of the involute, premature and
prolonged contact is carried by the rounding of the output gear's tip (entering pair) or the input
gear's tip (leaving pair). Those candidates use exact plane geometry: the grid points on the
rounding are projected on the mate's involute along its normal; a contact off the line of action
acts on the output gear with the lever arm of its normal, so its gap and compliance are expressed
per unit rigid approach along the line of action (factor ``lambda``, Vijayakar's generalised
contact). Without the rounding a sharp tip corner would touch: a singular contact whose pressure
and STE never converge with mesh refinement.
"""
from __future__ import annotations

import functools
import logging
import math
import warnings
import weakref
from dataclasses import dataclass

import numpy as np

from gearrom.errors import SolverError
from gearrom.fe.compliance import FlankCompliance
from gearrom.fe.contact import single_thread_blas, solve_contact
from gearrom.fe.flankgaps import needs_3d, pitch_removal, profile_removal, runout_removal, tip_limit
from gearrom.fe.tipedge import FlankArc, InvoluteFrame

log = logging.getLogger(__name__)

EDGE_GAP_MAX = 0.2e-3
"""Tip edge points farther than this from the mate's flank [m] are not contact candidates."""

EDGE_CANDIDATE_SPAN = 0.1e-3
"""Candidates on a tip edge rounding span +- this arc length around its closest point [m]
(gap s^2 / 2R of about 35 um at the end for R ~ 0.14 mm)."""

EDGE_PHI_WARN = 0.5
"""A loaded last grid point on the rounding beyond this fraction of the rounding's angle is an error
(the contact may run off the grid, which covers ``compliance.EDGE_GRID_FRACTION`` of it)."""
#: candidate geometry per compliance set (weak key: the input gear's compliances), LTCA geometry and
#: position (see :meth:`SpurLTCA._geometry`); a store holds at most GEOMETRY_CACHE_ENTRIES positions
_GEOMETRY: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
GEOMETRY_CACHE_ENTRIES = 4096


def _position_key(theta: float, mesh_index: int, window: float, only) -> tuple:
    """Key of one position in a store of :data:`_GEOMETRY`."""
    return float(theta), int(mesh_index), float(window), None if only is None else tuple(only)


_GX, _GW = np.polynomial.legendre.leggauss(8)
_GX, _GW = 0.5 * (_GX + 1), 0.5 * _GW


def _drop(t: np.ndarray, L_p: float, rb: float, sign: float) -> np.ndarray:
    """Distance of an involute point at arc offset ``t`` from the tangent at the contact point [m]."""
    s = np.multiply.outer(t, _GX)
    kappa = 1.0 / np.sqrt(np.maximum(L_p**2 + 2 * rb * sign * s, 1e-30))
    return t**2 * (((1 - _GX) * kappa) @ _GW)


def _interp(G: np.ndarray, ia: np.ndarray, wa: np.ndarray, ib: np.ndarray, wb: np.ndarray) -> np.ndarray:
    """``G`` between grid positions ``ia + wa`` (rows) and ``ib + wb`` (columns), interpolated along the
    diagonal (shift of both points, exact for a shift-invariant kernel, so the self-compliance peak is
    not smeared) and linearly in the offset between the two points."""
    n = G.shape[0]
    if not (np.any(wa) or np.any(wb)):
        return G[np.ix_(ia, ib)]
    off = (ib + wb)[None, :] - (ia + wa)[:, None]
    m = np.floor(off).astype(int)
    f = off - m
    A = np.broadcast_to(ia[:, None], m.shape)

    def g(r, c):
        return G[np.clip(r, 0, n - 1), np.clip(c, 0, n - 1)]

    base = (1 - f) * g(A, A + m) + f * g(A, A + m + 1)
    if not np.any(wa):
        return base
    shifted = (1 - f) * g(A + 1, A + 1 + m) + f * g(A + 1, A + m + 2)
    return (1 - wa)[:, None] * base + wa[:, None] * shifted


@dataclass(frozen=True)
class PositionResult:
    """Contact solution at one mesh position and torque.

    Attributes
    ----------
    theta, torque : float
        Input angle in the mesh period [rad], output torque [N m].
    ste, ste_kinematic : float
        Loaded and unloaded TE along the transverse line of action [m] (positive: output lags).
    force : float
        Transverse line-of-action force torque / r_b2 [N].
    pair, roll1, force_c, pressure : ndarray
        Per contact candidate: pair index, input-gear roll length [m], contact force along the flank
        normal [N] (for a helical pair its transverse component is ``cos(beta_b)`` times it, the rest
        is axial), contact pressure [Pa] (normal force over the candidate's patch in the flank).
    pairs : ndarray of int; pair_force : ndarray
        Pair indices and the force each carries [N], as its share of the transverse line-of-action
        force (torque on the output gear / r_b2), so ``pair_force.sum() == force``; for the involute
        contact of a spur pair this is the normal force, for a helical pair ``cos(beta_b)`` times it.
    """

    theta: float
    torque: float
    ste: float
    ste_kinematic: float
    force: float
    pair: np.ndarray
    roll1: np.ndarray
    force_c: np.ndarray
    pressure: np.ndarray
    pairs: np.ndarray
    pair_force: np.ndarray

    @property
    def max_pressure(self) -> float:
        return float(self.pressure.max())

    @property
    def stiffness(self) -> float:
        """Secant mesh stiffness F / (STE - STE_kinematic) [N/m]."""
        return self.force / max(self.ste - self.ste_kinematic, 1e-300)


class SpurLTCA:
    """LTCA of a spur pair (the plane-strain model of any pair's transverse section).

    Parameters
    ----------
    pair : GearPair
        Geometry and micro-geometry (changing the micro-geometry needs no new FE solve: build a new
        ``SpurLTCA`` with the same compliances).
    compliances : (FlankCompliance, FlankCompliance)
        Influence coefficients of both gears (same grid spacing).
    window : float
        Half-width of the candidate zone around each ideal contact point [m] (grows automatically).
    tol : float
        Allowed penetration after the solve [m].
    """

    def __init__(self, pair, compliances: tuple[FlankCompliance, FlankCompliance], window: float = 0.4e-3,
                 tol: float = 1e-11) -> None:
        c1, c2 = compliances
        if not math.isclose(c1.spacing, c2.spacing, rel_tol=1e-9):
            raise SolverError(f"both gears need the same flank grid spacing, got {c1.spacing} and {c2.spacing} m")
        ignored = needs_3d(pair)
        if ignored:
            warnings.warn(f"the plane (2D) LTCA ignores {', '.join(ignored)}: use the 3D model", stacklevel=2)
        self.pair, self.c = pair, (c1, c2)
        self.window, self.tol = window, tol
        self.T = pair.aw * math.sin(pair.alpha_wt)
        self.L1_start = pair.roll_start_active[0]
        self.pb = pair.pb_t
        # the tip edge rounding of each gear (geometry of the compliance grid: the FE mesh has it)
        self.arcs = tuple(FlankArc.of(pair, i, c.edge_radius) for i, c in enumerate((c1, c2)))
        self.n_inv = (c1.n_involute, c2.n_involute)
        # involute contact ends at the effective tip (d_Na) or where the involute ends; beyond the
        # involute end the rounding carries the contact (when d_Na does not cut the tooth below it)
        self.L_tip = tuple(min(tip_limit(pair, i), math.sqrt(2 * c.rb * min(c.u_edge, c.sigma[-1] + 0.5 * c.spacing)))
                           for i, c in enumerate((c1, c2)))
        self.rounded = tuple(c.edge_radius > 0 and c.sigma.size > c.n_involute
                             and tip_limit(pair, i) >= self.arcs[i].L_t * (1 - 1e-9) for i, c in enumerate((c1, c2)))
        # every pair that can touch: the nominal ones (0 .. ceil(eps_alpha)) plus one more on each side
        # (premature contact of the next pair, prolonged contact of the leaving one), plus a spare each
        # side that must stay unloaded (checked in mesh_cycle)
        n_pairs = int(math.ceil(pair.eps_alpha)) + 1
        self.pair_range = np.arange(-2, n_pairs + 1)

    @property
    def period(self) -> float:
        return 2 * math.pi / self.pair.z[0]

    # ---------------------------------------------------------------- gaps
    def _frames(self, L1P: float, L2P: float) -> tuple[InvoluteFrame, InvoluteFrame]:
        """Both loaded involutes of one pair in the line-of-action frame (x along the line of action from
        the input base tangent point, input centre at (0, -r_b1), output centre at (T, r_b2))."""
        rb1, rb2 = self.c[0].rb, self.c[1].rb
        return (InvoluteFrame((0.0, -rb1), rb1, (0.0, 1.0), (1.0, 0.0), L1P),
                InvoluteFrame((self.T, rb2), rb2, (0.0, -1.0), (-1.0, 0.0), L2P))

    def _edge_candidates(self, g: int, L1P: float, L2P: float):
        """Contact of the tip edge rounding of gear ``g`` with the mate's involute (exact plane geometry).

        The rounding's point closest to the mate's involute is found exactly (its centre projected on
        the involute along the involute's normal, which is tangent to the mate's base circle);
        candidates sit there and at multiples of the grid spacing on either side along the rounding
        (compliances interpolated between grid points), so the first touch and the gap function
        ``s^2 / 2R`` of the small rounding radius are not sampled at arbitrary grid points. Each
        candidate is projected on the mate's involute (the master). Returns (i1, w1, i2, w2, d, lam,
        roll1, end, u_min, Lf) or None (``u_min``: the first candidate's flank coordinate on the rounding [m],
        the involute-involute candidates stop half a spacing before it; ``Lf``: the roll length of the
        projection on the mate's involute [m]); ``d`` is the geometric normal gap [m] (the flank
        modifications are added by :meth:`candidates`), ``lam`` the normal displacement of the
        contact per unit rigid approach along the line of action (1 when the master is the output
        gear's involute; the output gear's lever arm of the contact normal over r_b2 otherwise).
        """
        c, cm = self.c[g], self.c[1 - g]
        arc = self.arcs[g]
        h = c.spacing
        frames = self._frames(L1P, L2P)
        centre = frames[g].arc_points(arc, np.array([0.0])) - arc.rho * frames[g].basis(np.array([arc.L_t]))[1]
        _, _, n0 = frames[1 - g].project(centre)
        ug, eg = frames[g].basis(np.array([arc.L_t]))
        phi0 = math.atan2(-n0[0] @ ug[0], -n0[0] @ eg[0])  # rounding angle of the closest point
        u_lo, u_hi = c.u_edge, c.sigma[-1]
        K = int(math.ceil(EDGE_CANDIDATE_SPAN / h))
        u = c.u_edge + arc.rho * phi0 + h * np.arange(-K, K + 1)
        u = u[(u >= u_lo) & (u <= u_hi)]
        if u.size == 0:
            return None
        phi = (u - c.u_edge) / arc.rho
        q = frames[g].arc_points(arc, phi)
        d, Lf, n = frames[1 - g].project(q)
        if g == 1:  # master = input involute: lever arm of the normal about the output centre
            r = q - frames[1].o
            lam = (-r[:, 1] * n[:, 0] + r[:, 0] * n[:, 1]) / c.rb
        else:
            lam = np.ones(u.size)
        U = (Lf**2 / (2 * cm.rb) - cm.sigma[0]) / cm.spacing
        im = np.floor(U).astype(int)
        wm = U - im
        keep = ((im >= 0) & (im + 1 <= self.n_inv[1 - g] - 1) & (Lf <= self.L_tip[1 - g] + 1e-12) & (d < EDGE_GAP_MAX)
                & (lam > 0.1))
        if not keep.any():
            return None
        u, im, wm, d, Lf, lam, phi = u[keep], im[keep], wm[keep], d[keep], Lf[keep], lam[keep], phi[keep]
        Us = (u - c.sigma[0]) / h
        io = np.minimum(np.floor(Us).astype(int), c.sigma.size - 2)
        wo = Us - io
        end = (u > u_hi - h) & (phi >= EDGE_PHI_WARN * arc.phi_full)
        if g == 1:
            return im, wm, io, wo, d, lam, Lf, end, float(u.min()), Lf
        return io, wo, im, wm, d, lam, np.sqrt(2 * c.rb * u), end, float(u.min()), Lf

    @functools.cached_property
    def _positions(self) -> dict:
        """This LTCA's store in :data:`_GEOMETRY`: keyed by what the candidate geometry depends on besides the
        compliances and the position (taken at first use, when a subclass has set its own fields)."""
        key = (type(self).__name__, self.c[1], self.T, self.L1_start, self.pb, self.L_tip, self.rounded, self.arcs,
               self.n_inv, tuple(self.pair_range), self.pair.z, getattr(self, "dz", None))
        return _GEOMETRY.setdefault(self.c[0], {}).setdefault(key, {})

    def _geometry(self, theta: float, mesh_index: int, window: float, only) -> list:
        """The part of :meth:`candidates` that does not depend on the flank modifications, runout or pitch
        deviations (candidate points, weights, lambdas, geometric gaps, roll lengths), per pair.

        Kept per compliance set and position (:data:`_GEOMETRY`): LTCAs rebuilt with the same compliances
        for another micro-geometry (:func:`gearrom.calibrate.microfe.with_micro`, tolerance studies)
        reuse it and only add their gaps.
        """
        store, key = self._positions, _position_key(theta, mesh_index, window, only)
        hit = store.get(key)
        if hit is not None:
            return hit
        pr, (c1, c2) = self.pair, self.c
        W = window
        rb1, rb2 = c1.rb, c2.rb
        d = c1.spacing
        n1, n2 = self.n_inv
        L1_0 = self.L1_start + rb1 * theta
        rot1 = mesh_index * self.period + (L1_0 - 0.5 * pr.dw[0] * math.sin(pr.alpha_wt)) / rb1
        out = []
        for p in self.pair_range if only is None else only:
            L1P = L1_0 + p * self.pb
            L2P = self.T - L1P
            if L1P <= 0 or L2P <= 0:
                continue
            # tip edge roundings against the mate's involute (premature / prolonged contact)
            edges, u_stop = [], [np.inf, np.inf]
            for g in (1, 0):
                if self.rounded[g]:
                    e = self._edge_candidates(g, L1P, L2P)
                    if e is not None:
                        edges.append((g, e))
                        u_stop[g] = e[8] - 0.5 * d
            # involute against involute, around the ideal contact point on the line of action
            s1P, s2P = L1P**2 / (2 * rb1), L2P**2 / (2 * rb2)
            a = np.flatnonzero((np.abs(c1.sigma[:n1] - s1P) <= W) & (c1.sigma[:n1] <= u_stop[0]))
            a = a[np.sqrt(2 * rb1 * c1.sigma[a]) <= self.L_tip[0] + 1e-12]
            U0 = (s2P + s1P - c2.sigma[0] - c1.sigma[0]) / d
            fa0 = math.floor(U0)
            w = U0 - fa0
            fa = fa0 - a
            keep = (fa >= 0) & (fa + 1 <= n2 - 1)
            a, fa = a[keep], fa[keep]
            s2 = c2.sigma[0] + (fa + w) * d
            keep = (np.sqrt(2 * rb2 * s2) <= self.L_tip[1] + 1e-12) & (s2 <= u_stop[1])
            a, fa, s2 = a[keep], fa[keep], s2[keep]
            inv = None
            if a.size:
                t = c1.sigma[a] - s1P
                L1 = np.sqrt(2 * rb1 * c1.sigma[a])
                L2 = np.sqrt(2 * rb2 * s2)
                inv = (a, fa, w, _drop(t, L1P, rb1, 1.0) + _drop(t, L2P, rb2, -1.0), L1, L2, np.abs(t) >= W - 1.01 * d)
            if inv is None and not edges:
                continue
            # the ideal contact point itself (t = 0) when it lies on both involutes
            on = (c1.sigma[0] <= s1P <= c1.sigma[n1 - 1] and L1P <= self.L_tip[0] and c2.sigma[0] <= s2P <= c2.sigma[n2 - 1]
                  and L2P <= self.L_tip[1])
            out.append((int(p), mesh_index - p, rot1 + p * self.period, L1P, L2P, inv, edges, on))
        if len(store) >= GEOMETRY_CACHE_ENTRIES:
            store.clear()
        store[key] = out
        return out

    def cached_compliance(self, theta: float, mesh_index: int, window: float, only, cands) -> np.ndarray:
        """:meth:`compliance_matrix` of ``cands`` (the candidates at that position), kept with their geometry
        (:meth:`_geometry`: it depends on the candidate points only); read-only."""
        store, key = self._positions, ("C", *_position_key(theta, mesh_index, window, only))
        C = store.get(key)
        if C is None:
            C = self.compliance_matrix(cands)
            C.flags.writeable = False
            store[key] = C
        return C

    def candidates(self, theta: float, mesh_index: int = 0, window: float | None = None, only=None):
        """Contact candidates per pair at ``theta``.

        Each entry: (pair, gear-1 grid indices, gear-2 grid indices, gear-2 interpolation weights,
        gaps [m], input roll lengths [m], window-edge flags, smallest gap incl. the ideal point [m],
        gear-1 interpolation weights, lambda, grid-end flags). A point of gear ``g`` at ``(i, w)`` lies at
        ``sigma[i] + w * spacing``. The gaps are expressed as rigid approach along the line of action
        that closes them (normal gap / lambda, see :meth:`_edge_candidates`); involute-involute
        candidates have lambda = 1.
        """
        pr = self.pair
        out = []
        for p, tooth, r1, L1P, L2P, inv, edges, on in self._geometry(theta, mesh_index, window or self.window, only):
            extra = (pitch_removal(pr, 0, tooth) + pitch_removal(pr, 1, tooth)
                     + runout_removal(pr, 0, r1) + runout_removal(pr, 1, r1 * pr.z[0] / pr.z[1]))
            parts = []
            if inv is not None:
                a, fa, w, geo, L1, L2, edge = inv
                gap = geo + profile_removal(pr, 0, L1) + profile_removal(pr, 1, L2) + extra
                ones = np.ones(a.size)
                parts.append((a, 0 * ones, fa, w * ones, gap, ones, L1, edge, ones < 0))
            for g, (i1, w1, i2, w2, dist, lam, roll, end, _, Lf) in edges:
                L_own = np.full(dist.size, self.arcs[g].L_t)
                gap = dist + extra + profile_removal(pr, g, L_own) + profile_removal(pr, 1 - g, Lf)
                parts.append((i1, w1, i2, w2, gap, lam, roll, np.zeros(i1.size, bool), end))
            i1, w1, i2, w2, gap, lam, roll, edge, end = (np.concatenate(x) for x in zip(*parts))
            h = gap / lam
            g0 = float(profile_removal(pr, 0, np.array([L1P]))[0] + profile_removal(pr, 1, np.array([L2P]))[0]
                       + extra) if on else np.inf
            out.append((p, i1.astype(int), i2.astype(int), w2, h, roll, edge, min(g0, float(h.min())), w1, lam, end))
        return out

    def compliance_matrix(self, cands) -> np.ndarray:
        """Compliance [m/N] between all candidates (both gears, cyclic symmetry), in line-of-action
        units (scaled by 1 / (lambda_k lambda_l), see :meth:`candidates`)."""
        c1, c2 = self.c
        n = sum(c[1].size for c in cands)
        C = np.zeros((n, n))
        starts = np.cumsum([0] + [c[1].size for c in cands])
        for i, ci in enumerate(cands):
            p, a, fa, w, w1a = ci[0], ci[1], ci[2], ci[3], ci[8]
            for j, cj in enumerate(cands):
                q, b, fb, v, w1b = cj[0], cj[1], cj[2], cj[3], cj[8]
                blk = _interp(c1.block(p - q), a, w1a, b, w1b) + _interp(c2.block(q - p), fa, w, fb, v)
                C[starts[j]:starts[j + 1], starts[i]:starts[i + 1]] = blk.T  # rows: response, cols: load
        lam = np.concatenate([c[9] for c in cands])
        C /= np.outer(lam, lam)
        return 0.5 * (C + C.T)

    # --------------------------------------------------------------- solve
    def solve(self, theta: float, torque: float, mesh_index: int = 0, only=None) -> PositionResult:
        """Contact solution at input angle ``theta`` [rad] and output torque ``torque`` [N m]."""
        return self.solve_many(theta, [torque], mesh_index, only)[0]

    def solve_many(self, theta: float, torques, mesh_index: int = 0, only=None) -> list[PositionResult]:
        """Solutions at one position for several output torques [N m] (one compliance matrix).

        ``only``: restrict the contact to these pair indices (e.g. ``[0]`` for a single pair's stiffness).
        """
        with single_thread_blas():
            return self._solve_many(theta, torques, mesh_index, only)

    def _solve_many(self, theta: float, torques, mesh_index: int, only) -> list[PositionResult]:
        W = self.window
        for _ in range(4):
            cands = self.candidates(theta, mesh_index, W, only)
            where = f" at theta = {math.degrees(theta):.4f} deg (mesh {mesh_index})"
            if not cands:
                raise SolverError(f"contact not found{where}: no flank points of both gears lie near the line of action")
            C = self.cached_compliance(theta, mesh_index, W, only, cands)
            h = np.concatenate([c[4] for c in cands])
            pid = np.concatenate([np.full(c[1].size, c[0]) for c in cands])
            roll = np.concatenate([c[5] for c in cands])
            edge = np.concatenate([c[6] for c in cands])
            lam = np.concatenate([c[9] for c in cands])
            end = np.concatenate([c[10] for c in cands])
            kin = min(c[7] for c in cands)
            results, grow = [], False
            for tq in torques:
                F = tq / self.pair.rb[1]
                sol = solve_contact(C, h, F, tol=self.tol, where=where)
                if np.any(sol.f[edge] > 1e-9 * F):
                    grow = True
                    break
                if np.any(sol.f[end] > 1e-9 * F):
                    raise SolverError(f"contact reaches the end of the flank grid on the tip edge rounding{where} "
                                      f"at {tq:.4g} N m (extend gearrom.fe.compliance.EDGE_GRID_FRACTION)")
                if sol.gap.min() < -self.tol:
                    raise SolverError(f"penetration {-sol.gap.min() * 1e6:.3g} um{where} exceeds {self.tol * 1e6:.3g} um")
                width = self.c[0].spacing * self.c[0].face_width
                pf = np.array([sol.f[pid == p].sum() for p in self.pair_range])
                fn = sol.f / lam  # normal contact forces (sol.f: line-of-action equivalents)
                results.append(PositionResult(theta=theta, torque=tq, ste=sol.delta, ste_kinematic=kin, force=F,
                                              pair=pid, roll1=roll, force_c=fn, pressure=fn / width,
                                              pairs=self.pair_range.copy(), pair_force=pf))
            if not grow:
                return results
            W *= 2
        raise SolverError(f"contact zone reaches the candidate window{where} even at {W * 1e3:.2f} mm")
