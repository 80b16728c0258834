"""Sliced-face-width (thin-slice) mesh law with per-tooth deviations, compiled with numba.

The common face width b is cut into ``n_slices`` slices of width ``dy``. Slice m (centre ``y_m``,
``-b/2 < y_m < b/2``) is a spur pair whose teeth are staggered by the base helix:
tooth pair j (tooth ``j mod z1`` of gear 1 with tooth ``j mod z2`` of gear 2) touches at the
distance ``u = rb1 phi1 + (y_m - b/2) tan(beta_b) - j pbt`` from A along the transverse line of action,
and only for ``0 <= u <= g_alpha``. At ``phi1 = 0`` tooth pair 0 enters contact: its leading face end
(``y = b/2``) is at A (gearrom's "pair 0 enters contact at theta = 0").
A slice's contact spans ``u -+ w`` in roll, ``w = max(dy tan(beta_b)/2, 0.05 mm)``; its stiffness is
weighted by the share of that span inside the path, so slices enter and leave contact over a short
ramp (no slice staircase for the helical pair; for the spur pair a 0.1 mm roll ramp, like a small
edge rounding at the tips, instead of a jump that a fixed-step integrator resolves only to O(h)).

Each contact is a linear spring (compression only) on the gap ``delta - dev``:
stiffness ``c' dy shape(u)``, ``shape(u) = 1 - (1 - s_end) (2 u / g_alpha - 1)^2`` (parabolic, lowest
at tip and root, ``s_end`` = 0.65: mean 0.883, ISO 6336-1's ``c_gamma/(c' eps_alpha) = 0.75 + 0.25/eps_alpha``
is 0.885 at eps_alpha = 1.85). ``delta = rb1 phi1 - rb2 phi2`` (gear body angles, positive = output
lags = compression), ``dev`` the minus-material deviation of that contact [m].
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .effects import Case, DamagedTooth, Eccentricity, HelixSlope, LeadCrowning, PitchError, TipRelief
from .geometry import PairGeometry, iso_single_stiffness

UM = 1e-6
S_END = 0.65
#: contacts per slice that the buffers hold (eps_alpha + 2 is enough)
MAX_PER_SLICE = 6
#: smallest half length of the contact ramp at the path ends [m] (edge rounding at the tips; also keeps
#: the stiffness continuous in time for the fixed-step integrator)
EDGE_RAMP = 0.05e-3


@dataclass(frozen=True)
class MeshModel:
    """Packed arrays of the mesh law (all SI), passed to the compiled kernels.

    Attributes
    ----------
    gp : ndarray, shape (18,)
        rb1, pbt, g_alpha, tan(beta_b), c' dy, s_end, tip relief gear 1 (amount, start u, exponent),
        tip relief gear 2 (amount, start u, exponent), eccentricity gear 1 (e, phase), gear 2 (e, phase),
        edge ramp half length, half face width.
    ys, slice_dev : ndarray, shape (n_slices,)
        Slice centres [m] and the lead deviation (crowning + slope) of each slice [m].
    pitch1, pitch2 : ndarray, shape (z1,), (z2,)
        Pitch deviation of each tooth [m].
    dmg : ndarray, shape (n, 7)
        Pits: gear (1/2), tooth, depth [m], centre u [m], half width [m], y_from, y_to [m].
    c_prime : float
        Single stiffness used [N/m per m of face width].
    """

    gp: np.ndarray
    ys: np.ndarray
    slice_dev: np.ndarray
    pitch1: np.ndarray
    pitch2: np.ndarray
    dmg: np.ndarray
    c_prime: float

    def args(self) -> tuple:
        return self.gp, self.ys, self.slice_dev, self.pitch1, self.pitch2, self.dmg


def build_mesh(g: PairGeometry, case: Case | None = None, n_slices: int = 40, c_prime: float | None = None,
               stiffness_scale: float = 1.0, edge_ramp: float = EDGE_RAMP) -> MeshModel:
    """Mesh arrays of pair ``g`` with the flank effects of ``case``.

    Parameters
    ----------
    g : PairGeometry
    case : Case, optional
        Its eccentricity, pitch_error, tip_relief, lead_crowning, helix_slope, damaged_tooth are used.
    n_slices : int
        Slices over the face width.
    c_prime : float, optional
        Single stiffness [N/m/m]; default ISO 6336-1 method B.
    stiffness_scale : float
        Factor on the stiffness (``mesh_stiffness`` of a torsional_mode case).
    edge_ramp : float
        Smallest half roll length [m] over which a slice's contact enters and leaves (see module doc).
    """
    case = case or Case()
    cp = (c_prime if c_prime is not None else iso_single_stiffness(g)) * stiffness_scale
    dy = g.b / n_slices
    ys = (np.arange(n_slices) + 0.5) * dy - g.b / 2
    slice_dev = np.zeros(n_slices)
    for e in case.of(LeadCrowning):
        slice_dev += e.amount_um * UM * (2 * ys / g.b) ** 2
    for e in case.of(HelixSlope):
        slice_dev += e.amount_um * UM * ys / g.b
    pitch = {"input_gear": np.zeros(g.z1), "output_gear": np.zeros(g.z2)}
    for e in case.of(PitchError):
        p = pitch[e.target]
        p[e.tooth_index % p.size] += e.deviation_um * UM
    relief = {"input_gear": [0.0, g.g_alpha, 1.0], "output_gear": [0.0, 0.0, 1.0]}
    for e in case.of(TipRelief):
        rs = e.start_diameter_mm * 1e-3 / 2
        if e.target == "input_gear":  # gear 1's tip is at E: relieved for u > u_start
            u_s = math.sqrt(max(rs ** 2 - g.rb1 ** 2, 0.0)) - g.rho_a
        else:  # gear 2's tip is at A: relieved for u < u_start
            u_s = g.t1t2 - math.sqrt(max(rs ** 2 - g.rb2 ** 2, 0.0)) - g.rho_a
        relief[e.target] = [e.amount_um * UM, min(max(u_s, 0.0), g.g_alpha), 1.0 if e.shape == "linear" else 2.0]
    ecc = {"input_gear": (0.0, 0.0), "output_gear": (0.0, 0.0)}
    for e in case.of(Eccentricity):
        ecc[e.target] = (e.amplitude_um * UM, math.radians(e.phase_deg))
    dmg = [[1.0 if e.target == "input_gear" else 2.0, float(e.tooth_index), e.depth_um * UM,
            e.center * g.g_alpha, e.width * g.g_alpha / 2, (e.face_from - 0.5) * g.b, (e.face_to - 0.5) * g.b]
           for e in case.of(DamagedTooth)]
    gp = np.array([g.rb1, g.pbt, g.g_alpha, math.tan(g.beta_b), cp * dy, S_END,
                   *relief["input_gear"], *relief["output_gear"], *ecc["input_gear"], *ecc["output_gear"],
                   edge_ramp, g.b / 2])
    return MeshModel(gp, ys, slice_dev, pitch["input_gear"], pitch["output_gear"],
                     np.array(dmg, float).reshape(-1, 7), cp)


@njit(cache=True)
def contacts(phi1, phi2, gp, ys, slice_dev, pitch1, pitch2, dmg, dev_out, k_out):
    """Fill ``dev_out``/``k_out`` with the deviation [m] and stiffness [N/m] of every contact.

    The eccentricities are included in ``dev``. Returns the number of contacts.
    """
    rb1, pbt, ga, tanbb, kdy, s_end = gp[0], gp[1], gp[2], gp[3], gp[4], gp[5]
    ca1, us1, pw1, ca2, us2, pw2 = gp[6], gp[7], gp[8], gp[9], gp[10], gp[11]
    ecc = gp[12] * math.cos(phi1 + gp[13]) + gp[14] * math.cos(phi2 + gp[15])
    z1, z2 = pitch1.size, pitch2.size
    s = rb1 * phi1
    hw = gp[16] if ys.size < 2 else max(gp[16], 0.5 * (ys[1] - ys[0]) * abs(tanbb))
    n = 0
    for m in range(ys.size):
        sm = s + (ys[m] - gp[17]) * tanbb
        jlo = int(math.ceil((sm - ga - hw) / pbt))
        jhi = int(math.floor((sm + hw) / pbt))
        for j in range(jlo, jhi + 1):
            uc = sm - j * pbt
            # share of the slice's contact line (roll extent uc -+ hw) inside the path [0, ga]
            frac = (min(uc + hw, ga) - max(uc - hw, 0.0)) / (2.0 * hw)
            if frac <= 0.0:
                continue
            u = min(max(uc, 0.0), ga)
            t1 = j % z1
            t2 = j % z2
            dev = ecc + slice_dev[m] + pitch1[t1] + pitch2[t2]
            if ca1 > 0.0 and u > us1:
                dev += ca1 * ((u - us1) / (ga - us1)) ** pw1
            if ca2 > 0.0 and u < us2:
                dev += ca2 * ((us2 - u) / us2) ** pw2
            for i in range(dmg.shape[0]):
                tooth = t1 if dmg[i, 0] == 1.0 else t2
                if tooth == int(dmg[i, 1]) and dmg[i, 5] <= ys[m] <= dmg[i, 6]:
                    x = (u - dmg[i, 3]) / dmg[i, 4]
                    if -1.0 < x < 1.0:
                        dev += dmg[i, 2] * math.cos(0.5 * math.pi * x) ** 2
            x = 2.0 * u / ga - 1.0
            dev_out[n] = dev
            k_out[n] = frac * kdy * (1.0 - (1.0 - s_end) * x * x)
            n += 1
    return n


@njit(cache=True)
def force(delta, n, dev, k):
    """Elastic force [N] and active stiffness [N/m] of the first ``n`` contacts at deflection ``delta``."""
    f = 0.0
    kk = 0.0
    for i in range(n):
        gap = delta - dev[i]
        if gap > 0.0:
            f += k[i] * gap
            kk += k[i]
    return f, kk


@njit(cache=True)
def solve_delta(f_target, n, dev, k):
    """Deflection ``delta`` [m] at which the piecewise-linear force of the contacts equals ``f_target``."""
    order = np.argsort(dev[:n])
    ksum = 0.0
    kdev = 0.0
    for ii in range(n):
        i = order[ii]
        ksum += k[i]
        kdev += k[i] * dev[i]
        d = (f_target + kdev) / ksum
        if ii == n - 1 or d <= dev[order[ii + 1]]:
            return d
    return np.nan


def buffers(m: MeshModel) -> tuple[np.ndarray, np.ndarray]:
    """Work arrays large enough for all contacts."""
    size = m.ys.size * MAX_PER_SLICE
    return np.empty(size), np.empty(size)


def static_te(g: PairGeometry, m: MeshModel, phi1: np.ndarray, force_n: float) -> tuple[np.ndarray, np.ndarray]:
    """Quasi-static TE and secant mesh stiffness at gear-1 angles ``phi1`` under mesh force ``force_n``.

    Parameters
    ----------
    g : PairGeometry
    m : MeshModel
    phi1 : ndarray
        Gear-1 body angles [rad]; gear 2 is placed kinematically (``phi2 = phi1 rb1/rb2``).
    force_n : float
        Mesh force on the transverse line of action [N] (output torque / rb2).

    Returns
    -------
    te : ndarray
        ``delta`` [m] (positive = output lags).
    k_tan : ndarray
        Tangent mesh stiffness at ``delta`` (sum of the contacts in compression) [N/m].
    """
    dev, k = buffers(m)
    te = np.empty(len(phi1))
    kt = np.empty(len(phi1))
    for i, p in enumerate(np.asarray(phi1, float)):
        n = contacts(p, p * g.rb1 / g.rb2, *m.args(), dev, k)
        te[i] = solve_delta(force_n, n, dev, k)
        kt[i] = force(te[i], n, dev, k)[1]
    return te, kt


def mean_stiffness(g: PairGeometry, m: MeshModel, force_n: float, n_pos: int = 256) -> float:
    """Mean tangent mesh stiffness [N/m] over one mesh period at mesh force ``force_n``."""
    phi = np.arange(n_pos) * 2 * math.pi / g.z1 / n_pos
    return float(np.mean(static_te(g, m, phi, force_n)[1]))
