"""Loaded tooth contact analysis of a helical pair with 3D FE compliances.

Contact lines: the face width is cut into ``n_slices`` strips at axial positions ``z_m``. The
transverse section at ``z`` of gear 1 is its z = 0 section turned by the helix twist, so at input
angle ``theta`` (clockwise, the running direction) it meshes like the z = 0 section at
``theta_z = theta - twist_1(z) = theta + contact_shift(z)``
(:func:`gearrom.geometry.profile.contact_shift` derives it and the face end that enters contact
first); pair ``p`` touches there at input roll ``L1 = L1_SAP + r_b1 theta_z + p p_bt`` (the oblique
contact lines of the plane of action). Around each line point the contact is resolved across the
line by ``2 K + 1`` patches of width ``d_mu`` (along the transverse profile, which is perpendicular
to the contact line in the flank's tangent plane) and length
``d_z / cos(beta_b)`` (along the line): the candidates.

Compliance between two candidates = for each gear the smooth 3D FE part ``B`` of
:mod:`gearrom.fe.compliance3d` (bilinear in the flank grid, cyclic symmetry between teeth, coupled
over the whole face width and the neighbouring teeth) + for candidates of the same tooth pair the
half-space surface compliance of the two uniform-pressure patches (Love's rectangle,
:mod:`gearrom.fe.halfspace`): the near field that the FE mesh does not resolve.

Gaps: the transverse separation of the two involutes at each candidate (second-order drop,
exact curvature) plus micro-geometry, measured as ISO 1328 does in the transverse plane along
the base tangent: tip relief / profile crowning / profile slope (own roll length), lead crowning
C_b (parabolic, C_b at both ends of the common face width) and helix slope f_Hbeta (linear,
+f_Hbeta/2 removed at z = +b/2), pitch deviations and runout of the tooth / section. Normal
gaps are the transverse ones times cos(beta_b), the normal force sum is F_t / cos(beta_b)
(F_t = torque / r_b2), and the static TE is the normal approach / cos(beta_b) (transverse line of
action, positive when the output lags). Changing torque or micro-geometry needs no FE solve.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gearrom.errors import SolverError
from gearrom.fe.contact import single_thread_blas, solve_contact
from gearrom.fe.halfspace import rect_surface
from gearrom.fe.ltca import PositionResult
from gearrom.fe.flankgaps import lead_removal, pitch_removal, profile_removal, runout_removal, tip_limit

_GX, _GW = np.polynomial.legendre.leggauss(8)
_GX, _GW = 0.5 * (_GX + 1), 0.5 * _GW


def _drop(t: np.ndarray, L_p: np.ndarray, rb: float, sign: float) -> np.ndarray:
    """Distance of involute points at arc offsets ``t`` from the tangents at roll lengths ``L_p`` [m]."""
    s = t[:, None] * _GX[None, :]
    kappa = 1.0 / np.sqrt(np.maximum(L_p[:, None] ** 2 + 2 * rb * sign * s, 1e-30))
    return t**2 * (((1 - _GX) * kappa) @ _GW)


def _solve_from(C: np.ndarray, h: np.ndarray, force: float, active: np.ndarray, tol: float, max_iter: int = 30):
    """Primal-dual active set from an initial active set (the iteration of
    :func:`gearrom.fe.contact.solve_contact`); None if it does not converge (caller falls back)."""
    from scipy.linalg import cho_factor, cho_solve

    from gearrom.fe.contact import activate_penetrating

    active = active.copy()
    if not active.any():
        return None
    for it in range(1, max_iter + 1):
        idx = np.flatnonzero(active)
        try:  # on the active set: C_AA f = delta 1 - h_A with sum f = F (Cholesky of the SPD block)
            cf = cho_factor(C[np.ix_(idx, idx)], check_finite=False)
        except np.linalg.LinAlgError:
            return None
        x = cho_solve(cf, np.column_stack([np.ones(idx.size), h[idx]]), check_finite=False)
        delta = float((force + x[:, 1].sum()) / x[:, 0].sum())
        fa = delta * x[:, 0] - x[:, 1]
        if np.any(fa < 0):
            active[idx[fa < 0]] = False
            if not active.any():
                return None
            continue
        sol, _ = activate_penetrating(h, C, idx, fa, delta, active, tol, it)
        if sol is not None:
            return sol
    return None


@dataclass(frozen=True)
class HelicalPositionResult(PositionResult):
    """:class:`~gearrom.fe.ltca.PositionResult` plus the axial position ``z`` [m] of every candidate
    (``roll1`` x ``z`` x ``pressure`` is the contact pattern over profile x face width)."""

    z: np.ndarray = None


class Helical3DLTCA:
    """LTCA of a helical pair with 3D FE compliances (see module doc); interface of :class:`SpurLTCA`.

    Parameters
    ----------
    pair : GearPair
    compliances : (FlankCompliance3D, FlankCompliance3D)
    n_slices : int
        Strips over the common face width (contact line resolution along the face).
    d_mu : float
        Patch width across the contact line [m] (resolves the Hertz width, ~0.08 mm here).
    half_window : float
        Candidates within this distance of the ideal contact line [m] at the start of each torque's solve
        (doubled while the contact reaches the window's edge or could lie past it, :meth:`_touches_outside`).
    tol : float
        Allowed penetration after the solve [m].
    window : float, optional
        Alias of ``half_window`` (the keyword of the other LTCA classes; attribute ``window``).
    """

    def __init__(self, pair, compliances, n_slices: int = 24, d_mu: float = 0.03e-3, half_window: float = 0.18e-3,
                 tol: float = 1e-11, window: float | None = None) -> None:
        if n_slices < 4:
            raise SolverError(f"n_slices must be >= 4, got {n_slices}")
        half_window = half_window if window is None else window
        if not 0 < d_mu < half_window:
            raise SolverError(f"need 0 < d_mu < half_window, got {d_mu}, {half_window} m")
        self.pair, self.c, self.tol = pair, tuple(compliances), tol
        self.n_slices, self.d_mu = int(n_slices), float(d_mu)
        self.K = int(math.ceil(half_window / d_mu - 1e-9))
        self.window = self.K * self.d_mu
        b = pair.face_width
        self.dz = b / n_slices
        self.z = -0.5 * b + (np.arange(n_slices) + 0.5) * self.dz
        self.cosb = math.cos(pair.beta_b)
        self.d_lam = self.dz / self.cosb
        self.T = pair.aw * math.sin(pair.alpha_wt)
        self.L1_start = pair.roll_start_active[0]
        self.pb = pair.pb_t
        from gearrom.geometry.profile import contact_shift

        self.shift = np.asarray(contact_shift(pair, self.z), float)  # theta_z - theta (clockwise input angle)
        s_lo = [c.sigma[0] - 0.5 * c.d_sigma for c in self.c]
        s_hi = [c.sigma[-1] + 0.5 * c.d_sigma for c in self.c]
        self.s_lo = tuple(s_lo)
        self.s_hi = tuple(min(s, tip_limit(pair, i) ** 2 / (2 * c.rb)) for i, (s, c) in enumerate(zip(s_hi, self.c)))
        # pairs that can touch anywhere on the face during one mesh period, plus one spare each side
        L_lo = math.sqrt(2 * self.c[0].rb * self.s_lo[0])
        L_hi = math.sqrt(2 * self.c[0].rb * self.s_hi[0])
        base = self.L1_start + self.c[0].rb * self.shift
        p_min = math.floor((L_lo - base.max() - self.c[0].rb * self.period) / self.pb) - 1
        p_max = math.ceil((L_hi - base.min()) / self.pb) + 1
        self.pair_range = np.arange(p_min, p_max + 1)
        kap = sum(c.halfspace_factor for c in self.c)
        self._hs_kappa = kap
        self._table_K = -1
        self._warm: dict = {}
        self.model_description = (f"3D FE sector compliances ({self.c[0].info.get('dofs', '?')} / "
                                  f"{self.c[1].info.get('dofs', '?')} dofs, P2 tetrahedra), {n_slices} strips x "
                                  f"{2 * self.K + 1} patches of {d_mu * 1e3:.3f} mm across each contact line, "
                                  "Boussinesq half-space near field; normal forces, TE on the transverse line of action")

    @property
    def period(self) -> float:
        return 2 * math.pi / self.pair.z[0]

    # ---------------------------------------------------------------- gaps
    def _lead_removal(self, z: np.ndarray) -> np.ndarray:
        return lead_removal(self.pair, 0, z) + lead_removal(self.pair, 1, z)

    def _fine(self, theta: float, mesh_index: int, K: int, only=None) -> dict:
        """All candidates at ``theta`` (flat arrays; see module doc)."""
        pr, (c1, c2) = self.pair, self.c
        rb1, rb2 = c1.rb, c2.rb
        P = self.pair_range if only is None else np.asarray(only)
        thz = theta + self.shift
        L1P = self.L1_start + rb1 * thz[:, None] + P[None, :] * self.pb  # (M, np)
        L2P = self.T - L1P
        k = np.arange(-K, K + 1)
        t = k * self.d_mu
        ok = (L1P > 0) & (L2P > 0)
        s1P = np.where(ok, L1P, 0) ** 2 / (2 * rb1)
        s2P = np.where(ok, L2P, 0) ** 2 / (2 * rb2)
        s1 = s1P[:, :, None] + t
        s2 = s2P[:, :, None] - t
        valid = (ok[:, :, None] & (s1 >= self.s_lo[0]) & (s1 <= self.s_hi[0]) & (s2 >= self.s_lo[1])
                 & (s2 <= self.s_hi[1]))
        ip, m, ik = np.nonzero(valid.transpose(1, 0, 2))  # pair-major: same-pair blocks are contiguous
        if m.size == 0:
            return {}
        p = P[ip]
        tt = t[ik]
        L1, L2 = np.sqrt(2 * rb1 * s1[m, ip, ik]), np.sqrt(2 * rb2 * s2[m, ip, ik])
        gap = (_drop(tt, L1P[m, ip], rb1, 1.0) + _drop(tt, L2P[m, ip], rb2, -1.0) + profile_removal(pr, 0, L1)
               + profile_removal(pr, 1, L2) + self._lead_removal(self.z[m]))
        # pitch and runout per (slice, pair)
        lines, li = np.unique(np.column_stack([ip, m]), axis=0, return_inverse=True)
        lines = lines[:, ::-1]  # (slice, pair column)
        li = li.ravel()
        extra = np.zeros(lines.shape[0])
        for n, (mm, jj) in enumerate(lines):
            tooth = mesh_index - int(P[jj])
            r1 = (mesh_index * self.period + (self.L1_start + rb1 * thz[mm] - 0.5 * pr.dw[0] * math.sin(pr.alpha_wt)) / rb1
                  + int(P[jj]) * self.period)
            extra[n] = (pitch_removal(pr, 0, tooth) + pitch_removal(pr, 1, tooth) + runout_removal(pr, 0, r1)
                        + runout_removal(pr, 1, r1 * pr.z[0] / pr.z[1]))
        gap = gap + extra[li]
        return {"m": m, "p": p, "k": k[ik], "li": li, "gap_t": gap, "roll1": L1, "z": self.z[m],
                "line_m": lines[:, 0], "line_p": P[lines[:, 1]], "line_s1": s1P[lines[:, 0], lines[:, 1]],
                "line_s2": s2P[lines[:, 0], lines[:, 1]], "edge": np.abs(k[ik]) == K}

    def candidates(self, theta: float, mesh_index: int = 0, window: float | None = None, only=None):
        """Per pair: (pair, slice indices, across indices, None, transverse gaps [m], input roll [m],
        window-edge flags, smallest gap [m]) - the layout of :meth:`SpurLTCA.candidates`."""
        K = self.K if window is None else max(1, int(math.ceil(window / self.d_mu)))
        d = self._fine(theta, mesh_index, K, only)
        out = []
        if not d:
            return out
        for p in np.unique(d["p"]):
            s = d["p"] == p
            out.append((int(p), d["m"][s], d["k"][s], None, d["gap_t"][s], d["roll1"][s], d["edge"][s],
                        float(d["gap_t"][s].min())))
        return out

    # ----------------------------------------------------------- compliance
    def _hs_table(self, K: int) -> np.ndarray:
        if self._table_K != K:
            dk = np.arange(-2 * K, 2 * K + 1)[:, None] * self.d_mu
            dm = np.arange(-(self.n_slices - 1), self.n_slices)[None, :] * self.d_lam
            self._table = self._hs_kappa * rect_surface(dk, dm, 0.5 * self.d_mu, 0.5 * self.d_lam)
            self._table_K = K
        return self._table

    def line_compliance(self, d: dict) -> np.ndarray:
        """FE normal compliance [m/N] between the contact lines (slice, pair) of the candidates ``d`` of
        :meth:`_fine` (symmetric: rows response, columns load); every candidate of a line shares it."""
        lp = d["line_p"]
        Cl = np.zeros((lp.size, lp.size))
        for g, (c, s) in enumerate(zip(self.c, (d["line_s1"], d["line_s2"]))):
            W = c.weights(s, self.z[d["line_m"]])
            off = (lp[:, None] - lp[None, :]) if g == 0 else (lp[None, :] - lp[:, None])  # [load i, response j]
            for o in np.unique(off):
                if o not in c.offsets:
                    continue
                Y = W @ c.block(int(o)) @ W.T  # [i load, j response]
                Cl += np.where((off == o).T, Y.T, 0.0)
        return 0.5 * (Cl + Cl.T)  # the FE part is symmetric up to discretisation (~2 %); the table is symmetric

    def compliance_matrix(self, d: dict, K: int) -> np.ndarray:
        """Normal compliance [m/N] between all candidates of :meth:`_fine` (rows response, columns load): the
        FE part of their lines (:meth:`line_compliance`) and the half-space near field within a line's pair."""
        li = d["li"]
        C = self.line_compliance(d)[np.ix_(li, li)]
        tab = self._hs_table(K)
        p = d["p"]
        cuts = np.flatnonzero(np.diff(p)) + 1
        for a, b in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [p.size]])):
            k, m = d["k"][a:b], d["m"][a:b]
            C[a:b, a:b] += tab[k[:, None] - k[None, :] + 2 * K, m[:, None] - m[None, :] + self.n_slices - 1]
        return C

    # --------------------------------------------------------------- solve
    def solve(self, theta: float, torque: float, mesh_index: int = 0, only=None) -> HelicalPositionResult:
        """Contact solution at input angle ``theta`` [rad] and output torque ``torque`` [N m]."""
        return self.solve_many(theta, [torque], mesh_index, only)[0]

    def solve_many(self, theta: float, torques, mesh_index: int = 0, only=None) -> list[HelicalPositionResult]:
        """Solutions at one position for several output torques [N m] (one compliance matrix)."""
        with single_thread_blas():
            return self._solve_many(theta, torques, mesh_index, only)

    def _solve_many(self, theta: float, torques, mesh_index: int, only) -> list[HelicalPositionResult]:
        """Each torque on its own candidate window: it starts at :attr:`K` patches each side of the contact
        lines and doubles while the solution loads the window's edge or could touch outside it
        (:meth:`_touches_outside`), so that a torque's result does not depend on the others of the call."""
        where = f" at theta = {math.degrees(theta):.4f} deg (mesh {mesh_index})"
        windows: dict[int, tuple] = {}

        def window(K: int):
            if K not in windows:
                d = self._fine(theta, mesh_index, K, only)
                if not d:
                    raise SolverError(f"contact not found{where}: no flank points of both gears lie near the "
                                      "contact lines")
                windows[K] = (d, self.compliance_matrix(d, K), self._outside(theta, mesh_index, K, only, d))
            return windows[K]

        results = []
        for tq in torques:
            K = self.K
            for _ in range(4):
                d, C, outside = window(K)
                Ft = tq / self.pair.rb[1]
                sol = self._contact(C, d["gap_t"] * self.cosb, Ft / self.cosb, tq, where)
                if not (np.any(sol.f[d["edge"]] > 1e-9 * Ft) or self._touches_outside(outside, d, sol)):
                    break
                K *= 2
            else:
                raise SolverError(f"contact zone reaches the candidate window{where} even at "
                                  f"{K // 2 * self.d_mu * 1e3:.2f} mm")
            if sol.gap.min() < -self.tol:
                raise SolverError(f"penetration {-sol.gap.min() * 1e6:.3g} um{where} exceeds {self.tol * 1e6:.3g} um")
            ft = sol.f * self.cosb  # share of the transverse line-of-action force
            pf = np.array([ft[d["p"] == p].sum() for p in self.pair_range])
            results.append(HelicalPositionResult(
                theta=theta, torque=tq, ste=sol.delta / self.cosb, ste_kinematic=float(d["gap_t"].min()), force=Ft,
                pair=d["p"], roll1=d["roll1"], force_c=sol.f, pressure=sol.f / (self.d_mu * self.d_lam),
                pairs=self.pair_range.copy(), pair_force=pf, z=d["z"]))
            self.last_state = (theta, mesh_index, K, d)  # candidates of the last solve (exports, checks)
        return results

    def _outside(self, theta: float, mesh_index: int, K: int, only, d: dict):
        """The flank points up to ``2 K`` patches from their contact lines, outside the window of ``K`` whose
        candidates are ``d``: their normal gaps [m] and the FE compliance [m/N] of their contact lines to the
        lines of ``d`` (:meth:`line_compliance`, the same for every point of a line); None when there are none.
        It does not depend on the torque, so one window's screen serves every torque solved on it."""
        wide = self._fine(theta, mesh_index, 2 * K, only)
        out = np.abs(wide["k"]) > K
        if not out.any():
            return None
        lines = {(int(m), int(p)): n for n, (m, p) in enumerate(zip(wide["line_m"], wide["line_p"]))}
        loaded = np.array([lines[(int(m), int(p))] for m, p in zip(d["line_m"], d["line_p"])])
        return wide["gap_t"][out] * self.cosb, self.line_compliance(wide)[np.ix_(wide["li"][out], loaded)]

    def _touches_outside(self, outside, d: dict, sol) -> bool:
        """Whether a point of :meth:`_outside` could penetrate under the solution ``sol``: its gap after the
        approach ``sol.delta`` and the FE (bending, body) displacement of its contact line is below ``-tol``.
        The half-space near field, which only opens the gap, is left out, so the screen is conservative; a
        non-convex gap (modified or deviating flanks) that rises past the window's edge and falls again is what
        it catches."""
        if outside is None:
            return False
        gap, C_out = outside
        f_line = np.bincount(d["li"], weights=sol.f, minlength=d["line_m"].size)
        return bool((gap - sol.delta + C_out @ f_line).min() < -self.tol)

    def _contact(self, C: np.ndarray, h: np.ndarray, force: float, torque: float, where: str):
        """Active-set contact solve (:func:`gearrom.fe.contact.solve_contact`), warm-started with the
        active gap range of the previous solve at this torque (consecutive positions); the cold
        solver is the fallback."""
        n_prev = self._warm.get(round(float(torque), 9)) or max(1, h.size // 3)
        active = np.zeros(h.size, bool)
        active[np.argsort(h)[:min(n_prev, h.size)]] = True
        sol = _solve_from(C, h, force, active, self.tol)
        if sol is None:
            sol = solve_contact(C, h, force, tol=self.tol, where=where)
        self._warm[round(float(torque), 9)] = int(np.count_nonzero(sol.f > 0))
        return sol

    def with_pair(self, pair) -> "Helical3DLTCA":
        """Same compliances and settings, new micro-geometry / errors (no FE solve)."""
        return Helical3DLTCA(pair, self.c, self.n_slices, self.d_mu, self.window, self.tol)


def contact_pattern(result: HelicalPositionResult, pair, n_z: int = 24, n_roll: int = 40):
    """Contact pressure binned over face width x input roll length.

    Returns (z edges [m], roll edges [m], max pressure per bin [Pa], shape (n_z, n_roll)).
    """
    b = pair.face_width
    ze = np.linspace(-0.5 * b, 0.5 * b, n_z + 1)
    re = np.linspace(pair.roll_start_active[0], pair.roll_tip[0], n_roll + 1)
    out = np.zeros((n_z, n_roll))
    iz = np.clip(np.searchsorted(ze, result.z) - 1, 0, n_z - 1)
    ir = np.clip(np.searchsorted(re, result.roll1) - 1, 0, n_roll - 1)
    np.maximum.at(out, (iz, ir), result.pressure)
    return ze, re, out


def build_helical3d(pair, settings=None, cache_dir=None, n_slices: int = 24, **kw) -> Helical3DLTCA:
    """3D compliances of both gears (:func:`gearrom.fe.compliance3d.cached_compliance3d`, cached on
    disk when ``cache_dir`` is given) and the :class:`Helical3DLTCA` (``kw``: its options)."""
    from gearrom.fe.compliance3d import cached_compliance3d

    comps = tuple(cached_compliance3d(pair, i, settings, cache_dir=cache_dir) for i in range(2))
    return Helical3DLTCA(pair, comps, n_slices=n_slices, **kw)
