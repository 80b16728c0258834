"""Read a measurement into both shaft angles on one uniform time grid (:func:`load_angles`).

Kind "edges": each channel goes through an :class:`~gearrom.signal.edges.EdgeStream` (bounded
memory, checks and repairs); the two angle series are then cut to their common grid span.
Kind "angles": the rows are checked (finite, increasing time, no duplicated time, no reversal),
gaps are listed as repairs and bridged by linear interpolation onto the grid.
Finally the measured input speed is compared with ``rpm_in`` of the metadata.
"""
from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np

from gearrom.errors import MeasurementError
from gearrom.signal.edges import EdgeStream, ReadSettings, Repair, check_time_resolution
from gearrom.signal.measurement import CHANNELS, MeasurementMeta, read_meta
from gearrom.signal.readers import (
    AngleChunk,
    EdgeChunk,
    first_bad,
    fmt_t,
    iter_chunks,
    row_label,
)
from gearrom.signal.qload import load_quadrature
from gearrom.signal.streams import AngleData, auto_fs, combine_streams
from gearrom.signal.trim import ForwardFilter, edge_file_runs, report_run, windowed

log = logging.getLogger(__name__)


def load_angles(source: str | Path | MeasurementMeta, settings: ReadSettings | None = None) -> AngleData:
    """Read a ``gearrom.measurement/1`` measurement into both shaft angles on one time grid.

    Parameters
    ----------
    source : str, Path or MeasurementMeta
        The JSON metadata file (or its parsed metadata).
    settings : ReadSettings, optional

    Returns
    -------
    AngleData

    Raises
    ------
    MeasurementError
        Any format, validation or consistency problem; the message names file, channel, row, time.
    """
    settings = settings or ReadSettings()
    meta = source if isinstance(source, MeasurementMeta) else read_meta(source)
    if meta.kind == "edges":
        data = _load_edges(meta, settings)
    elif meta.kind == "quadrature":
        data = load_quadrature(meta, settings)
    else:
        data = _load_angle_rows(meta, settings)
    _check_rpm(data, settings)
    return data


def _load_edges(meta: MeasurementMeta, settings: ReadSettings) -> AngleData:
    fs = auto_fs(meta, settings)
    file, label = str(meta.data_path), row_label(meta)
    res_s = settings.timing_resolution_s or 1.0 / meta.clock_hz
    streams = {ch: EdgeStream(ch, meta.encoders[ch].counts_per_shaft_rev, fs, file, label, settings,
                              period=settings.edge_period or 1, timing_resolution_s=res_s) for ch in CHANNELS}
    t0, t1 = settings.t_start_s, settings.t_end_s
    info: dict = {"timing_resolution_s": res_s}
    runs = edge_file_runs(meta, settings) if settings.trim else None
    keep = {}
    if runs is not None:
        keep = {ch: ForwardFilter(runs, ch) for ch in CHANNELS}
        info["trimmed"] = []
        info["direction"] = {ch: {"reversed_sign": r.reversed_sign, "jitter_edges_dropped": r.jitter_edges}
                             for ch, r in runs.runs.items()}
        for ch, r in runs.runs.items():
            report_run(file, ch, r, info)
    for chunk in iter_chunks(meta, settings.chunk_rows, allow_outside_data=settings.allow_outside_data):
        assert isinstance(chunk, EdgeChunk)
        chunk = windowed(chunk, settings)
        if keep:
            chunk = keep[chunk.channel](chunk)
        if chunk.t.size:
            streams[chunk.channel].feed(chunk)
    if t0 is not None or t1 is not None:
        info["window_s"] = [t0, t1]
    return combine_streams(meta, streams, fs, info=info)


