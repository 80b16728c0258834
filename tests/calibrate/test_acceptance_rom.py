"""Acceptance of the closed loop on data made by the exudyn ROM with effects the diagnosis is not told about.

Data: :func:`gearrom.testing.synthetic.make_rom_run`: the ROM of ``thesis-rig`` with the ROM's *own*
effect models (``gearrom.rom.Runout`` with centre-distance modulation, ``PitchDeviations`` through the
ROM's smoothed cumulative pitch curve, ``LoadRipple``, rig overrides via ``with_overrides``, a scaled
mesh table, flank modifications as a change of the ROM's table from the quasi-static FE), encoder
emulation (edges CSV, 80 MHz clock, jitter, line errors, random start and disc angles, 2.3 output
revolutions, 40000/36000 edges) and the measurement reader. The diagnosis uses the config's nominal
ROM only.

Reference values: the injected sizes and, for phases, the ROM's absolute angles converted to the
diagnosis' convention (angle zero at each channel's first edge, known from the emulation):
``gearrom.testing.synthetic.rom_runout_phase_deg`` / ``encoder_phase_deg``. Tolerances are the
acceptance criteria: right effect and target named first, amplitude within 25 %, phase within 20 deg, error
after <= half the error before.
"""
from __future__ import annotations

import math

import pytest

pytest.importorskip("exudyn")

from gearrom.calibrate import MicroMods  # noqa: E402
from gearrom.testing.synthetic import RomInjected, encoder_phase_deg, rom_runout_phase_deg  # noqa: E402
from gearrom.rom import LoadRipple, PitchDeviations, Runout  # noqa: E402

K_CLUTCH = 2.0e5  # thesis-rig's rig.clutch.stiffness_Nm_per_rad


def _phase_err(a, b):
    return abs((a - b + 180.0) % 360.0 - 180.0)


def _first(res):
    assert res.effects, f"no effect found:\n{res.text()}"
    return res.effects[0]


def _halved(res):
    s = res.summary
    assert s["error_after_rms_um"] <= 0.5 * s["error_before_rms_um"], res.text()


def _first_edge(info, target):
    return info["theta_first_in" if target.startswith("input") else "theta_first_out"]


def one_tooth(z: int, k: int, f: float) -> tuple:
    """Single pitch deviations that displace tooth ``k`` alone by ``f`` (cumulative deviation f at k)."""
    d = [0.0] * z
    d[k], d[(k + 1) % z] = f, -f
    return tuple(d)


@pytest.mark.parametrize("key,inj,effect,target,amp,phase_rad", [
    ("ecc_out", RomInjected(runout=(Runout(1, 15e-6, 0.3),)), "eccentricity", "output_gear", 15.0, 0.3),
    pytest.param("ecc_in", RomInjected(runout=(Runout(0, 12e-6, -1.0),)), "eccentricity", "input_gear", 12.0, -1.0,
                 marks=pytest.mark.slow),  # the input gear's runout is also in test_two_effects_at_once
    ("enc_in", RomInjected(encoder={"input_encoder": (12.0, 0.5)}), "encoder_eccentricity", "input_encoder", 12.0, 0.5),
    pytest.param("enc_out", RomInjected(encoder={"output_encoder": (8.0, 2.5)}), "encoder_eccentricity",
                 "output_encoder", 8.0, 2.5, marks=pytest.mark.slow),  # also in test_two_effects_at_once
])
def test_once_per_rev_effects(rom_diagnosed, key, inj, effect, target, amp, phase_rad):
    """Gear runout (ROM: kinematic error + mesh modulation) vs encoder eccentricity of either shaft."""
    res, (info,) = rom_diagnosed(key, inj)
    e = _first(res)
    assert (e["effect"], e["target"]) == (effect, target), res.text()
    conv = rom_runout_phase_deg if effect == "eccentricity" else encoder_phase_deg
    true_phase = conv(phase_rad, _first_edge(info, target))
    assert e["parameters"]["amplitude_um"] == pytest.approx(amp, rel=0.25)
    assert _phase_err(e["parameters"]["phase_deg"], true_phase) <= 20.0
    assert len(res.effects) == 1, res.text()
    _halved(res)


