"""Second, independent formulation: both gears in one FE system with Lagrange-multiplier contact.

Used to cross-check the influence-coefficient LTCA at a few positions. Differences from the LTCA:

* both meshes are placed at their true angular positions in one global frame (no cyclic symmetry);
* the gaps come from the meshed geometry itself (node-to-segment: every boundary dof point of the
  input gear's loaded flanks against the output gear's quadratic flank edges), not from the
  analytic involute gap;
* the contact forces are nodal Lagrange multipliers (no pressure patches, no grid interpolation);
* the torque is a moment on the rigid reference node of the input gear's bore (kinematic coupling
  u = theta_ref x r on every bore dof); the output bore is held fixed.

The saddle-point system [[K, -B_A^T], [B_A, 0]] is solved for each active set (sparse LU) until no
multiplier is tensile and no inactive point penetrates. STE = -theta_ref r_b1 (the rotation of the
input reference node along its base circle, positive when the output lags).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from gearrom.errors import SolverError
from gearrom.fe.elastic import ElasticBody2D
from gearrom.fe.mesh2d import MeshSettings, gear_mesh
from gearrom.geometry.pair import inv

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FullContactResult:
    """STE [m], contact force [N] (sum of multipliers), active point count, placement angles [rad]."""

    theta: float
    torque: float
    ste: float
    force: float
    n_active: int
    phi: tuple[float, float]
    iterations: int


def _flank_angle(pair, i: int, L: float) -> float:
    """Polar angle (from +x) of the right-flank point at roll ``L`` of tooth 0 in the gear's own frame."""
    rb = pair.rb[i]
    r = math.hypot(rb, L)
    eta = pair.s_t[i] / pair.d[i] + float(inv(pair.alpha_t)) - float(inv(math.acos(rb / r)))
    return math.pi / 2 - eta


def placement(pair, L1: float) -> tuple[float, float]:
    """Rotations (phi1, phi2) [rad, CCW] that put tooth 0 of both gears in contact at input roll ``L1``.

    Gear 1 centre at the origin, gear 2 centre at (0, a_w) with its own frame turned by pi + phi2.
    """
    a = pair.alpha_wt
    u = np.array([math.cos(a), math.sin(a)])
    B1 = pair.rb[0] * np.array([-math.sin(a), math.cos(a)])
    P = B1 + L1 * u
    phi1 = math.atan2(P[1], P[0]) - _flank_angle(pair, 0, L1)
    L2 = pair.aw * math.sin(a) - L1
    Q = P - np.array([0.0, pair.aw])
    phi2 = math.atan2(Q[1], Q[0]) - _flank_angle(pair, 1, L2) - math.pi
    return phi1, phi2


def _rot(phi: float) -> np.ndarray:
    return np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])


def frames_at(pair, theta: float):
    """Rotation and origin of each gear's frame at input angle ``theta`` [rad] (0: start of the active mesh)."""
    phi1, phi2 = placement(pair, pair.roll_start_active[0] + pair.rb[0] * theta)
    return [(_rot(phi1), np.zeros(2)), (_rot(math.pi + phi2), np.array([0.0, pair.aw]))]


def _rot(phi: float) -> np.ndarray:
    return np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])


def _boundary_points(body: ElasticBody2D, edges: np.ndarray):
    """Dof points (vertices + edge midpoints) of a curve: coordinates and (x-dof, y-dof) pairs."""
    pts = body.mesh.points
    v = np.unique(edges)
    fac = body.facet_index(edges)
    xy = np.vstack([pts[v], 0.5 * (pts[edges[:, 0]] + pts[edges[:, 1]])])
    dofs = np.vstack([body._nodal[:, v].T, body._facet[:, fac].T])
    return xy, dofs


