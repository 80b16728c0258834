"""Each corruption a recording can have, as a real corrupted file: an error (or a listed repair) naming the
file, the channel and the row (CSV line) / time. Repaired records must still give the known TE
(conftest.py) within the round-trip tolerances.
"""
from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from signal_synth import MESH, assert_components, synth_angles
from gearrom.errors import MeasurementError
from gearrom.signal import AngleRecord, EdgeRecord, ReadSettings, load_angles, process_measurement, write_measurement


def _lines(run: Path) -> list[str]:
    return (run.parent / "run.csv").read_text().splitlines(keepends=True)


def corrupted(base: Path, tmp: Path, lines: list[str] | None = None, **meta_changes) -> Path:
    """Copy the base run to ``tmp`` with new CSV lines and/or changed JSON keys (None deletes a key)."""
    doc = json.loads(base.read_text())
    for k, v in meta_changes.items():
        if v is None:
            doc.pop(k, None)
        else:
            doc[k] = v
    doc["data"] = "bad.csv"
    (tmp / "bad.json").write_text(json.dumps(doc))
    if lines is None:
        shutil.copy(base.parent / "run.csv", tmp / "bad.csv")
    else:
        (tmp / "bad.csv").write_text("".join(lines))
    return tmp / "bad.json"


def rows_of(lines: list[str], channel: str) -> list[int]:
    """Indices (0-based list index = line number - 1) of the rows of a channel."""
    return [i for i, ln in enumerate(lines) if ln.startswith(channel + ",")]


def t_of(line: str) -> float:
    return float(line.split(",")[1])


def expect_error(path: Path, *parts: str, settings: ReadSettings | None = None) -> str:
    with pytest.raises(MeasurementError) as exc:
        load_angles(path, settings)
    msg = str(exc.value)
    for p in parts:
        assert p in msg, f"{p!r} not in {msg!r}"
    return msg


# -- metadata -------------------------------------------------------------------------------------
def test_missing_key(base_run, tmp_path):
    expect_error(corrupted(base_run, tmp_path, rpm_in=None), "bad.json", "missing key", "rpm_in")


def test_unknown_key(base_run, tmp_path):
    expect_error(corrupted(base_run, tmp_path, rpm=1250), "bad.json", "unknown key", "rpm")


def test_unknown_encoder_key_and_bad_value(base_run, tmp_path):
    enc = {"input": {"edges_per_rev": 4000, "lines": 1000}, "output": {"edges_per_rev": 4000}}
    expect_error(corrupted(base_run, tmp_path, encoders=enc), "bad.json", "encoders.input", "lines")
    enc = {"input": {"edges_per_rev": 0}, "output": {"edges_per_rev": 4000}}
    expect_error(corrupted(base_run, tmp_path, encoders=enc), "bad.json", "edges_per_rev")


def test_not_json(tmp_path):
    (tmp_path / "x.json").write_text("{'format': 1")
    expect_error(tmp_path / "x.json", "x.json", "not valid JSON", "line 1")


def test_missing_data_file(base_run, tmp_path):
    doc = json.loads(base_run.read_text())
    doc["data"] = "nothere.csv"
    (tmp_path / "m.json").write_text(json.dumps(doc))
    expect_error(tmp_path / "m.json", "nothere.csv", "not found")


# -- channels and header --------------------------------------------------------------------------
def test_missing_channel(base_run, tmp_path):
    lines = [ln for ln in _lines(base_run) if not ln.startswith("output,")]
    expect_error(corrupted(base_run, tmp_path, lines), "bad.csv", "channel 'output'", "0 edges")


def test_unknown_channel(base_run, tmp_path):
    lines = _lines(base_run)
    lines[99] = lines[99].replace("input,", "inptu,").replace("output,", "inptu,")
    expect_error(corrupted(base_run, tmp_path, lines), "bad.csv", "line 100", "channel", "inptu")


def test_bad_header(base_run, tmp_path):
    lines = _lines(base_run)
    lines[0] = "chan,time\n"
    expect_error(corrupted(base_run, tmp_path, lines), "bad.csv", "line 1", "channel", "t_s")


def test_not_a_number(base_run, tmp_path):
    lines = _lines(base_run)
    i = rows_of(lines, "output")[500]
    lines[i] = "output,12.3.4\n"
    expect_error(corrupted(base_run, tmp_path, lines), "bad.csv", f"line {i + 1}", "channel 'output'",
                 "not a number")


def test_nan_timestamp(base_run, tmp_path):
    lines = _lines(base_run)
    i = rows_of(lines, "input")[1234]
    lines[i] = "input,nan\n"
    expect_error(corrupted(base_run, tmp_path, lines), "bad.csv", f"line {i + 1}", "channel 'input'",
                 "not a finite number")


