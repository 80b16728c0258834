"""The slow explicit FE run (60 rpm) against the quasi-static STE of the LTCA.

Reference: the quasi-static FE (gearrom.fe LTCA: P2 plane strain, influence coefficients, Hertz-resolved
flanks) at the same torque, plus the rigid kinematic TE of the explicit FE's faceted outlines
(gearrom.validation.facets), an independent method for the same discretised gears. The validation's tolerance:
within 5 % (mean TE, and RMS of the curve difference relative to the mean STE), never loosened; a miss
is a strict xfail that states the measured numbers. Skipped while validation/spur_60rpm.* is not committed.
"""
from __future__ import annotations

import pytest

from gearrom.validation.report import DEFAULT_FE_DIR

MISSES = {   # element integration of the stored run -> measured miss
    "reduced": ("mean TE +6.8 % (FE 11.29 vs LTCA + outline facets 10.57 um; ideal involute 9.84 um), RMS curve "
                "difference 9.0 % of the mean STE (validation/quasistatic_spur_60rpm.json): the one-point Q4 with "
                "soft hourglass control is softer than the P2 LTCA (the fully integrated run removes the mean miss)"),
    "full": ("RMS curve difference 5.5 % of the mean STE > 5 % (validation/quasistatic_spur_60rpm_full.json); "
             "the mean TE passes: -0.26 % (FE 10.54 vs LTCA + outline facets 10.57 um); STE p-p FE 6.0 vs 6.3 um"),
}
ENERGY_MISSES = {   # element integration -> measured energy balance error above 2 %
    "full": ("energy balance error 3.3 % of the largest energy (validation/spur_60rpm_full.json; the one-point "
             "run: 1.3 %): the slow run's energy scale is the small elastic energy, and the mass-scaled, undamped "
             "fully integrated model keeps its contact-entry vibration"),
}


def _have(integration: str) -> bool:
    tag = "_full" if integration == "full" else ""
    return all((DEFAULT_FE_DIR / f"spur_60rpm{tag}{ext}").is_file() for ext in (".npz", ".json"))


@pytest.fixture(scope="module", params=["reduced", "full"])
def check(request):
    from gearrom.validation.quasistatic import quasistatic_check

    if not _have(request.param):
        pytest.skip(f"no committed 60 rpm explicit FE run ({request.param} integration) in {DEFAULT_FE_DIR}")
    return quasistatic_check("thesis-spur", 60.0, integration=request.param)


def test_slow_run_is_quasi_static(check):
    # the run covers at least one mesh period after the torque ramp
    assert check["mesh_periods"] >= 0.95
    if check["integration"] == "full":
        assert check["fe"]["hourglass_ratio"] == 0.0


def test_slow_run_energy_balance(check, request):
    # energy balance of the long mass-scaled run (one-point run: 1.3 %; Abaqus practice: total energy
    # constant within a few per cent of the largest energy)
    miss = ENERGY_MISSES.get(check["integration"])
    if miss:
        request.applymarker(pytest.mark.xfail(strict=True, reason=miss))
    assert check["fe"]["energy_error"] < 0.02


def test_within_five_percent_of_quasi_static_ste(check, request):
    miss = MISSES.get(check["integration"])
    if miss:
        request.applymarker(pytest.mark.xfail(strict=True, reason=miss))
    assert check["passed"], "; ".join(check["misses"])
