"""Diagnosis of data made by the package's own torsional rig model (a second, independent data path).

The closed loop's acceptance runs on ROM-made data (test_acceptance_rom.py). Here the same diagnosis sees
data from the torsional rig model (:mod:`gearrom.calibrate.torsional`); the cases that duplicate the ROM
acceptance are marked slow (run by hand / in the benchmark), the cheap ones stay in the suite.

Reference: the injected effects themselves (sizes at drawing tolerance, written from their physical
definitions in :mod:`gearrom.testing.synthetic`, independently of the diagnosis' effect models),
passed through the encoder emulation and the measurement reader. The tolerances are the acceptance's:
right effect and target named first, amplitude within 25 %, phase within 20 deg, error after <= half
the error before; the negative control adds nothing; an out-of-library ripple is reported as
unexplained with the right order class.
"""
from __future__ import annotations

import math

import pytest

from gearrom.calibrate import MicroMods, RigParams, TorsionalRig, diagnose
from gearrom.testing import Injected, make_run

ONE = (1250.0,)


def _first(res):
    assert res.effects, f"no effect found:\n{res.text()}"
    return res.effects[0]


def _phase_err(a, b):
    return abs((a - b + 180.0) % 360.0 - 180.0)


def _halved(res):
    s = res.summary
    assert s["error_after_rms_um"] <= 0.5 * s["error_before_rms_um"], res.text()


@pytest.mark.parametrize("key,inj,effect,target,amp,phase", [
    ("ecc_out", Injected(eccentricity={"output_gear": (10.0, 40.0)}), "eccentricity", "output_gear", 10.0, 40.0),
    ("ecc_in", Injected(eccentricity={"input_gear": (8.0, -120.0)}), "eccentricity", "input_gear", 8.0, -120.0),
    ("enc_in", Injected(encoder={"input_encoder": (12.0, -70.0)}), "encoder_eccentricity", "input_encoder", 12.0, -70.0),
    ("enc_out", Injected(encoder={"output_encoder": (8.0, 150.0)}), "encoder_eccentricity", "output_encoder", 8.0, 150.0),
])
def test_once_per_rev_effects_named_and_sized(diagnosed, key, inj, effect, target, amp, phase):
    """Gear runout vs encoder eccentricity on the same shaft: the other channel's motion tells them apart."""
    res = diagnosed(key, inj, speeds=ONE)
    e = _first(res)
    assert (e["effect"], e["target"]) == (effect, target), res.text()
    assert e["parameters"]["amplitude_um"] == pytest.approx(amp, rel=0.25)
    assert _phase_err(e["parameters"]["phase_deg"], phase) <= 20.0
    assert len(res.effects) == 1, res.text()
    _halved(res)


def test_pitch_error_tooth_and_size(diagnosed):
    res = diagnosed("pitch", Injected(pitch={"input_gear": (7, 6.0)}), speeds=ONE)
    e = _first(res)
    assert (e["effect"], e["target"]) == ("pitch_error", "input_gear"), res.text()
    assert e["parameters"]["tooth_index"] == 7
    assert e["parameters"]["deviation_um"] == pytest.approx(6.0, rel=0.25)
    _halved(res)


@pytest.mark.slow
@pytest.mark.parametrize("key,mods,effect,target,amount", [
    ("tip_in", MicroMods(tip_relief=(10e-6, 0.0), tip_relief_start_diameter=(59.37e-3, 74.29e-3)),
     "tip_relief", "input_gear", 10.0),
    ("helix", MicroMods(helix_slope=11e-6), "helix_slope", None, 11.0),
])
def test_flank_modifications(diagnosed, key, mods, effect, target, amount):
    """Drawing-size flank modifications of the helical pair (through the micro-geometry STE model), one run
    at 1250 rpm (its 4th GMF harmonic sits near the ~2.7 kHz mesh mode; more speeds in the benchmark)."""
    res = diagnosed(key, Injected(micro=mods), speeds=ONE)
    e = _first(res)
    assert (e["effect"], e["target"]) == (effect, target), res.text()
    assert e["parameters"]["amount_um"] == pytest.approx(amount, rel=0.25)
    _halved(res)


@pytest.mark.slow
def test_moved_resonance(diagnosed):
    """A softer input shaft (x0.7) moves the ~635 Hz mode of the spur rig, near GMF at 1250 rpm."""
    res = diagnosed("mode", Injected(rig_scale=(("k_shaft_in", 0.7),)), config="thesis-spur", speeds=ONE)
    e = _first(res)
    assert e["effect"] == "torsional_mode", res.text()
    p = e["parameters"]
    assert p["parameter"] == "k_shaft_in" and p["scale"] == pytest.approx(0.7, rel=0.25)
    rig = TorsionalRig.from_config("thesis-spur")
    true_f = [f for f, _ in rig.modes_hz((("k_shaft_in", 0.7),))]
    assert min(abs(p["frequency_hz"] / f - 1) for f in true_f) < 0.05
    _halved(res)


