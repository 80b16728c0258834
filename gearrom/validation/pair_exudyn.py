"""The explicit FE's gear-pair system as an exudyn :class:`~gearrom.rom.model.Drivetrain` (second method).

:mod:`gearrom.validation.pair_rom` integrates the system of the explicit FE run (input gear at a
prescribed speed, free output gear of inertia ``J2`` loaded by a resisting torque, the mesh law of
:mod:`gearrom.rom.mesh`) with its own 1-DOF RK4/numba code. This module describes the *same* system
with the components of the project's drivetrain ROM (:mod:`gearrom.rom`) and runs it through
:func:`gearrom.rom.simulate.simulate_run` (modal reduction, exudyn ``ObjectGenericODE2`` plus a
coordinate spring-damper with limit stops for the mesh, exudyn RK44), so that the two models share
only the mesh table and the operating point:

* two 1-DOF (``rz``) stations ``in.gear`` and ``out.gear``: no lateral, axial or tilting DOFs (rigid
  bearings, as the FE's rigid bore references); the mesh vector of a 1-DOF station is
  ``(rb1, rb2)``, i.e. ``delta_t = rb1 rz1 + rb2 rz2 = rb1 theta1 - rb2 theta2`` (``rz2 = -theta2``,
  the output turns about -z): the TE of the pair ROM, positive when the output lags;
* output gear: :class:`~gearrom.rom.components.Disk` with the polar inertia ``J2`` only
  (``setup.inertia_out``); the resisting torque ``T_out`` is applied on it (no brake station);
* input gear: a flywheel :class:`~gearrom.rom.components.Disk` of ``J1 = input_inertia_ratio *
  J2 rb1^2 / rb2^2`` plus a PI speed loop (:class:`~gearrom.rom.components.Motor` on the same station,
  feed-forward ``T_out rb1 / rb2``, crossover ``speed_loop_hz``, far below the mesh frequency). The
  input's share of the mesh compliance is ``1 / (1 + input_inertia_ratio)`` (1e-6 by default): the
  input angle is prescribed to that accuracy (its deviation is reported in the metadata);
* mesh: the same :class:`~gearrom.excitation.table.MeshExcitation`, drive flank only (backlash
  ``backlash``, 1 mm by default, so the back-flank stop is never reached, as in the FE and the pair
  ROM) and a damping ratio chosen so that the mesh damping ``c = 2 zeta sqrt(k_mean m_eq)`` equals the
  pair ROM's exactly (``m_eq = J2 / rb2^2`` there, ``1 / (rb1^2/J1 + rb2^2/J2)`` in the Drivetrain);
* mesh phase: ``simulate_run``'s ``theta0`` is the table phase of the FE start position
  (:func:`~gearrom.validation.pair_rom.fe_start_mesh_phase`), so ``theta_in = Omega t`` is the input
  angle from the FE origin in both models.

Differences to :func:`~gearrom.validation.pair_rom.simulate_pair_rom` (besides the integrator):
``simulate_run`` starts from the static preload plus the linear periodic response at the mean mesh
stiffness with the full output torque (no torque ramp: ``setup.torque_ramp_time`` is not used), so
the start transients differ and the models are to be compared in steady state only. Both modes of
the 2-DOF model are kept (``cutoff_Hz = inf``): no modal truncation.

Timing: exudyn (1.13) passes the *end* time of the coming step to the pre-step function;
``simulate_run`` indexes its step-averaged ``k`` and ``e0`` accordingly (this cross-check found the
one-step lead it had before: a phase lead of ``m z1 Omega h`` at mesh order ``m``).
"""
from __future__ import annotations

import logging
import math

import numpy as np

from gearrom.errors import ModelError
from gearrom.rom.components import Disk, Encoder, Motor, Station
from gearrom.rom.mesh import Effects, ExtraTE
from gearrom.rom.model import Drivetrain, MeshSpec
from gearrom.validation.pair_rom import PairRomResult, PairRomSetup, fe_start_mesh_phase

log = logging.getLogger(__name__)

__all__ = ["body_drivetrain", "mesh_mode", "pair_drivetrain", "simulate_pair_exudyn"]


