"""Drivetrain assembly, config validation, effects, result round trip."""
import math
import warnings

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.errors import ConfigError, ModelError
from gearrom.rom.mesh import Effects, LoadRipple, PitchDeviations, Runout, line_of_action
from gearrom.rom.result import DynamicRun
from gearrom.rom.rig import build_rig
from gearrom.rom.simulate import simulate_run


@pytest.fixture(scope="module")
def rig():
    return build_rig("thesis-rig")


def test_rig_dofs_and_rigid_mode(rig):
    # 10 shaft stations x 6 + motor + brake rotors
    assert rig.ndof == 62
    M, K, D, G = rig.structure
    r = rig.rigid_mode
    # the nominal rotation stores no strain energy, does not stretch the mesh, and the loads balance on it
    assert np.abs(K @ r).max() < 1e-6 * np.abs(K).max()
    assert abs(rig.w @ r) < 1e-15
    assert abs(rig.loads(120.0) @ r) < 1e-9
    assert np.allclose(G, -G.T)  # gyroscopic matrix is skew


def test_mesh_vector_kinematics(helical):
    """Pure rotations give delta_t = rb1 rz1 + rb2 rz2 (rz2 = -theta2); helical adds axial/tilt terms."""
    w1, w2, n = line_of_action(helical.pair)
    rb1, rb2 = helical.pair.rb
    assert w1[5] == pytest.approx(rb1) and w2[5] == pytest.approx(rb2)
    assert abs(n[2]) == pytest.approx(math.sin(helical.pair.beta_b))  # axial component of the LOA
    assert np.linalg.norm(n) == pytest.approx(1.0)
    assert abs(w1[3]) + abs(w1[4]) > 0  # tilting moments


def test_quasi_static_mesh_force_is_torque_balance(rig):
    run = simulate_run(rig, 60.0, duration_s=0.02)
    assert np.allclose(run.force, 120.0 / rig.pair.rb[1], rtol=2e-3)
    assert not run.contact_loss and run.dynamic_factor == pytest.approx(1.0, abs=2e-3)


def test_runout_gives_once_per_revolution_te(rig):
    """Quasi-static: an output-gear eccentricity ecc appears as ecc sin(theta2) in the DTE (rigid following)."""
    ecc = 5e-6
    run = simulate_run(rig, 30.0, n_output_revs=1, settle_s=0.05,
                       effects=Effects(runout=(Runout(1, ecc, 0.3, modulation=False),)))
    d = run.dte["sensor"] - run.dte["sensor"].mean()
    th2 = run.theta[run.encoders.index("out.sensor")]
    amp = 2 * abs(np.mean(d * np.exp(-1j * th2)))
    assert amp == pytest.approx(ecc, rel=0.01)


def test_pitch_and_ripple_effects_run(rig):
    z2 = rig.pair.z[1]
    fp = np.zeros(z2)
    fp[3] = 8e-6
    eff = Effects(pitch=(PitchDeviations(1, tuple(fp)),), load_ripple=(LoadRipple(1.0, 5.0),))
    run = simulate_run(rig, 600.0, n_output_revs=1, effects=eff)
    # one tooth with +8 um pitch deviation shifts the rest of the revolution: ptp of the cumulative curve
    d = run.dte["sensor"]
    assert np.ptp(d) > 5e-6
    assert "pitch" in run.metadata["effects"]


def test_run_round_trip(tmp_path, rig):
    run = simulate_run(rig, 1500.0, n_output_revs=0.25)
    p = run.save(tmp_path / "run.nc")
    back = DynamicRun.load(p)
    np.testing.assert_array_equal(back.dte["sensor"], run.dte["sensor"])
    np.testing.assert_array_equal(back.theta, run.theta)
    assert back.encoders == run.encoders and back.metadata["config"] == "thesis-rig"
    assert back.contact_loss == run.contact_loss
    # DTE from the encoder angles (seed eq. 40 with base radii): rb1 theta_in - rb2 theta_out, mean removed
    te = run.radii["rb1"] * run.angle("in", "sensor") - run.radii["rb2"] * run.angle("out", "sensor")
    np.testing.assert_allclose(te - te.mean(), run.dte["sensor"] - run.dte["sensor"].mean(), atol=1e-9)
    assert run.sample_rate == pytest.approx(64 * 32 * 1500 / 60, rel=1e-6)
    # pitch-circle option of the seed's eqs. 39/40
    assert np.allclose(run.dte_at("sensor", "pitch"), run.dte["sensor"] * run.radii["r1"] / run.radii["rb1"])
    fig = run.plot()
    assert fig.axes


