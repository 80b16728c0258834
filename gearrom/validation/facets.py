"""Rigid-geometry TE of the explicit FE's faceted gear outlines (the kinematic error of its mesh).

The explicit FE resamples each gear outline uniformly along its whole length, so the flanks are
chords of the involute whose positions differ from tooth to tooth. Rigid, such a pair has a
non-zero TE that the quasi-static LTCA table (resolved 25 um flanks) does not contain. To let the
ROM describe the same discretised gears, this module computes it: at each input angle the output
gear (rigid, about its centre) is turned until its outline first touches the input's, by
bisection on the overlap of the two outline polygons (vertex-in-polygon both ways, as the FE's
node-to-segment contact), with the FE's start position and TE convention (TE = 0 at t = 0).
"""
from __future__ import annotations

import logging
import math

import numpy as np

from gearrom.errors import MeshError
from gearrom.fe.explicit.gearpair import first_touch, outline_order

log = logging.getLogger(__name__)

__all__ = ["faceted_rigid_te", "faceted_pair_gaps", "loaded_kinematic_te", "elastic_deflection", "share_rows"]


def _rot(p: np.ndarray, c: np.ndarray, a: float) -> np.ndarray:
    cs, sn = math.cos(a), math.sin(a)
    q = p - c
    return c + np.column_stack([cs * q[:, 0] - sn * q[:, 1], sn * q[:, 0] + cs * q[:, 1]])


def share_rows(share_tab: np.ndarray, phi: np.ndarray, period: float) -> np.ndarray:
    """Load-share rows of a mesh table (``share_tab``: (n_theta, n_pairs)) at the mesh phases ``phi`` [rad].

    Nearest table row, except that a phase within half a step of the period end takes the *last* row
    instead of wrapping to row 0: the pair columns of row 0 belong to the next mesh period (pair 0 there
    is pair -1 here), while the contact points are placed at ``phi`` itself.
    """
    n = share_tab.shape[0]
    idx = np.minimum(np.round(np.mod(np.asarray(phi, float), period) / period * n).astype(int), n - 1)
    return share_tab[idx]


def faceted_rigid_te(pair, meshes, theta_in: np.ndarray, share: np.ndarray, phase0: float, clearance: float = 1e-6,
                     radius: float = 1.2e-3, zero_start: bool = False, force: float | None = None,
                     stiffness: np.ndarray | None = None, pairs: np.ndarray | None = None) -> np.ndarray:
    """Kinematic TE [m] of the explicit FE's faceted outlines at the input angles ``theta_in`` [rad, from the FE start].

    Each tooth pair ``k`` in contact (load share ``share[:, k] > 0``; pair 0 entered contact at the table
    phase 0) gets its own rigid gap ``g_k`` (first touch of the flank patches within ``radius`` of its
    contact point on the line of action); the loaded pair's TE shifts by the stiffness-weighted mean
    ``sum_k w_k g_k`` (linear springs: load share at zero gaps = stiffness share), which is returned.
    With ``force`` [N] and the total mesh ``stiffness`` [N/m] per angle, pairs whose gap exceeds the
    loaded deflection carry nothing: ``delta`` solves ``sum_k w_k K max(delta - g_k, 0) = F`` and
    ``delta - F / K`` is returned.

    Parameters
    ----------
    pair : GearPair
    meshes : sequence of two (nodes, quads, bore) tuples
        The explicit FE's gear meshes (:func:`gearrom.fe.explicit.gearmesh.gear_quad_mesh`).
    theta_in : ndarray
        Input-gear rotations (counter-clockwise) from the FE start position.
    share : ndarray (n_angles, n_pairs)
        Load share of pairs 0, 1, ... at each angle (from the mesh table at the ROM's phase).
    phase0 : float
        Table mesh phase of the FE start (:func:`gearrom.validation.pair_rom.fe_start_mesh_phase`).
    clearance : float
        The FE's initial clearance on the line of action, m (its TE is zero at rigid first contact).
    radius : float
        Flank patch radius around each pair's contact point, m.
    zero_start : bool
        Subtract the value at the first angle.
    pairs : ndarray of int, optional
        Pair index of each ``share`` column (:attr:`MeshExcitation.pairs`; pair p entered contact p mesh
        periods before pair 0); default ``0 .. n_pairs-1``.
    """
    gaps = faceted_pair_gaps(pair, meshes, theta_in, share, phase0, clearance, radius, pairs)
    te = loaded_kinematic_te(gaps, share, force, stiffness, theta_in)
    return te - te[0] if zero_start else te


