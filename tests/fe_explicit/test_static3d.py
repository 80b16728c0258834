"""Direct static solves of the 3D explicit model (gearrom.fe.explicit.static3d).

References: the patch test of linear elasticity (a linear displacement field gives a uniform stress:
no force on interior nodes, the face resultant is sigma A, E = mu (3 lam + 2 mu) / (lam + mu)); the
explicit kernel's own internal force (:func:`gearrom.fe.explicit.kernels.hex8_full_element`) at small
displacements, a second code for the same element; two contact springs solved by hand; and the explicit
model's dynamic relaxation of the same coarse helical model (the explicit solver with mass damping), a second
method for the same equilibrium (slow: the full-size comparison is in validation/static_gate_helical_*.json).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from gearrom.errors import SolverError
from gearrom.fe.explicit.static3d import hex8_stiffness, solve_contact_lcp

LAM, MU = 121.15e9, 80.77e9


def _box(nx=3, ny=2, nz=2, L=(3e-3, 2e-3, 1e-3), jitter=0.15, seed=1):
    """A Hex8 box mesh (VTK node order) with interior nodes displaced at random."""
    xs = [np.linspace(0, L[d], n + 1) for d, n in enumerate((nx, ny, nz))]
    X = np.array(np.meshgrid(*xs, indexing="ij")).reshape(3, -1).T
    idx = np.arange(X.shape[0]).reshape(nx + 1, ny + 1, nz + 1)
    inner = np.ones(idx.shape, bool)
    inner[[0, -1], :, :] = inner[:, [0, -1], :] = inner[:, :, [0, -1]] = False
    rng = np.random.default_rng(seed)
    h = np.array([L[0] / nx, L[1] / ny, L[2] / nz])
    X[idx[inner]] += jitter * h * rng.uniform(-1, 1, (int(inner.sum()), 3))
    hexes = []
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                hexes.append([idx[i, j, k], idx[i + 1, j, k], idx[i + 1, j + 1, k], idx[i, j + 1, k],
                              idx[i, j, k + 1], idx[i + 1, j, k + 1], idx[i + 1, j + 1, k + 1], idx[i, j + 1, k + 1]])
    return X, np.array(hexes), idx, inner


def test_patch_test_uniaxial_stress():
    """u = (eps x, -nu eps y, -nu eps z) on a distorted mesh: interior forces vanish, the end-face resultant
    is E eps A (exact for Hex8: linear fields are in its space)."""
    X, hexes, idx, inner = _box()
    K = hex8_stiffness(X, hexes, LAM, MU)
    E = MU * (3 * LAM + 2 * MU) / (LAM + MU)
    nu = LAM / (2 * (LAM + MU))
    eps = 1e-4
    u = np.column_stack([eps * X[:, 0], -nu * eps * X[:, 1], -nu * eps * X[:, 2]])
    f = (K @ u.ravel()).reshape(-1, 3)
    scale = E * eps * 2e-3 * 1e-3
    assert np.abs(f[idx[inner]]).max() < 1e-9 * scale
    end = idx[-1].ravel()
    assert f[end, 0].sum() == pytest.approx(scale, rel=1e-9)
    # an infinitesimal rigid rotation about z loads nothing
    rot = np.column_stack([-X[:, 1], X[:, 0], np.zeros(len(X))]) * 1e-6
    assert np.abs(K @ rot.ravel()).max() < 1e-9 * scale


def test_stiffness_is_the_explicit_kernels_tangent():
    """K u equals minus the explicit kernel's internal force for a small random u (its tangent at zero)."""
    from gearrom.fe.explicit.geometry import full_integration_data
    from gearrom.fe.explicit.kernels import hex8_full_element

    X, hexes, _, _ = _box(2, 2, 1, jitter=0.2, seed=3)
    u = np.random.default_rng(4).standard_normal(X.shape) * 1e-10
    Bg, Wg = full_integration_data(X, hexes)
    f = np.zeros_like(X)
    own, identity = np.arange(hexes.shape[0]), np.tile([1.0, 0.0], (hexes.shape[0], 1))
    for e in range(hexes.shape[0]):
        hex8_full_element(e, hexes, u, Bg, Wg, own, identity, LAM, MU, f)
    Ku = (hex8_stiffness(X, hexes, LAM, MU) @ u.ravel()).reshape(-1, 3)
    assert np.allclose(Ku, -f, rtol=1e-5, atol=1e-6 * np.abs(f).max())


