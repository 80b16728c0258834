"""Helical pair of the rig (thesis-helical) with the slice LTCA (transverse plane-strain slices).

References: ISO 6336-1 method B c_gamma_alpha (anchor, about +-20 %; the ratio is printed);
eps_beta = 2.02 nearly an integer, so the ideal stiffness fluctuation nearly cancels and the STE
peak-to-peak is sub-micron (fe-method-notes; Smith, Gear Noise and Vibration, ch. 3); lead
crowning and tip relief remove material and shorten the loaded contact lines (larger mean STE,
lower secant stiffness; crowning raises the mid-face Hertz pressure), and the drawing
modifications break the near-integer-overlap cancellation so that the ripple grows (Smith 2003,
ch. 3). The block contact solver is checked against the dense one. Lead modifications are taken
along the transverse line of action, as ISO 1328-1 measures helix deviations: closed-form kinematic
and uncoupled-slice references, and agreement with the 3D LTCA (see each test).
"""
from __future__ import annotations

import dataclasses
import math
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


#: every flank modification of the drawing switched off (the lead tests set one at a time)
NO_MODS = dict(tip_relief=0.0, profile_crowning=0.0, lead_crowning=0.0, helix_slope=0.0, tip_form_diameter=None)


def _lead(pair, helix_slope_1=0.0, lead_crowning=0.0):
    """``pair`` with only a helix slope on gear 1 and a lead crowning on each gear [m]."""
    p = _micro(pair, **{**NO_MODS, "lead_crowning": lead_crowning})
    g1 = dataclasses.replace(p.gears[0], micro=dataclasses.replace(p.gears[0].micro, helix_slope=helix_slope_1))
    return dataclasses.replace(p, gears=(g1, p.gears[1]))


def _mean_ste(ltca, torque, n=8):
    """Mean loaded and unloaded TE over ``n`` positions of one mesh period [m], and the results."""
    res = [ltca.solve(k * ltca.period / n, torque) for k in range(n)]
    return np.mean([r.ste for r in res]), np.mean([r.ste_kinematic for r in res]), res


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


@pytest.mark.parametrize("f_h", [20e-6, -20e-6])
def test_helix_slope_unloaded_shift_is_half_the_slope_transverse(helical, f_h):
    """Unloaded TE of a helix slope is -|f_Hbeta| / 2 along the transverse line of action.

    Reference (closed form): gear 1 carries the helix slope ``f_Hbeta`` (removal ``f_Hbeta z / b``
    along the transverse line of action, from -f_Hbeta/2 to +f_Hbeta/2 across the face, zero mean),
    gear 2 none. The involutes touch on the contact lines, so the unloaded pair turns until the
    point of least removal touches: TE = min over the contact points of ``f_Hbeta z / b``. With
    eps_alpha > 1 every transverse section is in contact at every position, the face-end section
    included, so TE = -|f_Hbeta| / 2 at every position. The slices sample the face at their centres
    ``z_k = -b/2 + (k + 1/2) b / n``: the outermost lies b / (2 n) inside the face end, so the
    model's reference is -|f_Hbeta| / 2 (1 - 1/n). Taking the removal as a normal value
    (transverse = normal / cos(beta_b)) would give 1 / cos(beta_b) = 1.16 times that.

    Checked on the contact solution at 1e-3 N m (its deflection is a few nm) relative to the
    perfect pair at the same load, and on the kinematic TE.
    """
    pair, ltca, _ = helical
    n = ltca.n_slices
    ref = -0.5 * abs(f_h) * (1 - 1 / n)
    ste0, kin0, _ = _mean_ste(ltca, 1e-3)
    ste, kin, res = _mean_ste(HelicalSliceLTCA(_lead(pair, helix_slope_1=f_h), ltca.c, n_slices=n), 1e-3)
    assert kin0 == 0.0
    np.testing.assert_allclose([r.ste_kinematic for r in res], ref, atol=1e-12)
    assert ste - ste0 == pytest.approx(ref, abs=0.03e-6)
    assert abs(ref / math.cos(pair.beta_b) - ref) > 1e-6  # the normal reading differs by far more


