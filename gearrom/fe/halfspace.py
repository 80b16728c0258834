"""Elastic half-space (Boussinesq) compliances: the analytical near field of the 3D contact model.

References: Boussinesq's point load on a half-space (Johnson, Contact Mechanics, 1985, eq. 3.21):
normal displacement at depth ``h`` below the surface and distance ``R`` from the load point

    u_n = P (1 + nu) / (2 pi E) [2 (1 - nu) / R + h^2 / R^3],

which reduces to ``P (1 - nu^2) / (pi E rho)`` on the surface; Love (1929) integrated it over a
uniformly loaded rectangle in closed form (Johnson eq. 3.25).
"""
from __future__ import annotations

import math

import numpy as np


def _F(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Antiderivative of 1/sqrt(X^2 + Y^2) in X and Y: X ln(Y + R) + Y ln(X + R) (0 ln 0 = 0)."""
    R = np.hypot(X, Y)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(X != 0, X * np.log(np.maximum(Y + R, 1e-300)), 0.0)
        b = np.where(Y != 0, Y * np.log(np.maximum(X + R, 1e-300)), 0.0)
    return a + b


def rect_surface(dx, dy, half_x: float, half_y: float) -> np.ndarray:
    """Geometric part of the surface normal displacement at ``(dx, dy)`` from the centre of a
    rectangle ``2 half_x x 2 half_y`` carrying a unit total force as uniform pressure [1/m].

    Multiply by (1 - nu^2) / (pi E) for the displacement per newton [m/N] (Love 1929).
    """
    dx, dy = np.asarray(dx, float), np.asarray(dy, float)
    a, b = half_x, half_y
    I = _F(dx + a, dy + b) - _F(dx + a, dy - b) - _F(dx - a, dy + b) + _F(dx - a, dy - b)
    return I / (4 * a * b)


def point_depth_kernel(Xq: np.ndarray, wq: np.ndarray, Y: np.ndarray, N: np.ndarray, depth: np.ndarray,
                       E: float, nu: float) -> np.ndarray:
    """Half-space normal displacement at depth points from patch loads given by quadrature points.

    Parameters
    ----------
    Xq : ndarray (n, m, 3)
        Quadrature points (on the surface) of ``n`` patch loads [m].
    wq : ndarray (n, m)
        Force fractions (sum 1 per patch) [-].
    Y : ndarray (k, 3)
        Read-out points below the surface [m].
    N : ndarray (k, 3)
        Outward unit normals at the read-out points (the half-space's normal).
    depth : ndarray (k,)
        Depth of each read-out point [m] (``Y = X - depth N``).
    E, nu : float

    Returns
    -------
    ndarray (n, k)
        Inward normal displacement per newton of each patch load [m/N].
    """
    D = Xq[:, :, None, :] - Y[None, None, :, :]  # (n, m, k, 3)
    R = np.linalg.norm(D, axis=-1)
    h = np.einsum("nmkc,kc->nmk", D, N)
    h = np.where(h > 0, h, depth[None, None, :])
    K = (1 + nu) / (2 * math.pi * E) * (2 * (1 - nu) / R + h**2 / R**3)
    return np.einsum("nm,nmk->nk", wq, K)