def test_pitch_error(rom_diagnosed):
    """7 um on tooth 7 of the input gear, through the ROM's pitch curve (single pitch deviations +7/-7 um on
    teeth 7/8: tooth 7 stands 7 um ahead, the TE drops by up to 7 um while it is in mesh: a TE-equivalent
    deviation of -7 um). Position: the ROM's tooth k enters contact at absolute gear angle k 2 pi / z, the
    diagnosis counts teeth from the record start with the same rule."""
    z, k, f = 32, 7, 7e-6
    res, (info,) = rom_diagnosed("pitch_in", RomInjected(pitch=(PitchDeviations(0, one_tooth(z, k, f)),)))
    e = _first(res)
    assert (e["effect"], e["target"]) == ("pitch_error", "input_gear"), res.text()
    assert e["parameters"]["deviation_um"] == pytest.approx(-7.0, rel=0.25)
    pitch = 2 * math.pi / z
    true_entry = (k * pitch - info["theta_first_in"]) % (2 * math.pi)
    found = (e["parameters"]["tooth_index"] * pitch) % (2 * math.pi)
    assert _phase_err(math.degrees(found), math.degrees(true_entry)) <= 20.0  # about 1.8 pitches
    _halved(res)


TIP = (59.37e-3, 74.29e-3)  # start diameters d_Ca of the helical drawings


@pytest.mark.parametrize("key,config,mods,effect,target,amount", [
    ("spur_tip_out", "thesis-spur", MicroMods(tip_relief=(0.0, 10e-6)), "tip_relief", "output_gear", 10.0),
    ("spur_helix", "thesis-spur", MicroMods(helix_slope=11e-6), "helix_slope", None, 11.0),
    pytest.param("spur_tip_in", "thesis-spur", MicroMods(tip_relief=(8e-6, 0.0)), "tip_relief", "input_gear", 8.0,
                 marks=pytest.mark.slow),
    pytest.param("tip_out", "thesis-rig", MicroMods(tip_relief=(0.0, 15e-6), tip_relief_start_diameter=TIP),
                 "tip_relief", "output_gear", 15.0, marks=pytest.mark.slow),
    pytest.param("helix", "thesis-rig", MicroMods(helix_slope=11e-6), "helix_slope", None, 11.0,
                 marks=pytest.mark.slow),
])
def test_flank_modifications(rom_diagnosed, key, config, mods, effect, target, amount):
    """Drawing-size flank modifications (data: the ROM's nominal table changed by the quasi-static FE LTCA).
    In the suite on the spur pair, whose GMF lines (1-1.5 um) react clearly (10 um tip relief: ~1 um rms).
    The helical pair of thesis-rig (eps_beta 2.02) barely reacts: 0.01-0.02 um rms against a 0.006 um
    noise floor, so after <= half before holds only for some noise realizations (slow cases)."""
    res, _ = rom_diagnosed(key, RomInjected(micro=mods), config=config)
    e = _first(res)
    assert (e["effect"], e["target"]) == (effect, target), res.text()
    found = e["parameters"]["amount_um"]
    if effect == "helix_slope" and config == "thesis-spur":
        found = abs(found)  # a spur face is mirror-symmetric: +f and -f slope over the face give the same TE
    assert found == pytest.approx(amount, rel=0.25)
    _halved(res)


@pytest.mark.slow
@pytest.mark.parametrize("config,torque", [("thesis-spur", 120.0), ("thesis-rig", 240.0)])
def test_lead_crowning_at_drawing_size(rom_diagnosed, config, torque):
    """Lead crowning 7 um (top of the drawing's 4 +- 3 um). Slow (not in the suite). On the helical pair its
    TE change (FE slices: 13 nm rms of STE at 120 N m, 16 nm at 240 N m) is about two to three times the
    encoder noise floor (6 nm): at 120 N m the error does not halve (0.0129 -> 0.0067 um), at 240 N m it
    does in the benchmark (8.3 um found, 0.0215 -> 0.0052 um). On the spur pair a helix slope of ~4.6 um
    is a near look-alike (96 % vs 97 % of the residual explained): found first since the re-simulated fits
    re-estimate the mesh phase from the modified model's GMF lines (6.9 um, 0.065 -> 0.012 um), and the
    report names the helix slope as not told apart, with the run that would separate them."""
    res, _ = rom_diagnosed(f"crown_{config}", RomInjected(micro=MicroMods(lead_crowning=7e-6)), config=config,
                           torque_out_Nm=torque)
    e = _first(res)
    assert (e["effect"], e["target"]) == ("lead_crowning", None), res.text()
    assert e["parameters"]["amount_um"] == pytest.approx(7.0, rel=0.25)
    _halved(res)


