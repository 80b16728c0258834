"""Small version of the streaming benchmark (benchmarks/bench_signal_stream.py runs the 10 s, 2 x 40000
edges/rev, 5000 rpm record): memory depends on the chunk size, not on the record length, and the
streamed angles are the emulated ones."""
from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest

from gearrom.signal import ReadSettings, emulate_edges, load_angles, write_measurement


def _record(folder, seconds):
    t = np.arange(0, seconds, 1 / 200e3)
    w = 2 * math.pi * 5000 / 60
    rec = emulate_edges(t, w * t, w * t * 32 / 41, edges_per_rev=40000, jitter_s=1e-9, rng=0)
    return write_measurement(folder / f"s{seconds}.json", rec, rpm_in=5000.0)


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    d = tmp_path_factory.mktemp("stream")
    return {s: _record(d, s) for s in (0.05, 0.3)}


def _peak(path, chunk):
    tracemalloc.start()
    try:
        data = load_angles(path, ReadSettings(chunk_rows=chunk))
        return tracemalloc.get_traced_memory()[1], data
    finally:
        tracemalloc.stop()


def test_memory_bounded_by_chunk_not_record(records):
    """6x longer record, same chunk size: the traced peak grows only by the output grid (8 B x 2 channels x
    fs x duration, about 0.8 MB here), far below the record's own size (1.8 M edges x 8 B = 14 MB)."""
    short, _ = _peak(records[0.05], 20_000)
    long, data = _peak(records[0.3], 20_000)
    edges = sum(data.n_edges.values())
    assert edges > 1.7e6
    grid = 3 * 8 * data.t_s.size  # t, theta_in, theta_out of the result
    assert long - short < 1.5 * grid + 1e6
    assert long < 0.5 * 8 * edges


def test_long_record_angles_match_the_emulated_truth(records):
    """The streamed 0.3 s record (1.8 M edges, 20 000-row chunks) against the emulation's own shaft angles:
    constant speeds 5000 rpm and 5000 x 32/41 rpm, so each angle is a straight line in time. The residual
    of a line fit stays within a tenth of an edge pitch (2 pi / 40000; the 1 ns timing jitter alone is
    0.003 pitch, one lost or doubled edge leaves about half a pitch) and the slopes are the emulated
    speeds to 1e-8. (Throughput is measured by benchmarks/bench_signal_stream.py.)"""
    data = load_angles(records[0.3], ReadSettings(chunk_rows=20_000))
    w = 2 * math.pi * 5000 / 60
    pitch = 2 * math.pi / 40000
    assert sum(data.n_edges.values()) > 1.7e6
    for theta, speed in ((data.theta_in_rad, w), (data.theta_out_rad, w * 32 / 41)):
        slope, icpt = np.polyfit(data.t_s, theta, 1)
        assert slope == pytest.approx(speed, rel=1e-8)
        assert np.max(np.abs(theta - (slope * data.t_s + icpt))) < 0.1 * pitch