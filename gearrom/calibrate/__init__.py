"""Close the loop with measured data: residual, traced effect, added effect, error before and after.

Pipeline (:func:`diagnose`): measured runs (``gearrom.measurement/1``) -> :mod:`.residual` (same TE
processing for model and measurement, honest mesh-phase alignment) -> :mod:`.model` (nominal
simulation and drivetrain sensitivities per run) -> :mod:`.fit` / :mod:`.select` (candidates of
the registered effects, :mod:`.registry` and :mod:`.effects`, ranked by the residual they explain, bounded fits, ambiguities) -> verification
re-simulation -> :mod:`.characterize` (orders, sidebands, fixed vs tracking, unexplained lines) ->
:class:`DiagnosisResult` (JSON, text, plots, save/load).

Models: :class:`~gearrom.calibrate.simulator.Simulator` protocol; the exudyn ROM through
:class:`~gearrom.calibrate.simulator.RomSimulator` when it has the hooks, else the torsional rig
model :class:`~gearrom.calibrate.torsional.TorsionalRig`. Micro-geometry changes through the quasi-static FE
tables without an FE solve (:class:`~gearrom.calibrate.microfe.FEMicroModel`; the analytical
:class:`~gearrom.calibrate.micromodel.SliceMicroModel` only as an explicit fallback).
"""
import gearrom.calibrate.effects  # noqa: F401  (registers the built-in effects)
from gearrom.calibrate.diagnose import diagnose
from gearrom.calibrate.registry import LIBRARY, PLUGINS, EffectPlugin, EffectSpec, check_name, register, unregister
from gearrom.calibrate.fit import FitSettings
from gearrom.calibrate.microfe import FEMicroModel, with_micro
from gearrom.calibrate.micromodel import MicroGeometryModel
from gearrom.excitation.slices import MicroMods, SliceMicroModel
from gearrom.calibrate.report import DiagnosisResult
from gearrom.calibrate.torsional import RigParams, TorsionalRig
from gearrom.calibrate.simulator import (ModelChanges, RomSimulator, RunConditions, SimHistory, Simulator,
                                         default_simulator)

__all__ = ["LIBRARY", "PLUGINS", "DiagnosisResult", "EffectPlugin", "EffectSpec", "FEMicroModel", "FitSettings", "MicroGeometryModel",
           "MicroMods", "ModelChanges", "RigParams", "RomSimulator", "RunConditions", "SimHistory", "SliceMicroModel",
           "Simulator", "TorsionalRig", "check_name", "default_simulator", "diagnose", "register", "unregister", "with_micro"]
