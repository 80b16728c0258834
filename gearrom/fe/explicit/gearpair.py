"""A 2D (plane-strain Q4) spur gear pair for the explicit solver, and its transmission error.

Meshes: the quasi-static FE's triangle meshes (:func:`gearrom.fe.mesh2d.gear_mesh`) are split into
quadrilaterals (each triangle into three quads through its centroid and edge midpoints), so both
models share the same outline discretization (the explicit flank has twice the node density).

Set-up (gear frames as in :mod:`gearrom.fe.mesh2d`: tooth 0 on +y): the input gear sits at the
origin with tooth 0 turned onto +x, the output gear at (a_w, 0) with a tooth space facing it, then
turned counter-clockwise until its flank touches the input gear's leading (+y) flank, minus a small
clearance (no initial overclosure). The input gear turns counter-clockwise (positive speed) and
drives; the output turns clockwise and is loaded by a counter-clockwise (resisting) torque.

Transmission error on the line of action, positive when the output lags:
    TE = rb1 theta1 - rb2 theta2,   theta2 = clockwise rotation of the output gear,
measured from the rigid first-contact position of the model (reference angles zero).

Two starts: "gap" (both gears at speed, the flanks a small clearance apart, the output torque ramped
in) and "loaded" (the loaded static state of the same model at the start position, found by dynamic
relaxation, given the rigid-body speed of each gear and the full torque: no impact and no torque
transient, so that the run settles in a few time constants of its damping).
"""
from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gearrom.errors import ConfigError, MeshError
from gearrom.fe.explicit.driver import prepare, solve
from gearrom.fe.explicit.model import ContactPair, ExplicitModel, Material, RigidReference, boundary_segments
from gearrom.fe.explicit.result import ExplicitResult

log = logging.getLogger(__name__)

__all__ = ["GearPairSetup", "gear_pair_model", "loaded_model", "relaxed_state", "run_gear_pair", "stored_meshes",
           "start_state_key", "stored_start_state", "transmission_error", "triangles_to_quads"]


def triangles_to_quads(points: np.ndarray, triangles: np.ndarray):
    """Split each counter-clockwise triangle into three counter-clockwise quads.

    Returns (nodes, quads, edge_mid) where ``edge_mid`` maps a sorted original edge (a, b) to the
    index of its midpoint node.
    """
    tri = np.asarray(triangles, np.int64)
    pts = np.asarray(points, float)
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    uniq, inv = np.unique(edges, axis=0, return_inverse=True)
    inv = inv.ravel()
    n0 = pts.shape[0]
    mids = 0.5 * (pts[uniq[:, 0]] + pts[uniq[:, 1]])
    cents = pts[tri].mean(axis=1)
    nodes = np.vstack([pts, mids, cents])
    nt = tri.shape[0]
    m01, m12, m20 = (n0 + inv[:nt], n0 + inv[nt:2 * nt], n0 + inv[2 * nt:])
    g = n0 + uniq.shape[0] + np.arange(nt)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    quads = np.vstack([np.column_stack([a, m01, g, m20]), np.column_stack([b, m12, g, m01]),
                       np.column_stack([c, m20, g, m12])])
    edge_mid = {(int(p), int(q)): n0 + k for k, (p, q) in enumerate(uniq)}
    return nodes, quads, edge_mid


def _rotate(points: np.ndarray, angle: float) -> np.ndarray:
    """Rotate row-vector points counter-clockwise by ``angle`` (rad) about the origin."""
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


def _outer_loop(nodes: np.ndarray, segs: np.ndarray, bore: set) -> np.ndarray:
    """Outer boundary segments (bore edges removed)."""
    keep = np.array([not (int(a) in bore and int(b) in bore) for a, b in segs])
    return segs[keep]