def faceted_pair_gaps(pair, meshes, theta_in: np.ndarray, share: np.ndarray, phase0: float, clearance: float = 1e-6,
                      radius: float = 1.2e-3, pairs: np.ndarray | None = None) -> np.ndarray:
    """Rigid gap [m] of each loaded tooth pair of the explicit FE's faceted outlines (TE convention of the FE).

    ``gaps[j, k]`` is the rigid TE at which pair ``k`` (column ``k`` of ``share``) first touches at the
    input angle ``theta_in[j]`` [rad], measured like the FE's TE (zero at the clearance-free start);
    NaN where the pair carries no load (``share <= 1e-6``) or its flank patch is not bracketed within
    +-50 um. Parameters as :func:`faceted_rigid_te`.
    """
    from matplotlib.path import Path

    from gearrom.fe.explicit.gearpair import GearPairSetup, gear_pair_model
    from gearrom.fe.explicit.model import boundary_segments

    model, info = gear_pair_model(pair, meshes, GearPairSetup(clearance=clearance))
    x = np.asarray(model.nodes, float)
    off = info["n_gear1"]
    segs = boundary_segments(np.asarray(model.elements))
    bore = set(int(i) for i in model.node_sets["bore_1"]) | set(int(i) for i in model.node_sets["bore_2"])
    outer = np.array([s for s in segs if not (int(s[0]) in bore and int(s[1]) in bore)])
    g1 = outer[(outer < off).all(axis=1)]
    g2 = outer[(outer >= off).all(axis=1)]
    loop1, loop2 = outline_order(g1), outline_order(g2)
    c1, c2 = np.zeros(2), np.array([pair.aw, 0.0])
    rb1, rb2 = pair.rb
    z1, z2 = pair.z
    p1, p2 = x[loop1], x[loop2]
    drive1 = np.isin(loop1, model.node_sets["flank_1"])
    drive2 = np.isin(loop2, model.node_sets["flank_2"])
    hi = 50e-6 / rb2                                     # +-50 um on the line of action (facets: a few um)
    a = pair.alpha_wt
    n_loa = np.array([math.sin(a), math.cos(a)])
    t1 = rb1 * np.array([math.cos(a), -math.sin(a)])   # tangent point on the input base circle
    period = 2 * math.pi / z1
    phi = np.mod(phase0 + np.asarray(theta_in, float), period)
    n_pairs = share.shape[1]
    pairs = np.arange(n_pairs) if pairs is None else np.asarray(pairs, int)
    if pairs.shape != (n_pairs,):
        raise MeshError(f"faceted_rigid_te: {pairs.size} pair indices for {n_pairs} load-share columns")
    gaps = np.full((len(phi), n_pairs), np.nan)
    for j, (th, ph) in enumerate(zip(np.asarray(theta_in, float), phi)):
        q1 = _rot(p1, c1, th)
        base2 = _rot(p2, c2, -th * z1 / z2)           # output turns clockwise at the ratio
        poly1 = Path(q1)
        w = share[j]
        for k in range(n_pairs):
            if w[k] <= 1e-6:
                continue
            point = t1 + n_loa * (pair.roll_start_active[0] + rb1 * ph + pairs[k] * pair.pb_t)
            sel1 = drive1 & (np.hypot(*(q1 - point).T) < radius)
            near1 = q1[sel1]

            def overlap(ang, sel1=sel1, near1=near1, point=point):
                q2 = _rot(base2, c2, ang)
                near2 = q2[drive2 & (np.hypot(*(q2 - point).T) < radius)]
                return bool(poly1.contains_points(near2).any() or Path(q2).contains_points(near1).any())

            lo, up = -hi, hi
            if overlap(lo) or not overlap(up):
                continue                                  # this pair's flank patch is not bracketed: skip it
            gaps[j, k] = rb2 * first_touch(overlap, lo, up, iterations=40) - clearance   # the FE's TE is zero at the clearance-free start
    return gaps


def loaded_kinematic_te(gaps: np.ndarray, share: np.ndarray, force: float | None = None,
                        stiffness: np.ndarray | None = None, theta_in: np.ndarray | None = None) -> np.ndarray:
    """Kinematic TE [m] of per-pair rigid ``gaps`` [m] (:func:`faceted_pair_gaps`) under the load share ``share``.

    Without ``force`` [N] / ``stiffness`` [N/m per angle]: the share-weighted mean gap of the pairs with
    a gap. With them: ``delta - F / K`` where ``delta`` solves ``sum_k w_k K max(delta - g_k, 0) = F``
    (pairs whose gap exceeds the loaded deflection carry nothing). ``theta_in`` [rad] only names the
    angle in the error raised when no pair has a gap.
    """
    te = np.zeros(gaps.shape[0])
    for j in range(gaps.shape[0]):
        w = share[j]
        ok = np.isfinite(gaps[j])
        if not ok.any():
            th = theta_in[j] if theta_in is not None else float("nan")
            raise MeshError(f"no tooth pair in rigid contact at input angle {th:.6g} rad")
        if force is None or stiffness is None:
            te[j] = np.sum(w[ok] * gaps[j, ok]) / np.sum(w[ok])
            continue
        g, ww = gaps[j, ok], w[ok] / np.sum(w[ok]) * stiffness[j]
        order = np.argsort(g)
        g, ww = g[order], ww[order]
        for m in range(1, g.size + 1):                   # pairs 0..m-1 in contact
            delta = (force + np.sum(ww[:m] * g[:m])) / np.sum(ww[:m])
            if m == g.size or delta <= g[m]:
                break
        te[j] = delta - force / stiffness[j]
    return te


def elastic_deflection(te: np.ndarray, gaps: np.ndarray, share: np.ndarray) -> np.ndarray:
    """Elastic mesh deflection ``F / K`` [m] that reproduces a measured loaded TE ``te`` [m] with the rigid
    ``gaps`` [m] and the stiffness share ``share`` (the inverse of :func:`loaded_kinematic_te`).

    From ``sum_k w_k K max(te - g_k, 0) = F`` (``w`` normalised over the pairs with a gap):
    ``F / K = sum_k w_k max(te - g_k, 0)``. Raises MeshError where no pair has a gap or the measured TE
    lies below every gap (no pair loaded).
    """
    out = np.zeros(gaps.shape[0])
    for j in range(gaps.shape[0]):
        ok = np.isfinite(gaps[j])
        if not ok.any():
            raise MeshError(f"elastic_deflection: no tooth pair with a rigid gap at sample {j}")
        w = share[j, ok] / np.sum(share[j, ok])
        out[j] = float(np.sum(w * np.maximum(te[j] - gaps[j, ok], 0.0)))
        if not out[j] > 0:
            raise MeshError(f"elastic_deflection: TE {te[j]:.4g} m at sample {j} is below every rigid gap")
    return out
