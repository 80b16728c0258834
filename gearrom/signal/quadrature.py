"""Decoding of sampled quadrature signals (A/B and optional index) into signed encoder edges.

Each sampled channel goes through a Schmitt trigger (threshold and hysteresis, vectorised: the
logic level is the last sample outside the hysteresis band, carried forward with
``numpy.maximum.accumulate``). The two logic levels give the quadrature phase
``(A, B) = 00, 10, 11, 01 -> 0, 1, 2, 3``; a phase step of +1 is a forward edge, -1 a backward
edge and 2 an *illegal transition* (both channels changed within one sample: the edge rate is too
close to the sample rate, or a glitch). An illegal transition counts two edges in the direction of
the last legal step and is reported.

x4 decoding counts every edge of A and B, x2 the edges of A, x1 the rising edges of A (falling
when running backward), so all three give consistent signed counts.

Edge times are where the sampled signal crosses its switching level, interpolated linearly
between the two samples around the switch (``edge_time="interpolate"``), or the time of the first
sample past the switch (``"sample"``). The timing resolution is the sample step either way: the
interpolation cannot move an edge outside its sample interval.

:func:`select_run` then picks, per channel, the longest stretch of forward rotation without
standstill, so that start-ups from rest, coast-downs, jitter at standstill and direction reversals
are cut instead of stopping the whole record.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gearrom.errors import MeasurementError

_PHASE = np.array([0, 3, 1, 2], np.int8)  # index 2*A + B -> quadrature phase


def schmitt(x: np.ndarray, lo: float, hi: float, init: int) -> np.ndarray:
    """Logic level (0/1) of ``x`` with hysteresis: high above ``hi``, low below ``lo``, else unchanged.

    ``init`` is the level before the first sample (-1: unknown, then the first decided level).
    """
    lev = np.full(x.size, -1, np.int8)
    lev[x > hi] = 1
    lev[x < lo] = 0
    idx = np.where(lev >= 0, np.arange(x.size), -1)
    np.maximum.accumulate(idx, out=idx)
    out = np.where(idx >= 0, lev[np.maximum(idx, 0)], np.int8(init))
    if init < 0 and (out < 0).any():
        known = lev[lev >= 0]
        out[out < 0] = known[0] if known.size else 0
    return out.astype(np.int8)


@dataclass
class _Chan:
    lo: float
    hi: float
    level: int = -1
    x: float = math.nan


def auto_levels(x: np.ndarray, threshold: float | None, hysteresis: float | None, name: str,
                file: str) -> tuple[float, float]:
    """Switching levels ``(lo, hi)``; threshold/hysteresis None: from the channel's 1st/99th percentile."""
    p1, p99 = np.percentile(x, [1, 99])
    swing = float(p99 - p1)
    if threshold is None and not swing > 0:
        raise MeasurementError(f"{file}: channel {name!r} does not switch (constant {p1:.6g} in the first chunk); "
                               "give quadrature.threshold, or check the channel names")
    thr = float(threshold) if threshold is not None else 0.5 * float(p1 + p99)
    hyst = float(hysteresis) if hysteresis is not None else 0.1 * swing
    return thr - hyst / 2, thr + hyst / 2


@dataclass
class DecodeReport:
    """What the decoder saw on one encoder: illegal transitions, index pulses, timing resolution."""

    illegal: int = 0
    illegal_first_t: float | None = None
    index_positions: list = field(default_factory=list)
    sample_step_s: float = math.nan
    levels: dict = field(default_factory=dict)


