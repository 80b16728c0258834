"""Both shaft angles on one grid (:class:`AngleData`), made from the two channels' edge streams.

The readers of every measurement kind (edge files, angle rows, sampled quadrature signals) end here:
:func:`auto_fs` picks the grid rate, :func:`combine_streams` cuts both channels to their common span.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from gearrom.errors import MeasurementError
from gearrom.signal.edges import EdgeStream, Repair
from gearrom.signal.measurement import MeasurementMeta
from gearrom.signal.readers import fmt_t
from gearrom.signal.settings import ReadSettings

__all__ = ["AngleData", "auto_fs", "combine_streams"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class AngleData:
    """Both shaft angles on one uniform time grid.

    Attributes
    ----------
    t_s : ndarray
        Grid times, s (``k / fs_hz``).
    theta_in_rad, theta_out_rad : ndarray
        Shaft angles, rad, zero at each channel's first edge (or first row).
    fs_hz : float
        Grid rate, Hz.
    meta : MeasurementMeta
    repairs : tuple of Repair
    rpm_in_measured : float
        Mean input speed over the record, rpm.
    n_edges : dict
        Rows read per channel.
    info : dict
        Reader reports: for kind ``quadrature`` the decoding (sample rate, edge rate, timing
        resolution, illegal transitions, index pulses, direction) and what was cut (``trimmed``);
        ``window_s`` when a time window was applied.
    """

    t_s: np.ndarray
    theta_in_rad: np.ndarray
    theta_out_rad: np.ndarray
    fs_hz: float
    meta: MeasurementMeta
    repairs: tuple[Repair, ...] = ()
    rpm_in_measured: float = float("nan")
    n_edges: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)


def auto_fs(meta: MeasurementMeta, settings: ReadSettings) -> float:
    """Grid rate: the nominal input edge rate divided down to at most ``settings.fs_max_hz``."""
    if settings.fs_hz is not None:
        return float(settings.fs_hz)
    rate = meta.rpm_in / 60.0 * meta.encoders["input"].counts_per_shaft_rev
    return rate / max(1, math.ceil(rate / settings.fs_max_hz - 1e-9))


def combine_streams(meta: MeasurementMeta, streams: dict[str, EdgeStream], fs: float, repairs: tuple = (),
                    info: dict | None = None) -> AngleData:
    """Both channels' angles cut to their common grid span (the streams have been fed)."""
    file = str(meta.data_path)
    res = {ch: s.finish() for ch, s in streams.items()}
    (k_in, th_in), (k_out, th_out) = res["input"], res["output"]
    k0 = max(k_in, k_out)
    k1 = min(k_in + th_in.size, k_out + th_out.size)
    if k1 - k0 < 16:
        raise MeasurementError(f"{file}: channels 'input' ({_span(streams['input'])}) and 'output' "
                               f"({_span(streams['output'])}) overlap by fewer than 16 grid samples")
    th_in = th_in[k0 - k_in:k1 - k_in]
    th_out = th_out[k0 - k_out:k1 - k_out]
    s_in = streams["input"]
    rpm = s_in.last_count * s_in.dtheta / (s_in.last_t - s_in.first_t) * 60.0 / (2 * math.pi)
    repairs = tuple(repairs) + tuple(r for s in streams.values() for r in s.repairs)
    for r in repairs:
        log.info("repair: %s", r.message())
    return AngleData(t_s=np.arange(k0, k1) / fs, theta_in_rad=th_in, theta_out_rad=th_out, fs_hz=fs, meta=meta,
                     repairs=repairs, rpm_in_measured=rpm, n_edges={ch: s.n_edges for ch, s in streams.items()},
                     info=info or {})


def _span(s: EdgeStream) -> str:
    if s.first_t is None:
        return "no edges"
    return f"t={fmt_t(s.first_t)}..{fmt_t(s.last_t)}"
