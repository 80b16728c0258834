"""Building blocks of the diagnosis against independent references (closed forms, scipy, theory)."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import signal

from gearrom.calibrate import characterize as chz
from gearrom.calibrate.registry import amp_phase
from gearrom.excitation.slices import MicroMods, SliceMicroModel
from gearrom.calibrate.residual import detrend, estimate_mesh_phase, fit_lines, noise_rms
from gearrom.calibrate.torsional import TorsionalRig
from gearrom.calibrate.simulator import ModelChanges, RunConditions
from gearrom.config import load_config
from gearrom.errors import CalibrationError
from gearrom.excitation import analytical_excitation


@pytest.fixture(scope="module")
def pairs():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {n: load_config(n, check=False).pair for n in ("thesis-spur", "thesis-helical")}


def test_slice_model_reproduces_closed_form_analytical_excitation(pairs):
    """Perfect flanks: the thin slices must reproduce the closed-form face integral of
    gearrom.excitation.analytical (same ISO stiffness, same pair shape) to the slice discretization (0.5 %)."""
    for pair in pairs.values():
        ref = analytical_excitation(pair, [120.0], n_theta=128)
        ex = SliceMicroModel(n_slices=64).excitation(pair, [120.0], MicroMods())
        assert ex.mean_stiffness(120.0) == pytest.approx(ref.mean_stiffness(120.0), rel=5e-3)
        np.testing.assert_allclose(ex.e[0], ref.e[0], rtol=1e-2)  # pointwise: contact entry on a slice grid


def test_helix_slope_on_spur_matches_closed_form_partial_contact(pairs):
    """Spur pair, linear gap g(y) = f (y/b - 1/2) across the face, uniform stiffness k/b per unit width.
    Closed form: full contact if F/k >= f/2, then delta = F/k; else contact width w = sqrt(2 b F / (c f))
    (c = k/b) and delta = f w / b - f/2. Reference: elementary statics of a linearly varying gap."""
    pair = pairs["thesis-spur"]
    f = 40e-6  # large enough for partial contact at low load
    model = SliceMicroModel(n_theta=32, n_slices=400)
    ex0 = model.excitation(pair, [30.0], MicroMods())
    ex = model.excitation(pair, [30.0], MicroMods(helix_slope=f))  # the slope along the transverse line of action
    F = 30.0 / pair.rb[1]
    for k0, d in zip(ex0.k[0], ex.e[0]):
        c = k0 / pair.face_width
        if F / k0 >= f / 2:
            ref = F / k0
        else:
            w = math.sqrt(2 * pair.face_width * F / (c * f))
            ref = f * w / pair.face_width - f / 2
        assert d == pytest.approx(ref, rel=5e-3, abs=2e-9)


def test_tip_relief_start_inside_base_circle_is_rejected(pairs):
    with pytest.raises(CalibrationError, match="base circle"):
        SliceMicroModel().excitation(pairs["thesis-helical"], [120.0],
                                     MicroMods(tip_relief=(8e-6, 0.0), tip_relief_start_diameter=(40e-3, None)))


def test_tooth_te_all_teeth_displaced_shift_te_by_the_deviation(pairs):
    """Every tooth displaced by the same small amount shifts the TE by that amount (a rigid rotation of the
    gear): the single-tooth patterns of all teeth sum to the deviation at every angle."""
    from gearrom.excitation.slices import tooth_te

    pair = pairs["thesis-helical"]
    z = pair.z[0]
    te = tooth_te(pair, 120.0, 0, 1e-6)
    n = te.size // z
    total = sum(np.roll(te, k * n) for k in range(z))
    np.testing.assert_allclose(total, 1e-6, rtol=1e-9)


def test_tooth_te_spur_single_contact_and_saturation(pairs):
    """Spur pair (eps_alpha 1.85): while the displaced tooth carries the load alone (single-pair zone) the TE
    changes by the whole deviation; a tooth set back further than its neighbour's static deflection leaves
    contact, and the TE change saturates at F/k_neighbour - F/k_both (hand statics of two springs)."""
    from gearrom.excitation.slices import SliceMicroModel
    from gearrom.excitation.slices import tooth_te

    pair = pairs["thesis-spur"]
    small = tooth_te(pair, 120.0, 0, 1e-6)
    assert small.max() == pytest.approx(1e-6, rel=1e-9)
    assert small.sum() / (small.size / pair.z[0]) == pytest.approx(1e-6, rel=1e-6)  # area: one pitch x d
    big = tooth_te(pair, 120.0, 0, 200e-6)
    theta, k, gap = SliceMicroModel().slices(pair, MicroMods())
    n_t = theta.size
    # a double-contact angle: pairs 0 and 1 in mesh, the displaced tooth is pair 1 in mesh period 1
    i = next(i for i in range(n_t) if k[i, 0].sum() > 0 and k[i, 1].sum() > 0)
    f = 120.0 / pair.rb[1]
    k0, k1 = k[i, 0].sum(), k[i, 1].sum()
    assert big[n_t + i] == pytest.approx(f / k0 - f / (k0 + k1), rel=1e-9)


def test_fit_lines_recovers_lines_with_trend_and_short_record():
    """Joint least squares: two lines 0.22 orders apart over 2.5 revolutions plus a trend (exact data)."""
    th1 = np.linspace(0, 2.5 * 2 * math.pi, 3000)
    th2 = th1 * 32 / 41
    y = 3e-6 * np.cos(th1 + 0.4) + 2e-6 * np.cos(th2 - 1.0) + 1e-7 * th1 + 5e-7
    c = fit_lines(y, th1, th2, np.array([[1.0, 0.0], [0.0, 1.0]]))
    assert abs(c[0]) == pytest.approx(3e-6, rel=1e-9) and np.angle(c[0]) == pytest.approx(0.4, abs=1e-9)
    assert abs(c[1]) == pytest.approx(2e-6, rel=1e-9) and np.angle(c[1]) == pytest.approx(-1.0, abs=1e-9)


def test_detrend_equals_scipy():
    a = np.random.default_rng(0).normal(size=(3, 257, 4))
    np.testing.assert_allclose(detrend(a, axis=1), signal.detrend(a, axis=1), atol=1e-12)


def test_noise_rms_ignores_strong_lines():
    """White noise of known rms under lines 1000x stronger: the median periodogram estimate within 10 %."""
    rng = np.random.default_rng(1)
    fs, n = 20e3, 8000
    t = np.arange(n) / fs
    x = 1e-5 * np.cos(2 * math.pi * 123.4 * t) + 1e-5 * np.cos(2 * math.pi * 3210 * t) + rng.normal(0, 1e-8, n)
    assert noise_rms(x, fs) == pytest.approx(1e-8, rel=0.1)


def test_mesh_phase_estimate_recovers_rotation_and_refuses_without_content():
    z1 = 32
    model = np.array([1e-6 * np.exp(0.3j), 4e-7 * np.exp(-1j), 2e-7])
    psi = 0.0123
    meas = model * np.exp(1j * np.arange(1, 4) * z1 * psi)
    est, ok = estimate_mesh_phase(meas, model, z1, 1e-4)
    assert ok and est == pytest.approx(psi, abs=1e-6)
    _, ok = estimate_mesh_phase(meas, model * 1e-3, z1, 1e-4)  # the model explains < 1/3 of the lines
    assert not ok


def test_sideband_modulation_tells_am_from_pm():
    """x = C (1 + m cos) is AM, x = C cos(phi + b cos) is PM (Bessel J1 sidebands): U L / C^2 > 0 vs < 0."""
    from gearrom.calibrate.residual import RunData
    from gearrom.signal import GearMeshInfo

    mesh = GearMeshInfo(32, 41, 0.0266, 0.0341, 0.0283, 0.0363)
    th1 = np.linspace(0, 3 * 2 * math.pi, 6000)
    th2 = th1 * 32 / 41
    run = RunData("x", 1250.0, 1250.0, 120.0, th1 / 130.9, th1, th2, np.zeros((3, th1.size)), 16e3, mesh)
    am = 1e-6 * (1 + 0.3 * np.cos(th2 + 0.5)) * np.cos(32 * th1 + 0.2)
    pm = 1e-6 * np.cos(32 * th1 + 0.2 + 0.3 * np.cos(th1 - 0.7))
    kinds = {(d["shaft"], d["modulation"]) for d in chz.sideband_modulation(run, am, 1e-10) if d["harmonic"] == 1}
    assert ("output", "AM") in kinds
    kinds = {(d["shaft"], d["modulation"]) for d in chz.sideband_modulation(run, pm, 1e-10) if d["harmonic"] == 1}
    assert ("input", "PM") in kinds


def test_amp_phase_convention():
    a, ph = amp_phase(2.0 * math.cos(math.radians(40)), 2.0 * math.sin(math.radians(40)))
    assert a == pytest.approx(2.0) and ph == pytest.approx(40.0)


def test_rig_matches_linear_frequency_response():
    """Time-domain rig vs its linear state-space model (independent: matrices + complex FRF): the TE response
    to a sinusoidal kinematic error at output order 3 (near the first torsional mode range) within 1 %."""
    rig = TorsionalRig.from_config("thesis-helical")
    rpm = 1250.0
    cond = RunConditions(rpm, 120.0, 0.2)
    th = np.arange(4096) * 2 * math.pi / 4096
    a = 1e-6
    h0 = rig.simulate(cond)
    h1 = rig.simulate(cond, ModelChanges(kinematic_out=a * np.cos(3 * th)))
    rb1, rb2 = rig.pair.rb
    d = (rb1 * h1.theta_in_rad - rb2 * h1.theta_out_rad) - (rb1 * h0.theta_in_rad - rb2 * h0.theta_out_rad)
    c = fit_lines(d, h0.theta_in_rad, h0.theta_out_rad, np.array([[0.0, 3.0]]))
    M, K, C, (_, _, cm) = rig.matrices()
    g = np.array([0.0, rb1, -rb2, 0.0])
    km = K[1, 1] - rig.params.k_shaft_in  # mesh part on the pinion: k rb1^2
    k_mesh = km / rb1**2
    w = 2 * math.pi * 3 * rpm / 60 * 32 / 41
    # kinematic error e enters as force vector g (k e + i w c e); TE = g . x
    x = np.linalg.solve(K - w**2 * M + 1j * w * C, g * (k_mesh + 1j * w * cm) * a)
    ref = g @ x
    assert abs(c[0]) == pytest.approx(abs(ref), rel=0.01)
    assert np.angle(c[0]) == pytest.approx(np.angle(ref), abs=0.01)


def test_rig_quasi_static_te_equals_ste_at_low_speed():
    """At 2 rpm the dynamic TE of the spur rig equals the static TE of its excitation table within 2.5 %
    of the ripple: the quasi-static limit (at 10 rpm the sharp single/double contact steps of the spur
    STE still ring the ~190 Hz mode by ~7 %)."""
    rig = TorsionalRig.from_config("thesis-spur", h_s=1e-4, warmup_s=0.05)
    h = rig.simulate(RunConditions(2.0, 120.0, 60 / 2 / 32 * 2))
    rb1, rb2 = rig.pair.rb
    te = rb1 * h.theta_in_rad - rb2 * h.theta_out_rad
    ex = SliceMicroModel().excitation(rig.pair, [120.0], MicroMods())
    ste = ex.ste(h.theta_in_rad, 120.0)
    ripple = np.ptp(ste)
    assert np.max(np.abs((te - te.mean()) - (ste - ste.mean()))) < 0.025 * ripple


def test_classify_peaks_fixed_vs_tracking():
    from gearrom.calibrate.residual import RunData
    from gearrom.signal import GearMeshInfo

    mesh = GearMeshInfo(32, 41, 0.0266, 0.0341, 0.0283, 0.0363)

    def run(rpm):
        t = np.linspace(0, 0.5, 100)
        return RunData(f"r{rpm}", rpm, rpm, 120.0, t, t, t, np.zeros((3, 100)), 16e3, mesh)

    runs = [run(1250.0), run(2500.0)]
    peaks = [[(200.0, 1e-6), (55.1, 5e-7)], [(201.0, 1e-6), (110.2, 5e-7)]]
    out = {round(p["frequency_hz"]): p for p in chz.classify_peaks(runs, peaks)}
    assert out[200]["kind"] == "fixed_frequency" and out[200]["order"] is None
    assert out[55]["kind"] == "order_tracking" and out[55]["order"] == pytest.approx(55.1 / (1250 / 60))


def test_classify_peaks_short_records_one_order_line():
    """Input order 1 of two short records (4 output revolutions of a 32/41 pair at 1250 and 2000 rpm, measured
    speeds 0.3 % off nominal, peaks read 0.1-0.8 % off the exact order by leakage) is one order-tracking line,
    not two single-speed lines: the two hypotheses (fixed: 20.9 Hz; order: 33.4 Hz) lie 2 bins of the
    shorter record apart, the peaks within 0.05 bin of the order prediction."""
    from gearrom.calibrate.residual import RunData
    from gearrom.signal import GearMeshInfo

    mesh = GearMeshInfo(32, 41, 0.0266, 0.0341, 0.0283, 0.0363)

    def run(rpm):
        t = np.linspace(0, 4 * 60 / rpm * 41 / 32, 100)
        return RunData(f"r{rpm}", rpm, rpm / 1.003, 120.0, t, t, t, np.zeros((3, 100)), 16e3, mesh)

    runs = [run(1253.75), run(2006.0)]
    peaks = [[(20.9, 2e-6)], [(33.6, 1.5e-6)]]
    out = chz.classify_peaks(runs, peaks)
    assert len(out) == 1
    assert out[0]["kind"] == "order_tracking" and out[0]["runs_seen"] == 2
    assert out[0]["order"] == pytest.approx(1.0, abs=0.01)
    assert out[0]["integer_order"] == "input order 1"


@pytest.mark.parametrize("config,mods", [
    ("thesis-spur", MicroMods(tip_relief=(0.0, 15e-6))),
])
def test_fe_micro_change_agrees_with_slice_model(pairs, config, mods):
    """The FE-table route (cached compliances, contact re-solved, no FE solve) against the independent
    analytical thin-slice model: the first GMF harmonic of the STE change by a tip relief within 25 % in
    amplitude and 30 deg in phase (the FE adds Hertzian flattening and load spreading the slices lack).
    Not for the helical pair: with eps_beta ~ 2.02 its GMF lines are small residues of a cancellation over
    the face, where the two models differ by a factor ~2.5 (10 um input tip relief: 0.024 vs 0.009 um)."""
    from gearrom.calibrate.microfe import FEMicroModel, micro_delta

    pair = pairs[config]
    fe = FEMicroModel(cache_dir=None)
    if fe.ltca(pair) is None:
        pytest.skip("FE tables not available")
    z1 = pair.z[0]
    th = np.arange(64) * 2 * math.pi / z1 / 64
    d_fe, rk = micro_delta(fe, pair, 120.0, MicroMods(), mods, th)
    d_sl, _ = micro_delta(SliceMicroModel(), pair, 120.0, MicroMods(), mods, th)
    c_fe, c_sl = np.fft.rfft(d_fe)[1], np.fft.rfft(d_sl)[1]
    assert abs(c_fe) == pytest.approx(abs(c_sl), rel=0.25)
    assert abs(math.degrees(np.angle(c_fe / c_sl))) < 30.0
    assert np.all(rk > 0.5) and np.all(rk < 1.5)


def test_tooth_local_pulse_found_at_its_tooth_and_not_in_smooth_or_random_residuals():
    """A residual with a pulse at one input tooth (a raised-cosine bump over eps_gamma = 4 pitches, entering
    mesh at tooth 11 of 32: the pattern a pitted tooth leaves) plus white noise: reported as a tooth-local
    pulse of the input gear at tooth 11, not of the output gear. A once-per-revolution sinusoid of the
    same energy (runout) and the noise alone are not: the first is spread over the revolution, the second
    is at the standard error of the average."""
    from gearrom.calibrate.residual import RunData
    from gearrom.signal import GearMeshInfo

    z1, z2, eps_gamma = 32, 41, 4.0
    mesh = GearMeshInfo(z1, z2, 0.0266, 0.0341, 0.0283, 0.0363)
    th1 = np.linspace(0, 8 * 2 * math.pi, 8 * 32 * 64)
    th2 = th1 * z1 / z2
    run = RunData("x", 1250.0, 1250.0, 120.0, th1 / 130.9, th1, th2, np.zeros((3, th1.size)), 16e3, mesh)
    pitch = 2 * math.pi / z1
    u = ((th1 % (2 * math.pi)) - 11 * pitch) / (eps_gamma * pitch)          # 0..1 while tooth 11 is in mesh
    pulse = np.where((u >= 0) & (u <= 1), 0.5 * (1 - np.cos(2 * math.pi * np.clip(u, 0, 1))), 0.0) * 1e-6
    noise = np.random.default_rng(3).normal(0.0, 0.1e-6, th1.size)
    found = chz.tooth_local_pulses([run], [pulse + noise], eps_gamma)
    assert [(p["shaft"], p["tooth_index"]) for p in found] == [("input", 11)]
    assert found[0]["amplitude_um"] == pytest.approx(1.0, rel=0.2)
    runout = np.cos(th1 + 0.4) * math.sqrt(2 * np.mean(pulse ** 2))
    assert chz.tooth_local_pulses([run], [runout + noise], eps_gamma) == []
    assert chz.tooth_local_pulses([run], [noise], eps_gamma) == []


def test_report_text_names_a_tooth_local_pulse():
    """The readable summary of a diagnosis with an unexplained tooth-local pulse names the gear and tooth."""
    from gearrom.calibrate.report import DiagnosisResult

    summary = {"runs": [], "model": {"simulator": "rom", "config": "x.toml"}, "error_before_rms_um": 0.15,
               "error_after_rms_um": 0.15, "noise_rms_um": 0.01, "effects": [], "ambiguities": [],
               "unexplained": [{"kind": "tooth_local_pulse", "shaft": "input", "gear": "input_gear", "z": 32,
                                "tooth_index": 11, "amplitude_um": 0.85, "frequency_hz": None, "order": None,
                                "order_out": None, "integer_order": "input order 1 pulse train", "runs_seen": 2}]}
    text = DiagnosisResult(summary, []).text()
    assert "pulse at tooth 11 of the input gear" in text and "0.85 um p-p" in text
