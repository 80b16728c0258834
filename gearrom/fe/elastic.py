"""Plane-strain linear elasticity with scikit-fem (quadratic triangles), factorised once.

The bore nodes are tied to a rigid reference node (a kinematic coupling, u = u_ref + theta_ref x r).
The reference node is held fixed, so the coupling reduces to clamping the bore; the reference
node's reaction is the bore reaction. Loads and displacement read-outs on the boundary are
expressed as sparse matrices built from the quadratic edge shape functions, so a point on an edge
at local coordinate xi gets the consistent weights of the P2 field.
"""
from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from gearrom.errors import MeshError, SolverError
from gearrom.fe.mesh2d import Mesh2D

log = logging.getLogger(__name__)


class FacetIndex:
    """Lookup of scikit-fem facet numbers from node pairs for a :class:`Mesh2D` (no assembly)."""

    def __init__(self, mesh: Mesh2D) -> None:
        from skfem import MeshTri

        self.mesh = mesh
        self.skmesh = MeshTri(np.ascontiguousarray(mesh.points.T), np.ascontiguousarray(mesh.triangles.T))
        f = self.skmesh.facets
        nv = mesh.points.shape[0]
        keys = np.minimum(f[0], f[1]).astype(np.int64) * nv + np.maximum(f[0], f[1])
        order = np.argsort(keys)
        self._facet_keys, self._facet_order = keys[order], order

    def facet_index(self, edges: np.ndarray) -> np.ndarray:
        """skfem facet index of each node pair (q, 2)."""
        nv = self.mesh.points.shape[0]
        e = np.asarray(edges, dtype=np.int64)
        keys = np.minimum(e[:, 0], e[:, 1]) * nv + np.maximum(e[:, 0], e[:, 1])
        pos = np.clip(np.searchsorted(self._facet_keys, keys), 0, self._facet_keys.size - 1)
        if np.any(self._facet_keys[pos] != keys):
            raise MeshError("boundary edge not found among the mesh facets (curve and mesh do not match)")
        return self._facet_order[pos]


