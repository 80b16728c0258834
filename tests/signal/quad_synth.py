"""Emulated sampled A/B records of a small two-encoder stage (z = 15/30, m = 2 mm, 1000 lines, 50 kHz).

The truth is the imposed TE: ``theta_out = (theta_in * rb1 - te) / rb2`` with a mesh-order sine,
so every test compares the pipeline's TE with the emulated one.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from gearrom.signal.daq import DAQSettings, emulate_quadrature, runup_angle, write_quadrature

Z1, Z2 = 15, 30
M_MM = 2.0
ALPHA = math.radians(20.0)
RB1 = Z1 * M_MM / 2 * 1e-3 * math.cos(ALPHA)
RB2 = Z2 * M_MM / 2 * 1e-3 * math.cos(ALPHA)
RPM = 82.0
TE_AMP = 20e-6  # m, at the mesh order (15 per input revolution)
TE_OUT1 = 5e-6  # m, output order 1 (= input order 0.5)

CONFIG = f"""
name = "stage-15-30"
description = "small test stage, m = 2 mm, z = 15/30"
[pair]
normal_module_mm = {M_MM}
normal_pressure_angle_deg = 20.0
helix_angle_deg = 0.0
[material]
youngs_modulus_GPa = 210.0
poisson_ratio = 0.3
density_kg_per_m3 = 7850.0
[input_gear]
teeth = {Z1}
hand = "spur"
profile_shift = 0.0
face_width_mm = 10.0
bore_diameter_mm = 10.0
[output_gear]
teeth = {Z2}
hand = "spur"
profile_shift = 0.0
face_width_mm = 10.0
bore_diameter_mm = 15.0
[operating]
torque_out_Nm = 2.0
rpm_in = {RPM}
"""


def te_truth(theta_in: np.ndarray) -> np.ndarray:
    """The imposed TE (m) as a function of the input angle: mesh order 15 and output order 1."""
    return TE_AMP * np.cos(Z1 * theta_in + 0.3) + TE_OUT1 * np.cos(theta_in * Z1 / Z2 + 1.0)


def history(duration_s: float = 5.0, rpm: float = RPM, n: int = 400_000, **runup):
    """Fine angle histories of a start-up / steady / coast-down run with the imposed TE."""
    t = np.linspace(0.0, duration_s, n)
    th1 = runup_angle(t, rpm, **runup)
    th2 = (RB1 * th1 - te_truth(th1)) / RB2
    return t, th1, th2


def write_stage(folder: Path, *, data_format: str = "mat", daq: DAQSettings | None = None, duration_s: float = 5.0,
                rng: int = 1, out_ratio: float = 1.0, name: str = "stage", **kw) -> Path:
    """Write the config TOML and a sampled record of the stage; returns the measurement JSON."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "stage.toml").write_text(CONFIG)
    t, th1, th2 = history(duration_s)
    rec = emulate_quadrature(t, th1, -th2, lines=1000, daq=daq or DAQSettings(noise_V=0.05, phase_error_rad=0.2,
                                                                              jitter_s=2e-7),
                             ratio=(1.0, out_ratio), rng=rng)
    return write_quadrature(folder / f"{name}.json", rec, rpm_in=RPM, data_format=data_format, config="stage.toml",
                            torque_out_Nm=2.0, **kw)
