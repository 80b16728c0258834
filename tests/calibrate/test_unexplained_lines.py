"""Which lines of the after-residual the diagnosis reports as unexplained (gearrom.calibrate.diagnose).

Synthetic residuals of known content: a large misfit line at 2 kHz, a small line far from it at
88 Hz (a load ripple's size) and a small line next to it at 2.05 kHz (where the large line's
leakage and modulation products lie), in white noise. Reference: the lines put in.
"""
from __future__ import annotations

import numpy as np

from gearrom.calibrate.diagnose import UNEXPLAINED_SHARE, _unexplained_peaks

FS, N = 20000.0, 8000
NOISE = 0.01e-6


def _signal(lines):
    t = np.arange(N) / FS
    x = np.random.default_rng(3).normal(0.0, NOISE, N)
    for f, a in lines:
        x += a * np.cos(2 * np.pi * f * t + 0.3)
    return x


def _found(peaks, f):
    return [a for g, a in peaks if abs(g - f) < 2 * FS / N]


def test_a_small_line_far_from_a_large_misfit_line_is_reported():
    big, small = (2000.0, 6.5e-6), (88.0, 0.25e-6)
    assert small[1] < UNEXPLAINED_SHARE * big[1]        # below the share of the large line
    before = [(big[0], big[1]), (small[0], small[1])]
    peaks = _unexplained_peaks(_signal([big, small]), before, FS, NOISE)
    (a,) = _found(peaks, small[0])
    assert abs(a / small[1] - 1) < 0.05                 # Hann amplitude of a line of known size
    assert _found(peaks, big[0])


def test_a_small_line_next_to_a_large_misfit_line_is_not():
    big, near = (2000.0, 6.5e-6), (2050.0, 0.25e-6)
    peaks = _unexplained_peaks(_signal([big, near]), [big], FS, NOISE)
    assert not _found(peaks, near[0]) and _found(peaks, big[0])


def test_lines_at_noise_level_are_not_reported():
    peaks = _unexplained_peaks(_signal([(300.0, 2 * NOISE)]), [], FS, NOISE)
    assert not _found(peaks, 300.0)
