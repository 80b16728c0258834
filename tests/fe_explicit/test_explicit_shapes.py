"""Shared gradient shapes of rotated element copies (geometry.congruent_shapes) and the kernels that read them.

References: the number of distinct shapes follows from how the meshes are built (an annulus of ``nr`` rings
repeats one shape per ring around the circle and, extruded with a constant twist and layer height, along the
axis); the forces and energies are checked against the same kernels fed with each element's own gradients
(``full_integration_data``, the form checked against the assembled stiffness in ``test_static3d``).
"""
from __future__ import annotations

import numpy as np
import pytest

from gearrom.fe.explicit.geometry import congruent_shapes, full_integration_data
from gearrom.fe.explicit.kernels import hex8_full_element, q4_full_element
from gearrom.fe.explicit.meshes import annulus_q4

LAM, MU = 1.15e11, 7.7e10


def _twisted_ring(nr: int, nt: int, nz: int, twist: float, dz: float):
    """Hex8 annulus (r 20-35 mm, centre off the origin) extruded in ``nz`` layers, each turned by ``twist``."""
    nodes2, quads, _, _ = annulus_q4(0.02, 0.035, nr, nt, center=(0.0, 0.0))
    layers = []
    for k in range(nz + 1):
        c, s = np.cos(k * twist), np.sin(k * twist)
        xy = nodes2 @ np.array([[c, s], [-s, c]])
        layers.append(np.column_stack([xy[:, 0] + 0.11, xy[:, 1] - 0.03, np.full(len(xy), k * dz)]))
    nodes = np.concatenate(layers)
    m = len(nodes2)
    hexes = np.concatenate([np.column_stack([quads + k * m, quads + (k + 1) * m]) for k in range(nz)])
    return nodes, hexes


def _forces(kernel, X, conn, u, Bg, Wg, shape, rot):
    f = np.zeros_like(X)
    w = sum(kernel(e, conn, u, Bg, Wg, shape, rot, LAM, MU, f) for e in range(len(conn)))
    return f, w


def _own(conn):
    return np.arange(len(conn)), np.tile([1.0, 0.0], (len(conn), 1))


@pytest.mark.parametrize("rtol", [1e-9, -1.0])
def test_hex8_twisted_ring_one_shape_per_ring(rtol):
    """A helically twisted Hex8 annulus of 3 rings, 24 sectors and 4 layers holds 3 shapes; its forces and energy
    from the shape table equal those from each element's own gradients. ``rtol`` < 0 makes every element fail
    the member check: each keeps its own gradients and the forces still agree."""
    X, conn = _twisted_ring(3, 24, 4, np.radians(2.0), 2.5e-3)
    Bg, Wg = full_integration_data(X, conn)
    tb, tw, shape, rot = congruent_shapes(X, conn, Bg, Wg, rtol=rtol)
    assert len(tb) == (3 if rtol > 0 else len(conn))
    assert np.allclose(rot[:, 0] ** 2 + rot[:, 1] ** 2, 1.0)
    u = np.random.default_rng(1).standard_normal(X.shape) * 2e-5          # strains of order 1e-3, nonlinear
    f_ref, w_ref = _forces(hex8_full_element, X, conn, u, Bg, Wg, *_own(conn))
    f, w = _forces(hex8_full_element, X, conn, u, tb, tw, shape, rot)
    assert np.abs(f - f_ref).max() < 1e-10 * np.abs(f_ref).max()
    assert w == pytest.approx(w_ref, rel=1e-10)


def test_q4_annulus_one_shape_per_ring():
    """A Q4 annulus of 4 rings and 30 sectors, centred off the origin, holds 4 shapes; same forces and energy."""
    X, conn, _, _ = annulus_q4(0.01, 0.03, 4, 30, center=(0.07, -0.02))
    Bg, Wg = full_integration_data(X, conn, 0.01)
    tb, tw, shape, rot = congruent_shapes(X, conn, Bg, Wg)
    assert len(tb) == 4
    u = np.random.default_rng(2).standard_normal(X.shape) * 1e-5
    f_ref, w_ref = _forces(q4_full_element, X, conn, u, Bg, Wg, *_own(conn))
    f, w = _forces(q4_full_element, X, conn, u, tb, tw, shape, rot)
    assert np.abs(f - f_ref).max() < 1e-10 * np.abs(f_ref).max()
    assert w == pytest.approx(w_ref, rel=1e-10)


def test_distorted_mesh_keeps_every_shape():
    """Randomly perturbed nodes: no two elements are copies, every element is its own shape."""
    X, conn = _twisted_ring(2, 12, 2, 0.0, 4e-3)
    X = X + np.random.default_rng(3).uniform(-2e-4, 2e-4, X.shape)
    Bg, Wg = full_integration_data(X, conn)
    tb, tw, shape, rot = congruent_shapes(X, conn, Bg, Wg)
    assert len(tb) == len(conn) and len(np.unique(shape)) == len(conn)
    u = np.random.default_rng(4).standard_normal(X.shape) * 1e-5
    f_ref, _ = _forces(hex8_full_element, X, conn, u, Bg, Wg, *_own(conn))
    f, _ = _forces(hex8_full_element, X, conn, u, tb, tw, shape, rot)
    assert np.abs(f - f_ref).max() < 1e-10 * np.abs(f_ref).max()


@pytest.mark.parametrize("dim", [2, 3])
def test_large_rigid_rotation_leaves_no_strain(dim):
    """A ring centred 0.11 m off the origin turned rigidly by 3 rad about the origin (the displacements reach
    0.2 m): exact kinematics give F = Q, E = 0, no energy and no force. Through the prepared table the energy
    stays below 1e-12 of the ring's energy under a uniform 1e-3 stretch and the forces below 1e-9 of the
    forces of that stretch."""
    if dim == 3:
        X, conn = _twisted_ring(3, 24, 4, np.radians(2.0), 2.5e-3)
        kernel, thickness = hex8_full_element, ()
    else:
        X, conn, _, _ = annulus_q4(0.02, 0.035, 3, 24, center=(0.11, -0.03))
        kernel, thickness = q4_full_element, (0.01,)
    Bg, Wg = full_integration_data(X, conn, *thickness)
    table = congruent_shapes(X, conn, Bg, Wg)
    th = 3.0
    Q = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    u = np.zeros_like(X)
    u[:, :2] = X[:, :2] @ Q.T - X[:, :2]
    f_rot, w_rot = _forces(kernel, X, conn, u, *table)
    f_str, w_str = _forces(kernel, X, conn, 1e-3 * (X - X.mean(axis=0)), *table)
    assert w_rot < 1e-12 * w_str
    assert np.abs(f_rot).max() < 1e-9 * np.abs(f_str).max()
