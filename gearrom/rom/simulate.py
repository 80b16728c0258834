"""Time-domain run of the drivetrain in exudyn: :func:`simulate_run`.

The exudyn system holds (see :mod:`gearrom.rom.reduce`)

* one ``NodeGenericODE2`` with the reduced coordinates ``y`` and one ``ObjectGenericODE2`` with the
  constant reduced mass, stiffness, damping (+ gyroscopic at the run's speed) and the constant loads
  (motor feed-forward, brake torque);
* the mesh: :class:`gearrom.rom.meshstep.MeshStepper`, a limit-stop coordinate spring on ``delta_t``
  whose stiffness and stop position a pre-step function sets once per step from the mesh law
  (secant, or load-dependent along the FE force-deflection map); mesh angles from the nominal
  rotation (the angular deviation, < 1e-4 of a mesh period, is neglected in the phase). Holding the
  parameters over a step (their step averages) makes the scheme second order in ``h``;
* an optional ``LoadCoordinate`` for brake torque ripple on the retained brake coordinate.

Explicit RK44 with a fixed step ``h = min(max_step, 2.2/rho, T_mesh/32)``, ``rho`` being the spectral
radius of the reduced first-order system at the largest mesh stiffness, shortened so that it divides
the output sample period (sensors sample on steps, without jitter). The run starts from the static preload plus the
linear periodic response (:func:`gearrom.rom.reduce.periodic_initial_state`), settles, then records.
"""
from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np

from gearrom.config import GearConfig
from gearrom.errors import ModelError
from gearrom.rom.components import RZ
from gearrom.rom.mesh import Effects, MeshLaw
from gearrom.rom.meshstep import MeshStepper, reduced_system, solve_rk44
from gearrom.rom.model import Drivetrain
from gearrom.rom.reduce import periodic_initial_state, reduce
from gearrom.rom.result import DynamicRun

log = logging.getLogger(__name__)


def _as_model(config_or_model, torque: float | None) -> Drivetrain:
    if isinstance(config_or_model, Drivetrain):
        return config_or_model
    from gearrom.rom.rig import build_rig

    if isinstance(config_or_model, (str, Path, GearConfig)):
        return build_rig(config_or_model, torque_out=torque)
    raise ModelError(f"simulate_run needs a Drivetrain, GearConfig, bundled name or path, got {type(config_or_model)!r}")


def mesh_law(model: Drivetrain, torque_out: float, effects: Effects | None = None, n: int = 512) -> MeshLaw:
    """The mesh law of ``model`` at ``torque_out`` [N m], sampled on ``n`` points per mesh period:
    load-dependent (:class:`~gearrom.rom.mesh.ForceMap` of the table's torque map) when the table
    has several torques and ``model.mesh.load_dependent``, else the secant law at ``torque_out``."""
    th, k, e = model.memo(("sampled", float(torque_out), n), lambda: model.excitation.sampled(torque_out, n))
    fmap = model.force_map(torque_out, n) if model.mesh.load_dependent and model.excitation.n_torque > 1 else None
    return MeshLaw(model.pair, th, k, e, model.nominal_force(torque_out), effects or Effects(), fmap)


