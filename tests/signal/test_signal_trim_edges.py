"""Kind ``edges`` with a ``direction`` column: reversals, jitter at rest and a coast-down are cut to
the longest forward stretch, as for sampled quadrature records.

Reference: the same record without the added edges (the clean base run of conftest.py, whose TE
components are known exactly, signal_synth.COMPONENTS). The kept edges of the corrupted record
are the base run's edges, so its TE must equal the base run's TE to rounding.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from signal_synth import assert_components
from gearrom.errors import MeasurementError
from gearrom.signal import ReadSettings, load_angles, process_measurement
from gearrom.signal.trim import select_run


def _rows(base: Path) -> list[tuple[str, float, int]]:
    lines = (base.parent / "run.csv").read_text().splitlines()[1:]
    return [(ln.split(",")[0], float(ln.split(",")[1]), 1) for ln in lines]


def _write(base: Path, tmp: Path, rows: list[tuple[str, float, int]]) -> Path:
    rows = sorted(rows, key=lambda r: r[1])
    (tmp / "rev.csv").write_text("channel,t_s,direction\n" + "".join(f"{c},{t:.10f},{d}\n" for c, t, d in rows))
    doc = json.loads(base.read_text())
    doc["data"] = "rev.csv"
    (tmp / "rev.json").write_text(json.dumps(doc))
    return tmp / "rev.json"


def _after_run(rows, channel: str, pattern: list[int], pause_s: float = 2e-3, step_s: float = 1.2e-5):
    """Edges of ``channel`` after its last edge: a pause, then the direction ``pattern``."""
    t_end = max(t for c, t, _ in rows if c == channel)
    return [(channel, t_end + pause_s + i * step_s, d) for i, d in enumerate(pattern)]


@pytest.fixture(scope="module")
def reversed_run(base_run, tmp_path_factory):
    """The base run, plus: input stops and turns back 60 edges, then forward 20; output jitters at
    rest over one line after the run (edges 0.5 ms apart); one output direction bit in the middle
    flipped (a one-edge back-and-forth)."""
    rows = _rows(base_run)
    rows += _after_run(rows, "input", [-1] * 60 + [1] * 20)
    rows += _after_run(rows, "output", [-1, 1] * 10, step_s=5e-4)
    out_idx = [i for i, r in enumerate(rows) if r[0] == "output"]
    k = out_idx[len(out_idx) // 2]
    rows[k] = (rows[k][0], rows[k][1], -1)
    return _write(base_run, tmp_path_factory.mktemp("rev"), rows)


def test_reversal_is_trimmed_and_te_equals_clean_run(base_run, reversed_run):
    clean = process_measurement(base_run)
    res = process_measurement(reversed_run)
    assert_components(res)
    assert res.t_s.size == clean.t_s.size and res.t_s[0] == clean.t_s[0]
    # the flipped bit costs two edges that the gap repair puts back (filled linearly in time): the
    # angles equal the clean run's outside the bridged interval, and differ inside it by less than
    # the TE curvature over three output edge intervals allows (GMF1 5 um at order 32: ~0.3 um)
    (rep,) = res.repairs
    near = np.abs(res.t_s - rep["t_s"]) < 4 * 60 / 1250 / 4000 * 41 / 32
    np.testing.assert_allclose(res.te_m[~near], clean.te_m[~near], rtol=0, atol=1e-11)
    assert np.abs(res.te_m[near] - clean.te_m[near]).max() < 0.3e-6


def test_trim_report(reversed_run):
    data = load_angles(reversed_run)
    cut = {c["channel"]: c for c in data.info["trimmed"]}
    assert set(cut) == {"input", "output"}
    assert cut["input"]["edges"] == 80 and "after the run" in cut["input"]["reason"]
    assert cut["output"]["edges"] == 20
    assert data.info["direction"]["output"]["jitter_edges_dropped"] == 2
    assert data.info["direction"]["input"]["reversed_sign"] is False
    kinds = [(r.kind, r.channel, r.count) for r in data.repairs]
    assert kinds == [("dropped_edges", "output", 2)]


def test_no_trim_keeps_the_reversal_error(reversed_run):
    with pytest.raises(MeasurementError, match=r"rev\.csv: line [0-9]+, channel '(input|output)', t=.*direction reversal"):
        load_angles(reversed_run, ReadSettings(trim=False))


@pytest.mark.parametrize("chunk_rows", [997, 100_000])
def test_streamed_filter_keeps_what_select_run_keeps(base_run, reversed_run, chunk_rows):
    """The chunked second pass keeps exactly the edges select_run keeps on the whole channel."""
    from gearrom.signal.measurement import read_meta
    from gearrom.signal.readers import iter_chunks
    from gearrom.signal.trim import ForwardFilter, edge_file_runs

    meta = read_meta(reversed_run)
    s = ReadSettings(chunk_rows=chunk_rows)
    runs = edge_file_runs(meta, s)
    rows = [r for r in _rows(base_run)]
    for ch in ("input", "output"):
        f = ForwardFilter(runs, ch)
        got = np.concatenate([f(c).t for c in iter_chunks(meta, chunk_rows) if c.channel == ch])
        doc = (reversed_run.parent / "rev.csv").read_text().splitlines()[1:]
        t = np.array([float(ln.split(",")[1]) for ln in doc if ln.startswith(ch)])
        d = np.array([int(ln.split(",")[2]) for ln in doc if ln.startswith(ch)], np.int8)
        rs = select_run(t, d, period=1, min_speed_fraction=s.min_speed_fraction)
        want = t[rs.keep]
        np.testing.assert_array_equal(got, want)
        assert got.size >= sum(1 for r in rows if r[0] == ch) - 2
