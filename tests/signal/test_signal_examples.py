"""The bundled example measurements read and give their known TE (README.md in the examples folder)."""
from __future__ import annotations

from importlib import resources

import pytest

from gearrom.signal import process_measurement

EXAMPLES = resources.files("gearrom") / "data" / "examples" / "measurements"


def test_edges_example():
    """1024 edges/rev, cubic interpolation between edges: harmonics 5, 2, 1 um within 1 %."""
    res = process_measurement(EXAMPLES / "sim_1250rpm_edges.json")
    assert [a * 1e6 for a, _ in res.gmf_lines()] == pytest.approx([5.0, 2.0, 1.0], rel=0.01)
    assert res.mesh.name == "thesis-helical" and res.gmf_hz == pytest.approx(666.67, rel=1e-4)


def test_angles_example():
    res = process_measurement(EXAMPLES / "sim_60rpm_angles.json")
    assert [a * 1e6 for a, _ in res.gmf_lines()] == pytest.approx([5.0, 2.0, 1.0], rel=0.01)
