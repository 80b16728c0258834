"""Non-steady records: speed profile, plateau speed, steady window and order tracking.

A rig record often holds a start-up, a steady part and a coast-down. The speed profile is the
input speed averaged over consecutive blocks of the record; the *plateau speed* is the speed at
which the record spends most of its time (the fullest 1 %-wide speed bin), and the *steady
window* the longest stretch whose block speeds stay within a tolerance of it. Order tracking
(:func:`order_map`) resamples the TE onto the input angle and takes the order spectrum of
consecutive blocks of whole revolutions, so each block gives the order amplitudes at its own
speed (an order-vs-speed map): mesh and shaft orders stay on their bins while the speed changes.
"""
from __future__ import annotations

import math

import numpy as np

#: Relative speed band of a steady record and of the steady window.
STEADY_TOLERANCE = 0.02


def speed_profile(t_s: np.ndarray, theta_rad: np.ndarray, n_blocks: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Mean speed over ``n_blocks`` consecutive blocks of the record.

    Returns
    -------
    t_mid_s, rpm : ndarray
        Block centre times, s, and mean speeds, rpm (angle advance over the block divided by its duration).
    """
    n = t_s.size
    nb = max(1, min(n_blocks, n // 4))
    edges = np.linspace(0, n - 1, nb + 1).round().astype(np.int64)
    dt = t_s[edges[1:]] - t_s[edges[:-1]]
    rpm = (theta_rad[edges[1:]] - theta_rad[edges[:-1]]) / dt * 60.0 / (2 * math.pi)
    return 0.5 * (t_s[edges[1:]] + t_s[edges[:-1]]), rpm


def plateau_rpm(rpm: np.ndarray) -> float:
    """Speed at which the record spends the most time: median of the fullest 1 %-wide speed bin
    (of the highest block speed) and its two neighbours."""
    top = float(np.max(rpm))
    if not top > 0:
        return float(np.median(rpm))
    width = 0.01 * top
    idx = np.floor(rpm / width).astype(np.int64)
    vals, counts = np.unique(idx, return_counts=True)
    mode = vals[np.argmax(counts)]
    return float(np.median(rpm[np.abs(idx - mode) <= 1]))


def steady_window(t_mid: np.ndarray, rpm: np.ndarray, tol: float = STEADY_TOLERANCE) -> tuple[float, float]:
    """Longest stretch of blocks within ``tol`` of the plateau speed: ``(t_start_s, t_end_s)`` of block centres."""
    ref = plateau_rpm(rpm)
    ok = np.abs(rpm - ref) <= tol * abs(ref)
    best, start, best_ab = 0, None, (0, 0)
    for i, v in enumerate(np.append(ok, False)):
        if v and start is None:
            start = i
        elif not v and start is not None:
            if i - start > best:
                best, best_ab = i - start, (start, i - 1)
            start = None
    a, b = best_ab
    return float(t_mid[a]), float(t_mid[b])


def steadiness(t_s: np.ndarray, theta_rad: np.ndarray, tol: float = STEADY_TOLERANCE) -> dict:
    """Speed profile summary: min/max/plateau speed, whether the record is steady, the steady window.

    A record is steady when every block speed lies within ``tol`` of the plateau speed.
    """
    t_mid, rpm = speed_profile(t_s, theta_rad)
    ref = plateau_rpm(rpm)
    steady = bool(np.all(np.abs(rpm - ref) <= tol * abs(ref)))
    t0, t1 = steady_window(t_mid, rpm, tol)
    out = {"rpm_min": float(rpm.min()), "rpm_max": float(rpm.max()), "rpm_plateau": ref, "steady": steady,
           "tolerance": tol, "steady_window_s": [t0, t1],
           "profile": {"t_s": t_mid.tolist(), "rpm_in": rpm.tolist()}}
    if not steady:
        out["statement"] = (f"not a steady run: the input speed varies from {rpm.min():.4g} to {rpm.max():.4g} rpm "
                            f"(plateau {ref:.4g} rpm, tolerance {100 * tol:g} %); the order spectrum, GMF lines and "
                            "averages are order-tracked over the whole record (amplitudes at the plateau speed: "
                            f"use the steady window t={t0:.4g}..{t1:.4g} s, gearrom te --t-start/--t-end); the "
                            "spectrum in Hz and 'gmf_hz' refer to the plateau speed")
    return out


def order_map(te_m: np.ndarray, theta_in_rad: np.ndarray, t_s: np.ndarray, orders, *, revs_per_block: int = 1,
              samples_per_rev: int = 1024) -> dict:
    """Order tracking: amplitudes of ``orders`` per block of ``revs_per_block`` input revolutions.

    Each block of whole revolutions is resampled onto a uniform input-angle grid (linear
    interpolation) and transformed with a rectangular window, so an integer order ``k`` (per block
    of ``R`` revolutions, orders that are multiples of ``1/R``) falls on a bin.

    Returns
    -------
    dict
        ``t_s`` (block centre), ``rpm_in`` (block mean speed), ``orders`` and ``amplitude_m``
        (blocks x orders).
    """
    orders = np.asarray(orders, dtype=np.float64)
    th = theta_in_rad - theta_in_rad[0]
    n_blocks = int(math.floor(th[-1] / (2 * math.pi * revs_per_block) + 1e-9))
    m = samples_per_rev * revs_per_block
    amps, tm, rpm = [], [], []
    for i in range(n_blocks):
        grid = 2 * math.pi * revs_per_block * (i + np.arange(m) / m)
        y = np.interp(grid, th, te_m)
        tb = np.interp(grid[[0, -1]], th, t_s)
        spec = np.fft.rfft(y) / m
        k = np.rint(orders * revs_per_block).astype(np.int64)
        ok = (k >= 1) & (k < spec.size)
        a = np.full(orders.size, np.nan)
        a[ok] = 2 * np.abs(spec[k[ok]])
        amps.append(a)
        tm.append(float(tb.mean()))
        rpm.append(revs_per_block * 60.0 / float(tb[1] - tb[0]) * (m - 1) / m)
    return {"t_s": tm, "rpm_in": rpm, "orders": orders.tolist(),
            "amplitude_m": np.array(amps).reshape(len(amps), orders.size).tolist()}