def test_contact_lcp_two_springs():
    """Two contacts of compliance c each, closure a = 1, gaps 0 and g: below the load c M = g only the first
    carries (phi = c M); above, both share: phi = (2 c M... by hand) f1 + f2 = M, c f1 = phi = g + c f2."""
    c, g = 1e-8, 2e-6
    C = np.diag([c, c])
    a = np.ones(2)
    f, phi = solve_contact_lcp(C, a, np.array([0.0, g]), 100.0, np.zeros(2))
    assert f == pytest.approx([100.0, 0.0]) and phi == pytest.approx(c * 100.0)
    M = 1000.0   # c M = 10 um > g: both loaded
    f, phi = solve_contact_lcp(C, a, np.array([0.0, g]), M, np.zeros(2))
    f1 = (M + g / c) / 2
    assert f == pytest.approx([f1, M - f1]) and phi == pytest.approx(c * f1)
    # a penalty adds its compliance in series: one spring of c + 1/k
    f, phi = solve_contact_lcp(C, a, np.array([0.0, 1.0]), 100.0, np.array([c, c]))
    assert phi == pytest.approx(2 * c * 100.0)
    with pytest.raises(SolverError):
        solve_contact_lcp(np.eye(3), np.ones(3), np.zeros(3), 1.0, np.zeros(3), max_iter=0)


@pytest.fixture(scope="module")
def coarse_helical():
    from gearrom.config import load_config
    from gearrom.fe.explicit.gearpair import GearPairSetup
    from gearrom.fe.explicit.helicalpair import helical_meshes, helical_pair_model

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pair = load_config("thesis-helical").pair
    meshes = helical_meshes(pair, 0.5e-3, 3e-3, 1e-3)
    setup = GearPairSetup(rpm_in=1e-4, torque_out=120.0, penalty_scale=0.1, integration="full")
    model, info = helical_pair_model(pair, meshes, setup, 2, run_angle=0.0)
    return pair, model, info


def test_unloaded_contact_is_the_start_clearance(coarse_helical):
    """At a vanishing torque the static TE at the start position is zero: the model places the output so that
    the 3D contact's smallest gap on the line of action is the set-up clearance, and the TE convention
    removes it (``contact_min_gap``, a separate pass over the same contact). Under load the penalty's
    compliance adds to the TE: hard contact < tenfold penalty < the model's penalty."""
    from gearrom.fe.explicit.static3d import static_te_3d

    pair, model, info = coarse_helical
    pts = static_te_3d(model, info, pair, [0.0], [1e-3, 120.0], [0.1, 1.0, math.inf])
    te = {(p.penalty_scale, p.torque): p.te for p in pts}
    # the placement converts the facet's normal gap to the line of action with cos(beta_b) (the faceted
    # normals tilt by a few per cent) and stops its turns within a few nm: 5 % of the 1 um clearance
    assert abs(te[(math.inf, 1e-3)]) < 0.05e-6
    assert te[(math.inf, 120.0)] < te[(1.0, 120.0)] < te[(0.1, 120.0)]
    assert 5e-6 < te[(math.inf, 120.0)] < 50e-6
    assert all(p.n_loaded > 0 for p in pts)


def test_loaded_state_is_an_equilibrium_of_the_explicit_model(coarse_helical):
    """The direct static state (contact geometry updated to the deformed positions), given to the explicit
    solver as its start (input held, full output torque, no ramp, at rest), stays put: over 0.1 ms the TE
    moves by less than 0.3 % of its static value and the kinetic energy stays below 1e-3 of the strain +
    contact energy. The linear solve on the rigid placement's contact geometry is off by more on this
    coarse model (9 mm layers): the geometry update is what makes it the explicit model's equilibrium."""
    import dataclasses

    from gearrom.fe.explicit.driver import prepare, solve
    from gearrom.fe.explicit.gearpair import GearPairSetup, loaded_model
    from gearrom.fe.explicit.static3d import StaticPair3D

    pair, model, info = coarse_helical
    u, theta, te0 = StaticPair3D(model, info, pair).loaded_state(120.0)
    setup = GearPairSetup(rpm_in=1e-4, torque_out=120.0, penalty_scale=0.1, integration="full")
    start = dataclasses.replace(loaded_model(model, info, setup, relaxed=(u, theta, 0.0)), mass_scaling_dt=5e-8)
    res = solve(start, 0.1e-3, 5e-6, parallel=False, prepared=prepare(start, 0.9, 32))
    te = pair.rb[0] * res.theta[:, 0] + pair.rb[1] * (res.theta[:, 1] - info["clearance_angle"])
    assert te[0] == pytest.approx(te0, rel=1e-6)
    assert np.max(np.abs(te - te0)) < 0.003 * te0
    from gearrom.fe.explicit.result import ENERGY_NAMES

    e = dict(zip(ENERGY_NAMES, res.energies.T))
    stored = e["internal"] + e["contact"]
    assert np.max(e["kinetic"]) < 1e-3 * np.max(stored)