def test_lead_crowning_shift_unloaded_and_under_full_face_load(helical):
    """Lead crowning: no unloaded TE shift; under load the shift is the face-mean removal.

    References (closed form), crowning ``C_b`` on each gear, ``C = 2 C_b`` for the pair, removal
    ``C (2 z / b)^2`` along the transverse line of action (zero at mid-face, C at both face ends):

    * unloaded: the mid-face section is always in contact (eps_alpha > 1), so TE = min of the removal
      = 0; the slices' centres nearest to mid-face lie b / (2 n) off it (n even): C / n^2.
    * loaded, every slice in contact: uncoupled slices are independent springs with equal stiffness
      per unit face width on average over a mesh period (every slice passes through the same mesh
      phases, the contact lines only shift along the face), so the approach ``delta`` with
      ``sum_k k_k (delta - h_k) = F`` exceeds the perfect pair's by the stiffness-weighted mean
      removal: the mean over the slice centres, C (1 - 1/n^2) / 3. The perfect pair's deflection is
      larger than 2 C / 3, so every slice stays loaded (checked). The tolerance (5 %) covers the
      contact non-linearity (a slice's stiffness grows with its load, and crowning unloads the face
      ends) and eps_beta = 2.02 being not exactly an integer. The normal reading would be
      1 / cos(beta_b) = 1.16 times the reference.
    """
    pair, ltca, _ = helical
    n = ltca.n_slices
    c_b = 4e-6  # the drawing's lead crowning of each gear
    C = 2 * c_b
    crowned = HelicalSliceLTCA(_lead(pair, lead_crowning=c_b), ltca.c, n_slices=n)
    ste0, _, _ = _mean_ste(ltca, 1e-3)
    ste, kin, _ = _mean_ste(crowned, 1e-3)
    assert kin == pytest.approx(C / n**2, rel=1e-9)
    assert ste - ste0 == pytest.approx(C / n**2, abs=0.03e-6)
    ste0, _, _ = _mean_ste(ltca, 120.0, n=16)
    ste, _, res = _mean_ste(crowned, 120.0, n=16)
    for r in res:  # every slice carries load at every position
        assert np.unique(r.z[r.force_c > 0]).size == n
    assert ste - ste0 == pytest.approx(C * (1 - 1 / n**2) / 3, rel=0.05)


def test_slices_and_3d_ltca_agree_on_the_crowning_shift(helical):
    """The slice and 3D LTCAs give the same mean TE shift of a lead crowning within the effect of
    the slices' approximation.

    Both models take the removal along the transverse line of action (:mod:`gearrom.fe.flankgaps`).
    When the whole face carries load, the shift of the mean TE is, to first order, the removal
    ``h(z)`` averaged with the perfect pair's load distribution over the face as weights (the
    linearised contact problem: delta = F / sum(w) + sum(w h) / sum(w), with w = C^-1 1). The
    uncoupled slices load the face uniformly; the 3D teeth carry less load near their free end faces
    (no material beyond them), where a crowning removes most. That difference of weighted means,
    computed here from the 3D model's own perfect-pair load distribution at the same positions,
    bounds the difference of the two models' shifts, plus 5 % of the shift for the contact
    non-linearity (in the 3D model the face-end strips of the crowned pair may lift off, which keeps
    its shift below the linear estimate). Drawing crowning C_b = 4 um on each gear, 120 N m, 24 strips
    in both models, 16 positions of one mesh period.

    Uses the 3D compliances of the package's FE cache, as tests/fe/test_fe_helical3d.py does
    (computed and stored there when absent).
    """
    from gearrom.fe.compliance3d import cached_compliance3d
    from gearrom.fe.ltca_helical import Helical3DLTCA
    from gearrom.fe.mesh3d import Mesh3DSettings
    from gearrom.fe.sweep import default_cache_dir

    pair, ltca, _ = helical
    n, c_b = 24, 4e-6
    crowned = _lead(pair, lead_crowning=c_b)
    comps = tuple(cached_compliance3d(pair, i, Mesh3DSettings(), cache_dir=default_cache_dir()) for i in range(2))
    d3 = Helical3DLTCA(pair, comps, n_slices=n)
    models = {"slices": (HelicalSliceLTCA(pair, ltca.c, n_slices=n), HelicalSliceLTCA(crowned, ltca.c, n_slices=n)),
              "3d": (d3, d3.with_pair(crowned))}
    shift = {}
    for name, (lt, lt_crowned) in models.items():
        ste0, _, res0 = _mean_ste(lt, 120.0, n=16)
        ste, _, res = _mean_ste(lt_crowned, 120.0, n=16)
        loaded = [np.unique(r.z[r.force_c > 0]).size for r in res]
        assert min(loaded) >= (n if name == "slices" else n - 2)  # whole face loaded (3D: but the end strips)
        shift[name] = ste - ste0
        if name == "3d":  # perfect pair's load over the face strips, summed over the positions
            z = np.concatenate([r.z for r in res0])
            f = np.concatenate([r.force_c for r in res0])
            zk = np.unique(z)
            w = np.array([f[z == v].sum() for v in zk])
            h = 2 * c_b * (2 * zk / pair.face_width) ** 2
            coupling = abs(h.mean() - (w * h).sum() / w.sum())
    tol = coupling + 0.05 * shift["3d"]
    print(f"crowning shift: slices {shift['slices'] * 1e6:.3f} um, 3D {shift['3d'] * 1e6:.3f} um, "
          f"tolerance {tol * 1e6:.3f} um (coupling {coupling * 1e6:.3f} um)")
    assert shift["slices"] > shift["3d"] > 0  # uncoupled slices over-estimate the lead sensitivity
    assert abs(shift["slices"] - shift["3d"]) <= tol