@pytest.mark.slow
def test_two_effects_at_once(diagnosed):
    """Runout of the input gear plus eccentricity of the output encoder (the other shaft)."""
    res = diagnosed("two", Injected(eccentricity={"input_gear": (10.0, 120.0)},
                                    encoder={"output_encoder": (8.0, -30.0)}), speeds=ONE)
    found = {(e["effect"], e["target"]): e["parameters"] for e in res.effects}
    assert ("eccentricity", "input_gear") in found and ("encoder_eccentricity", "output_encoder") in found, res.text()
    a = found[("eccentricity", "input_gear")]
    b = found[("encoder_eccentricity", "output_encoder")]
    assert a["amplitude_um"] == pytest.approx(10.0, rel=0.25) and _phase_err(a["phase_deg"], 120.0) <= 20
    assert b["amplitude_um"] == pytest.approx(8.0, rel=0.25) and _phase_err(b["phase_deg"], -30.0) <= 20
    assert len(res.effects) == 2, res.text()
    _halved(res)


@pytest.mark.slow
def test_negative_control_adds_nothing(diagnosed):
    res = diagnosed("none", Injected())
    s = res.summary
    assert res.effects == [], res.text()
    assert s["error_after_rms_um"] == pytest.approx(s["error_before_rms_um"])
    assert s["error_before_rms_um"] < 3 * s["noise_rms_um"], res.text()
    assert all(u["amplitude_um"] < 5 * s["noise_rms_um"] for u in res.unexplained), res.text()


@pytest.mark.slow
def test_out_of_library_load_ripple_is_unexplained(diagnosed):
    """5 % brake-torque ripple at output order 3.4: reported as an order-tracking line at that order
    (seen at both speeds), and no library effect is claimed."""
    res = diagnosed("ripple", Injected(load_ripple=(0.05, 3.4, 0.5)), speeds=(1250.0, 2000.0), revs_out=4.0)
    assert res.effects == [], res.text()
    big = max(res.unexplained, key=lambda u: u["amplitude_um"])
    assert big["kind"] == "order_tracking", res.text()
    assert big["order_out"] == pytest.approx(3.4, abs=0.05)
    assert big["integer_order"] is None


@pytest.mark.slow
def test_robust_to_speed_error_noise_and_short_record(diagnosed):
    """1 % wrong nominal rpm in the file, +10 % timing noise (2.96 ns jitter on top of the 12.5 ns clock
    quantization), 2 output revolutions: same effect, same size (5 %) and phase (3 deg) as the clean run."""
    inj = Injected(eccentricity={"output_gear": (10.0, 40.0)})
    base = _first(diagnosed("ecc_out", inj, speeds=ONE))
    res = diagnosed("ecc_out_perturbed", inj, speeds=ONE, rpm_meta=1250.0 * 1.01, jitter_s=2.96e-9)
    e = _first(res)
    assert (e["effect"], e["target"]) == (base["effect"], base["target"])
    assert e["parameters"]["amplitude_um"] == pytest.approx(base["parameters"]["amplitude_um"], rel=0.05)
    assert _phase_err(e["parameters"]["phase_deg"], base["parameters"]["phase_deg"]) < 3.0
    assert res.summary["runs"][0]["revs_out"] < 2.1


def test_data_from_a_different_rig(tmp_path):
    """Generality: data from a rig with other inertias, controller and clutch than the diagnosis model."""
    other = TorsionalRig.from_config("thesis-helical", params=RigParams(J_in=1.8e-3, J_out=3.5e-3, k_ctrl=4e3,
                                                                        c_ctrl=15.0, k_clutch=2.2e4, J_load=0.03))
    p = make_run(tmp_path / "r.json", "thesis-helical", 1250.0, simulator=other,
                 injected=Injected(eccentricity={"output_gear": (10.0, 40.0)}))
    res = diagnose("thesis-helical", [p], simulator=TorsionalRig.from_config("thesis-helical"))
    e = _first(res)
    assert e["effect"] == "eccentricity" and e["target"] == "output_gear", res.text()
    assert e["parameters"]["amplitude_um"] == pytest.approx(10.0, rel=0.25)
    assert _phase_err(e["parameters"]["phase_deg"], 40.0) <= 20.0
    assert math.isfinite(res.summary["error_after_rms_um"])
