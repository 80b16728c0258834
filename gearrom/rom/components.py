"""Lumped drivetrain components. Each adds its element matrices to the assembled model and its items
to an exudyn system (:meth:`Component.add_to_exudyn`).

Degrees of freedom
------------------
A shaft *station* (node) has 6 DOFs in the global frame, shafts parallel to z:
``(ux, uy, uz, rx, ry, rz)`` [m, rad]; a *rotor* station (motor, brake) has the single DOF ``rz``.
Rotations are small except ``rz``, which the model carries as the deviation from the nominal rigid
rotation (see :mod:`gearrom.rom.model`). Gyroscopic terms couple ``rx, ry`` of spinning stations.
DOFs per body in the rig model: each gear body (on its ``gear`` station) has lateral ``ux, uy``,
axial ``uz``, tilting ``rx, ry`` and torsional ``rz`` DOFs, so the helical mesh force acts with its
axial component and its moments; every other shaft station (sensor end, ball bearing, needle
bearing, clutch end) has the same 6 DOFs; motor and brake rotors have ``rz`` only (62 DOFs in all).

Element formulations
--------------------
* :class:`ShaftSegment`: Euler-Bernoulli beam in two bending planes (cubic Hermite stiffness),
  axial bar and torsion ``GJ/L``; solid circular section; mass lumped half to each end station
  (translational mass, polar and diametral inertia of each half). Damping ``beta K`` (stiffness
  proportional).
* :class:`Disk`: rigid body mass, polar inertia ``Ip`` and diametral inertia ``Id``.
* :class:`BallBearing`: radial (``ux``, ``uy``) and axial (``uz``) springs to ground; no tilt stiffness.
* :class:`NeedleBearing`: radial springs only (axially free, seed ch. 5.2.2).
* :class:`Clutch`: torsional spring-damper between two ``rz`` DOFs.
* :class:`Motor`: speed controller = viscous coupling ``c (Omega - omega)`` of the rotor to the ideal
  speed, plus a feed-forward torque equal to the nominal load (a proportional speed law).
* :class:`Load`: constant brake torque on the brake rotor.
* :class:`Encoder`: an angle sensor on a station (radius and side recorded; reads ``rz``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

UX, UY, UZ, RX, RY, RZ = range(6)


@dataclass(frozen=True)
class Station:
    """A node of the lumped model.

    Parameters
    ----------
    name : str
        Unique name, e.g. ``"in.gear"``.
    shaft : str
        ``"in"`` or ``"out"``: which shaft (sets position and spin).
    z : float
        Axial position [m].
    ndof : int
        6 (shaft station) or 1 (rotor, ``rz`` only).
    spin : float
        Spin rate about +z per unit input speed [-] (+1 input, -z1/z2 output).
    """

    name: str
    shaft: str
    z: float
    ndof: int
    spin: float

    def local(self, dof: int) -> int:
        """Local index of global-frame DOF ``dof`` (UX..RZ) in this station."""
        if self.ndof == 1:
            if dof != RZ:
                raise IndexError(f"rotor station {self.name} has only rz")
            return 0
        return dof


@dataclass(frozen=True)
class Element:
    """Element matrices over a list of (station, dof) pairs (dof in UX..RZ)."""

    dofs: tuple[tuple[str, int], ...]
    M: np.ndarray | None = None
    K: np.ndarray | None = None
    D: np.ndarray | None = None
    G: np.ndarray | None = None  # gyroscopic matrix per unit input speed


class Component:
    """Base class: subclasses implement :meth:`elements`."""

    def elements(self, stations: dict[str, Station]) -> list[Element]:  # pragma: no cover - abstract
        raise NotImplementedError

    def add_to_exudyn(self, mbs, nodes: dict[str, int], stations: dict[str, Station]) -> list[int]:
        """Add one ObjectGenericODE2 per element over the nodes of its stations. Returns object indices."""
        from exudyn.itemInterface import ObjectGenericODE2

        out = []
        for el in self.elements(stations):
            names = list(dict.fromkeys(s for s, _ in el.dofs))
            offs, n = {}, 0
            for s in names:
                offs[s] = n
                n += stations[s].ndof
            idx = [offs[s] + stations[s].local(d) for s, d in el.dofs]
            kw = {}
            for key in ("M", "K", "D"):
                mat = getattr(el, key)
                big = np.zeros((n, n))
                if mat is not None:
                    big[np.ix_(idx, idx)] = mat
                kw[key] = big
            out.append(mbs.AddObject(ObjectGenericODE2(
                nodeNumbers=[nodes[s] for s in names], massMatrix=kw["M"], stiffnessMatrix=kw["K"],
                dampingMatrix=kw["D"])))
        return out


def _beam_plane(ei: float, length: float) -> np.ndarray:
    """Euler-Bernoulli bending stiffness for (v1, t1, v2, t2), t = dv/dz."""
    L = length
    return ei / L**3 * np.array([
        [12, 6 * L, -12, 6 * L], [6 * L, 4 * L * L, -6 * L, 2 * L * L],
        [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L * L, -6 * L, 4 * L * L]])


@dataclass(frozen=True)
class ShaftSegment(Component):
    """Solid shaft segment between two 6-DOF stations (Euler-Bernoulli, lumped mass).

    Parameters
    ----------
    a, b : str
        End stations (``z_b > z_a``).
    diameter : float
        Outer diameter [m].
    youngs_modulus, poisson_ratio, density : float
        Material [Pa, -, kg/m^3].
    damping_beta : float
        Stiffness-proportional damping coefficient [s].
    """

    a: str
    b: str
    diameter: float
    youngs_modulus: float = 210e9
    poisson_ratio: float = 0.3
    density: float = 7850.0
    damping_beta: float = 1e-5

    def elements(self, stations):
        sa, sb = stations[self.a], stations[self.b]
        L = sb.z - sa.z
        if not L > 0:
            raise ValueError(f"shaft segment {self.a}->{self.b}: stations must increase in z (length {L})")
        r = 0.5 * self.diameter
        area, inertia, polar = math.pi * r**2, math.pi * r**4 / 4, math.pi * r**4 / 2
        E, G = self.youngs_modulus, self.youngs_modulus / (2 * (1 + self.poisson_ratio))
        K = np.zeros((12, 12))
        ka, kt = E * area / L, G * polar / L
        for i, k in ((UZ, ka), (RZ, kt)):
            K[np.ix_([i, 6 + i], [i, 6 + i])] += k * np.array([[1, -1], [-1, 1]])
        kb = _beam_plane(E * inertia, L)
        ix = [UX, RY, 6 + UX, 6 + RY]  # dux/dz = ry
        K[np.ix_(ix, ix)] += kb
        iy = [UY, RX, 6 + UY, 6 + RX]  # duy/dz = -rx
        sgn = np.array([1, -1, 1, -1])
        K[np.ix_(iy, iy)] += kb * np.outer(sgn, sgn)
        m = self.density * area * L / 2  # half segment per end
        ip = m * r**2 / 2
        idia = m * (r**2 / 4 + (L / 2) ** 2 / 3)
        mdiag = np.array([m, m, m, idia, idia, ip] * 2)
        dofs = tuple((s, d) for s in (self.a, self.b) for d in range(6))
        G = np.zeros((12, 12))
        for off, st in ((0, sa), (6, sb)):
            G[off + RX, off + RY] = ip * st.spin
            G[off + RY, off + RX] = -ip * st.spin
        return [Element(dofs, M=np.diag(mdiag), K=K, D=self.damping_beta * K, G=G)]


@dataclass(frozen=True)
class Disk(Component):
    """Rigid disk (gear body, coupling half) on a station: mass [kg], polar and diametral inertia [kg m^2]."""

    station: str
    mass: float
    ip: float
    id: float

    def elements(self, stations):
        st = stations[self.station]
        if st.ndof == 1:
            return [Element(((self.station, RZ),), M=np.array([[self.ip]]))]
        dofs = tuple((self.station, d) for d in range(6))
        G = np.zeros((6, 6))
        G[RX, RY], G[RY, RX] = self.ip * st.spin, -self.ip * st.spin
        return [Element(dofs, M=np.diag([self.mass] * 3 + [self.id, self.id, self.ip]), G=G)]


@dataclass(frozen=True)
class BallBearing(Component):
    """Ball bearing on a station: radial and axial stiffness [N/m] to ground, damping ``beta k``."""

    station: str
    k_radial: float
    k_axial: float
    damping_beta: float = 2e-5

    def elements(self, stations):
        k = np.diag([self.k_radial, self.k_radial, self.k_axial])
        dofs = tuple((self.station, d) for d in (UX, UY, UZ))
        return [Element(dofs, K=k, D=self.damping_beta * k)]


@dataclass(frozen=True)
class NeedleBearing(Component):
    """Needle bearing: radial stiffness only [N/m]; axially free (seed ch. 5.2.2)."""

    station: str
    k_radial: float
    damping_beta: float = 2e-5

    def elements(self, stations):
        k = np.diag([self.k_radial, self.k_radial])
        dofs = tuple((self.station, d) for d in (UX, UY))
        return [Element(dofs, K=k, D=self.damping_beta * k)]


@dataclass(frozen=True)
class Clutch(Component):
    """Torsional coupling between the ``rz`` of two stations: stiffness [N m/rad], damping [N m s/rad]."""

    a: str
    b: str
    k_torsion: float
    c_torsion: float

    def elements(self, stations):
        s = np.array([[1.0, -1.0], [-1.0, 1.0]])
        return [Element(((self.a, RZ), (self.b, RZ)), K=self.k_torsion * s, D=self.c_torsion * s)]


@dataclass(frozen=True)
class Motor(Component):
    """Speed-controlled motor: rotor inertia [kg m^2], speed-loop gain ``c`` [N m s/rad] and optional
    integral gain ``k_i`` [N m/rad].

    The torque is ``T_ff + c (Omega - omega) + k_i integral(Omega - omega) dt`` (PI speed law,
    feed-forward ``T_ff`` = the nominal input torque): in deviation coordinates a damper and a spring
    to ground plus a constant load. With ``k_i = 0`` (P law) the nominal rotation is a free mode.
    """

    station: str
    inertia: float
    c_speed: float
    k_i: float = 0.0

    def elements(self, stations):
        return [Element(((self.station, RZ),), M=np.array([[self.inertia]]), D=np.array([[self.c_speed]]),
                        K=np.array([[self.k_i]]))]


@dataclass(frozen=True)
class Load(Component):
    """Brake rotor inertia [kg m^2]; the brake torque (N m, resisting) is applied by the model."""

    station: str
    inertia: float

    def elements(self, stations):
        return [Element(((self.station, RZ),), M=np.array([[self.inertia]]))]


@dataclass(frozen=True)
class Encoder:
    """Angle sensor at a shaft end.

    Parameters
    ----------
    name : str
        ``"in.sensor"``, ``"out.clutch"``... (shaft + side).
    station : str
        Station it reads (its ``rz``).
    radius : float
        Shaft radius at the sensor [m] (seed eqs. 39/40 scale node velocities by it).
    side : str
        ``"sensor"`` or ``"clutch"``.
    shaft : str
        ``"in"`` or ``"out"``.
    """

    name: str
    station: str
    radius: float
    side: str
    shaft: str
