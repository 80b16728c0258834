"""The compiled reference interval and cubic emission of EdgeStream against their vectorised statements.

The reference stream below is :class:`EdgeStream` with the two kernels replaced by the numpy
statements they implement; both must give bit-identical angles and the same repairs on emulated
edges with x4 phase errors, speed changes, dropped and spurious edges, for any chunking.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearrom.errors import MeasurementError
from gearrom.signal import qkernel as qk
from gearrom.signal.edges import EdgeStream, check_time_resolution
from gearrom.signal.readers import EdgeChunk, fmt_t
from gearrom.signal.settings import ReadSettings


def _median4_np(ext: np.ndarray, p: int, n: int) -> np.ndarray:
    a, b, c, e = ext[0:n], ext[p:n + p], ext[3 * p:n + 3 * p], ext[4 * p:n + 4 * p]
    hi = np.maximum(np.maximum(a, b), np.maximum(c, e))
    lo = np.minimum(np.minimum(a, b), np.minimum(c, e))
    return (a + b + c + e - hi - lo) * 0.5


def _hermite_np(bt, bc, k0, k_end, fs, dtheta):
    tg = np.arange(k0, k_end + 1) / fs
    n = bt.size
    i = np.clip(np.searchsorted(bt, tg, side="right") - 1, 0, n - 2)

    def slope(j):
        jl, jr = np.maximum(j - 1, 0), np.minimum(j + 1, n - 1)
        return (bc[jr] - bc[jl]) / (bt[jr] - bt[jl])

    h = bt[i + 1] - bt[i]
    u = (tg - bt[i]) / h
    u2, u3 = u * u, u * u * u
    rel = ((-2 * u3 + 3 * u2) * (bc[i + 1] - bc[i]) + (u3 - 2 * u2 + u) * h * slope(i)
           + (u3 - u2) * h * slope(i + 1))
    return (bc[i] + rel) * dtheta


class _NumpyStream(EdgeStream):
    """EdgeStream with the vectorised statements instead of the compiled kernels, and the interval
    checks written with full-length masks and index arrays (the statement of ``_process``)."""

    def _process(self, final: bool) -> None:  # noqa: C901, PLR0912, PLR0915
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
        small = np.flatnonzero((r[:n_dec] < self.s.double_ratio) & (ref[:n_dec] - d[:n_dec] > jit))
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
            acc = np.arange(n_acc)
            ta, dk, rk = e_t[:n_acc], d[:n_dec], r[:n_dec]
        inc = np.ones(dk.size, np.int64)
        gaps = np.flatnonzero((rk > self.s.gap_ratio) & (dk - dk / rk > jit))
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
        counts = self.last_count + np.concatenate([[0], np.cumsum(inc)])
        self._prev_d = np.concatenate([self._prev_d, dk])[-2 * self.period:]
        self._emit(ta, counts)
        self.last_t, self.last_row, self.last_count = float(ta[-1]), int(e_row[acc[-1]]), int(counts[-1])
        rest = np.arange(n_acc, n)
        rest = rest[keep[rest]]
        self._tail_t, self._tail_row = e_t[rest], e_row[rest]


    def _reference(self, d):
        p = self.period
        ext = np.concatenate([self._prev_d, d])
        left = np.resize(ext, 2 * p)[:2 * p - self._prev_d.size] if self._prev_d.size < 2 * p else ext[:0]
        right = ext[-2 * p:] if ext.size >= 2 * p else np.resize(ext, 2 * p)
        ref = _median4_np(np.concatenate([left, ext, right]), p, d.size)
        if not (ref > 0).all():
            raise MeasurementError("zero intervals")
        return ref

    def _emit_cubic(self, t_end):
        k_end = math.floor(t_end * self.fs + 1e-9)
        if k_end < self.next_k:
            return
        self._reserve(k_end + 1 - self.next_k, float(t_end))
        self._out.append(_hermite_np(self._buf_t, self._buf_c, self.next_k, k_end, self.fs, self.dtheta))
        self.next_k = k_end + 1


def _edges(period: int, n: int = 60_000, seed: int = 0) -> np.ndarray:
    """Edge times of a run-up with a per-phase interval error (x4), jitter, dropped and spurious edges."""
    rng = np.random.default_rng(seed)
    k = np.arange(n + 200)
    w = 2 * math.pi * (20 + 30 * k / k.size)  # rad/s, a run-up
    dt = (2 * math.pi / 4000) / w
    if period == 4:
        dt = dt * (1 + np.array([0.03, -0.02, 0.01, -0.02])[k % 4])
    t = 0.013 + np.cumsum(dt) + rng.normal(0, 2e-8, k.size)
    drop = rng.choice(np.arange(50, t.size - 50), 12, replace=False)
    drop = np.concatenate([drop, drop[:3] + 1])  # three double drops
    t = np.delete(t, drop)
    extra = rng.choice(np.arange(50, t.size - 50), 8, replace=False)
    t = np.sort(np.concatenate([t, t[extra] + 0.1 * (t[extra + 1] - t[extra])]))
    return t[:n]


def _run(cls, t, period, chunk, interp="cubic"):
    s = cls("input", 4000.0, 9000.0, "f", "line", ReadSettings(edge_interp=interp, max_repairs=1000),
            period=period, timing_resolution_s=1e-7)
    rows = np.arange(t.size)
    for a in range(0, t.size, chunk):
        s.feed(EdgeChunk("input", t[a:a + chunk], rows[a:a + chunk]))
    k0, theta = s.finish()
    return k0, theta, s.repairs, (s.last_t, s.last_count)


@pytest.mark.parametrize("period", [1, 4])
@pytest.mark.parametrize("chunk", [7, 1000, 4099, 1 << 20])
def test_stream_identical_to_vectorised(period, chunk):
    t = _edges(period)
    new = _run(EdgeStream, t, period, chunk)
    ref = _run(_NumpyStream, t, period, chunk)
    assert new[0] == ref[0]
    np.testing.assert_array_equal(new[1], ref[1])
    assert new[2] == ref[2] and new[3] == ref[3]
    kinds = {r.kind for r in new[2]}
    assert {"dropped_edges", "double_edge"} <= kinds
    whole = _run(EdgeStream, t, period, t.size)  # chunk boundaries change nothing
    np.testing.assert_array_equal(new[1], whole[1])
    key = lambda r: (r.t_s, r.kind)  # within a chunk, doubles are listed before gaps
    assert sorted(new[2], key=key) == sorted(whole[2], key=key)


def test_linear_unchanged_by_reference_kernel():
    t = _edges(4, 20_000, seed=1)
    new = _run(EdgeStream, t, 4, 3001, "linear")
    ref = _run(_NumpyStream, t, 4, 3001, "linear")
    np.testing.assert_array_equal(new[1], ref[1])
    assert new[2] == ref[2]


def test_kernels_against_statements():
    rng = np.random.default_rng(3)
    bt = np.cumsum(rng.uniform(0.5e-4, 2e-4, 500))
    bt[100] = bt[99]  # a repeated time: the same interval choice as searchsorted
    bc = np.cumsum(rng.integers(1, 3, 500)).astype(np.float64)
    fs = 12345.0
    for k0, k_end in ((0, 5), (math.ceil(bt[0] * fs), math.floor(bt[-1] * fs)), (0, int(bt[-1] * fs) + 40)):
        out = np.empty(k_end + 1 - k0)
        qk.hermite_grid(bt, bc, k0, fs, 0.7, out)
        with np.errstate(all="ignore"):
            np.testing.assert_array_equal(out, _hermite_np(bt, bc, k0, k_end, fs, 0.7))
    ext = rng.uniform(1, 2, 1000)
    for p in (1, 2, 4):
        out = np.empty(ext.size - 4 * p)
        qk.median4(ext, p, out)
        np.testing.assert_array_equal(out, _median4_np(ext, p, out.size))


@pytest.mark.parametrize("fmt", ["hdf5", "csv"])
def test_quadrature_pieces_change_nothing(tmp_path, monkeypatch, fmt):
    """Samples fed to the decoders and edges fed to the streams in small pieces: the same angles."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from quad_synth import write_stage

    from gearrom.signal import load_angles, qload

    path = write_stage(tmp_path, data_format=fmt, duration_s=1.0)
    st = ReadSettings(chunk_rows=150_000)
    ref = load_angles(path, st)
    monkeypatch.setattr(qload, "DECODE_PIECE_SAMPLES", 997)
    monkeypatch.setattr(qload, "STREAM_CHUNK_EDGES", 613)
    new = load_angles(path, st)
    np.testing.assert_array_equal(new.theta_in_rad, ref.theta_in_rad)
    np.testing.assert_array_equal(new.theta_out_rad, ref.theta_out_rad)
    assert new.t_s[0] == ref.t_s[0] and new.info == ref.info
    assert sorted(new.repairs, key=lambda r: (r.t_s, r.kind)) == sorted(ref.repairs, key=lambda r: (r.t_s, r.kind))