@dataclass(frozen=True)
class GearPairSetup:
    """Operating point and model options of an explicit gear-pair run (SI units).

    Parameters
    ----------
    rpm_in : float
        Input speed, rev/min (input gear turns counter-clockwise).
    torque_out : float
        Resisting torque on the output gear, N m.
    ramp_time : float
        Speed ramp of the input reference from rest (s); 0 starts both gears at speed.
    torque_ramp_time : float
        Ramp of the output torque, s.
    mu : float
        Coulomb friction coefficient on the flanks.
    penalty_scale : float
        Contact penalty factor (see :class:`ContactPair`).
    clearance : float
        Initial gap on the line of action, m (no initial overclosure).
    inertia_in, inertia_out : float
        Extra lumped inertias on the input / output references, kg m^2 (drivetrain parts).
    mass_damping : float
        Mass-proportional damping, 1/s.
    integration : {"reduced", "full"}
        Element integration (see :class:`ExplicitModel`; "full": no hourglass energy).
    hourglass_stiffness, hourglass_viscosity : float
        Flanagan-Belytschko coefficients (one-point elements only).
    mass_scaling_dt : float
        Selective mass scaling target step, s (0: off); see :class:`ExplicitModel`.
    flanks : str
        "drive": contact only on the driving flank side of every tooth (the pair of the seed has
        zero design backlash, so with "both" the coast flanks touch too and the pair jams).
    relative_damping : float
        Mass-proportional damping on the velocity relative to each gear's rigid rotation, 1/s
        (:class:`ExplicitModel`); it damps the mesh vibration without braking the spin.
    start : {"gap", "loaded"}
        Initial state (module docstring); "loaded" ignores the speed and torque ramps.
    """

    rpm_in: float = 1250.0
    torque_out: float = 120.0
    ramp_time: float = 0.0
    torque_ramp_time: float = 0.2e-3
    mu: float = 0.0
    penalty_scale: float = 0.3
    clearance: float = 1e-6
    inertia_in: float = 0.0
    inertia_out: float = 0.0
    mass_damping: float = 0.0
    integration: str = "reduced"
    hourglass_stiffness: float = 0.05
    hourglass_viscosity: float = 0.02
    mass_scaling_dt: float = 0.0
    flanks: str = "drive"
    relative_damping: float = 0.0
    start: str = "gap"

    def __post_init__(self) -> None:
        if self.start not in ("gap", "loaded"):
            raise ConfigError(f"GearPairSetup.start must be 'gap' or 'loaded', got {self.start!r}")
        if not self.relative_damping >= 0:
            raise ConfigError(f"GearPairSetup.relative_damping must be >= 0 1/s, got {self.relative_damping}")
        if not self.rpm_in > 0:
            raise ConfigError(f"GearPairSetup.rpm_in must be > 0, got {self.rpm_in}")
        if self.flanks not in ("drive", "both"):
            raise ConfigError(f"GearPairSetup.flanks must be 'drive' or 'both', got {self.flanks!r}")
        if not self.clearance >= 0:
            raise ConfigError(f"GearPairSetup.clearance must be >= 0 m, got {self.clearance}")


def outline_order(segs: np.ndarray) -> np.ndarray:
    """Node indices of a closed boundary, in order, from its (start, end) segments.

    Raises
    ------
    MeshError
        The segments do not form one closed loop.
    """
    nxt = {int(a): int(b) for a, b in segs}
    start = int(segs[0, 0])
    order = [start]
    while True:
        k = nxt[order[-1]]
        if k == start:
            return np.array(order)
        order.append(k)
        if len(order) > len(segs):
            raise MeshError("gear outline is not a single closed loop")


def first_touch(overlap, lo: float, hi: float, iterations: int = 50) -> float:
    """Bisection of a bracket ``overlap(lo) is False``, ``overlap(hi) is True``: the largest rotation
    found without overlap (rad). The caller checks the bracket (its error message says why it fails)."""
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if overlap(mid):
            hi = mid
        else:
            lo = mid
    return lo