def _load_angle_rows(meta: MeasurementMeta, settings: ReadSettings) -> AngleData:
    file, label = str(meta.data_path), row_label(meta)
    parts: list[AngleChunk] = [c for c in iter_chunks(meta, settings.chunk_rows, allow_outside_data=settings.allow_outside_data)]  # type: ignore[misc]
    if not parts or sum(p.t.size for p in parts) < 16:
        raise MeasurementError(f"{file}: fewer than 16 data rows")
    t = np.concatenate([p.t for p in parts])
    if settings.t_start_s is not None or settings.t_end_s is not None:
        lo = settings.t_start_s if settings.t_start_s is not None else -np.inf
        hi = settings.t_end_s if settings.t_end_s is not None else np.inf
        masks = [(p_.t >= lo) & (p_.t < hi) for p_ in parts]
        parts = [AngleChunk(p_.t[m], p_.theta_in[m], p_.theta_out[m], p_.row[m]) for p_, m in zip(parts, masks)]
        t = np.concatenate([p.t for p in parts])
        if t.size < 16:
            raise MeasurementError(f"{file}: fewer than 16 data rows in the time window {lo}..{hi} s")
    th = {"input": np.concatenate([p.theta_in for p in parts]),
          "output": np.concatenate([p.theta_out for p in parts])}
    row = np.concatenate([p.row for p in parts])
    del parts
    for name, arr in (("t_s", t), ("theta_in_rad", th["input"]), ("theta_out_rad", th["output"])):
        i = first_bad(arr)
        if i is not None:
            raise MeasurementError(f"{file}: {label} {row[i]}, column {name!r}: value is not a finite number "
                                   f"({arr[i]}) at t={fmt_t(t[i])}")
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        j = bad[0] + 1
        what = "duplicated time stamp" if dt[j - 1] == 0 else "time stamp decreases"
        raise MeasurementError(f"{file}: {label} {row[j]}, column 't_s', t={fmt_t(t[j])}: {what} "
                               f"(previous row {label} {row[j - 1]}, t={fmt_t(t[j - 1])})")
    for ch, col in (("input", "theta_in_rad"), ("output", "theta_out_rad")):
        rev = np.flatnonzero(np.diff(th[ch]) < 0)
        if rev.size:
            j = rev[0] + 1
            raise MeasurementError(f"{file}: {label} {row[j]}, channel {ch!r} (column {col!r}), t={fmt_t(t[j])}: "
                                   "direction reversal (angle decreases); angles must increase in the "
                                   "direction of rotation")
        th[ch] = th[ch] - th[ch][0]
    med = float(np.median(dt))
    check_time_resolution(float(t[0]), float(t[-1]), med, f"{file}: column 't_s'")
    fs = float(settings.fs_hz) if settings.fs_hz is not None else 1.0 / med
    repairs = []
    gaps = np.flatnonzero(dt > settings.gap_ratio * med)
    for g in gaps:
        j = g + 1
        rep = Repair("gap", "input+output", f"{file}: {label} {row[j]}", float(t[j]), int(round(dt[g] / med)) - 1,
                     f"{dt[g]:.6g} s without samples ({dt[g] / med:.1f} x the median interval) bridged by "
                     "linear interpolation")
        if settings.strict or dt[g] / med - 1 > settings.max_fill_edges:
            raise MeasurementError(rep.message() + ": gap too long" if not settings.strict else
                                   rep.message() + " (strict mode: no repairs allowed)")
        repairs.append(rep)
    if len(repairs) > settings.max_repairs:
        raise MeasurementError(f"{file}: {len(repairs)} gaps, more than max_repairs={settings.max_repairs}")
    uniform = settings.fs_hz is None and not gaps.size and np.max(np.abs(dt - med)) <= 1e-6 * med
    if uniform:
        tg, th_in, th_out = t, th["input"], th["output"]
        fs = 1.0 / float(np.mean(dt))
    else:
        k0, k1 = math.ceil(t[0] * fs), math.floor(t[-1] * fs) + 1
        if k1 - k0 > settings.max_grid_samples:
            raise MeasurementError(f"{file}: the time grid at fs_hz={fs:.6g} Hz over t={fmt_t(t[0])}..{fmt_t(t[-1])} "
                                   f"needs {k1 - k0:.4g} samples ({8 * (k1 - k0) / 2**30:.3g} GiB per channel), more "
                                   f"than max_grid_samples={settings.max_grid_samples}; lower the grid rate (fs_hz, "
                                   "gearrom te --fs-hz)")
        tg = np.arange(k0, k1) / fs
        th_in, th_out = np.interp(tg, t, th["input"]), np.interp(tg, t, th["output"])
    rpm = (th["input"][-1]) / (t[-1] - t[0]) * 60.0 / (2 * math.pi)
    return AngleData(t_s=tg, theta_in_rad=th_in, theta_out_rad=th_out, fs_hz=fs, meta=meta, repairs=tuple(repairs),
                     rpm_in_measured=rpm, n_edges={"rows": int(t.size)})


def _check_rpm(data: AngleData, settings: ReadSettings) -> None:
    """``rpm_in`` against the plateau speed of the data (the speed the record spends most time at:
    the steady part of a run with start-up and coast-down; the mean speed of a steady run)."""
    from gearrom.signal.runup import plateau_rpm, speed_profile

    meta = data.meta
    rpm = plateau_rpm(speed_profile(data.t_s, data.theta_in_rad)[1])
    rel = abs(rpm - meta.rpm_in) / meta.rpm_in
    if not rel <= settings.rpm_tolerance:
        raise MeasurementError(
            f"{meta.path}: key 'rpm_in' = {meta.rpm_in:g} disagrees with the data ({meta.data_path}, channel "
            f"'input', t={fmt_t(float(data.t_s[0]))}..{fmt_t(float(data.t_s[-1]))}: plateau speed "
            f"{rpm:.6g} rpm, mean {data.rpm_in_measured:.6g} rpm) by {100 * rel:.2f} % (tolerance "
            f"{100 * settings.rpm_tolerance:g} %; gearrom te --rpm-tolerance)")
