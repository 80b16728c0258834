"""Load-dependent mesh law (:class:`gearrom.rom.mesh.ForceMap`): the mesh force follows the FE
force-deflection map over the table's torques.

References: an analytic force-deflection law (exact for a piecewise-linear map at its knots); the
LTCA's own tangent stiffness (a finite difference of its contact solution at +0.1 % load,
``StiffnessResult.k_tangent``), a second method against the map's chord; the generalized eigenvalue
problem of the model's structure with that FE tangent for the mesh mode.
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from gearrom.excitation.table import MeshExcitation


def _hertz_like_table(rb2: float) -> MeshExcitation:
    """A table of the law delta = e_kin(theta) + c F^(2/3) (stiffening with load, like Hertz contact)."""
    n = 64
    theta = np.arange(n) * (2 * np.pi / 20) / n
    kin = 1e-6 * np.sin(20 * theta)
    torques = np.array([30.0, 60.0, 120.0, 240.0])
    F = torques / rb2
    c = 5e-6 / F[2] ** (2 / 3)
    e = kin[None, :] + c * F[:, None] ** (2 / 3) * (1 + 0.1 * np.cos(20 * theta))[None, :]
    k = F[:, None] / (e - kin[None, :])
    return MeshExcitation(z1=20, theta=theta, torque=torques, k=k, e=e, load_share=np.ones((4, n, 1)),
                          definition="synthetic", pairs=np.array([0]))


def test_force_map_reproduces_the_law_at_its_knots():
    from gearrom.rom.mesh import ForceMap

    rb2 = 0.03
    ex = _hertz_like_table(rb2)
    fm = ForceMap.from_table(ex, rb2, 120.0, n=64)
    assert fm.n_torques == 4 and fm.f[0] == 0.0
    np.testing.assert_allclose(fm.e[0], 1e-6 * np.sin(20 * fm.theta), atol=1e-15)  # kinematic TE row
    for j, T in enumerate(ex.torque):
        knots = np.repeat(fm.e[:, :1].T, 1, axis=0)
        assert fm.force(knots, np.array([fm.e[j + 1, 0]]))[0] == pytest.approx(T / rb2)
        np.testing.assert_allclose(fm.static_te(T / rb2), fm.e[j + 1], rtol=1e-12)
    # below the separation point: no force; a modulation scales the force
    knots = fm.e[:, :1].T
    assert fm.force(knots, np.array([fm.e[0, 0] - 1e-7]))[0] == 0.0
    assert fm.force(knots, np.array([fm.e[2, 0]]), 1.1)[0] == pytest.approx(1.1 * ex.torque[1] / rb2)
    # tangent at the knot of 120 N m: chord over 60 and 240 N m of the analytic law
    F = ex.torque / rb2
    e_of = lambda f: fm.e[0] + (fm.e[3] - fm.e[0]) * (f / F[2]) ** (2 / 3)
    np.testing.assert_allclose(fm.tangent(F[2]), (F[3] - F[1]) / (e_of(F[3]) - e_of(F[1])), rtol=1e-9)
    # the analytic derivative dF/d(delta) = 1.5 F / (delta - e_kin) at 120 N m: the chord is within 6 %
    exact = 1.5 * F[2] / (fm.e[3] - fm.e[0])
    np.testing.assert_allclose(fm.tangent(F[2]), exact, rtol=0.06)


def test_compiled_law_matches_the_analytic_law_and_the_map():
    """The numba law of the integrators (:func:`gearrom.rom.lawkernel.law_force`) against the analytic
    Hertz-like law at its knots and between them against the map's numpy evaluation; the secant
    tables against ``k (delta - e0)``."""
    from gearrom.rom.lawkernel import LawTables, law_force
    from gearrom.rom.mesh import ForceMap

    rb2 = 0.03
    ex = _hertz_like_table(rb2)
    fm = ForceMap.from_table(ex, rb2, 120.0, n=64)
    period = 2 * np.pi / 20

    class _Law:  # what LawTables reads from a load-dependent MeshLaw
        z1 = 20
        load_dependent = True
        force_map = fm

    tab = LawTables.from_law(_Law())
    F = ex.torque / rb2
    rng = np.random.default_rng(3)
    for i in rng.integers(0, 64, 8):
        for j in range(4):  # at the knots: the analytic law's forces
            assert law_force(tab.E, tab.f, float(i), fm.e[j + 1, i], 0.0, 0.0) == pytest.approx(F[j], rel=1e-12)
        assert law_force(tab.E, tab.f, float(i), fm.e[0, i] - 1e-9, 1.0, 1e3) == 0.0  # no contact, no damping
    # between grid angles and knots, beyond the last knot, with damping: the map's own evaluation
    u = rng.uniform(0, 128, 200)  # phase in grid steps, two periods
    th = u * period / 64
    knots = np.array([np.interp(np.mod(th, period), np.r_[fm.theta, period], np.r_[row, row[0]]) for row in fm.e]).T
    delta = knots[:, 0] + rng.uniform(-0.2, 1.3, u.size) * (knots[:, -1] - knots[:, 0])
    want = fm.force(knots, delta) + np.where(delta > knots[:, 0], 2e3 * 0.01, 0.0)
    got = np.array([law_force(tab.E, tab.f, ui, di, 0.01, 2e3) for ui, di in zip(u, delta)])
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-9)

    class _Secant:
        z1 = 20
        load_dependent = False
        k_grid = 2e8 * (1 + 0.2 * np.cos(20 * fm.theta))
        e_grid = 1e-6 * np.sin(20 * fm.theta) + 5e-6
        f_nom = 1000.0

    sec = LawTables.from_law(_Secant())
    e0 = _Secant.e_grid - _Secant.f_nom / _Secant.k_grid
    for i in (0, 17, 40):
        for d in (e0[i] + 1e-6, e0[i] + 9e-6):
            assert law_force(sec.E, sec.f, float(i), d, 0.0, 0.0) == pytest.approx(_Secant.k_grid[i] * (d - e0[i]), rel=1e-12)


@pytest.fixture(scope="module")
def fe_rig(spur_fe_rig_config):
    from gearrom.rom.rig import build_rig

    return build_rig(spur_fe_rig_config)


@pytest.fixture(scope="module")
def fe_tangent(fe_rig, spur_fe_mesh):
    """The LTCA's own mean tangent stiffness [N/m] at 60, 120 and 240 N m."""
    from gearrom.fe.sweep import build_ltca, mesh_cycle

    res = mesh_cycle(build_ltca(fe_rig.pair, spur_fe_mesh), [60.0, 120.0, 240.0], 32)
    return {float(T): float(res.k_tangent[j].mean()) for j, T in enumerate(res.torque)}


