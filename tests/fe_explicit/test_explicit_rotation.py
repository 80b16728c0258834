"""Rigid-body rotation through a large angle produces no strain (total-Lagrangian kinematics).

Reference: a rigid rotation x = R(theta) X has F = R, Green-Lagrange strain E = (F^T F - I)/2 = 0,
hence zero St Venant-Kirchhoff energy, whatever theta. A small-strain formulation in a fixed frame
would see eps = sym(grad u) = (cos theta - 1) I, i.e. -1.17 at 100 degrees (checked below on the
same displacement field so that the test can discriminate). A free block spun with the rigid
velocity field v = omega z x X keeps rotating rigidly; the only physical strain is the centrifugal
stretch rho omega^2 r^2 / E ~ 1e-8, so the internal energy must stay below 1e-6 of the kinetic
energy and the final nodal positions must match R(omega t) X. Both element integrations (one-point
with hourglass control, and full 2x2 / 2x2x2 Gauss) are checked.
"""
from __future__ import annotations

import numpy as np
import pytest

from gearrom.fe.explicit import ExplicitModel, Material, solve
from gearrom.fe.explicit.geometry import element_geometry
from gearrom.fe.explicit.meshes import box_hex8, rectangle_q4

OMEGA = 10.0          # rad/s
ANGLE = np.radians(100.0)


def _rotate(nodes, theta):
    c, s = np.cos(theta), np.sin(theta)
    out = nodes.copy()
    out[:, 0] = c * nodes[:, 0] - s * nodes[:, 1]
    out[:, 1] = s * nodes[:, 0] + c * nodes[:, 1]
    return out


def _check(nodes, elements, thickness, integration="reduced"):
    nodes = nodes - nodes.mean(axis=0)
    v0 = np.zeros_like(nodes)
    v0[:, 0] = -OMEGA * nodes[:, 1]
    v0[:, 1] = OMEGA * nodes[:, 0]
    model = ExplicitModel(nodes, elements, Material(), thickness=thickness, initial_velocity=v0,
                          integration=integration)
    t_end = ANGLE / OMEGA
    res = solve(model, t_end, sample_period=t_end / 50)
    ke = res.energy("kinetic")
    assert np.all(res.energy("internal") < 1e-6 * ke.max()), res.energy("internal").max() / ke.max()
    assert abs(ke[-1] / ke[0] - 1) < 1e-6
    exact = _rotate(nodes, OMEGA * res.t[-1]) - nodes
    size = np.ptp(nodes, axis=0).max()
    assert np.abs(res.u_final - exact).max() < 1e-5 * size
    # the same field seen by small-strain kinematics would be strongly "strained"
    B, _, _, _ = element_geometry(nodes, elements, thickness)
    grad = np.einsum("eai,eaj->eij", res.u_final[elements], B)
    eps = 0.5 * (grad + np.swapaxes(grad, 1, 2))
    assert abs(eps[:, 0, 0].mean() - (np.cos(OMEGA * res.t[-1]) - 1)) < 1e-3
    return res


@pytest.mark.parametrize("integration", ["reduced", "full"])
def test_q4_rigid_rotation_100deg_no_strain(integration):
    nodes, elements = rectangle_q4(0.1, 0.05, 10, 5)
    _check(nodes, elements, 0.01, integration)


@pytest.mark.parametrize("integration", ["reduced", "full"])
def test_hex8_rigid_rotation_100deg_no_strain(integration):
    nodes, elements = box_hex8(0.1, 0.05, 0.02, 8, 4, 2)
    _check(nodes, elements, 1.0, integration)
