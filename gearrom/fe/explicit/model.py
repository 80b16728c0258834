"""Input description of an explicit transient FE model (plain arrays, SI units).

The model is mesh-generator agnostic: node coordinates, Q4 or Hex8 connectivity, a material,
named node sets, and the boundary conditions the gear problems need (rigid reference nodes on
the bores, fixed DOFs, nodal load histories, node-to-segment contact pairs).

Conventions
-----------
* 2D models are plane strain with thickness ``thickness`` (m, the face width): forces, torques,
  masses and energies are totals for that thickness.
* Q4 connectivity is counter-clockwise in the (x, y) plane; Hex8 follows the usual VTK/Abaqus
  order (bottom face counter-clockwise seen from +z, then the top face). Inverted elements are
  rejected by :func:`gearrom.fe.explicit.geometry.element_geometry`.
* Master segments (2D: 2 nodes, 3D: 4 nodes) are oriented so that their normal points out of
  the master body: 2D edge (a, b) has outward normal (dy, -dx)/L, i.e. the body lies to the left
  of a -> b (counter-clockwise boundary); a 3D facet's normal is (x1-x0) x (x3-x0), i.e. the
  facet is counter-clockwise seen from outside. :func:`boundary_segments` builds them.
* A rigid reference has translations (x, y[, z]) and one rotation about the z axis (2D: the
  out-of-plane axis; 3D: the gear axis, which must be z). Tilting of 3D bores is not modelled.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping

import numpy as np

from gearrom.errors import ConfigError, MeshError

__all__ = [
    "Material",
    "RigidReference",
    "ContactPair",
    "NodalLoad",
    "ExplicitModel",
    "boundary_segments",
]


@dataclass(frozen=True)
class Material:
    """Isotropic St Venant-Kirchhoff material.

    Parameters
    ----------
    E : float
        Young's modulus, Pa.
    nu : float
        Poisson's ratio (-).
    rho : float
        Density, kg/m^3.
    """

    E: float = 210e9
    nu: float = 0.3
    rho: float = 7850.0

    def __post_init__(self) -> None:
        if not self.E > 0:
            raise ConfigError(f"Material.E must be > 0 Pa, got {self.E}")
        if not -1.0 < self.nu < 0.5:
            raise ConfigError(f"Material.nu must be in (-1, 0.5), got {self.nu}")
        if not self.rho > 0:
            raise ConfigError(f"Material.rho must be > 0 kg/m^3, got {self.rho}")

    @property
    def lame(self) -> tuple[float, float]:
        """Lame constants (lambda, mu), Pa (3D values; plane strain uses them unchanged)."""
        lam = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))
        mu = self.E / (2 * (1 + self.nu))
        return lam, mu

    @property
    def wave_speed(self) -> float:
        """Dilatational wave speed c_d = sqrt((lambda + 2 mu) / rho), m/s."""
        lam, mu = self.lame
        return float(np.sqrt((lam + 2 * mu) / self.rho))


@dataclass(frozen=True)
class RigidReference:
    """A reference node rigidly tied to a node set (kinematic coupling of a bore).

    DOFs: translations and the rotation ``theta`` about z (rad, counter-clockwise positive)
    about the reference point ``center`` (default: the plain mean of the tied node coordinates,
    the axis of a uniformly discretized bore). Give the gear axis explicitly when the bore
    nodes are not uniform: a shifted point makes the body orbit around it. With free
    translations the point should be the centre of mass of the tied nodes; the translation-
    rotation coupling of an offset is neglected.

    Parameters
    ----------
    nodes : str
        Name of the tied node set in ``ExplicitModel.node_sets``.
    speed : float or None
        If given, the rotation is driven at this speed (rad/s) reached through a cosine ramp of
        ``ramp_time`` (s). Without a spring the rotation is prescribed kinematically; with
        ``spring_k > 0`` a virtual driver follows the speed and the reference is connected to it
        by the torsional spring-damper (``spring_k`` N m/rad, ``spring_c`` N m s/rad).
    ramp_time : float
        Duration of the speed ramp, s (0: the speed applies from t = 0).
    torque : float
        External torque on the rotation, N m (applied through a cosine ramp of ``torque_ramp_time``).
    torque_ramp_time : float
        Ramp duration of the torque, s.
    inertia : float
        Extra lumped polar inertia added to the rotation, kg m^2.
    mass : float
        Extra lumped mass added to the translations, kg.
    spring_k, spring_c : float
        Torsional spring/damper to the driver (``speed`` given) or to ground (``speed`` None).
    fix_translation : bool
        Translations fixed (rigid bearing). If False they are free, with ``bearing_k`` (N/m) and
        ``bearing_c`` (N s/m) to ground.
    theta0, omega0 : float
        Initial rotation (rad) and speed (rad/s). With a prescribed speed, omega0 is ignored.
    center : tuple of float or None
        Reference point (x, y), m.
    """

    nodes: str
    speed: float | None = None
    ramp_time: float = 0.0
    torque: float = 0.0
    torque_ramp_time: float = 0.0
    inertia: float = 0.0
    mass: float = 0.0
    spring_k: float = 0.0
    spring_c: float = 0.0
    fix_translation: bool = True
    bearing_k: float = 0.0
    bearing_c: float = 0.0
    theta0: float = 0.0
    omega0: float = 0.0
    center: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.center is not None and (len(self.center) != 2 or not np.all(np.isfinite(self.center))):
            raise ConfigError(f"RigidReference.center must be two finite coordinates (x, y) in m, got {self.center}")
        for name in ("ramp_time", "torque_ramp_time", "inertia", "mass", "spring_k", "spring_c",
                     "bearing_k", "bearing_c"):
            val = getattr(self, name)
            if not (np.isfinite(val) and val >= 0):
                raise ConfigError(f"RigidReference.{name} must be finite and >= 0, got {val}")


@dataclass(frozen=True)
class ContactPair:
    """Node-to-segment penalty contact: slave nodes against master segments.

    Parameters
    ----------
    slave : str
        Name of the slave node set.
    master : str
        Name of the master surface in ``ExplicitModel.surfaces`` (oriented segments).
    mu : float
        Coulomb friction coefficient (0: frictionless), regularized by ``v_reg``.
    penalty_scale : float
        Penalty stiffness factor f_s in k = f_s median((lambda + 2 mu) A_seg^2 / V_el) over the master
        segments (the LS-DYNA form with the P-wave modulus; 2D: A_seg = edge length * thickness); one
        value per pair, so that the penalty energy is continuous as a node slides across segments.
    v_reg : float
        Slip velocity (m/s) below which friction is regularized: f_t = -mu f_n v_t/sqrt(v_t^2+v_reg^2).
    capture_depth : float or None
        Largest penetration (m) still treated as contact; None: half the smallest master element
        size. Deeper nodes are ignored (they belong to the far side of the master body).
    """

    slave: str
    master: str
    mu: float = 0.0
    penalty_scale: float = 0.1
    v_reg: float = 1e-3
    capture_depth: float | None = None

    def __post_init__(self) -> None:
        if not self.mu >= 0:
            raise ConfigError(f"ContactPair.mu must be >= 0, got {self.mu}")
        if not self.penalty_scale > 0:
            raise ConfigError(f"ContactPair.penalty_scale must be > 0, got {self.penalty_scale}")
        if not self.v_reg > 0:
            raise ConfigError(f"ContactPair.v_reg must be > 0 m/s, got {self.v_reg}")


@dataclass(frozen=True)
class NodalLoad:
    """A force on every node of a set: ``force`` (N per node, vector) times a table of factors.

    ``times`` (s, increasing) and ``factors`` (-) define a piecewise-linear amplitude, held
    constant outside the table.
    """

    nodes: str
    force: tuple[float, ...]
    times: tuple[float, ...] = (0.0,)
    factors: tuple[float, ...] = (1.0,)

    def __post_init__(self) -> None:
        if len(self.times) != len(self.factors) or len(self.times) == 0:
            raise ConfigError("NodalLoad.times and NodalLoad.factors must have the same non-zero length")
        if np.any(np.diff(self.times) <= 0):
            raise ConfigError("NodalLoad.times must be strictly increasing")


def _frozen_sets(sets: Mapping[str, np.ndarray]) -> Mapping[str, np.ndarray]:
    out = {}
    for k, v in sets.items():
        arr = np.array(v, dtype=np.int64)
        arr.setflags(write=False)
        out[str(k)] = arr
    return MappingProxyType(out)


@dataclass(frozen=True, eq=False)
class ExplicitModel:
    """A complete explicit FE model.

    Parameters
    ----------
    nodes : ndarray (n, 2) or (n, 3)
        Reference coordinates, m.
    elements : ndarray (ne, 4) Q4 or (ne, 8) Hex8
        Connectivity (0-based node indices).
    material : Material
    thickness : float
        Out-of-plane thickness for 2D plane strain, m (ignored in 3D).
    node_sets : mapping str -> int array
        Named node sets.
    surfaces : mapping str -> int array (m, 2) or (m, 4)
        Named oriented master segments (see module docstring).
    references : tuple of RigidReference
    contacts : tuple of ContactPair
    loads : tuple of NodalLoad
    fixed : mapping str -> tuple of int
        Node set name -> fixed components (0 = x, 1 = y, 2 = z); displacement held at zero.
    integration : {"reduced", "full"}
        "reduced": one-point elements with Flanagan-Belytschko hourglass control (the cheap default);
        "full": 2x2 (Q4) / 2x2x2 (Hex8) Gauss integration, no hourglass modes and no hourglass energy
        (about twice the element cost; stiffer in bending of coarse meshes: shear locking).
    hourglass_stiffness : float
        Flanagan-Belytschko stiffness coefficient kappa: k_hg = kappa (lambda + 2 mu) V sum(B^2)/dim.
    hourglass_viscosity : float
        Flanagan-Belytschko viscous coefficient: c_hg = coef sqrt(rho (lambda+2mu)) V sqrt(sum(B^2)/dim).
    mass_damping : float
        Mass-proportional damping alpha, 1/s (0: none), on the absolute nodal velocity: it also
        brakes a rigid rotation, so it suits quasi-static relaxation, not a running gear.
    relative_damping : float
        Mass-proportional damping alpha_r, 1/s (0: none), on each free node's velocity relative to the
        rigid motion of the reference tied to its body (the connected part of the mesh that holds the
        reference's nodes): a dashpot m alpha_r between the node and its gear's rigid frame, whose
        reaction acts on the reference. It damps elastic vibration and leaves the rigid spin, the
        total momentum and the angular momentum unchanged.
    initial_velocity : ndarray (n, dim) or None
        Initial nodal velocities, m/s (tied nodes take their reference's motion instead).
    initial_displacement : ndarray (n, dim) or None
        Initial nodal displacements, m (e.g. a static loaded state).
    mass_scaling_dt : float
        Selective mass scaling: nodes whose stable step is below this value (s) get the extra
        mass that raises it to this value (0: off). The added mass is reported in the run metadata.
    """

    nodes: np.ndarray
    elements: np.ndarray
    material: Material = Material()
    thickness: float = 1.0
    node_sets: Mapping[str, np.ndarray] = field(default_factory=dict)
    surfaces: Mapping[str, np.ndarray] = field(default_factory=dict)
    references: tuple[RigidReference, ...] = ()
    contacts: tuple[ContactPair, ...] = ()
    loads: tuple[NodalLoad, ...] = ()
    fixed: Mapping[str, tuple[int, ...]] = field(default_factory=dict)
    integration: str = "reduced"
    hourglass_stiffness: float = 0.05
    hourglass_viscosity: float = 0.0
    mass_damping: float = 0.0
    relative_damping: float = 0.0
    initial_velocity: np.ndarray | None = None
    initial_displacement: np.ndarray | None = None
    mass_scaling_dt: float = 0.0

    def __post_init__(self) -> None:
        x = np.array(self.nodes, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] not in (2, 3) or x.shape[0] == 0:
            raise MeshError(f"ExplicitModel.nodes must have shape (n, 2) or (n, 3), got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise MeshError("ExplicitModel.nodes contains non-finite coordinates")
        dim = x.shape[1]
        conn = np.array(self.elements, dtype=np.int64)
        nen = 4 if dim == 2 else 8
        if conn.ndim != 2 or conn.shape[1] != nen or conn.shape[0] == 0:
            raise MeshError(f"ExplicitModel.elements must have shape (ne, {nen}) for a {dim}D model "
                            f"({'Q4' if dim == 2 else 'Hex8'}), got {conn.shape}")
        if conn.min() < 0 or conn.max() >= x.shape[0]:
            raise MeshError(f"ExplicitModel.elements refers to node {conn.max()} outside 0..{x.shape[0] - 1}")
        x.setflags(write=False)
        conn.setflags(write=False)
        object.__setattr__(self, "nodes", x)
        object.__setattr__(self, "elements", conn)
        sets = _frozen_sets(self.node_sets)
        for k, v in sets.items():
            if v.size and (v.min() < 0 or v.max() >= x.shape[0]):
                raise MeshError(f"ExplicitModel.node_sets[{k!r}] refers to a node outside 0..{x.shape[0] - 1}")
        object.__setattr__(self, "node_sets", sets)
        nseg = 2 if dim == 2 else 4
        surfs = {}
        for k, v in self.surfaces.items():
            s = np.array(v, dtype=np.int64).reshape(-1, nseg) if np.size(v) else np.zeros((0, nseg), np.int64)
            if s.size and (s.min() < 0 or s.max() >= x.shape[0]):
                raise MeshError(f"ExplicitModel.surfaces[{k!r}] refers to a node outside 0..{x.shape[0] - 1}")
            s.setflags(write=False)
            surfs[str(k)] = s
        object.__setattr__(self, "surfaces", MappingProxyType(surfs))
        object.__setattr__(self, "fixed", MappingProxyType({str(k): tuple(int(c) for c in v)
                                                            for k, v in self.fixed.items()}))
        if not self.thickness > 0:
            raise ConfigError(f"ExplicitModel.thickness must be > 0 m, got {self.thickness}")
        if self.integration not in ("reduced", "full"):
            raise ConfigError(f"ExplicitModel.integration must be 'reduced' or 'full', got {self.integration!r}")
        for name in ("hourglass_stiffness", "hourglass_viscosity", "mass_damping", "relative_damping",
                     "mass_scaling_dt"):
            if not getattr(self, name) >= 0:
                raise ConfigError(f"ExplicitModel.{name} must be >= 0, got {getattr(self, name)}")
        for r in self.references:
            if r.nodes not in sets:
                raise ConfigError(f"RigidReference.nodes: unknown node set {r.nodes!r}")
        for c in self.contacts:
            if c.slave not in sets:
                raise ConfigError(f"ContactPair.slave: unknown node set {c.slave!r}")
            if c.master not in surfs:
                raise ConfigError(f"ContactPair.master: unknown surface {c.master!r}")
        for ld in self.loads:
            if ld.nodes not in sets:
                raise ConfigError(f"NodalLoad.nodes: unknown node set {ld.nodes!r}")
            if len(ld.force) != dim:
                raise ConfigError(f"NodalLoad.force must have {dim} components, got {len(ld.force)}")
        for k, comps in self.fixed.items():
            if k not in sets:
                raise ConfigError(f"ExplicitModel.fixed: unknown node set {k!r}")
            if any(c < 0 or c >= dim for c in comps):
                raise ConfigError(f"ExplicitModel.fixed[{k!r}]: components must be in 0..{dim - 1}")
        for name in ("initial_velocity", "initial_displacement"):
            val = getattr(self, name)
            if val is not None:
                arr = np.array(val, dtype=np.float64)
                if arr.shape != x.shape:
                    raise ConfigError(f"ExplicitModel.{name} must have shape {x.shape}, got {arr.shape}")
                arr.setflags(write=False)
                object.__setattr__(self, name, arr)

    @property
    def dim(self) -> int:
        """Spatial dimension (2 or 3)."""
        return int(self.nodes.shape[1])


def boundary_segments(elements: np.ndarray, dim: int | None = None) -> np.ndarray:
    """Oriented boundary segments of a Q4 (edges) or Hex8 (quad facets) mesh.

    Parameters
    ----------
    elements : ndarray (ne, 4) or (ne, 8)
        Counter-clockwise Q4 or standard-order Hex8 connectivity.

    Returns
    -------
    ndarray (m, 2) or (m, 4)
        Segments oriented with the outward normal convention of :mod:`model`.
    """
    conn = np.asarray(elements, dtype=np.int64)
    if dim is None:
        dim = 2 if conn.shape[1] == 4 else 3
    if dim == 2:
        loc = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    else:
        # faces with outward normals (counter-clockwise seen from outside)
        loc = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])
    segs = conn[:, loc].reshape(-1, loc.shape[1])
    key = np.sort(segs, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return segs[counts[inv.ravel()] == 1]
