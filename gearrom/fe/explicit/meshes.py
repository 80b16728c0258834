"""Small structured meshes (rectangle, box, annulus, disk) for tests, benchmarks and examples."""
from __future__ import annotations

import numpy as np

from gearrom.errors import ConfigError


def rectangle_q4(lx: float, ly: float, nx: int, ny: int, x0: float = 0.0, y0: float = 0.0):
    """Structured Q4 mesh of [x0, x0+lx] x [y0, y0+ly]; returns (nodes (n,2), elements (ne,4)).

    Node (i, j) has index j * (nx + 1) + i.
    """
    if nx < 1 or ny < 1:
        raise ConfigError(f"rectangle_q4 needs nx, ny >= 1, got {nx}, {ny}")
    xs = np.linspace(x0, x0 + lx, nx + 1)
    ys = np.linspace(y0, y0 + ly, ny + 1)
    X, Y = np.meshgrid(xs, ys)
    nodes = np.column_stack([X.ravel(), Y.ravel()])
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    n0 = (j * (nx + 1) + i).ravel()
    elements = np.column_stack([n0, n0 + 1, n0 + nx + 2, n0 + nx + 1])
    return nodes, elements


def box_hex8(lx: float, ly: float, lz: float, nx: int, ny: int, nz: int):
    """Structured Hex8 mesh of [0,lx] x [0,ly] x [0,lz]; node (i,j,k) = (k (ny+1) + j) (nx+1) + i."""
    if min(nx, ny, nz) < 1:
        raise ConfigError(f"box_hex8 needs nx, ny, nz >= 1, got {nx}, {ny}, {nz}")
    return grid_hex8(np.linspace(0, lx, nx + 1), np.linspace(0, ly, ny + 1), np.linspace(0, lz, nz + 1))


def annulus_q4(r_in: float, r_out: float, nr: int, nt: int, center=(0.0, 0.0)):
    """Q4 mesh of an annulus, ``nr`` radial by ``nt`` circumferential elements.

    Returns (nodes, elements, inner_ids, outer_ids). Node (i radial, j circumferential) = i nt + j.
    """
    if not 0 < r_in < r_out or nr < 1 or nt < 3:
        raise ConfigError("annulus_q4 needs 0 < r_in < r_out, nr >= 1, nt >= 3")
    r = np.linspace(r_in, r_out, nr + 1)
    t = np.linspace(0, 2 * np.pi, nt, endpoint=False)
    R, T = np.meshgrid(r, t, indexing="ij")
    nodes = np.column_stack([center[0] + (R * np.cos(T)).ravel(), center[1] + (R * np.sin(T)).ravel()])
    i, j = np.meshgrid(np.arange(nr), np.arange(nt), indexing="ij")
    i, j = i.ravel(), j.ravel()
    jn = (j + 1) % nt
    elements = np.column_stack([i * nt + j, (i + 1) * nt + j, (i + 1) * nt + jn, i * nt + jn])
    return nodes, elements, np.arange(nt), nr * nt + np.arange(nt)


def graded_coordinates(n: int, length: float, h0: float) -> np.ndarray:
    """``n + 1`` coordinates from 0 to ``length`` with first cell ``h0`` and geometric growth."""
    if not 0 < h0 <= length or n < 1:
        raise ConfigError("graded_coordinates needs 0 < h0 <= length and n >= 1")
    if h0 * n >= length:
        return np.linspace(0.0, length, n + 1)
    lo, hi = 1.0 + 1e-12, 2.0
    while h0 * (hi ** n - 1) / (hi - 1) < length:
        hi *= 2
    for _ in range(200):
        r = 0.5 * (lo + hi)
        if h0 * (r ** n - 1) / (r - 1) < length:
            lo = r
        else:
            hi = r
    x = np.concatenate([[0.0], np.cumsum(h0 * r ** np.arange(n))])
    return x * (length / x[-1])


def grid_hex8(xs: np.ndarray, ys: np.ndarray, zs: np.ndarray):
    """Structured Hex8 mesh on the tensor grid xs x ys x zs (node (i,j,k) = (k ny + j) nx + i)."""
    nx, ny, nz = len(xs) - 1, len(ys) - 1, len(zs) - 1
    Z, Y, X = np.meshgrid(zs, ys, xs, indexing="ij")
    nodes = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    sx, sxy = nx + 1, (nx + 1) * (ny + 1)
    n0 = (k * sxy + j * sx + i).ravel()
    bottom = [n0, n0 + 1, n0 + sx + 1, n0 + sx]
    return nodes, np.column_stack(bottom + [b + sxy for b in bottom])


def quarter_ball_hex8(radius: float, n_xy: int, n_z: int, h_pole: float):
    """Hex8 mesh of the quarter ball x >= 0, y >= 0 (centre at the origin), graded to the south pole.

    A graded tensor grid of the box [0,1] x [0,1] x [-1,1] is mapped to the ball by
    p -> radius p max|p_i| / |p| (cube shells onto spheres, linear along every ray); cells are
    smallest (about ``h_pole``) at the pole (0, 0, -radius). Returns (nodes, elements, surface_ids) where surface_ids are the
    nodes on the spherical surface.
    """
    if not 0 < h_pole < radius:
        raise ConfigError("quarter_ball_hex8 needs 0 < h_pole < radius")
    t = graded_coordinates(n_xy, 1.0, h_pole / radius)
    z = graded_coordinates(n_z, 2.0, h_pole / radius) - 1.0
    p, elements = grid_hex8(t, t, z)
    inf = np.abs(p).max(axis=1)
    nrm = np.linalg.norm(p, axis=1)
    scale = np.divide(inf, nrm, out=np.zeros_like(inf), where=nrm > 0)
    nodes = radius * p * scale[:, None]
    return nodes, elements, np.nonzero(np.isclose(inf, 1.0))[0]
