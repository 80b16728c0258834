"""Incremental encoder model: edge times from a simulated shaft angle history.

Disc with ``edges_per_rev`` edges (10000 lines x4 decoding = 40000). The encoder *reads*
``theta = phi + err(phi)`` with ``phi`` the shaft angle at the encoder inertia and
``err = ecc cos(phi + ecc_phase) + line_error[line]`` (eccentricity of the disc, graduation error of
the line, the same for the 4 edges of a line, zero for line 0). Edge n fires when the reading passes
``n 2 pi / edges_per_rev``, i.e. at ``phi = n 2 pi/N - err``; its time is found on the cubic Hermite
interpolant of the history (angle and angular velocity at each step) by Newton's method, then
Gaussian jitter is added and the time is latched by a counter (``floor``) of ``clock_hz``.
The record of a channel starts at its index (the first edge with ``n = 0 mod N`` after ``t_from``):
its first edge is the encoder zero, shaft angle ``2 pi k - err(0)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class EncoderErrors:
    """Errors of one encoder.

    Parameters
    ----------
    ecc_rad : float
        Amplitude of the once-per-rev reading error [rad] (disc eccentricity / disc radius).
    ecc_phase_rad : float
        Phase: error ``ecc_rad cos(phi + ecc_phase_rad)``.
    line_rms_rad : float
        Rms graduation error of a line [rad] (fixed per line, drawn from ``seed``).
    jitter_s : float
        Rms time jitter of each edge [s].
    seed : int
        Seed of the line errors (a property of the disc: the same in every run of a case).
    jitter_seed : int
        Seed of the jitter (differs between runs).
    """

    ecc_rad: float = 0.0
    ecc_phase_rad: float = 0.0
    line_rms_rad: float = 0.0
    jitter_s: float = 0.0
    seed: int = 0
    jitter_seed: int = 1


def hermite_crossings(t: np.ndarray, phi: np.ndarray, omega: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Times at which the increasing history ``phi(t)`` passes ``targets`` (sorted, inside the history).

    Cubic Hermite interpolation between samples (values ``phi``, slopes ``omega``), Newton iteration.
    """
    k = np.clip(np.searchsorted(phi, targets, side="right") - 1, 0, len(t) - 2)
    h = t[k + 1] - t[k]
    p0, p1 = phi[k], phi[k + 1]
    m0, m1 = omega[k] * h, omega[k + 1] * h
    tau = np.clip((targets - p0) / (p1 - p0), 0.0, 1.0)
    for _ in range(6):
        t2, t3 = tau * tau, tau * tau * tau
        val = (2 * t3 - 3 * t2 + 1) * p0 + (t3 - 2 * t2 + tau) * m0 + (-2 * t3 + 3 * t2) * p1 + (t3 - t2) * m1
        der = (6 * t2 - 6 * tau) * p0 + (3 * t2 - 4 * tau + 1) * m0 + (-6 * t2 + 6 * tau) * p1 + (3 * t2 - 2 * tau) * m1
        tau = np.clip(tau - (val - targets) / der, 0.0, 1.0)
    return t[k] + tau * h


def edge_times(t: np.ndarray, phi: np.ndarray, omega: np.ndarray, t_from: float, t_to: float,
               edges_per_rev: int = 40000, err: EncoderErrors = EncoderErrors()) -> np.ndarray:
    """Exact (unquantized) edge times [s] of one channel from its index after ``t_from`` to ``t_to``.

    Parameters
    ----------
    t, phi, omega : ndarray
        History: time [s], shaft angle at the encoder [rad], angular velocity [rad/s].
    t_from, t_to : float
        The record starts at the first index at or after ``t_from`` and ends before ``t_to`` [s].
    edges_per_rev : int
    err : EncoderErrors

    Returns
    -------
    ndarray
        Edge times, edge 0 = the index; jitter included (kept non-decreasing).
    """
    n_ = edges_per_rev
    per_line = 4 if n_ % 4 == 0 else 1  # x4 decoding: the 4 edges of a line share its error
    lines = np.random.default_rng(err.seed).normal(0.0, err.line_rms_rad, n_ // per_line)
    lines[0] = 0.0
    step = 2 * math.pi / n_

    def target(n: np.ndarray) -> np.ndarray:
        nominal = n * step - lines[(n % n_) // per_line]
        phi_n = nominal.copy()
        for _ in range(2):  # phi + ecc cos(phi + phase) = nominal (fixed point, ecc << 1)
            phi_n = nominal - err.ecc_rad * np.cos(phi_n + err.ecc_phase_rad)
        return phi_n

    phi_from = np.interp(t_from, t, phi)
    rev0 = math.ceil((phi_from + err.ecc_rad * math.cos(err.ecc_phase_rad)) / (2 * math.pi))
    if target(np.array([rev0 * n_]))[0] < phi_from:
        rev0 += 1
    n = np.arange(rev0 * n_, int(np.interp(t_to, t, phi) / step) + 2)
    targets = target(n)
    targets = targets[targets < np.interp(t_to, t, phi)]
    times = hermite_crossings(t, phi, omega, targets)
    if err.jitter_s:
        jit = np.random.default_rng(err.jitter_seed).normal(0.0, err.jitter_s, times.size)
        times = np.maximum.accumulate(times + jit)
    return times


def latch(times: np.ndarray, t0: float, clock_hz: float) -> np.ndarray:
    """Counter values ``floor((times - t0) clock_hz)`` (int64) of a counter started at ``t0``."""
    return np.floor((times - t0) * clock_hz).astype(np.int64)
