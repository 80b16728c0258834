"""``gearrom diagnose`` CLI: the report JSON schema, report files, save/load, clear errors."""
from __future__ import annotations

import json


from gearrom.calibrate import DiagnosisResult
from gearrom.testing import Injected
from gearrom.cli import main

ECC = Injected(eccentricity={"output_gear": (10.0, 40.0)})


def test_cli_json_schema_and_report(dataset, tmp_path, capsys):
    paths = dataset("ecc_out", ECC, speeds=(1250.0,))
    out = tmp_path / "diag.json"
    rep = tmp_path / "report"
    assert main(["diagnose", "thesis-helical", str(paths[0]), "--json", str(out), "--report", str(rep),
                 "--simulator", "torsional", "--save", str(tmp_path / "res.npz")]) == 0
    text = capsys.readouterr().out
    assert "eccentricity of output_gear" in text
    d = json.loads(out.read_text())
    for k in ("error_before_rms_um", "error_after_rms_um", "runs", "effects", "unexplained"):
        assert k in d
    r = d["runs"][0]
    for k in ("measurement", "rpm_in", "error_before_rms_um", "error_after_rms_um", "orders"):
        assert k in r
    assert {"order", "before_um", "after_um"} <= set(r["orders"][0])
    e = d["effects"][0]
    assert {"effect", "target", "parameters", "evidence", "rms_reduction_um"} <= set(e)
    assert {"amplitude_um", "phase_deg"} <= set(e["parameters"])
    for name in ("diagnosis.json", "summary.txt", "run_0.png"):
        assert (rep / name).stat().st_size > 0
    back = DiagnosisResult.load(tmp_path / "res.npz")
    assert back.summary["effects"] == d["effects"]
    assert back.traces[0].measured.size == len(back.traces[0].t_s)


def test_cli_unknown_effect_is_a_clear_error(dataset, capsys):
    paths = dataset("ecc_out", ECC, speeds=(1250.0,))
    assert main(["diagnose", "thesis-helical", str(paths[0]), "--effects", "eccentricity,wobble"]) == 2
    err = capsys.readouterr().err
    assert "wobble" in err and "library" in err


def test_cli_missing_torque_names_the_field(dataset, tmp_path, capsys):
    src = dataset("ecc_out", ECC, speeds=(1250.0,))[0]
    doc = json.loads(src.read_text())
    doc.pop("torque_out_Nm")
    doc["data"] = str(src.with_suffix(".csv"))
    bad = tmp_path / "no_torque.json"
    bad.write_text(json.dumps(doc))
    assert main(["diagnose", "thesis-helical", str(bad), "--simulator", "torsional"]) == 2
    assert "torque_out_Nm" in capsys.readouterr().err


def test_cli_missing_file(tmp_path, capsys):
    assert main(["diagnose", "thesis-helical", str(tmp_path / "nope.json")]) == 2
    assert "nope.json" in capsys.readouterr().err


def test_cli_rig_parameters_are_checked_by_name(dataset, capsys):
    """``--rig-parameters`` names parameters a simulator can scale: an unknown one is refused before the
    diagnosis, and one the chosen simulator lacks (the bearing support is a ROM parameter) is refused
    with the simulator named."""
    paths = dataset("ecc_out", ECC, speeds=(1250.0,))
    assert main(["diagnose", "thesis-helical", str(paths[0]), "--rig-parameters", "k_clutch,k_gearbox"]) == 2
    err = capsys.readouterr().err
    assert "k_gearbox" in err and "k_support" in err
    assert main(["diagnose", "thesis-helical", str(paths[0]), "--simulator", "torsional",
                 "--rig-parameters", "k_support"]) == 2
    err = capsys.readouterr().err
    assert "k_support" in err and "torsional" in err.lower()
