"""3D FE model of the helical pair (issue #3): elastic machinery, near field, LTCA, sweep.

References (each test names its own):
* Timoshenko beam theory for the 3D P2-tetrahedron elasticity (cantilever, tip load);
* Love's closed form for a uniformly loaded rectangle on a half-space (Johnson, Contact
  Mechanics, eq. 3.25) against direct quadrature of Boussinesq's point-load solution;
* ISO 6336-1 method B mesh stiffness c_gamma_alpha (an empirical anchor; ISO's own accuracy
  statement for method B is about +-20 % for spur gears, and it carries the helical case only
  through the factor cos(beta) at beta <= 30 deg while this pair has 32 deg: the band is +-35 %);
* eps_beta = 2.02 nearly an integer: the ideal stiffness fluctuation cancels, STE p-p sub-micron
  (fe-method-notes; Smith, Gear Noise and Vibration, ch. 3);
* lead crowning and tip relief remove material: larger mean STE, lower secant stiffness, a
  contact pattern concentrated mid-face and a higher peak pressure for crowning (Smith ch. 3);
* meshing kinematics: both flanks meet at the contact points in the global frame (placement of
  :mod:`gearrom.fe.fullcontact`, independent of the LTCA's shift formula);
* second formulation: the plane-strain slice model (:class:`HelicalSliceLTCA`).
"""
from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.fe.compliance3d import cached_compliance3d, flank_geometry
from gearrom.fe.halfspace import rect_surface
from gearrom.fe.ltca_helical import Helical3DLTCA, contact_pattern
from gearrom.fe.iso6336 import mesh_stiffness
from gearrom.fe.mesh3d import Mesh3DSettings
from gearrom.fe.sweep import default_cache_dir, mesh_cycle

MESH3D = Mesh3DSettings()  # the default (7-tooth elastic sector, ~90k / 120k dofs): chosen by the refinement study


def _micro(pair, **kw):
    gears = [dataclasses.replace(g, micro=dataclasses.replace(g.micro, enabled=True, **kw)) for g in pair.gears]
    return dataclasses.replace(pair, gears=tuple(gears))


@pytest.fixture(scope="module")
def helical3d():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pair = load_config("thesis-helical").pair
    # the package's FE cache: the README's main job (thesis-rig, the same pair and default 3D mesh) stores these
    # compliances there, and a run without it computes and stores them. An entry is keyed by the gearrom version,
    # the model code revision, the geometry and the mesh, and its arrays are checked against their SHA-256 on read.
    comps = tuple(cached_compliance3d(pair, i, MESH3D, cache_dir=default_cache_dir()) for i in range(2))
    ltca = Helical3DLTCA(pair, comps, n_slices=24)
    return pair, ltca, mesh_cycle(ltca, [120.0], 32, tangent=False)


def test_cantilever_p2_tets_match_timoshenko():
    """Tip deflection of a clamped 3D beam (P2 tets of the 3D machinery) vs Timoshenko beam theory."""
    from skfem import MeshTet

    from gearrom.fe.elastic3d import ElasticBody3D
    from gearrom.fe.mesh2d import Mesh2D
    from gearrom.fe.mesh3d import Mesh3D

    Lb, h, w = 30e-3, 4e-3, 4e-3
    m = MeshTet.init_tensor(np.linspace(0, Lb, 16), np.linspace(0, w, 3), np.linspace(0, h, 3))
    pts, tets = m.p.T.copy(), m.t.T.copy()
    clamp = np.flatnonzero(pts[:, 0] < 1e-12)
    mesh = Mesh3D(points=pts, tets=tets, section=Mesh2D(np.zeros((0, 2)), np.zeros((0, 3), int)),
                  zeta=np.zeros(1), bore_nodes=clamp)
    E, nu, P = 210e9, 0.3, 1000.0
    body = ElasticBody3D(mesh, E, nu)
    # end load: uniform shear traction on the free end face by a 6 x 6 midpoint rule
    u = (np.arange(6) + 0.5) / 6
    Y, Z = np.meshgrid(u * w, u * h)
    q = np.column_stack([np.full(Y.size, Lb - 1e-9), Y.ravel(), Z.ravel()])
    dirs = np.tile([0.0, 0.0, 1.0], (q.shape[0], 1))
    F = body.probe_matrix(q, dirs).T @ np.full(q.shape[0], P / q.shape[0])
    U = body.solve(F)[:, 0]
    tip = body.probe_matrix(np.array([[Lb - 1e-9, w / 2, h / 2]]), np.array([[0.0, 0.0, 1.0]])) @ U
    I, A, G = w * h**3 / 12, w * h, E / (2 * (1 + nu))
    ref = P * Lb**3 / (3 * E * I) + P * Lb / (5 / 6 * G * A)
    # Timoshenko ignores the clamp's local warping restraint (a few 0.1 %); P2 on 2 x 2 x 15 cells: ~1 %
    assert tip[0] == pytest.approx(ref, rel=0.03)


