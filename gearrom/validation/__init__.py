"""ROM-vs-explicit-FE validation: the pair ROM of the FE's system, TE metrics, reports.

Entry points: :func:`gearrom.validation.report.validate` (CLI ``gearrom validate``),
:func:`gearrom.validation.pair_rom.simulate_pair_rom`, :func:`gearrom.validation.compare.te_metrics`.
"""
from gearrom.validation.compare import TOLERANCES, compare_metrics, steady_window, te_metrics
from gearrom.validation.pair_rom import (PairRomResult, PairRomSetup, fe_start_mesh_phase, mesh_excitation,
                                         polar_inertia, simulate_pair_rom)

__all__ = ["TOLERANCES", "compare_metrics", "steady_window", "te_metrics", "PairRomResult", "PairRomSetup",
           "fe_start_mesh_phase", "mesh_excitation", "polar_inertia", "simulate_pair_rom"]
