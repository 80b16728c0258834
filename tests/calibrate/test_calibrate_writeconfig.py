"""``gearrom diagnose --write-config``: the found effects become config keys that the ROM reads back.

References: the ROM's own effect model (:mod:`gearrom.rom.mesh`: runout ``e sin(theta + phase)``,
pitch curve with sign -1 on the input gear) and the diagnosis' conventions
(:mod:`gearrom.calibrate.effects`: ``a cos(theta + phi)``, tooth pattern of
:mod:`gearrom.excitation.slices`). Each test evaluates what the written config makes the ROM add to
the TE and compares it with what the diagnosis fitted.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearrom.calibrate.writeconfig import diagnosed_config, write_config
from gearrom.config import load_config
from gearrom.excitation.slices import tooth_te
from gearrom.rom.mesh import Effects, pitch_curve


def _summary(*effects, torque=120.0):
    return {"format": "gearrom.diagnosis/1", "error_before_rms_um": 3.0, "error_after_rms_um": 1.0,
            "runs": [{"torque_out_Nm": torque}], "effects": list(effects)}


def test_eccentricity_round_trip_through_rom_effects(tmp_path):
    """Runout 2 x 9 um at phase 30 deg: the ROM's TE term from the written config equals 9 cos(theta + 30 deg)."""
    s = _summary({"effect": "eccentricity", "target": "output_gear",
                  "parameters": {"amplitude_um": 9.0, "phase_deg": 30.0}})
    out = write_config(s, "thesis-rig", tmp_path / "d.toml")
    cfg = load_config(out)
    eff = Effects.from_pair(cfg.pair)
    (r,) = eff.runout
    th = np.linspace(0, 2 * math.pi, 50)
    np.testing.assert_allclose(r.eccentricity * np.sin(th + r.phase), 9e-6 * np.cos(th + math.radians(30.0)), atol=1e-12)
    assert r.gear == 1
    # the drawing micro-geometry of thesis-rig is off in the nominal model: switching the section on adds nothing else
    m = cfg.pair.gears[1].micro
    assert m.enabled and m.tip_relief == 0.0 and m.lead_crowning == 0.0 and m.helix_slope == 0.0
    assert cfg.pair.effective_tip_diameter == pytest.approx(load_config("thesis-rig").pair.effective_tip_diameter)


