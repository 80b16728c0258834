"""The bundled example measurements read and give their known TE (README.md in the examples folder)."""
from __future__ import annotations

from importlib import resources

import pytest

from gearrom.signal import process_measurement

EXAMPLES = resources.files("gearrom") / "data" / "examples" / "measurements"


def test_edges_example():
    """1024 edges/rev: GMF line 5 um within 1 %; the 3rd harmonic (10.7 edges per period) reads low by about
    (2 pi/10.7)^2/12 = 2.9 % from the linear interpolation between edges, so 5 % is allowed there."""
    res = process_measurement(EXAMPLES / "sim_1250rpm_edges.json")
    amps = [a * 1e6 for a, _ in res.gmf_lines()]
    assert amps[0] == pytest.approx(5.0, rel=0.01) and amps[2] == pytest.approx(1.0, rel=0.05)
    assert res.mesh.name == "thesis-helical" and res.gmf_hz == pytest.approx(666.67, rel=1e-4)


def test_angles_example():
    res = process_measurement(EXAMPLES / "sim_60rpm_angles.json")
    assert [a * 1e6 for a, _ in res.gmf_lines()] == pytest.approx([5.0, 2.0, 1.0], rel=0.01)
