"""gearrom.spectral against signals with known lines (the reference is the synthesized signal itself:
amplitudes and phases put in analytically)."""
from __future__ import annotations

import numpy as np
import pytest

from gearrom.errors import MeasurementError
from gearrom.spectral import line_amplitudes, line_coefficients, spectrum


def test_line_coefficients_recover_amplitude_and_phase_over_whole_periods():
    z1, n_per = 32, 8
    th = np.arange(n_per * 64) * 2 * np.pi / (z1 * 64)  # uniform input angle, 8 whole mesh periods
    x = 3.0 + 2.0 * np.cos(z1 * th + 0.4) + 0.5 * np.cos(3 * z1 * th - 1.1) + 0.3 * np.cos(2.5 * z1 * th)
    c = line_coefficients(x, z1 * th, (1, 2, 3))
    np.testing.assert_allclose(np.abs(c), [2.0, 0.0, 0.5], atol=1e-12)  # order 2.5 makes 20 whole cycles: orthogonal
    assert np.angle(c[0]) == pytest.approx(0.4, abs=1e-12) and np.angle(c[2]) == pytest.approx(-1.1, abs=1e-12)
    np.testing.assert_allclose(line_amplitudes(x, z1 * th, [1]), [2.0], atol=1e-12)


@pytest.mark.parametrize("window", ["rect", "hann", "flattop"])
def test_spectrum_gives_the_amplitude_of_a_sine_on_a_bin_with_any_window(window):
    fs, n = 1000.0, 1000
    t = np.arange(n) / fs
    x = 1.5 * np.cos(2 * np.pi * 50 * t + 0.3)
    sp = spectrum(x, 1 / fs, window)
    a, ph, f = sp.at(50.0)
    assert (a, f) == (pytest.approx(1.5, rel=1e-9), 50.0)
    if window == "rect":
        assert ph == pytest.approx(0.3, abs=1e-9)


def test_spectrum_rows_and_nyquist_line():
    n = 16
    k = np.arange(n)
    rows = np.vstack([np.cos(np.pi * k), 2 * np.cos(2 * np.pi * 3 * k / n)])  # Nyquist line; bin 3
    amp = spectrum(rows, 1.0 / n).amplitude
    assert amp[0, -1] == pytest.approx(1.0) and amp[1, 3] == pytest.approx(2.0)
    with pytest.raises(MeasurementError, match="at least 2 samples"):
        spectrum(np.ones(1), 1.0)