def _check_positive(where: str, **values: float) -> None:
    """ModelError naming the first of ``values`` that is not a positive finite number."""
    for key, val in values.items():
        if not (val > 0 and math.isfinite(val)):
            raise ModelError(f"{where}: {key} must be a positive finite number, got {val!r}")


def pair_drivetrain(pair, excitation, setup: PairRomSetup, *, input_inertia_ratio: float = 1e6,
                    speed_loop_hz: float = 50.0, backlash: float = 1e-3, max_step: float = 2e-6,
                    name: str = "explicit-fe-pair", bodies: tuple | None = None) -> Drivetrain:
    """The explicit FE's gear-pair system (the pair ROM's) as a :class:`~gearrom.rom.model.Drivetrain`.

    Parameters
    ----------
    pair : GearPair
        The gear pair.
    excitation : MeshExcitation
        Mesh table (evaluated at ``setup.torque_out``).
    setup : PairRomSetup
        Operating point: ``torque_out`` [N m], ``inertia_out`` ``J2`` [kg m^2], ``damping_ratio`` [-];
        ``rpm_in`` is given to :func:`simulate_pair_exudyn` (the Drivetrain is speed independent).
    input_inertia_ratio : float
        ``J1 rb2^2 / (J2 rb1^2)`` [-]: the input flywheel relative to the output gear on the line of
        action. Its inverse is the input's share of the mesh-mode compliance (how far the input speed
        is from prescribed at mesh frequencies).
    speed_loop_hz : float
        Crossover of the PI speed loop of the input [Hz] (keeps the mean speed and angle; well below
        the mesh frequency so that it does not load the mesh dynamics).
    backlash : float
        Backlash along the transverse line of action [m] (large: drive flank only, as in the FE).
    max_step : float
        Largest time step of :func:`~gearrom.rom.simulate.simulate_run` [s].
    name : str
        Model name.
    bodies : (GearBody, GearBody), optional
        Flexible gear bodies (:mod:`gearrom.fe.bodies`, input and output; the output's inertia is taken as
        ``setup.inertia_out``): :func:`body_drivetrain`.

    Returns
    -------
    Drivetrain
        Stations ``in.gear`` and ``out.gear`` (``rz`` only), encoders ``in.sensor`` / ``out.sensor`` on
        them (radius ``rb``), ``metadata["torque_out_Nm"] = setup.torque_out``.

    Raises
    ------
    ModelError
        Non-positive ``input_inertia_ratio``, ``speed_loop_hz``, ``backlash`` or ``max_step``.
    """
    _check_positive("pair_drivetrain", input_inertia_ratio=input_inertia_ratio, speed_loop_hz=speed_loop_hz,
                    backlash=backlash, max_step=max_step)
    if bodies is not None:
        return body_drivetrain(pair, excitation, setup, bodies, input_inertia_ratio=input_inertia_ratio,
                               speed_loop_hz=speed_loop_hz, backlash=backlash, max_step=max_step, name=name)
    rb1, rb2 = pair.rb
    z1, z2 = pair.z
    j2 = float(setup.inertia_out)
    j1 = float(input_inertia_ratio) * j2 * rb1**2 / rb2**2
    meq_pair = j2 / rb2**2                              # the pair ROM's m_eq (prescribed input)
    meq_model = 1.0 / (rb1**2 / j1 + rb2**2 / j2)       # Drivetrain.mesh_mass()
    zeta = float(setup.damping_ratio) * math.sqrt(meq_pair / meq_model)   # same c [N s/m] as the pair ROM
    wc = 2 * math.pi * float(speed_loop_hz)
    stations = (Station("in.gear", "in", 0.0, 1, 1.0), Station("out.gear", "out", 0.0, 1, -z1 / z2))
    components = (Disk("in.gear", 0.0, j1, 0.0), Disk("out.gear", 0.0, j2, 0.0),
                  Motor("in.gear", 0.0, c_speed=2 * 0.7 * j1 * wc, k_i=j1 * wc**2))
    encoders = (Encoder("in.sensor", "in.gear", rb1, "sensor", "in"),
                Encoder("out.sensor", "out.gear", rb2, "sensor", "out"))
    return Drivetrain(
        name=name, pair=pair, stations=stations, components=components,
        mesh=MeshSpec(("in.gear", "out.gear"), zeta, float(backlash)), excitation=excitation, encoders=encoders,
        motor_station="in.gear", load_station=None, cutoff_frequency=math.inf, max_step=float(max_step),
        metadata={"config": name, "torque_out_Nm": float(setup.torque_out), "input_inertia_kgm2": j1,
                  "inertia_out_kgm2": j2, "speed_loop_hz": float(speed_loop_hz)})


