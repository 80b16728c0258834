"""Gates a dynamic TE record must pass before it is a reference, and the noise floor of its spectrum.

A record of a run in steady state repeats every mesh period (the pair's only excitation is the mesh
and everything turns at constant speed). Over a window of whole mesh periods it splits into

* the mesh-periodic part: the mean and the harmonics at every integer mesh order the window resolves
  (the judged DTE is orders 1..20; the higher orders, e.g. the flank facets' passing, are mesh-periodic
  too and belong to no transient);
* the non-periodic rest: start transients, ringing at the mesh mode or other modes, drift.

Gates (a run that fails one is not a reference):

* energy: the largest |balance error| over the run below 1 % of the peak internal energy
  (strain + hourglass + contact): a balance error of the size of the vibration energy would hide
  energy injected or lost at the contact;
* non-periodic share: RMS of the non-periodic rest below 10 % of the judged mesh-periodic DTE RMS
  (orders 1..20);
* drift: the change of the per-period mean TE across the window (least-squares line) below 2 % of the
  GMF1 amplitude (a drift leaks into the first harmonics).

Noise floor: the RMS amplitude of the window's spectrum lines that are not at integer mesh orders
(same scaling as the GMF amplitudes). A harmonic below 3 times the floor is "below floor": it cannot be
told from the non-periodic rest and is reported, not judged.
"""
from __future__ import annotations

import math

import numpy as np

from gearrom.errors import ModelError
from gearrom.spectral import line_amplitudes, line_coefficients, spectrum

__all__ = ["GATES", "periodic_split", "nonperiodic_rest", "noise_floor", "record_gates"]

#: gate limits: energy error / peak internal energy, non-periodic RMS / periodic DTE RMS, drift / GMF1
GATES = {"energy_error_rel": 0.01, "nonperiodic_share": 0.10, "drift_rel_gmf1": 0.02}
#: a harmonic is judged only above this multiple of the noise floor
FLOOR_FACTOR = 3.0


def _periods(theta_in: np.ndarray, z1: int) -> int:
    th = np.asarray(theta_in, float)
    step = float(np.mean(np.diff(th)))
    n = th.size * step * z1 / (2 * math.pi)
    if abs(n - round(n)) > 1e-3 or round(n) < 1:
        raise ModelError(f"the window spans {n:.4f} mesh periods, not a whole number")
    return int(round(n))


def periodic_split(theta_in: np.ndarray, te: np.ndarray, z1: int, orders: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """(mesh-periodic part, non-periodic rest) of a TE window of whole mesh periods, uniform in angle.

    The periodic part is the mean plus the Fourier lines at mesh orders 1..``orders`` (the discrete
    Fourier coefficients over the window at those exact orders: orthogonal to every other line of a
    whole-period window).
    """
    th = np.asarray(theta_in, float)
    x = np.asarray(te, float)
    _periods(th, z1)
    per = np.full_like(x, x.mean())
    for m, c in zip(range(1, orders + 1), line_coefficients(x, z1 * th, range(1, orders + 1))):
        per += np.real(c * np.exp(1j * m * z1 * th))
    return per, x - per


def nonperiodic_rest(theta_in: np.ndarray, te: np.ndarray, z1: int) -> np.ndarray:
    """What no integer mesh order holds: ``te`` less its mean and every integer mesh-order line of the
    window (whole mesh periods, uniform in angle), up to the sampling's Nyquist order."""
    x = np.asarray(te, float)
    n_per = _periods(theta_in, z1)
    spec = np.fft.rfft(x)
    spec[np.arange(spec.size) % n_per == 0] = 0.0
    return np.fft.irfft(spec, x.size)


def noise_floor(theta_in: np.ndarray, te: np.ndarray, z1: int, max_order: float = 20.0) -> float:
    """RMS zero-to-peak amplitude (m) of the window's spectrum lines off the integer mesh orders,
    below ``max_order``."""
    x = np.asarray(te, float)
    n_per = _periods(theta_in, z1)
    spec = spectrum(x - x.mean(), 1.0, "rect").amplitude
    order = np.arange(spec.size) / n_per
    off = (order > 0) & (order <= max_order) & (np.arange(spec.size) % n_per != 0)
    if not off.any():
        raise ModelError("noise floor: the window needs >= 2 mesh periods to have lines between the mesh orders")
    return float(np.sqrt(np.mean(spec[off] ** 2)))


def record_gates(theta_in: np.ndarray, te: np.ndarray, z1: int, energies: dict | None = None) -> dict:
    """Gate values and verdicts of one steady window (``energies``: name -> array over the whole run, J).

    Returns a dict with ``energy_error_rel`` (None without energies), ``nonperiodic_share``,
    ``drift_rel_gmf1``, ``noise_floor_um``, ``passed`` and ``failed`` (names of failed gates).
    """
    th = np.asarray(theta_in, float)
    x = np.asarray(te, float)
    n_per = _periods(th, z1)
    per, _ = periodic_split(th, x, z1)
    rest = nonperiodic_rest(th, x, z1)
    dte = per - x.mean()
    dte_rms = float(np.sqrt(np.mean(dte ** 2)))
    share = float(np.sqrt(np.mean(rest ** 2)) / dte_rms) if dte_rms > 0 else math.inf
    means = x[: (x.size // n_per) * n_per].reshape(n_per, -1).mean(axis=1)
    drift = abs(np.polyfit(np.arange(n_per), means, 1)[0]) * (n_per - 1) if n_per > 1 else 0.0
    gmf1 = float(line_amplitudes(x, z1 * th, (1,))[0])
    out = {"nonperiodic_share": share, "drift_rel_gmf1": drift / gmf1 if gmf1 > 0 else math.inf,
           "drift_um": drift * 1e6, "periodic_dte_rms_um": dte_rms * 1e6, "noise_floor_um": noise_floor(th, x, z1) * 1e6,
           "energy_error_rel": None}
    if energies is not None:
        internal = sum(np.asarray(energies[k], float) for k in ("internal", "hourglass", "contact") if k in energies)
        peak = float(np.max(internal))
        err = float(np.max(np.abs(energies["balance_error"])))
        out["energy_error_rel"] = err / peak if peak > 0 else math.inf
    failed = [k for k, lim in GATES.items() if out[k] is not None and not out[k] < lim]
    out.update(passed=not failed, failed=failed, limits=dict(GATES))
    return out