@pytest.mark.parametrize("torque", [60.0, 120.0, 240.0])
def test_map_tangent_matches_the_ltca_tangent(fe_rig, fe_tangent, torque):
    assert fe_rig.mesh_stiffness(torque) == pytest.approx(fe_tangent[torque], rel=0.015)
    assert fe_rig.mesh_stiffness(torque) > 1.03 * fe_rig.excitation.mean_stiffness(torque)  # stiffer than the secant


@pytest.mark.parametrize("torque", [60.0, 240.0])
def test_mesh_mode_follows_the_tangent_stiffness(fe_rig, fe_tangent, torque):
    from gearrom.rom.modal import modal_analysis

    res = modal_analysis(fe_rig, 0.0, torque, fmax=20e3, damping=False)
    i = int(np.argmax(res.mesh_share))
    M, K, _, _ = fe_rig.structure
    kt = fe_tangent[torque]
    lam = scipy.linalg.eigh(K + kt * np.outer(fe_rig.w, fe_rig.w), M, eigvals_only=True)
    f_ref = np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)
    assert res.freqs[i] == pytest.approx(f_ref[np.argmin(abs(f_ref - res.freqs[i]))], rel=0.01)


def test_contact_loss_and_back_flank_with_the_load_dependent_law(fe_rig):
    """A 150 um kinematic error at the mesh frequency at 4000 rpm and 30 N m: the flanks separate
    (force 0) and the back flanks touch (force < 0)."""
    from gearrom.rom.mesh import Effects, ExtraTE
    from gearrom.rom.simulate import mesh_law, simulate_run

    z1 = fe_rig.pair.z[0]
    eff = Effects(extra=(ExtraTE(lambda a, b: 150e-6 * np.sin(z1 * a)),))
    assert mesh_law(fe_rig, 30.0, eff).load_dependent
    run = simulate_run(fe_rig, 4000.0, 30.0, effects=eff, n_output_revs=0.5)
    assert run.contact_loss
    assert np.any(run.contact_state == 0) and np.all(run.force[run.contact_state == 0] <= 1e-9)
    assert np.any(run.force < 0)


@pytest.mark.skipif(not __import__("os").path.exists("/proc/self/statm"), reason="reads /proc/self/statm (Linux)")
def test_runs_release_their_memory():
    """Repeated runs (a tolerance study makes thousands) keep the process size flat: the exudyn system
    of a run is freed when it returns (its pre-step closure would otherwise keep it alive)."""
    import gc
    import os

    from gearrom.rom.rig import build_rig
    from gearrom.rom.simulate import simulate_run

    def rss_MB() -> float:  # the current resident size (not the peak, which earlier tests may have set)
        gc.collect()
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20

    model = build_rig("thesis-spur")
    for _ in range(3):
        simulate_run(model, 3000.0, n_output_revs=0.5)
    before = rss_MB()
    for _ in range(20):
        simulate_run(model, 3000.0, n_output_revs=0.5)
    grown_MB = rss_MB() - before
    assert grown_MB < 5.0  # a kept system costs ~0.7 MB per run: 14 MB over these 20 runs
