"""Local contact machinery against Hertz, and the contact solver against closed-form cases.

Reference: K. L. Johnson, Contact Mechanics (1985), eqs. 4.43-4.45 (2D cylinders in line contact):
b = sqrt(4 w R* / (pi E*)), p0 = 2 w / (pi b) with 1/E* = sum (1 - nu^2)/E, 1/R* = 1/R1 + 1/R2.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearrom.errors import MeshError, SolverError
from gearrom.fe.compliance import patch_operator
from gearrom.fe.contact import solve_contact
from gearrom.fe.elastic import ElasticBody2D
from gearrom.fe.mesh2d import MeshSettings, disk_mesh

E, NU, B, R = 210e9, 0.3, 18e-3, 8e-3


def test_hertz_two_disks_within_3_percent():
    """Two equal disks (R = 8 mm, bore clamped) under the spur pair's line load 225 N/mm:
    the same mesh + patch influence + active-set machinery as the gears."""
    h = 0.02e-3
    m = disk_mesh(R, R / 2, h, 1e-3, 0.4e-3)
    body = ElasticBody2D(m, E, NU, B)
    ang = np.arctan2(m.points[:, 1], m.points[:, 0])
    sig = np.arange(-30, 31) * h
    P = patch_operator(body, m.curves["contact"], ang, lambda s: math.pi / 2 - s / R, sig, h, -0.4e-3, 0.4e-3)
    G = P.T @ body.solve(P)
    C = G + G.T  # two identical bodies (symmetrised)
    w = 225e3
    sol = solve_contact(C, sig**2 / R, w * B)  # gap s^2/(2 R*) with R* = R/2
    mean = np.sum(sol.f * sig) / (w * B)
    b = 2 * math.sqrt(np.sum(sol.f * sig**2) / (w * B) - mean**2)  # elliptic: <x^2> = b^2/4
    p_max = sol.f.max() / (h * B)
    E_star = E / (2 * (1 - NU**2))
    b_ref = math.sqrt(4 * w * (R / 2) / (math.pi * E_star))
    p_ref = 2 * w / (math.pi * b_ref)
    assert b == pytest.approx(b_ref, rel=0.03)
    assert p_max == pytest.approx(p_ref, rel=0.03)


def test_contact_solver_two_springs():
    """Two independent springs (C diagonal) with gaps 0 and g: closed form by hand."""
    c1, c2, g, F = 1e-9, 2e-9, 1e-6, 3000.0
    sol = solve_contact(np.diag([c1, c2]), np.array([0.0, g]), F)
    # both in contact: c1 f1 = g + c2 f2 = delta, f1 + f2 = F
    f2 = (c1 * F - g) / (c1 + c2)
    assert sol.f[1] == pytest.approx(f2, rel=1e-9)
    assert sol.delta == pytest.approx(c1 * (F - f2), rel=1e-9)
    sol = solve_contact(np.diag([c1, c2]), np.array([0.0, g]), 500.0)  # c1 F < g: one spring only
    assert sol.f[1] == 0 and sol.delta == pytest.approx(c1 * 500.0)


def test_contact_errors_are_clear():
    with pytest.raises(SolverError, match="contact not found"):
        solve_contact(np.zeros((0, 0)), np.zeros(0), 1.0, where=" at theta = 1 deg")
    with pytest.raises(SolverError, match="force must be positive"):
        solve_contact(np.eye(2), np.zeros(2), -1.0)


def test_mesh_settings_validation_names_field():
    with pytest.raises(MeshError, match="flank_size"):
        MeshSettings(flank_size=-1.0)
    with pytest.raises(MeshError, match="flank_size <= tooth_size"):
        MeshSettings(flank_size=1e-3, tooth_size=0.5e-3)


def test_degenerate_triangles_are_reported():
    from gearrom.fe.mesh2d import Mesh2D

    mesh = Mesh2D(points=np.array([[0, 0], [1, 0], [2, 1e-9]], float), triangles=np.array([[0, 1, 2]]))
    with pytest.raises(MeshError, match="degenerate"):
        mesh.check()
