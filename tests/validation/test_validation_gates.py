"""Reference gates and noise floor of a TE window (gearrom.validation.gates) on signals of known content.

References (exact for a window of whole mesh periods sampled uniformly in angle):
* the Fourier lines at integer mesh orders are orthogonal to all other lines: a mean plus harmonics
  is all periodic (non-periodic share 0), and a sinusoid between two orders is all non-periodic; a
  harmonic above the judged orders 1-20 (mesh order 40, e.g. the flank facets' passing) is periodic too
  and adds nothing to the non-periodic share, while it stays out of the judged DTE RMS;
* a linear drift ``s t`` changes the per-period means by ``s`` per period: drift = s (n - 1) periods;
* white noise of standard deviation sigma has spectrum lines ``2 |X_k| / N`` of RMS ``2 sigma / sqrt(N)``
  (Parseval), which is the noise floor (3 % sampling tolerance over ~1000 lines).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearrom.errors import ModelError
from gearrom.validation.gates import noise_floor, nonperiodic_rest, periodic_split, record_gates

Z1 = 32
PERIODS = 10
PER = 128


def _theta():
    return np.arange(PERIODS * PER) * (2 * math.pi / Z1) / PER


def test_harmonics_are_periodic_and_an_in_between_tone_is_not():
    th = _theta()
    per = 5e-6 + 1e-6 * np.cos(Z1 * th + 0.3) + 0.4e-6 * np.cos(2 * Z1 * th - 1.0) + 0.1e-6 * np.sin(17 * Z1 * th)
    tone = 0.2e-6 * np.cos(6.5 * Z1 * th)                      # between orders 6 and 7
    p, rest = periodic_split(th, per + tone, Z1)
    assert np.allclose(p, per, atol=1e-15)
    assert np.allclose(rest, tone, atol=1e-15)
    g = record_gates(th, per + tone, Z1)
    dte_rms = math.sqrt((1 + 0.16 + 0.01) / 2) * 1e-6
    assert g["nonperiodic_share"] == pytest.approx(0.2e-6 / math.sqrt(2) / dte_rms, rel=1e-9)
    assert g["periodic_dte_rms_um"] == pytest.approx(dte_rms * 1e6, rel=1e-9)
    assert g["failed"] == ["nonperiodic_share"]          # 0.1 / 0.77 = 13 % > 10 %
    assert record_gates(th, per, Z1)["passed"]


def test_mesh_orders_above_the_judged_ones_are_periodic():
    th = _theta()
    judged = 1e-6 * np.cos(Z1 * th + 0.3)
    high = 0.5e-6 * np.cos(40 * Z1 * th - 0.7)                 # mesh order 40
    tone = 0.05e-6 * np.cos(6.5 * Z1 * th)
    rest = nonperiodic_rest(th, judged + high + tone, Z1)
    assert np.allclose(rest, tone, atol=1e-15)
    g = record_gates(th, judged + high + tone, Z1)
    assert g["periodic_dte_rms_um"] == pytest.approx(1 / math.sqrt(2), rel=1e-9)
    assert g["nonperiodic_share"] == pytest.approx(0.05, rel=1e-9)
    assert g["passed"]


def test_drift_and_energy_gates():
    th = _theta()
    t = th / th[1] * 1e-5                                   # uniform time
    slope = 0.05e-6 / (PER * 1e-5)                         # 0.05 um per mesh period
    x = 1e-6 * np.cos(Z1 * th) + slope * t
    g = record_gates(th, x, Z1)
    assert g["drift_um"] == pytest.approx(0.05 * (PERIODS - 1), rel=1e-6)
    assert "drift_rel_gmf1" in g["failed"]
    e = {"internal": np.array([0.0, 1.0, 2.0]), "contact": np.array([0.0, 0.5, 1.0]),
         "balance_error": np.array([0.0, -0.02, 0.01])}
    g = record_gates(th, 1e-6 * np.cos(Z1 * th), Z1, energies=e)
    assert g["energy_error_rel"] == pytest.approx(0.02 / 3.0)
    assert g["passed"]
    e["balance_error"] = np.array([0.0, 0.05, 0.0])
    assert record_gates(th, 1e-6 * np.cos(Z1 * th), Z1, energies=e)["failed"] == ["energy_error_rel"]


def test_noise_floor_of_white_noise():
    th = _theta()
    rng = np.random.default_rng(1)
    sigma = 0.3e-6
    x = 1e-6 * np.cos(Z1 * th) + rng.normal(0, sigma, th.size)
    floor = noise_floor(th, x, Z1, max_order=PER / 2)
    assert floor == pytest.approx(2 * sigma / math.sqrt(th.size), rel=0.03)


def test_window_must_hold_whole_periods():
    th = _theta()[:-5]
    with pytest.raises(ModelError, match="whole number"):
        record_gates(th, np.cos(Z1 * th), Z1)