class FullContactModel:
    """Both gears of a spur pair meshed with ``settings`` (refined_teeth >= 1) in one FE system."""

    def __init__(self, pair, settings: MeshSettings | None = None) -> None:
        s = settings or MeshSettings(refined_teeth=1)
        if s.refined_teeth < 1:
            raise SolverError("the full-contact model needs refined_teeth >= 1 (all pairs in contact refined)")
        self.pair = pair
        self.bodies = []
        for i in range(2):
            g = pair.gears[i]
            self.bodies.append(ElasticBody2D(gear_mesh(pair, i, s), g.material.youngs_modulus,
                                             g.material.poisson_ratio, g.face_width))
        b1, b2 = self.bodies
        # gear 1: bore dofs slaved to the reference rotation (last unknown of block 1)
        n1 = b1.ndof
        free1 = b1.free
        rows, cols, vals = list(free1), list(range(free1.size)), [1.0] * free1.size
        pts = b1.mesh.points
        bore_dofs = b1.fixed
        # coordinates of each fixed dof's point: vertices or facet midpoints
        coords = np.zeros((n1, 2))
        coords[b1._nodal[0]] = pts
        coords[b1._nodal[1]] = pts
        f = b1.skmesh.facets
        mid = 0.5 * (pts[f[0]] + pts[f[1]])
        coords[b1._facet[0]] = mid
        coords[b1._facet[1]] = mid
        is_x = np.zeros(n1, bool)
        is_x[b1._nodal[0]] = True
        is_x[b1._facet[0]] = True
        for d in bore_dofs:  # u = theta x r: ux = -theta y, uy = theta x
            rows.append(d)
            cols.append(free1.size)
            vals.append(-coords[d, 1] if is_x[d] else coords[d, 0])
        self.T1 = sp.csc_matrix((vals, (rows, cols)), shape=(n1, free1.size + 1))
        K1 = (self.T1.T @ b1.K @ self.T1).tocsc()
        K2 = b2.K[b2.free][:, b2.free].tocsc()
        self.K = sp.block_diag([K1, K2], format="csc")
        self.n1 = free1.size + 1
        self.map2 = np.full(b2.ndof, -1)
        self.map2[b2.free] = np.arange(b2.free.size)

    def solve(self, theta: float, torque: float, teeth: int = 1, tol: float = 1e-10, max_iter: int = 60) -> FullContactResult:
        """Static contact at input angle ``theta`` [rad] in the mesh period and output torque [N m]."""
        pair, (b1, b2) = self.pair, self.bodies
        L1 = pair.roll_start_active[0] + pair.rb[0] * theta
        phi1, phi2 = placement(pair, L1)
        R1, R2 = _rot(phi1), _rot(math.pi + phi2)
        O2 = np.array([0.0, pair.aw])
        # slave points: input-gear flank dof points; master: output-gear flank edges
        xs, ds = [], []
        for j in range(-teeth, teeth + 1):
            xy, dofs = _boundary_points(b1, b1.mesh.curves[f"involute_r_{j}"])
            xs.append(xy @ R1.T)
            ds.append(dofs)
        xs, ds = np.vstack(xs), np.vstack(ds)
        medges = np.vstack([b2.mesh.curves[f"involute_r_{j}"] for j in range(-teeth, teeth + 1)])
        m0 = b2.mesh.points[medges[:, 0]] @ R2.T + O2
        m1 = b2.mesh.points[medges[:, 1]] @ R2.T + O2
        nrm = b2.outward_normals(medges) @ R2.T
        # closest master edge for every slave point
        t = m1 - m0
        ll = np.einsum("ij,ij->i", t, t)
        rel = xs[:, None, :] - m0[None, :, :]
        xi = np.clip(np.einsum("sej,ej->se", rel, t) / ll[None, :], 0.0, 1.0)
        proj = m0[None] + xi[..., None] * t[None]
        dist = np.linalg.norm(xs[:, None, :] - proj, axis=2)
        e = np.argmin(dist, axis=1)
        xi_s = xi[np.arange(xs.shape[0]), e]
        n_s = nrm[e]
        g0 = np.einsum("ij,ij->i", xs - proj[np.arange(xs.shape[0]), e], n_s)
        inside = (xi[np.arange(xs.shape[0]), e] > 0) & (xi[np.arange(xs.shape[0]), e] < 1)
        near = inside & (g0 < 50e-6)
        xs, ds, e, xi_s, n_s, g0 = xs[near], ds[near], e[near], xi_s[near], n_s[near], g0[near]
        if g0.size == 0:
            raise SolverError(f"contact not found at theta = {math.degrees(theta):.4f} deg: no flank points within 50 um")
        # constraint rows: g = g0 + n . (R1 u1_s - R2 u2_m)
        n = g0.size
        rows, cols, vals = [], [], []
        nl1 = n_s @ R1  # n expressed in gear 1's frame
        for c in range(2):
            rows.append(np.arange(n))
            cols.append(ds[:, c])
            vals.append(nl1[:, c])
        B1 = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, b1.ndof))
        B1 = B1 @ self.T1
        nl2 = n_s @ R2
        me = medges[e]
        fac = b2.facet_index(me)
        N = [(1 - xi_s) * (1 - 2 * xi_s), xi_s * (2 * xi_s - 1), 4 * xi_s * (1 - xi_s)]
        rows, cols, vals = [], [], []
        for c in range(2):
            for dofs, Nk in ((b2._nodal[c, me[:, 0]], N[0]), (b2._nodal[c, me[:, 1]], N[1]), (b2._facet[c, fac], N[2])):
                loc = self.map2[dofs]
                ok = loc >= 0
                rows.append(np.arange(n)[ok])
                cols.append(loc[ok])
                vals.append(-nl2[ok, c] * Nk[ok])
        B2 = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(n, b2.free.size))
        B = sp.hstack([B1, B2]).tocsr()
        F = np.zeros(self.K.shape[0])
        T1 = torque * pair.z[0] / pair.z[1]
        F[self.n1 - 1] = -T1  # driving moment, clockwise
        active = g0 <= g0.min() + 0.2e-6
        for it in range(1, max_iter + 1):
            A = np.flatnonzero(active)
            BA = B[A]
            S = sp.bmat([[self.K, -BA.T], [BA, None]], format="csc")
            rhs = np.concatenate([F, -g0[A]])
            try:
                x = splu(S, permc_spec="COLAMD").solve(rhs)
            except RuntimeError as exc:
                raise SolverError(f"full-contact saddle system singular at theta = {math.degrees(theta):.4f} deg ({exc})") from None
            u, lam = x[: self.K.shape[0]], x[self.K.shape[0]:]
            if np.any(lam < 0):
                active[A[lam < 0]] = False
                continue
            g = g0 + B @ u
            pen = np.flatnonzero(~active & (g < -tol))
            if pen.size == 0:
                theta_ref = u[self.n1 - 1]
                return FullContactResult(theta=theta, torque=torque, ste=-theta_ref * pair.rb[0], force=float(lam.sum()),
                                         n_active=int(A.size), phi=(phi1, phi2), iterations=it)
            active[pen] = True
        raise SolverError(f"full-contact active set did not converge at theta = {math.degrees(theta):.4f} deg "
                          f"after {max_iter} iterations")
