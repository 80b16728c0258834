"""Read a kind-``quadrature`` measurement into both shaft angles (:func:`load_quadrature`).

The sampled A/B (and index) channels are read chunk by chunk (:mod:`gearrom.signal.samples`) and
decoded into signed edges (:mod:`gearrom.signal.quadrature`); memory is the sample chunk plus the
decoded edges (9 bytes per edge, fewer than the samples whenever the record is resolved). Each
channel is then cut to its longest stretch of forward rotation (start-up from rest, coast-down to
rest, jitter and reversals at standstill are cut and reported), both channels to their common
span, and the edges go through the same checks and interpolation as kind ``edges``
(:class:`~gearrom.signal.edges.EdgeStream`), with the sample step as timing resolution and the
decoding factor as the period of the interval comparison.
"""
from __future__ import annotations

import logging
import math

import numpy as np

from gearrom.errors import MeasurementError
from gearrom.signal.edges import EdgeStream, Repair
from gearrom.signal.measurement import CHANNELS, MeasurementMeta
from gearrom.signal.quadrature import QuadratureDecoder
from gearrom.signal.readers import EdgeChunk
from gearrom.signal.samples import iter_samples
from gearrom.signal.settings import ReadSettings
from gearrom.signal.streams import auto_fs, combine_streams
from gearrom.signal.trim import report_run, select_run

log = logging.getLogger(__name__)

#: Edges per piece fed to an EdgeStream: the edges are in memory already, so smaller pieces only
#: bound the stream's per-piece working arrays (a few float64 per edge) without changing its result.
STREAM_CHUNK_EDGES = 1 << 18

#: Samples per piece fed to a decoder for a record without a time column. The decoder's scratch
#: arrays hold two edges per fed sample; smaller pieces keep them small.
#: The automatic switching levels come from the whole first chunk; pieces are cut only when the
#: sample times come from the rate (with a time column the decoder's step estimate is per piece).
DECODE_PIECE_SAMPLES = 1 << 18

#: Above this sample step / shortest edge interval the decoder misses x4 edges (illegal transitions).
TIMING_WARN_RATIO = 0.25


def decode(meta: MeasurementMeta, settings: ReadSettings) -> dict[str, tuple]:
    """Decode both encoders: ``{channel: (t, sign, rows, QuadratureDecoder)}``."""
    if not meta.data_inside and not settings.allow_outside_data:
        raise MeasurementError(f"{meta.path}: key 'data' = {meta.data_path} lies outside the measurement's folder "
                               f"{meta.path.parent.resolve()}; move the data file there, or allow it explicitly "
                               "(gearrom te/diagnose --allow-outside-data, ReadSettings(allow_outside_data=True))")
    if not meta.data_path.is_file():
        raise MeasurementError(f"{meta.path}: data file {meta.data_path} not found (key 'data')")
    q = meta.quadrature
    file = str(meta.data_path)
    needed, optional = [], []
    for ch in CHANNELS:
        e = meta.encoders[ch]
        needed += [e.a, e.b]
        if e.z is not None:
            needed.append(e.z)
        else:
            optional.append(f"{ch}_z")
    decs = {ch: QuadratureDecoder(ch, q.decoding, q.threshold, q.hysteresis, q.edge_time, file) for ch in CHANNELS}
    first = True
    for chunk in iter_samples(meta, needed, optional, settings.chunk_rows):
        m = next(iter(chunk.cols.values())).size
        if first:  # the automatic switching levels come from the whole first chunk
            for ch in CHANNELS:
                e = meta.encoders[ch]
                decs[ch].set_levels(chunk.cols[e.a], chunk.cols[e.b], chunk.cols.get(e.z or f"{ch}_z"))
        piece = m if chunk.t is not None else DECODE_PIECE_SAMPLES
        first = False
        for a in range(0, m, piece):
            b = min(m, a + piece)
            for ch in CHANNELS:
                e = meta.encoders[ch]
                z = chunk.cols.get(e.z or f"{ch}_z")
                decs[ch].feed(None if chunk.t is None else chunk.t[a:b], chunk.cols[e.a][a:b], chunk.cols[e.b][a:b],
                              None if z is None else z[a:b], chunk.row0 + a, rate_hz=chunk.rate_hz)
    return {ch: (*d.result(), d) for ch, d in decs.items()}


