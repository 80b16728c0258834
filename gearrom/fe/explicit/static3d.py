"""Direct static solves of the 3D (Hex8) explicit helical model: same mesh, elements and contact, no time stepping.

The explicit model of :func:`gearrom.fe.explicit.helicalpair.helical_pair_model` is solved for its static
equilibrium at a given input angle and output torque, as the quasi-static LTCA solves its own model:

* each gear's fully integrated Hex8 stiffness (2x2x2 Gauss points, the gradients and weights of the
  explicit kernel, :func:`gearrom.fe.explicit.geometry.full_integration_data`; linear elasticity, the
  small-strain limit of the kernel's St Venant-Kirchhoff law) with its bore clamped, factorized once in
  the gear's own frame;
* the pair placed rigidly at the input angle (input turned by ``theta``, output by the kinematic
  ``-theta z1 / z2``) from the model's start position; the output's rotation ``phi`` beyond that (the
  rigid approach) is the one unknown of the bores, as the explicit run's rigid references allow;
* the explicit contact of both passes (drive-flank nodes of each gear on the mate's flank facets,
  :func:`gearrom.fe.explicit.contact._signed_gap_3d`: the same facet, point and normal as the time loop)
  taken at the placed geometry: a candidate ``c`` with signed normal gap ``g0_c`` closes by
  ``a_c phi`` under the output's rotation and opens by the elastic deformation ``(C f)_c``, ``C`` the
  relative normal compliance of the candidates (both gears); with the penalty ``k`` of its facet,
  ``g0 - a phi + C f = -f / k`` on the loaded candidates, ``f >= 0``, and ``sum a f`` balances the
  output torque. A penalty scale of ``inf`` drops the ``1 / k`` (hard contact, the penalty's limit).

The TE is the explicit runs' (:func:`gearrom.fe.explicit.gearpair.transmission_error`): on the transverse
line of action, zero at rigid first contact in the start position, so that it includes the discretized
geometry's kinematic error at ``theta`` (facets with their sag restored, as the explicit contact sees them).

Compared with the explicit model's own dynamic relaxation (``validation/run_static_helical.py``), this
solve has no residual vibration, no mass scaling and no time-step limit on the penalty, so that penalty,
layers and body extent can be studied at a few seconds per position.
"""
from __future__ import annotations

import dataclasses
import logging
import math
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from gearrom.errors import SolverError
from gearrom.fe.explicit.contact import OPEN_TOL, contact_search, edge_fade, nearest_facets_3d, shape_q4
from gearrom.fe.explicit.geometry import full_integration_data

log = logging.getLogger(__name__)

__all__ = ["hex8_stiffness", "GearStiffness", "StaticPair3D", "StaticPoint3D", "static_te_3d"]


def hex8_stiffness(nodes: np.ndarray, hexes: np.ndarray, lam: float, mu: float) -> sp.csr_matrix:
    """Linear-elastic stiffness [N/m] of fully integrated Hex8 elements (3 dofs per node, node-major).

    ``K[3a + i, 3b + j] = sum_g W_g (lam dNa_i dNb_j + mu dNa_j dNb_i + mu delta_ij dNa . dNb)``: the
    tangent at zero displacement of the explicit kernel's St Venant-Kirchhoff element.
    """
    nodes = np.asarray(nodes, float)
    hexes = np.asarray(hexes, np.int64)
    Bg, Wg = full_integration_data(nodes, hexes)
    ne = hexes.shape[0]
    rows, cols, vals = [], [], []
    eye = np.eye(3)
    for lo in range(0, ne, 20000):
        B = Bg[lo:lo + 20000]
        W = Wg[lo:lo + 20000]
        # (e, a, i, b, j)
        Ke = (lam * np.einsum("eg,egai,egbj->eaibj", W, B, B) + mu * np.einsum("eg,egaj,egbi->eaibj", W, B, B)
              + mu * np.einsum("eg,egak,egbk,ij->eaibj", W, B, B, eye))
        dof = (3 * hexes[lo:lo + 20000, :, None] + np.arange(3)[None, None, :]).reshape(-1, 24)
        rows.append(np.repeat(dof, 24, axis=1).ravel())
        cols.append(np.tile(dof, (1, 24)).ravel())
        vals.append(Ke.reshape(-1, 24 * 24).ravel())
    n = 3 * nodes.shape[0]
    return sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsr()