def body_drivetrain(pair, excitation, setup: PairRomSetup, bodies: tuple, *, input_inertia_ratio: float = 1e6,
                    speed_loop_hz: float = 50.0, backlash: float = 1e-3, max_step: float = 2e-6,
                    name: str = "explicit-fe-pair-bodies") -> Drivetrain:
    """The pair system of :func:`pair_drivetrain` with flexible gear bodies (:mod:`gearrom.fe.bodies`).

    Each gear is a hub (``in.hub`` / ``out.hub``: the FE's bore reference) and a rim (``in.gear`` /
    ``out.gear``: the mesh acts on it) joined by the body's torsional spring (a
    :class:`~gearrom.rom.components.Clutch`): the input hub carries the flywheel and the speed loop, the output
    hub the rest of the output inertia ``setup.inertia_out`` and the resisting torque. The mesh table loses
    both bodies' compliance (:func:`gearrom.fe.bodies.without_body_compliance`), so the static TE between the
    hubs is the table's. Encoders: ``sensor`` side on the hubs (the TE the FE measures), ``clutch`` side on the
    rims. Each body spring has a dashpot of ``setup.damping_ratio`` at its own mode, and the mesh dashpot is
    set so that the mesh mode of the linearised model has the ratio ``setup.damping_ratio``.
    """
    from gearrom.fe.bodies import without_body_compliance
    from gearrom.rom.components import Clutch

    _check_positive("body_drivetrain", input_inertia_ratio=input_inertia_ratio, speed_loop_hz=speed_loop_hz,
                    backlash=backlash, max_step=max_step)
    b1, b2 = bodies[0], bodies[1].with_inertia(float(setup.inertia_out))
    rb1, rb2 = pair.rb
    z1, z2 = pair.z
    zeta = float(setup.damping_ratio)
    j1 = float(input_inertia_ratio) * b2.inertia * rb1**2 / rb2**2
    wc = 2 * math.pi * float(speed_loop_hz)
    spin2 = -z1 / z2
    stations = (Station("in.hub", "in", 0.0, 1, 1.0), Station("in.gear", "in", 0.0, 1, 1.0),
                Station("out.gear", "out", 0.0, 1, spin2), Station("out.hub", "out", 0.0, 1, spin2))

    def springs(z):
        return tuple(Clutch(a, b, body.stiffness, 2 * z * math.sqrt(body.stiffness * body.rim_inertia))
                     for a, b, body in (("in.hub", "in.gear", b1), ("out.gear", "out.hub", b2)))

    masses = (Disk("in.hub", 0.0, j1 + b1.hub_inertia, 0.0), Disk("in.gear", 0.0, b1.rim_inertia, 0.0),
              Disk("out.gear", 0.0, b2.rim_inertia, 0.0), Disk("out.hub", 0.0, b2.hub_inertia, 0.0),
              Motor("in.hub", 0.0, c_speed=2 * 0.7 * j1 * wc, k_i=j1 * wc**2))
    encoders = (Encoder("in.sensor", "in.hub", rb1, "sensor", "in"),
                Encoder("out.sensor", "out.hub", rb2, "sensor", "out"),
                Encoder("in.rim", "in.gear", rb1, "clutch", "in"), Encoder("out.rim", "out.gear", rb2, "clutch", "out"))
    table = without_body_compliance(excitation, (b1, b2), pair.rb)

    def build(mesh_zeta):
        return Drivetrain(
            name=name, pair=pair, stations=stations, components=masses + springs(zeta),
            mesh=MeshSpec(("in.gear", "out.gear"), mesh_zeta, float(backlash)), excitation=table, encoders=encoders,
            motor_station="in.hub", load_station="out.hub", cutoff_frequency=math.inf, max_step=float(max_step),
            metadata={"config": name, "torque_out_Nm": float(setup.torque_out), "input_inertia_kgm2": j1,
                      "inertia_out_kgm2": b2.inertia, "speed_loop_hz": float(speed_loop_hz), "bodies": True,
                      "body_frequency_Hz": (b1.frequency, b2.frequency),
                      "rim_inertia_kgm2": (b1.rim_inertia, b2.rim_inertia),
                      "body_stiffness_Nm_per_rad": (b1.stiffness, b2.stiffness)})

    # the mesh mode's damping ratio is affine in the mesh dashpot (light damping): two trial models give the
    # dashpot of the target ratio
    r0, f_mode = mesh_mode(build(0.0), setup.torque_out)
    r1, _ = mesh_mode(build(max(zeta, 1e-3)), setup.torque_out)
    mesh_zeta = max(zeta, 1e-3) * (zeta - r0) / (r1 - r0) if r1 != r0 else zeta
    model = build(max(mesh_zeta, 0.0))
    ratio, f_mode = mesh_mode(model, setup.torque_out)
    model.metadata.update(mesh_mode_Hz=f_mode, mesh_mode_damping_ratio=ratio, mesh_damping_ratio_parameter=mesh_zeta)
    return model


