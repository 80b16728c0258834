"""Decoding of sampled quadrature signals (A/B and optional index) into signed encoder edges.

Each sampled channel goes through a Schmitt trigger (threshold and hysteresis: the logic level is
that of the last sample outside the hysteresis band; before the first such sample of the record,
the level of that sample). The two logic levels give the quadrature phase
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

The decoding is one compiled pass per chunk (:func:`gearrom.signal.qkernel.decode_chunk`); the
state (levels, phase, position, last sample) carries over, so chunk boundaries change nothing.

:func:`gearrom.signal.trim.select_run` then picks, per channel, the longest stretch of forward
rotation without standstill, so that start-ups from rest, coast-downs, jitter at standstill and
direction reversals are cut instead of stopping the whole record.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

import gearrom.signal.qkernel as qk
from gearrom.errors import MeasurementError


@dataclass
class _Chan:
    lo: float
    hi: float


def auto_levels(x: np.ndarray, threshold: float | None, hysteresis: float | None, name: str,
                file: str) -> tuple[float, float]:
    """Switching levels ``(lo, hi)``; threshold/hysteresis None: from the channel's 1st/99th percentile."""
    if threshold is not None and hysteresis is not None:
        return float(threshold) - float(hysteresis) / 2, float(threshold) + float(hysteresis) / 2
    p1, p99 = np.percentile(np.asarray(x, np.float64), [1, 99])
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


_EMPTY = (np.empty(0), np.empty(0, np.int8), np.empty(0, np.int64))


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
        self.report = DecodeReport()
        self._si = np.zeros(qk.N_INT, np.int64)
        self._si[[qk.LA, qk.LB, qk.LZ, qk.PHASE]] = -1
        self._si[qk.LAST_DIR] = 1
        self._sf = np.full(qk.N_FLOAT, math.nan)
        self._levels = np.zeros(6)
        self._steps: list[float] = []
        self._zbuf = np.empty(0, np.int64)
        self._new_output()

    @property
    def pos(self) -> int:
        """x4 position after the last decoded sample (phase-consistent: ``pos % 4 == phase``)."""
        return int(self._si[qk.POS])

    def _chan(self, key: str, x: np.ndarray) -> None:
        if key not in self.ch:
            lo, hi = auto_levels(x, self.thr, self.hyst, f"{self.name}.{key}", self.file)
            self.ch[key] = _Chan(lo, hi)
            self.report.levels[key] = (lo, hi)
            j = 2 * "abz".index(key)
            self._levels[j:j + 2] = lo, hi

    def set_levels(self, a: np.ndarray, b: np.ndarray, z: np.ndarray | None = None) -> None:
        """Fix the switching levels of the channels from these samples (by default they come from
        the first chunk fed)."""
        self._chan("a", a)
        self._chan("b", b)
        if z is not None:
            self._chan("z", z)

    def _new_output(self) -> None:
        self.n = 0
        self._parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._st, self._ss, self._sr = _EMPTY

    def _reserve(self, m: int) -> None:
        """Scratch room for the edges of a chunk of ``m`` samples (at most two per sample).

        A chunk decodes into scratch arrays that are reused from chunk to chunk; only its edges are
        copied out (:meth:`_keep`). The decoded record therefore takes its own size plus one
        chunk's scratch, and no memory is written for capacity that no edge fills.
        """
        if self._st.size < 2 * m:
            self._st, self._ss, self._sr = np.empty(2 * m), np.empty(2 * m, np.int8), np.empty(2 * m, np.int64)
        if self._zbuf.size < m:
            self._zbuf = np.empty(m, np.int64)

    def _keep(self, n: int) -> None:
        """Copy the ``n`` edges of the last chunk out of the scratch arrays."""
        if n:
            self._parts.append((self._st[:n].copy(), self._ss[:n].copy(), self._sr[:n].copy()))
            self.n += n

    def feed(self, t: np.ndarray | None, a: np.ndarray, b: np.ndarray, z: np.ndarray | None, row0: int,
             rate_hz: float | None = None) -> None:
        """Decode one chunk of samples.

        Parameters
        ----------
        t : ndarray or None
            Sample times (s); None: sample ``row0 + j`` is at ``(row0 + j) / rate_hz``.
        a, b, z : ndarray
            Samples of A, B and index (``z`` None: no index channel).
        row0 : int
            Index of the first sample in the record.
        rate_hz : float, optional
            Sample rate (Hz), used when ``t`` is None.
        """
        m = a.size
        if m == 0:
            return
        if t is None:
            if rate_hz is None:
                raise MeasurementError(f"{self.file}: {self.name}: no sample times and no sample rate")
            self._steps.append(1.0 / rate_hz)
            t = np.empty(0)
        elif m > 1:
            self._steps.append(float(np.median(np.diff(t))))
        self._chan("a", a)
        self._chan("b", b)
        cols = [a, b] + ([z] if z is not None else [])
        if len({c.dtype for c in cols}) > 1 or cols[0].dtype.kind not in "fiu":
            cols = [np.asarray(c, np.float64) for c in cols]
        a, b = np.ascontiguousarray(cols[0]), np.ascontiguousarray(cols[1])
        if z is not None:
            self._chan("z", z)
            z = np.ascontiguousarray(cols[2])
        else:
            z = a[:0]
        self._reserve(m)
        n, nz = qk.decode_chunk(a, b, z, np.ascontiguousarray(t, np.float64), int(row0),
                                float(rate_hz or 0.0), self._levels, int(self.k), self.edge_time == "interpolate",
                                self._si, self._sf, self._st, self._ss, self._sr, self._zbuf)
        self._keep(n)
        if nz:
            self.report.index_positions.extend(self._zbuf[:nz].tolist())
        self.report.illegal = int(self._si[qk.ILLEGAL])
        if self._si[qk.HAS_ILLEGAL]:
            self.report.illegal_first_t = float(self._sf[qk.ILLEGAL_T])

    def result(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Hand over the edges decoded so far: times (s), signs (+1/-1), sample indices.

        The decoder keeps no reference to them (the caller owns the only copy, so memory is freed
        when the caller drops them); a later call returns the edges decoded after this one.
        """
        self.report.sample_step_s = float(np.median(self._steps)) if self._steps else math.nan
        parts = self._parts
        parts.reverse()
        out = tuple(np.empty(self.n, e.dtype) for e in _EMPTY)
        i = 0
        while parts:  # each piece is freed once copied: the edges are held about once, not twice
            piece = parts.pop()
            k = piece[0].size
            for o, x in zip(out, piece):
                o[i:i + k] = x
            i += k
            del piece
        self._zbuf = np.empty(0, np.int64)
        self._new_output()
        return out
