"""A plane-strain cantilever strip with its first Euler-Bernoulli bending mode as initial velocity.

Reference: f1 = (beta1 L)^2 / (2 pi L^2) sqrt(E' I / (rho A)), beta1 L = 1.87510407, E' = E / (1 - nu^2)
for cylindrical bending of a wide plate (Timoshenko & Woinowsky-Krieger, Theory of Plates and Shells, sec. 1).
"""
from __future__ import annotations

import numpy as np

from gearrom.fe.explicit import Material
from gearrom.fe.explicit.meshes import rectangle_q4

L, H = 0.25, 0.01
BL = 1.8751040687


def cantilever_strip(nx: int, ny: int, mat: Material = Material()):
    """(nodes, elements, clamp node ids, tip node id, initial velocity (n, 2), f1 Euler-Bernoulli [Hz])."""
    nodes, elements = rectangle_q4(L, H, nx, ny, y0=-H / 2)
    e_plane = mat.E / (1 - mat.nu ** 2)
    f_eb = BL ** 2 / (2 * np.pi * L ** 2) * np.sqrt(e_plane * H ** 2 / 12 / mat.rho)
    x = nodes[:, 0] / L
    shape = (np.cosh(BL * x) - np.cos(BL * x)
             - (np.cosh(BL) + np.cos(BL)) / (np.sinh(BL) + np.sin(BL)) * (np.sinh(BL * x) - np.sin(BL * x)))
    v0 = np.zeros_like(nodes)
    v0[:, 1] = 0.5 * shape / shape.max()
    clamp = np.nonzero(nodes[:, 0] < 1e-12)[0]
    tip = int(np.argmin(np.abs(nodes[:, 0] - L) + np.abs(nodes[:, 1])))
    return nodes, elements, clamp, tip, v0, f_eb