def _hertz_ratio(res, pair, cosb, dz, normal: bool):
    """Peak pressure over the Hertz peak (Johnson, Contact Mechanics, eqs. 4.43-4.45) of every contact
    line of ``res`` (one strip of one pair) in the middle of the path of contact.

    Line load and relative radius of curvature: transverse section (``normal=False``): the transverse
    load per unit face width ``w = f_t / dz`` and the involutes' transverse radii ``R_t`` (roll lengths);
    normal section across the contact line (``normal=True``): ``w_n = f_n / (dz / cos(beta_b))`` (equal
    to ``w``) and ``R_n = R_t / cos(beta_b)`` (the flank's normal curvature across the contact line is
    the transverse involute's times cos(beta_b)). ``p0 = sqrt(w E* / (pi R))``, ``E* = E / (2 (1 - nu^2))``.
    The lines whose load centre lies within 1.5 mm of either end of the active path are left out (tip
    edges, loads too low for the flank grid to resolve the Hertz width).
    """
    mat = pair.gears[0].material
    e_star = mat.youngs_modulus / (2 * (1 - mat.poisson_ratio**2))
    tan_len = pair.aw * math.sin(pair.alpha_wt)
    lo, hi = pair.roll_start_active[0] + 1.5e-3, pair.roll_tip[0] - 1.5e-3
    out = []
    for z in np.unique(res.z):
        for p in np.unique(res.pair):
            on = (res.z == z) & (res.pair == p) & (res.force_c > 0)
            if not on.any():
                continue
            fn = res.force_c[on].sum()
            L1 = float(np.sum(res.force_c[on] * res.roll1[on]) / fn)
            if not lo < L1 < hi:
                continue
            L2 = tan_len - L1
            r_rel = L1 * L2 / (L1 + L2) / (cosb if normal else 1.0)
            w = fn * cosb / dz  # = f_n / (dz / cos(beta_b)): the same line load in both sections
            out.append(res.pressure[on].max() / math.sqrt(w * e_star / (math.pi * r_rel)))
    return np.array(out)


def test_slice_forces_are_normal_forces_and_pressure_their_flank_patch_load(helical):
    """The slice LTCA reports normal contact forces and the pressure on the candidate's flank patch.

    References:

    * statics (hand): the output torque T acts through the normal contact forces, whose transverse
      components sum to F_t = T / r_b2, so they sum to F_t / cos(beta_b) (involute contact; no tip-edge
      candidate carries load at these positions: COARSE flank grid at 120 N m); the 3D LTCA
      (:mod:`gearrom.fe.ltca_helical`, 3D compliances of the package's FE cache) reports the same total
      at the same torque; both models' pair forces are shares of F_t.
    * area (hand): a slice candidate's patch in the flank is ``spacing`` wide along the transverse
      profile (perpendicular to the contact line in the flank's tangent plane) and ``dz / cos(beta_b)``
      long along the contact line, so ``pressure * spacing * dz / cos(beta_b)`` is the candidate's normal
      force, and the mean pressure over the loaded patches is the total normal force over their area.
    """
    from gearrom.fe.compliance3d import cached_compliance3d
    from gearrom.fe.ltca_helical import Helical3DLTCA
    from gearrom.fe.mesh3d import Mesh3DSettings
    from gearrom.fe.sweep import default_cache_dir

    pair, ltca, _ = helical
    cosb = math.cos(pair.beta_b)
    area = ltca.c[0].spacing * ltca.dz / cosb
    comps = tuple(cached_compliance3d(pair, i, Mesh3DSettings(), cache_dir=default_cache_dir()) for i in range(2))
    d3 = Helical3DLTCA(pair, comps, n_slices=ltca.n_slices)
    torque = 120.0
    f_t = torque / pair.rb[1]
    for theta in np.arange(4) * ltca.period / 4:
        r = ltca.solve(theta, torque)
        r3 = d3.solve(theta, torque)
        assert r.force_c.sum() == pytest.approx(f_t / cosb, rel=1e-9)
        assert r3.force_c.sum() == pytest.approx(r.force_c.sum(), rel=1e-9)
        assert r.pair_force.sum() == pytest.approx(f_t, rel=1e-9) and r3.pair_force.sum() == pytest.approx(f_t, rel=1e-9)
        np.testing.assert_allclose(r.pressure * area, r.force_c, rtol=1e-12)
        on = r.force_c > 0
        assert r.pressure[on].mean() == pytest.approx(f_t / cosb / (on.sum() * area), rel=1e-9)