class GearStiffness:
    """One gear's Hex8 stiffness with its bore clamped, factorized (sparse LU) for many load cases.

    Parameters
    ----------
    nodes : ndarray (n, 3)
        The gear's nodes in its start position, m.
    hexes : ndarray (ne, 8)
        Its elements (indices into ``nodes``).
    clamped : ndarray of int
        Bore nodes (all three displacements held).
    lam, mu : float
        Lame constants, Pa.
    """

    def __init__(self, nodes: np.ndarray, hexes: np.ndarray, clamped: np.ndarray, lam: float, mu: float) -> None:
        t0 = time.perf_counter()
        K = hex8_stiffness(nodes, hexes, lam, mu)
        n = nodes.shape[0]
        fixed = np.zeros(3 * n, bool)
        fixed[(3 * np.asarray(clamped)[:, None] + np.arange(3)).ravel()] = True
        used = np.zeros(n, bool)
        used[np.unique(hexes)] = True
        fixed |= np.repeat(~used, 3)   # nodes of no element (none in a gear mesh; kept safe)
        self.free = np.nonzero(~fixed)[0]
        Kf = K[self.free][:, self.free]
        self.n_dofs = int(self.free.size)
        try:   # MKL PARDISO (optional): a multi-threaded Cholesky whose many-column solves are BLAS 3
            import pypardiso

            self._upper = sp.triu(Kf, format="csr")
            self._pardiso = pypardiso.PyPardisoSolver(mtype=2)   # real symmetric positive definite
            self._pardiso.factorize(self._upper)
            self.lu = None
            backend = "MKL PARDISO"
        except ImportError:
            self._pardiso = None
            self.lu = sla.splu(Kf.tocsc(), permc_spec="MMD_AT_PLUS_A")
            backend = "SuperLU (install pypardiso for faster many-load solves)"
        log.info("Hex8 stiffness: %d free dofs, assembled and factorized in %.1f s (%s)", self.n_dofs,
                 time.perf_counter() - t0, backend)

    @classmethod
    def of_model(cls, model, n1: int) -> tuple[GearStiffness, GearStiffness]:
        """Both gears of a two-gear explicit model whose first ``n1`` nodes are the input's, bores
        ``bore_1`` / ``bore_2`` clamped."""
        X = np.asarray(model.nodes, float)
        hexes = np.asarray(model.elements, np.int64)
        lam, mu = model.material.lame
        return (cls(X[:n1], hexes[(hexes < n1).all(1)], model.node_sets["bore_1"], lam, mu),
                cls(X[n1:], hexes[(hexes >= n1).all(1)] - n1, model.node_sets["bore_2"] - n1, lam, mu))

    def response(self, loads) -> np.ndarray:
        """Displacements (free dofs x load cases) under nodal ``loads`` on the free dofs (free dofs x load
        cases, gear frame; sparse or dense)."""
        rhs = np.asarray(loads.toarray() if sp.issparse(loads) else loads, float)
        if self._pardiso is not None:
            return self._pardiso.solve(self._upper, rhs).reshape(rhs.shape)
        return self.lu.solve(rhs)

    def compliance(self, loads: sp.spmatrix, block: int = 256) -> np.ndarray:
        """``loads^T K^-1 loads`` (load cases x load cases) [m/N], solved ``block`` load cases at a time so that
        the dense responses of many cases are never held at once."""
        loads = sp.csc_matrix(loads)
        n = loads.shape[1]
        out = np.empty((n, n))
        for j in range(0, n, block):
            out[:, j:j + block] = loads.T @ self.response(loads[:, j:j + block])
        return out


