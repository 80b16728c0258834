"""The command line's JSON outputs for the bundled configs equal those saved from the code before the
restructuring into plugins and registries (``tests/data/cli_baseline``, written by ``tests/cli_baseline.py``
on the commit named in its ``baseline.json``), within numerical noise (relative 1e-5, absolute 1e-3: the FE tables and
the ROM differ by about 1e-6 relative between CPUs and BLAS builds, and a difference of two close numbers, a
relative error or the phase of a small harmonic in degrees, carries that noise as an absolute one). Keys that depend on
the machine, the time or the checkout (``cli_baseline.VOLATILE``) are not compared. ``validate_spur`` reads
the stored explicit FE reference, which is data: its baseline is saved again when that record is replaced.
A baseline saved again after a change of the physics is listed with the reason in ``baseline.json`` (``saved_again``).
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from cli_baseline import COMMANDS, differences, run

BASELINE = Path(__file__).resolve().parent / "data" / "cli_baseline"


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_cli_output_equals_the_baseline(name, tmp_path):
    if name.startswith(("campbell", "sweep", "diagnose", "validate")):
        pytest.importorskip("exudyn")
    saved = json.loads((BASELINE / f"{name}.json").read_text())
    new = run(name, tmp_path)
    diff = differences(new, saved)
    assert not diff, f"{len(diff)} differences, first: {diff[:5]}"


def test_comparison_sees_a_change_and_skips_volatile_keys():
    base = {"a": [1.0, {"b": "x"}], "wall_s": 3.0, "n": 2}
    assert differences({"a": [1.0 + 1e-9, {"b": "x"}], "wall_s": 9.0, "n": 2}, base) == []
    assert differences({"a": [1.01, {"b": "x"}], "wall_s": 3.0, "n": 2}, base) == [".a[0]: 1.01 vs 1.0"]
    assert differences({"a": [1.0, {"b": "y"}], "n": 2, "wall_s": 3.0}, base) == [".a[1].b: 'y' vs 'x'"]
    assert differences({"a": [1.0], "n": 2}, base) == [".a: length 1 vs 2"]
    assert differences({"f": "/x/y/run.json"}, {"f": "/z/run.json"}) == []
    assert differences({"f": "/x/y/run.json"}, {"f": "/x/y/other.json"}) == [".f: '/x/y/run.json' vs '/x/y/other.json'"]
