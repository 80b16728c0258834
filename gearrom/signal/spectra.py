"""Spectra of measured TE: amplitude spectra in time and angle (orders), synchronous averages, GMF labels.

The spectrum object and its amplitude scaling are those of :mod:`gearrom.spectral`.

Order spectra resample the TE onto a uniform grid of the input shaft angle (cubic spline), so
speed fluctuations do not smear the mesh orders. Over a whole number of input revolutions every
mesh order (``h * z1``) falls on a bin; over whole hunting-tooth periods (``z2/gcd(z1, z2)``
input revolutions) the output-shaft orders (``m * z1/z2``) do too, and no window is needed.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from gearrom.errors import MeasurementError
from gearrom.spectral import Spectrum, spectrum


def amplitude_spectrum(x: np.ndarray, fs_hz: float, window: str = "hann") -> Spectrum:
    """One-sided amplitude spectrum of a time signal.

    Parameters
    ----------
    x : ndarray
        Signal (e.g. TE in m) sampled at ``fs_hz``.
    fs_hz : float
        Sampling rate, Hz.
    window : str
        ``"rect"`` or any :func:`scipy.signal.get_window` name (``"hann"``, ``"flattop"``...).

    Returns
    -------
    Spectrum
        Frequencies in Hz, amplitudes corrected by the coherent gain of the window.
    """
    return spectrum(np.asarray(x, float) - np.mean(x), 1.0 / fs_hz, window, "Hz")


def resample_angle(x: np.ndarray, theta_rad: np.ndarray, samples_per_rev: int,
                   n_revs: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Resample ``x(theta)`` onto a uniform angle grid starting at ``theta[0]``.

    Parameters
    ----------
    x : ndarray
        Signal samples.
    theta_rad : ndarray
        Shaft angle at the same samples, rad, strictly increasing.
    samples_per_rev : int
        Grid points per revolution.
    n_revs : int, optional
        Whole revolutions to keep (default: as many as the record holds).

    Returns
    -------
    theta_grid, x_grid : ndarray
        ``samples_per_rev * n_revs`` points.
    """
    theta = np.asarray(theta_rad, float)
    bad = np.flatnonzero(np.diff(theta) <= 0)
    if bad.size:
        raise MeasurementError(f"shaft angle does not increase at sample {bad[0] + 1}: the shaft stands "
                               "still or reverses, no angle-domain resampling possible")
    avail = (theta[-1] - theta[0]) / (2 * math.pi)
    n_revs = int(math.floor(avail + 1e-9)) if n_revs is None else int(n_revs)
    if n_revs < 1 or n_revs > avail + 1e-9:
        raise MeasurementError(f"record holds {avail:.3f} revolutions; {n_revs} whole revolution(s) needed")
    grid = theta[0] + np.arange(samples_per_rev * n_revs) * (2 * math.pi / samples_per_rev)
    return grid, CubicSpline(theta, x)(grid)


def order_spectrum(x: np.ndarray, theta_rad: np.ndarray, samples_per_rev: int, *, n_revs: int | None = None,
                   window: str = "rect") -> Spectrum:
    """Order spectrum (orders of the shaft whose angle is ``theta_rad``) by angle-domain resampling.

    Parameters
    ----------
    x, theta_rad : ndarray
        Signal and shaft angle (rad) at the same samples.
    samples_per_rev : int
        Angle-grid points per revolution (highest order = half of it).
    n_revs : int, optional
        Whole revolutions to transform (default: all whole revolutions available).
    window : str
        Window (``"rect"`` when the record holds whole periods of every order of interest).

    Returns
    -------
    Spectrum
        ``x`` in orders; phase relative to ``theta_rad = 0``: ``x = A cos(order * theta + phase)``.
    """
    grid, xg = resample_angle(x, theta_rad, samples_per_rev, n_revs)
    sp = spectrum(xg - xg.mean(), 1.0 / samples_per_rev, window, "order")
    # refer the phases to angle zero instead of the first grid point: x = A cos(q*theta + phase)
    phase = np.angle(np.exp(1j * (sp.phase_rad - sp.x * grid[0])))
    return dataclasses.replace(sp, phase_rad=phase)


