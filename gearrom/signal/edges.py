"""Encoder edges to shaft angle on a uniform time grid, in bounded memory, with repairs.

Edge ``n`` of a channel sits at angle ``n * 2*pi/edges_per_rev`` (plus an unknown offset, taken
as zero at the first edge). :class:`EdgeStream` takes the edges of one channel chunk by chunk,
checks them, repairs what can be repaired and emits the angle, interpolated between edges
(cubic Hermite by default, or linear), at the grid times ``k / fs_hz``.

Checks, against a local reference interval (the median of the two intervals before and the two
after at the same phase of the decoding, i.e. ``period`` and ``2 period`` edges away: with x4
decoding an interval is compared with the ones four and eight edges earlier and later, which
share its A/B phase error; the reference follows the local speed, accelerations and run-ups from
rest included; the first ``2 period`` intervals of a channel have no reference before them and
are not checked). An interval that differs from its reference by no more than twice the timing
resolution (the time-stamp clock or the sample step) is normal whatever the ratios say: an
interval within the timing jitter is never repaired.

- non-finite or decreasing time stamps, direction reversals (``direction`` column = -1): error;
- an interval shorter than ``double_ratio`` times the reference: a spurious double edge (or a
  duplicated time stamp). The edge whose removal leaves the interval closest to the reference is
  removed (repair ``double_edge`` / ``duplicate_timestamp``);
- an interval close to ``m`` times the reference (m >= 2, within ``integer_tol``): ``m - 1``
  dropped edges. The angle advances by ``m`` edges over that interval, i.e. the missing edges are
  filled by linear interpolation in time (repair ``dropped_edges``). Longer or non-integer gaps
  are errors.

Every repair is listed (:class:`Repair`); with ``strict=True`` every repair is an error instead.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass

import numpy as np

import gearrom.signal.qkernel as qk
from gearrom.errors import MeasurementError
from gearrom.signal.readers import EdgeChunk, first_bad, fmt_t
from gearrom.signal.settings import ReadSettings

__all__ = ["EdgeStream", "ReadSettings", "Repair", "check_time_resolution"]


#: Largest float64 spacing of the time stamps, relative to the edge (or row) interval, that passes
#: without a warning: above it the stored times no longer resolve the angle between edges.
TIME_RESOLUTION_RATIO = 1e-4


def check_time_resolution(t_first: float, t_last: float, interval_s: float, where: str) -> float:
    """Warn when float64 time stamps of this magnitude cannot resolve the edge interval.

    Time stamps stored as absolute times (e.g. Unix time, about 1.7e9 s) keep only the float64
    spacing at that magnitude (``numpy.spacing``; 2.4e-7 s at 1.7e9 s); the rest is lost before
    gearrom reads them. The loss is reported, not repaired: subtracting the start time when the
    file is written keeps the resolution.

    Parameters
    ----------
    t_first, t_last : float
        First and last time stamp of the chunk, s.
    interval_s : float
        Typical interval between consecutive stamps (edges or rows), s.
    where : str
        File and channel for the message.

    Returns
    -------
    float
        The float64 spacing (ulp) at the largest magnitude, s.
    """
    ulp = float(np.spacing(max(abs(t_first), abs(t_last))))
    if interval_s > 0 and ulp > TIME_RESOLUTION_RATIO * interval_s:
        warnings.warn(f"{where}: time stamps near t={max(abs(t_first), abs(t_last)):.6g} s are stored with a float64 "
                      f"resolution of {ulp:.3g} s, {ulp / interval_s:.3g} x the interval of {interval_s:.3g} s between "
                      "stamps: the timing below that resolution is lost; store times relative to the start of the "
                      "record", stacklevel=3)
    return ulp


@dataclass(frozen=True)
class Repair:
    """One repair made while reading: kind, channel, location (file and row), time, count, detail."""

    kind: str
    channel: str
    where: str
    t_s: float
    count: int
    detail: str

    def message(self) -> str:
        """One line naming file, channel, row and time."""
        return f"{self.where}, channel {self.channel!r}, t={fmt_t(self.t_s)}: {self.kind}: {self.detail}"

    def to_dict(self) -> dict:
        """JSON-friendly dict."""
        return asdict(self)


class EdgeStream:
    """Turn the edges of one channel, fed chunk by chunk, into angle samples on a uniform grid.

    Parameters
    ----------
    channel : str
        ``"input"`` or ``"output"``.
    edges_per_rev : float
        Counted edges per shaft revolution.
    fs_hz : float
        Grid rate; grid times are ``k / fs_hz`` for integers k.
    file : str
        File name used in messages.
    label : str
        Row label used in messages (``"line"`` or ``"sample"``).
    settings : ReadSettings
    period : int
        Edges per decoding period (intervals are compared with those ``period`` edges away).
    timing_resolution_s : float
        Timing resolution of the edge times, s (intervals within twice this of the reference are
        never repaired).
    """

    def __init__(self, channel: str, edges_per_rev: float, fs_hz: float, file: str, label: str,
                 settings: ReadSettings, period: int = 1, timing_resolution_s: float = 0.0):
        self.channel, self.fs, self.file, self.label, self.s = channel, fs_hz, file, label, settings
        self.period = int(period)
        self.res = float(timing_resolution_s)
        # edges held back per chunk: each decision looks 2 periods ahead (reference) and one edge more
        self._TAIL = max(3, 2 * self.period + 1)
        self.dtheta = 2.0 * math.pi / edges_per_rev
        self.repairs: list[Repair] = []
        self.n_edges = 0
        self.first_t: float | None = None
        self.last_t: float | None = None  # last accepted edge
        self.last_row = -1
        self.last_count = 0
        self.next_k: int | None = None
        self.k0: int | None = None
        self._tail_t = np.empty(0)
        self._tail_row = np.empty(0, np.int64)
        self._prev_d = np.empty(0)  # last two accepted intervals: left context of the reference
        self._out: list[np.ndarray] = []
        self._buf_t = np.empty(0)  # cubic: accepted edges not yet fully emitted (3 kept for slopes)
        self._buf_c = np.empty(0)
        self.n_grid = 0  # grid samples emitted so far (bounded by settings.max_grid_samples)

    # -- messages ---------------------------------------------------------------------------
    def _where(self, row: int) -> str:
        return f"{self.file}: {self.label} {row}"

    def _fail(self, row: int, t: float, why: str) -> MeasurementError:
        return MeasurementError(f"{self._where(row)}, channel {self.channel!r}, t={fmt_t(t)}: {why}")

    def _repair(self, kind: str, row: int, t: float, count: int, detail: str) -> None:
        rep = Repair(kind, self.channel, self._where(row), float(t), int(count), detail)
        if self.s.strict:
            raise MeasurementError(rep.message() + " (strict mode: no repairs allowed)")
        self.repairs.append(rep)
        if len(self.repairs) > self.s.max_repairs:
            raise self._fail(row, t, f"more than max_repairs={self.s.max_repairs} repairs; the record is "
                                     "not trustworthy")

    # -- feeding ------------------------------------------------------------------------------
    def feed(self, chunk: EdgeChunk) -> None:
        """Check and process one chunk of edges of this channel."""
        t, row = chunk.t, chunk.row
        i = first_bad(t)
        if i is not None:
            raise self._fail(int(row[i]), float("nan"), f"time stamp is not a finite number ({t[i]})")
        if chunk.direction is not None:
            d = chunk.direction
            bad = np.flatnonzero(~np.isin(d, (1.0, -1.0)))
            if bad.size:
                j = bad[0]
                raise self._fail(int(row[j]), float(t[j]), f"column 'direction' must be 1 or -1, got {d[j]}")
            rev = np.flatnonzero(d < 0)
            if rev.size:
                j = rev[0]
                raise self._fail(int(row[j]), float(t[j]), "direction reversal (direction = -1); TE needs "
                                 "rotation in one direction")
        self.n_edges += t.size
        self._tail_t = np.concatenate([self._tail_t, t])
        self._tail_row = np.concatenate([self._tail_row, row])
        if self._tail_t.size > self._TAIL + 1:
            self._process(final=False)

    def finish(self) -> tuple[int, np.ndarray]:
        """Process what is left. Returns ``(k0, theta)``: grid index of the first sample, angles (rad)."""
        if self._tail_t.size:
            self._process(final=True)
        if self.s.edge_interp == "cubic" and self._buf_t.size >= 2:
            self._emit_cubic(self._buf_t[-1])
        if self.first_t is None or self.n_edges < 2:
            raise MeasurementError(f"{self.file}: channel {self.channel!r} has {self.n_edges} edges; "
                                   "at least 2 are needed (missing channel?)")
        theta = np.concatenate(self._out) if self._out else np.empty(0)
        self._out = []
        return (self.k0 if self.k0 is not None else 0), theta

    def _process(self, final: bool) -> None:
        t_new, r_new = self._tail_t, self._tail_row
        if self.last_t is None:
            e_t, e_row = t_new, r_new
            if t_new.size >= 2:
                pos = np.diff(t_new)
                pos = pos[pos > 0]
                if pos.size:
                    check_time_resolution(float(t_new[0]), float(t_new[-1]), float(np.median(pos)),
                                          f"{self.file}: channel {self.channel!r}")
            self.first_t = float(t_new[0])
            self.last_count = 0
            self.next_k = math.ceil(self.first_t * self.fs - 1e-9)
            self.k0 = self.next_k
        else:
            e_t = np.concatenate([[self.last_t], t_new])
            e_row = np.concatenate([[self.last_row], r_new])
        n = e_t.size
        if n < 2:
            return
        d = np.diff(e_t)
        neg = np.flatnonzero(d < 0)
        if neg.size:
            j = neg[0]
            raise self._fail(int(e_row[j + 1]), float(e_t[j + 1]),
                             f"time stamp decreases (previous edge at {self.label} {e_row[j]}, t={fmt_t(e_t[j])})")
        ref = self._reference(d)
        r = d / ref
        unchecked = 2 * self.period - self._prev_d.size  # start: no speed reference before these intervals
        r[:unchecked] = 1.0
        # intervals [0, n_dec) are decided now; the last _TAIL edges wait for the next chunk
        n_dec = n - 1 if final else n - 1 - self._TAIL
        if n_dec <= 0:
            return
        keep = np.ones(n, bool)
        jit = 2.0 * self.res  # intervals within the timing jitter of the reference are normal
        small = np.flatnonzero(r[:n_dec] < self.s.double_ratio)  # candidates first: few, so the jitter test is cheap
        small = small[ref[small] - d[small] > jit]
        if small.size:
            r = r.copy()
            self._remove_doubles(small, r, keep, d, e_t, e_row)
        n_acc = n_dec + 1  # edges e[0..n_dec] are accepted or removed now; e[0] was accepted earlier
        if small.size:
            acc = np.flatnonzero(keep[:n_acc])
            ta = e_t[acc]
            dk = np.diff(ta)
            rk = dk / ref[acc[1:] - 1]
            rk[acc[1:] - 1 < unchecked] = 1.0
        else:  # the usual case: no edge removed, slices instead of index arrays
            acc = range(n_acc)
            ta, dk, rk = e_t[:n_acc], d[:n_dec], r[:n_dec]
        inc = np.ones(dk.size, np.int64)
        gaps = np.flatnonzero(rk > self.s.gap_ratio)
        gaps = gaps[dk[gaps] - dk[gaps] / rk[gaps] > jit]
        for g in gaps:
            m = int(round(rk[g]))
            row, tt = int(e_row[acc[g + 1]]), float(ta[g + 1])
            tol = self.s.integer_tol + jit * rk[g] / dk[g]  # the timing jitter in units of the reference
            if abs(rk[g] - m) > tol or m - 1 > self.s.max_fill_edges:
                raise self._fail(row, tt, f"gap of {dk[g]:.6g} s = {rk[g]:.2f} edge intervals at the local speed "
                                 f"since the previous edge; not a whole number of dropped edges (within "
                                 f"integer_tol={self.s.integer_tol:g} plus the timing resolution {self.res:.3g} s) "
                                 f"up to max_fill_edges={self.s.max_fill_edges}; see the edge-check settings "
                                 "([signal] gap_ratio, integer_tol, timing_resolution_s; gearrom te --gap-ratio, "
                                 "--integer-tol, --timing-resolution-s) or cut the record (--t-start/--t-end)")
            inc[g] = m
            self._repair("dropped_edges", row, tt, m - 1, f"{m - 1} dropped edge(s) detected from the speed "
                         f"(interval {rk[g]:.2f} x local mean) and filled by interpolation")
        if gaps.size:
            counts = self.last_count + np.concatenate([[0], np.cumsum(inc)])
        else:  # one count per interval
            counts = self.last_count + np.arange(ta.size, dtype=np.int64)
        self._prev_d = np.concatenate([self._prev_d, dk])[-2 * self.period:]
        self._emit(ta, counts)
        self.last_t, self.last_row, self.last_count = float(ta[-1]), int(e_row[acc[-1]]), int(counts[-1])
        if small.size:
            rest = np.arange(n_acc, n)
            rest = rest[keep[rest]]
            self._tail_t, self._tail_row = e_t[rest], e_row[rest]
        else:
            self._tail_t, self._tail_row = e_t[n_acc:], e_row[n_acc:]

    def _reference(self, d: np.ndarray) -> np.ndarray:
        """Local reference of each interval: median of the intervals ``2P`` and ``P`` edges before and
        ``P`` and ``2P`` after it (``P`` = period; the mean of the middle two of four =
        (sum - max - min) / 2); the ends are padded with the first / last ``2P`` intervals, which keeps
        each padded interval at its own phase of the decoding."""
        p = self.period
        ext = np.concatenate([self._prev_d, d])
        left = np.resize(ext, 2 * p)[:2 * p - self._prev_d.size] if self._prev_d.size < 2 * p else ext[:0]
        right = ext[-2 * p:] if ext.size >= 2 * p else np.resize(ext, 2 * p)
        ext = np.concatenate([left, ext, right])
        ref = np.empty(d.size)
        qk.median4(ext, p, ref)
        if not (ref > 0).all():
            j = int(np.argmin(ref > 0))
            raise MeasurementError(f"{self.file}: channel {self.channel!r}: edge intervals around edge "
                                   f"{self.n_edges - self._tail_t.size + j} of the channel are zero (duplicated "
                                   "time stamps)")
        return ref

    def _remove_doubles(self, small, r, keep, d, e_t, e_row) -> None:
        n = e_t.size
        for i in small:
            if not r[i] < self.s.double_ratio:  # already merged by a previous removal
                continue
            left = i - 1
            while left >= 0 and np.isnan(r[left]):
                left -= 1
            right = i + 1 if i + 1 < r.size else None
            cost_right = abs(r[i] + r[right] - 1.0) if right is not None else math.inf
            cost_left = abs(r[left] + r[i] - 1.0) if left >= 0 else math.inf
            if right is None and left < 0:
                drop = i + 1
            elif cost_left < cost_right:  # drop edge i: merge intervals left and i
                drop, r[left], r[i] = i, r[left] + r[i], np.nan
            else:  # drop edge i + 1: merge intervals i and i + 1
                drop = i + 1
                if right is not None:
                    r[right], r[i] = r[i] + r[right], np.nan
            if drop == 0 or drop >= n:
                drop = i + 1
            keep[drop] = False
            kind = "duplicate_timestamp" if d[i] == 0 else "double_edge"
            self._repair(kind, int(e_row[drop]), float(e_t[drop]), 1,
                         f"spurious edge removed (interval {d[i]:.3g} s, below {self.s.double_ratio} x local mean)")

    def _reserve(self, n: int, t: float) -> None:
        """Count ``n`` more grid samples; refuse before allocating when the grid outgrows the limit."""
        self.n_grid += n
        if self.n_grid > self.s.max_grid_samples:
            raise MeasurementError(
                f"{self.file}: channel {self.channel!r}, t={fmt_t(t)}: the time grid at fs_hz={self.fs:.6g} Hz "
                f"needs more than max_grid_samples={self.s.max_grid_samples} samples "
                f"({8 * self.n_grid / 2**30:.3g} GiB per channel up to this edge); lower the grid rate "
                "(fs_hz, gearrom te --fs-hz) or read a shorter record")

    def _emit(self, ta: np.ndarray, counts: np.ndarray) -> None:
        if self.s.edge_interp == "cubic":
            new = slice(0, None) if self._buf_t.size == 0 else slice(1, None)  # ta[0] is buffered already
            self._buf_t = np.concatenate([self._buf_t, ta[new]])
            self._buf_c = np.concatenate([self._buf_c, counts[new].astype(np.float64)])
            if self._buf_t.size >= 3:
                self._emit_cubic(self._buf_t[-2])  # the last interval waits for its right slope
                self._buf_t, self._buf_c = self._buf_t[-3:], self._buf_c[-3:]
            return
        k_end = math.floor(ta[-1] * self.fs + 1e-9)
        if k_end < self.next_k:
            return
        self._reserve(k_end + 1 - self.next_k, float(ta[-1]))
        k = np.arange(self.next_k, k_end + 1)
        self._out.append(np.interp(k / self.fs, ta, counts.astype(np.float64)) * self.dtheta)
        self.next_k = k_end + 1

    def _emit_cubic(self, t_end: float) -> None:
        """Cubic Hermite through the buffered edges (centred-difference slopes) up to ``t_end``."""
        k_end = math.floor(t_end * self.fs + 1e-9)
        if k_end < self.next_k:
            return
        self._reserve(k_end + 1 - self.next_k, float(t_end))
        out = np.empty(k_end + 1 - self.next_k)
        qk.hermite_grid(self._buf_t, self._buf_c, self.next_k, self.fs, self.dtheta, out)
        self._out.append(out)
        self.next_k = k_end + 1
