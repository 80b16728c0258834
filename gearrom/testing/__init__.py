"""Test-data generators: synthetic measurements made by gearrom's own models with injected effects.

For tests, benchmarks and the notebooks; not a stage of the pipeline. :mod:`gearrom.testing.synthetic`
simulates a run with effects put in from their physical definitions (the torsional rig model or the
exudyn ROM), emulates the encoders and writes a ``gearrom.measurement/1`` file. Data made independently
of gearrom's models come from ``tests/datasim``.
"""
from gearrom.testing.synthetic import Injected, RomInjected, make_rom_run, make_run

__all__ = ["Injected", "RomInjected", "make_rom_run", "make_run"]