@dataclasses.dataclass(frozen=True)
class StaticPoint3D:
    """A direct static solve of the 3D explicit model.

    Attributes
    ----------
    theta_in : float
        Input angle from the model's start position, rad.
    torque : float
        Output torque, N m.
    te : float
        Transmission error on the transverse line of action, m (explicit runs' convention).
    n_loaded : int
        Loaded contact nodes (both passes).
    n_candidates : int
        Candidates in the solve (signed gap within the window).
    penalty_scale : float
        Contact penalty scale of the solve (``ContactPair.penalty_scale``; ``inf``: hard contact).
    """

    theta_in: float
    torque: float
    te: float
    n_loaded: int
    n_candidates: int
    penalty_scale: float


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def solve_contact_lcp(C: np.ndarray, a: np.ndarray, g0: np.ndarray, moment: float, soft: np.ndarray,
                      tol: float = 1e-10, max_iter: int = 2000) -> tuple[np.ndarray, float]:
    """Contact forces ``f >= 0`` [N] and rigid rotation ``phi`` [rad] of ``g0 - a phi + (C + diag(soft)) f >= 0``,
    complementary to ``f``, with ``a . f = moment`` (active set: drop the most negative force, add the
    most penetrated candidate).

    Raises
    ------
    SolverError
        No convergence within ``max_iter`` active-set changes.
    """
    n = g0.size
    r = g0 / np.maximum(a, 1e-30)
    active = np.zeros(n, bool)
    active[np.argmin(np.where(a > 0, r, np.inf))] = True
    Cs = C + np.diag(soft)
    for _ in range(max_iter):
        A = np.nonzero(active)[0]
        m = A.size
        M = np.zeros((m + 1, m + 1))
        M[:m, :m] = Cs[np.ix_(A, A)]
        M[:m, m] = -a[A]
        M[m, :m] = a[A]
        rhs = np.concatenate([-g0[A], [moment]])
        sol = np.linalg.solve(M, rhs)
        fA, phi = sol[:m], sol[m]
        if fA.min() < -1e-12 * max(abs(fA).max(), 1e-30):
            active[A[np.argmin(fA)]] = False
            continue
        gap = g0 - a * phi + Cs[:, A] @ fA
        gap[A] = 0.0
        j = int(np.argmin(gap))
        if gap[j] < -tol:
            active[j] = True
            continue
        f = np.zeros(n)
        f[A] = np.maximum(fA, 0.0)
        return f, float(phi)
    raise SolverError(f"contact active set did not converge in {max_iter} changes ({n} candidates)")


