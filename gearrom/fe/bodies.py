"""Torsional flexibility of a gear body: its rim swings on the body's torsional compliance.

A reduced model that puts a gear's whole polar inertia on the mesh spring treats the body as rigid, while the
quasi-static mesh table (bore-clamped gears) counts the body's torsion in the mesh compliance: the rim and
teeth, most of the inertia, then sit behind a compliance they are in fact in front of. The body model here
splits the gear into a rim on the mesh side and a hub on the bore, joined by a torsional spring:

* the bore-clamped in-plane modes of the gear's transverse section (plane strain, times the face width;
  scikit-fem, consistent mass);
* each mode's effective inertia about the axis, ``J_j = (phi_j^T M r)^2`` for mass-normalised ``phi_j`` and the
  rigid rotation field ``r``; the first torsional mode is the mode of largest effective inertia;
* rim inertia ``J_r = J_j`` and spring ``k_b = J_r w_j^2`` of that mode, so that the rim on the clamped hub
  has the body's first torsional frequency; the hub carries the rest of the gear's inertia.

The mesh law then carries the table's compliance less both bodies' (:func:`without_body_compliance`), so that
the static TE between the bores is the table's.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np

from gearrom.errors import ModelError

log = logging.getLogger(__name__)

__all__ = ["GearBody", "body_from_modes", "gear_body", "torsional_modes", "without_body_compliance"]


@dataclass(frozen=True)
class GearBody:
    """Rim-on-hub model of a gear body.

    Attributes
    ----------
    inertia : float
        Polar inertia of the whole gear [kg m^2].
    rim_inertia : float
        Inertia of the rim (the effective inertia of the first bore-clamped torsional mode) [kg m^2].
    stiffness : float
        Torsional stiffness between hub and rim [N m/rad].
    frequency : float
        First bore-clamped torsional mode [Hz] (``sqrt(stiffness / rim_inertia) / 2 pi``).
    """

    inertia: float
    rim_inertia: float
    stiffness: float
    frequency: float

    def __post_init__(self) -> None:
        if not (0 < self.rim_inertia < self.inertia and self.stiffness > 0):
            raise ModelError(f"GearBody needs 0 < rim_inertia < inertia and stiffness > 0, got {self}")

    @property
    def hub_inertia(self) -> float:
        """Inertia on the hub [kg m^2]."""
        return self.inertia - self.rim_inertia

    def with_inertia(self, inertia: float) -> "GearBody":
        """The same body with its inertia scaled to ``inertia`` [kg m^2] (e.g. a model's mass-scaled gear):
        same stiffness and rim share, so the body frequency moves with the mass."""
        s = float(inertia) / self.inertia
        return replace(self, inertia=float(inertia), rim_inertia=self.rim_inertia * s,
                       frequency=self.frequency / np.sqrt(s))


def torsional_modes(nodes: np.ndarray, quads: np.ndarray, bore: np.ndarray, width: float, *, E: float = 210e9,
                    nu: float = 0.3, density: float = 7850.0, n_modes: int = 8) -> dict:
    """Bore-clamped in-plane modes of a gear's transverse Q4 mesh (centred on the axis; plane strain, ``width``
    thick) with their effective inertias about the axis, and the body's static mode.

    Returns a dict: ``frequency_Hz`` and ``effective_inertia_kgm2`` of the ``n_modes`` lowest modes,
    ``inertia_kgm2`` (the whole mesh's polar inertia), ``inertia_without_bore_kgm2``, and ``static_mode``: the
    deflection under the inertia load of a unit angular acceleration (``M r``) scaled to a unit mass-weighted
    mean rotation, as its stiffness ``k_body_Nm_per_rad`` and mass ``M_qq_kgm2`` (a Rayleigh-Ritz body model).
    """
    import scipy.sparse.linalg as sla
    from skfem import Basis, BilinearForm, ElementQuad1, ElementVector, MeshQuad1
    from skfem.helpers import dot
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    nodes = np.asarray(nodes, float)
    bore = np.unique(np.asarray(bore, np.int64))
    if bore.size < 2 or width <= 0:
        raise ModelError(f"gear body needs >= 2 bore nodes and width > 0, got {bore.size} nodes, width {width}")
    basis = Basis(MeshQuad1(np.ascontiguousarray(nodes.T), np.ascontiguousarray(np.asarray(quads).T)),
                  ElementVector(ElementQuad1()))
    lam, mu = lame_parameters(E, nu)                # plane strain
    K = width * linear_elasticity(lam, mu).assemble(basis)

    @BilinearForm
    def mass(u, v, w):
        return density * width * dot(u, v)

    M = mass.assemble(basis)
    rot = np.zeros(K.shape[0])                      # DOFs of ElementVector(Quad1): x of node i at 2 i, y at 2 i + 1
    rot[0::2], rot[1::2] = -nodes[:, 1], nodes[:, 0]
    free = np.setdiff1d(np.arange(K.shape[0]), np.concatenate([2 * bore, 2 * bore + 1]))
    Kf, Mf, r = K[free][:, free].tocsc(), M[free][:, free].tocsc(), rot[free]
    lu = sla.splu(Kf)                               # one factorisation: the static mode and the shift-invert modes
    psi = lu.solve(Mf @ r)
    psi /= (r @ (Mf @ psi)) / (r @ (Mf @ r))
    w2, phi = sla.eigsh(Kf, k=min(n_modes, free.size - 2), M=Mf, sigma=0.0, which="LM",
                        OPinv=sla.LinearOperator(Kf.shape, matvec=lu.solve, dtype=float))
    order = np.argsort(w2)
    w2, phi = w2[order], phi[:, order]
    phi = phi / np.sqrt(np.einsum("ij,ij->j", phi, Mf @ phi))
    return {"frequency_Hz": (np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi)).tolist(),
            "effective_inertia_kgm2": ((phi.T @ (Mf @ r)) ** 2).tolist(),
            "inertia_kgm2": float(rot @ (M @ rot)), "inertia_without_bore_kgm2": float(r @ (Mf @ r)),
            "static_mode": {"k_body_Nm_per_rad": float(psi @ (Kf @ psi)), "M_qq_kgm2": float(psi @ (Mf @ psi))}}


def body_from_modes(modes: dict) -> GearBody:
    """The rim-on-hub model of :func:`torsional_modes`' result: the mode of largest effective inertia as the rim."""
    J = np.asarray(modes["effective_inertia_kgm2"])
    j = int(np.argmax(J))
    w = 2 * np.pi * modes["frequency_Hz"][j]
    return GearBody(inertia=modes["inertia_kgm2"], rim_inertia=float(J[j]), stiffness=float(J[j] * w * w),
                    frequency=float(modes["frequency_Hz"][j]))


def gear_body(nodes: np.ndarray, quads: np.ndarray, bore: np.ndarray, width: float, *, E: float = 210e9,
              nu: float = 0.3, density: float = 7850.0, n_modes: int = 8) -> GearBody:
    """The rim-on-hub body model of a gear from its transverse Q4 mesh (centred on the axis).

    Parameters
    ----------
    nodes : ndarray (n, 2)
        Node coordinates [m], the gear axis at the origin.
    quads : ndarray (m, 4)
        Q4 elements (counter-clockwise).
    bore : ndarray of int
        Nodes on the bore, clamped.
    width : float
        Face width [m] (the section is plane strain).
    E, nu, density : float
        Young's modulus [Pa], Poisson's ratio [-], density [kg/m^3].
    n_modes : int
        Bore-clamped modes computed; the torsional one is the mode of largest effective inertia among them.

    Returns
    -------
    GearBody
    """
    body = body_from_modes(torsional_modes(nodes, quads, bore, width, E=E, nu=nu, density=density,
                                           n_modes=n_modes))
    log.info("gear body: first torsional mode %.0f Hz, rim %.1f %% of %.4g kg m^2", body.frequency,
             100 * body.rim_inertia / body.inertia, body.inertia)
    return body


def without_body_compliance(excitation, bodies: tuple[GearBody, GearBody], rb: tuple[float, float]):
    """The mesh table with both bodies' torsional compliance taken out of its mesh compliance.

    On the transverse line of action body i adds ``rb_i^2 / k_i`` [m/N]; the static TE of each torque loses
    ``F c`` (``F = T / rb2``) and the secant compliance ``c``: the kinematic TE stays, and the static TE of a
    model with the bodies, measured between the bores, is the table's.
    """
    c = sum(r ** 2 / b.stiffness for r, b in zip(rb, bodies))
    force = np.asarray(excitation.torque, float)[:, None] / rb[1]
    flex = 1.0 / np.asarray(excitation.k, float) - c
    if np.any(flex <= 0):
        raise ModelError(f"the bodies' torsional compliance ({c * 1e9:.3g} um/kN) exceeds the mesh table's: the "
                         "body model does not apply to this table")
    meta = dict(excitation.metadata, body_compliance_m_per_N=c)
    return replace(excitation, k=1.0 / flex, e=np.asarray(excitation.e, float) - force * c,
                   definition=f"{excitation.definition}; both gear bodies' torsion taken out ({c * 1e9:.4g} um/kN)",
                   metadata=meta)
