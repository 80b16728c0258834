"""3D linear elasticity with scikit-fem (quadratic tetrahedra), factorised once per gear.

The bore nodes are tied to a rigid reference node (kinematic coupling of all six rigid-body
degrees of freedom, u = u_ref + theta_ref x r). The reference node is held fixed (rigid bearings,
TE measured as the relative rotation of the two references), so the coupling reduces to
clamping the bore surface; the reference node's reaction is the bore reaction.

Loads and read-outs at arbitrary points (flank patches, points below the flank) are sparse
operators built from the P2 shape functions at those points (scikit-fem ``probes``), so a point
force gets its consistent nodal loads and a read-out is the interpolated P2 displacement.

Linear solver: Intel MKL PARDISO through ``pypardiso`` when it is installed (much faster for
3D), else SciPy's SuperLU.
"""
from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp

from gearrom.errors import MeshError, SolverError
from gearrom.fe.mesh3d import Mesh3D

log = logging.getLogger(__name__)


class _Factor:
    """Factorisation of an SPD sparse matrix: PARDISO if available, else SuperLU."""

    def __init__(self, A: sp.csr_matrix) -> None:
        self.backend = "superlu"
        try:
            import pypardiso

            self._ps = pypardiso.PyPardisoSolver(mtype=2)  # real symmetric positive definite
            self._A = sp.triu(A, format="csr")
            self._ps.factorize(self._A)
            self.backend = "pardiso"
            return
        except ImportError:
            pass
        from scipy.sparse.linalg import splu

        try:
            self._lu = splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
        except RuntimeError as exc:
            raise SolverError(f"factorisation of the 3D stiffness matrix failed ({exc}): check the mesh") from None

    def free(self) -> None:
        """Release the factorisation (PARDISO keeps it in MKL memory until told otherwise)."""
        if self.backend == "pardiso":
            self._ps.free_memory(everything=True)
        else:
            self._lu = None

    def __del__(self) -> None:  # pragma: no cover - best effort
        try:
            self.free()
        except Exception:  # noqa: BLE001
            pass

    def solve(self, B: np.ndarray) -> np.ndarray:
        B = np.asarray(B, float)
        if self.backend == "pardiso":
            return np.asarray(self._ps.solve(self._A, np.ascontiguousarray(B))).reshape(B.shape)
        if B.ndim == 1:
            return self._lu.solve(B)
        return np.column_stack([self._lu.solve(np.ascontiguousarray(B[:, k])) for k in range(B.shape[1])])


