"""Mesh excitation: the hand-off from the quasi-static mesh analysis to the dynamic model.

:class:`MeshExcitation` (stiffness, static TE and load share over mesh phase and torque) and
:func:`analytical_excitation` (ISO 6336-1 shaped analytical model, an explicit choice; the default is the quasi-static FE table of
:mod:`gearrom.excitation.fe`).
"""
from gearrom.excitation.analytical import analytical_excitation, iso_mesh_stiffness, iso_single_stiffness
from gearrom.excitation.table import Harmonics, MeshExcitation

__all__ = ["Harmonics", "MeshExcitation", "analytical_excitation", "iso_mesh_stiffness", "iso_single_stiffness"]
