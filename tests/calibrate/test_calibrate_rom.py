"""Diagnosis of data made by the exudyn ROM with its *own* runout model (eccentricity plus
centre-distance modulation of the mesh), through the encoder emulation.

Reference: the ROM's injected runout, ``e sin(theta_2 + phase)`` in absolute drive-sense angle. In this
package's convention (TE-equivalent ``a cos(theta + phi)``, angle zero at the record's first edge)
that is ``a = e`` and ``phi = phase - 90 deg + theta_2(record start)``. Two diagnoses: with the ROM
itself (through :class:`RomSimulator`) and with the torsional rig model, i.e. a different simulator
and rig than the one that made the data (the diagnosis must not depend on the model that made the data).
"""
from __future__ import annotations

import math

import pytest

pytest.importorskip("exudyn")

from gearrom.calibrate import RomSimulator, TorsionalRig, diagnose  # noqa: E402
from gearrom.signal import emulate_edges, write_measurement  # noqa: E402


@pytest.fixture(scope="module")
def rom_runout(tmp_path_factory):
    from gearrom.rom import Effects, Runout, simulate_run

    r = simulate_run("thesis-helical", 1250.0, 120.0, n_output_revs=2.1, sample_rate_hz=50e3,
                     effects=Effects(runout=(Runout(gear=1, eccentricity=10e-6, phase=0.3),)))
    th1, th2 = r.angle("in"), r.angle("out")
    rec = emulate_edges(r.time, th1 - th1[0], th2 - th2[0], rng=3, jitter_s=2e-9, line_error_rad=2e-7)
    path = write_measurement(tmp_path_factory.mktemp("rom") / "rom_1250.json", rec, rpm_in=1250.0,
                             torque_out_Nm=120.0, config="thesis-helical")
    phase = math.degrees(0.3 - math.pi / 2 + th2[0])
    return path, 10.0, (phase + 180) % 360 - 180


@pytest.mark.parametrize("which", [pytest.param("rom", marks=pytest.mark.slow), "torsional"])
def test_rom_runout_is_found(rom_runout, which):
    path, amp, phase = rom_runout
    sim = RomSimulator("thesis-helical") if which == "rom" else TorsionalRig.from_config("thesis-helical")
    res = diagnose("thesis-helical", [path], simulator=sim)
    e = res.effects[0]
    assert (e["effect"], e["target"]) == ("eccentricity", "output_gear"), res.text()
    assert e["parameters"]["amplitude_um"] == pytest.approx(amp, rel=0.25 if which == "torsional" else 0.05)
    assert abs((e["parameters"]["phase_deg"] - phase + 180) % 360 - 180) <= (20 if which == "torsional" else 2)
    s = res.summary
    assert s["error_after_rms_um"] <= 0.5 * s["error_before_rms_um"], res.text()


def test_rom_adapter_scales_rig_parameters():
    """``rig_scale`` reaches the ROM: scaling the clutch stiffness through the adapter gives the same modes
    as a config whose clutch value was changed by hand (gearrom.rom.with_overrides), a stiffer clutch
    raises the first torsional mode, and an unknown parameter is refused with its name."""
    from gearrom.calibrate.simulator import ModelChanges, RunConditions
    from gearrom.errors import CalibrationError
    from gearrom.rom import modal_analysis, rig_parameters, with_overrides, build_rig

    sim = RomSimulator("thesis-rig")
    assert {"k_clutch", "J_load", "mesh_stiffness"} <= set(sim.tunable())
    k0 = rig_parameters("thesis-rig")["rig.clutch.stiffness_Nm_per_rad"]
    by_hand = modal_analysis(build_rig(with_overrides("thesis-rig", {"rig.clutch.stiffness_Nm_per_rad": 2 * k0}), 120.0))
    scaled = sim.modes_hz((("k_clutch", 2.0),))
    assert [f for f, _ in scaled][:5] == pytest.approx(list(by_hand.freqs[:5]), rel=1e-9)
    assert scaled[0][0] > sim.modes_hz()[0][0]
    with pytest.raises(CalibrationError, match="k_gearbox"):
        sim.simulate(RunConditions(1250.0, 120.0, 0.01), ModelChanges(rig_scale=(("k_gearbox", 1.2),)))


def test_rom_adapter_scales_the_bearing_support_as_one_parameter():
    """``k_support`` scales the three bearing stiffnesses together: the same modes as a config with the
    three values changed by hand; a stiffer support raises the first drivetrain mode (the helical mesh's
    axial force no longer rocks the gears), and its search spans three decades."""
    from gearrom.rom import build_rig, modal_analysis, rig_parameters, with_overrides

    sim = RomSimulator("thesis-rig")
    keys = ("rig.bearings.ball_radial_N_per_um", "rig.bearings.ball_axial_N_per_um",
            "rig.bearings.needle_radial_N_per_um")
    p = rig_parameters("thesis-rig")
    by_hand = modal_analysis(build_rig(with_overrides("thesis-rig", {k: 10 * p[k] for k in keys}), 120.0))
    scaled = sim.modes_hz((("k_support", 10.0),))
    assert [f for f, _ in scaled][:5] == pytest.approx(list(by_hand.freqs[:5]), rel=1e-9)
    assert scaled[0][0] > 1.05 * sim.modes_hz()[0][0]
    lo, hi, ratio = sim.search_range("k_support")
    assert lo <= 0.1 and hi >= 100 and ratio > 1
