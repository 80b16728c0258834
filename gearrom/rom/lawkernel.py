"""The mesh force law compiled for the numba integrators: :func:`law_force` on :class:`LawTables`.

The exudyn drivetrain sets the law once per step through :class:`gearrom.rom.meshstep.MeshStepper`;
the integrators written in numba (the pair model of the validation, the torsional model of the
diagnosis) evaluate it at every stage with :func:`law_force`. Both read the same tables, made by
:meth:`LawTables.from_law` from a :class:`~gearrom.rom.mesh.MeshLaw`:

* the knot deflections ``E[j](theta)`` over one mesh period (``j = 0``: the separation point,
  force 0) and the knot forces ``f[j]``;
* load-dependent law (a :class:`~gearrom.rom.mesh.ForceMap` over the table's torques): the map's
  knots; secant law: two knots, the separation point ``e - F_nom/k`` and the static TE ``e`` at
  ``F_nom``, so that the law is ``k (delta - e0)``.

Between knots the force is linear in the deflection; beyond the last knot the last segment
continues; at or below the separation point there is no contact (force 0). The damping force
``c d(delta)/dt`` acts while the flanks touch, as in the exudyn limit stop.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from gearrom.rom.mesh import MeshLaw

__all__ = ["LawTables", "law_force"]


@dataclass(frozen=True, eq=False)
class LawTables:
    """Knot deflections ``E`` (m + 1, n) [m] on ``n`` equal steps of one mesh period ``period``
    [rad of the input gear], and knot forces ``f`` (m + 1,) [N]."""

    E: np.ndarray
    f: np.ndarray
    period: float

    @classmethod
    def from_law(cls, law: MeshLaw) -> LawTables:
        """The tables of ``law`` on its own angle grid (its effects are not included: a numba model
        adds its kinematic errors to the deflection itself)."""
        period = 2 * math.pi / law.z1
        if law.load_dependent:
            E = np.array(law.force_map.e, dtype=float)
            f = np.array(law.force_map.f, dtype=float)
        else:
            e0 = law.e_grid - law.f_nom / law.k_grid
            E = np.vstack([e0, e0 + law.f_nom / law.k_grid])
            f = np.array([0.0, law.f_nom])
        return cls(np.ascontiguousarray(E), f, period)


@njit(cache=True)
def law_force(E, f, u, delta, ddelta, c):
    """Mesh force [N] at deflection ``delta`` [m] and its rate ``ddelta`` [m/s], with mesh damping
    ``c`` [N s/m], at the mesh phase ``u`` in grid steps (``theta / period * n``, any real number:
    the tables repeat every ``n`` steps). ``E``, ``f``: :class:`LawTables` arrays."""
    n = E.shape[1]
    m = E.shape[0] - 1
    i = int(math.floor(u))
    w = u - i
    i0 = i % n
    i1 = (i0 + 1) % n
    lo = E[0, i0] + w * (E[0, i1] - E[0, i0])
    if delta <= lo:
        return 0.0
    hi = E[1, i0] + w * (E[1, i1] - E[1, i0])
    j = 0
    while j < m - 1 and delta >= hi:
        j += 1
        lo = hi
        hi = E[j + 1, i0] + w * (E[j + 1, i1] - E[j + 1, i0])
    return f[j] + (delta - lo) * (f[j + 1] - f[j]) / (hi - lo) + c * ddelta