class StaticPair3D:
    """A 3D explicit helical model prepared for direct static solves (stiffness factorized, contact arrays).

    Parameters
    ----------
    model, info
        From :func:`gearrom.fe.explicit.helicalpair.helical_pair_model` (full bodies or cut sectors).
    pair : GearPair
    stiffness : pair of GearStiffness, optional
        Factorized gears of this model (built when omitted).
    window : float
        Candidates: slave nodes whose signed gap at the rigid placement is below this, m; enlarged
        automatically when the solve closes a gap that was left out.
    """

    def __init__(self, model, info: dict, pair, stiffness: tuple[GearStiffness, GearStiffness] | None = None,
                 window: float = 40e-6) -> None:
        from gearrom.fe.explicit.driver import prepare

        self.model, self.info, self.pair, self.window = model, info, pair, window
        self.X = np.asarray(model.nodes, float)
        self.n1 = int(info["n_nodes_gear1"])
        self.c2 = np.array([pair.aw, 0.0, 0.0])
        self.stiffness = stiffness if stiffness is not None else GearStiffness.of_model(model, self.n1)
        self.d = prepare(model, 0.9, 32)
        self.depth = self.d["p_depth"][self.d["s_pair"]]
        self.p_model = float(model.contacts[0].penalty_scale)

    def _scales(self, penalty_scales) -> list[float]:
        scales = [self.p_model] if penalty_scales is None else [float(p) for p in penalty_scales]
        if any(not p > 0 for p in scales):
            raise SolverError(f"penalty scales must be positive (inf: hard contact), got {scales}")
        return scales

    def solve(self, theta: float, torques, penalty_scales=None, keep_state: bool = False):
        """Contact solves at input angle ``theta`` [rad] for every penalty scale and torque.

        Returns ``(rows, n_candidates, state)``: ``rows[p][t] = (forces, phi)``; ``state`` (with
        ``keep_state``) holds what :meth:`equilibrium` starts from.
        """
        n1, c2, d = self.n1, self.c2, self.d
        slaves, segs = d["slaves"], d["segs"]
        scales = self._scales(penalty_scales)
        s1 = math.copysign(1.0, self.info["omega_in"])
        rot = (s1 * theta, -s1 * theta * self.pair.z[0] / self.pair.z[1])
        x = self._positions(rot)
        g_k = d["g_k"] * (np.array(scales)[:, None] / self.p_model)
        w = self.window
        for _attempt in range(4):
            facet, xe, gap, nrm, reach, fade, _ = self._nearest(x, w)
            pick = np.nonzero(reach & (gap < w))[0]
            if pick.size == 0:
                raise SolverError(f"no contact candidate within {w * 1e6:.0f} um at theta = {theta:.6f} rad")
            P, C, a = _system(x, n1, c2, (_rot_z(rot[0]), _rot_z(rot[1])), slaves, segs, facet, xe, nrm, pick,
                              self.stiffness)
            wk = np.maximum(fade[pick, 0], 1e-9)
            rows = [[solve_contact_lcp(C, a, gap[pick], float(tq), 1.0 / (gk[facet[pick]] * wk)) for tq in torques]
                    for gk in g_k]
            # a slave left out that the rigid approach alone would close: widen the window and redo
            rest = np.setdiff1d(np.nonzero(reach)[0], pick)
            phi_max = max(r[1] for rs in rows for r in rs)
            if rest.size == 0 or np.all(gap[rest] - _approach(x, slaves, segs, facet, xe, nrm, rest, n1, c2) * phi_max
                                        > 0):
                break
            w *= 2
        else:
            raise SolverError(f"contact window grew beyond {w * 1e6:.0f} um at theta = {theta:.6f} rad")
        state = dict(P=P, rot=rot) if keep_state else None
        return rows, int(pick.size), state

    def _positions(self, rot, u_el=None, phi: float = 0.0) -> np.ndarray:
        """Node positions [m]: each gear turned rigidly by its placement ``rot`` [rad] with its elastic field
        ``u_el`` (free dofs of its start frame; none: rigid), the output further by ``phi`` about its centre."""
        X, n1, c2 = self.X, self.n1, self.c2
        body = [X[:n1].copy(), X[n1:] - c2]
        if u_el is not None:
            for g, (stf, ue) in enumerate(zip(self.stiffness, u_el)):
                flat = body[g].reshape(-1)
                flat[stf.free] += ue
        return np.vstack([body[0] @ _rot_z(rot[0]).T, body[1] @ _rot_z(rot[1] + phi).T + c2])

    def _nearest(self, x: np.ndarray, window: float):
        """Nearest master feature of every slave at positions ``x`` (:func:`nearest_facets_3d`, search reach
        ``window`` beyond the contact margin) and the slaves in reach: a facet found, not deeper than the
        capture depth (past the facet's body; the explicit contact ignores those)."""
        d = self.d
        contact_search(x, d["slaves"], d["s_pair"], d["segs"], d["g_pair"], d["g_rad"], d["margin"] + window,
                       d["head"], d["nxt"], d["cand"], d["ncand"], d["cell_h"])
        facet, xe, gap, nrm, ov, tdir = nearest_facets_3d(x, d["slaves"], d["segs"], d["g_rad"], d["cand"],
                                                          d["ncand"], d["seg_open"], d["seg_sag"])
        # penalty weight beyond an open edge and its slope [1/m], as the explicit contact takes them
        w, dw = edge_fade(ov, OPEN_TOL * d["g_rad"][np.maximum(facet, 0)])
        fade = np.column_stack([w, dw])
        return facet, xe, gap, nrm, (facet >= 0) & (gap > -self.depth), fade, tdir

    def equilibrium(self, theta: float, torque: float, penalty_scale: float | None = None, iterations: int = 8,
                    tol: float = 1e-9, linear=None):
        """The static state at input angle ``theta`` [rad] on the deformed contact geometry.

        The linear solve (:meth:`solve`) takes the contact geometry of the rigid placement; the explicit
        contact acts on the deformed one (facets turned with the output's rotation, points slid along them).
        So the state is re-solved on the current geometry: with the candidates' gaps, normals and facet
        points found at the deformed positions and the elastic field's own normal opening removed from the
        gaps, the forces and the output's further rotation follow from the same complementarity problem;
        repeated until the rotation changes by less than ``tol`` on the line of action [m]. ``linear``:
        ``(forces, phi, state)`` of an earlier :meth:`solve` at ``theta`` with ``keep_state`` for this
        torque and penalty scale (solved here when omitted).

        Returns
        -------
        u_el : list of two ndarrays
            Elastic displacements of each gear's free dofs in its start frame, m.
        phi : float
            The output's rotation beyond the rigid placement, rad.
        rot : tuple of float
            The rigid placement's turn of each gear, rad.
        n_loaded : int
            Loaded contact nodes.
        """
        scales = self._scales(None if penalty_scale is None else [penalty_scale])
        if linear is None:
            rows, _, st = self.solve(theta, [torque], scales, keep_state=True)
            linear = (*rows[0][0], st)
        f, phi, st = linear
        n1, c2, d = self.n1, self.c2, self.d
        g_k = d["g_k"] * (scales[0] / self.p_model)
        rot = st["rot"]
        u_el = [stf.response(Pg @ f) for stf, Pg in zip(self.stiffness, st["P"])]   # elastic fields (free dofs)
        f_all = np.zeros(d["slaves"].size)        # normal force per slave, N (for the edge-fade forces)
        for it in range(iterations):
            x = self._positions(rot, u_el, phi)
            facet, xe, gap, nrm, reach, fade, tdir = self._nearest(x, self.window)
            pick = np.nonzero(reach & (gap < self.window))[0]
            R = (_rot_z(rot[0]), _rot_z(rot[1] + phi))
            P, C, a = _system(x, n1, c2, R, d["slaves"], d["segs"], facet, xe, nrm, pick, self.stiffness)
            opening = sum(Pg.T @ ue for Pg, ue in zip(P, u_el))
            # beyond an open edge the explicit contact's faded energy k w g^2 / 2 also pushes tangentially,
            # -k g^2 w' / 2 = -f^2 w' / (2 k w^2) along the overshoot: a load from the last forces
            wk = np.maximum(fade[pick, 0], 1e-9)
            ft = -0.5 * f_all[pick] ** 2 * fade[pick, 1] / (g_k[facet[pick]] * wk ** 2)
            Ut, moment_t = _tangential(x, n1, c2, R, d["slaves"], d["segs"], facet, xe, tdir, pick, ft,
                                           self.stiffness)
            opening_t = sum(Pg.T @ ut for Pg, ut in zip(P, Ut))
            f, dphi = solve_contact_lcp(C, a, gap[pick] - opening + opening_t, float(torque) + moment_t,
                                        1.0 / (g_k[facet[pick]] * wk))
            phi += dphi
            f_all[:] = 0.0
            f_all[pick] = f
            u_el = [stf.response(Pg @ f) + ut for stf, Pg, ut in zip(self.stiffness, P, Ut)]
            log.info("static state at theta %.5f rad, geometry update %d: output turned by %.3g um more on the "
                     "line of action", theta, it + 1, dphi * self.pair.rb[1] * 1e6)
            if abs(dphi) * self.pair.rb[1] < tol and it > 0:
                break
        return u_el, float(phi), rot, int((f > 0).sum())

    def loaded_state(self, torque: float, penalty_scale: float | None = None, iterations: int = 8,
                     tol: float = 1e-9):
        """The loaded static state at the model's start position (:meth:`equilibrium` at ``theta = 0``), as
        the explicit driver takes it.

        Returns
        -------
        u : ndarray (n, 3)
            Nodal displacements from the model's nodes, m (the output's rigid rotation included).
        theta : ndarray (2,)
            Reference rotations (input 0, output ``phi``), rad, as :func:`gearrom.fe.explicit.gearpair.loaded_model`
            takes them.
        te : float
            The state's TE, m.
        """
        u_el, phi, rot, _ = self.equilibrium(0.0, torque, penalty_scale, iterations, tol)
        u = self._positions(rot, u_el, phi) - self.X
        te = self.pair.rb[1] * (phi - self.info["clearance_angle"])
        return u, np.array([0.0, phi]), float(te)

    def points(self, thetas, torques, penalty_scales=None, geometry_update: bool = False) -> list[StaticPoint3D]:
        """Static TE at input angles ``thetas`` [rad] and output torques [N m]: :func:`static_te_3d` on this
        prepared model."""
        scales = self._scales(penalty_scales)
        rb2 = self.pair.rb[1]
        out = []
        for th in thetas:
            rows, nc, st = self.solve(th, torques, scales, keep_state=geometry_update)
            for p, rs in zip(scales, rows):
                for tq, (f, phi) in zip(torques, rs):
                    n_loaded = int((f > 0).sum())
                    if geometry_update:
                        _, phi, _, n_loaded = self.equilibrium(th, tq, p, linear=(f, phi, st))
                    te = rb2 * (phi - self.info["clearance_angle"])
                    out.append(StaticPoint3D(float(th), float(tq), float(te), n_loaded, nc, p))
                    log.info("theta %.5f rad, %g N m, penalty %g: TE %.3f um (%d of %d candidates loaded)", th, tq,
                             p, te * 1e6, n_loaded, nc)
        return out


