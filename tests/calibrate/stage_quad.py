"""Sampled A/B recordings of the bundled 15/30 stage (``stage-15-30``) made from the torsional rig model.

The rig model is simulated at the steady speed with the injected effects (kinematic tables of
:mod:`gearrom.testing.synthetic`, written from their physical definitions); its shaft angles, as
functions of the nominal input angle, are replayed along a start-up / steady / stop angle history
(:func:`gearrom.signal.daq.runup_angle`; quasi-static replay: the stage's first mode is far above
the shaft orders and the GMF at 82 rpm) and sampled by the DAQ emulation (1000 lines, 50 kHz).
The truth of a test is then the injected effect; a clean recording carries the nominal model only.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from gearrom.calibrate.torsional import TorsionalRig
from gearrom.calibrate.simulator import ModelChanges, RunConditions
from gearrom.testing.synthetic import Injected, kinematic_tables
from gearrom.signal.daq import DAQSettings, emulate_quadrature, runup_angle, write_quadrature

CONFIG = "stage-15-30"
RPM = 82.0
TORQUE = 2.0
T_SKIP = 0.5  # s of the steady simulation dropped (start transient of the rig model)


def write_stage_run(path_json: Path, injected: Injected | None = None, *, rig: TorsionalRig | None = None,
                    rpm: float = RPM, duration_s: float = 5.0, t_steady_s: float = 2.0, seed: int = 1,
                    daq: DAQSettings | None = None, data_format: str = "mat",
                    out_ratio: float = 1.0) -> Path:
    """Write one emulated sampled recording of the stage; returns the measurement JSON."""
    rig = rig or TorsionalRig.from_config(CONFIG)
    inj = injected or Injected()
    w = rpm * 2 * math.pi / 60
    t = np.linspace(0.0, duration_s, int(duration_s * 100_000))
    phi = runup_angle(t, rpm, t_steady_s=t_steady_s)
    ch = ModelChanges(kinematic_in=kinematic_tables(inj, rig.pair, "input_gear"),
                      kinematic_out=kinematic_tables(inj, rig.pair, "output_gear"))
    h = rig.simulate(RunConditions(rpm, TORQUE, T_SKIP + phi[-1] / w + 0.2), ch)
    keep = h.t_s >= T_SKIP
    phi_sim = w * (h.t_s[keep] - T_SKIP)
    th1 = np.interp(phi, phi_sim, h.theta_in_rad[keep] - h.theta_in_rad[keep][0])
    th2 = np.interp(phi, phi_sim, h.theta_out_rad[keep] - h.theta_out_rad[keep][0])
    rec = emulate_quadrature(t, th1, th2, lines=1000, rng=seed, ratio=(1.0, out_ratio),
                             daq=daq or DAQSettings(sample_rate_hz=50e3, noise_V=0.05, phase_error_rad=0.1,
                                                    jitter_s=1e-7))
    return write_quadrature(path_json, rec, rpm_in=rpm, data_format=data_format, config=CONFIG,
                            torque_out_Nm=TORQUE, description=f"emulated stage-15-30 run-up, effects {inj}")
