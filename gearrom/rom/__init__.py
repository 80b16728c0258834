"""Reduced-order drivetrain model (exudyn): dynamic TE, speed sweeps, modes, Campbell, frequency response.

Main entry points::

    from gearrom.rom import build_rig, simulate_run, Effects, Runout
    run = simulate_run("thesis-rig", 1250.0, 120.0, n_output_revs=2,
                       effects=Effects(runout=(Runout(gear=1, eccentricity=11e-6, phase=0.0),)))
    run.theta, run.dte["sensor"], run.force          # encoder angles, DTE, mesh force

See :mod:`gearrom.rom.components` for the DOFs per body and :mod:`gearrom.rom.mesh` for the mesh law.
"""
from gearrom.rom.frf import gmf_estimate, plot_transfer, state_space
from gearrom.rom.mesh import Effects, ExtraTE, LoadRipple, PitchDeviations, Runout
from gearrom.rom.modal import CampbellResult, ModalResult, campbell, modal_analysis
from gearrom.rom.model import Drivetrain, MeshSpec
from gearrom.rom.result import DynamicRun
from gearrom.rom.rig import build_rig, rig_parameters, with_overrides
from gearrom.rom.simulate import simulate_run
from gearrom.rom.sweep import SweepResult, parse_rpm, run_sweep

__all__ = [
    "CampbellResult", "Drivetrain", "DynamicRun", "Effects", "ExtraTE", "LoadRipple", "MeshSpec", "ModalResult",
    "PitchDeviations", "Runout", "SweepResult", "build_rig", "campbell", "gmf_estimate", "modal_analysis",
    "parse_rpm", "plot_transfer", "rig_parameters", "run_sweep", "simulate_run", "state_space", "with_overrides",
]