def load_quadrature(meta: MeasurementMeta, settings: ReadSettings):
    """Decode, trim, check and interpolate a kind-``quadrature`` measurement.

    Returns
    -------
    AngleData
        With ``info["quadrature"]`` (per channel: sample rate, highest edge rate, timing
        resolution as a fraction of the shortest edge interval, illegal transitions, index
        pulses and counts per index revolution, direction) and ``info["trimmed"]``.

    Raises
    ------
    MeasurementError
        Unreadable data, a channel that does not switch, too few edges, no common forward span.
    """
    file = str(meta.data_path)
    dec = decode(meta, settings)
    fs = auto_fs(meta, settings)
    lo = settings.t_start_s if settings.t_start_s is not None else -np.inf
    hi = settings.t_end_s if settings.t_end_s is not None else np.inf
    period = settings.edge_period or meta.quadrature.decoding
    info: dict = {"quadrature": {}, "trimmed": []}
    repairs: list[Repair] = []
    sel = {}
    for ch in CHANNELS:
        t, sign, rows, d = dec.pop(ch)  # dropped after this iteration: only the kept edges stay
        if lo > -np.inf or hi < np.inf:
            w = (t >= lo) & (t < hi)
            t, sign, rows = t[w], sign[w], rows[w]
        if t.size < 4 * period + 4:
            raise MeasurementError(f"{file}: channel {ch!r}: {t.size} edges decoded in the time window; check the "
                                   "channel names, threshold and hysteresis (quadrature.threshold/hysteresis)")
        try:
            rs = select_run(t, sign, period=period, min_speed_fraction=settings.min_speed_fraction,
                            trim=settings.trim)
        except MeasurementError as exc:
            raise MeasurementError(f"{file}: channel {ch!r}: {exc}") from None
        k = rs.keep
        if k[-1] - k[0] + 1 == k.size:  # no jitter edge inside the run: views instead of copies
            sel[ch] = (t[k[0]:k[-1] + 1], rows[k[0]:k[-1] + 1])
        else:
            sel[ch] = (t[k], rows[k])
        del k
        step = d.report.sample_step_s
        tk = sel[ch][0]
        span = tk[period:] - tk[:-period]
        shortest = float(np.percentile(span, 1)) / period if span.size else math.nan
        rep = {"sample_rate_hz": 1.0 / step, "edge_rate_max_hz": 1.0 / shortest,
               "timing_resolution_s": step, "resolution_of_edge_interval": step / shortest,
               "illegal_transitions": d.report.illegal, "reversed_sign": rs.reversed_sign,
               "jitter_edges_dropped": rs.jitter_edges, "levels": {k: list(v) for k, v in d.report.levels.items()},
               "edges_decoded": int(t.size)}
        idx = d.report.index_positions
        if len(idx) >= 2:
            per = np.abs(np.diff(idx))
            rep["index_pulses"] = len(idx)
            rep["counts_per_index_rev"] = float(np.median(per))
            expect = meta.encoders[ch].lines * 4
            if abs(np.median(per) - expect) > 1:
                log.warning("%s: channel %r: %g x4 counts between index pulses, %d expected from %d lines",
                            file, ch, float(np.median(per)), expect, meta.encoders[ch].lines)
        info["quadrature"][ch] = rep
        if step / shortest > TIMING_WARN_RATIO:
            log.warning("%s: channel %r: sample step %.3g s is %.0f %% of the shortest edge interval: expect illegal "
                        "transitions (missed edges)", file, ch, step, 100 * step / shortest)
        report_run(file, ch, rs, info)
        if d.report.illegal:
            repairs.append(Repair("illegal_transition", ch, f"{file}: sample (first at t={d.report.illegal_first_t:.9g} s)",
                                  float(d.report.illegal_first_t), d.report.illegal,
                                  "both A and B changed within one sample; counted as two edges in the direction "
                                  "of the last legal step"))
        del t, sign, rows, tk, span, rs
    if settings.strict and repairs:
        raise MeasurementError(repairs[0].message() + " (strict mode: no repairs allowed)")
    t0 = max(sel[ch][0][0] for ch in CHANNELS)
    t1 = min(sel[ch][0][-1] for ch in CHANNELS)
    if not t1 > t0:
        raise MeasurementError(f"{file}: the forward-rotation stretches of 'input' and 'output' do not overlap")
    streams = {}
    for ch in CHANNELS:
        t, rows = sel.pop(ch)  # only the common span stays
        m = (t >= t0) & (t <= t1)
        if not m.all():
            t, rows = t[m], rows[m]
        del m
        step = info["quadrature"][ch]["timing_resolution_s"]
        s = EdgeStream(ch, meta.encoders[ch].counts_per_shaft_rev, fs, file, "sample", settings, period=period,
                       timing_resolution_s=settings.timing_resolution_s or step)
        step = min(settings.chunk_rows, STREAM_CHUNK_EDGES)
        for a in range(0, t.size, step):
            s.feed(EdgeChunk(ch, t[a:a + step], rows[a:a + step]))
        streams[ch] = s
        del t, rows
    if lo > -np.inf or hi < np.inf:
        info["window_s"] = [settings.t_start_s, settings.t_end_s]
    info["timing_resolution_s"] = max(info["quadrature"][ch]["timing_resolution_s"] for ch in CHANNELS)
    return combine_streams(meta, streams, fs, repairs=tuple(repairs), info=info)