# -- time stamps ------------------------------------------------------------------------------------
def test_non_monotonic(base_run, tmp_path):
    lines = _lines(base_run)
    rows = rows_of(lines, "input")
    a, b = rows[2000], rows[2001]
    lines[a], lines[b] = lines[b], lines[a]  # two edges of one channel out of order
    expect_error(corrupted(base_run, tmp_path, lines), "bad.csv", f"line {b + 1}", "channel 'input'",
                 f"t={t_of(lines[b]):.9g} s", "decreases")


def test_duplicated_timestamp_repaired(base_run, tmp_path):
    lines = _lines(base_run)
    i = rows_of(lines, "output")[7000]
    lines.insert(i + 1, lines[i])
    path = corrupted(base_run, tmp_path, lines)
    res = process_measurement(path, MESH)
    (rep,) = res.repairs
    assert rep["kind"] == "duplicate_timestamp" and rep["channel"] == "output" and rep["count"] == 1
    assert "bad.csv" in rep["where"] and re.search(rf"line ({i + 1}|{i + 2})\b", rep["where"])
    assert rep["t_s"] == pytest.approx(t_of(lines[i]), abs=1e-9)
    assert_components(res)
    expect_error(path, "bad.csv", "channel 'output'", "strict", settings=ReadSettings(strict=True))


def test_dropped_edges_filled(base_run, tmp_path):
    lines = _lines(base_run)
    rows = rows_of(lines, "output")
    gone = rows[50_000:50_003]  # three consecutive output edges lost
    t_next = t_of(lines[rows[50_003]])
    lines = [ln for k, ln in enumerate(lines) if k not in set(gone)]
    path = corrupted(base_run, tmp_path, lines)
    res = process_measurement(path, MESH)
    (rep,) = res.repairs
    assert rep["kind"] == "dropped_edges" and rep["count"] == 3 and rep["channel"] == "output"
    assert rep["t_s"] == pytest.approx(t_next, abs=1e-9) and "bad.csv: line" in rep["where"]
    assert_components(res)
    expect_error(path, "bad.csv", "channel 'output'", "dropped", settings=ReadSettings(strict=True))


def test_gap_too_long(base_run, tmp_path):
    lines = _lines(base_run)
    rows = rows_of(lines, "input")
    gone = set(rows[30_000:30_100])
    t_next = t_of(lines[rows[30_100]])
    lines = [ln for k, ln in enumerate(lines) if k not in gone]
    expect_error(corrupted(base_run, tmp_path, lines), "bad.csv", "channel 'input'", f"t={t_next:.9g} s",
                 "gap", "max_fill_edges")


def test_spurious_double_edge_removed(base_run, tmp_path):
    lines = _lines(base_run)
    rows = rows_of(lines, "input")
    i = rows[90_000]
    t0, t1 = t_of(lines[i]), t_of(lines[rows[90_001]])
    lines.insert(i + 1, f"input,{t0 + 0.03 * (t1 - t0):.10f}\n")  # a glitch 3 % of an interval later
    path = corrupted(base_run, tmp_path, lines)
    res = process_measurement(path, MESH)
    (rep,) = res.repairs
    assert rep["kind"] == "double_edge" and rep["channel"] == "input"
    assert rep["where"].endswith(f"line {i + 2}") or rep["where"].endswith(f"line {i + 1}")
    assert_components(res)


def test_direction_reversal_edges(base_run, tmp_path):
    """With trimming off, a reversal is an error (trimmed records: test_signal_trim_edges.py)."""
    lines = _lines(base_run)
    lines = ["channel,t_s,direction\n"] + [ln.rstrip("\n") + ",1\n" for ln in lines[1:]]
    i = rows_of(lines, "output")[3000]
    lines[i] = lines[i].replace(",1\n", ",-1\n")
    expect_error(corrupted(base_run, tmp_path, lines), "bad.csv", f"line {i + 1}", "channel 'output'",
                 f"t={t_of(lines[i]):.9g} s", "direction reversal", settings=ReadSettings(trim=False))


def test_rpm_disagrees(base_run, tmp_path):
    expect_error(corrupted(base_run, tmp_path, rpm_in=1400.0), "bad.json", "rpm_in", "channel 'input'", "t=",
                 "1250")


def test_wrong_edges_per_rev_found_by_ratio(base_run, tmp_path):
    enc = {"input": {"edges_per_rev": 4000}, "output": {"edges_per_rev": 3900}}
    with pytest.raises(MeasurementError, match=r"speed ratio .* z1/z2 = 32/41"):
        process_measurement(corrupted(base_run, tmp_path, encoders=enc), MESH)


# -- kind "angles" and TDMS -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def angle_rows(tmp_path_factory):
    t, th1, th2 = synth_angles(1250.0, revs=3)
    p = write_measurement(tmp_path_factory.mktemp("ang") / "run.json", AngleRecord(t, th1, th2), rpm_in=1250.0)
    return p


