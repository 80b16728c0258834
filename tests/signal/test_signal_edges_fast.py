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
from gearrom.signal.edges import EdgeStream
from gearrom.signal.readers import EdgeChunk
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
    """EdgeStream with the vectorised statements instead of the compiled kernels."""

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
    key = lambda r: (r.t_s, r.kind)  # noqa: E731 - within a chunk doubles are listed before gaps
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
