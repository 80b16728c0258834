"""Synthetic runs with a known TE for the signal tests.

The reference is analytic: the output angle is built from the input angle and a TE that is a sum
of cosines in the shaft angles (mesh orders h*z1 and input-shaft orders on the input angle,
output-shaft orders on the output angle), theta_2 = (r_b1*theta_1 - TE)/r_b2, i.e. the output
lags by TE along the line of action. Gear data: the rig's helical pair, base and pitch diameters
db = 53.2461 / 68.2215 mm, d = 56.6006 / 72.5195 mm (shared/notes/reference-values.md).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from gearrom.signal import GearMeshInfo, emulate_edges, write_measurement

MESH = GearMeshInfo(32, 41, 53.2461e-3 / 2, 68.2215e-3 / 2, 56.6006e-3 / 2, 72.5195e-3 / 2, name="reference values")

# (shaft, order of that shaft, amplitude um, phase deg): TE = sum A cos(order * theta_shaft + phase)
COMPONENTS = [("input", 32, 5.0, 30.0), ("input", 64, 2.0, -60.0), ("input", 96, 1.0, 120.0),
              ("input", 1, 3.0, 45.0), ("output", 1, 4.0, -100.0)]


def input_order(shaft: str, order: float) -> float:
    """Order of a component in terms of the input shaft angle."""
    return order if shaft == "input" else order * MESH.z1 / MESH.z2


def synth_angles(rpm: float, revs: float = 42.0, *, noise_um: float = 0.05, ripple_rad: float = 0.002,
                 seed: int = 0, components=COMPONENTS, mesh: GearMeshInfo = MESH):
    """Input/output angle histories with a known TE (input speed with a slow ripple)."""
    w1 = 2 * math.pi * rpm / 60
    fmax = 3 * mesh.z1 * rpm / 60
    t = np.arange(0.0, revs * 2 * math.pi / w1, 1.0 / (60 * fmax))
    th1 = w1 * t + ripple_rad * np.sin(0.5 * w1 * t)
    th2_nom = th1 * mesh.z1 / mesh.z2
    te = np.random.default_rng(seed).normal(0.0, noise_um * 1e-6, t.size)
    for shaft, order, amp, ph in components:
        te += amp * 1e-6 * np.cos(order * (th1 if shaft == "input" else th2_nom) + math.radians(ph))
    return t, th1, (mesh.rb1_m * th1 - te) / mesh.rb2_m


def write_run(path: Path, rpm: float, edges_per_rev: int, *, revs: float = 42.0, data_format: str = "csv",
              jitter_s: float = 1e-9, line_error_rad: float = 2e-6, seed: int = 1, **meta) -> Path:
    """Emulate both encoders for a synthetic run and write a measurement; returns the JSON path."""
    t, th1, th2 = synth_angles(rpm, revs)
    rec = emulate_edges(t, th1, th2, edges_per_rev=edges_per_rev, clock_hz=80e6, jitter_s=jitter_s,
                        line_error_rad=line_error_rad, rng=seed)
    return write_measurement(path, rec, rpm_in=rpm, data_format=data_format, **meta)


def assert_components(result, amp_rtol: float = 0.01, phase_tol_deg: float = 2.0, components=COMPONENTS):
    """Every known component recovered within the tolerances (order spectrum of the result)."""
    sp = result.order_spectrum()
    for shaft, order, amp, ph in components:
        a, p, _ = sp.at(input_order(shaft, order))
        assert abs(a * 1e6 / amp - 1) < amp_rtol, (shaft, order, a * 1e6, amp)
        dphi = (math.degrees(p) - ph + 180) % 360 - 180
        assert abs(dphi) < phase_tol_deg, (shaft, order, math.degrees(p), ph)
