"""Quasi-static solves of the explicit FE gear pair at fixed input angles (dynamic relaxation).

The explicit solver of :mod:`gearrom.fe.explicit` has no static mode; a static equilibrium of its
model (same Q4 meshes, penalty contact, hourglass control) is reached here by *dynamic relaxation*:
the input gear is held (a prescribed speed of ``1e-4`` rpm, i.e. at rest), the output torque is ramped
in, mass-proportional damping (``alpha`` ~ the mesh mode's circular frequency: about half critical)
removes the vibration, and selective mass scaling lifts the stable step as in the 60 rpm run (neither
changes the static equilibrium). The TE is averaged over the last ``settle_window`` and reported in
the convention of the explicit FE runs (``TE = 0`` at rigid first contact in the start position,
:func:`gearrom.fe.explicit.gearpair.transmission_error`), so that it can be compared point by point
with the slow (60 rpm) explicit run and with the mesh tables.

Placing the pair at input angle ``theta``: the model of :func:`gear_pair_model` (start position) is
rotated rigidly, the input by ``theta`` about its centre, the output by ``-theta z1/z2`` about its
centre and then turned until its drive flanks first touch the input's (bisection on the overlap of
the outline polygons, drive-flank nodes only: the pair has zero design backlash) less the FE's
initial clearance. The rigid turn ``rb2 a* - clearance`` is the TE of the rigid faceted outlines at
``theta`` and is added to the solve's TE.
"""
from __future__ import annotations

import dataclasses
import logging
import math
import time

import numpy as np

from gearrom.errors import MeshError

log = logging.getLogger(__name__)

__all__ = ["StaticPoint", "static_pair_model", "static_te"]


def _rot(p: np.ndarray, c: np.ndarray, a: float) -> np.ndarray:
    cs, sn = math.cos(a), math.sin(a)
    q = p - c
    return c + np.column_stack([cs * q[:, 0] - sn * q[:, 1], sn * q[:, 0] + cs * q[:, 1]])


