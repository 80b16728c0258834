"""The unreduced drivetrain as an exudyn system, built component by component.

Each station becomes a ``NodeGenericODE2`` (6 or 1 coordinates); each component adds its own
``ObjectGenericODE2`` items (:meth:`gearrom.rom.components.Component.add_to_exudyn`); the mesh at its
mean stiffness is an ``ObjectGenericODE2`` over the two gear nodes with ``k w w^T`` and ``c w w^T``.
This is the reference the reduced time-domain model is checked against (exudyn's own linearisation
must reproduce the assembled ``M, K, D``), and the starting point for exudyn-side extensions
(graphics, other solvers). Time runs use :func:`gearrom.rom.simulate.simulate_run`.
"""
from __future__ import annotations

import numpy as np

from gearrom.rom.model import Drivetrain


def build_exudyn(model: Drivetrain, torque_out: float | None = None):
    """Return ``(SystemContainer, mbs, nodes)`` with every component added (mesh at mean stiffness).

    ``nodes`` maps station name to exudyn node index; the global coordinate order equals the model's.
    """
    import exudyn as exu
    from exudyn.itemInterface import NodeGenericODE2, ObjectGenericODE2

    torque = float(model.metadata.get("torque_out_Nm", 120.0) if torque_out is None else torque_out)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = {}
    for st in model.stations:
        n = st.ndof
        nodes[st.name] = mbs.AddNode(NodeGenericODE2(referenceCoordinates=[0.0] * n, initialCoordinates=[0.0] * n,
                                                     initialCoordinates_t=[0.0] * n, numberOfODE2Coordinates=n))
    for comp in model.components:
        comp.add_to_exudyn(mbs, nodes, model.station)
    g1, g2 = model.mesh.gear_stations
    idx = np.r_[model.offset[g1]:model.offset[g1] + model.station[g1].ndof,
                model.offset[g2]:model.offset[g2] + model.station[g2].ndof]
    w = model.w[idx]
    k = model.mesh_stiffness(torque)
    c = model.mesh_damping(torque)
    mbs.AddObject(ObjectGenericODE2(nodeNumbers=[nodes[g1], nodes[g2]], massMatrix=np.zeros((len(w), len(w))),
                                    stiffnessMatrix=k * np.outer(w, w), dampingMatrix=c * np.outer(w, w)))
    mbs.Assemble()
    return SC, mbs, nodes
