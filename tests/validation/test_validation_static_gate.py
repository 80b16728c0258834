"""Static consistency gate (gearrom.validation.static_gate) on curves of known content.

Reference: a linear mesh of stiffness k with a kinematic part e0(theta) has the static TE
TE(theta, T) = e0(theta) + T / (r_b2 k); the gate's stiffness between two torques must return k
exactly, and its GMF amplitudes the cosine amplitudes put in (16 points per period: exact to order 7).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearrom.errors import ModelError
from gearrom.validation.static_gate import curve_metrics, static_gate

RB2 = 0.03
K = 420e6
TH = np.arange(16) * 2 * math.pi / 16


def _curves(k=K, gmf1=0.8e-6, scale=1.0):
    return {t: scale * (t / RB2 / k + gmf1 * np.cos(TH + 0.4) + 0.2e-6 * np.cos(2 * TH) + 0.1e-6 * np.cos(3 * TH))
            for t in (60.0, 120.0)}


def test_metrics_and_stiffness_of_a_linear_mesh():
    m = curve_metrics(_curves()[120.0])
    assert m["gmf1"] == pytest.approx(0.8e-6, rel=1e-12)
    assert m["gmf3"] == pytest.approx(0.1e-6, rel=1e-12)
    g = static_gate(_curves(), _curves(), RB2)
    assert g["passed"] and not g["misses"]
    assert g["stiffness_N_per_um"]["fe"] == pytest.approx(K * 1e-6, rel=1e-12)


def test_each_limit_can_fail():
    g = static_gate(_curves(k=K / 1.05), _curves(), RB2)           # 5 % softer: mean TE and stiffness miss
    assert not g["passed"]
    assert any("mean_te" in m for m in g["misses"]) and any("stiffness" in m for m in g["misses"])
    g = static_gate(_curves(gmf1=0.9e-6), _curves(), RB2)          # GMF1 +12.5 %
    assert any("gmf1" in m for m in g["misses"]) and not any("stiffness" in m for m in g["misses"])
    helical = static_gate(_curves(gmf1=0.9e-6), _curves(), RB2, helical=True)   # GMF not judged on helical pairs
    assert helical["passed"]


def test_mismatched_inputs_are_refused():
    with pytest.raises(ModelError, match="same >= 2 torques"):
        static_gate({60.0: np.zeros(16)}, {60.0: np.zeros(16)}, RB2)