def test_bad_rig_config_names_file_and_key(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text('extends = "thesis-helical"\n[rig.bearings]\nball_radial_N_per_mm = 1.0\n')
    with pytest.raises(ConfigError, match=r"bad\.toml.*rig\.bearings\.ball_radial_N_per_mm"):
        build_rig(p)
    p.write_text('extends = "thesis-helical"\n[rig.input_shaft]\ngear_mm = 10.0\n')
    with pytest.raises(ConfigError, match="must increase strictly"):
        build_rig(p)
    p.write_text('extends = "thesis-helical"\n[rom]\nmesh_damping_ratio = -0.1\n')
    with pytest.raises(ConfigError, match="rom.mesh_damping_ratio"):
        build_rig(p)


def test_bad_run_arguments(rig):
    with pytest.raises(ModelError, match="rpm_in"):
        simulate_run(rig, -5.0)
    with pytest.raises(ModelError, match="Drivetrain"):
        simulate_run(3.0, 100.0)


def test_components_in_exudyn_match_assembly(rig):
    """Second method: exudyn's own linearisation of the component-by-component system equals M, K, D."""
    from gearrom.rom.physical import build_exudyn

    _, mbs, nodes = build_exudyn(rig)
    assert len(nodes) == len(rig.stations)
    M, K, D = mbs.ComputeLinearizedSystem()
    M0, K0, D0 = rig.linear(0.0, 120.0)
    for a, b in ((M, M0), (K, K0), (D, D0)):
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()


def test_effects_from_enabled_microgeometry(tmp_path):
    p = tmp_path / "ro.toml"
    p.write_text('extends = "thesis-rig"\n[output_gear.microgeometry]\nenabled = true\nrunout_um = 22.0\n'
                 'runout_phase_deg = 90.0\n')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg = load_config(p)
    eff = Effects.from_pair(cfg.pair)
    assert len(eff.runout) == 1 and eff.runout[0].gear == 1
    assert eff.runout[0].eccentricity == pytest.approx(11e-6)  # F_r / 2
    assert eff.runout[0].phase == pytest.approx(math.pi / 2)


def test_helical_static_bearing_reactions_balance_mesh_force(rig):
    """Statics: the bearings carry the 3D mesh force: axial F_t tan(beta_b) on the ball bearing (the needle
    bearing is axially free), radial F_t (sin alpha_wt, cos alpha_wt) shared by both bearings."""
    from gearrom.rom.components import UX, UY, UZ

    k, e = rig.excitation.mean_stiffness(120.0), rig.excitation.mean_ste(120.0)
    x = rig.static_state(120.0, k, e)
    ft = rig.nominal_force(120.0)
    kb = {c.station: c for c in rig.components if type(c).__name__ in ("BallBearing", "NeedleBearing")}
    for sh, sign in (("in", -1.0), ("out", 1.0)):
        ball, needle = kb[f"{sh}.ball_bearing"], kb[f"{sh}.needle_bearing"]
        fz = ball.k_axial * x[rig.index(ball.station, UZ)]
        assert sign * fz == pytest.approx(ft * math.tan(rig.pair.beta_b), rel=1e-9)
        fx = sum(b.k_radial * x[rig.index(b.station, UX)] for b in (ball, needle))
        fy = sum(b.k_radial * x[rig.index(b.station, UY)] for b in (ball, needle))
        assert sign * fx == pytest.approx(ft * math.sin(rig.pair.alpha_wt), rel=1e-6)
        assert sign * fy == pytest.approx(ft * math.cos(rig.pair.alpha_wt), rel=1e-6)


def test_pi_speed_law(tmp_path):
    """With an integral term the nominal rotation is no longer free; statics and modes stay consistent."""
    from gearrom.rom.modal import modal_analysis

    p = tmp_path / "pi.toml"
    p.write_text('extends = "thesis-rig"\n[rig.motor]\nintegral_gain_Nm_per_rad = 2000.0\n')
    model = build_rig(p)
    assert not model.free_rotation
    m = modal_analysis(model, 1000.0, fmax=500.0)
    # J_total ~ 0.05 kg m^2 on a 2000 N m/rad angle loop: a new low mode of a few Hz (sqrt(k/J)/2 pi ~ 30 Hz)
    assert 1.0 < m.freqs[0] < 100.0
    run = simulate_run(model, 60.0, duration_s=0.02)
    assert np.allclose(run.force, model.nominal_force(120.0), rtol=2e-3)


def test_overrides_change_the_model():
    from gearrom.rom import rig_parameters
    from gearrom.rom.modal import modal_analysis

    params = rig_parameters("thesis-rig")
    assert params["rig.clutch.stiffness_Nm_per_rad"] == 200000.0 and "rom.mesh_damping_ratio" in params
    base = modal_analysis(build_rig("thesis-rig"), 0.0, fmax=2e3)
    soft = modal_analysis(build_rig("thesis-rig", overrides={"rig.motor.inertia_kg_m2": 0.08}), 0.0, fmax=2e3)
    assert soft.freqs[0] < base.freqs[0]  # a heavier motor rotor lowers the first torsional mode
    with pytest.raises(ConfigError, match="not a rig/rom parameter"):
        build_rig("thesis-rig", overrides={"rig.motor.mass_kg": 1.0})


def test_runout_modulation_sidebands_quasi_static(spur):
    """Quasi-static, the DTE follows the modulated STE: the sidebands at GMF +- 1 output order have
    amplitude kappa * ecc * |E1| / 2 (first-order amplitude modulation, mesh.py docstring)."""
    from gearrom.rom.mesh import centre_distance_sensitivity

    model = build_rig(spur)
    ecc = 11e-6
    run = simulate_run(model, 20.0, n_output_revs=1, settle_s=0.05, sample_rate_hz=128 * 32 * 20 / 60,
                       effects=Effects(runout=(Runout(1, ecc, 0.0),)))
    d = run.dte["sensor"] - run.dte["sensor"].mean()
    amp = 2 * np.abs(np.fft.rfft(d)) / d.size  # bin = output order (one output revolution recorded)
    z2 = spur.pair.z[1]
    # reference GMF amplitude: the table's STE sampled the same way (aliasing of the table's steps included)
    th1 = run.angle("in")
    e_tab = model.excitation.ste(th1, 120.0)
    e1 = 2 * np.abs(np.fft.rfft(e_tab - e_tab.mean()))[z2] / d.size
    expect = 0.5 * abs(centre_distance_sensitivity(spur.pair)) * ecc * e1
    assert amp[1] == pytest.approx(ecc, rel=0.02)  # the once-per-revolution TE itself
    assert amp[z2] == pytest.approx(e1, rel=0.02)  # GMF: DTE = STE
    for sb in (z2 - 1, z2 + 1):
        assert amp[sb] == pytest.approx(expect, rel=0.1)