def static_te_3d(model, info: dict, pair, thetas, torques, penalty_scales=None, window: float = 40e-6,
                 stiffness: tuple[GearStiffness, GearStiffness] | None = None,
                 geometry_update: bool = False) -> list[StaticPoint3D]:
    """Static TE of a 3D explicit helical model at input angles ``thetas`` [rad] and output torques [N m].

    Parameters
    ----------
    model, info, pair, stiffness, window
        As for :class:`StaticPair3D`.
    thetas : sequence of float
        Input angles from the start position, rad.
    torques : sequence of float
        Output torques, N m (solved on the same compliances).
    penalty_scales : sequence of float, optional
        Contact penalty scales to solve with (``ContactPair.penalty_scale``: the explicit penalty ``k`` in
        proportion; ``math.inf``: hard contact, the penalty's limit), each on the same compliances.
        Default: the model's own.
    geometry_update : bool
        Re-solve every point on its deformed contact geometry (:meth:`StaticPair3D.equilibrium`, the
        explicit model's own equilibrium; two or three more solves per point, penalty and torque) instead
        of the linear solve on the rigid placement's geometry.

    Returns
    -------
    list of StaticPoint3D, angle-major, then penalty scale, then torque.
    """
    return StaticPair3D(model, info, pair, stiffness, window).points(thetas, torques, penalty_scales, geometry_update)


