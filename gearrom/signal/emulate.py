"""Encoder emulation: simulated angle histories to edge time stamps.

A simulated run (e.g. the exudyn drivetrain) gives shaft angles at its time steps. The functions
here turn them into what an incremental encoder with a time-stamping counter would record, so
that simulated runs go through the same reader and TE pipeline as rig data::

    rec = emulate_edges(t_s, theta_in, theta_out, edges_per_rev=40000, clock_hz=80e6, rng=1)
    write_measurement(tmp / "sim.json", rec, rpm_in=1250.0, config="thesis-helical")

Model: line ``j`` of the disc sits at ``j * 2*pi/edges_per_rev + offset_rad + e[j % edges_per_rev]``
(``e`` = line-spacing errors). An edge is recorded when the shaft angle passes a line; the
crossing time is found by inverse interpolation of the angle history (a cubic spline of t(theta)
by default, accurate to about ``(omega*h)**4/384`` of a TE component for a history step ``h``),
then Gaussian jitter is added and the time is quantized down to the counter clock.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
from scipy.interpolate import CubicSpline

from gearrom.errors import MeasurementError
from gearrom.signal.measurement import EdgeRecord

_SEGMENT = 500_000  # history samples per spline segment (bounded memory)
_MARGIN = 16


def _line_errors(line_error_rad, n: int, rng: np.random.Generator) -> np.ndarray | None:
    if line_error_rad is None:
        return None
    arr = np.asarray(line_error_rad, dtype=np.float64)
    if arr.ndim == 0:
        return rng.normal(0.0, float(arr), n) if float(arr) > 0 else None
    if arr.shape != (n,):
        raise ValueError(f"line_error_rad must be a scalar rms or an array of {n} values, got shape {arr.shape}")
    return arr


def emulate_channel(t_s: np.ndarray, theta_rad: np.ndarray, edges_per_rev: int, *, clock_hz: float | None = 80e6,
                    jitter_s: float = 0.0, line_error_rad: float | np.ndarray | None = None, offset_rad: float = 0.0,
                    rng: np.random.Generator | int | None = None, t_window: tuple[float, float] | None = None,
                    interp: Literal["cubic", "linear"] = "cubic", name: str = "theta") -> np.ndarray:
    """Edge time stamps of one encoder for a given angle history.

    Parameters
    ----------
    t_s : ndarray
        Time samples of the history, s, increasing.
    theta_rad : ndarray
        Shaft angle at ``t_s``, rad, non-decreasing (rotation in one direction; standstill allowed).
    edges_per_rev : int
        Counted edges per revolution (lines x decoding factor).
    clock_hz : float or None
        Counter clock; time stamps are quantized down to ``1/clock_hz``. None: no quantization.
    jitter_s : float
        Rms of Gaussian timing jitter added to each edge, s.
    line_error_rad : float, ndarray or None
        Line-spacing errors: an rms (drawn once per line with ``rng``) or one value per line, rad.
    offset_rad : float
        Angle of line 0, rad.
    rng : Generator, int or None
        Random generator or seed (jitter, line errors).
    t_window : (float, float), optional
        Keep only edges with ``t0 <= t < t1`` (before jitter): lets long records be emulated in pieces.
    interp : {"cubic", "linear"}
        Inverse interpolation of the history.
    name : str
        Name of the history in error messages.

    Returns
    -------
    ndarray
        Edge times, s, increasing.

    Raises
    ------
    MeasurementError
        The history is not finite, the time not increasing or the angle decreasing (names index and time).
    """
    t = np.asarray(t_s, dtype=np.float64)
    th = np.asarray(theta_rad, dtype=np.float64)
    if t.shape != th.shape or t.ndim != 1 or t.size < 2:
        raise ValueError(f"t_s and {name} must be 1-D arrays of equal length >= 2, got {t.shape} and {th.shape}")
    if not (np.isfinite(t).all() and np.isfinite(th).all()):
        i = int(np.argmin(np.isfinite(t) & np.isfinite(th)))
        raise MeasurementError(f"{name}: non-finite value at index {i}")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise MeasurementError(f"t_s is not strictly increasing at index {i} (t={t[i]:.9g} s)")
    step = np.diff(th)
    bad = np.flatnonzero(step < 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise MeasurementError(f"{name} decreases at index {i} (t={t[i]:.9g} s); the encoder emulation needs "
                               "rotation in one direction")
    if not step.all():  # standstill: keep the last sample of each plateau (when the shaft moves off)
        keep = np.concatenate([step > 0, [True]])
        t, th = t[keep], th[keep]
        if t.size < 2:
            return np.empty(0)
    rng = np.random.default_rng(rng)
    n = int(edges_per_rev)
    dth = 2.0 * math.pi / n
    err = _line_errors(line_error_rad, n, rng)
    out = []
    for a in range(0, t.size - 1, _SEGMENT):
        b = min(a + _SEGMENT, t.size - 1)  # core [a, b] in samples
        lo, hi = max(0, a - _MARGIN), min(t.size, b + _MARGIN + 1)
        j0 = math.ceil((th[a] - offset_rad) / dth - 1e-12) if a == 0 else math.floor((th[a] - offset_rad) / dth) + 1
        j1 = math.floor((th[b] - offset_rad) / dth)
        if j1 < j0:
            continue
        j = np.arange(j0, j1 + 1, dtype=np.int64)
        lines = j * dth + offset_rad
        if err is not None:
            lines = lines + err[j % n]
        lines = np.clip(lines, th[lo], th[hi - 1])
        if interp == "cubic" and hi - lo >= 4:
            te = CubicSpline(th[lo:hi], t[lo:hi])(lines)
        else:
            te = np.interp(lines, th[lo:hi], t[lo:hi])
        out.append(te)
    edges = np.concatenate(out) if out else np.empty(0)
    if t_window is not None:
        edges = edges[(edges >= t_window[0]) & (edges < t_window[1])]
    if jitter_s > 0:
        edges = np.sort(edges + rng.normal(0.0, jitter_s, edges.size))
    if clock_hz is not None:
        edges = np.floor(edges * clock_hz + 1e-6) / clock_hz
    return edges


def _pair(value, what: str):
    if isinstance(value, (tuple, list)) and len(value) == 2:
        return value[0], value[1]
    if isinstance(value, Sequence) and not isinstance(value, str):
        raise ValueError(f"{what}: give one value or a pair (input, output), got {len(value)} values")
    return value, value


def emulate_edges(t_s: np.ndarray, theta_in_rad: np.ndarray, theta_out_rad: np.ndarray, *,
                  edges_per_rev: int | tuple[int, int] = 40000, clock_hz: float = 80e6, jitter_s: float = 0.0,
                  line_error_rad=None, offset_rad: float | tuple[float, float] = 0.0,
                  rng: np.random.Generator | int | None = None, interp: Literal["cubic", "linear"] = "cubic",
                  locations: tuple[str, str] = ("sensor", "sensor")) -> EdgeRecord:
    """Emulate the input and output encoders of a TE rig from simulated angle histories.

    Parameters
    ----------
    t_s : ndarray
        Time samples, s.
    theta_in_rad, theta_out_rad : ndarray
        Input and output shaft angles at ``t_s``, rad, non-decreasing (each in its own sense of rotation).
    edges_per_rev : int or (int, int)
        Counted edges per revolution, one value or ``(input, output)``.
    clock_hz : float
        Counter clock (time stamps quantized to it).
    jitter_s : float
        Rms timing jitter per edge, s.
    line_error_rad : float, ndarray, None or a pair of them
        Line-spacing errors (rms or per line), one for both or ``(input, output)``.
    offset_rad : float or (float, float)
        Angle of line 0 of each disc, rad.
    rng : Generator, int or None
        Random generator or seed.
    interp : {"cubic", "linear"}
        Inverse interpolation of the histories.
    locations : (str, str)
        Encoder locations written to the metadata.

    Returns
    -------
    EdgeRecord
        Ready for :func:`~gearrom.signal.measurement.write_measurement`.
    """
    rng = np.random.default_rng(rng)
    n_in, n_out = _pair(edges_per_rev, "edges_per_rev")
    e_in, e_out = _pair(line_error_rad, "line_error_rad")
    o_in, o_out = _pair(offset_rad, "offset_rad")
    kw = dict(clock_hz=clock_hz, jitter_s=jitter_s, rng=rng, interp=interp)
    t_in = emulate_channel(t_s, theta_in_rad, int(n_in), line_error_rad=e_in, offset_rad=o_in,
                           name="theta_in_rad", **kw)
    t_out = emulate_channel(t_s, theta_out_rad, int(n_out), line_error_rad=e_out, offset_rad=o_out,
                            name="theta_out_rad", **kw)
    return EdgeRecord(t_input_s=t_in, t_output_s=t_out, edges_per_rev=(int(n_in), int(n_out)),
                      clock_hz=float(clock_hz), locations=tuple(locations))
