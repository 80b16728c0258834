"""Explicit transient FE (central differences, numba): plane-strain Q4 and Hex8, total Lagrangian
St Venant-Kirchhoff, one-point integration with Flanagan-Belytschko hourglass control, row-sum
lumped mass, node-to-segment penalty contact with Coulomb friction, rigid reference nodes.

Public API::

    from gearrom.fe.explicit import ExplicitModel, Material, RigidReference, ContactPair, NodalLoad
    result = solve(model, t_end, sample_period)      # -> ExplicitResult (save/load/plot)

    # spur gear pair (2D): meshes from gear_quad_mesh or the quasi-static Mesh2D
    from gearrom.fe.explicit import GearPairSetup, gear_quad_mesh, run_gear_pair
    result, te, info = run_gear_pair(pair, meshes, GearPairSetup(rpm_in=1250), t_end, sample_period)
"""
from __future__ import annotations

from gearrom.fe.explicit.driver import prepare, solve, stable_dt
from gearrom.fe.explicit.gearmesh import gear_quad_mesh
from gearrom.fe.explicit.gearpair import (GearPairSetup, gear_pair_model, run_gear_pair, transmission_error,
                                          triangles_to_quads)
from gearrom.fe.explicit.model import (ContactPair, ExplicitModel, Material, NodalLoad, RigidReference,
                                       boundary_segments)
from gearrom.fe.explicit.result import ENERGY_NAMES, ExplicitResult

__all__ = ["ContactPair", "ENERGY_NAMES", "ExplicitModel", "ExplicitResult", "GearPairSetup", "Material",
           "NodalLoad", "RigidReference", "boundary_segments", "gear_pair_model", "gear_quad_mesh", "prepare",
           "run_gear_pair", "solve", "stable_dt", "transmission_error", "triangles_to_quads"]