def _touch_angle(n1, loop1, n2, loop2, center2, hi: float) -> float:
    """Largest counter-clockwise turn of gear 2 (about ``center2``) without overlap, by bisection."""
    from matplotlib.path import Path

    def polygon(nodes, segs):
        return Path(nodes[outline_order(segs)])

    p1 = polygon(n1, loop1)
    b1 = np.unique(loop1)
    b2 = np.unique(loop2)
    zone = 4e-3
    near1 = b1[np.abs(n1[b1, 1]) < zone]
    near2 = b2[np.abs(n2[b2, 1]) < zone]

    def overlap(angle):
        q2 = center2 + _rotate(n2 - center2, angle)
        p2 = polygon(q2, loop2)
        return bool(p1.contains_points(q2[near2]).any() or p2.contains_points(n1[near1]).any())

    lo = 0.0
    if overlap(lo):
        raise MeshError("gears overlap in the start position: check the centre distance and tooth phasing")
    if not overlap(hi):
        raise MeshError("gears do not touch within half a pitch: check the centre distance")
    return first_touch(overlap, lo, hi)


def gear_pair_model(pair, meshes, setup: GearPairSetup, material: Material | None = None) -> tuple[ExplicitModel, dict]:
    """Build the explicit model of a spur pair from two gear meshes.

    ``meshes`` holds, per gear, either a quasi-static :class:`gearrom.fe.mesh2d.Mesh2D` (triangles,
    split into quads here) or a tuple (nodes, quads, bore_ids) such as
    :func:`gearrom.fe.explicit.gearmesh.gear_quad_mesh` returns, in the gear frame (tooth 0 on +y).

    Returns the model and a dict with ``rb`` (base radii), ``theta2_touch`` (the reference rotation of
    gear 2 at first contact, rad), ``omega_in`` (rad/s) and the node ranges of the two gears.
    """
    if pair.is_helical:
        raise ConfigError("gear_pair_model is 2D (spur pairs); helical pairs need the Hex8 model")
    g1, g2 = pair.gears
    if material is None:
        m = g1.material
        material = Material(E=m.youngs_modulus, nu=m.poisson_ratio, rho=m.density)
    width = min(g1.face_width, g2.face_width)
    parts = []
    for k, mesh in enumerate(meshes):
        if hasattr(mesh, "triangles"):          # a quasi-static Mesh2D: split into quads
            nodes, quads, mid = triangles_to_quads(mesh.points, mesh.triangles)
            bore = set(int(i) for i in mesh.bore_nodes)
            bore_q = set(bore)
            for (a, b), mnode in mid.items():
                if a in bore and b in bore:
                    bore_q.add(mnode)
        else:                                    # (nodes, quads, bore) e.g. from gear_quad_mesh
            nodes, quads, bore = (np.asarray(x) for x in mesh)
            bore_q = set(int(i) for i in bore)
        segs = boundary_segments(quads)
        outer = _outer_loop(nodes, segs, bore_q)
        contact = outer
        if setup.flanks == "drive":
            # drive side = left half of every tooth (x < 0 for tooth 0 on +y) for both gears
            mid_xy = nodes[outer].mean(axis=1)
            phi = np.mod(np.arctan2(mid_xy[:, 1], mid_xy[:, 0]) - math.pi / 2, 2 * math.pi / pair.z[k])
            contact = outer[phi < math.pi / pair.z[k]]
        parts.append((nodes, quads, np.array(sorted(bore_q)), outer, contact))
    (n1, q1, bore1, out1, c1), (n2, q2, bore2, out2, c2) = parts
    z2 = pair.z[1]
    n1 = _rotate(n1, -math.pi / 2)                    # tooth 0 from +y to +x
    center2 = np.array([pair.aw, 0.0])
    n2 = center2 + _rotate(n2, math.pi / 2 + math.pi / z2)     # a tooth space faces gear 1
    touch = _touch_angle(n1, out1, n2, out2, center2, math.pi / z2)
    rb1, rb2 = pair.rb
    start = touch - setup.clearance / rb2
    n2 = center2 + _rotate(n2 - center2, start)
    off = n1.shape[0]
    nodes = np.vstack([n1, n2])
    elements = np.vstack([q1, q2 + off])
    omega1 = setup.rpm_in * 2 * math.pi / 60
    omega2 = -omega1 * pair.z[0] / pair.z[1]
    at_speed = setup.ramp_time <= 0
    v0 = None
    if at_speed:
        v0 = np.zeros_like(nodes)
        v0[:off] = omega1 * np.column_stack([-nodes[:off, 1], nodes[:off, 0]])
        r2 = nodes[off:] - center2
        v0[off:] = omega2 * np.column_stack([-r2[:, 1], r2[:, 0]])
    refs = (
        RigidReference("bore_1", speed=omega1, ramp_time=max(setup.ramp_time, 0.0), inertia=setup.inertia_in,
                       center=(0.0, 0.0)),
        RigidReference("bore_2", torque=setup.torque_out, torque_ramp_time=setup.torque_ramp_time,
                       inertia=setup.inertia_out, omega0=omega2 if at_speed else 0.0,
                       center=(float(center2[0]), float(center2[1]))),
    )
    contacts = (
        ContactPair("flank_1", "outline_2", mu=setup.mu, penalty_scale=setup.penalty_scale),
        ContactPair("flank_2", "outline_1", mu=setup.mu, penalty_scale=setup.penalty_scale),
    )
    model = ExplicitModel(
        nodes, elements, material, thickness=width,
        node_sets={"bore_1": bore1, "bore_2": bore2 + off, "flank_1": np.unique(c1),
                   "flank_2": np.unique(c2) + off},
        surfaces={"outline_1": c1, "outline_2": c2 + off},
        references=refs, contacts=contacts, initial_velocity=v0, mass_damping=setup.mass_damping,
        relative_damping=setup.relative_damping,
        integration=setup.integration, hourglass_stiffness=setup.hourglass_stiffness,
        hourglass_viscosity=setup.hourglass_viscosity,
        mass_scaling_dt=setup.mass_scaling_dt)
    info = dict(rb=(rb1, rb2), clearance_angle=setup.clearance / rb2, omega_in=omega1, omega_out=omega2,
                n_gear1=off, flank_spacing_m=float(np.median(np.linalg.norm(n1[out1[:, 1]] - n1[out1[:, 0]], axis=1))))
    return model, info


