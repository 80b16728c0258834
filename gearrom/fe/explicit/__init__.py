"""Explicit transient FE (central differences, numba): plane-strain Q4 and Hex8, total Lagrangian
St Venant-Kirchhoff, one-point integration with Flanagan-Belytschko hourglass control, row-sum
lumped mass, node-to-segment penalty contact with Coulomb friction, rigid reference nodes.

Public API::

    from gearrom.fe.explicit import ExplicitModel, Material, RigidReference, ContactPair, NodalLoad
    result = solve(model, t_end, sample_period)      # -> ExplicitResult (save/load/plot)
"""
from __future__ import annotations

from gearrom.fe.explicit.driver import prepare, solve, stable_dt
from gearrom.fe.explicit.model import (ContactPair, ExplicitModel, Material, NodalLoad, RigidReference,
                                       boundary_segments)
from gearrom.fe.explicit.result import ENERGY_NAMES, ExplicitResult

__all__ = ["ContactPair", "ENERGY_NAMES", "ExplicitModel", "ExplicitResult", "Material", "NodalLoad",
           "RigidReference", "boundary_segments", "prepare", "solve", "stable_dt"]