class ElasticBody3D:
    """Linear elastic body (P2 tetrahedra) with the bore clamped through a rigid reference node.

    Parameters
    ----------
    mesh : Mesh3D
    youngs_modulus, poisson_ratio : float
        Material [Pa], [-].
    factorise : bool
        False: assemble only (tests of the assembly, export without a solve).
    """

    def __init__(self, mesh: Mesh3D, youngs_modulus: float, poisson_ratio: float, factorise: bool = True) -> None:
        from skfem import Basis, ElementTetP2, ElementVector, MeshTet, asm
        from skfem.models.elasticity import lame_parameters, linear_elasticity

        if mesh.bore_nodes.size < 3:
            raise MeshError("the 3D mesh has fewer than 3 bore nodes: the rigid bore coupling needs the bore surface")
        self.mesh = mesh
        self.E, self.nu = float(youngs_modulus), float(poisson_ratio)
        self.skmesh = MeshTet(np.ascontiguousarray(mesh.points.T), np.ascontiguousarray(mesh.tets.T))
        self.basis = Basis(self.skmesh, ElementVector(ElementTetP2()), intorder=2)
        self.sbasis = Basis(self.skmesh, ElementTetP2(), intorder=2)
        K = asm(linear_elasticity(*lame_parameters(self.E, self.nu)), self.basis)
        self.ndof = K.shape[0]
        # bore: every vertex and edge dof whose vertices all lie on the bore
        on = np.zeros(mesh.points.shape[0], bool)
        on[mesh.bore_nodes] = True
        edges = self.skmesh.edges
        bore_edges = np.flatnonzero(on[edges[0]] & on[edges[1]])
        fixed = np.concatenate([self.basis.nodal_dofs[:, mesh.bore_nodes].ravel(),
                                self.basis.edge_dofs[:, bore_edges].ravel()])
        self.fixed = np.unique(fixed)
        free = np.ones(self.ndof, bool)
        free[self.fixed] = False
        self.free = np.flatnonzero(free)
        self.K = K
        self._factor = _Factor(K[self.free][:, self.free].tocsr()) if factorise else None
        # scalar P2 dof s, component c -> vector dof (checked against the vector basis numbering)
        self._vec = np.vstack([self.basis.nodal_dofs[c] for c in range(3)])
        log.info("3D body: %d dofs, %d fixed (bore), solver %s", self.ndof, self.fixed.size,
                 self._factor.backend if self._factor else "-")

    @property
    def backend(self) -> str:
        return self._factor.backend if self._factor else "none"

    def _scalar_to_vector(self, S: sp.csr_matrix, comp: int) -> sp.csr_matrix:
        """Map a (q, n_scalar_dofs) probe matrix to vector dofs of component ``comp``."""
        # the vector basis numbers dofs entity by entity: scalar dof s -> 3 s + comp
        S = S.tocoo()
        return sp.csr_matrix((S.data, (S.row, 3 * S.col + comp)), shape=(S.shape[0], self.ndof))

    def probe_matrix(self, points: np.ndarray, directions: np.ndarray, what: str = "point") -> sp.csr_matrix:
        """Sparse (q, ndof): row k gives the displacement at ``points[k]`` along ``directions[k]``.

        Its transpose maps point forces of unit magnitude along ``directions`` to nodal loads.
        """
        x = np.ascontiguousarray(np.asarray(points, float).T)
        try:
            P = self.sbasis.probes(x)
        except (ValueError, IndexError) as exc:
            raise MeshError(f"{what}: a point lies outside the 3D mesh ({exc})") from None
        d = np.asarray(directions, float)
        out = None
        for c in range(3):
            Pc = self._scalar_to_vector(sp.diags(d[:, c]) @ P, c)
            out = Pc if out is None else out + Pc
        return out.tocsr()

    def solve(self, loads) -> np.ndarray:
        """Displacements (ndof, ncols) for load vectors (ndof, ncols) [N] with the bore clamped."""
        F = loads.toarray() if sp.issparse(loads) else np.asarray(loads, float)
        if F.ndim == 1:
            F = F[:, None]
        if self._factor is None:
            raise SolverError("this 3D body was built without factorisation")
        U = np.zeros((self.ndof, F.shape[1]))
        U[self.free] = self._factor.solve(F[self.free]).reshape(self.free.size, F.shape[1])
        if not np.all(np.isfinite(U)):
            raise SolverError("3D linear solve returned non-finite displacements (singular stiffness?)")
        return U

    def release(self) -> None:
        """Release the factorisation (the body can no longer solve)."""
        if self._factor is not None:
            self._factor.free()
            self._factor = None

    def vertex_displacement(self, U: np.ndarray) -> np.ndarray:
        """Displacement of the mesh vertices (nverts, 3) from a solution vector (ndof,)."""
        return np.column_stack([U[self.basis.nodal_dofs[c]] for c in range(3)])

    def stress_vm_cells(self, U: np.ndarray) -> np.ndarray:
        """Von Mises stress per tetrahedron (mean over its quadrature points) [Pa]."""
        lam = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))
        mu = self.E / (2 * (1 + self.nu))
        du = self.basis.interpolate(U).grad  # (3, 3, nel, nqp)
        eps = 0.5 * (du + np.transpose(du, (1, 0, 2, 3)))
        tr = eps[0, 0] + eps[1, 1] + eps[2, 2]
        s = 2 * mu * eps
        for k in range(3):
            s[k, k] = s[k, k] + lam * tr
        dev = s - np.eye(3)[:, :, None, None] * (tr * (lam + 2 * mu / 3))[None, None]
        return np.sqrt(1.5 * np.einsum("ijkl,ijkl->kl", dev, dev)).mean(axis=1)
