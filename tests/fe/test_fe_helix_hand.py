"""Helix hand: which face end of a helical pair enters contact first, the same in every mesh model.

Models: the slice LTCA (:class:`~gearrom.fe.ltca_slices.HelicalSliceLTCA`), the 3D LTCA
(:class:`~gearrom.fe.ltca_helical.Helical3DLTCA`) and the analytical thin-slice model
(:class:`~gearrom.excitation.slices.SliceMicroModel`), all placing their sections with
:func:`gearrom.geometry.profile.contact_shift`.

References (each test names its own):

* geometry: the involute helicoids of :mod:`gearrom.geometry` (the transverse flank of
  :func:`~gearrom.geometry.profile.tooth_profile` turned by :func:`~gearrom.geometry.profile.twist`),
  cut with the transverse line of action; no LTCA code. The hand label is checked against the
  chirality of the flank's helices (sign of their torsion);
* mirror symmetry: the mirror image z -> -z of a pair is the pair with both hands swapped, and
  it turns the removal ``f_Hbeta z / b`` into ``-f_Hbeta z / b``; the transverse sections, the
  rotation sense and so the TE are unchanged;
* closed form of uncoupled linear slices under a linear removal (for the mean TE shift).

The 3D compliances come from the package's FE cache, as in tests/fe/test_fe_helical3d.py (computed
and stored there when absent), and so do the plane-strain compliances of the slice LTCA (the
default mesh that :func:`gearrom.fe.sweep.build_ltca` and the FE micro-geometry model use).
"""
from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

import gearrom.excitation.slices as slice_model
from gearrom.config import load_config
from gearrom.excitation.slices import MicroMods, SliceMicroModel
from gearrom.fe.compliance3d import cached_compliance3d
from gearrom.fe.ltca_helical import Helical3DLTCA
from gearrom.fe.ltca_slices import HelicalSliceLTCA
from gearrom.fe.mesh3d import Mesh3DSettings
from gearrom.fe.sweep import build_ltca, default_cache_dir
from gearrom.geometry.profile import contact_shift, entry_face_end, tooth_profile, twist

F_H = 44e-6  # helix slope of the input gear [m] (4 x the drawing tolerance of +-11 um)
N_POS = 16  # positions per mesh period
N_STRIPS = 24
PARTLY, FULLY = 30.0, 400.0  # output torques [N m]: about a third of the face loaded / the whole face loaded


def _right():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config("thesis-helical").pair


def _mirror(pair):
    """``pair`` with both hands swapped (its mirror image z -> -z)."""
    g1, g2 = pair.gears
    return dataclasses.replace(pair, gears=(dataclasses.replace(g1, hand=g2.hand),
                                            dataclasses.replace(g2, hand=g1.hand)))


def _slope(pair, f_h):
    """``pair`` with a helix slope ``f_h`` [m] on the input gear and no other flank modification."""
    gears = []
    for i, g in enumerate(pair.gears):
        m = dataclasses.replace(g.micro, enabled=True, tip_relief=0.0, profile_crowning=0.0, lead_crowning=0.0,
                                helix_slope=f_h if i == 0 else 0.0, tip_form_diameter=None)
        gears.append(dataclasses.replace(g, micro=m))
    return dataclasses.replace(pair, gears=tuple(gears))


