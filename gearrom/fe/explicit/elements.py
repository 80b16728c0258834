"""Element types of the explicit solver: each owns its geometry precomputation, its stable-time-step bound
and names the compiled kernel the time loop runs for it.

=============  =====  ==========  ============================================================
type           dim    integration  kernel (:mod:`gearrom.fe.explicit.kernels`)
=============  =====  ==========  ============================================================
``Q4``         2      reduced     :func:`q4_element`: one point, Flanagan-Belytschko hourglass control
``Q4-full``    2      full        :func:`q4_full_element`: 2x2 Gauss points, no hourglass modes
``Hex8``       3      reduced     :func:`hex8_element`: one point, hourglass control
``Hex8-full``  3      full        :func:`hex8_full_element`: 2x2x2 Gauss points
=============  =====  ==========  ============================================================

The compiled loop (:mod:`gearrom.fe.explicit.loop`) dispatches on the model's dimension and the per-element
full-integration flag: numba compiles one loop with the kernels inlined, so a new type adds its kernel there
and its branch in the element loop, and an :class:`ElementType` here with its precomputation.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gearrom.errors import ConfigError
from gearrom.fe.explicit.kernels import hex8_element, hex8_full_element, q4_element, q4_full_element
from gearrom.fe.explicit.geometry import (element_geometry, element_max_eigenvalue, element_max_eigenvalue_full,
                                          full_integration_data, hourglass_coefficients)

__all__ = ["ELEMENT_TYPES", "ElementData", "ElementType", "element_type"]


@dataclass(frozen=True, eq=False)
class ElementData:
    """Per-element arrays the loop needs (``ne`` elements of ``nen`` nodes in ``dim`` dimensions).

    Attributes
    ----------
    B, V0, gamma, me : ndarray
        Mean gradients (1/m), volumes (m^3; 2D: area x thickness), hourglass vectors, row-sum masses per
        unit density (m^3) (:func:`gearrom.fe.explicit.geometry.element_geometry`).
    khg, chg : ndarray
        Hourglass stiffness (N/m) and viscosity (N s/m); zero for fully integrated elements.
    Bg, Wg : ndarray
        Gauss-point gradients and weights of fully integrated elements (placeholders otherwise).
    lam_max : ndarray
        Largest eigenvalue of each element stiffness, N/m: the element's bound of the stable time step.
    full : bool
        Fully integrated.
    """

    B: np.ndarray
    V0: np.ndarray
    gamma: np.ndarray
    me: np.ndarray
    khg: np.ndarray
    chg: np.ndarray
    Bg: np.ndarray
    Wg: np.ndarray
    lam_max: np.ndarray
    full: bool


@dataclass(frozen=True)
class ElementType:
    """An element formulation: its name, dimension, node count, integration and compiled kernel."""

    name: str
    dim: int
    nodes: int
    integration: str
    kernel: Callable

    def precompute(self, X: np.ndarray, conn: np.ndarray, thickness: float, lam: float, mu: float, rho: float,
                   hourglass_stiffness: float, hourglass_viscosity: float) -> ElementData:
        """Geometry, hourglass coefficients and stiffness bounds of the elements ``conn`` on the nodes ``X``."""
        B, V0, gamma, me = element_geometry(X, conn, thickness)
        khg, chg = hourglass_coefficients(B, V0, lam, mu, rho, hourglass_stiffness, hourglass_viscosity)
        ne, nen = conn.shape
        if self.integration == "full":
            Bg, Wg = full_integration_data(X, conn, thickness)
            lam_max = element_max_eigenvalue_full(Bg, Wg, lam, mu)
            khg[:] = 0.0
            chg[:] = 0.0
        else:
            Bg, Wg = np.zeros((ne, 1, nen, self.dim)), np.zeros((ne, 1))
            lam_max = element_max_eigenvalue(B, V0, gamma, lam, mu, khg)
        return ElementData(B, V0, gamma, me, khg, chg, Bg, Wg, lam_max, self.integration == "full")


#: element types by (dimension, nodes per element, integration)
ELEMENT_TYPES: dict[tuple[int, int, str], ElementType] = {
    (2, 4, "reduced"): ElementType("Q4", 2, 4, "reduced", q4_element),
    (2, 4, "full"): ElementType("Q4-full", 2, 4, "full", q4_full_element),
    (3, 8, "reduced"): ElementType("Hex8", 3, 8, "reduced", hex8_element),
    (3, 8, "full"): ElementType("Hex8-full", 3, 8, "full", hex8_full_element),
}


def element_type(dim: int, nodes: int, integration: str) -> ElementType:
    """The element type of a model's elements.

    Raises
    ------
    ConfigError
        No element type for that dimension, node count and integration.
    """
    try:
        return ELEMENT_TYPES[(dim, nodes, integration)]
    except KeyError:
        known = ", ".join(f"{t.name} ({t.dim}D, {t.nodes} nodes, {t.integration})" for t in ELEMENT_TYPES.values())
        raise ConfigError(f"no explicit element for {dim}D elements of {nodes} nodes with {integration!r} "
                          f"integration (known: {known})") from None
