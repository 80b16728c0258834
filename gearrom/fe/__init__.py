"""Quasi-static FE of the tooth pair: static TE, mesh stiffness and load sharing over a mesh cycle.

Pipeline (one module each): :mod:`~gearrom.fe.mesh2d` (gmsh meshes of the transverse section,
graded flanks), :mod:`~gearrom.fe.elastic` (scikit-fem P2 plane strain, rigid bore, one
factorisation per gear), :mod:`~gearrom.fe.compliance` (flank influence coefficients, disk cache),
:mod:`~gearrom.fe.contact` (active-set frictionless contact), :mod:`~gearrom.fe.flankgaps`
(initial gaps), :mod:`~gearrom.fe.ltca` (spur LTCA), :mod:`~gearrom.fe.ltca_slices` (helical slices),
:mod:`~gearrom.fe.sweep` (mesh cycle x torque -> :class:`~gearrom.fe.sweep.StiffnessResult` ->
:class:`gearrom.excitation.table.MeshExcitation`), :mod:`~gearrom.fe.fullcontact` (second
formulation), :mod:`~gearrom.fe.export` (VTU, Abaqus/CalculiX deck), :mod:`~gearrom.fe.iso6336`.

Entry points::

    from gearrom.fe.sweep import stiffness_sweep, build_ltca, mesh_cycle, kinematic_te
    res = stiffness_sweep(load_config("thesis-spur").pair, torques=[60, 120, 240])
    table = res.to_excitation()

The explicit dynamics solver lives in :mod:`gearrom.fe.explicit` (separate owner).
"""
