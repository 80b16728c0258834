"""Sampled quadrature records (kind ``quadrature``): decoding, readers, trimming, timing-aware checks,
run-ups and encoder scale.

References: the emulated truth of ``quad_synth`` (imposed TE, known line counts and speeds) and
hand-made A/B sequences whose counts follow from the quadrature definition.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gearrom.errors import MeasurementError
from gearrom.signal import ReadSettings, TESettings, process_measurement
from gearrom.signal.daq import DAQSettings
from gearrom.signal.quadrature import QuadratureDecoder
from gearrom.signal.trim import select_run
from quad_synth import RB1, RPM, TE_AMP, te_truth, write_stage


def _decode(a, b, k=4, edge_time="sample"):
    d = QuadratureDecoder("input", k, 0.5, 0.2, edge_time, "test")
    t = np.arange(len(a), dtype=float)
    d.feed(t, np.asarray(a, float), np.asarray(b, float), None, 0)
    return d.result(), d


# forward quadrature cycle (A leads B): 00 -> 10 -> 11 -> 01 -> 00
FWD_A = [0, 1, 1, 0] * 5
FWD_B = [0, 0, 1, 1] * 5


@pytest.mark.parametrize("k, n", [(4, 19), (2, 10), (1, 5)])
def test_decoding_counts_forward(k, n):
    """19 phase steps forward: x4 counts each, x2 counts A's edges (10), x1 A's rising edges (5)."""
    (t, s, _), _ = _decode(FWD_A, FWD_B, k)
    assert s.size == n and (s == 1).all()


def test_decoding_backward_and_signed():
    """Reversing the sequence counts down; the signed sum is the net position."""
    (t, s, _), _ = _decode(FWD_A[::-1], FWD_B[::-1], 4)
    assert (s == -1).all() and s.sum() == -19


def test_illegal_transition_reported_and_counted_twice():
    """00 -> 11 skips a phase: two edges in the direction of the last legal step, reported."""
    a = [0, 1, 1, 0, 0, 1, 1]
    b = [0, 0, 1, 1, 0, 1, 1]  # step 4 -> 5: 00 -> 11
    (t, s, _), d = _decode(a, b, 4)
    assert d.report.illegal == 1 and s.sum() == 6


def test_chunked_decoding_equals_whole():
    """Chunk boundaries change nothing (the state carries over)."""
    rng = np.random.default_rng(3)
    phi = np.cumsum(rng.uniform(0.0, 0.9, 3000))
    a, b = (np.sin(phi) > 0).astype(float), (np.sin(phi - math.pi / 2) > 0).astype(float)
    (t1, s1, _), _ = _decode(a, b, 4, "interpolate")
    d = QuadratureDecoder("input", 4, 0.5, 0.2, "interpolate", "test")
    tt = np.arange(a.size, dtype=float)
    for i in range(0, a.size, 77):
        d.feed(tt[i:i + 77], a[i:i + 77], b[i:i + 77], None, i)
    t2, s2, _ = d.result()
    np.testing.assert_array_equal(s1, s2)
    np.testing.assert_allclose(t1, t2)


def test_select_run_cuts_jitter_and_reversal():
    """Jitter at rest (back and forth over one line) and a reversal are cut; the longest forward run stays."""
    t = np.concatenate([np.arange(10) * 50.0, 500.0 + np.arange(30)])  # slow jitter at rest, then running
    s = np.array([1, -1] * 5 + [1] * 20 + [-1] * 5 + [1] * 5)
    rs = select_run(t, s, period=1, min_speed_fraction=0.05)
    # edge 10 re-crosses the line of the jitter; the first new position is edge 11
    assert rs.keep[0] == 11 and rs.keep[-1] == 29 and rs.cut
    with pytest.raises(MeasurementError, match="reversal"):
        select_run(t, s, period=1, min_speed_fraction=0.05, trim=False)


@pytest.fixture(scope="module")
def stage(tmp_path_factory):
    """The acceptance record: 5 s at 50 kHz, 1000 lines, 15/30, start-up, steady, coast-down (MATLAB v5)."""
    return write_stage(tmp_path_factory.mktemp("stage"))


def _steady_error(res, t0, t1):
    """Rms difference between processed TE and the emulated truth inside [t0, t1] (offset and slope removed)."""
    m = (res.t_s >= t0) & (res.t_s <= t1)
    th = res.theta_in_rad[m]
    err = res.te_m[m] - te_truth(th - res.theta_in_rad[0] + 0.0)
    A = np.vstack([np.ones_like(th), th]).T
    err = err - A @ np.linalg.lstsq(A, err, rcond=None)[0]
    return float(np.sqrt(np.mean(err ** 2)))


def test_acceptance_te_of_steady_part(stage):
    """The TE in the steady part matches the truth within the timing-resolution floor.

    Floor: each channel's edge times are known to one sample step dt = 20 us (uniform error, rms
    dt/sqrt(12)); the TE error of one channel is r_b omega dt/sqrt(12), both channels together
    sqrt(2) times that: 1.0 um at 82 rpm. The phase of the truth is unknown up to the angle of the
    first edge, so the truth is aligned by a least-squares phase fit.
    """
    res = process_measurement(stage)
    info = res.to_json_dict()
    assert not info["speed"]["steady"] and "not a steady run" in info["speed"]["statement"]
    t0, t1 = info["speed"]["steady_window_s"]
    assert t1 - t0 > 1.5
    assert info["rpm_in"] == pytest.approx(RPM, rel=2e-3)
    assert info["trimmed"]
    q = info["quadrature"]["input"]
    assert q["sample_rate_hz"] == pytest.approx(50e3) and 0.09 < q["resolution_of_edge_interval"] < 0.12
    # align the truth's phase (the angle of the first kept edge is unknown to the reader)
    m = (res.t_s >= t0) & (res.t_s <= t1)
    th, te = res.theta_in_rad[m], res.te_m[m]
    best = min(np.linspace(0, 2 * math.pi, 4001)[:-1],
               key=lambda off: np.sum((te - te.mean() - (te_truth(th + off) - te_truth(th + off).mean())) ** 2))
    err = te - te_truth(th + best)
    A = np.vstack([np.ones_like(th), th]).T
    err = err - A @ np.linalg.lstsq(A, err, rcond=None)[0]
    # the emulated A/B phase error displaces the x4 edges within each line: an encoder error at the
    # line order (1000) and its harmonics, not a timing error; it is removed above order 500
    f_rot = RPM / 60.0
    spec = np.fft.rfft(err)
    spec[np.fft.rfftfreq(err.size, 1 / res.fs_hz) > 500 * f_rot] = 0
    err = np.fft.irfft(spec, err.size)
    floor = math.sqrt(2) * RB1 * RPM * 2 * math.pi / 60 * 20e-6 / math.sqrt(12)
    assert float(np.sqrt(np.mean(err ** 2))) < floor
    assert info["gmf_amplitude_um"][0] == pytest.approx(TE_AMP * 1e6, rel=0.01)


@pytest.mark.parametrize("fmt, layout", [("csv", "struct"), ("tdms", "struct"), ("hdf5", "struct"),
                                         ("mat", "variables"), ("mat", "matrix"), ("mat73", "struct"),
                                         ("mat73", "matrix")])
def test_readers_give_the_same_gmf(tmp_path, fmt, layout):
    """Every supported file form of the same 2 s record gives the same mesh-order amplitude (the truth)."""
    path = write_stage(tmp_path, data_format=fmt, layout=layout, duration_s=2.0, with_time=fmt != "hdf5")
    res = process_measurement(path)
    assert res.gmf_lines()[0][0] == pytest.approx(TE_AMP, rel=0.02)


def test_time_window(stage):
    """--t-start/--t-end: only the window is used, and it is reported."""
    res = process_measurement(stage, read_settings=ReadSettings(t_start_s=1.2, t_end_s=2.8))
    assert res.t_s[0] >= 1.2 and res.t_s[-1] <= 2.8
    d = res.to_json_dict()
    assert d["window_s"] == [1.2, 2.8] and d["speed"]["steady"]


def test_output_scale_estimated(tmp_path):
    """An output encoder turning 1.0325 x its shaft (the 1.937 case) fails the ratio check; with
    estimate_scale it is estimated (reference: the emulated ratio) and the GMF matches the truth."""
    path = write_stage(tmp_path, duration_s=3.0, out_ratio=1.0325)
    with pytest.raises(MeasurementError, match="speed ratio"):
        process_measurement(path)
    res = process_measurement(path, te_settings=TESettings(estimate_scale="output"))
    assert res.info["encoder_scale"]["scale"] == pytest.approx(1.0325, rel=2e-4)
    assert res.gmf_lines()[0][0] == pytest.approx(TE_AMP, rel=0.02)


def test_encoder_ratio_key_corrects_scale(tmp_path):
    """The same record with encoders.output.ratio = 1.0325 passes the ratio check."""
    path = write_stage(tmp_path, duration_s=3.0, out_ratio=1.0325,
                       encoders={"input": {"lines": 1000}, "output": {"lines": 1000, "ratio": 1.0325}})
    res = process_measurement(path)
    assert res.gmf_lines()[0][0] == pytest.approx(TE_AMP, rel=0.02)


def test_phase_error_and_noise_do_not_trigger_repairs(tmp_path):
    """A large A/B phase error (x4 intervals 0.43/1.57 of the mean) with sampling: no repair and no
    gap error, because intervals are compared four edges apart and within the timing resolution."""
    daq = DAQSettings(noise_V=0.1, phase_error_rad=0.9, jitter_s=1e-6)
    path = write_stage(tmp_path, duration_s=3.0, daq=daq)
    res = process_measurement(path)
    assert res.repairs == ()
    with pytest.raises(MeasurementError):  # comparing neighbours instead fails on the same record
        process_measurement(path, read_settings=ReadSettings(edge_period=1, timing_resolution_s=1e-9))


def test_sampled_edges_not_repaired_within_timing_jitter():
    """Edge times quantized to a 20 us sample step (11 % of the interval) with an x4 pattern: the
    stream repairs nothing when told the timing resolution, as the edges are all there."""
    from gearrom.signal.edges import EdgeStream
    from gearrom.signal.readers import EdgeChunk

    n = 20000
    base = np.arange(n) * 183e-6 + np.tile([0, 40e-6, 0, -40e-6], n // 4)
    t = np.floor(base / 20e-6) * 20e-6
    s = EdgeStream("input", 4000, 5000.0, "f", "line", ReadSettings(), period=4, timing_resolution_s=20e-6)
    s.feed(EdgeChunk("input", t, np.arange(n)))
    s.finish()
    assert s.repairs == [] and s.last_count == n - 1


def test_cli_te_runs_with_only_the_file(stage, tmp_path, capsys):
    """Acceptance: ``gearrom te FILE`` with no other option."""
    from gearrom.cli import main

    out = tmp_path / "te.json"
    assert main(["te", str(stage), "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["gmf_amplitude_um"][0] == pytest.approx(TE_AMP * 1e6, rel=0.01)
    assert "timing resolution" in capsys.readouterr().out


def test_cli_bad_window_option(stage, capsys):
    """--t-end before --t-start: one line naming the option, exit code 2."""
    from gearrom.cli import main

    assert main(["te", str(stage), "--t-start", "3", "--t-end", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--t-end" in err[0]


# -- compiled decoder against a pure-numpy reference ----------------------------------------------

_REF_PHASE = np.array([0, 3, 1, 2], np.int8)


def _ref_schmitt(x, lo, hi, init):
    """Vectorised Schmitt trigger: the last level decided outside [lo, hi], carried forward."""
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


class _RefDecoder:
    """Vectorised (numpy) statement of the decoder: each chunk with the previous sample prepended."""

    def __init__(self, k, lo, hi, interp):
        self.k, self.lo, self.hi, self.interp = k, lo, hi, interp
        self.lev = {"a": -1, "b": -1, "z": -1}
        self.x = {"a": math.nan, "b": math.nan}
        self.phase, self.pos, self.last_dir, self.t_prev = None, 0, 1, math.nan
        self.illegal, self.illegal_t, self.index = 0, None, []
        self.t, self.s, self.r = [], [], []

    def _cross(self, x, t, i, rising):
        if not self.interp:
            return t[i]
        lvl = np.where(rising, self.hi, self.lo)
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.clip((lvl - x[i - 1]) / (x[i] - x[i - 1]), 0.0, 1.0)
        frac = np.where(np.isfinite(frac), frac, 1.0)
        return t[i - 1] + frac * (t[i] - t[i - 1])

    def feed(self, t, a, b, z, row0):
        a, b = np.asarray(a, float), np.asarray(b, float)
        la, lb = _ref_schmitt(a, self.lo, self.hi, self.lev["a"]), _ref_schmitt(b, self.lo, self.hi, self.lev["b"])
        ph = _REF_PHASE[2 * la + lb]
        if self.phase is None:
            self.phase = self.pos = int(ph[0])
            tp, ap, bp, php, rows = t, a, b, ph, row0 + np.arange(t.size)
        else:
            tp, ap, bp = np.r_[self.t_prev, t], np.r_[self.x["a"], a], np.r_[self.x["b"], b]
            php = np.r_[np.int8(self.phase), ph]
            la, lb = np.r_[np.int8(self.lev["a"]), la], np.r_[np.int8(self.lev["b"]), lb]
            rows = row0 - 1 + np.arange(tp.size)
        step = (np.diff(php.astype(np.int16)) % 4).astype(np.int8)
        i = np.flatnonzero(step) + 1
        st = step[i - 1]
        sgn = np.where(st == 1, 1, np.where(st == 3, -1, 0)).astype(np.int8)
        bad = sgn == 0
        if bad.any():
            idx = np.where(~bad, np.arange(sgn.size), -1)
            np.maximum.accumulate(idx, out=idx)
            sgn = np.where(idx >= 0, sgn[np.maximum(idx, 0)], np.int8(self.last_dir)).astype(np.int8)
            self.illegal_t = self.illegal_t if self.illegal_t is not None else float(tp[i[bad][0]])
            self.illegal += int(bad.sum())
        if sgn.size:
            self.last_dir = int(sgn[-1])
        da, db = la[i] != la[i - 1], lb[i] != lb[i - 1]
        ta, tb = self._cross(ap, tp, i, la[i] == 1), self._cross(bp, tp, i, lb[i] == 1)
        t_e, s_e = np.r_[ta[da], tb[db]], np.r_[sgn[da], sgn[db]]
        r_e, is_a = np.r_[rows[i[da]], rows[i[db]]], np.r_[np.ones(da.sum(), bool), np.zeros(db.sum(), bool)]
        o = np.lexsort((t_e, r_e))
        t_e, s_e, r_e, is_a = t_e[o], s_e[o], r_e[o], is_a[o]
        pos = self.pos + np.cumsum(s_e, dtype=np.int64)
        keep = np.ones(t_e.size, bool)
        if self.k != 4:
            off, div = (1 if self.k == 2 else 3), 4 // self.k
            keep = is_a & ((pos + off) // div != (pos - s_e + off) // div)
        if z is not None:
            lz = _ref_schmitt(np.asarray(z, float), self.lo, self.hi, self.lev["z"])
            prev = np.r_[np.int8(self.lev["z"] if self.lev["z"] >= 0 else lz[0]), lz[:-1]]
            rise = np.flatnonzero((lz == 1) & (prev == 0))
            j = np.searchsorted(t_e, t[rise], side="right") - 1
            self.index += [int(v) for v in np.where(j >= 0, pos[np.maximum(j, 0)], self.pos)]
            self.lev["z"] = int(lz[-1])
        if pos.size:
            self.pos = int(pos[-1])
        self.t.append(t_e[keep]), self.s.append(s_e[keep]), self.r.append(r_e[keep])
        self.phase, self.t_prev = int(ph[-1]), float(t[-1])
        self.lev["a"], self.lev["b"] = int(la[-1]), int(lb[-1])
        self.x["a"], self.x["b"] = float(a[-1]), float(b[-1])

    def result(self):
        return np.concatenate(self.t), np.concatenate(self.s), np.concatenate(self.r)


def _emulated_analog(n=6000, seed=7, dtype=np.float64):
    """Noisy, jittered A/B/Z around 0..1 with slow and fast stretches, a reversal, a glitch causing
    illegal transitions and samples exactly on the switching levels (0.4/0.6)."""
    rng = np.random.default_rng(seed)
    speed = np.concatenate([rng.uniform(0.0, 0.3, n // 3), rng.uniform(0.5, 2.2, n // 3),
                            -rng.uniform(0.0, 0.6, n - 2 * (n // 3))])
    phi = np.cumsum(speed) + rng.normal(0, 0.02, n)  # jitter
    a = 0.5 + 0.5 * np.sin(phi) + rng.normal(0, 0.06, n)  # noise: crossings back and forth in the band
    b = 0.5 + 0.5 * np.sin(phi - math.pi / 2) + rng.normal(0, 0.06, n)
    z = (np.sin(phi / 37.0) > 0.995).astype(float) + rng.normal(0, 0.05, n)
    a[::97], b[::89] = 0.6, 0.4  # exactly on the levels
    a[1500:1502], b[1500:1502] = 1.0 - np.round(a[1499]), 1.0 - np.round(b[1499])  # glitch: both switch
    if dtype != np.float64:
        a, b, z = (np.round(v * 1000).astype(dtype) for v in (a, b, z))
    return a, b, z


@pytest.mark.parametrize("k", [1, 2, 4])
@pytest.mark.parametrize("edge_time", ["interpolate", "sample"])
@pytest.mark.parametrize("dtype", [np.float64, np.int16])
def test_compiled_decoder_equals_numpy_reference(k, edge_time, dtype):
    """Edges, signs, rows, illegal transitions and index positions are bit-identical to the vectorised
    statement, with chunk boundaries inside the hysteresis band and with times given or from the rate."""
    a, b, z = _emulated_analog(dtype=dtype)
    scale = 1000.0 if dtype != np.float64 else 1.0
    lo, hi = 0.4 * scale, 0.6 * scale
    rate = 3.0e5
    t = np.arange(a.size) / rate
    inband = np.flatnonzero((a > lo) & (a < hi))
    cuts = sorted({0, int(inband[10]), int(inband[200]), 2500, 2501, 4000, a.size})
    ref = _RefDecoder(k, lo, hi, edge_time == "interpolate")
    new = QuadratureDecoder("input", k, 0.5 * scale, 0.2 * scale, edge_time, "test")
    new_rate = QuadratureDecoder("input", k, 0.5 * scale, 0.2 * scale, edge_time, "test")
    for c0, c1 in zip(cuts[:-1], cuts[1:]):
        ref.feed(t[c0:c1], a[c0:c1], b[c0:c1], z[c0:c1], c0)
        new.feed(t[c0:c1], a[c0:c1], b[c0:c1], z[c0:c1], c0)
        new_rate.feed(None, a[c0:c1], b[c0:c1], z[c0:c1], c0, rate_hz=rate)
    want = ref.result()
    assert ref.illegal > 0 and len(ref.index) > 2 and (want[1] < 0).any() and (want[1] > 0).any()
    for d in (new, new_rate):
        got = d.result()
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)
        assert d.report.illegal == ref.illegal and d.report.illegal_first_t == ref.illegal_t
        assert d.report.index_positions == ref.index


def _ref_select_run(t, sign, period, min_speed_fraction, trim=True):
    """Vectorised statement of :func:`select_run`: kept edge indices."""
    s = -sign if int(sign.sum(dtype=np.int64)) < 0 else sign
    pos = np.cumsum(s, dtype=np.int64)
    rm = np.maximum.accumulate(pos)
    new = np.flatnonzero(pos > np.r_[0, rm[:-1]])
    deep = (rm - pos) >= 2
    if not trim and deep.any():
        return None
    cd = np.r_[0, np.cumsum(deep)]
    brk = np.zeros(new.size, bool)
    brk[1:] = cd[new[1:]] - cd[new[:-1] + 1] > 0
    tn = t[new]
    span = tn[period:] - tn[:-period]
    standstill = np.percentile(span[span > 0], 1) / period / min_speed_fraction
    if trim:
        brk[1:] |= np.diff(tn) > standstill
    starts = np.r_[0, np.flatnonzero(brk)]
    ends = np.r_[starts[1:], new.size]
    best = int(np.argmax(tn[ends - 1] - tn[starts]))
    return new[starts[best]:ends[best]]


@pytest.mark.parametrize("seed", range(6))
def test_select_run_equals_numpy_reference(seed):
    """Kept edges equal the vectorised statement on random walks: backward starts, reversals, jitter,
    standstills, with and without trimming."""
    rng = np.random.default_rng(seed)
    n = 4000
    sign = np.where(rng.random(n) < 0.8, 1, -1).astype(np.int8)
    sign[:30] = -1  # starts backward: the start position is not a reached maximum
    sign[2000:2040] *= -1 if seed % 2 else 1
    t = np.cumsum(rng.exponential(1.0, n) * np.where(rng.random(n) < 0.002, 200.0, 1.0))
    for trim, sign in [(True, sign), (False, sign), (True, -sign)]:
        want = _ref_select_run(t, sign, 4, 0.05, trim)
        if want is None:
            with pytest.raises(MeasurementError, match="reversal"):
                select_run(t, sign, period=4, min_speed_fraction=0.05, trim=trim)
        else:
            np.testing.assert_array_equal(select_run(t, sign, period=4, min_speed_fraction=0.05, trim=trim).keep,
                                          want)
