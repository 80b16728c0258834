"""Helical pair of the rig (thesis-helical) with the slice LTCA (transverse plane-strain slices).

References: ISO 6336-1 method B c_gamma_alpha (anchor, about +-20 %; the ratio is printed);
eps_beta = 2.02 nearly an integer, so the ideal stiffness fluctuation nearly cancels and the STE
peak-to-peak is sub-micron (fe-method-notes; Smith, Gear Noise and Vibration, ch. 3); lead
crowning and tip relief remove material and shorten the loaded contact lines (larger mean STE,
lower secant stiffness; crowning raises the mid-face Hertz pressure), and the drawing
modifications break the near-integer-overlap cancellation so that the ripple grows (Smith 2003,
ch. 3). The block contact solver is checked against the dense one.
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.fe.contact import solve_contact, solve_contact_blocks
from gearrom.fe.ltca_slices import HelicalSliceLTCA, plot_contact_pattern
from gearrom.fe.iso6336 import mesh_stiffness
from gearrom.fe.mesh2d import MeshSettings
from gearrom.fe.sweep import build_ltca, mesh_cycle

COARSE = MeshSettings(flank_size=0.04e-3, tooth_size=0.45e-3, body_size=3e-3)


@pytest.fixture(scope="module")
def helical(tmp_path_factory):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pair = load_config("thesis-helical").pair
        ltca = build_ltca(pair, COARSE, cache_dir=tmp_path_factory.mktemp("h"), n_slices=16, helical_model="slices")
    return pair, ltca, mesh_cycle(ltca, [120.0], 32, tangent=False)


def _micro(pair, **kw):
    gears = [dataclasses.replace(g, micro=dataclasses.replace(g.micro, enabled=True, **kw)) for g in pair.gears]
    return dataclasses.replace(pair, gears=tuple(gears))


def test_helical_mean_stiffness_vs_iso_and_submicron_ripple(helical):
    pair, _, res = helical
    ratio = res.k_secant[0].mean() / (mesh_stiffness(pair) * pair.face_width)
    print(f"helical FE (slices) / ISO 6336 c_gamma_alpha = {ratio:.3f}; STE ptp {np.ptp(res.ste[0]) * 1e6:.3f} um")
    assert 0.7 <= ratio <= 1.3
    assert np.ptp(res.ste[0]) < 1e-6


def test_helical_lead_crowning_and_tip_relief_directions(helical):
    pair, ltca, base = helical
    crowned = _micro(pair, tip_relief=0.0, profile_crowning=0.0, tip_form_diameter=None)  # drawing C_b = 4 um
    relieved = _micro(pair, lead_crowning=0.0, profile_crowning=0.0, tip_form_diameter=None)  # drawing C_a
    drawing = _micro(pair)
    rc, rr, rd = (mesh_cycle(HelicalSliceLTCA(p, ltca.c, n_slices=16), [120.0], 32, tangent=False)
                  for p in (crowned, relieved, drawing))
    # removed material: larger STE and a lower secant stiffness (shorter effective contact lines)
    for r in (rc, rr, rd):
        assert r.ste[0].mean() > base.ste[0].mean()
        assert r.k_secant[0].mean() < base.k_secant[0].mean()
    # crowning concentrates the load in mid-face: higher peak (Hertz) pressure
    assert rc.max_pressure.max() > 1.1 * base.max_pressure.max()
    # the drawing modifications break the near-integer-overlap cancellation: larger ripple, still sub-micron
    assert np.ptp(base.ste[0]) < np.ptp(rd.ste[0]) < 1e-6
    assert np.ptp(rd.ste_kinematic) > 0.1e-6


def test_contact_pattern_plot(helical):
    pair, ltca, _ = helical
    res = ltca.solve(0.0, 120.0)
    assert res.z.shape == res.pressure.shape
    assert len(plot_contact_pattern(res, pair).axes) == 2


def test_sweep_contact_pattern_over_the_cycle(helical, tmp_path):
    """The mesh-cycle result carries the contact pattern (face width x profile, per position).

    References: the pattern is a binning of the contact solution, so its largest value is the
    position's peak pressure; the drawing's lead crowning moves load to mid-face (Smith, Gear Noise
    and Vibration, ch. 3), so the cycle envelope there rises relative to the face ends.
    """
    pair, ltca, base = helical
    assert base.pattern.shape[:2] == base.ste.shape
    np.testing.assert_allclose(base.pattern.max(axis=(2, 3)), base.max_pressure, rtol=1e-12)
    s = base.summary(0)["contact_pattern"]
    env = np.asarray(s["max_pressure_MPa"])
    assert env.shape == (len(s["z_mm"]), len(s["roll_input_mm"]))
    # without crowning the whole face carries load over the cycle (eps_beta ~ 2: every bin row sees contact)
    assert np.all(env.max(axis=1) > 0)
    crowned = mesh_cycle(HelicalSliceLTCA(_micro(pair, tip_relief=0.0, profile_crowning=0.0, tip_form_diameter=None),
                                          ltca.c, n_slices=16), [120.0], 32, tangent=False)
    rows = np.asarray(crowned.summary(0)["contact_pattern"]["max_pressure_MPa"]).max(axis=1)
    rows0 = env.max(axis=1)
    mid, ends = slice(len(rows) // 3, 2 * len(rows) // 3), np.r_[0, len(rows) - 1]
    assert rows[mid].mean() / rows[ends].mean() > 1.2 * rows0[mid].mean() / rows0[ends].mean()
    back = type(base).load(base.save(tmp_path / "r.npz"))
    np.testing.assert_array_equal(back.pattern, base.pattern)
    np.testing.assert_array_equal(back.pattern_roll, base.pattern_roll)
    assert len(base.plot_pattern().axes) == 2


def test_block_solver_matches_dense():
    rng = np.random.default_rng(1)
    blocks, gaps = [], []
    for n in (5, 8, 3):
        A = rng.normal(size=(n, n))
        blocks.append(A @ A.T * 1e-9 + np.eye(n) * 1e-9)
        gaps.append(np.abs(rng.normal(size=n)) * 1e-6)
    C = np.zeros((16, 16))
    k = 0
    for b in blocks:
        C[k:k + b.shape[0], k:k + b.shape[0]] = b
        k += b.shape[0]
    ref = solve_contact(C, np.concatenate(gaps), 5000.0)
    got = solve_contact_blocks(blocks, gaps, 5000.0)
    np.testing.assert_allclose(got.f, ref.f, rtol=1e-8, atol=1e-9)
    assert got.delta == pytest.approx(ref.delta, rel=1e-10)


def test_block_solver_reports_singular_block_and_non_convergence():
    """The compiled active set reports, with the position, a singular block and an iteration limit reached."""
    from gearrom.errors import SolverError

    with pytest.raises(SolverError, match="singular contact block at theta = 3 deg"):
        solve_contact_blocks([np.zeros((2, 2))], [np.zeros(2)], 100.0, where=" at theta = 3 deg")
    C = np.eye(4) * 1e-9  # all 1e4 N on the first point: the others penetrate by 10 um less their gaps
    with pytest.raises(SolverError, match=r"did not converge after 1 iterations \(largest penetration 10 um, 4 active of 4\)"):
        solve_contact_blocks([C], [np.array([0.0, 1e-9, 2e-9, 3e-9])], 1e4, max_iter=1)