def test_slice_and_3d_peak_pressures_follow_their_hertz_sections(helical):
    """Peak pressures against Hertz: the slices' of their transverse sections, the 3D model's of the
    normal section, so that at the same line load the slices' peak is 1 / sqrt(cos(beta_b)) times the 3D's.

    Reference: Hertz line contact (Johnson, Contact Mechanics, eqs. 4.43-4.45) of every contact line
    in mid-path (see :func:`_hertz_ratio`), with each model's own load of that line. The slices are
    plane-strain transverse sections: each carries the transverse force on the transverse involutes,
    so its peak is the transverse Hertz peak ``sqrt(w E* / (pi R_t))``; the 3D LTCA resolves the
    contact across the line (half-space near field) with the flank's normal radius ``R_t / cos(beta_b)``:
    ``sqrt(cos(beta_b))`` times that at the same ``w``. Tolerance 5 % on each line: the 2D FE
    patch machinery meets Hertz within 3 % (tests/fe/test_fe_hertz.py) and the COARSE flank grid
    (0.04 mm) averages the pressure over patches about half the Hertz half-width wide (a semi-ellipse
    averaged over a patch centred up to half a patch off its peak: up to 5 % below its peak). The median
    ratio of the two models is 1 / sqrt(cos(beta_b)) within 3 %; a pressure of f_t / (spacing dz) /
    cos(beta_b) in the slices (the normal force over the transverse patch) would put it at
    cos(beta_b)^-1.5, 16 % higher.
    """
    from gearrom.fe.compliance3d import cached_compliance3d
    from gearrom.fe.ltca_helical import Helical3DLTCA
    from gearrom.fe.mesh3d import Mesh3DSettings
    from gearrom.fe.sweep import default_cache_dir

    pair, ltca, _ = helical
    cosb = math.cos(pair.beta_b)
    comps = tuple(cached_compliance3d(pair, i, Mesh3DSettings(), cache_dir=default_cache_dir()) for i in range(2))
    d3 = Helical3DLTCA(pair, comps, n_slices=ltca.n_slices)
    sl, s3 = [], []
    for theta in np.arange(4) * ltca.period / 4:
        sl.append(_hertz_ratio(ltca.solve(theta, 120.0), pair, cosb, ltca.dz, normal=False))
        s3.append(_hertz_ratio(d3.solve(theta, 120.0), pair, cosb, d3.dz, normal=True))
    sl, s3 = np.concatenate(sl), np.concatenate(s3)
    print(f"peak / Hertz: slices {sl.min():.3f}-{sl.max():.3f} ({sl.size} lines), "
          f"3D {s3.min():.3f}-{s3.max():.3f} ({s3.size} lines)")
    assert sl.size >= 20 and s3.size >= 20
    np.testing.assert_allclose(sl, 1.0, rtol=0.05)
    np.testing.assert_allclose(s3, 1.0, rtol=0.05)
    # at the same line load the slices' peak over the 3D's is (sl p0_t) / (s3 p0_n), p0_n = sqrt(cos(beta_b)) p0_t
    assert np.median(sl) / (np.median(s3) * math.sqrt(cosb)) == pytest.approx(1 / math.sqrt(cosb), rel=0.03)
