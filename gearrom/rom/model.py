"""The assembled lumped drivetrain: stations, components, mesh; linear matrices and the static preload.

Coordinates are deviations from the nominal rigid rotation (``rz`` of input stations turns at
``Omega``, output stations at ``-Omega z1/z2``), so the linear part is time invariant and the static
preload is a plain linear solve. The rig layout (:func:`build_rig`) comes from the ``[rig]`` and
``[rom]`` config sections (see ``gearrom/data/configs/thesis-rig.toml`` for every parameter).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from gearrom.errors import ModelError
from gearrom.excitation.table import MeshExcitation
from gearrom.geometry.pair import GearPair
from gearrom.rom.components import RZ, Component, Disk, Encoder, Station
from gearrom.rom.mesh import line_of_action


@dataclass(frozen=True)
class MeshSpec:
    """Mesh element parameters: gear stations, damping ratio, backlash (transverse LOA) [m], and
    whether the mesh force follows the table's force-deflection map over its torques
    (``load_dependent``; a one-torque table always gives the secant law)."""

    gear_stations: tuple[str, str]
    damping_ratio: float = 0.05
    backlash: float = 50e-6
    load_dependent: bool = True


@dataclass(eq=False)
class Drivetrain:
    """A lumped drivetrain model.

    Parameters
    ----------
    name : str
        Model name (config name).
    pair : GearPair
        The gear pair.
    stations : tuple of Station
        All nodes.
    components : tuple of Component
        Shafts, disks, bearings, clutches, motor, load.
    mesh : MeshSpec
        Mesh element parameters.
    excitation : MeshExcitation
        Mesh stiffness / STE table.
    encoders : tuple of Encoder
        Angle sensors (sensor and clutch side of each shaft).
    motor_station, load_station : str
        Rotor stations of the motor and of the brake.
    cutoff_frequency : float
        Modes kept by the reduced time-domain model [Hz].
    max_step : float
        Largest time step [s].
    min_mesh_share : float
        The reduced model drops modes whose mesh strain-energy share is below this [-].
    metadata : dict
        Provenance (config name, digest).
    """

    name: str
    pair: GearPair
    stations: tuple[Station, ...]
    components: tuple[Component, ...]
    mesh: MeshSpec
    excitation: MeshExcitation
    encoders: tuple[Encoder, ...] = ()
    motor_station: str | None = None
    load_station: str | None = None
    cutoff_frequency: float = 12e3
    max_step: float = 1e-5
    metadata: dict = field(default_factory=dict)
    min_mesh_share: float = 0.0
    _memo: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        names = [s.name for s in self.stations]
        if len(set(names)) != len(names):
            raise ModelError(f"duplicate station names in model {self.name!r}: {names}")
        self.station = {s.name: s for s in self.stations}
        for ref in (*self.mesh.gear_stations, self.motor_station, self.load_station, *(e.station for e in self.encoders)):
            if ref is not None and ref not in self.station:
                raise ModelError(f"model {self.name!r}: unknown station {ref!r} (known: {', '.join(names)})")
        self.offset, n = {}, 0
        for s in self.stations:
            self.offset[s.name] = n
            n += s.ndof
        self.ndof = n

    # ------------------------------------------------------------- indexing
    def index(self, station: str, dof: int) -> int:
        """Global index of ``dof`` (UX..RZ) of ``station``."""
        st = self.station[station]
        return self.offset[station] + st.local(dof)

    def dof_labels(self) -> list[str]:
        labels = []
        names = ("ux", "uy", "uz", "rx", "ry", "rz")
        for s in self.stations:
            labels += [f"{s.name}.rz"] if s.ndof == 1 else [f"{s.name}.{d}" for d in names]
        return labels

    # ------------------------------------------------------------- matrices
    @cached_property
    def structure(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(M, K, D, G)`` of everything but the mesh; ``G`` per unit input speed [rad/s]."""
        n = self.ndof
        mats = {k: np.zeros((n, n)) for k in "MKDG"}
        for comp in self.components:
            for el in comp.elements(self.station):
                idx = [self.index(s, d) for s, d in el.dofs]
                for key in "MKDG":
                    m = getattr(el, key)
                    if m is not None:
                        mats[key][np.ix_(idx, idx)] += m
        if np.any(np.diag(mats["M"]) <= 0):
            bad = [lab for lab, v in zip(self.dof_labels(), np.diag(mats["M"])) if v <= 0]
            raise ModelError(f"model {self.name!r}: DOFs without mass: {', '.join(bad)}")
        return mats["M"], mats["K"], mats["D"], mats["G"]

    @cached_property
    def w(self) -> np.ndarray:
        """Transverse mesh vector: ``delta_t = w . q`` [m per coordinate unit]."""
        w1, w2, _ = line_of_action(self.pair)
        w = np.zeros(self.ndof)
        for st_name, wi in zip(self.mesh.gear_stations, (w1, w2)):
            st = self.station[st_name]
            if st.ndof == 1:
                w[self.index(st_name, RZ)] += wi[5]
            else:
                w[self.offset[st_name]:self.offset[st_name] + 6] += wi
        return w

    @cached_property
    def rigid_mode(self) -> np.ndarray:
        """Nominal rigid rotation per unit input angle (rz of every station = its spin ratio)."""
        r = np.zeros(self.ndof)
        for s in self.stations:
            r[self.index(s.name, RZ)] = s.spin
        return r

    @cached_property
    def free_rotation(self) -> bool:
        """True when the nominal rotation is a zero-stiffness mode (speed loop without an angle term)."""
        _, K, _, _ = self.structure
        return bool(np.abs(K @ self.rigid_mode).max() <= 1e-9 * np.abs(K).max())

    def gauge(self, A: np.ndarray) -> np.ndarray:
        """``A`` plus a penalty on the nominal-rotation component when that mode is free (else ``A``)."""
        if not self.free_rotation:
            return A
        M = self.structure[0]
        mr = M @ self.rigid_mode
        return A + (np.trace(A) / max(float(mr @ mr), 1e-30)) * np.outer(mr, mr)

    def mesh_mass(self) -> float:
        """Equivalent mesh mass ``1 / (rb1^2/J1 + rb2^2/J2)`` [kg] from the gear disks."""
        J = []
        for st_name in self.mesh.gear_stations:
            j = sum(c.ip for c in self.components if isinstance(c, Disk) and c.station == st_name)
            if j <= 0:
                raise ModelError(f"model {self.name!r}: no gear Disk on station {st_name!r}")
            J.append(j)
        rb1, rb2 = self.pair.rb
        return 1.0 / (rb1**2 / J[0] + rb2**2 / J[1])

    def force_map(self, torque_out: float, n: int = 512):
        """:class:`~gearrom.rom.mesh.ForceMap` of the excitation table for a run at ``torque_out``
        [N m] (``n`` angles per mesh period)."""
        from gearrom.rom.mesh import ForceMap

        return self.memo(("force_map", float(torque_out), n),
                         lambda: ForceMap.from_table(self.excitation, self.pair.rb[1], torque_out, n))

    def memo(self, key: tuple, make: Callable[[], Any]) -> Any:
        """``make()``, computed once per ``key`` for this model: quantities that depend on the model
        and a few scalars only (a built model is not changed), such as the sampled mesh table at a
        torque, reused by every speed of a sweep."""
        if key not in self._memo:
            self._memo[key] = make()
        return self._memo[key]

    def mesh_stiffness(self, torque: float) -> float:
        """Mean mesh stiffness of the linear models at output ``torque`` [N/m]: the tangent of the
        force-deflection map at the static loaded state when the table has a torque map and the law
        is load-dependent, else the table's secant stiffness."""
        if self.mesh.load_dependent and self.excitation.n_torque > 1:
            return float(np.mean(self.force_map(torque).tangent(self.nominal_force(torque))))
        return self.excitation.mean_stiffness(torque)

    def mesh_damping(self, torque: float) -> float:
        """Mesh damping ``c = 2 zeta sqrt(k_mean m_eq)`` [N s/m] (``k_mean``: :meth:`mesh_stiffness`)."""
        return 2 * self.mesh.damping_ratio * math.sqrt(self.mesh_stiffness(torque) * self.mesh_mass())

    def nominal_force(self, torque_out: float) -> float:
        """Transverse line-of-action force ``T_out / rb2`` [N]."""
        return torque_out / self.pair.rb[1]

    def loads(self, torque_out: float) -> np.ndarray:
        """Constant generalized forces: motor feed-forward and brake torque (balanced on the rigid mode)."""
        f = np.zeros(self.ndof)
        rb1, rb2 = self.pair.rb
        if self.load_station is not None:
            f[self.index(self.load_station, RZ)] += torque_out  # resists output rotation (about -z)
        elif torque_out:
            f[self.index(self.mesh.gear_stations[1], RZ)] += torque_out
        if self.motor_station is not None:
            f[self.index(self.motor_station, RZ)] += torque_out * rb1 / rb2
        else:
            f[self.index(self.mesh.gear_stations[0], RZ)] += torque_out * rb1 / rb2
        return f

    def linear(self, rpm_in: float, torque_out: float, k_mesh: float | None = None):
        """``(M, K, D)`` linearised at the mean mesh stiffness (or ``k_mesh``), gyroscopic terms at ``rpm_in``."""
        M, K, D, G = self.structure
        k = self.mesh_stiffness(torque_out) if k_mesh is None else k_mesh
        c = self.mesh_damping(torque_out)
        ww = np.outer(self.w, self.w)
        omega = rpm_in * 2 * math.pi / 60
        return M, K + k * ww, D + c * ww + omega * G

    def static_state(self, torque_out: float, k: float, e: float) -> np.ndarray:
        """Static deflection with mesh stiffness ``k`` and STE ``e`` (rigid-mode component zero)."""
        M, K, _, _ = self.structure
        f_nom = self.nominal_force(torque_out)
        A = K + k * np.outer(self.w, self.w)
        rhs = self.loads(torque_out) - self.w * (f_nom - k * e)
        return np.linalg.solve(self.gauge(A), rhs)
