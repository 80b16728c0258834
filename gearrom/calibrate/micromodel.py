"""The micro-geometry model interface of the diagnosis: flank modifications to a mesh excitation table.

Anything with an ``excitation(pair, torques_Nm, mods) -> MeshExcitation`` method serves
(:class:`MicroGeometryModel`): the quasi-static FE tables (:class:`~gearrom.calibrate.microfe.FEMicroModel`)
or the analytical thin slices (:class:`~gearrom.excitation.slices.SliceMicroModel`). The modification
type :class:`~gearrom.excitation.slices.MicroMods` comes with the slice model; its amounts are material
removed from the flank along the transverse line of action (ISO 1328-1), the convention of the config's
micro-geometry, and every model takes them so.
"""
from __future__ import annotations

from typing import Protocol

from gearrom.excitation.slices import MicroMods
from gearrom.excitation.table import MeshExcitation
from gearrom.geometry.pair import GearPair


class MicroGeometryModel(Protocol):
    """Anything that turns flank modifications into a mesh excitation table (:class:`~gearrom.calibrate.microfe.FEMicroModel`, or this module's slices)."""

    def excitation(self, pair: GearPair, torques_Nm, mods: MicroMods) -> MeshExcitation:  # pragma: no cover
        ...
