"""Measurement data and TE signal processing: encoders in, TE, filters, spectra, orders.

Pipeline: :func:`read_meta` / :func:`load_angles` (``gearrom.measurement/1`` files, CSV or TDMS,
checked and repaired in bounded memory) -> :func:`compute_te` (TE on the line of action or the
pitch circle) -> :class:`TEResult` (spectra, order spectra, synchronous averages, GMF lines,
plot, save/load). :func:`process_measurement` does all of it. :func:`emulate_edges` and
:func:`write_measurement` turn simulated angle histories into measurement files, so that
simulations run through the same pipeline.
"""
from gearrom.signal.angles import AngleData, load_angles
from gearrom.signal.config import settings_from_config, settings_from_section
from gearrom.signal.edges import ReadSettings, Repair
from gearrom.signal.emulate import emulate_channel, emulate_edges
from gearrom.signal.filters import FilterSettings, apply_filters, bessel_lowpass, highpass
from gearrom.signal.measurement import (AngleRecord, EdgeCSVWriter, EdgeRecord, EncoderInfo, MeasurementMeta,
                                        read_meta, write_measurement, write_meta)
from gearrom.signal.result import TEResult
from gearrom.signal.spectra import (Peak, Spectrum, amplitude_spectrum, annotate_gmf, order_spectrum,
                                    resample_angle, synchronous_average)
from gearrom.signal.te import GearMeshInfo, TESettings, compute_te, process_measurement, te_from_angles

__all__ = [
    "AngleData", "AngleRecord", "EdgeCSVWriter", "EdgeRecord", "EncoderInfo", "FilterSettings", "GearMeshInfo", "MeasurementMeta",
    "Peak", "ReadSettings", "Repair", "Spectrum", "TEResult", "TESettings", "amplitude_spectrum", "annotate_gmf",
    "apply_filters", "bessel_lowpass", "compute_te", "emulate_channel", "emulate_edges", "highpass", "load_angles",
    "order_spectrum", "process_measurement", "read_meta", "resample_angle", "settings_from_config",
    "settings_from_section", "synchronous_average",
    "te_from_angles", "write_measurement", "write_meta",
]
