"""The loaded 3D state of a helical pair at one position: direct FE solve, cross-check, VTU export.

:class:`LoadedPair3D` re-meshes and factorises both gears (same :class:`Mesh3DSettings` as the
compliances), applies the LTCA contact forces of one position as point forces on the real teeth
of the mesh (no influence coefficients, no cyclic symmetry, no grid interpolation) and solves
once. Two uses:

* :meth:`LoadedPair3D.crosscheck`: the approach implied by the direct solve at every loaded
  candidate, ``h + u_1 + u_2 + (half-space surface - half-space depth)`` with ``u_g`` the FE inward
  normal displacement ``depth`` below the flank and the half-space terms computed directly for the
  fine contact patches, against the LTCA's approach (the second formulation of the 3D model:
  superposition, cyclic symmetry and the coarse-grid interpolation are what it checks);
* :meth:`LoadedPair3D.write_vtu`: both deformed gears in the global frame (ParaView).

Frames: gear 1 centre at the origin, gear 2 centre at (0, a_w, 0), both turned about +z by the
angles of :func:`gearrom.fe.fullcontact.placement` (its own frame turned by pi + phi_2 for gear 2).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from gearrom.fe.compliance3d import flank_geometry
from gearrom.fe.elastic3d import ElasticBody3D
from gearrom.fe.halfspace import point_depth_kernel, rect_surface
from gearrom.fe.mesh3d import Mesh3DSettings, sector_mesh


def _rotz(phi: float) -> np.ndarray:
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class LoadedPair3D:
    """Both gears of a :class:`~gearrom.fe.ltca_helical.Helical3DLTCA` as FE bodies (see module doc).

    Parameters
    ----------
    ltca : Helical3DLTCA
    settings : Mesh3DSettings, optional
        Default: the settings stored with the LTCA's compliances.
    """

    def __init__(self, ltca, settings: Mesh3DSettings | None = None) -> None:
        self.ltca, self.pair = ltca, ltca.pair
        self.bodies, teeth = [], []
        for i in range(2):
            s = settings or Mesh3DSettings(**ltca.c[i].info["settings"])
            g = self.pair.gears[i]
            self.bodies.append(ElasticBody3D(sector_mesh(self.pair, i, s), g.material.youngs_modulus,
                                             g.material.poisson_ratio))
            teeth.append(s.teeth)
        self.teeth = min(teeth)

    def _points(self, d: dict, gear: int):
        """Flank points, outward normals and tooth numbers of the candidates on ``gear``."""
        lt = self.ltca
        t = d["k"] * lt.d_mu
        if gear == 0:
            sig, tooth = d["line_s1"][d["li"]] + t, -d["p"]
        else:
            sig, tooth = d["line_s2"][d["li"]] - t, d["p"]
        X = np.empty((sig.size, 3))
        N = np.empty((sig.size, 3))
        for j in np.unique(tooth):
            s = tooth == j
            X[s], N[s] = flank_geometry(self.pair, gear, sig[s], d["z"][s], int(j))
        return X, N, tooth

    def solve(self, theta: float, torque: float, inset: float = 50e-6):
        """LTCA solution at ``theta`` [rad], ``torque`` [N m] and the FE displacements of both gears.

        Returns (result, candidates dict, [U_1, U_2], [(X, N, tooth) of the candidates per gear]).
        Forces on teeth outside the elastic sector are dropped (they carry nothing at sane positions).
        ``inset``: the forces act this far below the flank (inside the faceted mesh of the coarser
        teeth; irrelevant at the read-out depth).
        """
        res = self.ltca.solve(theta, torque)
        d = self.ltca.last_state[3]
        U, geo = [], []
        for g, body in enumerate(self.bodies):
            X, N, tooth = self._points(d, g)
            on = (res.force_c > 0) & (np.abs(tooth) <= self.teeth)
            P = body.probe_matrix(X[on] - inset * N[on], -N[on], f"gear {g} contact forces")
            U.append(body.solve(P.T @ res.force_c[on])[:, 0])
            geo.append((X, N, tooth))
        return res, d, U, geo

    def crosscheck(self, theta: float, torque: float, nq: int = 3) -> dict:
        """Approach of the direct FE solve vs the LTCA's (see module doc); lengths in m.

        Returns ``ste_ltca``, ``ste_direct`` (force-weighted mean over the loaded candidates, transverse
        line of action) and ``spread`` (force-weighted rms of the per-candidate difference).
        """
        lt = self.ltca
        res, d, U, geo = self.solve(theta, torque)
        f = res.force_c
        on = (f > 0) & (np.abs(d["p"]) <= self.teeth)  # loaded candidates on the teeth of both meshes
        app = d["gap_t"][on] * lt.cosb
        u_mu = ((np.arange(nq) + 0.5) / nq - 0.5) * lt.d_mu
        u_lam = ((np.arange(nq) + 0.5) / nq - 0.5) * lt.d_lam
        for g, (body, c, (X, N, tooth)) in enumerate(zip(self.bodies, lt.c, geo)):
            dep = np.interp(d["line_s1" if g == 0 else "line_s2"][d["li"]], c.sigma, c.depth.reshape(c.shape)[:, 0])
            Y = X[on] - dep[on, None] * N[on]
            app = app + body.probe_matrix(Y, -N[on], f"gear {g} read-out") @ U[g]
            # half-space: fine patches of the same pair, surface minus depth
            hs = np.zeros(on.sum())
            idx = np.flatnonzero(on)
            for p in np.unique(d["p"][on]):
                s = d["p"][on] == p
                ii = idx[s]
                dk = (d["k"][ii][:, None] - d["k"][ii][None, :]) * lt.d_mu
                dm = (d["m"][ii][:, None] - d["m"][ii][None, :]) * lt.d_lam
                surf = c.halfspace_factor * rect_surface(dk, dm, 0.5 * lt.d_mu, 0.5 * lt.d_lam) @ f[ii]
                # patch quadrature points in the flank's tangent plane (across x along the contact line)
                Xc, Nc = X[ii], N[ii]
                a = np.cross(Nc, [0.0, 0.0, 1.0])
                a /= np.linalg.norm(a, axis=1, keepdims=True)
                lam = np.cross(Nc, a)
                mu = np.cross(lam, Nc)
                Q = (Xc[:, None, None, :] + u_mu[None, :, None, None] * mu[:, None, None, :]
                     + u_lam[None, None, :, None] * lam[:, None, None, :]).reshape(ii.size, nq * nq, 3)
                H = point_depth_kernel(Q, np.full((ii.size, nq * nq), 1.0 / nq**2), Xc - dep[ii, None] * Nc, Nc,
                                       dep[ii], c.youngs_modulus, c.poisson_ratio)
                hs[s] = surf - H.T @ f[ii]
            app = app + hs
        w = f[on] / f[on].sum()
        delta = float(w @ app)
        return {"ste_ltca": res.ste, "ste_direct": delta / lt.cosb,
                "spread": float(np.sqrt(w @ (app - res.ste * lt.cosb) ** 2)) / lt.cosb, "stiffness_ltca": res.stiffness,
                "stiffness_direct": res.force / max(delta / lt.cosb - res.ste_kinematic, 1e-300)}

    def write_vtu(self, theta: float, torque: float, path: str | Path) -> Path:
        """Both deformed gears at one position as VTU: point data ``displacement`` [m],
        ``contact_pressure`` [Pa] (nearest candidate within a patch), ``gear``; cell data ``von_mises`` [Pa]."""
        import meshio
        from scipy.spatial import cKDTree

        from gearrom.fe.fullcontact import placement

        res, d, U, geo = self.solve(theta, torque)
        phi1, phi2 = placement(self.pair, self.pair.roll_start_active[0] + self.pair.rb[0] * theta)
        frames = [(_rotz(phi1), np.zeros(3)), (_rotz(math.pi + phi2), np.array([0.0, self.pair.aw, 0.0]))]
        pts, cells, disp, pres, gid, vm = [], [], [], [], [], []
        off = 0
        for g, (body, (X, N, tooth)) in enumerate(zip(self.bodies, geo)):
            R, O = frames[g]
            m = body.mesh
            p = np.zeros(m.points.shape[0])
            on = res.force_c > 0
            if on.any():
                flank = np.unique(np.concatenate([v for k, v in m.flank_nodes.items() if k.startswith("involute_r_")]))
                dist, k = cKDTree(X[on]).query(m.points[flank])
                near = dist < 2 * self.ltca.d_lam
                p[flank[near]] = res.pressure[on][k[near]]
            pts.append(m.points @ R.T + O)
            cells.append(m.tets + off)
            disp.append(body.vertex_displacement(U[g]) @ R.T)
            pres.append(p)
            gid.append(np.full(m.points.shape[0], float(g)))
            vm.append(body.stress_vm_cells(U[g]))
            off += m.points.shape[0]
        mesh = meshio.Mesh(np.vstack(pts), [("tetra", np.vstack(cells))],
                           point_data={"displacement": np.vstack(disp), "contact_pressure": np.concatenate(pres),
                                       "gear": np.concatenate(gid)},
                           cell_data={"von_mises": [np.concatenate(vm)]})
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        meshio.write(path, mesh)
        return path