def _approach(x, slaves, segs, facet, xe, nrm, idx, n1, c2) -> np.ndarray:
    """Closure of the signed gap per unit output rotation (counter-clockwise about its centre), m/rad."""
    ez = np.array([0.0, 0.0, 1.0])
    a = np.empty(idx.size)
    for k, i in enumerate(idx):
        s = slaves[i]
        if s < n1:   # slave on the input, facet on the output: the facet point moves
            N = shape_q4(xe[i, 0], xe[i, 1])
            p = np.asarray(N) @ x[segs[facet[i]]]
            a[k] = nrm[i] @ np.cross(ez, p - c2)
        else:        # slave on the output: the node moves
            a[k] = -nrm[i] @ np.cross(ez, x[s] - c2)
    return a


def _tangential(x, n1, c2, R, slaves, segs, facet, xe, tdir, pick, ft, stiffness):
    """Known contact forces ``ft`` [N] along ``tdir`` (the edge-fade forces): their elastic responses (per
    gear, free dofs), their counter-clockwise moment on the output about its centre [N m] (``-sum a_t ft``
    with ``a_t`` the closure rate along ``tdir``, as the normal forces' moment is ``-sum a f``)."""
    loaded = np.nonzero(ft != 0.0)[0]
    if loaded.size == 0:
        return [np.zeros(st.n_dofs) for st in stiffness], 0.0
    idx = pick[loaded]
    Pt = _unit_loads(x.shape[0], n1, R, slaves, segs, facet, xe, tdir, idx, stiffness)
    Ut = [st.response(P @ ft[loaded]) for st, P in zip(stiffness, Pt)]
    moment = -float(_approach(x, slaves, segs, facet, xe, tdir, idx, n1, c2) @ ft[loaded])
    return Ut, moment