def synchronous_average(x: np.ndarray, theta_rad: np.ndarray, period_rad: float,
                        samples_per_period: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Time-synchronous average over whole periods of a shaft angle.

    Parameters
    ----------
    x, theta_rad : ndarray
        Signal and the angle it is synchronized to, rad (strictly increasing).
    period_rad : float
        Averaging period in that angle (``2*pi`` for one revolution; ``2*pi*z2/gcd(z1, z2)`` of the
        input angle for the hunting-tooth period).
    samples_per_period : int
        Grid points per period.

    Returns
    -------
    angle_rad, average, n_periods
        Angle within the period (sample i at ``i * period_rad / samples_per_period``, modulo the
        period, angle zero = ``theta_rad == 0``), the averaged signal, periods averaged.
    """
    theta = np.asarray(theta_rad, float)
    if np.any(np.diff(theta) <= 0):
        raise MeasurementError("shaft angle does not increase: the shaft stands still or reverses, no "
                               "synchronous average possible")
    step = period_rad / samples_per_period
    i0 = math.ceil(theta[0] / step - 1e-9)  # first grid point on the angle-zero-aligned grid
    n_per = int(math.floor((theta[-1] - i0 * step) / period_rad + 1e-9))
    if n_per < 1:
        raise MeasurementError(f"record covers {(theta[-1] - theta[0]) / period_rad:.3f} of the averaging period "
                               f"({period_rad / (2 * math.pi):.4g} rev); at least one whole period is needed")
    grid = (i0 + np.arange(n_per * samples_per_period)) * step
    avg = CubicSpline(theta, x)(grid).reshape(n_per, samples_per_period).mean(axis=0)
    avg = np.roll(avg, i0 % samples_per_period)
    return np.arange(samples_per_period) * step, avg, n_per


@dataclass(frozen=True)
class Peak:
    """An annotated spectral line: label (e.g. ``"2xGMF-1xf_out"``), position, amplitude, phase."""

    label: str
    x: float
    amplitude: float
    phase_rad: float


def annotate_gmf(spec: Spectrum, gmf: float, f_in: float, f_out: float, *, n_harmonics: int = 3,
                 n_sidebands: int = 2, search_bins: int = 0) -> list[Peak]:
    """Label the GMF harmonics and their shaft-order sidebands in a spectrum.

    Parameters
    ----------
    spec : Spectrum
        Time spectrum (Hz) or order spectrum (orders); ``gmf``, ``f_in``, ``f_out`` in the same unit
        (for an input-order spectrum: ``z1``, ``1`` and ``z1/z2``).
    n_harmonics, n_sidebands : int
        GMF harmonics 1..n and sidebands +-1..n_sidebands of each shaft.
    search_bins : int
        Take the largest bin within +- this many bins (for lines between bins).

    Returns
    -------
    list of Peak
        Harmonics first (``"1xGMF"``...), then sidebands (``"1xGMF+1xf_in"``...), within the spectrum's range.
    """
    peaks = []
    for h in range(1, n_harmonics + 1):
        a, p, x = spec.at(h * gmf, search_bins)
        if a == a:
            peaks.append(Peak(f"{h}xGMF", x, a, p))
    for h in range(1, n_harmonics + 1):
        for name, f in (("f_in", f_in), ("f_out", f_out)):
            for m in range(1, n_sidebands + 1):
                for sign in (-1, 1):
                    x0 = h * gmf + sign * m * f
                    a, p, x = spec.at(x0, search_bins)
                    if a == a and x0 > 0:
                        peaks.append(Peak(f"{h}xGMF{'+' if sign > 0 else '-'}{m}x{name}", x, a, p))
    return peaks
