"""ROM vs the explicit FE references of the spur pair (validation/spur_<rpm>rpm_loaded.*): gates and verdict.

The references start from the loaded static state at speed, carry the damping ratio the ring-down
calibrated at the mesh mode (validation/ringdown_spur.json) and have their outline nodes on the
generated profile; the ROM is the exudyn Drivetrain of the same pair system on the sweep's
load-dependent FE table, with the same damping ratio (gearrom.validation.report.validate). Reference
for each judged number: the explicit FE record itself (an independent method: 2D continuum with
penalty contact, not the LTCA), at the tolerances of gearrom.validation.compare.TOLERANCES.
A speed whose record is not committed yet is skipped with that reason.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from gearrom.validation.gates import GATES
from gearrom.validation.report import DEFAULT_FE_DIR, record_stem

SPEEDS = (1250.0, 2000.0)


def _record(rpm: float):
    stem = record_stem(DEFAULT_FE_DIR, rpm, "spur", "loaded")
    if not stem.with_suffix(".npz").is_file():
        pytest.skip(f"no committed loaded-start reference at {rpm:g} rpm ({stem.name}.npz)")
    return stem


@pytest.mark.parametrize("rpm", SPEEDS)
def test_reference_record_passes_its_gates(rpm):
    """The stored record is a reference: energy balance, steady state and drift gates."""
    from gearrom.validation.gates import record_gates
    from gearrom.validation.report import load_fe_record
    from gearrom.validation.compare import steady_window

    stem = _record(rpm)
    fe = load_fe_record(DEFAULT_FE_DIR, rpm, "spur", "loaded")
    meta = json.loads(stem.with_suffix(".json").read_text())
    assert meta["start"] == "loaded" and meta["mesh_periods_recorded"] >= 10
    w = steady_window(fe.theta_in, fe.t, float(fe.meta["t_steady_from_s"]), 32)
    g = record_gates(fe.theta_in[w], fe.te[w], 32, fe.energies)
    assert g["passed"], {k: g[k] for k in GATES}
    assert np.all(np.isfinite(fe.te))


@pytest.mark.parametrize("rpm", SPEEDS)
def test_rom_matches_the_reference(rpm):
    from gearrom.validation.report import validate

    _record(rpm)
    s = validate("thesis-spur", [rpm], fe_integration="loaded").speeds[0]
    assert s.rom_meta["rom_model"] == "exudyn"
    assert s.passed, "; ".join(s.misses)