def test_changed_clutch_stiffness_moves_a_mode(rom_diagnosed, rom_sims):
    """Clutch stiffness x0.6 (a rig override of the data's ROM) on the spur pair at 1250 rpm, where it moves
    the 2255 Hz mode next to GMF 3 (2000 Hz): named as torsional_mode of k_clutch, scale within 25 %, and
    the moved mode's frequency matches the true rig's within 5 %."""
    inj = RomInjected(overrides={"rig.clutch.stiffness_Nm_per_rad": 0.6 * K_CLUTCH})
    res, _ = rom_diagnosed("spur_clutch", inj, config="thesis-spur")
    e = _first(res)
    assert e["effect"] == "torsional_mode", res.text()
    p = e["parameters"]
    assert p["parameter"] == "k_clutch" and p["scale"] == pytest.approx(0.6, rel=0.25), res.text()
    true_f = [f for f, _ in rom_sims("thesis-spur").modes_hz((("k_clutch", 0.6),))]
    assert min(abs(p["frequency_hz"] / f - 1) for f in true_f) < 0.05
    _halved(res)


def test_mesh_stiffness_change_is_explained(rom_diagnosed):
    """thesis-spur with its mesh table's stiffness x0.75 at 1250 rpm (the case the last session left
    unexplained): a rig-parameter effect (mesh_stiffness) with the right scale, error halved."""
    res, _ = rom_diagnosed("mesh075", RomInjected(mesh_stiffness=0.75), config="thesis-spur")
    e = _first(res)
    assert e["effect"] == "torsional_mode", res.text()
    assert e["parameters"]["parameter"] == "mesh_stiffness"
    assert e["parameters"]["scale"] == pytest.approx(0.75, rel=0.25)
    _halved(res)


def test_two_effects_at_once(rom_diagnosed):
    """Runout of the input gear plus eccentricity of the output encoder (the other shaft)."""
    inj = RomInjected(runout=(Runout(0, 12e-6, 2.0),), encoder={"output_encoder": (8.0, -0.7)})
    res, (info,) = rom_diagnosed("two", inj)
    found = {(e["effect"], e["target"]): e["parameters"] for e in res.effects}
    assert ("eccentricity", "input_gear") in found and ("encoder_eccentricity", "output_encoder") in found, res.text()
    a, b = found[("eccentricity", "input_gear")], found[("encoder_eccentricity", "output_encoder")]
    assert a["amplitude_um"] == pytest.approx(12.0, rel=0.25)
    assert _phase_err(a["phase_deg"], rom_runout_phase_deg(2.0, info["theta_first_in"])) <= 20
    assert b["amplitude_um"] == pytest.approx(8.0, rel=0.25)
    assert _phase_err(b["phase_deg"], encoder_phase_deg(-0.7, info["theta_first_out"])) <= 20
    assert len(res.effects) == 2, res.text()
    _halved(res)


def test_negative_control_adds_nothing(rom_diagnosed):
    res, _ = rom_diagnosed("none", RomInjected())
    s = res.summary
    assert res.effects == [], res.text()
    assert s["error_after_rms_um"] == pytest.approx(s["error_before_rms_um"])
    assert s["error_before_rms_um"] < 3 * s["noise_rms_um"], res.text()
    assert all(u["amplitude_um"] < 5 * s["noise_rms_um"] for u in res.unexplained), res.text()


