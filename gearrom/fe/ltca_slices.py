"""Helical pairs by thin transverse slices (an approximation; the 3D model is :mod:`gearrom.fe.ltca_helical`).

The face width is cut into ``n_slices`` slices. Each slice is the transverse section at its axial
position ``z`` and meshes like a spur pair at the shifted position ``theta + contact_shift(z)``
(:func:`gearrom.geometry.profile.contact_shift`: ``-h z tan(beta_b) / r_b1`` for an input gear of
hand ``h`` = +1 right, -1 left; the contact line runs across the face at the base helix angle and the
face end :func:`~gearrom.geometry.profile.entry_face_end` enters contact first), as in the 3D model.
Its compliance is the plane-strain compliance of the transverse section (:mod:`gearrom.fe.compliance`)
scaled to the slice thickness; the slices are *uncoupled* (no load spreading along the face width),
which over-estimates end effects and the sensitivity to lead modifications. The rigid approach along
the transverse line of action is common to all slices; the transverse force torque / r_b2 is shared
among them.

Gaps: every quantity of the contact problem is taken along the transverse line of action (the
convention of :class:`~gearrom.fe.ltca.SpurLTCA`, whose candidates each slice uses): the
separation of the two transverse involutes, the profile modifications, pitch deviations and runout
of the slice's section (:meth:`SpurLTCA.candidates`), plus the lead modifications of
:func:`gearrom.fe.flankgaps.lead_removal` at the slice's ``z``: lead crowning C_b (parabolic, C_b
at both ends of the face width) and helix slope f_Hbeta (linear, +f_Hbeta/2 removed at
z = +b/2). All micro-geometry values are transverse, as ISO 1328-1 measures profile and helix
deviations (along the transverse base tangent), the convention of
:class:`~gearrom.fe.ltca_helical.Helical3DLTCA`.

Forces and pressure: the contact problem of the slices is solved for the transverse line-of-action
force ``F_t = torque / r_b2`` (per candidate its line-of-action share ``f_t``, as in
:class:`SpurLTCA`). The results report what :class:`~gearrom.fe.ltca.PositionResult` defines, as the
3D model does: the normal contact force ``f_n = f_t / (lambda cos(beta_b))`` (``lambda`` = 1 on the
involutes, the lever factor of a tip-edge candidate, see :meth:`SpurLTCA.candidates`), whose
transverse component is ``f_t / lambda`` (the rest is axial), and the pressure on the candidate's
patch in the flank: ``spacing`` wide along the transverse profile, which crosses the contact line at
right angles in the flank's tangent plane, and ``dz / cos(beta_b)`` long along the contact line, so
``p = f_n cos(beta_b) / (spacing dz) = f_t / (lambda spacing dz)``. ``pair_force`` stays the share of
``F_t`` (sums to ``force``).
"""
from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np

from gearrom.errors import SolverError
from gearrom.fe.contact import solve_contact_blocks
from gearrom.fe.flankgaps import lead_removal
from gearrom.fe.ltca import PositionResult, SpurLTCA
from gearrom.geometry.profile import contact_shift