class ElasticBody2D(FacetIndex):
    """Plane-strain body (quadratic triangles) with the bore clamped through a rigid reference node.

    Parameters
    ----------
    mesh : Mesh2D
        Linear triangle mesh; quadratic displacement (P2) is used on it.
    youngs_modulus, poisson_ratio : float
        Material [Pa], [-].
    thickness : float
        Out-of-plane thickness (face width) [m]; loads are total forces over it [N].
    """

    def __init__(self, mesh: Mesh2D, youngs_modulus: float, poisson_ratio: float, thickness: float) -> None:
        from skfem import Basis, ElementTriP2, ElementVector, asm
        from skfem.models.elasticity import lame_parameters, linear_elasticity

        if mesh.bore_nodes.size < 3:
            raise MeshError("the mesh has fewer than 3 bore nodes: the rigid bore coupling needs the bore curve")
        super().__init__(mesh)
        self.thickness = float(thickness)
        self.E, self.nu = float(youngs_modulus), float(poisson_ratio)
        self.basis = Basis(self.skmesh, ElementVector(ElementTriP2()), intorder=4)
        K = asm(linear_elasticity(*lame_parameters(self.E, self.nu)), self.basis) * self.thickness
        self.ndof = K.shape[0]
        nodal = self.basis.nodal_dofs  # (2, nverts)
        facet = self.basis.facet_dofs  # (2, nfacets)
        f = self.skmesh.facets
        nv = mesh.points.shape[0]
        self._nodal, self._facet = nodal, facet
        on_bore = np.zeros(nv, bool)
        on_bore[mesh.bore_nodes] = True
        bore_facets = np.flatnonzero(on_bore[f[0]] & on_bore[f[1]] & (self.skmesh.f2t[1] < 0))
        fixed = np.unique(np.concatenate([nodal[:, mesh.bore_nodes].ravel(), facet[:, bore_facets].ravel()]))
        self.fixed = fixed
        free = np.ones(self.ndof, bool)
        free[fixed] = False
        self.free = np.flatnonzero(free)
        Kff = K[self.free][:, self.free].tocsc()
        self.K = K
        try:
            self._lu = splu(Kff, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
        except RuntimeError as exc:
            raise SolverError(f"factorisation of the stiffness matrix failed ({exc}): check the mesh") from None
        log.info("elastic body: %d dofs, %d fixed (bore)", self.ndof, fixed.size)

    # ------------------------------------------------------------- lookup
    def outward_normals(self, edges: np.ndarray) -> np.ndarray:
        """Unit outward normals of boundary edges (q, 2)."""
        p = self.mesh.points
        e = np.asarray(edges)
        t = p[e[:, 1]] - p[e[:, 0]]
        n = np.column_stack([t[:, 1], -t[:, 0]])
        n /= np.linalg.norm(n, axis=1)[:, None]
        tri = self.skmesh.f2t[0, self.facet_index(e)]
        cen = p[self.mesh.triangles[tri]].mean(axis=1)
        mid = 0.5 * (p[e[:, 0]] + p[e[:, 1]])
        flip = np.einsum("ij,ij->i", n, mid - cen) < 0
        n[flip] *= -1
        return n

    def edge_operator(self, edges: np.ndarray, xi: np.ndarray, direction: np.ndarray,
                      weights: np.ndarray, column: np.ndarray, ncols: int) -> sp.csc_matrix:
        """Sparse (ndof, ncols) matrix: column c = sum of weight * direction * N(xi) over its points.

        Used both for loads (force vectors) and, transposed, for displacement read-outs.
        """
        e = np.asarray(edges, dtype=np.int64)
        xi = np.asarray(xi, float)
        fac = self.facet_index(e)
        n0 = (1 - xi) * (1 - 2 * xi)
        n1 = xi * (2 * xi - 1)
        nm = 4 * xi * (1 - xi)
        rows, vals, cols = [], [], []
        for comp in range(2):
            d = weights * direction[:, comp]
            for dofs, shape in ((self._nodal[comp, e[:, 0]], n0), (self._nodal[comp, e[:, 1]], n1),
                                (self._facet[comp, fac], nm)):
                rows.append(dofs)
                vals.append(d * shape)
                cols.append(column)
        return sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(self.ndof, ncols))

    # ------------------------------------------------------------- solve
    def solve(self, loads: np.ndarray | sp.spmatrix) -> np.ndarray:
        """Displacements (ndof, ncols) for load vectors (ndof, ncols) [N] with the bore clamped."""
        F = loads.toarray() if sp.issparse(loads) else np.asarray(loads, float)
        if F.ndim == 1:
            F = F[:, None]
        U = np.zeros((self.ndof, F.shape[1]))
        Ff = F[self.free]
        for a in range(F.shape[1]):  # SuperLU is faster column by column than with a block
            U[self.free, a] = self._lu.solve(np.ascontiguousarray(Ff[:, a]))
        if not np.all(np.isfinite(U)):
            raise SolverError("linear solve returned non-finite displacements (singular stiffness?)")
        return U

    def vertex_displacement(self, U: np.ndarray) -> np.ndarray:
        """Displacement of the mesh vertices (nverts, 2) from a solution vector (ndof,)."""
        return np.column_stack([U[self._nodal[0]], U[self._nodal[1]]])

    def stress_vm_vertices(self, U: np.ndarray) -> np.ndarray:
        """Von Mises stress projected to vertices [Pa] (plane strain)."""
        lam = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))
        mu = self.E / (2 * (1 + self.nu))
        ib = self.basis
        du = ib.interpolate(U).grad  # (2, 2, nel, nqp)
        eps = 0.5 * (du + np.transpose(du, (1, 0, 2, 3)))
        tr = eps[0, 0] + eps[1, 1]
        sxx = lam * tr + 2 * mu * eps[0, 0]
        syy = lam * tr + 2 * mu * eps[1, 1]
        sxy = 2 * mu * eps[0, 1]
        szz = self.nu * (sxx + syy)
        vm = np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2) + 3 * sxy**2).mean(axis=1)
        out = np.zeros(self.mesh.points.shape[0])
        cnt = np.zeros_like(out)
        for k in range(3):
            np.add.at(out, self.mesh.triangles[:, k], vm)
            np.add.at(cnt, self.mesh.triangles[:, k], 1)
        return out / np.maximum(cnt, 1)


def locate_on_chain(points: np.ndarray, edges: np.ndarray, coord_nodes: np.ndarray, target: np.ndarray,
                    what: str = "point") -> tuple[np.ndarray, np.ndarray]:
    """Find, for each target value of a monotonic nodal coordinate (e.g. radius), the edge and xi.

    Parameters
    ----------
    points : ndarray (n, 2)
        Mesh nodes (unused except for messages).
    edges : ndarray (k, 2)
        Edges of a curve.
    coord_nodes : ndarray (n,)
        The coordinate of every mesh node (only the curve's nodes are used).
    target : ndarray (q,)
        Values to locate.

    Returns
    -------
    edge_index : ndarray (q,) into ``edges``; xi : ndarray (q,) in [0, 1] from ``edges[:, 0]``.
    """
    ca, cb = coord_nodes[edges[:, 0]], coord_nodes[edges[:, 1]]
    lo, hi = np.minimum(ca, cb), np.maximum(ca, cb)
    order = np.argsort(lo)
    lo_s, hi_s = lo[order], hi[order]
    t = np.asarray(target, float)
    k = np.clip(np.searchsorted(lo_s, t, side="right") - 1, 0, lo_s.size - 1)
    tol = 1e-9 * max(abs(hi_s[-1]), 1e-12)
    bad = (t < lo_s[0] - tol) | (t > hi_s[-1] + tol) | (t > hi_s[k] + tol)
    if np.any(bad):
        v = t[bad][0]
        raise MeshError(
            f"{what} at coordinate {v:.6g} lies outside the meshed curve [{lo_s[0]:.6g}, {hi_s[-1]:.6g}]"
        )
    e = order[k]
    xi = np.clip((t - ca[e]) / np.where(cb[e] != ca[e], cb[e] - ca[e], 1.0), 0.0, 1.0)
    return e, xi