@pytest.mark.parametrize("target,gi", [("input_gear", 0), ("output_gear", 1)])
def test_pitch_error_round_trip_sign_area_and_position(tmp_path, target, gi):
    """A -6 um deviation of tooth 3 (standing proud: the TE drops while it is in mesh): the ROM's pitch curve from
    the written config equals the diagnosis' tooth pattern of tooth 3 (same thin-slice tooth model, the
    config's single pitch deviations turned back into that tooth's displacement), up to the mean that the
    ROM removes."""
    s = _summary({"effect": "pitch_error", "target": target, "parameters": {"tooth_index": 3, "deviation_um": -6.0}})
    out = write_config(s, "thesis-rig", tmp_path / "p.toml")
    cfg = load_config(out)
    pair = cfg.pair
    z = pair.z[gi]
    (p,) = Effects.from_pair(pair).pitch
    curve = pitch_curve(pair, gi, p.deviations, 120.0)
    pat = tooth_te(pair, 120.0, gi, -6e-6)
    pat = np.roll(pat, 3 * (pat.size // z))
    # the ROM closes the cumulative curve (mean deviation removed): every tooth also moves by +6/z um
    np.testing.assert_allclose(curve - np.median(curve), pat - np.median(pat), atol=0.01e-6)
    assert np.min(curve - np.median(curve)) < -2e-6


def test_flank_and_rig_changes_add_to_the_nominal_values(tmp_path):
    """Tip relief adds to the drawing value when the drawing micro-geometry is on; a rig stiffness is scaled;
    an encoder error and a change without a config key are listed in the header, not applied."""
    base = tmp_path / "base.toml"
    base.write_text('extends = "thesis-rig"\nname = "base"\n[output_gear.microgeometry]\nenabled = true\n')
    s = _summary({"effect": "tip_relief", "target": "output_gear", "parameters": {"amount_um": 5.0}},
                 {"effect": "torsional_mode", "target": None, "parameters": {"parameter": "k_clutch", "scale": 0.5}},
                 {"effect": "torsional_mode", "target": None, "parameters": {"parameter": "mesh_stiffness", "scale": 1.1}},
                 {"effect": "encoder_eccentricity", "target": "input_encoder",
                  "parameters": {"amplitude_um": 4.0, "phase_deg": 10.0}})
    doc, notes = diagnosed_config(s, base)
    nominal = load_config(base)
    out = write_config(s, base, tmp_path / "out.toml")
    cfg = load_config(out)
    assert cfg.pair.gears[1].micro.tip_relief == pytest.approx(nominal.pair.gears[1].micro.tip_relief + 5e-6)
    assert cfg.raw["rig"]["clutch"]["stiffness_Nm_per_rad"] == pytest.approx(
        0.5 * nominal.raw["rig"]["clutch"]["stiffness_Nm_per_rad"])
    text = out.read_text()
    assert "mesh_stiffness" in text and "input_encoder" in text and len(notes) == 2


def test_support_scale_writes_every_bearing_stiffness(tmp_path):
    """A parameter that scales several config keys (the bearing support) writes each of them scaled."""
    base = tmp_path / "base.toml"
    base.write_text('extends = "thesis-rig"\nname = "base"\n')
    s = _summary({"effect": "torsional_mode", "target": None, "parameters": {"parameter": "k_support", "scale": 20.0}})
    nominal = load_config(base).raw["rig"]["bearings"]
    out = load_config(write_config(s, base, tmp_path / "out.toml")).raw["rig"]["bearings"]
    for k in ("ball_radial_N_per_um", "ball_axial_N_per_um", "needle_radial_N_per_um"):
        assert out[k] == pytest.approx(20.0 * nominal[k]), k
    assert out["damping_beta_us"] == nominal["damping_beta_us"]


def test_cli_refuses_a_non_toml_output_before_the_diagnosis(tmp_path, capsys):
    from gearrom.cli import main

    rc = main(["diagnose", "thesis-rig", str(tmp_path / "m.json"), "--write-config", str(tmp_path / "x.json")])
    assert rc != 0
    assert "--write-config" in capsys.readouterr().err


def test_sub_pitch_tooth_position_fixes_the_index_mesh_phase(tmp_path):
    """A tooth fitted 4.5 pitches from the record's zero on a record whose GMF lines left the mesh phase free:
    the written config states the mesh phase that puts it on a whole tooth (-0.5 pitch = -5.625 deg of input
    angle on z1 = 32), writes the deviation on that tooth (4), and the diagnosis reads the phase back."""
    from gearrom.calibrate.model import index_mesh_phase

    s = _summary({"effect": "pitch_error", "target": "input_gear",
                  "parameters": {"tooth_index": 4, "tooth_position_pitch": 4.5, "deviation_um": -6.0}})
    s["runs"][0].update(mesh_phase_estimated=False, mesh_phase_model_rad=0.0)
    out = write_config(s, "thesis-rig", tmp_path / "p.toml")
    cfg = load_config(out)
    assert cfg.raw["calibrate"]["index_mesh_phase_deg"] == pytest.approx(-0.5 * 360.0 / 32)
    assert index_mesh_phase(cfg) == pytest.approx(math.radians(-0.5 * 360.0 / 32))
    fp = cfg.raw["input_gear"]["microgeometry"]["pitch_deviations_um"]
    assert fp[4] == pytest.approx(6.0) and fp[5] == pytest.approx(-6.0)  # ROM sign: +6 on tooth 4, -6 on 5
    # a record whose GMF lines fixed the mesh phase keeps it: nothing is written
    s["runs"][0]["mesh_phase_estimated"] = True
    doc, _ = diagnosed_config(s, "thesis-rig")
    assert "calibrate" not in doc


def test_index_mesh_phase_that_is_not_a_number_is_named(tmp_path):
    from gearrom.calibrate.model import index_mesh_phase
    from gearrom.errors import CalibrationError

    p = tmp_path / "bad.toml"
    p.write_text('extends = "thesis-rig"\n[calibrate]\nindex_mesh_phase_deg = "north"\n')
    with pytest.raises(CalibrationError, match="calibrate.index_mesh_phase_deg"):
        index_mesh_phase(load_config(p))