@dataclasses.dataclass(frozen=True)
class StaticPoint:
    """One quasi-static explicit solve.

    Attributes
    ----------
    theta_in : float
        Input angle from the FE start position, rad.
    te : float
        Static TE in the FE runs' convention, m.
    rigid_te : float
        Rigid TE of the faceted outlines at ``theta_in`` (first touch of the drive flanks), m.
    settle_ptp : float
        Peak-to-peak TE over the averaging window (residual vibration), m.
    wall_s : float
        Wall time of the solve, s.
    meta : dict
        Solver settings and counts.
    """

    theta_in: float
    te: float
    rigid_te: float
    settle_ptp: float
    wall_s: float
    meta: dict = dataclasses.field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready (units in the keys)."""
        return {"theta_in_rad": self.theta_in, "te_um": self.te * 1e6, "rigid_te_um": self.rigid_te * 1e6,
                "settle_ptp_um": self.settle_ptp * 1e6, "wall_s": self.wall_s, **self.meta}


def static_pair_model(pair, meshes, theta_in: float, setup, search: float = 50e-6, zone: float = 10e-3):
    """The explicit model of ``pair`` placed at input angle ``theta_in`` [rad] with the FE's clearance.

    Parameters
    ----------
    pair : GearPair
    meshes : sequence of two (nodes, quads, bore)
        :func:`gearrom.fe.explicit.gearmesh.gear_quad_mesh` of both gears.
    theta_in : float
        Input rotation (counter-clockwise) from the FE start position, rad.
    setup : GearPairSetup
    search : float
        Bisection bracket of the output's rigid turn, +- m on the line of action.
    zone : float
        Only outline nodes within this distance of the pitch point are tested for overlap, m.

    Returns
    -------
    (ExplicitModel, info dict of :func:`gear_pair_model`, rigid TE [m])
    """
    from matplotlib.path import Path

    from gearrom.fe.explicit.gearpair import first_touch, gear_pair_model, outline_order
    from gearrom.fe.explicit.model import boundary_segments

    model, info = gear_pair_model(pair, meshes, setup)
    x = np.asarray(model.nodes, float)
    off = info["n_gear1"]
    c2 = np.array([pair.aw, 0.0])
    rb2 = pair.rb[1]
    z1, z2 = pair.z
    segs = boundary_segments(np.asarray(model.elements))
    bore = set(int(i) for i in model.node_sets["bore_1"]) | set(int(i) for i in model.node_sets["bore_2"])
    outer = np.array([s for s in segs if not (int(s[0]) in bore and int(s[1]) in bore)])
    loop1 = outline_order(outer[(outer < off).all(axis=1)])
    loop2 = outline_order(outer[(outer >= off).all(axis=1)]) - off
    x1 = _rot(x[:off], np.zeros(2), theta_in)
    x2 = _rot(x[off:], c2, -theta_in * z1 / z2)
    pitch = np.array([pair.aw * pair.rb[0] / (pair.rb[0] + rb2), 0.0])
    f1 = np.asarray(model.node_sets["flank_1"])
    f2 = np.asarray(model.node_sets["flank_2"]) - off
    poly1 = Path(x1[loop1])
    near1 = x1[f1][np.hypot(*(x1[f1] - pitch).T) < zone]

    def overlap(angle: float) -> bool:
        q = _rot(x2, c2, angle)
        near2 = q[f2][np.hypot(*(q[f2] - pitch).T) < zone]
        return bool(poly1.contains_points(near2).any() or Path(q[loop2]).contains_points(near1).any())

    hi = search / rb2
    if overlap(-hi) or not overlap(hi):
        raise MeshError(f"static_pair_model: drive flanks not bracketed within +-{search * 1e6:g} um at "
                        f"input angle {theta_in:.6g} rad")
    a_star = first_touch(overlap, -hi, hi)
    nodes = np.vstack([x1, _rot(x2, c2, a_star - setup.clearance / rb2)])
    return dataclasses.replace(model, nodes=nodes, initial_velocity=None), info, rb2 * a_star - setup.clearance


def static_te(pair, meshes, theta_in: float, torque: float = 120.0, alpha: float = 4.0e4, ramp: float = 0.2e-3,
              t_end: float = 0.45e-3, settle_window: float = 0.1e-3, mass_scaling_dt: float = 2.5e-8,
              **setup_kw) -> StaticPoint:
    """Static TE of the explicit FE model at input angle ``theta_in`` [rad] under ``torque`` [N m].

    Parameters
    ----------
    pair, meshes
        As :func:`static_pair_model`.
    theta_in : float
        Input angle from the FE start position, rad.
    torque : float
        Output resisting torque, N m.
    alpha : float
        Mass-proportional damping, 1/s (4e4: about half critical at the ~6.5 kHz mesh mode).
    ramp, t_end, settle_window : float
        Torque ramp, run end and averaging window at the end, s.
    mass_scaling_dt : float
        Selective mass scaling target step, s (as the 60 rpm run).
    **setup_kw
        Further :class:`GearPairSetup` fields (element formulation, hourglass control).
    """
    from gearrom.fe.explicit.driver import solve
    from gearrom.fe.explicit.gearpair import GearPairSetup, transmission_error

    setup = GearPairSetup(rpm_in=1e-4, torque_out=torque, torque_ramp_time=ramp, mu=0.0,
                          mass_scaling_dt=mass_scaling_dt, mass_damping=alpha, **setup_kw)
    model, info, rigid = static_pair_model(pair, meshes, theta_in, setup)
    t0 = time.perf_counter()
    res = solve(model, t_end, 5e-6, parallel=False)
    wall = time.perf_counter() - t0
    te = transmission_error(res, info["rb"], info["clearance_angle"])
    w = res.t >= t_end - settle_window
    point = StaticPoint(theta_in=float(theta_in), te=float(te[w].mean()) + rigid, rigid_te=float(rigid),
                        settle_ptp=float(np.ptp(te[w])), wall_s=wall,
                        meta={"torque_Nm": torque, "mass_damping_per_s": alpha, "ramp_s": ramp, "t_end_s": t_end,
                              "settle_window_s": settle_window, "mass_scaling_dt_s": mass_scaling_dt,
                              "dt_s": res.meta["dt_s"], "n_steps": res.meta["n_steps"],
                              "added_mass_kg": res.meta["added_mass_kg"],
                              "hourglass_ratio": float(res.hourglass_ratio), **setup_kw})
    log.info("static explicit solve at %.5f rad: TE %.3f um (rigid %.3f um, residual ptp %.3f um), %.0f s",
             theta_in, point.te * 1e6, rigid * 1e6, point.settle_ptp * 1e6, wall)
    return point