def test_out_of_library_load_ripple_is_unexplained(rom_diagnosed):
    """Brake-torque ripple of 6 N m (5 %) at output order 3.4 (``gearrom.rom.LoadRipple``), two speeds: an
    order-tracking line at output order 3.4, no integer order, and no library effect claimed."""
    res, _ = rom_diagnosed("ripple", RomInjected(load_ripple=(LoadRipple(3.4, 6.0, 0.5),)),
                           speeds=(1250.0, 2000.0), revs_out=4.0)
    assert res.effects == [], res.text()
    big = max(res.unexplained, key=lambda u: u["amplitude_um"])
    assert big["kind"] == "order_tracking", res.text()
    assert big["order_out"] == pytest.approx(3.4, abs=0.05)
    assert big["integer_order"] is None


def test_robust_to_speed_error_noise_and_short_record(rom_diagnosed):
    """1 % wrong nominal rpm in the file, +10 % timing noise (2.75 ns jitter: sqrt(3.6^2 + 2.75^2) = 4.5 ns
    against 4.1 ns with the 12.5 ns clock quantization), exactly 2 output revolutions: same effect, size
    within 5 % and phase within 3 deg of the clean run (and both within the acceptance tolerances)."""
    inj = RomInjected(runout=(Runout(1, 15e-6, 0.3),))
    base, _ = rom_diagnosed("ecc_out", inj)
    res, (info,) = rom_diagnosed("ecc_out_perturbed", inj, rpm_meta=1250.0 * 1.01, jitter_s=2.75e-9, revs_out=2.0)
    b, e = _first(base), _first(res)
    assert (e["effect"], e["target"]) == (b["effect"], b["target"]) == ("eccentricity", "output_gear")
    assert e["parameters"]["amplitude_um"] == pytest.approx(b["parameters"]["amplitude_um"], rel=0.05)
    assert _phase_err(e["parameters"]["phase_deg"], b["parameters"]["phase_deg"]) < 3.0
    assert _phase_err(e["parameters"]["phase_deg"], rom_runout_phase_deg(0.3, info["theta_first_out"])) <= 20
    assert res.summary["runs"][0]["revs_out"] < 2.05
    _halved(res)


def test_stiffer_support_is_found_with_a_displaced_tooth(rom_diagnosed):
    """Bearing supports 10 x stiffer than the config's and input tooth 7 standing 15 um proud (ROM-made: the
    ROM's pitch curve and its bearings scaled by hand). With ``k_support`` among the rig parameters the
    diagnosis names the tooth within 25 %, names the support with the true 10 inside the range of scales it
    cannot tell apart from its best, and at least halves the error. The support alone hardly changes the TE;
    it changes how the tooth's pulse reaches the encoders, so each scale is judged with the tooth refitted
    on the re-tuned rig (a profile). Above about 10 x the support no longer limits the drivetrain, so the
    range may reach the end of the search (a lower bound)."""
    from gearrom.calibrate import FitSettings
    from gearrom.rom import rig_parameters

    keys = ("rig.bearings.ball_radial_N_per_um", "rig.bearings.ball_axial_N_per_um",
            "rig.bearings.needle_radial_N_per_um")
    p = rig_parameters("thesis-rig")
    inj = RomInjected(pitch=(PitchDeviations(0, one_tooth(32, 7, 15e-6)),), overrides={k: 10 * p[k] for k in keys})
    # the suite's settings for self-made data (no model floor: the data come from the diagnosis' own ROM)
    settings = FitSettings(model_floor_um=0.0, rig_parameters=FitSettings().rig_parameters + ("k_support",))
    res, _ = rom_diagnosed("support_pitch", inj, settings=settings)
    found = {e["effect"]: e for e in res.effects}
    assert "pitch_error" in found, res.text()
    assert found["pitch_error"]["parameters"]["deviation_um"] == pytest.approx(-15.0, rel=0.25), res.text()
    assert "torsional_mode" in found, res.text()
    rig = found["torsional_mode"]["parameters"]
    assert rig["parameter"] == "k_support" and rig["scale_range"][0] <= 10.0 <= rig["scale_range"][1], res.text()
    assert rig["scale_range"][0] > 2.0, res.text()            # a stiffer support, told apart from the config's
    _halved(res)