def mesh_mode(model: Drivetrain, torque_out: float) -> tuple[float, float]:
    """Damping ratio [-] and frequency [Hz] of the mode of ``model`` linearised at ``torque_out`` [N m] with the
    largest mesh deflection per unit modal energy (the mesh mode)."""
    from scipy.linalg import eig

    M, K, D = model.linear(0.0, torque_out)
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, D)]])
    lam, vec = eig(A)
    osc = np.flatnonzero(lam.imag > 1.0)
    x = vec[:n, osc]
    energy = np.real(np.einsum("ij,ij->j", x.conj(), K @ x))
    share = np.abs(model.w @ x) ** 2 * model.mesh_stiffness(torque_out) / np.maximum(energy, 1e-300)
    j = osc[int(np.argmax(share))]
    return float(-lam[j].real / abs(lam[j])), float(abs(lam[j]) / (2 * math.pi))


def simulate_pair_exudyn(pair, excitation, setup: PairRomSetup, t_end: float, sample_period: float, *,
                         phase0: float | None = None, step: float | None = None,
                         kinematic: tuple[float, np.ndarray] | None = None,
                         model: Drivetrain | None = None) -> PairRomResult:
    """Run the pair system as an exudyn Drivetrain (:func:`pair_drivetrain` through ``simulate_run``).

    The result has the layout of :func:`~gearrom.validation.pair_rom.simulate_pair_rom`'s: samples at
    ``0, sample_period, ...`` up to ``t_end`` [s] (the last sample may be dropped), ``theta_in = Omega t``
    [rad] (input angle from the FE origin), ``te = rb1 theta1 - rb2 theta2`` [m] (the mesh coordinate
    ``delta_t`` of the model; positive when the output lags) and the mesh ``force`` [N]. The run starts
    from the static preload plus the linear periodic response (full torque at t = 0, no ramp): compare
    with the pair ROM in steady state only (:func:`~gearrom.validation.compare.steady_window`).

    Parameters
    ----------
    pair : GearPair
        The gear pair.
    excitation : MeshExcitation
        Mesh table; evaluated at ``setup.torque_out``.
    setup : PairRomSetup
        Operating point (``torque_ramp_time`` unused; ``dt``, when > 0, is the step unless ``step`` is given).
    t_end, sample_period : float
        End time and output sampling period [s].
    phase0 : float, optional
        Table mesh phase at t = 0 [rad]; default :func:`~gearrom.validation.pair_rom.fe_start_mesh_phase`.
    step : float, optional
        Fixed exudyn RK44 step [s], shortened to divide ``sample_period``; default ``setup.dt`` or else
        ``model.max_step`` (2 us).
    kinematic : (step, values), optional
        Extra kinematic TE [m] at input angles ``0, step, 2 step...`` [rad] from the FE origin (linear,
        held beyond the end), added to ``e`` as in the pair ROM (an :class:`~gearrom.rom.mesh.ExtraTE`).
    model : Drivetrain, optional
        A model from :func:`pair_drivetrain` (default: built with its defaults).

    Returns
    -------
    PairRomResult
        ``meta`` holds the exudyn run data (step, modes, wall time) and ``input_deviation_max_m``: the
        largest ``rb1 |theta1 - Omega t|`` (how well the input speed is prescribed).

    Raises
    ------
    ModelError
        Bad arguments.
    SolverError
        The integration diverged.
    """
    from gearrom.rom.simulate import simulate_run

    if not (t_end > 0 and sample_period > 0):
        raise ModelError(f"t_end and sample_period must be > 0 s, got {t_end}, {sample_period}")
    if not t_end >= 8 * sample_period:
        raise ModelError(f"t_end = {t_end} s holds fewer than 8 samples of {sample_period} s")
    model = pair_drivetrain(pair, excitation, setup) if model is None else model
    phi0 = fe_start_mesh_phase(pair) if phase0 is None else float(phase0)
    effects = Effects()
    kin_ptp = 0.0
    if kinematic is not None:
        kin_step, kin = float(kinematic[0]), np.asarray(kinematic[1], float)
        if not kin_step > 0 or kin.ndim != 1 or kin.size < 2:
            raise ModelError("kinematic TE needs a step > 0 rad and at least 2 values")
        grid = np.arange(kin.size) * kin_step
        kin_ptp = float(np.ptp(kin))
        # theta1 of the mesh law is the absolute input angle phi0 + Omega t; np.interp holds the end values
        effects = Effects(extra=(ExtraTE(lambda th1, th2: np.interp(np.asarray(th1) - phi0, grid, kin),
                                         "kinematic TE (pair ROM)"),))
    if step is None and setup.dt > 0:
        step = setup.dt
    # simulate_run records [settle, settle + duration); settle = 0 records from t = 0 like the pair ROM
    duration = (math.floor(t_end / sample_period + 1e-9) + 1) * sample_period
    run = simulate_run(model, setup.rpm_in, setup.torque_out, duration_s=duration, effects=effects,
                       sample_rate_hz=1.0 / sample_period, settle_s=0.0, step_s=step, cutoff_Hz=math.inf,
                       theta0=phi0)
    om = setup.rpm_in * 2 * math.pi / 60
    t = run.time
    keep = t <= t_end * (1 + 1e-12)
    t = t[keep]
    rb1 = pair.rb[0]
    j_in = run.encoders.index("in.sensor")
    dev = rb1 * (run.theta[j_in][keep] - (phi0 + om * t))
    te = run.delta[keep]
    if model.metadata.get("bodies"):        # the TE between the hubs (the FE's bore references)
        te = te + (run.dte["sensor"] - run.dte["clutch"])[keep]
    meta = {"model": "exudyn Drivetrain (in.gear flywheel + PI speed loop, out.gear J2 only, 1-DOF stations), "
                     "modal reduction without truncation, exudyn RK44 (gearrom.rom.simulate.simulate_run)",
            "rpm_in": setup.rpm_in, "torque_out_Nm": setup.torque_out, "inertia_out_kgm2": setup.inertia_out,
            "damping_ratio": setup.damping_ratio, "damping_Ns_per_m": model.mesh_damping(setup.torque_out),
            "mesh_frequency_Hz": om * pair.z[0] / (2 * math.pi), "phase0_rad": phi0,
            "k_mean_N_per_m": model.excitation.mean_stiffness(setup.torque_out),
            "input_inertia_kgm2": model.metadata.get("input_inertia_kgm2"),
            "input_deviation_max_m": float(np.max(np.abs(dev))) if dev.size else 0.0,
            "kinematic_te_ptp_m": kin_ptp, "dt_s": run.metadata["step_s"],
            "excitation_definition": excitation.definition,
            **{k: run.metadata[k] for k in ("n_steps", "modes_kept", "wall_s", "cpu_s", "simulated_s")}}
    log.info("exudyn pair model: %d steps of %.3g s in %.2f s wall", meta["n_steps"], meta["dt_s"], meta["wall_s"])
    for key in ("body_frequency_Hz", "rim_inertia_kgm2", "body_stiffness_Nm_per_rad", "mesh_mode_Hz",
                "mesh_mode_damping_ratio", "mesh_damping_ratio_parameter"):
        if key in model.metadata:
            meta[key] = model.metadata[key]
    if model.metadata.get("bodies"):
        meta["model"] = meta["model"].replace("out.gear J2 only", "gear bodies as rim on hub (gearrom.fe.bodies)")
    return PairRomResult(t=t, theta_in=om * t, te=te, force=run.force[keep], meta=meta)