class HelicalSliceLTCA(SpurLTCA):
    """Slice LTCA of a helical pair (see module doc). Same interface as :class:`SpurLTCA`.

    Parameters
    ----------
    pair, compliances, window, tol
        As for :class:`SpurLTCA` (compliances of the transverse sections, thickness = each face width).
    n_slices : int
        Slices across the common face width.
    """

    def __init__(self, pair, compliances, window: float = 0.4e-3, tol: float = 1e-11, n_slices: int = 24) -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # lead modifications are handled here
            super().__init__(pair, compliances, window, tol)
        if n_slices < 2:
            raise SolverError(f"n_slices must be >= 2, got {n_slices}")
        b = pair.face_width
        self.n_slices = n_slices
        self.dz = b / n_slices
        self.z = (np.arange(n_slices) + 0.5) * self.dz - 0.5 * b
        self.shift = np.asarray(contact_shift(pair, self.z), float)  # input angle shift per slice [rad]
        self.cosb = math.cos(pair.beta_b)
        # compliance of a slice of thickness dz: the plane model's (thickness b_i) times b_i / dz;
        # ``self.c`` keeps the plane compliances (reusable for a new micro-geometry)
        self._slice_c = tuple(dataclasses.replace(c, G=c.G * (c.face_width / self.dz)) for c in self.c)
        npairs = int(math.ceil(pair.eps_alpha + pair.eps_beta)) + 2
        self.pair_range = np.arange(-npairs, npairs + 1)

    def compliance_matrix(self, cands) -> np.ndarray:
        """Compliance [m/N] between the candidates of one slice."""
        plane, self.c = self.c, self._slice_c
        try:
            return super().compliance_matrix(cands)
        finally:
            self.c = plane

    def _lead_removal(self, z: float) -> float:
        """Material removed by the lead modifications of both gears at axial position ``z`` [m], along the
        transverse line of action [m]."""
        return float(lead_removal(self.pair, 0, z) + lead_removal(self.pair, 1, z))

    def solve_many(self, theta: float, torques, mesh_index: int = 0, only=None) -> list[PositionResult]:
        """Contact solutions at one input angle for several output torques [N m]."""
        blocks, gaps, pids, rolls, lams, zs = [], [], [], [], [], []
        kin = np.inf
        for k, z in enumerate(self.z):
            th = theta + self.shift[k]
            m_idx = mesh_index + int(math.floor(th / self.period))
            th -= math.floor(th / self.period) * self.period
            cands = self.candidates(th, m_idx, self.window, only)
            if not cands:
                continue
            # pair index relative to theta's mesh cycle
            off = m_idx - mesh_index
            C = self.cached_compliance(th, m_idx, self.window, only, cands)  # slice compliances (scaled in __init__)
            lead = self._lead_removal(z)
            h = np.concatenate([c[4] for c in cands]) + lead  # transverse gaps of the section plus the lead removal
            kin = min(kin, min(c[7] for c in cands) + lead)
            blocks.append(C)
            gaps.append(h)
            pids.append(np.concatenate([np.full(c[1].size, c[0] - off) for c in cands]))
            rolls.append(np.concatenate([c[5] for c in cands]))
            lams.append(np.concatenate([c[9] for c in cands]))
            zs.append(np.full(h.size, z))
        if not blocks:
            raise SolverError(f"contact not found at theta = {math.degrees(theta):.4f} deg in any slice")
        h, pid, roll, lam, zc = (np.concatenate(x) for x in (gaps, pids, rolls, lams, zs))
        area_t = self.c[0].spacing * self.dz  # patch area in the flank times cos(beta_b) (module doc)
        out = []
        for tq in torques:
            F = tq / self.pair.rb[1]
            sol = solve_contact_blocks(blocks, gaps, F, tol=self.tol, where=f" at theta = {math.degrees(theta):.4f} deg")
            f_t = sol.f / lam  # transverse component of each candidate's contact force
            pf = np.array([sol.f[pid == p].sum() for p in self.pair_range])
            res = PositionResult(theta=theta, torque=tq, ste=sol.delta, ste_kinematic=float(kin), force=F, pair=pid,
                                 roll1=roll, force_c=f_t / self.cosb, pressure=f_t / area_t,
                                 pairs=self.pair_range.copy(), pair_force=pf)
            object.__setattr__(res, "z", zc)  # axial position of each candidate (contact pattern)
            out.append(res)
        return out


def plot_contact_pattern(result: PositionResult, pair):
    """Contact pattern of one helical position: pressure over face width x roll length (scatter)."""
    from gearrom.plotting import subplots

    z = getattr(result, "z", np.zeros_like(result.roll1))
    on = result.force_c > 0
    fig, ax = subplots(figsize=(7, 4))
    ax.scatter(z[~on] * 1e3, result.roll1[~on] * 1e3, s=2, c="0.85")
    sc = ax.scatter(z[on] * 1e3, result.roll1[on] * 1e3, s=8, c=result.pressure[on] * 1e-6, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="pressure [MPa]")
    ax.set_xlabel("axial position z [mm]")
    ax.set_ylabel("input roll length [mm]")
    ax.set_title(f"contact pattern at {result.torque:.4g} N m, theta = {math.degrees(result.theta):.3f} deg", fontsize=9)
    fig.tight_layout()
    return fig
