"""TE metrics on a steady window and the ROM-vs-FE comparison with the validation tolerances.

All angles are the *input-gear* angle measured from a common origin (the explicit FE's start
position), so that phases of the ROM and the FE refer to the same gear position. A mesh order ``m``
is the harmonic ``A_m cos(m z1 theta_in + phi_m)`` of the TE over the input angle; ``A_m`` is the
zero-to-peak amplitude.
"""
from __future__ import annotations

import math

import numpy as np

from gearrom.errors import ModelError
from gearrom.spectral import line_coefficients

__all__ = ["TOLERANCES", "steady_window", "te_metrics", "compare_metrics"]

#: Acceptance (never loosened): relative errors of the mesh-periodic DTE RMS (mesh orders 1-20) and of
#: the GMF amplitudes, and the GMF1 phase error in degrees.
TOLERANCES = {"dte_periodic_rms_um": 0.10, "gmf1_amplitude_um": 0.10, "gmf2_amplitude_um": 0.20,
              "gmf3_amplitude_um": 0.20, "gmf1_phase_deg": 15.0}
#: orders of the mesh-periodic DTE
PERIODIC_ORDERS = 20


def steady_window(theta_in: np.ndarray, t: np.ndarray, t_from: float, z1: int) -> np.ndarray:
    """Boolean mask of the largest whole number of mesh periods (in input angle) at the end of the
    record that starts at or after ``t_from`` [s]."""
    theta_in = np.asarray(theta_in, float)
    period = 2 * math.pi / z1
    ok = np.asarray(t) >= t_from
    if ok.sum() < 8:
        raise ModelError(f"steady window from t = {t_from:.4g} s holds fewer than 8 samples")
    th = theta_in[ok]
    step = float(np.median(np.diff(th)))
    a, b = th[0], th[-1]
    # samples a, a + step, ..., b cover (b - a + step): a whole number n of periods, half-open
    n = math.floor((b - a + step) / period + 1e-6)
    if n < 1:
        raise ModelError(f"steady window from t = {t_from:.4g} s is shorter than one mesh period")
    start = b + step - n * period
    return ok & (theta_in >= start - 0.5 * step) & (theta_in <= b + 0.5 * step)


def te_metrics(theta_in: np.ndarray, te: np.ndarray, z1: int, orders: int = 3) -> dict:
    """Mean TE, DTE peak-to-peak and RMS (mean removed) and the GMF harmonics of one record.

    Parameters
    ----------
    theta_in : ndarray
        Input angle of each sample [rad], uniformly spaced over a whole number of mesh periods.
    te : ndarray
        Transmission error [m].
    z1 : int
        Input teeth.
    orders : int
        Mesh orders 1..orders.

    Returns
    -------
    dict with ``te_mean_um``, ``dte_ptp_um``, ``dte_rms_um``, ``dte_periodic_rms_um`` (mesh orders 1-20 only,
    :func:`gearrom.validation.gates.periodic_split`), ``gmf{m}_amplitude_um``,
    ``gmf{m}_phase_deg`` (te ~ A cos(m z1 theta_in + phase)) and ``mesh_periods``.
    """
    th = np.asarray(theta_in, float)
    x = np.asarray(te, float)
    if th.shape != x.shape or th.ndim != 1 or th.size < 8:
        raise ModelError(f"te_metrics needs matching 1-D theta/te with >= 8 samples, got {th.shape} and {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ModelError("te_metrics: TE record contains non-finite values")
    step = np.diff(th)
    if np.ptp(step) > 1e-3 * abs(step.mean()):
        raise ModelError("te_metrics: samples must be uniform in the input angle (constant speed)")
    periods = (th.size * step.mean()) * z1 / (2 * math.pi)
    if abs(periods - round(periods)) > 1e-3 or round(periods) < 1:
        raise ModelError(f"te_metrics: the record spans {periods:.4f} mesh periods, not a whole number")
    from gearrom.validation.gates import periodic_split

    d = x - x.mean()
    per = periodic_split(th, x, z1, PERIODIC_ORDERS)[0] - x.mean()
    out = {"te_mean_um": x.mean() * 1e6, "dte_ptp_um": float(np.ptp(x)) * 1e6,
           "dte_rms_um": float(np.sqrt(np.mean(d * d))) * 1e6,
           "dte_periodic_rms_um": float(np.sqrt(np.mean(per * per))) * 1e6, "mesh_periods": int(round(periods))}
    for m, c in zip(range(1, orders + 1), line_coefficients(x, z1 * th, range(1, orders + 1))):
        out[f"gmf{m}_amplitude_um"] = float(abs(c)) * 1e6
        out[f"gmf{m}_phase_deg"] = float(np.degrees(np.angle(c)))
    return {k: float(v) if k != "mesh_periods" else v for k, v in out.items()}


def _wrap_deg(a: float) -> float:
    return float((a + 180.0) % 360.0 - 180.0)


def compare_metrics(rom: dict, fe: dict, orders: int = 3, floor_um: float | None = None) -> tuple[dict, bool, list[str]]:
    """Side-by-side metrics with relative errors (``(rom - fe) / |fe|``) and the verdict of :data:`TOLERANCES`.

    ``floor_um``: the FE record's noise floor (:func:`gearrom.validation.gates.noise_floor`); a GMF line
    of the FE below ``FLOOR_FACTOR`` times it is marked ``below_floor`` and neither its amplitude nor its
    phase is judged.

    Returns ``(metrics, passed, misses)``; ``misses`` explains each failed tolerance and by how much.
    """
    from gearrom.validation.gates import FLOOR_FACTOR

    metrics: dict = {}
    for key in ["te_mean_um", "dte_ptp_um", "dte_rms_um", "dte_periodic_rms_um"] + [f"gmf{m}_amplitude_um" for m in range(1, orders + 1)]:
        r, f = rom[key], fe[key]
        metrics[key] = {"rom": r, "fe": f, "rel_error": (r - f) / abs(f) if f != 0 else float("inf")}
    for m in range(1, orders + 1):
        key = f"gmf{m}_phase_deg"
        metrics[key] = {"rom": rom[key], "fe": fe[key], "error_deg": _wrap_deg(rom[key] - fe[key])}
    below = set()
    if floor_um is not None:
        for m in range(1, orders + 1):
            if fe[f"gmf{m}_amplitude_um"] < FLOOR_FACTOR * floor_um:
                below |= {f"gmf{m}_amplitude_um", f"gmf{m}_phase_deg"}
                metrics[f"gmf{m}_amplitude_um"]["below_floor"] = True
    misses = []
    for key, tol in TOLERANCES.items():
        if key in below:
            continue
        if key.endswith("phase_deg"):
            err = abs(metrics[key]["error_deg"])
            if not err <= tol:
                misses.append(f"{key}: error {err:.1f} deg > {tol:g} deg (by {err - tol:.1f} deg)")
        else:
            err = abs(metrics[key]["rel_error"])
            if not err <= tol:
                misses.append(f"{key}: |rel_error| {100 * err:.1f} % > {100 * tol:g} % (by {100 * (err - tol):.1f} points)")
    return metrics, not misses, misses
