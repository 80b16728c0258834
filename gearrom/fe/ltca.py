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
:mod:`gearrom.fe.microgeo`. The approach ``delta`` is the loaded static TE along the transverse
line of action (positive when the output lags); the unloaded kinematic TE is the smallest gap.
"""
from __future__ import annotations

import logging
import math
import warnings
from dataclasses import dataclass

import numpy as np

from gearrom.errors import SolverError
from gearrom.fe.compliance import FlankCompliance
from gearrom.fe.contact import solve_contact
from gearrom.fe.microgeo import needs_3d, pitch_removal, profile_removal, runout_removal, tip_limit

log = logging.getLogger(__name__)

_GX, _GW = np.polynomial.legendre.leggauss(8)
_GX, _GW = 0.5 * (_GX + 1), 0.5 * _GW


def _drop(t: np.ndarray, L_p: float, rb: float, sign: float) -> np.ndarray:
    """Distance of an involute point at arc offset ``t`` from the tangent at the contact point [m]."""
    s = np.multiply.outer(t, _GX)
    kappa = 1.0 / np.sqrt(np.maximum(L_p**2 + 2 * rb * sign * s, 1e-30))
    return t**2 * (((1 - _GX) * kappa) @ _GW)


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
        Per contact candidate: pair index, input-gear roll length [m], force [N], pressure [Pa].
    pairs : ndarray of int; pair_force : ndarray
        Pair indices and the force each carries [N].
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
        # contact ends at the effective tip or where the involute ends (a tip edge rounding starts);
        # contact on the rounding itself is not modelled
        self.L_tip = tuple(min(tip_limit(pair, i), math.sqrt(2 * c.rb * (c.sigma[-1] + 0.5 * c.spacing)))
                           for i, c in enumerate((c1, c2)))
        n_pairs = int(math.ceil(pair.eps_alpha)) + 1
        self.pair_range = np.arange(-1, n_pairs)

    @property
    def period(self) -> float:
        return 2 * math.pi / self.pair.z[0]

    # ---------------------------------------------------------------- gaps
    def candidates(self, theta: float, mesh_index: int = 0, window: float | None = None, only=None):
        """Contact candidates per pair at ``theta``.

        Each entry: (pair, gear-1 grid indices, gear-2 floor grid indices, gear-2 interpolation weight,
        gaps [m], input roll lengths [m], window-edge flags, smallest gap incl. the ideal point [m]).
        """
        pr, (c1, c2) = self.pair, self.c
        W = window or self.window
        rb1, rb2 = c1.rb, c2.rb
        d = c1.spacing
        L1_0 = self.L1_start + rb1 * theta
        rot1 = mesh_index * self.period + (L1_0 - 0.5 * pr.dw[0] * math.sin(pr.alpha_wt)) / rb1
        out = []
        for p in self.pair_range if only is None else only:
            L1P = L1_0 + p * self.pb
            L2P = self.T - L1P
            if L1P <= 0 or L2P <= 0:
                continue
            s1P, s2P = L1P**2 / (2 * rb1), L2P**2 / (2 * rb2)
            a = np.flatnonzero(np.abs(c1.sigma - s1P) <= W)
            a = a[np.sqrt(2 * rb1 * c1.sigma[a]) <= self.L_tip[0] + 1e-12]
            if a.size == 0:
                continue
            U0 = (s2P + s1P - c2.sigma[0] - c1.sigma[0]) / d
            fa0 = math.floor(U0)
            w = U0 - fa0
            fa = fa0 - a
            keep = (fa >= 0) & (fa + 1 <= c2.sigma.size - 1)
            a, fa = a[keep], fa[keep]
            s2 = c2.sigma[0] + (fa + w) * d
            keep = np.sqrt(2 * rb2 * s2) <= self.L_tip[1] + 1e-12
            a, fa, s2 = a[keep], fa[keep], s2[keep]
            if a.size == 0:
                continue
            t = c1.sigma[a] - s1P
            L1 = np.sqrt(2 * rb1 * c1.sigma[a])
            L2 = np.sqrt(2 * rb2 * s2)
            tooth = mesh_index - p
            r1 = rot1 + p * self.period
            extra = (pitch_removal(pr, 0, tooth) + pitch_removal(pr, 1, tooth)
                     + runout_removal(pr, 0, r1) + runout_removal(pr, 1, r1 * pr.z[0] / pr.z[1]))
            gap = (_drop(t, L1P, rb1, 1.0) + _drop(t, L2P, rb2, -1.0) + profile_removal(pr, 0, L1)
                   + profile_removal(pr, 1, L2) + extra)
            # the gap at the ideal contact point itself (t = 0) when it lies on both flanks
            on = (c1.sigma[0] <= s1P <= c1.sigma[-1] and L1P <= self.L_tip[0] and c2.sigma[0] <= s2P <= c2.sigma[-1]
                  and L2P <= self.L_tip[1])
            g0 = float(profile_removal(pr, 0, np.array([L1P]))[0] + profile_removal(pr, 1, np.array([L2P]))[0]
                       + extra) if on else np.inf
            out.append((int(p), a, fa, w, gap, L1, np.abs(t) >= W - 1.01 * d, min(g0, float(gap.min()))))
        return out

    def compliance_matrix(self, cands) -> np.ndarray:
        """Compliance [m/N] between all candidates (both gears, cyclic symmetry)."""
        c1, c2 = self.c
        n = sum(c[1].size for c in cands)
        C = np.zeros((n, n))
        starts = np.cumsum([0] + [c[1].size for c in cands])
        for i, (p, a, fa, w, *_) in enumerate(cands):
            for j, (q, b, fb, v, *_) in enumerate(cands):
                G1, G2 = c1.block(p - q), c2.block(q - p)
                blk = G1[np.ix_(a, b)]
                if p == q:
                    blk = blk + (1 - w) * G2[np.ix_(fa, fb)] + w * G2[np.ix_(fa + 1, fb + 1)]
                else:
                    blk = blk + ((1 - w) * (1 - v) * G2[np.ix_(fa, fb)] + (1 - w) * v * G2[np.ix_(fa, fb + 1)]
                                 + w * (1 - v) * G2[np.ix_(fa + 1, fb)] + w * v * G2[np.ix_(fa + 1, fb + 1)])
                C[starts[j]:starts[j + 1], starts[i]:starts[i + 1]] = blk.T  # rows: response, cols: load
        return 0.5 * (C + C.T)

    # --------------------------------------------------------------- solve
    def solve(self, theta: float, torque: float, mesh_index: int = 0, only=None) -> PositionResult:
        """Contact solution at input angle ``theta`` [rad] and output torque ``torque`` [N m]."""
        return self.solve_many(theta, [torque], mesh_index, only)[0]

    def solve_many(self, theta: float, torques, mesh_index: int = 0, only=None) -> list[PositionResult]:
        """Solutions at one position for several output torques [N m] (one compliance matrix).

        ``only``: restrict the contact to these pair indices (e.g. ``[0]`` for a single pair's stiffness).
        """
        W = self.window
        for _ in range(4):
            cands = self.candidates(theta, mesh_index, W, only)
            where = f" at theta = {math.degrees(theta):.4f} deg (mesh {mesh_index})"
            if not cands:
                raise SolverError(f"contact not found{where}: no flank points of both gears lie near the line of action")
            C = self.compliance_matrix(cands)
            h = np.concatenate([c[4] for c in cands])
            pid = np.concatenate([np.full(c[1].size, c[0]) for c in cands])
            roll = np.concatenate([c[5] for c in cands])
            edge = np.concatenate([c[6] for c in cands])
            kin = min(c[7] for c in cands)
            results, grow = [], False
            for tq in torques:
                F = tq / self.pair.rb[1]
                sol = solve_contact(C, h, F, tol=self.tol, where=where)
                if np.any(sol.f[edge] > 1e-9 * F):
                    grow = True
                    break
                if sol.gap.min() < -self.tol:
                    raise SolverError(f"penetration {-sol.gap.min() * 1e6:.3g} um{where} exceeds {self.tol * 1e6:.3g} um")
                width = self.c[0].spacing * self.c[0].face_width
                pf = np.array([sol.f[pid == p].sum() for p in self.pair_range])
                results.append(PositionResult(theta=theta, torque=tq, ste=sol.delta, ste_kinematic=kin, force=F,
                                              pair=pid, roll1=roll, force_c=sol.f, pressure=sol.f / width,
                                              pairs=self.pair_range.copy(), pair_force=pf))
            if not grow:
                return results
            W *= 2
        raise SolverError(f"contact zone reaches the candidate window{where} even at {W * 1e3:.2f} mm")
