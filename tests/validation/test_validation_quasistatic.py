"""The slow explicit FE run (60 rpm) against the quasi-static STE of the LTCA (issue 5).

Reference: the quasi-static FE (gearrom.fe LTCA: P2 plane strain, influence coefficients, Hertz-resolved
flanks) at the same torque, plus the rigid kinematic TE of the explicit FE's faceted outlines
(gearrom.validation.facets), an independent method for the same discretised gears. Issue 5's tolerance:
within 5 % (mean TE, and RMS of the curve difference relative to the mean STE), never loosened; a miss
is a strict xfail that states the measured numbers. Skipped while validation/spur_60rpm.* is not committed.
"""
from __future__ import annotations

import pytest

from gearrom.validation.report import DEFAULT_FE_DIR

MISS = ("mean TE +6.8 % (FE 11.29 vs LTCA + outline facets 10.57 um; ideal involute 9.84 um), RMS curve difference "
        "9.0 % of the mean STE (validation/quasistatic_spur_60rpm.json): the explicit FE's penalty contact and "
        "first-order Q4 elements are softer than the P2 LTCA")


def _have() -> bool:
    return all((DEFAULT_FE_DIR / f"spur_60rpm{ext}").is_file() for ext in (".npz", ".json"))


@pytest.fixture(scope="module")
def check():
    from gearrom.validation.quasistatic import quasistatic_check

    if not _have():
        pytest.skip(f"no committed 60 rpm explicit FE run in {DEFAULT_FE_DIR}")
    return quasistatic_check("thesis-spur", 60.0)


def test_slow_run_is_quasi_static(check):
    # the run covers at least one mesh period after the torque ramp
    assert check["mesh_periods"] >= 0.95
    # energy balance of the long mass-scaled run (measured 1.3 %; Abaqus practice: total energy constant
    # within a few per cent of the largest energy)
    assert check["fe"]["energy_error"] < 0.02


@pytest.mark.xfail(strict=True, reason=MISS or "n/a", condition=bool(MISS))
def test_within_five_percent_of_quasi_static_ste(check):
    assert check["passed"], "; ".join(check["misses"])