def transmission_error(result: ExplicitResult, rb: tuple[float, float], clearance_angle: float = 0.0) -> np.ndarray:
    """TE on the line of action (m), positive when the output lags: rb1 theta1 - rb2 theta2_cw.

    The reference angles are zero in the model's start position (rigid first contact less the
    clearance); ``clearance_angle`` (rad) is that initial output-gear clearance, removed so that TE = 0
    at rigid first contact.
    """
    return rb[0] * result.theta[:, 0] + rb[1] * (result.theta[:, 1] - clearance_angle)


def relaxed_state(model: ExplicitModel, torque: float, *, alpha: float = 4.0e4, t_end: float = 0.45e-3,
                  ramp: float = 0.2e-3, window: float = 0.1e-3, mass_scaling_dt: float = 2.5e-8):
    """Loaded static state of a gear-pair ``model`` at its start position, by dynamic relaxation.

    The input gear is held, the output torque ramps to ``torque`` over ``ramp``; absolute mass damping
    ``alpha`` (about half critical at the mesh mode) removes the vibration and selective mass scaling
    lifts the step (neither changes a static equilibrium).

    Returns
    -------
    u : ndarray (n, 2)
        Nodal displacements, m.
    theta : ndarray (2,)
        Reference rotations, rad.
    residual_ptp : float
        Peak-to-peak of rb-weighted output rotation over the last ``window`` (residual vibration), rad.
    """
    r1, r2 = model.references
    relax = dataclasses.replace(
        model, references=(dataclasses.replace(r1, speed=0.0, ramp_time=0.0, theta0=0.0),
                           dataclasses.replace(r2, torque=torque, torque_ramp_time=ramp, omega0=0.0, theta0=0.0)),
        initial_velocity=None, initial_displacement=None, mass_damping=alpha, relative_damping=0.0,
        mass_scaling_dt=mass_scaling_dt)
    res = solve(relax, t_end, 5e-6, parallel=False, chunks=4)
    w = res.t >= t_end - window
    return res.u_final, res.theta[-1].copy(), float(np.ptp(res.theta[w, 1]))


