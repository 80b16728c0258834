"""3D (Hex8) helical gear pair of the explicit solver (gearrom.fe.explicit.helicalpair).

References: the helix geometry (a transverse section at axial position z is turned by
z tan(beta) / r, r the pitch radius: the definition of the helix angle, not the code's twist());
the polar inertia of the full gear (sector model + the reference's added inertia must equal it);
the rigid-body start (no contact energy at t = 0: no initial overclosure anywhere across the face).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from gearrom.errors import ConfigError
from gearrom.fe.explicit.gearpair import GearPairSetup
from gearrom.fe.explicit.helicalpair import helical_meshes, helical_pair_model


@pytest.fixture(scope="module")
def helical():
    from gearrom.config import load_config

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config("thesis-helical").pair


@pytest.fixture(scope="module")
def coarse_meshes(helical):
    return helical_meshes(helical, 0.5e-3, 3e-3, 1e-3)


@pytest.fixture(scope="module")
def pair_model(helical, coarse_meshes):
    """``pair_model(n_layers, **kw)``: ``helical_pair_model`` of the coarse meshes with the default set-up, built
    once per argument set and shared by the tests (which read the model and its info, never change them)."""
    built = {}

    def build(n_layers, **kw):
        key = (n_layers, tuple(sorted(kw.items())))
        if key not in built:
            built[key] = helical_pair_model(helical, coarse_meshes, GearPairSetup(), n_layers, **kw)
        return built[key]

    return build


def test_layers_follow_the_helix(helical, pair_model):
    """Every layer of the input gear is the mid-face section turned by z tan(beta) / r1 (right hand: ccw)."""
    n_layers = 4
    model, info = pair_model(n_layers)
    x = np.asarray(model.nodes)
    off = info["n_gear1_2d"]                            # input nodes: layer by layer, first in the model
    mid = x[2 * off:3 * off]                            # layer 2 of 4 is z = 0
    r1 = 0.5 * helical.d[0]
    for k in range(n_layers + 1):
        lay = x[k * off:(k + 1) * off]
        z = lay[0, 2]
        a = z * math.tan(helical.beta) / r1
        c, s = math.cos(a), math.sin(a)
        rot = np.column_stack([c * mid[:, 0] - s * mid[:, 1], s * mid[:, 0] + c * mid[:, 1]])
        assert np.allclose(lay[:, :2], rot, atol=1e-9)
        assert np.allclose(lay[:, 2], z)
    assert info["layer_m"] == pytest.approx(min(g.face_width for g in helical.gears) / n_layers)


def test_sector_keeps_the_full_gear_inertia(helical, pair_model):
    """Sector model: lumped polar inertia of the kept elements + the reference's added inertia = full gear's."""
    from gearrom.fe.explicit.driver import prepare

    full, _ = pair_model(2)
    sec, info = pair_model(2, run_angle=0.5)
    assert sec.elements.shape[0] < 0.7 * full.elements.shape[0]
    centers = (np.zeros(2), np.array([helical.aw, 0.0]))

    def inertia(model):
        d = prepare(model)
        x = np.asarray(model.nodes)
        out = []
        for g, ref in enumerate(model.references):
            gear_nodes = np.unique(np.asarray(model.elements)[np.isin(np.asarray(model.elements),
                                                                       model.node_sets[ref.nodes]).any(axis=1)])
            # all nodes connected to this gear: flood over elements from the bore
            conn = np.asarray(model.elements)
            mask = np.zeros(len(x), bool)
            mask[gear_nodes] = True
            for _ in range(200):
                e = mask[conn].any(axis=1)
                new = np.zeros(len(x), bool)
                new[np.unique(conn[e])] = True
                if (new == mask).all():
                    break
                mask = new
            r2 = np.sum((x[mask, :2] - centers[g]) ** 2, axis=1)
            out.append(float(np.sum(d["mass"][mask] * r2)) + ref.inertia)
        return out

    j_full, j_sec = inertia(full), inertia(sec)
    assert info["removed_inertia_kgm2"][0] > 0 and info["removed_inertia_kgm2"][1] > 0
    for a, b in zip(j_full, j_sec):
        assert b == pytest.approx(a, rel=0.01)


def test_rejects_spur_pair_and_bad_layers(helical, coarse_meshes):
    from gearrom.config import load_config

    spur = load_config("thesis-spur").pair
    with pytest.raises(ConfigError, match="helical"):
        helical_pair_model(spur, coarse_meshes, GearPairSetup(), 4)
    with pytest.raises(ConfigError, match="n_layers"):
        helical_pair_model(helical, coarse_meshes, GearPairSetup(), 0)


def test_no_initial_overclosure_across_the_face(pair_model):
    """The start position keeps the clearance everywhere: the 3D contact kernel finds no penetrating node at t = 0.

    (Seed pair: negative tip-root clearance and a tip-fillet interference below the root form circles;
    the contact sets stop at the root form circle, as the quasi-static LTCA's flanks do.)
    """
    from gearrom.fe.explicit.contact import contact_forces_3d, contact_search
    from gearrom.fe.explicit.driver import prepare

    model, info = pair_model(4, run_angle=0.05)
    d = prepare(model, 0.9, 32)
    x = np.array(model.nodes)
    contact_search(x, d["slaves"], d["s_pair"], d["segs"], d["g_pair"], d["g_rad"], d["margin"] + d["p_depth"].max(),
                   d["head"], d["nxt"], d["cand"], d["ncand"], d["cell_h"])
    assert d["ncand"].sum() > 0                      # the flanks are within reach of each other
    f = np.zeros_like(x)
    energy, _ = contact_forces_3d(x, np.zeros_like(x), d["slaves"], d["s_pair"], d["segs"], d["g_k"], d["g_rad"], d["cand"],
                                  d["ncand"], d["p_mu"], d["p_vreg"], d["p_depth"], f, d["gap"], d["seg_open"],
                                  d["seg_sag"])
    assert energy == 0.0 and np.all(d["gap"] >= 0)
    assert min(info["layer_slack_m"]) > -1e-3         # every layer's rigid touch was bracketed and found


def test_coarse_run_energy_balance(helical, coarse_meshes):
    """A short coarse run at 2000 rpm under the torque ramp: the energy balance closes (reference: energy
    conservation of the undamped central-difference scheme; the error is the unaccounted energy) within 5 %
    of the external work, and the output lags the input (TE > 0 once loaded). Until the open-edge rule of
    the 3D contact this run ended with a balance error of ~800 times the external work."""
    from gearrom.fe.explicit.helicalpair import run_helical_pair

    setup = GearPairSetup(rpm_in=2000.0, torque_out=120.0, torque_ramp_time=0.15e-3, penalty_scale=0.1,
                          hourglass_stiffness=0.1, mass_scaling_dt=3e-8)
    res, te, _ = run_helical_pair(helical, coarse_meshes, setup, t_end=0.2e-3, sample_period=5e-6, n_layers=4,
                                  parallel=False)
    work = np.max(np.abs(res.energies[:, 8]))
    assert np.max(np.abs(res.energies[:, 9])) < 0.05 * work
    assert te[-1] > 0
    assert np.max(res.energies[:, 4]) > 0          # the flanks did carry load through the contact


def test_start_gap_is_the_clearance_as_the_contact_sees_it(helical, pair_model):
    """The output is turned until the 3D contact's own smallest gap, on the transverse line of action
    (normal gap / cos(beta_b), the helix geometry), equals the set-up clearance. The rigid touch of the
    transverse sections alone is not that gap (points outside the contact sets, such as the mate's tip
    passing the root, or the outline polygons' own chords decide it), so the pair would start free or
    overclosed."""
    from gearrom.fe.explicit.helicalpair import contact_min_gap

    setup = GearPairSetup()
    model, info = pair_model(4, run_angle=0.05)
    g = contact_min_gap(model) / math.cos(helical.beta_b)
    assert g == pytest.approx(setup.clearance, abs=0.01e-6)
    # the section touch alone is not the contact's gap (here off by more than a um)
    assert abs(info["start_gap_loa_m"][0] - setup.clearance) > 1e-6


def test_staggered_layers(pair_model):
    """stagger=True: output planes at the input's mid-layers (plus the two end faces); valid Hex8 elements."""
    from gearrom.fe.explicit.geometry import element_geometry

    model, info = pair_model(2, stagger=True)
    b = info["width_m"]
    assert np.allclose(info["z_layers"][0], [-b / 2, 0.0, b / 2])
    assert np.allclose(info["z_layers"][1], [-b / 2, -b / 4, b / 4, b / 2])
    _, vol, _, _ = element_geometry(np.asarray(model.nodes), np.asarray(model.elements))
    assert np.all(vol > 0)


def test_every_slave_meets_the_mate_on_its_facets(helical, pair_model):
    """Involute geometry: a flank point at radius r of gear g meets the mate, on the transverse line of action,
    at the radius with roll length aw sin(alpha_wt) - sqrt(r^2 - rb_g^2). Every slave node's mate point must
    lie within the radii the mate's master facets cover (else it would load a facet-set edge)."""
    model, _ = pair_model(2)
    x = np.asarray(model.nodes)
    centres = (np.zeros(2), np.array([helical.aw, 0.0]))
    loa = helical.aw * math.sin(helical.alpha_wt)
    rb = helical.rb
    for g, (slave, master) in enumerate((("flank_1", "outline_2"), ("flank_2", "outline_1"))):
        r_s = np.hypot(*(x[model.node_sets[slave], :2] - centres[g]).T)
        r_m = np.hypot(*(x[np.unique(model.surfaces[master]), :2] - centres[1 - g]).T)
        mate = np.hypot(rb[1 - g], loa - np.sqrt(r_s ** 2 - rb[g] ** 2))
        assert mate.min() >= r_m.min() - 2e-6 and mate.max() <= r_m.max() + 2e-6
        assert r_s.min() >= 0.5 * helical.dff[g] - 2e-6            # no slave in the fillet


def test_model_settings_follow_the_setup(helical, coarse_meshes):
    """The set-up's model-wide settings (damping, integration, hourglass control, mass scaling) reach the 3D
    model unchanged (a dropped relative damping leaves the reference runs undamped)."""
    setup = GearPairSetup(mass_damping=30.0, relative_damping=2e4, integration="full", hourglass_stiffness=0.07,
                          hourglass_viscosity=0.02, mass_scaling_dt=3e-8)
    m3, _ = helical_pair_model(helical, coarse_meshes, setup, 2)
    for field in ("mass_damping", "relative_damping", "integration", "hourglass_stiffness", "hourglass_viscosity",
                  "mass_scaling_dt"):
        assert getattr(m3, field) == getattr(setup, field), field


def test_loaded_start_energy_balance_gate(helical, coarse_meshes):
    """From the loaded static state at 2000 rpm (whole bodies, penalty 0.1), contact nodes slide past the
    cut ends of the flank sets under load: the energy balance stays within the validation gate, 1 % of the
    peak strain + contact energy (reference: energy conservation of the undamped central-difference scheme;
    a contact energy cut off at the end of the open-edge reach instead of faded misses it several times)."""
    from gearrom.fe.explicit.helicalpair import run_helical_pair

    setup = GearPairSetup(rpm_in=2000.0, torque_out=120.0, penalty_scale=0.1, integration="full",
                          mass_scaling_dt=5e-8, start="loaded")
    res, te, info = run_helical_pair(helical, coarse_meshes, setup, t_end=0.1e-3, sample_period=5e-6, n_layers=4,
                                     sector=False, parallel=False)
    stored = np.max(res.energies[:, 1] + res.energies[:, 4])
    assert np.max(np.abs(res.energies[:, 9])) < 0.01 * stored
    assert te[0] == pytest.approx(info["loaded_te_m"], rel=1e-3)     # started loaded, not from a gap
