"""Spectra, order tracking, synchronous averages, filters, gear data and encoder emulation,
each against an analytic reference (named in the test)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from signal_synth import MESH
from gearrom.errors import ConfigError
from gearrom.signal import (AngleRecord, FilterSettings, GearMeshInfo, ReadSettings, Spectrum, amplitude_spectrum, annotate_gmf,
                            bessel_lowpass, emulate_edges, highpass, order_spectrum, process_measurement,
                            synchronous_average, write_measurement)

FS = 10_000.0
N = 10_000


def _tone(f, a=2.0, ph=0.7):
    t = np.arange(N) / FS
    return a * np.cos(2 * math.pi * f * t + ph)


@pytest.mark.parametrize("window", ["rect", "hann", "flattop"])
def test_amplitude_on_bin_any_window(window):
    """A tone on a bin shows its amplitude with every window (coherent-gain correction)."""
    sp = amplitude_spectrum(_tone(250.0), FS, window)
    a, p, f = sp.at(250.0)
    assert (a, f) == (pytest.approx(2.0, rel=1e-9), 250.0)
    assert p == pytest.approx(0.7, abs=1e-6)


def test_scalloping_between_bins():
    """Half a bin off: Hann reads 0.8488 (-1.42 dB), flat-top within 0.02 dB (Heinzel, Ruediger, Schilling 2002,
    'Spectrum and spectral density estimation by the DFT': Hann max. scalloping loss 1.4236 dB; flat-top
    windows of this family about 0.01 dB)."""
    x = _tone(250.5)
    hann = amplitude_spectrum(x, FS, "hann")
    assert max(hann.at(250.0)[0], hann.at(251.0)[0]) / 2 == pytest.approx(10 ** (-1.4236 / 20), rel=2e-3)
    flat = amplitude_spectrum(x, FS, "flattop")
    assert flat.at(250.5, search_bins=1)[0] / 2 == pytest.approx(1.0, abs=2.3e-3)


def test_order_spectrum_survives_speed_variation():
    """+-10 % speed swing: the order spectrum keeps the order-32 amplitude exactly (angle-domain resampling),
    the time spectrum smears it."""
    revs = 20
    theta = np.linspace(0, revs * 2 * math.pi, 400_000)
    t = (theta + 0.1 * np.sin(theta / 4) * 4) / (2 * math.pi * 20)  # speed ripple at order 1/4
    x = 3e-6 * np.cos(32 * theta + 0.3)
    sp = order_spectrum(x, theta, 1024)
    a, p, _ = sp.at(32)
    assert a == pytest.approx(3e-6, rel=1e-4) and p == pytest.approx(0.3, abs=1e-3)
    tu = np.linspace(t[0], t[-1], theta.size)
    xs = np.interp(tu, t, x)
    ts = amplitude_spectrum(xs, 1 / (tu[1] - tu[0]), "flattop")
    assert ts.amplitude.max() < 0.7 * 3e-6


def test_tsa_aligned_to_angle_zero():
    """TSA of cos(5 theta) + noise over whole revolutions starting at an arbitrary angle: cos(5 angle)
    within 5 sigma of the averaged noise, sigma / sqrt(n) (angle zero = theta 0)."""
    rng = np.random.default_rng(3)
    theta = np.linspace(0.37, 0.37 + 30 * 2 * math.pi, 300_000)
    x = np.cos(5 * theta) + rng.normal(0, 0.1, theta.size)
    ang, avg, n = synchronous_average(x, theta, 2 * math.pi, 512)
    assert n == 29
    assert np.max(np.abs(avg - np.cos(5 * ang))) < 5 * 0.1 / math.sqrt(29)


def test_annotate_gmf_labels():
    """Harmonics and sidebands land on the expected orders with their amplitudes."""
    x = np.arange(0, 200, 0.25)
    amp = np.zeros_like(x)
    amp[x == 32] = 5
    amp[x == 33] = 1  # 1xGMF + 1xf_in
    amp[x == 64] = 2
    sp = Spectrum(x=x, amplitude=amp, phase_rad=np.zeros_like(x), unit="order", window="rect", n=2 * x.size)
    peaks = {p.label: p for p in annotate_gmf(sp, 32, 1.0, 0.75)}
    assert peaks["1xGMF"].amplitude == 5 and peaks["2xGMF"].amplitude == 2 and peaks["3xGMF"].amplitude == 0
    assert peaks["1xGMF+1xf_in"].amplitude == 1 and peaks["1xGMF-2xf_out"].x == 30.5


def test_bessel_cutoff_is_minus_3dB_and_zero_phase():
    """Cut-off = -3 dB of one pass (norm 'mag'); forward-backward gives |H|^2 = 0.5 and no phase shift."""
    fc = 500.0
    x = _tone(fc, a=1.0, ph=0.0)
    causal = bessel_lowpass(x, FS, fc, 4, zero_phase=False)
    assert np.abs(np.fft.rfft(causal[N // 2:]))[250] * 2 / (N // 2) == pytest.approx(1 / math.sqrt(2), rel=0.01)
    zp = bessel_lowpass(x, FS, fc, 4, zero_phase=True)
    mid = slice(N // 4, 3 * N // 4)
    assert np.max(np.abs(zp[mid] - 0.5 * x[mid])) < 0.01


def test_highpass_removes_drift():
    """2nd-order Butterworth high-pass at 5 Hz: a 0.5 Hz drift drops to |H| = 1/sqrt(1+(fc/f)^4) ~ 0.01,
    a 200 Hz tone passes."""
    t = np.arange(N) / FS
    y = highpass(np.cos(2 * math.pi * 200 * t) + np.sin(2 * math.pi * 0.5 * t), FS, 5.0)
    mid = slice(N // 4, 3 * N // 4)
    assert np.max(np.abs(y[mid] - np.cos(2 * math.pi * 200 * t[mid]))) < 2 * (0.5 / 5) ** 2


def test_filter_settings_validated():
    with pytest.raises(ConfigError, match="lowpass_hz"):
        FilterSettings(lowpass_hz=-1.0)
    with pytest.raises(ConfigError, match="Nyquist"):
        bessel_lowpass(np.zeros(100), 1000.0, 600.0)


def test_gear_data_from_config():
    """Base and pitch diameters of the rig pair (reference-values.md: db 53.2461/68.2215, d 56.6006/72.5195 mm)."""
    m = GearMeshInfo.from_config("thesis-helical")
    assert (m.z1, m.z2, m.hunting_revs_in) == (32, 41, 41)
    assert 2e3 * np.array([m.rb1_m, m.rb2_m, m.r1_m, m.r2_m]) == pytest.approx([53.2461, 68.2215, 56.6006, 72.5195],
                                                                              abs=2e-4)


def test_line_error_shows_as_input_order_one(tmp_path):
    """Disc eccentricity e_j = a sin(2 pi j/N): the encoder reads theta - a sin(theta), so the TE gets
    -r_b1 a sin(theta) = r_b1 a cos(theta + 90 deg) at input order 1."""
    rpm, n, a = 600.0, 2000, 20e-6
    w = 2 * math.pi * rpm / 60
    t = np.arange(0, 41.5 * 2 * math.pi / w, 1 / 20_000)
    th1 = w * t
    err = a * np.sin(2 * math.pi * np.arange(n) / n)
    rec = emulate_edges(t, th1, th1 * MESH.rb1_m / MESH.rb2_m, edges_per_rev=n, line_error_rad=(err, None))
    res = process_measurement(write_measurement(tmp_path / "e.json", rec, rpm_in=rpm), MESH)
    amp, ph, _ = res.order_spectrum().at(1)
    assert amp == pytest.approx(MESH.rb1_m * a, rel=0.01)
    assert math.degrees(ph) == pytest.approx(90.0, abs=2.0)


def test_clock_quantization_noise_floor(tmp_path):
    """Counter clock 1 MHz, no other error: each edge time is late by U(0, 1/clock); in TE both channels give
    r_b1*w1*dt (r_b2 w2 = r_b1 w1), and linear interpolation between independent edges at a uniformly
    distributed position keeps 2/3 of the variance: rms = r_b1 w1 / clock * sqrt(2/12 * 2/3) = r_b1 w1 / (3 clock).
    (The grid rate is set incommensurate with both edge rates so that the position is uniform.)"""
    rpm, clock = 1250.0, 1e6
    w = 2 * math.pi * rpm / 60
    t = np.linspace(0, 3.0, 30_001)
    rec = emulate_edges(t, w * t, w * t * MESH.rb1_m / MESH.rb2_m, edges_per_rev=997, clock_hz=clock)
    res = process_measurement(write_measurement(tmp_path / "q.json", rec, rpm_in=rpm), MESH,
                              read_settings=ReadSettings(fs_hz=7777.7, edge_interp="linear"))
    assert res.te_rms_m == pytest.approx(MESH.rb1_m * w / (3 * clock), rel=0.05)


def test_angles_from_simulation_record(tmp_path):
    """A simulated AngleRecord passes through the same pipeline (kind 'angles', TDMS)."""
    t = np.linspace(0, 1, 20_001)
    w = 2 * math.pi * 1250 / 60
    th1 = w * t
    te = 2e-6 * np.cos(32 * th1)
    path = write_measurement(tmp_path / "s.json", AngleRecord(t, th1, (MESH.rb1_m * th1 - te) / MESH.rb2_m),
                             rpm_in=1250.0, data_format="tdms")
    res = process_measurement(path, MESH)
    assert res.gmf_lines()[0][0] == pytest.approx(2e-6, rel=1e-3)


def test_edge_interpolation_attenuation(tmp_path):
    """Coarse encoders (1000 edges/rev): the 3rd GMF harmonic rides on the output channel, which turns
    z1/z2 slower, so it has p = 1000 / (96 * 41/32) = 8.13 output edges per period. Linear interpolation between edges (uniformly distributed grid positions) passes
    sinc^2(pi/p) = 0.951; the cubic Hermite recovers the amplitude within 1 %."""
    from signal_synth import write_run

    path = write_run(tmp_path / "c.json", 1250.0, 1000)
    p = 1000 / (96 * 41 / 32)
    lin = process_measurement(path, MESH, read_settings=ReadSettings(edge_interp="linear"))
    assert lin.gmf_lines()[2][0] / 1e-6 == pytest.approx(np.sinc(1 / p) ** 2, rel=3e-3)
    cub = process_measurement(path, MESH)
    assert cub.gmf_lines()[2][0] / 1e-6 == pytest.approx(1.0, rel=0.01)


def test_emulation_from_standstill():
    """A run-up from rest (plateau until t0): edge j when theta = 0.5 a (t - t0)^2 reaches j 2 pi/N,
    i.e. t = t0 + sqrt(2 j (2 pi/N) / a) (analytic); the line the shaft rests on counts when it moves off."""
    from gearrom.errors import MeasurementError
    from gearrom.signal import emulate_channel

    a, t0, n = 50.0, 0.1, 360
    t = np.linspace(0, 1.0, 20_001)
    th = 0.5 * a * np.clip(t - t0, 0, None) ** 2
    edges = emulate_channel(t, th, n, clock_hz=None)
    j = np.arange(edges.size)
    exact = t0 + np.sqrt(2 * j * (2 * math.pi / n) / a)
    assert edges[0] == pytest.approx(t0, abs=1e-4)  # history step 5e-5 s
    np.testing.assert_allclose(edges[5:], exact[5:], atol=2e-6)
    with pytest.raises(MeasurementError, match="decreases at index 3"):
        emulate_channel(t[:5], np.array([0, 1, 2, 1.5, 3.0]), n)


def test_run_up_from_rest(tmp_path):
    """Run-up from rest (constant acceleration to 1250 rpm in 0.2 s, then 42 revolutions): no false repair
    (the reference interval follows the acceleration), and the order spectrum (angle domain) recovers a
    3 um mesh-order TE within 1 % despite the speed change."""
    w, ramp = 2 * math.pi * 1250 / 60, 0.2
    t = np.arange(0, ramp + 42 * 2 * math.pi / w, 1 / 100e3)
    th1 = np.where(t < ramp, 0.5 * w / ramp * t**2, 0.5 * w * ramp + w * (t - ramp))
    te = 3e-6 * np.cos(32 * th1)
    rec = emulate_edges(t, th1, (MESH.rb1_m * th1 - te) / MESH.rb2_m, edges_per_rev=4000)
    rpm_mean = th1[-1] / t[-1] * 60 / (2 * math.pi)
    res = process_measurement(write_measurement(tmp_path / "r.json", rec, rpm_in=rpm_mean), MESH)
    assert res.repairs == ()
    assert res.gmf_lines()[0][0] == pytest.approx(3e-6, rel=0.01)