def loaded_model(model: ExplicitModel, info: dict, setup: GearPairSetup, relaxed=None) -> ExplicitModel:
    """``model`` started from its loaded static state with rigid-body speeds and the full torque.

    ``relaxed`` is :func:`relaxed_state`'s output for ``model`` (computed when omitted), or ``(u, theta,
    0.0)`` of a direct static solve (3D models: :meth:`gearrom.fe.explicit.static3d.StaticPair3D.loaded_state`).
    Every node gets the velocity of its gear's rigid rotation about the gear axis at its deformed position.
    """
    u, theta, _ = relaxed if relaxed is not None else relaxed_state(model, setup.torque_out)
    off = info.get("n_nodes_gear1", info["n_gear1"])   # 3D (helical) models count the extruded nodes
    r1, r2 = model.references
    c2 = np.asarray(r2.center, float)
    x = model.nodes + u
    v = np.zeros_like(x)
    v[:off, :2] = info["omega_in"] * np.column_stack([-x[:off, 1], x[:off, 0]])
    p2 = x[off:, :2] - c2
    v[off:, :2] = info["omega_out"] * np.column_stack([-p2[:, 1], p2[:, 0]])
    refs = (dataclasses.replace(r1, speed=info["omega_in"], ramp_time=0.0, theta0=float(theta[0])),
            dataclasses.replace(r2, torque=setup.torque_out, torque_ramp_time=0.0, omega0=info["omega_out"],
                                theta0=float(theta[1])))
    return dataclasses.replace(model, references=refs, initial_displacement=u, initial_velocity=v)


def polar_inertias(model: ExplicitModel, mass: np.ndarray, off: int) -> tuple[float, float]:
    """Polar inertia [kg m^2] of each gear's nodes about its axis with the nodal masses a run used (selective
    mass scaling included; ``off``: the input's node count), plus the extra inertia of its reference."""
    xy = np.asarray(model.nodes, float)[:, :2]
    c2 = np.asarray(model.references[1].center, float)[:2]
    j1 = float(np.sum(mass[:off] * np.sum(xy[:off] ** 2, axis=1)))
    j2 = float(np.sum(mass[off:] * np.sum((xy[off:] - c2) ** 2, axis=1)))
    return j1 + float(model.references[0].inertia), j2 + float(model.references[1].inertia)


def start_state_key(model) -> str:
    """What a stored start state was solved for: the model's mesh and placement (nodes, elements) and the
    revision of the contact rule of its dimension (:data:`gearrom.fe.explicit.contact.CONTACT_REVISION`)."""
    import hashlib

    from gearrom.fe.explicit.contact import CONTACT_REVISION

    h = hashlib.sha1()
    for a in (np.ascontiguousarray(model.nodes, float), np.ascontiguousarray(model.elements, np.int64)):
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    h.update(CONTACT_REVISION[model.nodes.shape[1]].encode())
    return h.hexdigest()


def stored_start_state(checkpoint, suffix: str, value_key: str, shape, torque: float, compute, key: str = ""):
    """A run's start state ``(u, theta, value)``, kept next to its checkpoint as ``<checkpoint><suffix>``.

    A stored state is reused when its displacement shape, torque and ``key`` (:func:`start_state_key`: the
    model and contact rule it was solved with) match the run; otherwise ``compute()`` makes it and, with a
    checkpoint, it is stored (atomically; ``value`` under ``value_key``).
    """
    store = None if checkpoint is None else Path(str(checkpoint) + suffix)
    if store is not None and store.is_file():
        with np.load(store) as z:
            stored_key = str(z["key"]) if "key" in z else ""
            if z["u"].shape == shape and float(z["torque"]) == torque and stored_key == key:
                return z["u"].copy(), z["theta"].copy(), float(z[value_key])
        log.info("%s was solved for another model or contact rule: solved again", store)
    state = compute()
    if store is not None:
        from gearrom.fe.cache import atomic_path

        with atomic_path(store) as tmp:
            np.savez(tmp, u=state[0], theta=state[1], torque=torque, key=np.array(key), **{value_key: state[2]})
    return state


