"""Synthetic measurements with injected (undeclared) effects: simulator + encoder emulation + file.

For tests, benchmarks and the notebook. The effects are written here from their physical
definitions, independently of the diagnosis' own effect models:

* gear eccentricity: kinematic error ``e cos(theta_gear + phi)`` along the line of action;
* a displaced tooth: its deviation times its share of the contact-line length
  (:func:`contact_length_window`), not the load-share window the diagnosis uses;
* encoder eccentricity: an angle error ``(e / r_b) cos(theta + phi)`` of that channel only,
  applied to the simulated angle before the encoder emulation;
* micro-geometry: absolute flank modifications of the simulated pair;
* rig parameters and load-torque ripple: passed to the simulator.

The angle histories then go through :func:`gearrom.signal.emulate_edges` (edges per revolution,
counter clock quantization, timing jitter, line-spacing errors) and
:func:`gearrom.signal.write_measurement` (kind ``edges``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gearrom.excitation.slices import MicroMods
from gearrom.calibrate.simulator import ModelChanges, RunConditions
from gearrom.signal import emulate_edges, write_measurement

N_TAB = 4096


@dataclass(frozen=True)
class Injected:
    """Effects put into synthetic data (sizes in um, angles in deg; TE-equivalent on the line of action).

    Attributes
    ----------
    eccentricity : dict
        ``{"input_gear"|"output_gear": (amplitude_um, phase_deg)}``.
    pitch : dict
        ``{"input_gear"|"output_gear": (tooth_index, deviation_um)}``.
    encoder : dict
        ``{"input_encoder"|"output_encoder": (amplitude_um, phase_deg)}``.
    micro : MicroMods or None
        Absolute flank modifications of the pair.
    rig_scale : tuple
        ``(("k_shaft_in", 0.7),)`` etc.
    load_ripple : tuple or None
        ``(relative amplitude, order of the output shaft, phase_rad)``.
    """

    eccentricity: dict = field(default_factory=dict)
    pitch: dict = field(default_factory=dict)
    encoder: dict = field(default_factory=dict)
    micro: MicroMods | None = None
    rig_scale: tuple = ()
    load_ripple: tuple | None = None


def contact_length_window(pair, z: int, tooth: int) -> np.ndarray:
    """Share of the load on one tooth over a revolution, from its contact-line length alone.

    A helical tooth's contact line grows linearly while it enters the face (``eps_beta`` mesh
    periods), stays, and shrinks while it leaves: a trapezoid of ``eps_alpha + eps_beta`` periods.
    The share is its length over the sum of all teeth's lengths (independent of the diagnosis,
    which uses the load share of the stiffness model).
    """
    u = np.arange(N_TAB) / N_TAB * z  # position in mesh periods
    ea, eb = pair.eps_alpha, max(pair.eps_beta, 1e-3)
    lo = min(ea, eb)

    def trap(x):
        x = np.mod(x, z)
        return np.clip(np.minimum(np.minimum(x, lo), np.minimum(ea + eb - x, lo)), 0.0, None) * (x < ea + eb)

    total = sum(trap(u - j) for j in range(z))
    return trap(u - tooth) / total


def kinematic_tables(inj: Injected, pair, gear: str) -> np.ndarray | None:
    """Kinematic error [m] of the injected effects of one gear (``"input_gear"``/``"output_gear"``)
    over one revolution of it, on ``N_TAB`` points (None: no effect on that gear)."""
    th = np.arange(N_TAB) * 2 * math.pi / N_TAB
    tab = np.zeros(N_TAB)
    used = False
    if gear in inj.eccentricity:
        a, ph = inj.eccentricity[gear]
        tab += a * 1e-6 * np.cos(th + math.radians(ph))
        used = True
    if gear in inj.pitch:
        k, dev = inj.pitch[gear]
        z = pair.z[0 if gear == "input_gear" else 1]
        win = contact_length_window(pair, z, k)
        tab += dev * 1e-6 * (win - win.mean())
        used = True
    return tab if used else None


def make_run(path_json: str | Path, config: str, rpm_in: float, *, simulator, torque_out_Nm: float = 120.0,
             revs_out: float = 2.0, injected: Injected | None = None, edges_per_rev: int = 40000,
             clock_hz: float = 80e6, jitter_s: float = 2e-9, line_error_rad: float | None = 2e-7,
             rpm_meta: float | None = None, seed: int = 0) -> Path:
    """Simulate a run with injected effects, emulate the encoders and write a measurement file.

    Parameters
    ----------
    path_json : str or Path
        Measurement JSON to write (the CSV goes next to it).
    config : str
        Gear configuration name (written into the file).
    rpm_in : float
        Input speed simulated, rpm.
    simulator : Simulator
        The "rig" that produces the data (may differ from the model the diagnosis uses).
    torque_out_Nm, revs_out : float
        Load and record length in output revolutions.
    injected : Injected
    edges_per_rev, clock_hz, jitter_s, line_error_rad
        Encoder emulation (40000 edges/rev, 80 MHz counter, 2 ns jitter, 0.2 urad line errors).
    rpm_meta : float, optional
        ``rpm_in`` written to the metadata (to test a wrong nominal speed); default the true one.
    seed : int

    Returns
    -------
    Path
    """
    inj = injected or Injected()
    pair = simulator.pair
    ratio = pair.z[0] / pair.z[1]
    f_out = rpm_in / 60 * ratio
    dur = revs_out / f_out + 4e-3
    ch = ModelChanges(kinematic_in=kinematic_tables(inj, pair, "input_gear"), kinematic_out=kinematic_tables(inj, pair, "output_gear"),
                      micro=inj.micro, rig_scale=tuple(inj.rig_scale), load_ripple=inj.load_ripple)
    h = simulator.simulate(RunConditions(rpm_in, torque_out_Nm, dur), ch)
    th1, th2 = h.theta_in_rad.copy(), h.theta_out_rad.copy()
    rb1, rb2 = pair.rb
    if "input_encoder" in inj.encoder:
        a, ph = inj.encoder["input_encoder"]
        th1 = th1 + a * 1e-6 / rb1 * np.cos(th1 + math.radians(ph))
    if "output_encoder" in inj.encoder:
        a, ph = inj.encoder["output_encoder"]
        th2 = th2 - a * 1e-6 / rb2 * np.cos(th2 + math.radians(ph))
    rec = emulate_edges(h.t_s, th1, th2, edges_per_rev=edges_per_rev, clock_hz=clock_hz, jitter_s=jitter_s,
                        line_error_rad=line_error_rad, rng=seed)
    return write_measurement(path_json, rec, rpm_in=rpm_meta or rpm_in, torque_out_Nm=torque_out_Nm, config=config,
                             description=f"synthetic run ({getattr(simulator, 'name', 'simulator')}), effects {inj}")


# ---------------------------------------------------------------- data made by the exudyn ROM
@dataclass(frozen=True)
class RomInjected:
    """Effects put into ROM-made data with the ROM's *own* effect models (:mod:`gearrom.rom.mesh`).

    Attributes
    ----------
    runout, pitch, load_ripple : tuple
        :class:`gearrom.rom.Runout` (eccentricity with centre-distance modulation of the mesh),
        :class:`gearrom.rom.PitchDeviations`, :class:`gearrom.rom.LoadRipple` (N m, output order).
    encoder : dict
        ``{"input_encoder"|"output_encoder": (amplitude_um, phase_rad)}``: angle error of that disc,
        ``(a / r_b) cos(theta_disc + phase)`` in the *absolute* disc angle, as a TE equivalent.
    overrides : dict
        Rig parameter changes (:func:`gearrom.rom.with_overrides` keys), e.g. the clutch stiffness.
    mesh_stiffness : float
        Factor on the stiffness of the ROM's mesh table.
    micro : MicroMods or None
        Flank modifications (change of the ROM's nominal table by the micro-geometry model).
    """

    runout: tuple = ()
    pitch: tuple = ()
    load_ripple: tuple = ()
    encoder: dict = field(default_factory=dict)
    overrides: dict = field(default_factory=dict)
    mesh_stiffness: float = 1.0
    micro: MicroMods | None = None


def rom_model(config: str, torque_out_Nm: float, inj: RomInjected, micro_model=None):
    """The ROM drivetrain of ``config`` with the rig/mesh changes of ``inj`` (for :func:`make_rom_run`)."""
    import dataclasses

    from gearrom.calibrate.microfe import FEMicroModel, with_micro
    from gearrom.config import as_config
    from gearrom.rom import build_rig, with_overrides
    from gearrom.rom.rig import load_excitation, rom_section

    cfg = with_overrides(config, dict(inj.overrides)) if inj.overrides else config
    ex = None
    if inj.micro is not None or inj.mesh_stiffness != 1.0:
        loaded = as_config(config)
        ex = load_excitation(loaded, rom_section(loaded), torque_out_Nm)
        if inj.micro is not None:
            ex = with_micro(ex, micro_model or FEMicroModel(), loaded.pair, torque_out_Nm,
                            MicroMods.from_pair(loaded.pair), inj.micro)
        if inj.mesh_stiffness != 1.0:
            ex = dataclasses.replace(ex, k=ex.k * inj.mesh_stiffness)
    return build_rig(cfg, torque_out_Nm, excitation=ex)


def make_rom_run(path_json: str | Path, config: str, rpm_in: float, injected: RomInjected | None = None, *,
                 torque_out_Nm: float = 120.0, revs_out: float = 2.3, edges_per_rev=(40000, 36000),
                 clock_hz: float = 80e6, jitter_s: float = 2e-9, line_error_rad=2e-7, rpm_meta: float | None = None,
                 seed: int = 0, sample_rate_hz: float = 50e3, settle_s: float = 0.05, model=None) -> tuple[Path, dict]:
    """Simulate a run with the exudyn ROM and its own effect models, emulate the encoders, write the file.

    The record starts after ``settle_s`` (a steady state, as a rig is measured) at a random shaft angle, the encoder discs have random line-0 angles, the record
    is not a whole number of revolutions, and the two encoders may have different line counts.

    Returns
    -------
    path : Path
        The measurement JSON (edges CSV next to it).
    info : dict
        ``theta_first_in``, ``theta_first_out``: absolute drive-sense angle (rad) of each channel's
        first edge (the angle reference of the diagnosis' phases), ``rom_model``.
    """
    from gearrom.rom import Effects, simulate_run

    inj = injected or RomInjected()
    rng = np.random.default_rng(seed)
    model = model or rom_model(config, torque_out_Nm, inj)
    res = simulate_run(model, rpm_in, torque_out_Nm, n_output_revs=revs_out, sample_rate_hz=sample_rate_hz,
                       theta0=float(rng.uniform(0, 2 * math.pi)), settle_s=settle_s,
                       effects=Effects(runout=tuple(inj.runout), pitch=tuple(inj.pitch),
                                       load_ripple=tuple(inj.load_ripple)))
    t = np.asarray(res.time, float)
    th1, th2 = np.asarray(res.angle("in"), float), np.asarray(res.angle("out"), float)
    rb1, rb2 = model.pair.rb
    if "input_encoder" in inj.encoder:
        a, ph = inj.encoder["input_encoder"]
        th1 = th1 + a * 1e-6 / rb1 * np.cos(th1 + ph)
    if "output_encoder" in inj.encoder:
        a, ph = inj.encoder["output_encoder"]
        th2 = th2 - a * 1e-6 / rb2 * np.cos(th2 + ph)
    n_in, n_out = (edges_per_rev, edges_per_rev) if np.isscalar(edges_per_rev) else edges_per_rev
    off = (float(rng.uniform(0, 2 * math.pi / n_in)), float(rng.uniform(0, 2 * math.pi / n_out)))
    rec = emulate_edges(t - t[0], th1, th2, edges_per_rev=(int(n_in), int(n_out)), clock_hz=clock_hz,
                        jitter_s=jitter_s, line_error_rad=line_error_rad, offset_rad=off, rng=rng)
    first = [o + math.ceil((th[0] - o) / (2 * math.pi / n) - 1e-12) * (2 * math.pi / n)
             for o, th, n in ((off[0], th1, n_in), (off[1], th2, n_out))]
    path = write_measurement(path_json, rec, rpm_in=rpm_meta or rpm_in, torque_out_Nm=torque_out_Nm, config=config,
                             description=f"synthetic run (gearrom.rom, exudyn), effects {inj}")
    return path, {"theta_first_in": first[0], "theta_first_out": first[1]}


def rom_runout_phase_deg(phase_rad: float, theta_first: float) -> float:
    """A ROM runout ``e sin(theta_gear + phase)`` (absolute angle) in the diagnosis' convention
    ``a cos(theta + phi)`` with theta from the channel's first edge: ``phi = phase - 90 deg + theta_first``."""
    return (math.degrees(phase_rad - math.pi / 2 + theta_first) + 180.0) % 360.0 - 180.0


def encoder_phase_deg(phase_rad: float, theta_first: float) -> float:
    """An encoder error ``cos(theta_disc + phase)`` (absolute) as ``cos(theta + phi)`` from the first edge."""
    return (math.degrees(phase_rad + theta_first) + 180.0) % 360.0 - 180.0