@pytest.mark.parametrize("dx,dy", [(0.0, 0.0), (0.2e-3, 0.05e-3), (1.5e-3, -0.7e-3)])
def test_love_rectangle_matches_boussinesq_quadrature(dx, dy):
    """Love's closed form (near field of the LTCA) against brute-force quadrature of 1/r."""
    a, b = 0.05e-3, 0.4e-3
    n = 1200
    x = ((np.arange(n) + 0.5) / n * 2 - 1) * a
    y = ((np.arange(n) + 0.5) / n * 2 - 1) * b
    X, Y = np.meshgrid(x, y)
    ref = np.mean(1.0 / np.hypot(dx - X, dy - Y))
    assert rect_surface(dx, dy, a, b) == pytest.approx(ref, rel=2e-3)


def test_flanks_meet_at_the_contact_lines(helical3d):
    """Kinematics of the 3D model: at every strip, the candidate of gear 1 (tooth -p) and gear 2
    (tooth p) placed in the global frame by fullcontact.placement coincide (within 2 um)."""
    from gearrom.fe.fullcontact import placement

    pair, ltca, _ = helical3d
    theta = 0.3 * ltca.period
    d = ltca._fine(theta, 0, ltca.K)
    on = d["k"] == 0
    p, zc = d["p"][on], d["z"][on]
    s1 = d["line_s1"][d["li"][on]]
    s2 = d["line_s2"][d["li"][on]]
    phi1, phi2 = placement(pair, pair.roll_start_active[0] + pair.rb[0] * theta)
    gaps = []
    for pp, z, a, b in zip(p, zc, s1, s2):
        X1, _ = flank_geometry(pair, 0, a, z, -int(pp))
        X2, _ = flank_geometry(pair, 1, b, z, int(pp))
        R1 = np.array([[math.cos(phi1), -math.sin(phi1)], [math.sin(phi1), math.cos(phi1)]])
        f2 = math.pi + phi2
        R2 = np.array([[math.cos(f2), -math.sin(f2)], [math.sin(f2), math.cos(f2)]])
        g1 = R1 @ X1[:2]
        g2 = R2 @ X2[:2] + np.array([0.0, pair.aw])
        gaps.append(np.hypot(*(g1 - g2)))
    assert max(gaps) < 2e-6


def test_mean_stiffness_vs_iso_and_submicron_ste(helical3d):
    """ISO 6336-1 method B c_gamma_alpha x b as the anchor (see module doc for the +-35 % band)."""
    pair, _, res = helical3d
    iso = mesh_stiffness(pair) * pair.face_width
    ratio = res.k_secant[0].mean() / iso
    print(f"helical 3D FE / ISO 6336 c_gamma_alpha = {ratio:.3f}; STE p-p {np.ptp(res.ste[0]) * 1e6:.3f} um, "
          f"mean {res.ste[0].mean() * 1e6:.3f} um")
    assert 0.65 <= ratio <= 1.35
    assert np.ptp(res.ste[0]) < 1e-6
    assert "3D FE" in res.definition


def test_tip_relief_and_lead_crowning_directions(helical3d):
    """Material removed (drawing C_b = 4 um, drawing C_a = 8 / 15 um) -> larger mean STE, lower secant
    stiffness. Crowning moves the load to mid-face (contact pattern) and breaks the eps_beta ~ 2
    cancellation (larger STE p-p at the nominal load); tip relief removes the tip-corner contact (lower
    peak pressure). All drawing modifications together: larger ripple, still sub-micron."""
    pair, ltca, base = helical3d
    crowned = _micro(pair, tip_relief=0.0, profile_crowning=0.0, tip_form_diameter=None)
    relieved = _micro(pair, lead_crowning=0.0, profile_crowning=0.0, tip_form_diameter=None)
    rc, rr, rd = (mesh_cycle(ltca.with_pair(p), [120.0], 32, tangent=False) for p in (crowned, relieved, _micro(pair)))
    for r in (rc, rr, rd):
        assert r.ste[0].mean() > base.ste[0].mean() + 1e-6
        assert r.k_secant[0].mean() < 0.95 * base.k_secant[0].mean()
    print(f"STE p-p [um]: base {np.ptp(base.ste[0]) * 1e6:.3f}, crowned {np.ptp(rc.ste[0]) * 1e6:.3f}, "
          f"relieved {np.ptp(rr.ste[0]) * 1e6:.3f}, drawing {np.ptp(rd.ste[0]) * 1e6:.3f}")
    assert np.ptp(rc.ste[0]) > np.ptp(base.ste[0])
    assert np.ptp(base.ste[0]) < np.ptp(rd.ste[0]) < 1e-6
    assert rr.max_pressure.max() < 0.8 * base.max_pressure.max()
    b = pair.face_width

    def mid_share(p):
        r = ltca.with_pair(p).solve(0.0, 120.0)
        return r.force_c[np.abs(r.z) < 0.25 * b].sum() / r.force_c.sum()

    assert mid_share(crowned) > mid_share(pair) + 0.1