def stored_meshes(path: str | Path, key: str, build) -> list:
    """The gear meshes ``[(nodes, quads, bore), ...]`` kept in ``path`` (npz) under ``key``.

    A long run resumed on another machine or with another gmsh build must rebuild its model bit for bit,
    and gmsh's quad meshes are not reproducible across builds (nor always between processes): the
    meshes of a checkpointed run are therefore stored once and read back. ``key`` names what the
    meshes were made from (the pair and the mesh settings); a stored file of another key is replaced by
    ``build()``'s meshes (logged), a missing one is written (atomically).
    """
    path = Path(path)
    if path.is_file():
        try:
            with np.load(path) as z:
                if str(z["key"]) == key:
                    n = int(z["n_gears"])
                    return [(z[f"nodes{i}"].copy(), z[f"quads{i}"].copy(), z[f"bore{i}"].copy()) for i in range(n)]
                log.warning("%s holds meshes of other settings (key %s, wanted %s): rebuilt and replaced", path,
                            str(z["key"]), key)
        except (OSError, KeyError, ValueError) as exc:
            raise ConfigError(f"stored meshes {path} cannot be read ({exc}); delete the file to rebuild them") from None
    meshes = build()
    from gearrom.fe.cache import atomic_path

    arrays = {}
    for i, (nodes, quads, bore) in enumerate(meshes):
        arrays.update({f"nodes{i}": np.asarray(nodes), f"quads{i}": np.asarray(quads), f"bore{i}": np.asarray(bore)})
    with atomic_path(path) as tmp:
        np.savez_compressed(tmp, key=np.array(key), n_gears=np.array(len(meshes)), **arrays)
    return [tuple(np.asarray(a) for a in m) for m in meshes]


def run_gear_pair(pair, meshes, setup: GearPairSetup, t_end: float, sample_period: float,
                  **solve_kw) -> tuple[ExplicitResult, np.ndarray, dict]:
    """Build and run the pair; return (result, TE history in m, info).

    ``solve_kw`` go to :func:`solve` (checkpoint, wall_limit, parallel...). With a checkpoint and the
    "loaded" start, the relaxed state is stored next to it (``<checkpoint>.relaxed.npz``) and reused.
    """
    model, info = gear_pair_model(pair, meshes, setup)
    if setup.start == "loaded":
        relaxed = stored_start_state(solve_kw.get("checkpoint"), ".relaxed.npz", "ptp", model.nodes.shape,
                                     setup.torque_out, lambda: relaxed_state(model, setup.torque_out),
                                     key=start_state_key(model))
        log.info("loaded start: static TE %.3f um, residual %.2e rad",
                 (info["rb"][0] * relaxed[1][0] + info["rb"][1] * (relaxed[1][1] - info["clearance_angle"])) * 1e6,
                 relaxed[2])
        model = loaded_model(model, info, setup, relaxed)
    d = prepare(model, solve_kw.pop("safety", 0.9))
    res = solve(model, t_end, sample_period, prepared=d, **solve_kw)
    te = transmission_error(res, info["rb"], info["clearance_angle"])
    j1, j2 = polar_inertias(model, d["mass"], info["n_gear1"])
    res.meta.update(rpm_in=setup.rpm_in, torque_out_Nm=setup.torque_out, mu=setup.mu, start=setup.start,
                    flank_spacing_m=info["flank_spacing_m"], penalty_scale=setup.penalty_scale,
                    inertia_in_kgm2=j1, inertia_out_kgm2=j2)
    return res, te, info