def _unit_loads(n_nodes, n1, R, slaves, segs, facet, xe, dirs, idx, stiffness) -> list:
    """Per gear (free dofs of its start frame x slaves ``idx``, sparse): a unit force along ``dirs[i]`` on
    slave ``i`` and minus it on its facet's nodes by their shape functions, with the gears turned by ``R``."""
    loads = [([], [], []), ([], [], [])]   # per gear: rows, cols, values in its own frame
    for c, i in enumerate(idx):
        N = np.asarray(shape_q4(xe[i, 0], xe[i, 1]))
        for node, wgt in [(slaves[i], 1.0)] + [(q, -N[k]) for k, q in enumerate(segs[facet[i]])]:
            g = 0 if node < n1 else 1
            rows, cols, vals = loads[g]
            rows.extend(3 * (node - (0 if g == 0 else n1)) + np.arange(3))
            cols.extend([c] * 3)
            vals.extend(R[g].T @ dirs[i] * wgt)   # the load in the gear's start frame
    out = []
    for g, st in enumerate(stiffness):
        rows, cols, vals = loads[g]
        n_g = n1 if g == 0 else n_nodes - n1
        out.append(sp.csc_matrix((vals, (rows, cols)), shape=(3 * n_g, idx.size))[st.free])
    return out


def _system(x, n1, c2, R, slaves, segs, facet, xe, nrm, pick, stiffness):
    """Loads ``P`` (per gear: free dofs of its frame x candidates, sparse), the candidates' relative normal
    compliance ``C`` [m/N] and closure per output rotation ``a`` [m/rad] at positions ``x``."""
    nc = pick.size
    Ps = _unit_loads(x.shape[0], n1, R, slaves, segs, facet, xe, nrm, pick, stiffness)
    C = np.zeros((nc, nc))
    for P, st in zip(Ps, stiffness):
        C += st.compliance(P)
    C = 0.5 * (C + C.T)
    a = _approach(x, slaves, segs, facet, xe, nrm, pick, n1, c2)
    if np.median(a) <= 0:
        raise SolverError("the output's counter-clockwise rotation does not close the contact (flank sets reversed?)")
    return Ps, C, a