def simulate_run(config_or_model, rpm_in: float, torque_out_Nm: float | None = None, *,
                 duration_s: float | None = None, n_output_revs: float | None = None,
                 effects: Effects | None = None, sample_rate_hz: float | None = None,
                 settle_s: float | None = None, step_s: float | None = None, cutoff_Hz: float | None = None,
                 theta0: float = 0.0) -> DynamicRun:
    """Simulate a steady-state run and return the encoder angles, DTE, mesh deflection and force.

    Parameters
    ----------
    config_or_model : Drivetrain or GearConfig or str or Path
        A model, a loaded config, a bundled config name or a TOML path (built with
        :func:`gearrom.rom.rig.build_rig`).
    rpm_in : float
        Input speed [rpm] (> 0).
    torque_out_Nm : float, optional
        Load torque [N m] (default: the model's/config's operating torque).
    duration_s, n_output_revs : float, optional
        Recorded length, as time [s] or output revolutions (default 2 output revolutions).
    effects : Effects, optional
        Runout, pitch deviations, extra TE, load ripple. Default: the runout and pitch deviations of
        the config's *enabled* gear micro-geometry (:meth:`Effects.from_pair`); ``Effects()`` for none.
    sample_rate_hz : float, optional
        Output sample rate (default: 64 samples per mesh period).
    settle_s : float, optional
        Simulated time discarded before recording (default 5 mesh periods, within [5, 20] ms; the
        periodic initial state leaves little to settle).
    step_s : float, optional
        Fixed step [s] (default from the stiffest kept mode, see module docstring).
    cutoff_Hz : float, optional
        Mode cutoff of the reduced model (default ``model.cutoff_frequency``; ``inf`` keeps all).
    theta0 : float
        Input-gear angle at ``t = 0`` [rad].

    Returns
    -------
    DynamicRun

    Raises
    ------
    ModelError
        Bad arguments.
    SolverError
        The integration diverged.
    """
    import exudyn as exu
    from exudyn.itemInterface import MarkerNodeCoordinate, SensorMarker

    if not (rpm_in > 0 and math.isfinite(rpm_in)):
        raise ModelError(f"rpm_in must be positive, got {rpm_in!r}")
    model = _as_model(config_or_model, torque_out_Nm)
    torque = float(model.metadata.get("torque_out_Nm", 120.0) if torque_out_Nm is None else torque_out_Nm)
    if not torque > 0:
        raise ModelError(f"torque_out_Nm must be positive, got {torque!r}")
    effects = Effects.from_pair(model.pair) if effects is None else effects
    z1, z2 = model.pair.z
    omega = rpm_in * 2 * math.pi / 60
    omega2 = omega * z1 / z2
    t_mesh = 2 * math.pi / (z1 * omega)
    if duration_s is None:
        duration_s = (2.0 if n_output_revs is None else float(n_output_revs)) * 2 * math.pi / omega2
    if not duration_s > 0:
        raise ModelError(f"duration must be positive, got {duration_s!r}")
    settle = min(max(5 * t_mesh, 0.005), 0.02) if settle_s is None else float(settle_s)
    fs = 64 / t_mesh if sample_rate_hz is None else float(sample_rate_hz)

    law = mesh_law(model, torque, effects)
    red = reduce(model, rpm_in, torque, cutoff_Hz, retain_brake=bool(effects.load_ripple))
    h = min(model.max_step, 2.2 / red.omega_max, t_mesh / 32) if step_s is None else float(step_s)
    # the step divides the output sample period exactly (sensors sample on steps: no jitter)
    n_sub = int(math.ceil((1.0 / fs) / h - 1e-9))
    h = 1.0 / (fs * n_sub)
    settle = math.ceil(settle * fs - 1e-9) / fs
    t_end = settle + math.ceil(duration_s * fs - 1e-9) / fs
    n_steps = int(round(t_end / h))
    c_mesh = model.mesh_damping(torque)
    backlash = model.mesh.backlash
    # the non-periodic error terms at t = 0 are taken up in the static preload
    e_offset = law.evaluate(theta0, theta0 * z1 / z2)[1] - law.base(theta0)[1]
    y0, v0 = periodic_initial_state(red, model, rpm_in, torque, law.k_grid, law.e_grid, theta0, e_offset=e_offset)

    SC, mbs, node, _, sens = reduced_system(red, y0, v0)
    m_brake = None
    if effects.load_ripple:
        m_brake = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=red.i_brake))

    def angles(tm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return theta0 + omega * tm, theta0 * z1 / z2 + omega2 * tm

    # a whole number of steps per mesh period and no slower effect: the mesh parameters repeat
    per_mesh = fs * t_mesh * n_sub
    period = int(round(per_mesh)) if effects.empty and abs(per_mesh - round(per_mesh)) < 1e-6 else None
    mesh = MeshStepper(mbs, node, red.i_delta, law, c_mesh, backlash, h, n_steps, angles, m_brake, period)
    m_delta = mesh.marker
    mbs.SetPreStepUserFunction(mesh.pre_step)
    sens_v = mbs.AddSensor(SensorMarker(markerNumber=m_delta, outputVariableType=exu.OutputVariableType.Coordinates_t,
                                        storeInternal=True, writeToFile=False))
    raw, wall, cpu = solve_rk44(mbs, sens, n_steps, t_end, fs, f"time integration at {rpm_in} rpm")
    sel = (raw[:, 0] >= settle - 0.5 / fs) & (raw[:, 0] < t_end - 0.5 / fs)
    tt, yy = raw[sel, 0], raw[sel, 1:]
    vv = mbs.GetSensorStoredData(sens_v)[sel, 1]
    # the pre-step closure holds the system and the system holds the closure: a cycle through C++
    # objects that Python's collector cannot see; clearing the container frees the run's memory
    mbs.SetPreStepUserFunction(0)
    SC.Reset()
    return _postprocess(model, red, law, yy, vv, tt, settle, rpm_in, torque, theta0, {
        "config": model.metadata.get("config", model.name), "config_digest": model.metadata.get("config_digest", ""),
        "z1": z1, "z2": z2, "step_s": h, "n_steps": n_steps, "modes_kept": int(red.freqs.size),
        "cutoff_Hz": float(red.freqs.max()), "settle_s": settle, "wall_s": wall, "cpu_s": cpu, "simulated_s": t_end,
        "excitation": model.excitation.metadata.get("source", ""), "effects": repr(effects) if not effects.empty else "",
    })


def _postprocess(model, red, law, yy, vv, tt, settle, rpm_in, torque, theta0, meta) -> DynamicRun:
    z1, z2 = model.pair.z
    omega = rpm_in * 2 * math.pi / 60
    omega2 = omega * z1 / z2
    t = tt - settle
    rows = [model.index(e.station, RZ) for e in model.encoders]
    x = red.to_physical(yy, np.array(rows, dtype=int)) if rows else np.zeros((len(tt), 0))
    th1 = theta0 + omega * tt
    th2 = theta0 * z1 / z2 + omega2 * tt
    theta = []
    for j, e in enumerate(model.encoders):
        theta.append(th1 + x[:, j] if e.shaft == "in" else th2 - x[:, j])
    rb1, rb2 = model.pair.rb
    dte = {}
    for side in ("sensor", "clutch"):
        ei = [j for j, e in enumerate(model.encoders) if e.side == side and e.shaft == "in"]
        eo = [j for j, e in enumerate(model.encoders) if e.side == side and e.shaft == "out"]
        if ei and eo:
            dte[side] = rb1 * x[:, ei[0]] + rb2 * x[:, eo[0]]
    delta = yy[:, red.i_delta]
    k, e = law.evaluate_array(th1, th2)
    e0 = e - law.f_nom / k
    lower = float(np.mean(law.e_grid - law.f_nom / law.k_grid)) - model.mesh.backlash
    # mesh force at the sample instants (exact mesh angles; the solver holds k, e0 at each step's midpoint)
    c = model.mesh_damping(torque)
    ddelta = np.asarray(vv, dtype=float)
    if law.load_dependent:
        knots, scale = law.knots_array(th1, th2)
        e0 = knots[:, 0]
        k = scale * (law.force_map.f[1] / (knots[:, 1] - knots[:, 0]))  # back-flank stop: the first segment
        elastic = law.force_map.force(knots, delta, scale)
        force = np.where(delta > e0, elastic + c * ddelta,
                         np.where(delta < lower, k * (delta - lower) + c * ddelta, 0.0))
    else:
        force = np.where(delta > e0, k * (delta - e0) + c * ddelta,
                         np.where(delta < lower, k * (delta - lower) + c * ddelta, 0.0))
    # 1: drive flanks loaded; 0: separated or the (viscous) contact force turned tensile; -1: back flanks
    state = np.where(delta < lower, -1, np.where(force > 0, 1, 0)).astype(np.int8)
    return DynamicRun(
        time=t, encoders=tuple(e.name for e in model.encoders),
        encoder_radius=np.array([e.radius for e in model.encoders]), theta=np.array(theta), dte=dte,
        delta=delta, force=force, ste=e, rpm_in=float(rpm_in), torque_out=float(torque), f_nom=float(law.f_nom),
        radii={"rb1": rb1, "rb2": rb2, "r1": 0.5 * model.pair.d[0], "r2": 0.5 * model.pair.d[1]}, metadata=meta,
        contact_state=state,
    )
