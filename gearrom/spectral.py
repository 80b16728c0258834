"""Spectral analysis shared by every stage: one-sided amplitude spectra and lines at exact orders.

* :class:`Spectrum` owns a one-sided amplitude spectrum with its abscissa (Hz or shaft orders), window
  and scaling; :func:`spectrum` makes one. Amplitude correction: ``A_k = 2 |X_k| / sum(w)``
  (``|X_0| / sum(w)`` at DC and at Nyquist), the DFT divided by the window's coherent gain times N, so a
  sine on a bin shows its true amplitude with any window; between bins the rectangular window loses up
  to 36 %, Hann up to 15 %, flat-top less than 0.1 % (scalloping). Phases refer to the first sample
  (cosine convention ``x = A cos(2 pi f t + phase)``).
* :func:`line_coefficients`: the complex amplitudes of the lines at multiples of a reference phase
  (GMF harmonics of a TE record against the input angle ``z1 theta``, or against ``2 pi f_mesh t``):
  ``c_m = 2 mean((x - mean x) e^{-i m phi})``, the discrete Fourier coefficient at the exact order. Over
  a whole number of periods, uniform in ``phi``, it is exact and orthogonal to every other line; the
  rom's GMF amplitudes, the validation's metrics and gates and the run-up's order tracks all use it.
  Records that are not whole periods (measurements) fit their lines by least squares instead
  (:func:`gearrom.calibrate.residual.fit_lines`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import signal

from gearrom.errors import MeasurementError

__all__ = ["Spectrum", "line_amplitudes", "line_coefficients", "spectrum"]


@dataclass(frozen=True)
class Spectrum:
    """One-sided amplitude spectrum.

    Attributes
    ----------
    x : ndarray
        Frequencies in Hz (``unit == "Hz"``) or orders of the input shaft (``unit == "order"``).
    amplitude : ndarray
        Amplitude in the unit of the signal (m for TE).
    phase_rad : ndarray
        Phase, rad (cosine convention, relative to the first sample / angle zero).
    unit : {"Hz", "order"}
    window : str
        Window name; the amplitude is corrected by the window's coherent gain.
    n : int
        Number of samples transformed.
    """

    x: np.ndarray
    amplitude: np.ndarray
    phase_rad: np.ndarray
    unit: Literal["Hz", "order"]
    window: str
    n: int

    @property
    def amplitude_um(self) -> np.ndarray:
        """Amplitude in um (for a signal in m)."""
        return self.amplitude * 1e6

    @property
    def resolution(self) -> float:
        """Bin spacing (Hz or orders)."""
        return float(self.x[1] - self.x[0])

    def at(self, x0: float, search_bins: int = 0) -> tuple[float, float, float]:
        """Amplitude, phase and position of the bin nearest ``x0`` (largest within +-``search_bins``)."""
        k = round(x0 / self.resolution)
        if not 0 <= k < self.x.size:
            return float("nan"), float("nan"), float(x0)
        lo, hi = max(0, k - search_bins), min(self.x.size, k + search_bins + 1)
        j = lo + int(np.argmax(self.amplitude[lo:hi]))
        return float(self.amplitude[j]), float(self.phase_rad[j]), float(self.x[j])


def spectrum(x: np.ndarray, spacing: float, window: str = "rect", unit: Literal["Hz", "order"] = "Hz") -> Spectrum:
    """One-sided amplitude spectrum of ``x`` along its last axis (as given: remove its mean first if wanted).

    Parameters
    ----------
    x : ndarray
        Uniformly sampled signal (rows of a 2D array are transformed each).
    spacing : float
        Sample spacing: seconds (``unit="Hz"``) or revolutions (``unit="order"``).
    window : str
        ``"rect"`` or any :func:`scipy.signal.get_window` name (``"hann"``, ``"flattop"``...).

    Raises
    ------
    MeasurementError
        Fewer than 2 samples.
    """
    x = np.asarray(x, float)
    n = x.shape[-1]
    if n < 2:
        raise MeasurementError(f"spectrum needs at least 2 samples, got {n}")
    w = np.ones(n) if window in ("rect", "boxcar", "rectangular") else signal.get_window(window, n)
    X = np.fft.rfft(x * w, axis=-1)
    amp = np.abs(X) / w.sum()
    amp[..., 1:] *= 2.0
    if n % 2 == 0:
        amp[..., -1] /= 2.0
    return Spectrum(x=np.fft.rfftfreq(n, d=spacing), amplitude=amp, phase_rad=np.angle(X), unit=unit, window=window, n=n)


def line_coefficients(x: np.ndarray, phase: np.ndarray, orders) -> np.ndarray:
    """Complex amplitudes ``c_m = 2 mean((x - mean x) e^{-i m phase})`` of the lines at ``orders`` (multiples
    of ``phase`` [rad]): ``x ~ sum |c_m| cos(m phase + angle(c_m))``. Exact for a record uniform in ``phase``
    over whole periods of every order."""
    x = np.asarray(x, float)
    d = x - x.mean()
    ph = np.asarray(phase, float)
    return np.array([2.0 * np.mean(d * np.exp(-1j * m * ph)) for m in np.atleast_1d(orders)])


def line_amplitudes(x: np.ndarray, phase: np.ndarray, orders) -> np.ndarray:
    """Zero-to-peak amplitudes ``|c_m|`` of :func:`line_coefficients` (the unit of ``x``)."""
    return np.abs(line_coefficients(x, phase, orders))