@pytest.mark.slow
def test_direct_static_equals_dynamic_relaxation(coarse_helical):
    """The coarse helical sector model at its start position under 120 N m: the direct static TE (geometry
    updated) equals the explicit model's own dynamic relaxation (input held, torque ramped over 0.2 ms, mass damping 4e4 1/s
    the mesh mode overdamped, TE averaged over the last 0.5 ms of 3 ms) within 0.5 %, with the same penalty."""
    import dataclasses

    from gearrom.fe.explicit.driver import prepare, solve
    from gearrom.fe.explicit.static3d import StaticPair3D

    pair, model, info = coarse_helical
    r1, r2 = model.references
    relax = dataclasses.replace(
        model, references=(dataclasses.replace(r1, speed=0.0, ramp_time=0.0, theta0=0.0),
                           dataclasses.replace(r2, torque=120.0, torque_ramp_time=0.2e-3, omega0=0.0, theta0=0.0)),
        initial_velocity=None, mass_damping=4e4, mass_scaling_dt=5e-8)
    res = solve(relax, 3e-3, 5e-6, parallel=False, prepared=prepare(relax, 0.9, 32))
    te = pair.rb[0] * res.theta[:, 0] + pair.rb[1] * (res.theta[:, 1] - info["clearance_angle"])
    late = res.t > 2.5e-3
    assert np.ptp(te[late]) < 0.01 * te[late].mean()     # relaxed: the residual vibration is small
    _, _, te0 = StaticPair3D(model, info, pair).loaded_state(120.0)
    assert te0 == pytest.approx(te[late].mean(), rel=0.005)


def test_loaded_start_at_speed(coarse_helical):
    """``run_helical_pair(start="loaded")`` at 2000 rpm: the run starts at the direct static TE (the state's
    own value at t = 0) and the TE stays within 10 % of it over 0.1 ms (the coarse faceted mesh's own
    ripple; a gap start falls to zero first). The energy balance error stays below 0.5 % of the work the
    mesh transmits (output torque x its rotation): the faceted 3D contact is not exactly conservative
    when the flanks slide over facet creases under load, which on this coarse mesh costs about 0.2 % of
    the transmitted power."""
    from gearrom.fe.explicit.gearpair import GearPairSetup
    from gearrom.fe.explicit.helicalpair import helical_meshes, run_helical_pair
    from gearrom.fe.explicit.result import ENERGY_NAMES

    pair, _, _ = coarse_helical
    meshes = helical_meshes(pair, 0.5e-3, 3e-3, 1e-3)
    setup = GearPairSetup(rpm_in=2000.0, torque_out=120.0, penalty_scale=0.1, integration="full", start="loaded",
                          mass_scaling_dt=5e-8)
    res, te, info = run_helical_pair(pair, meshes, setup, t_end=0.1e-3, sample_period=5e-6, n_layers=2,
                                     parallel=False)
    assert te[0] == pytest.approx(info["loaded_te_m"], rel=1e-6)
    e = dict(zip(ENERGY_NAMES, res.energies.T))
    transmitted = 120.0 * abs(res.theta[-1, 1] - res.theta[0, 1])
    assert np.max(np.abs(e["balance_error"])) < 0.005 * transmitted
    assert np.max(np.abs(te - info["loaded_te_m"])) < 0.1 * info["loaded_te_m"]


def test_geometry_update_at_any_angle(coarse_helical):
    """:meth:`StaticPair3D.equilibrium` at the start position is :meth:`loaded_state`'s state; at another input
    angle the update moves the TE by the same order as at the start (the output's rotation turns the facets:
    a small correction, under 5 %), and ``static_te_3d(geometry_update=True)`` reports it."""
    from gearrom.fe.explicit.static3d import StaticPair3D, static_te_3d

    pair, model, info = coarse_helical
    sp3 = StaticPair3D(model, info, pair)
    _, theta0, te0 = sp3.loaded_state(120.0)
    _, phi, _, n_loaded = sp3.equilibrium(0.0, 120.0)
    assert phi == pytest.approx(theta0[1], rel=1e-12) and n_loaded > 0
    th = 0.3 * 2 * math.pi / pair.z[0]
    (lin,) = static_te_3d(model, info, pair, [th], [120.0])
    (upd,) = static_te_3d(model, info, pair, [th], [120.0], geometry_update=True)
    assert upd.te != lin.te
    assert abs(upd.te / lin.te - 1) < 0.05
