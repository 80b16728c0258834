"""The ROM on a table of the explicit FE's own discretisation ("the same discretised gears").

Unit checks of the pieces (facet inversion, low-pass, share rows, the dynamic-relaxation static solve
on a coarse mesh) and, against the committed records: the slow 60 rpm run is static at the stored
static solves; the ``explicit_scaled`` table (LTCA at the explicit FE's static compliance,
gearrom.validation.explicit_table) and the pair ROM with it (``validate(table="explicit_scaled")``) at
1250 / 2000 rpm under the validation tolerances (never loosened; a miss is a strict xfail that states the
measured numbers); the analysis-only ``explicit_qs`` table. The static-vs-dynamic analysis is
validation/rom_vs_fe_spur_same_discretization.json (validation/run_same_discretization.py).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gearrom.validation.report import DEFAULT_FE_DIR
from speed_verdicts import assert_speed_passes, speed_params

RPMS = (1250, 2000)


def test_elastic_deflection_inverts_loaded_kinematic_te():
    from gearrom.validation.facets import elastic_deflection, loaded_kinematic_te

    rng = np.random.default_rng(3)
    n = 40
    share = rng.uniform(0.1, 1.0, (n, 3))
    share /= share.sum(axis=1, keepdims=True)
    gaps = rng.uniform(-1e-6, 2e-6, (n, 3))
    gaps[::4, 0] = np.nan                                 # pair not loaded there
    gaps[1::7, 2] = 30e-6                                 # gap above the loaded deflection: pair carries nothing
    force, k = 4000.0, rng.uniform(3e8, 4.5e8, n)
    te = loaded_kinematic_te(gaps, share, force, k) + force / k
    np.testing.assert_allclose(elastic_deflection(te, gaps, share), force / k, rtol=1e-12)


def test_share_rows_do_not_wrap_to_the_next_period():
    from gearrom.validation.facets import share_rows

    tab = np.arange(8 * 2, dtype=float).reshape(8, 2)
    period = 1.0
    rows = share_rows(tab, np.array([0.0, 0.49 / 8, 7.6 / 8, 1.0 + 0.1 / 8]), period)
    np.testing.assert_array_equal(rows, tab[[0, 0, 7, 0]])


def test_lowpass_periodic_keeps_band_limited_signals():
    from gearrom.validation.explicit_table import _evaluate, lowpass_periodic

    n = 128
    u = np.arange(n) / n
    x = 10.0 + 1.5 * np.cos(2 * math.pi * u + 0.3) + 0.4 * np.sin(2 * math.pi * 5 * u)
    noise = 0.3 * np.cos(2 * math.pi * 37 * u)
    c = lowpass_periodic(x + noise, 16)
    np.testing.assert_allclose(_evaluate(c, u), x, atol=1e-12)
    np.testing.assert_allclose(_evaluate(c, u + 0.5 / n), 10.0 + 1.5 * np.cos(2 * math.pi * (u + 0.5 / n) + 0.3)
                               + 0.4 * np.sin(2 * math.pi * 5 * (u + 0.5 / n)), atol=1e-12)


def _have(*stems: str) -> bool:
    return all((DEFAULT_FE_DIR / f"{s}{ext}").is_file() for s in stems for ext in (".npz", ".json"))


@pytest.fixture(scope="module")
def slow_run(spur):
    """The LTCA table at 120 N m and the elastic deflection of the committed 60 rpm run on it, computed once
    for both tables built from that run (``slow=`` of the table builders)."""
    from gearrom.validation.explicit_table import slow_run_deflection
    from gearrom.validation.pair_rom import mesh_excitation
    from gearrom.validation.report import load_fe_record

    if not _have("spur_60rpm"):
        pytest.skip(f"no committed 60 rpm explicit FE run in {DEFAULT_FE_DIR}")
    ref, _ = mesh_excitation(spur.pair, 120.0, "fe")
    return ref, slow_run_deflection(spur.pair, load_fe_record(DEFAULT_FE_DIR, 60.0), ref)


@pytest.fixture(scope="module")
def slow_table(spur, slow_run):
    from gearrom.validation.explicit_table import explicit_qs_excitation

    ref, slow = slow_run
    return ref, explicit_qs_excitation(spur.pair, ref, slow=slow)


def test_explicit_qs_table_is_the_softer_explicit_model(slow_table, spur):
    ref, (table, label, prov) = slow_table
    assert prov["table"] == "explicit_qs" and prov["cutoff_mesh_order"] >= 8
    assert prov["fe_meta"]["outline_size_mm"] == 0.15 and "one mesh period" in prov["limit"]
    f_nom = 120.0 / spur.pair.rb[1]
    np.testing.assert_allclose(table.e[0], f_nom / table.k[0], rtol=1e-12)          # e0 = 0: facets added by the ROM
    np.testing.assert_array_equal(table.load_share[0], ref.load_share[-1])
    # measured: mean elastic deflection 10.56 um vs the LTCA's 9.85 um (explicit 7 % softer)
    ratio = prov["deflection_mean_um"] / prov["reference_deflection_mean_um"]
    assert 1.03 < ratio < 1.12
    assert "explicit_qs" in label and table.metadata["table_provenance"] is prov


def test_slow_run_is_static_at_the_static_solves():
    """The 60 rpm run against the dynamic-relaxation static solves of the same model at its own sample
    angles: equal within its aliased residual vibration (measured RMS 0.17 um, largest 0.36 um)."""
    from gearrom.validation.report import load_fe_record

    path = DEFAULT_FE_DIR / "spur_static_points.json"
    if not (_have("spur_60rpm") and path.is_file()):
        pytest.skip("no committed 60 rpm run or static points")
    d = json.loads(path.read_text())
    fe = load_fe_record(DEFAULT_FE_DIR, 60.0)
    th = fe.theta_in[fe.t >= float(fe.meta["t_steady_from_s"])]
    te = fe.te[fe.t >= float(fe.meta["t_steady_from_s"])]
    diffs = []
    for j, p in d["points"].items():
        if int(j) < th.size:
            assert abs(th[int(j)] - p["theta_in_rad"]) < 1e-9
            diffs.append(te[int(j)] - p["te_um"] * 1e-6)
            assert p["settle_ptp_um"] < 0.15              # relaxed: residual vibration of the static solve
    assert len(diffs) >= 8
    assert np.sqrt(np.mean(np.square(diffs))) < 0.25e-6 and np.max(np.abs(diffs)) < 0.5e-6


def test_static_solve_settles_on_a_coarse_mesh(spur):
    """Dynamic relaxation of the explicit model (0.3 mm outline: ~10 s): placed at rigid first contact,
    settled within 0.1 um, a positive elastic deflection of the order of the mesh compliance."""
    from gearrom.fe.explicit.gearmesh import gear_quad_mesh
    from gearrom.validation.explicit_static import static_pair_model, static_te
    from gearrom.fe.explicit.gearpair import GearPairSetup

    pair = spur.pair
    meshes = [gear_quad_mesh(pair, i, 0.3e-3, 2e-3) for i in (0, 1)]
    _, _, rigid0 = static_pair_model(pair, meshes, 0.0, GearPairSetup(rpm_in=1e-4))
    assert abs(rigid0) < 1e-12                           # the FE's own start: TE = 0 at rigid first contact
    p = static_te(pair, meshes, 0.05)
    assert p.settle_ptp < 0.1e-6
    assert 8e-6 < p.te - p.rigid_te < 20e-6              # measured 11.9 um (LTCA at 25 um flanks: ~9.5 um)


@pytest.fixture(scope="module")
def scaled_table(spur, slow_run):
    from gearrom.validation.explicit_table import explicit_scaled_excitation

    ref, slow = slow_run
    return ref, explicit_scaled_excitation(spur.pair, ref, slow=slow)


def test_explicit_scaled_table_keeps_the_ltca_shape(scaled_table):
    ref, (table, label, prov) = scaled_table
    # measured 0.932: the explicit model's elastic compliance is 7.3 % above the LTCA's (static data only;
    # the static solves give 1.077 over three mesh periods and 1.079 from two torques)
    assert prov["table"] == "explicit_scaled" and 0.90 < prov["stiffness_scale"] < 0.96
    np.testing.assert_allclose(table.k, ref.k * prov["stiffness_scale"], rtol=1e-12)
    np.testing.assert_allclose(table.e - 120.0 / table.metadata["rb2_m"] / table.k,
                               ref.e - 120.0 / table.metadata["rb2_m"] / ref.k, atol=1e-15)   # e0 kept
    assert table.metadata["table_provenance"] is prov and "0.93" in label
    assert prov["fe_meta"]["outline_size_mm"] == 0.15 and "limit" in prov


def test_validate_rejects_unknown_or_unsupported_tables():
    from gearrom.errors import ConfigError
    from gearrom.validation.report import validate

    with pytest.raises(ConfigError, match="table must be one of"):
        validate("thesis-spur", [1250], table="explicit_qs")
    with pytest.raises(ConfigError, match="not --fresh"):
        validate("thesis-spur", [1250], fresh=True, table="explicit_scaled")
    with pytest.raises(ConfigError, match="facets"):
        validate("thesis-spur", [1250], facets=False, table="explicit_scaled")


SCALED_MISSES: dict[int, str] = {     # rpm -> measured miss (validation/rom_vs_fe_spur_same_discretization.json)
    1250: "GMF1 +16.8 % > 10 %, GMF3 +36.7 % > 20 %; mean TE +0.1 %, DTE RMS -6.2 %, GMF2 +18.3 %, GMF1 phase "
          "+2.5 deg pass: the compliance level is the explicit model's, the static excitation's harmonics are not "
          "(ROM static GMF1/GMF3 +14 %/+52 % against the explicit static solves)",
    2000: "DTE RMS -16.7 % > 10 %, GMF1 +16.6 % > 10 %, GMF3 +43.4 % > 20 %; mean TE +0.4 %, GMF2 +19.99 %, GMF1 "
          "phase +3.2 deg pass",
}


@pytest.fixture(scope="module")
def scaled_report():
    from gearrom.validation.report import validate

    rpms = [r for r in RPMS if _have(f"spur_{r}rpm")]
    if not rpms or not _have("spur_60rpm"):
        pytest.skip(f"no committed explicit FE references in {DEFAULT_FE_DIR}")
    return validate("thesis-spur", rpms, table="explicit_scaled")


def test_scaled_report_records_its_table(scaled_report, tmp_path):
    d = json.loads(scaled_report.save(tmp_path / "v.json").read_text())
    for s in d["speeds"]:
        t = s["rom"]["table"]
        assert t["table"] == "explicit_scaled" and 0.90 < t["stiffness_scale"] < 0.96
        assert "spur_60rpm" in t["source"] and s["rom"]["excitation"].startswith("ltca x")
        assert abs(s["metrics"]["te_mean_um"]["rel_error"]) < 0.02      # static compliance level: mean TE matches


@pytest.mark.parametrize("rpm", speed_params(RPMS, SCALED_MISSES))
def test_rom_on_explicit_scaled_table_within_issue_tolerances(scaled_report, rpm):
    assert_speed_passes(scaled_report, rpm)


def test_stored_analysis_static_vs_dynamic():
    """validation/rom_vs_fe_spur_same_discretization.json: the statements of its analysis hold."""
    path = DEFAULT_FE_DIR / "rom_vs_fe_spur_same_discretization.json"
    if not path.is_file():
        pytest.skip("no stored same-discretisation analysis")
    d = json.loads(path.read_text())
    w = d["static_window"]
    assert w["static_points"] == 48 and w["mesh_periods"] == 3
    static = w["rom_static"]["ltca"]["metrics"]
    for row in w["speeds"]:
        rom = row["rom"]["ltca"]["amplification"]
        for key in ("gmf1_amplitude_um", "gmf2_amplitude_um", "gmf3_amplitude_um"):
            # the harmonics' dynamic amplification of ROM and FE agree (measured within 2.6 %) ...
            assert abs(rom[key] / row["fe_amplification"][key] - 1) < 0.05
            # ... so their miss is the static excitation's (ROM static vs explicit static, same sign)
            assert static[key]["rel_error"] > 0.05 and row["rom"]["ltca"]["metrics"][key]["rel_error"] > 0
        # the DTE RMS is amplified much more in the FE (1.67 / 1.51 vs 1.06 / 1.21): dynamic
        assert row["fe_amplification"]["dte_rms_um"] > 1.2 * rom["dte_rms_um"]
    # the mean TE miss is static: -6.2 % on the static window as on the dynamic runs
    dynamic_mean = d["rom_vs_fe"]["ltca"]["1250"]["metrics"]["te_mean_um"]["rel_error"]
    assert abs(static["te_mean_um"]["rel_error"] - dynamic_mean) < 0.01
    # the FE's extra DTE is vibration between the mesh orders around the mesh mode
    for rpm, b in d["mode_bands"].items():
        assert b["fe"]["fractional_in_band"] > 1.5 * b["ltca"]["fractional_in_band"]