def test_contact_pattern_and_no_fe_solve_for_new_micro(helical3d):
    pair, ltca, _ = helical3d
    res = ltca.solve(0.0, 120.0)
    ze, re, pat = contact_pattern(res, pair)
    assert pat.shape == (ze.size - 1, re.size - 1) and pat.max() == pytest.approx(res.max_pressure)
    other = ltca.with_pair(_micro(pair, lead_crowning=4e-6))
    assert other.c[0] is ltca.c[0] and other.c[1] is ltca.c[1]


@pytest.mark.parametrize("slope,theta", [(44e-6, 0.1718), (-44e-6, 0.1841)])
def test_contact_outside_the_candidate_window_is_found(helical3d, slope, theta):
    """A 44 um helix slope at 300 N m: part of the contact lies 0.4 mm from the ideal contact lines, past
    the default candidate window (0.18 mm), behind window-edge points that carry nothing (the gap rises
    past the edge and falls again). Reference: the same model on a window wide enough to hold the whole
    contact (0.96 mm); each torque's result is also the same whether it is solved alone or with others."""
    pair, ltca, _ = helical3d
    p = dataclasses.replace(pair, gears=(dataclasses.replace(pair.gears[0], micro=dataclasses.replace(
        pair.gears[0].micro, enabled=True, helix_slope=slope)), pair.gears[1]))
    torques = [30.0, 120.0, 300.0]
    default = Helical3DLTCA(p, ltca.c).solve_many(theta, torques)
    wide = Helical3DLTCA(p, ltca.c, half_window=0.96e-3).solve_many(theta, torques)
    alone = Helical3DLTCA(p, ltca.c).solve(theta, 300.0)
    assert [r.ste for r in default] == pytest.approx([r.ste for r in wide], abs=1e-12)
    assert alone.ste == pytest.approx(default[-1].ste, abs=1e-12)
    assert default[-1].ste - default[1].ste > 15e-6      # the case loads the far contact (not a trivial one)


@pytest.fixture(scope="module")
def loaded(helical3d):
    from gearrom.fe.loaded3d import LoadedPair3D

    _, ltca, _ = helical3d
    return LoadedPair3D(ltca)


@pytest.mark.parametrize("frac", [0.0, 0.33, 0.71])
def test_direct_fe_solve_matches_ltca(helical3d, loaded, frac):
    """Second formulation: the LTCA forces applied to the real teeth of both 3D meshes in one direct solve
    (no influence coefficients, no cyclic symmetry, no grid interpolation; near field computed directly
    for the fine patches) give the same approach within 3 % (issue acceptance: STE and stiffness).
    All loaded teeth lie in the 7-tooth elastic sector."""
    _, ltca, _ = helical3d
    r = loaded.crosscheck(frac * ltca.period, 120.0)
    print(f"theta = {frac:.2f} period: STE LTCA {r['ste_ltca'] * 1e6:.3f} um, direct {r['ste_direct'] * 1e6:.3f} um")
    assert r["ste_direct"] == pytest.approx(r["ste_ltca"], rel=0.03)
    assert r["stiffness_direct"] == pytest.approx(r["stiffness_ltca"], rel=0.03)


def test_vtu_export_of_the_3d_pair(helical3d, loaded, tmp_path):
    """VTU of the loaded 3D state: both gears, displacement magnitude of the order of the STE, the
    contact pressure of the LTCA on the flank nodes (export_vtu dispatches helical pairs here)."""
    import meshio

    from gearrom.fe.export import export_vtu

    pair, ltca, _ = helical3d
    res = ltca.solve(0.0, 120.0)
    m = meshio.read(loaded.write_vtu(0.0, 120.0, tmp_path / "h.vtu"))
    assert m.cells[0].type == "tetra" and set(np.unique(m.point_data["gear"])) == {0.0, 1.0}
    assert 0.5 * res.max_pressure < m.point_data["contact_pressure"].max() <= 1.001 * res.max_pressure
    umax = np.linalg.norm(m.point_data["displacement"], axis=1).max()
    assert 0.2 * res.ste < umax < 3 * res.ste
    assert np.all(m.cell_data["von_mises"][0] >= 0)
    from gearrom.errors import ModelError
    from gearrom.fe.ltca_slices import HelicalSliceLTCA

    slices = HelicalSliceLTCA.__new__(HelicalSliceLTCA)  # no FE needed: export refuses it up front
    slices.pair = pair
    with pytest.raises(ModelError, match="slice model"):
        export_vtu(slices, 0.0, 120.0, tmp_path / "x.vtu")


def test_bad_helical_model_is_named(helical3d):
    from gearrom.errors import ModelError
    from gearrom.fe.sweep import build_ltca

    pair, _, _ = helical3d
    with pytest.raises(ModelError, match="helical_model"):
        build_ltca(pair, cache_dir=None, helical_model="plates")