def _angle_file(base: Path, tmp: Path, edit) -> Path:
    lines = (base.parent / "run.csv").read_text().splitlines(keepends=True)
    edit(lines)
    return corrupted(base, tmp, lines)


def test_angles_reversal(angle_rows, tmp_path):
    def edit(lines):
        f = lines[800].split(",")
        lines[800] = f"{f[0]},{f[1]},{float(f[2]) - 0.01}\n"
    expect_error(_angle_file(angle_rows, tmp_path, edit), "bad.csv", "line 801", "channel 'output'",
                 "direction reversal")


def test_angles_duplicate_time_and_nan(angle_rows, tmp_path):
    def dup(lines):
        lines.insert(500, lines[499])
    expect_error(_angle_file(angle_rows, tmp_path, dup), "bad.csv", "line 501", "duplicated time stamp")

    def nan(lines):
        f = lines[300].split(",")
        lines[300] = f"{f[0]},nan,{f[2]}"
    expect_error(_angle_file(angle_rows, tmp_path, nan), "bad.csv", "line 301", "theta_in_rad", "not a finite")


def test_angles_gap_listed(angle_rows, tmp_path):
    def gap(lines):
        del lines[1000:1005]
    res = load_angles(_angle_file(angle_rows, tmp_path, gap))
    (rep,) = res.repairs
    assert rep.kind == "gap" and rep.where.endswith("line 1001") and rep.count == 5


def test_tdms_missing_channel(tmp_path):
    from nptdms import ChannelObject, TdmsWriter

    rec = EdgeRecord(np.arange(100) * 1e-4, np.arange(100) * 1e-4, (4000, 4000), 80e6)
    path = write_measurement(tmp_path / "m.json", rec, rpm_in=150.0, data_format="tdms")
    with TdmsWriter(str(tmp_path / "m.tdms")) as w:
        w.write_segment([ChannelObject("edges", "input", rec.t_input_s)])
    expect_error(path, "m.tdms", "channel 'output' missing")


def test_header_whitespace_tolerated(angle_rows, tmp_path):
    """Blanks around header names are not an error (found by the property test: ' t_s' crashed pandas)."""
    def blank(lines):
        lines[0] = " " + lines[0].replace(",", " , ")
    assert load_angles(_angle_file(angle_rows, tmp_path, blank)).t_s.size > 100


@pytest.mark.parametrize("data", ["a\x00.csv", "a" * 5000 + ".csv", "/", ".csv", "run.txt"],
                         ids=["nul", "long", "root", "suffix-only", "txt"])
def test_bad_data_names(base_run, tmp_path, data):
    doc = json.loads(base_run.read_text())
    doc["data"] = data
    (tmp_path / "m.json").write_text(json.dumps(doc))
    expect_error(tmp_path / "m.json", "m.json" if data in ("a\x00.csv", "/", "run.txt") else "", "data")


def test_windows_csv_with_bom_and_crlf(base_run, tmp_path):
    """A CSV written on Windows (UTF-8 byte-order mark, CRLF line ends) reads the same."""
    lines = _lines(base_run)
    path = corrupted(base_run, tmp_path)
    (tmp_path / "bad.csv").write_bytes(b"\xef\xbb\xbf" + "".join(lines).replace("\n", "\r\n").encode())
    a, b = load_angles(base_run), load_angles(path)
    np.testing.assert_array_equal(a.theta_out_rad, b.theta_out_rad)


@pytest.mark.parametrize("chunk", [97, 1000, 4099])
def test_repairs_independent_of_chunking(base_run, tmp_path, chunk):
    """A double edge and dropped edges near chunk boundaries: the same repairs and angles for any chunk size."""
    lines = _lines(base_run)
    rows = rows_of(lines, "input")
    i = rows[5000]
    t0, t1 = t_of(lines[i]), t_of(lines[rows[5001]])
    gone = set(rows_of(lines, "output")[6000:6002])
    lines.insert(i + 1, f"input,{t0 + 0.4 * (t1 - t0):.10f}\n")
    lines = [ln for k, ln in enumerate(lines) if k not in gone]
    path = corrupted(base_run, tmp_path, lines)
    one = load_angles(path)
    many = load_angles(path, ReadSettings(chunk_rows=chunk))
    assert [r.to_dict() for r in many.repairs] == [r.to_dict() for r in one.repairs]
    assert sorted(r.kind for r in one.repairs) == ["double_edge", "dropped_edges"]
    np.testing.assert_allclose(many.theta_out_rad, one.theta_out_rad, rtol=0, atol=1e-12)
    np.testing.assert_allclose(many.theta_in_rad, one.theta_in_rad, rtol=0, atol=1e-12)
