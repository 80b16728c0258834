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
    e_of = lambda f: fm.e[0] + (fm.e[3] - fm.e[0]) * (f / F[2]) ** (2 / 3)  # noqa: E731
    np.testing.assert_allclose(fm.tangent(F[2]), (F[3] - F[1]) / (e_of(F[3]) - e_of(F[1])), rtol=1e-9)
    # the analytic derivative dF/d(delta) = 1.5 F / (delta - e_kin) at 120 N m: the chord is within 6 %
    exact = 1.5 * F[2] / (fm.e[3] - fm.e[0])
    np.testing.assert_allclose(fm.tangent(F[2]), exact, rtol=0.06)


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
