"""datasim: an independent test-data simulator for gearrom (shares no code with it).

A thin-slice helical mesh law with per-tooth deviations inside a lumped torsional rig, two
incremental encoders and a writer of ``gearrom.measurement/1`` edge files. See README.md.
"""
from .effects import (Case, DamagedTooth, Eccentricity, EncoderEccentricity, HelixSlope, LeadCrowning, LoadRipple,
                      PitchError, TipRelief, TorsionalMode)
from .geometry import PairGeometry, geometry_from_config, iso_single_stiffness, pair_geometry
from .simulate import SimResult, simulate
from .writer import make_case_files, write_measurement

__all__ = ["Case", "DamagedTooth", "Eccentricity", "EncoderEccentricity", "HelixSlope", "LeadCrowning", "LoadRipple",
           "PitchError", "TipRelief", "TorsionalMode", "PairGeometry", "geometry_from_config", "iso_single_stiffness",
           "pair_geometry", "SimResult", "simulate", "make_case_files", "write_measurement"]
