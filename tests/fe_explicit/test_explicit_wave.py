"""Longitudinal wave in a bar: pulse speed vs the analytic bar speed c = sqrt(E / rho).

Reference: 1D wave equation. With nu = 0 the plane-strain P-wave modulus lambda + 2 mu equals E and
the lateral surfaces carry no Poisson coupling, so a long Q4 (plane strain) or Hex8 bar carries a
non-dispersive pulse at c = sqrt(E / rho) (Graff, Wave Motion in Elastic Solids, sec. 2.1). The
pulse is 20 elements long, for which the lumped-mass central-difference dispersion error of the
group velocity is well below 1 % (Belytschko & Mullen 1978); tolerance 1 %.
The speed is measured by cross-correlating the velocity histories of two stations 0.5 m apart.
"""
from __future__ import annotations

import numpy as np
import pytest

from gearrom.fe.explicit import ExplicitModel, Material, NodalLoad, solve, stable_dt
from gearrom.fe.explicit.meshes import box_hex8, rectangle_q4

MAT = Material(E=210e9, nu=0.0, rho=7850.0)
C_BAR = np.sqrt(MAT.E / MAT.rho)


def _pulse(nodes, length, n_el, dim):
    left = np.nonzero(nodes[:, 0] < 1e-12)[0]
    duration = 20 * length / n_el / C_BAR
    s = np.linspace(0, 1, 21)
    force = (1e3,) + (0.0,) * (dim - 1)
    return left, NodalLoad("left", force, times=tuple(s * duration), factors=tuple(np.sin(np.pi * s) ** 2))


def _measured_speed(nodes, result, x1, x2):
    v1 = result.probe_v[:, 0, 0]
    v2 = result.probe_v[:, 1, 0]
    n = v1.size
    cc = np.correlate(v2, v1, "full")
    k = int(np.argmax(cc))
    # parabolic refinement of the correlation peak
    y0, y1, y2 = cc[k - 1], cc[k], cc[k + 1]
    frac = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    lag = (k - (n - 1) + frac) * (result.t[1] - result.t[0])
    return (x2 - x1) / lag


def _probes(nodes, xs):
    return [int(np.argmin(np.abs(nodes[:, 0] - x) + np.abs(nodes[:, 1:]).sum(axis=1))) for x in xs]


@pytest.mark.parametrize("integration", ["reduced", "full"])
def test_q4_bar_wave_speed(integration):
    length, n_el = 1.0, 400
    nodes, elements = rectangle_q4(length, 0.01, n_el, 2)
    left, load = _pulse(nodes, length, n_el, 2)
    model = ExplicitModel(nodes, elements, MAT, thickness=0.01, node_sets={"left": left}, loads=(load,),
                          integration=integration)
    probes = _probes(nodes, (0.25, 0.75))
    res = solve(model, 0.9 * length / C_BAR, sample_period=2 * stable_dt(model), probes=probes)
    c = _measured_speed(nodes, res, 0.25, 0.75)
    assert abs(c / C_BAR - 1) < 0.01, (c, C_BAR)
    assert res.energy_error < 1e-2   # O((omega dt)^2) fluctuation of the discrete energy at Courant ~0.9


@pytest.mark.parametrize("integration", ["reduced", "full"])
def test_hex8_bar_wave_speed(integration):
    length, n_el = 0.6, 200
    nodes, elements = box_hex8(length, 0.006, 0.006, n_el, 2, 2)
    left, load = _pulse(nodes, length, n_el, 3)
    model = ExplicitModel(nodes, elements, MAT, node_sets={"left": left}, loads=(load,), integration=integration)
    probes = _probes(nodes, (0.15, 0.45))
    res = solve(model, 0.9 * length / C_BAR, sample_period=2 * stable_dt(model), probes=probes)
    c = _measured_speed(nodes, res, 0.15, 0.45)
    assert abs(c / C_BAR - 1) < 0.01, (c, C_BAR)
    assert res.energy_error < 1e-2   # O((omega dt)^2) fluctuation of the discrete energy at Courant ~0.9
