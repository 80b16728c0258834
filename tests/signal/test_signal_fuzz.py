"""Property test: random malformed measurement files never make the reader raise anything but
MeasurementError (the documented error class). Files are a small valid run with random edits
(deleted/duplicated/swapped/garbled lines, inserted text, truncation, flipped bytes), random
JSON metadata, and corrupted TDMS files.
"""
from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gearrom.errors import MeasurementError
from gearrom.signal import AngleRecord, ReadSettings, emulate_edges, load_angles, write_measurement

READ = ReadSettings(chunk_rows=64)


def _base_run(folder: Path, name: str) -> Path:
    t = np.linspace(0.0, 0.05, 2001)
    w = 2 * math.pi * 1250 / 60
    if name == "angles":
        rec = AngleRecord(t[::4], w * t[::4], w * t[::4] * 32 / 41)
    else:
        rec = emulate_edges(t, w * t, w * t * 32 / 41, edges_per_rev=1000, clock_hz=1e8)
    fmt = "tdms" if name == "tdms" else "csv"
    return write_measurement(folder / f"base_{name}.json", rec, rpm_in=1250.0, data_format=fmt)


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    return {name: _base_run(d, name) for name in ("csv", "tdms", "angles")}


def _try(path: Path) -> None:
    try:
        load_angles(path, READ)
    except MeasurementError:
        pass


line_ops = st.lists(st.tuples(st.sampled_from(["delete", "duplicate", "swap", "replace", "insert", "field"]),
                              st.integers(0, 10_000), st.text(max_size=30)), min_size=1, max_size=6)


@pytest.mark.parametrize("kind", ["csv", "angles"])
@settings(max_examples=80, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ops=line_ops, truncate=st.one_of(st.none(), st.integers(0, 60_000)),
       flips=st.lists(st.tuples(st.integers(0, 60_000), st.integers(0, 255)), max_size=4))
def test_csv_mutations_raise_only_measurement_error(base, kind, ops, truncate, flips):
    src = base[kind]
    lines = src.with_suffix(".csv").read_text().splitlines(keepends=True)
    for op, pos, text in ops:
        i = pos % len(lines) if lines else 0
        if not lines:
            lines = [text]
        elif op == "delete":
            del lines[i]
        elif op == "duplicate":
            lines.insert(i, lines[i])
        elif op == "swap":
            j = (i + 1) % len(lines)
            lines[i], lines[j] = lines[j], lines[i]
        elif op == "replace":
            lines[i] = text + "\n"
        elif op == "insert":
            lines.insert(i, text)
        else:  # garble one field
            f = lines[i].rstrip("\n").split(",")
            f[pos % len(f)] = text
            lines[i] = ",".join(f) + "\n"
    data = bytearray("".join(lines).encode("utf-8", "surrogatepass"))
    for pos, val in flips:
        if data:
            data[pos % len(data)] = val
    if truncate is not None:
        data = data[:truncate]
    with tempfile.TemporaryDirectory() as d:
        meta = json.loads(src.read_text())
        meta["data"] = "x.csv"
        (Path(d) / "x.json").write_text(json.dumps(meta))
        (Path(d) / "x.csv").write_bytes(bytes(data))
        _try(Path(d) / "x.json")


json_values = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=10),
                           lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=8), c, max_size=3),
                           max_leaves=8)


@settings(max_examples=150, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(edits=st.lists(st.tuples(st.sampled_from(["format", "rpm_in", "kind", "data", "clock_hz", "encoders",
                                                 "config", "extra", "description", "torque_out_Nm", "bogus",
                                                 "encoders.input", "encoders.output.edges_per_rev"]),
                                st.one_of(st.just("__delete__"), json_values)), max_size=3),
       raw=st.one_of(st.none(), st.binary(max_size=40)))
def test_json_mutations_raise_only_measurement_error(base, edits, raw):
    src = base["csv"]
    doc = json.loads(src.read_text())
    for key, val in edits:
        node, parts = doc, key.split(".")
        for p in parts[:-1]:
            node = node.setdefault(p, {}) if isinstance(node, dict) else {}
        if not isinstance(node, dict):
            continue
        if val == "__delete__":
            node.pop(parts[-1], None)
        else:
            node[parts[-1]] = val
    text = raw if raw is not None else json.dumps(doc).encode()
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "x.json").write_bytes(text)
        (Path(d) / "base_csv.csv").write_bytes((src.parent / "base_csv.csv").read_bytes())
        _try(Path(d) / "x.json")


@settings(max_examples=60, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(truncate=st.one_of(st.none(), st.integers(0, 40_000)),
       flips=st.lists(st.tuples(st.integers(0, 40_000), st.integers(0, 255)), max_size=6))
def test_tdms_corruption_raises_only_measurement_error(base, truncate, flips):
    src = base["tdms"]
    data = bytearray((src.parent / "base_tdms.tdms").read_bytes())
    for pos, val in flips:
        data[pos % len(data)] = val
    if truncate is not None:
        data = data[:truncate]
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "base_tdms.json").write_text(src.read_text())
        (Path(d) / "base_tdms.tdms").write_bytes(bytes(data))
        _try(Path(d) / "base_tdms.json")


def test_base_files_are_valid(base):
    """The unmutated files read fine (so the properties above exercise real edits)."""
    for path in base.values():
        assert load_angles(path, READ).t_s.size > 100


@settings(max_examples=100, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.text(max_size=300))
def test_random_data_file_names(base, name):
    doc = json.loads(base["csv"].read_text())
    doc["data"] = name
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "x.json").write_text(json.dumps(doc))
        _try(Path(d) / "x.json")