@pytest.fixture(scope="module")
def models():
    pair = _right()
    comps3 = tuple(cached_compliance3d(pair, i, Mesh3DSettings(), cache_dir=default_cache_dir()) for i in range(2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the slice model's approximation warning
        plane = build_ltca(pair, None, cache_dir=default_cache_dir(), n_slices=N_STRIPS, helical_model="slices").c
    return pair, comps3, plane


# ------------------------------------------------------------------------------------ (a) geometry
def _line(pair):
    """Transverse line of action: start (the input's base tangent point) and unit direction."""
    a = pair.alpha_wt
    return pair.rb[0] * np.array([-math.sin(a), math.cos(a)]), np.array([math.cos(a), math.sin(a)])


def _rot(points, angle):
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


def _crossings(pair, pts, centre, rb, own_roll):
    """Parameters ``L`` (from the input's base tangent point) where the flank polyline ``pts`` crosses the
    line of action at right angles, i.e. where the flank point's own roll length ``sqrt(r^2 - r_b^2)``
    (``r`` from ``centre``) equals ``own_roll(L)``."""
    B, u = _line(pair)
    n = np.array([-u[1], u[0]])
    d = (pts - B) @ n
    out = []
    for k in np.flatnonzero(np.sign(d[:-1]) != np.sign(d[1:])):
        P = pts[k] + d[k] / (d[k] - d[k + 1]) * (pts[k + 1] - pts[k])
        L = float((P - B) @ u)
        if abs(math.sqrt(max(np.sum((P - centre) ** 2) - rb**2, 0.0)) - own_roll(L)) < 1e-6:
            out.append(L)
    return out


def _contact_on_line(pair, i, z, angle):
    """Where the loaded (right) flank helicoid of gear ``i`` meets the line of action in the section ``z``.

    Gear 1 (centre at the origin) turned clockwise by ``angle``; gear 2 (centre at (0, a_w), its frame
    turned by pi) counter-clockwise by ``angle``. Returns the parameter ``L`` along the line [m] of its
    tooth 0, from the crossings of its teeth ``-8..8`` (tooth j is tooth 0 turned by ``2 pi j / z_i``:
    ``L_j = L_0 -+ j p_bt``, the sign of the running direction; all teeth must give the same ``L_0``).
    """
    flank = tooth_profile(pair, i, n_involute=400).flank(+1)
    zi, rb, pb = pair.z[i], pair.rb[i], pair.pb_t
    tan_len = pair.aw * math.sin(pair.alpha_wt)
    found = []
    for j in range(-8, 9):
        if i == 0:
            pts = _rot(flank, float(twist(pair, 0, z)) - angle + 2 * math.pi * j / zi)
            found += [L + j * pb for L in _crossings(pair, pts, np.zeros(2), rb, lambda L: L)]
        else:
            centre = np.array([0.0, pair.aw])
            pts = _rot(flank, math.pi + float(twist(pair, 1, z)) + angle + 2 * math.pi * j / zi) + centre
            found += [L - j * pb for L in _crossings(pair, pts, centre, rb, lambda L: tan_len - L)]
    assert len(found) >= 2 and np.ptp(found) < 1e-7  # every tooth: the same helicoid, pitch p_bt apart
    return float(np.mean(found))


def _torsion_sign(pair, i):
    """Sign of the torsion of the helix traced over the face by a point of gear ``i``'s flank (+1: right-handed)."""
    p0 = tooth_profile(pair, i).flank(+1)[5]
    z = np.linspace(-2e-3, 2e-3, 5)
    X = np.array([[*_rot(p0[None, :], float(twist(pair, i, zz)))[0], zz] for zz in z])
    d1 = (X[3] - X[1]) / (z[3] - z[1])
    d2 = (X[3] - 2 * X[2] + X[1]) / (z[3] - z[2]) ** 2
    d3 = (X[4] - 2 * X[3] + 2 * X[1] - X[0]) / (2 * (z[3] - z[2]) ** 3)
    return int(np.sign(np.dot(np.cross(d1, d2), d3)))


@pytest.mark.parametrize("hand", ["right", "left"])
def test_contact_lines_of_the_helicoids_match_every_models_shift(models, hand):
    """The involute helicoids of :mod:`gearrom.geometry` put the contact of the section ``z`` where each model does.

    Reference (geometry, no model code): the loaded right flank of each gear's tooth 0, turned by the
    helix twist of its section and by the running angle, cut with the transverse line of action
    (input turning clockwise, output counter-clockwise about (0, a_w)). Checked:

    * the hand label is the chirality of the flank (torsion > 0 for a right hand);
    * running direction: the input roll grows by ``r_b1 dtheta`` (the right flanks drive);
    * the two helicoids meet along the whole contact line: ``L1(z) + L2(z)`` is the same in every
      section (the gears share the axial coordinate z);
    * ``L1(z) - L1(0)`` equals ``r_b1`` times the shift of the slice LTCA's and the 3D LTCA's
      sections, and its differences between slices equal the analytical model's roll offsets of its
      slices (their axial positions read from the model's own helix-slope gaps, ``f_Hbeta z / b``);
    * the end with the larger ``L1`` (ahead on the path: it enters contact first) is
      :func:`entry_face_end`: z = -b/2 for a right-hand input gear, z = +b/2 for a left-hand one.

    The polyline of 400 involute points places the crossings within 0.02 um (chord sagitta); the
    tolerance is 0.1 um against shifts of several mm over the face.
    """
    right, comps3, plane = models
    pair = right if hand == "right" else _mirror(right)
    assert pair.gears[0].hand == hand
    h = 1 if hand == "right" else -1
    assert _torsion_sign(pair, 0) == h and _torsion_sign(pair, 1) == -h
    b, rb1 = pair.face_width, pair.rb[0]
    theta = 0.01
    L1_0 = _contact_on_line(pair, 0, 0.0, theta)
    assert _contact_on_line(pair, 0, 0.0, theta + 1e-3) - L1_0 == pytest.approx(rb1 * 1e-3, abs=1e-7)
    theta2 = theta * pair.z[0] / pair.z[1]
    sum0 = L1_0 - _contact_on_line(pair, 1, 0.0, theta2)
    ends = {}
    for z in (-0.5 * b, -0.2 * b, 0.3 * b, 0.5 * b):
        L1 = _contact_on_line(pair, 0, z, theta)
        ends[z] = L1
        assert L1 - _contact_on_line(pair, 1, z, theta2) == pytest.approx(sum0, abs=1e-7)
    assert max((-0.5 * b, 0.5 * b), key=ends.get) == entry_face_end(pair) == -0.5 * h * b
    assert ends[-0.5 * b] - ends[0.5 * b] == pytest.approx(h * b * math.tan(pair.beta_b), rel=1e-6)

    def geo(z):
        return np.array([_contact_on_line(pair, 0, zz, theta) - L1_0 for zz in np.atleast_1d(z)])

    slices = HelicalSliceLTCA(pair, plane, n_slices=N_STRIPS)
    d3 = Helical3DLTCA(pair, comps3, n_slices=N_STRIPS)
    for lt in (slices, d3):
        k = [0, 5, 11, 17, 23]
        np.testing.assert_allclose(rb1 * lt.shift[k], geo(lt.z[k]), atol=1e-7)
    model = SliceMicroModel(n_theta=8, n_slices=12)
    _, _, gap = model.slices(pair, MicroMods(helix_slope=F_H))
    z_an = gap[0, 0] * b / F_H  # the slices' axial positions, from the model's own removal f_Hbeta z / b
    # the slices' roll positions s on the path, from the model's own linear tip relief C_a (L - L_Ca) / (L_tip - L_Ca)
    # of the input gear, started 1 mm above the base circle so that it is linear over the whole path
    c_a, L_ca = 10e-6, 1e-3
    relief = MicroMods(tip_relief=(c_a, 0.0), tip_relief_start_diameter=(2 * math.hypot(rb1, L_ca), None))
    _, _, gap = model.slices(pair, relief)
    p = 3  # a pair on the path at theta = 0 in every slice (s = 3 p_bt - y tan(beta_b) > 0)
    s = gap[0, p] / c_a * (pair.roll_tip[0] - L_ca) + L_ca - pair.roll_start_active[0]
    lag = s - p * pair.pb_t
    np.testing.assert_allclose(lag - lag[0], geo(z_an) - geo(z_an[:1])[0], atol=1e-7)


# ------------------------------------------------------------------ (b) responses to a helix slope
def _closed_form_shift(f_h, delta0):
    """Mean TE shift [m] of uncoupled linear slices under the removal ``f_h z / b`` (zero mean), with the
    perfect pair's approach ``delta0`` [m]: ``-f_h/2 + sqrt(2 f_h delta0) - delta0`` while part of the face
    is loaded (``delta0 < f_h / 2``), 0 once the whole face is (|f_h| here)."""
    f = abs(f_h)
    return -0.5 * f + math.sqrt(2 * f * delta0) - delta0 if delta0 < 0.5 * f else 0.0


def _ltca_response(ltca, slope_ltca, torques):
    """Perfect pair's STE, the STE change of the slope and the loaded strips per position, shape (torques, N_POS)."""
    theta = np.arange(N_POS) * ltca.period / N_POS
    base = [ltca.solve_many(t, torques) for t in theta]
    mod = [slope_ltca.solve_many(t, torques) for t in theta]
    ste0 = np.array([[r.ste for r in row] for row in base]).T
    dste = np.array([[r.ste for r in row] for row in mod]).T - ste0
    strips = np.array([[np.unique(r.z[r.force_c > 0]).size for r in row] for row in mod]).T
    return ste0, dste, strips


def _analytical_response(pair, f_h, torques, shape_min=None):
    """Perfect pair's STE and the STE change of the slope of :class:`SliceMicroModel`, on the FE models'
    positions: the model's angle origin (pair 0 enters the path at the face end that enters first) lies
    ``contact_shift(entry_face_end)`` ahead of the FE tables' (pair 0 at the start of the path in z = 0).
    ``shape_min``: a fixed minimum of the pair-stiffness shape (1: uniform stiffness along the path)."""
    model = SliceMicroModel(n_theta=256, n_slices=48)
    with pytest.MonkeyPatch.context() as mp:
        if shape_min is not None:
            mp.setattr(slice_model, "shape_min", lambda eps_alpha: shape_min)
        ex0 = model.excitation(pair, torques, MicroMods())
        ex = model.excitation(pair, torques, MicroMods(helix_slope=f_h))
    period = 2 * math.pi / pair.z[0]
    q = np.mod(np.arange(N_POS) * period / N_POS + float(contact_shift(pair, entry_face_end(pair))), period)
    grid = np.append(ex.theta, period)

    def at(e):
        return np.array([np.interp(q, grid, np.append(row, row[0])) for row in e])

    return at(ex0.e), at(ex.e - ex0.e)


@pytest.fixture(scope="module")
def responses(models):
    pair, comps3, plane = models
    torques = [PARTLY, FULLY]
    d3 = Helical3DLTCA(pair, comps3, n_slices=N_STRIPS)
    out = {"3d": _ltca_response(d3, d3.with_pair(_slope(pair, F_H)), torques),
           "slices": _ltca_response(HelicalSliceLTCA(pair, plane, n_slices=N_STRIPS),
                                    HelicalSliceLTCA(_slope(pair, F_H), plane, n_slices=N_STRIPS), torques)}
    out["analytical"] = _analytical_response(pair, F_H, torques)
    out["analytical, uniform stiffness"] = _analytical_response(pair, F_H, torques, shape_min=1.0)
    return torques, out


@pytest.mark.parametrize("load", ["partly", "fully"])
def test_models_respond_alike_to_a_helix_slope(responses, load):
    """Static-TE change of a helix slope f_Hbeta = 44 um on the input gear (thesis-helical, right-hand input):
    the models correlate positively over the mesh period and their mean shifts agree.

    Loads: at 30 N m the FE models carry load on at most half of their strips at every position (the end
    with least removal), at 400 N m on all of them (checked), and the analytical model's perfect-pair
    approach exceeds f_Hbeta / 2 (its whole face loaded).

    Correlation threshold 0.5 over 16 positions: unrelated series of 16 samples exceed it by chance with
    a probability of about 2.5 % (t = r sqrt(n - 2) / sqrt(1 - r^2) = 2.2, 14 degrees of freedom). A
    model whose sections were shifted for the other hand gives the mirror image of its response to the
    opposite slope (test_left_hand_pair_mirrors_the_right_hand_pair), and that correlates negatively
    with these; with the same hand the models differ only by their mechanics (the 3D model's load
    spreading along the face and its acute and obtuse face-end corners, the uncoupled plane sections,
    the linear springs of the analytical model).

    The analytical model enters the correlations with its pair stiffness uniform along the path of
    contact, so that its response follows from where its contact lines lie (the hand and the angle
    origin) and not from the shape of its pair stiffness. With its ISO parabolic shape the ripple of
    its response is no test of the hand on this pair: eps_alpha and eps_beta are both within a few
    hundredths of 2, so the contact lines' share of the slope cancels to a small residual whose sign
    depends on how much the shape lowers the stiffness at the ends of the path. Its mean shift is
    checked with the ISO shape.

    Mean shifts (over the period): partly loaded, uncoupled linear slices give the closed form
    ``-f/2 + sqrt(2 f delta0) - delta0`` (exact for the analytical model; ``delta0`` the perfect pair's
    mean approach), so the shift depends on the mesh compliance; two models agree within the change of
    that closed form between their own ``delta0``, plus 0.5 um for the Hertzian non-linearity and the
    load spreading of the FE contacts. Reading the slope along the flank normal (1/cos(beta_b) larger)
    would move a shift by several times that margin. Fully loaded, the first-order shift is the
    load-weighted mean removal, zero for a face load symmetric about mid-face; the 3D model's lighter
    face ends and the stiffening of the FE contacts with load (second order in f) leave a fraction of a
    micron: the shifts agree within 0.5 um, about 2 % of f_Hbeta / 2.
    """
    torques, out = responses
    j = 0 if load == "partly" else 1
    for name in ("3d", "slices"):
        strips = out[name][2][j]
        if load == "partly":
            assert strips.max() <= N_STRIPS // 2
        else:
            assert strips.min() == N_STRIPS
    d0 = {name: float(out[name][0][j].mean()) for name in out}
    shift = {name: float(out[name][1][j].mean()) for name in out}
    if load == "fully":
        assert d0["analytical"] > 0.5 * F_H
    pairs = [("3d", "slices"), ("3d", "analytical, uniform stiffness"), ("slices", "analytical, uniform stiffness")]
    for a, b in pairs:
        r = np.corrcoef(out[a][1][j], out[b][1][j])[0, 1]
        print(f"{torques[j]:g} N m: {a} vs {b}: correlation {r:+.2f}")
        assert r > 0.5, (a, b, r)
    print({k: f"shift {shift[k] * 1e6:.3f} um (delta0 {d0[k] * 1e6:.2f} um)" for k in shift})
    for a, b in [("3d", "slices"), ("3d", "analytical"), ("slices", "analytical")]:
        tol = 0.5e-6 + abs(_closed_form_shift(F_H, d0[a]) - _closed_form_shift(F_H, d0[b]))
        assert abs(shift[a] - shift[b]) <= tol, (a, b, shift[a], shift[b], tol)
    if load == "partly":
        assert all(shift[k] < -0.2 * F_H for k in ("3d", "slices", "analytical"))  # far from the full-load value


# --------------------------------------------------------------------------------- (c) mirror image
def test_left_hand_pair_mirrors_the_right_hand_pair(models):
    """Mirror symmetry: the left-hand pair with +f_Hbeta has the right-hand pair's static TE with -f_Hbeta.

    Reference: the mirror image z -> -z of the right-hand pair is the left-hand pair; it keeps the
    transverse sections and the rotation sense and turns the removal ``f z / b`` into ``-f z / b``.
    Both the analytical slices and the slice LTCA (plane sections of either hand are the same; both
    place their slices symmetrically about mid-face) must reproduce it to round-off. That the
    check is not empty: the left-hand pair with +f_Hbeta differs from the right-hand pair with +f_Hbeta.
    """
    right, _, plane = models
    left = _mirror(right)
    tq = [PARTLY, FULLY]
    model = SliceMicroModel(n_theta=64, n_slices=32)
    e_left = model.excitation(left, tq, MicroMods(helix_slope=F_H)).e
    e_right = model.excitation(right, tq, MicroMods(helix_slope=-F_H)).e
    e_same = model.excitation(right, tq, MicroMods(helix_slope=F_H)).e
    np.testing.assert_allclose(e_left, e_right, rtol=0, atol=1e-15)
    assert np.abs(e_left - e_same).max() > 0.05e-6
    lt_left = HelicalSliceLTCA(_slope(left, F_H), plane, n_slices=N_STRIPS)
    lt_right = HelicalSliceLTCA(_slope(right, -F_H), plane, n_slices=N_STRIPS)
    lt_same = HelicalSliceLTCA(_slope(right, F_H), plane, n_slices=N_STRIPS)
    diff = 0.0
    for k in range(6):
        theta = k * lt_left.period / 6
        rows = zip(lt_left.solve_many(theta, tq), lt_right.solve_many(theta, tq), lt_same.solve_many(theta, tq))
        for a, b, c in rows:
            assert a.ste == pytest.approx(b.ste, abs=1e-13)
            for z in np.unique(a.z):  # the load of the strip at z is the mirror pair's at -z
                mirrored = b.force_c[np.isclose(b.z, -z)].sum()
                assert a.force_c[a.z == z].sum() == pytest.approx(mirrored, rel=1e-9, abs=1e-9)
            diff = max(diff, abs(a.ste - c.ste))
    assert diff > 0.05e-6
