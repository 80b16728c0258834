"""Cut a record to its forward rotation: standstill, jitter at rest and direction reversals.

:func:`select_run` picks, per channel, the longest stretch (by duration) of forward rotation:
only edges that reach a new largest position count, a stretch ends where the position falls back
by two edges or more or where no new edge comes for longer than a standstill time. Kind
``quadrature`` applies it to the decoded edges; kind ``edges`` with a ``direction`` column gets a
first pass over the file (:func:`edge_file_runs`) that finds the stretches, and a
:class:`ForwardFilter` per channel that keeps, while the file streams a second time, the same
edges that :func:`select_run` keeps.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

import gearrom.signal.qkernel as qk
from gearrom.errors import MeasurementError
from gearrom.signal.measurement import CHANNELS, MeasurementMeta
from gearrom.signal.readers import EdgeChunk, first_bad, iter_chunks
from gearrom.signal.settings import ReadSettings

__all__ = ["EdgeFileRuns", "ForwardFilter", "RunSelection", "edge_file_runs", "report_run", "select_run"]

log = logging.getLogger(__name__)

SPAN_SAMPLES = 1 << 18


@dataclass(frozen=True)
class RunSelection:
    """The stretch of forward rotation kept from one channel, and what was cut."""

    keep: np.ndarray          # indices of the kept edges
    reversed_sign: bool       # the channel counts backward for forward rotation (sign flipped)
    cut: tuple                # dicts: t_from_s, t_to_s, edges, reason
    jitter_edges: int         # back-and-forth edges dropped inside the kept stretch


def select_run(t: np.ndarray, sign: np.ndarray, *, period: int, min_speed_fraction: float,
               standstill_s: float | None = None, trim: bool = True) -> RunSelection:
    """Forward edges of the longest stretch without standstill or reversal (by duration).

    The direction with the larger net count is forward. Only edges that reach a new largest
    position count (a back-and-forth over one line, jitter at rest, adds no edge). A stretch ends
    where the position falls back by two edges or more (a reversal) or where no new edge comes
    for longer than ``standstill_s`` (default: the edge interval at ``min_speed_fraction`` of the
    highest speed of the record, over ``period`` edges). With ``trim=False`` the whole record is
    one stretch and a reversal is an error.
    """
    rev = int(sign.sum(dtype=np.int64)) < 0
    new, brk, first_deep = qk.new_positions(np.ascontiguousarray(sign), rev, np.zeros(5, np.int64))
    if new.size < 2 * period + 2:
        raise MeasurementError(f"only {new.size} forward edges")
    if not trim and first_deep >= 0:
        raise MeasurementError(f"direction reversal at t={t[first_deep]:.9g} s (trimming disabled)")
    if standstill_s is None:
        # the fastest speed from the 1st percentile of the time over ``period`` edges, on at most
        # SPAN_SAMPLES evenly spread spans (a percentile needs no more, and the record may hold tens
        # of millions of edges)
        j = np.arange(0, new.size - period, max(1, (new.size - period) // SPAN_SAMPLES))
        span = t[new[j + period]] - t[new[j]]
        span = span[span > 0]
        fastest = np.percentile(span, 1) / period if span.size else np.inf
        standstill_s = fastest / min_speed_fraction
    a, b = qk.longest_stretch(t, new, brk, float(standstill_s), bool(trim))
    keep = new[a:b]
    cut = []
    if trim:
        if keep[0] > 0:
            cut.append({"t_from_s": float(t[0]), "t_to_s": float(t[keep[0]]), "edges": int(keep[0]),
                        "reason": "standstill, jitter or reversal before the run"})
        if keep[-1] < t.size - 1:
            cut.append({"t_from_s": float(t[keep[-1]]), "t_to_s": float(t[-1]), "edges": int(t.size - 1 - keep[-1]),
                        "reason": "standstill or reversal after the run"})
    jitter = int((keep[-1] - keep[0] + 1) - keep.size)
    return RunSelection(keep=keep, reversed_sign=rev, cut=tuple(cut), jitter_edges=jitter)


def report_run(file: str, ch: str, rs: RunSelection, info: dict) -> None:
    """Add what :func:`select_run` cut from channel ``ch`` to ``info["trimmed"]``, and log it."""
    for c in rs.cut:
        info.setdefault("trimmed", []).append({"channel": ch, **c})
        log.info("%s: channel %r: cut t=%.6g..%.6g s (%d edges): %s", file, ch, c["t_from_s"], c["t_to_s"],
                 c["edges"], c["reason"])
    if rs.jitter_edges:
        log.info("%s: channel %r: %d back-and-forth edges (jitter on one line) not counted", file, ch,
                 rs.jitter_edges)


@dataclass(frozen=True)
class EdgeFileRuns:
    """The forward stretch of each channel of an edges file."""

    spans: dict                     # channel -> (first, last) time of its kept stretch, s
    runs: dict                      # channel -> RunSelection (``keep`` dropped: an empty array)


def _window(t: np.ndarray, settings: ReadSettings) -> np.ndarray | None:
    """Mask of the time window ``t_start_s``..``t_end_s`` (None: no window)."""
    if settings.t_start_s is None and settings.t_end_s is None:
        return None
    lo = settings.t_start_s if settings.t_start_s is not None else -np.inf
    hi = settings.t_end_s if settings.t_end_s is not None else np.inf
    return (t >= lo) & (t < hi)


def windowed(chunk: EdgeChunk, settings: ReadSettings) -> EdgeChunk:
    """The edges of ``chunk`` inside the time window of ``settings``."""
    m = _window(chunk.t, settings)
    if m is None or m.all():
        return chunk
    return EdgeChunk(chunk.channel, chunk.t[m], chunk.row[m], None if chunk.direction is None else chunk.direction[m])


def _signs(d: np.ndarray) -> np.ndarray:
    return np.where(d > 0, 1, -1).astype(np.int8)


def edge_file_runs(meta: MeasurementMeta, settings: ReadSettings) -> EdgeFileRuns | None:
    """First pass over a kind-``edges`` file with a ``direction`` column: the forward stretches.

    Reads times and directions of both channels (9 bytes per edge) inside the time window and
    applies :func:`select_run` to each. Returns None, and leaves the file to the checks of the
    edge stream, when there is nothing to trim this way: no ``direction`` column, no ``-1`` in it,
    or a time or direction value that the stream reports as an error (with its row).

    Raises
    ------
    MeasurementError
        Too few forward edges on a channel, or channels whose forward stretches do not overlap.
    """
    t: dict[str, list] = {ch: [] for ch in CHANNELS}
    s: dict[str, list] = {ch: [] for ch in CHANNELS}
    backward = False
    for chunk in iter_chunks(meta, settings.chunk_rows, allow_outside_data=settings.allow_outside_data):
        assert isinstance(chunk, EdgeChunk)
        d = chunk.direction
        if d is None or first_bad(chunk.t) is not None or not np.isin(d, (1.0, -1.0)).all():
            return None
        chunk = windowed(chunk, settings)
        backward = backward or bool((chunk.direction < 0).any())
        t[chunk.channel].append(chunk.t)
        s[chunk.channel].append(_signs(chunk.direction))
    if not backward:
        return None
    file, period = str(meta.data_path), settings.edge_period or 1
    runs, spans = {}, {}
    for ch in CHANNELS:
        tc = np.concatenate(t.pop(ch)) if t[ch] else np.empty(0)
        if np.any(np.diff(tc) < 0):
            return None  # a decreasing time stamp: the stream names its row
        try:
            rs = select_run(tc, np.concatenate(s.pop(ch)) if s[ch] else np.empty(0, np.int8), period=period,
                            min_speed_fraction=settings.min_speed_fraction)
        except MeasurementError as exc:
            raise MeasurementError(f"{file}: channel {ch!r}: {exc}") from None
        spans[ch] = (float(tc[rs.keep[0]]), float(tc[rs.keep[-1]]))
        runs[ch] = RunSelection(keep=rs.keep[:0], reversed_sign=rs.reversed_sign, cut=rs.cut, jitter_edges=rs.jitter_edges)
    if not min(b for _, b in spans.values()) > max(a for a, _ in spans.values()):
        raise MeasurementError(f"{file}: the forward-rotation stretches of 'input' and 'output' do not overlap")
    return EdgeFileRuns(spans, runs)


class ForwardFilter:
    """Keep, chunk by chunk, the edges of one channel that :func:`select_run` keeps.

    The edges that reach a new largest position (state carried across chunks) inside the channel's
    forward stretch found by :func:`edge_file_runs`; their direction is dropped (they all run
    forward). The channel keeps its own first edge (its angle origin); the common span of both
    channels is cut after the angles are formed, as for records without a ``direction`` column.
    """

    def __init__(self, runs: EdgeFileRuns, channel: str):
        self.t0, self.t1 = runs.spans[channel]
        self.rev = runs.runs[channel].reversed_sign
        self.state = np.zeros(5, np.int64)

    def __call__(self, chunk: EdgeChunk) -> EdgeChunk:
        new, _, _ = qk.new_positions(_signs(chunk.direction), self.rev, self.state)
        tn = chunk.t[new]
        m = (tn >= self.t0) & (tn <= self.t1)
        return EdgeChunk(chunk.channel, tn[m], chunk.row[new][m], None)