class QuadratureDecoder:
    """Decode the sampled A/B (and index) channels of one encoder, chunk by chunk.

    Parameters
    ----------
    name : str
        Encoder name (``"input"``/``"output"``), for messages.
    decoding : {1, 2, 4}
        Counted edges per line.
    threshold, hysteresis : float or None
        Switching levels (None: from the signal, see :func:`auto_levels`).
    edge_time : {"interpolate", "sample"}
    file : str
        Data file, for messages.
    """

    def __init__(self, name: str, decoding: int, threshold: float | None, hysteresis: float | None,
                 edge_time: str, file: str):
        self.name, self.k, self.thr, self.hyst, self.edge_time, self.file = \
            name, decoding, threshold, hysteresis, edge_time, file
        self.ch: dict[str, _Chan] = {}
        self.phase: int | None = None
        self.pos = 0  # x4 position (phase-consistent: pos % 4 == phase)
        self.last_dir = 1
        self.t_prev = math.nan
        self.report = DecodeReport()
        self._steps: list[float] = []
        self.t: list[np.ndarray] = []
        self.sign: list[np.ndarray] = []
        self.row: list[np.ndarray] = []

    def _levels(self, key: str, x: np.ndarray) -> np.ndarray:
        if key not in self.ch:
            lo, hi = auto_levels(x, self.thr, self.hyst, f"{self.name}.{key}", self.file)
            self.ch[key] = _Chan(lo, hi)
            self.report.levels[key] = (lo, hi)
        c = self.ch[key]
        lev = schmitt(x, c.lo, c.hi, c.level)
        return lev

    def _cross_t(self, key: str, x: np.ndarray, t: np.ndarray, i: np.ndarray, rising: np.ndarray) -> np.ndarray:
        """Time of the switch of channel ``key`` at sample ``i`` (arrays include the previous sample at 0)."""
        if self.edge_time == "sample":
            return t[i]
        c = self.ch[key]
        lvl = np.where(rising, c.hi, c.lo)
        x0, x1 = x[i - 1], x[i]
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.clip((lvl - x0) / (x1 - x0), 0.0, 1.0)
        frac = np.where(np.isfinite(frac), frac, 1.0)
        return t[i - 1] + frac * (t[i] - t[i - 1])

    def feed(self, t: np.ndarray, a: np.ndarray, b: np.ndarray, z: np.ndarray | None, row0: int) -> None:
        """Decode one chunk of samples (times ``t`` in s; ``row0`` = index of the first sample)."""
        if t.size == 0:
            return
        if t.size > 1:
            self._steps.append(float(np.median(np.diff(t))))
        la, lb = self._levels("a", a), self._levels("b", b)
        first = self.phase is None
        ph = _PHASE[2 * la + lb]
        # prepend the previous sample so that a switch at the chunk start is seen and interpolated
        if first:
            self.phase = int(ph[0])
            self.pos = self.phase
            tp, ap, bp, php = t, a, b, ph
            rows = row0 + np.arange(t.size)
        else:
            tp = np.concatenate([[self.t_prev], t])
            ap = np.concatenate([[self.ch["a"].x], a])
            bp = np.concatenate([[self.ch["b"].x], b])
            php = np.concatenate([[np.int8(self.phase)], ph])
            la = np.concatenate([[np.int8(self.ch["a"].level)], la])
            lb = np.concatenate([[np.int8(self.ch["b"].level)], lb])
            rows = row0 - 1 + np.arange(tp.size)
        step = (np.diff(php.astype(np.int16)) % 4).astype(np.int8)
        i = np.flatnonzero(step) + 1  # sample index (in the prepended arrays) of each switch
        st = step[i - 1]
        sgn = np.where(st == 1, 1, np.where(st == 3, -1, 0)).astype(np.int8)
        illegal = sgn == 0
        if illegal.any():  # direction of the last legal step, carried forward
            idx = np.where(~illegal, np.arange(sgn.size), -1)
            np.maximum.accumulate(idx, out=idx)
            sgn = np.where(idx >= 0, sgn[np.maximum(idx, 0)], np.int8(self.last_dir)).astype(np.int8)
            if self.report.illegal_first_t is None:
                self.report.illegal_first_t = float(tp[i[illegal][0]])
            self.report.illegal += int(illegal.sum())
        if sgn.size:
            self.last_dir = int(sgn[-1])
        da = la[i] != la[i - 1]
        db = lb[i] != lb[i - 1]
        ta = self._cross_t("a", ap, tp, i, la[i] == 1)
        tb = self._cross_t("b", bp, tp, i, lb[i] == 1)
        # one edge per switching channel: a legal step switches one channel, an illegal one both
        t_e = np.concatenate([ta[da], tb[db]])
        s_e = np.concatenate([sgn[da], sgn[db]])
        r_e = np.concatenate([rows[i[da]], rows[i[db]]])
        is_a = np.concatenate([np.ones(int(da.sum()), bool), np.zeros(int(db.sum()), bool)])
        order = np.lexsort((t_e, r_e))
        t_e, s_e, r_e, is_a = t_e[order], s_e[order], r_e[order], is_a[order]
        pos = self.pos + np.cumsum(s_e, dtype=np.int64)
        if self.k == 4:
            keep = np.ones(t_e.size, bool)
        else:  # x2: edges of A; x1: A rising forward / A falling backward (same physical edge)
            off = 1 if self.k == 2 else 3
            before = pos - s_e
            div = 4 // self.k  # x4 steps per counted edge
            keep = is_a & (np.floor_divide(pos + off, div) != np.floor_divide(before + off, div))
        if z is not None:
            self._index(z, t, pos, t_e)
        if pos.size:
            self.pos = int(pos[-1])
        self.t.append(t_e[keep])
        self.sign.append(s_e[keep])
        self.row.append(r_e[keep])
        self.phase = int(ph[-1])
        self.t_prev = float(t[-1])
        self.ch["a"].level, self.ch["b"].level = int(la[-1]), int(lb[-1])
        self.ch["a"].x, self.ch["b"].x = float(a[-1]), float(b[-1])

    def _index(self, z: np.ndarray, t: np.ndarray, pos: np.ndarray, t_e: np.ndarray) -> None:
        lz = self._levels("z", z)
        c = self.ch["z"]
        prev = np.concatenate([[np.int8(c.level if c.level >= 0 else lz[0])], lz[:-1]])
        rise = np.flatnonzero((lz == 1) & (prev == 0))
        if rise.size:
            j = np.searchsorted(t_e, t[rise], side="right") - 1
            p = np.where(j >= 0, pos[np.maximum(j, 0)], self.pos)
            self.report.index_positions.extend(int(v) for v in p)
        c.level = int(lz[-1])

    def result(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """All edges so far: times (s), signs (+1/-1), sample indices."""
        self.report.sample_step_s = float(np.median(self._steps)) if self._steps else math.nan
        cat = (lambda lst, dt: np.concatenate(lst) if lst else np.empty(0, dt))
        return cat(self.t, np.float64), cat(self.sign, np.int8), cat(self.row, np.int64)


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
    s = -sign if rev else sign
    pos = np.cumsum(s, dtype=np.int64)
    rm = np.maximum.accumulate(pos)
    prev_max = np.concatenate([[0], rm[:-1]])
    new = np.flatnonzero(pos > prev_max)
    deep = (rm - pos) >= 2
    if new.size < 2 * period + 2:
        raise MeasurementError(f"only {new.size} forward edges")
    cd = np.concatenate([[0], np.cumsum(deep)])
    brk = np.zeros(new.size, bool)
    brk[1:] = cd[new[1:]] - cd[new[:-1] + 1] > 0  # a reversal between two new-position edges
    if not trim and deep.any():
        j = int(np.argmax(deep))
        raise MeasurementError(f"direction reversal at t={t[j]:.9g} s (trimming disabled)")
    tn = t[new]
    if standstill_s is None:
        span = tn[period:] - tn[:-period]
        fastest = np.percentile(span[span > 0], 1) / period if (span > 0).any() else np.inf
        standstill_s = fastest / min_speed_fraction
    if trim:
        brk[1:] |= np.diff(tn) > standstill_s
    starts = np.concatenate([[0], np.flatnonzero(brk)])
    ends = np.concatenate([starts[1:], [new.size]])
    dur = tn[ends - 1] - tn[starts]
    best = int(np.argmax(dur))
    a, b = int(starts[best]), int(ends[best])
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
