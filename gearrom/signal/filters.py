"""Filters for TE signals: the seed's Bessel low-pass, a high-pass and detrending.

The seed (ch. 2.3) filters the rig's TE with a Bessel low-pass: maximally flat group delay, so
the wave shape is kept while noise above the cut-off is removed. Here the cut-off is the -3 dB
frequency of the single pass (``norm="mag"`` in :func:`scipy.signal.bessel`). With
``zero_phase=True`` the filter runs forward and backward (:func:`scipy.signal.sosfiltfilt`):
no delay, squared magnitude (-6 dB at the cut-off), and effectively twice the order.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import signal

from gearrom.errors import ConfigError


@dataclass(frozen=True)
class FilterSettings:
    """Processing filters applied to the TE, in this order: detrend, high-pass, low-pass.

    Parameters
    ----------
    lowpass_hz : float or None
        Bessel low-pass cut-off (-3 dB of one pass), Hz. None: no low-pass.
    lowpass_order : int
        Order of the Bessel low-pass.
    highpass_hz : float or None
        Butterworth high-pass cut-off, Hz, to remove drift. None: none.
    highpass_order : int
        Order of the high-pass.
    zero_phase : bool
        Forward-backward filtering (no delay) instead of causal filtering.
    detrend : {"angle", "linear", "constant", "none"}
        Removed before filtering: "angle" a least-squares line in the input angle (offset and
        nominal slope; the slope of ``r_b1 theta_1 - r_b2 theta_2`` is proportional to the angle, so
        this holds for run-ups and speed changes too), "linear" a line in time (the same for a
        steady run).
    """

    lowpass_hz: float | None = None
    lowpass_order: int = 4
    highpass_hz: float | None = None
    highpass_order: int = 2
    zero_phase: bool = True
    detrend: Literal["angle", "linear", "constant", "none"] = "angle"

    def __post_init__(self):
        for name in ("lowpass_hz", "highpass_hz"):
            v = getattr(self, name)
            if v is not None and not v > 0:
                raise ConfigError(f"Parameter {name}={v!r} must be > 0 or None")
        for name in ("lowpass_order", "highpass_order"):
            v = getattr(self, name)
            if not (isinstance(v, int) and 1 <= v <= 12):
                raise ConfigError(f"Parameter {name}={v!r} must be an integer in 1..12")
        if self.detrend not in ("angle", "linear", "constant", "none"):
            raise ConfigError(f"Parameter detrend={self.detrend!r} must be 'angle', 'linear', 'constant' or 'none'")


def _check_fc(fc: float, fs: float, what: str) -> None:
    if not 0 < fc < fs / 2:
        raise ConfigError(f"{what} cut-off {fc} Hz must lie between 0 and the Nyquist frequency {fs / 2:g} Hz")


def bessel_lowpass(x: np.ndarray, fs_hz: float, cutoff_hz: float, order: int = 4, *,
                   zero_phase: bool = True) -> np.ndarray:
    """Bessel low-pass filter (cut-off = -3 dB of one pass).

    Parameters
    ----------
    x : ndarray
        Signal sampled at ``fs_hz``.
    fs_hz, cutoff_hz : float
        Sampling rate and cut-off, Hz.
    order : int
        Filter order.
    zero_phase : bool
        Forward-backward (sosfiltfilt) instead of causal (sosfilt).

    Returns
    -------
    ndarray
    """
    _check_fc(cutoff_hz, fs_hz, "low-pass")
    sos = signal.bessel(order, cutoff_hz, btype="lowpass", norm="mag", output="sos", fs=fs_hz)
    return signal.sosfiltfilt(sos, x) if zero_phase else signal.sosfilt(sos, x)


def highpass(x: np.ndarray, fs_hz: float, cutoff_hz: float, order: int = 2, *, zero_phase: bool = True) -> np.ndarray:
    """Butterworth high-pass (drift removal), cut-off at -3 dB of one pass.

    ``x``, ``fs_hz``, ``cutoff_hz``, ``order`` and ``zero_phase`` are as in :func:`bessel_lowpass`.
    """
    _check_fc(cutoff_hz, fs_hz, "high-pass")
    sos = signal.butter(order, cutoff_hz, btype="highpass", output="sos", fs=fs_hz)
    return signal.sosfiltfilt(sos, x) if zero_phase else signal.sosfilt(sos, x)


def apply_filters(x: np.ndarray, fs_hz: float, settings: FilterSettings,
                  angle_rad: np.ndarray | None = None) -> np.ndarray:
    """Detrend, high-pass and low-pass ``x`` as ``settings`` say.

    Parameters
    ----------
    x : ndarray
        Signal.
    fs_hz : float
        Its sampling rate, Hz.
    settings : FilterSettings
    angle_rad : ndarray, optional
        Input angle at the samples, rad (detrend "angle"; without it, the line is fitted in time).

    Returns
    -------
    ndarray
        A new array.
    """
    y = np.asarray(x, dtype=np.float64)
    if settings.detrend == "angle" and angle_rad is not None:
        a = np.asarray(angle_rad, dtype=np.float64) - float(np.mean(angle_rad))
        y = y - y.mean() - a * (float(a @ (y - y.mean())) / float(a @ a) if a.any() else 0.0)
    elif settings.detrend == "angle":
        y = signal.detrend(y, type="linear")
    elif settings.detrend != "none":
        y = signal.detrend(y, type=settings.detrend)
    if settings.highpass_hz is not None:
        y = highpass(y, fs_hz, settings.highpass_hz, settings.highpass_order, zero_phase=settings.zero_phase)
    if settings.lowpass_hz is not None:
        y = bessel_lowpass(y, fs_hz, settings.lowpass_hz, settings.lowpass_order, zero_phase=settings.zero_phase)
    return y
