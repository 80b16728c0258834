"""3D (Hex8) helical gear pair of the explicit solver (gearrom.fe.explicit.helical3d).

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
from gearrom.fe.explicit.helical3d import helical_meshes, helical_pair_model


@pytest.fixture(scope="module")
def helical():
    from gearrom.config import load_config

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config("thesis-helical").pair


@pytest.fixture(scope="module")
def coarse_meshes(helical):
    return helical_meshes(helical, 0.5e-3, 3e-3, 1e-3)


def test_layers_follow_the_helix(helical, coarse_meshes):
    """Every layer of the input gear is the mid-face section turned by z tan(beta) / r1 (right hand: ccw)."""
    n_layers = 4
    model, info = helical_pair_model(helical, coarse_meshes, GearPairSetup(), n_layers)
    x = np.asarray(model.nodes)
    n2d, off = info["n_nodes_2d"], info["n_gear1_2d"]
    mid = x[2 * n2d:2 * n2d + off]                      # layer 2 of 4 is z = 0
    r1 = 0.5 * helical.d[0]
    for k in range(n_layers + 1):
        lay = x[k * n2d:k * n2d + off]
        z = lay[0, 2]
        a = z * math.tan(helical.beta) / r1
        c, s = math.cos(a), math.sin(a)
        rot = np.column_stack([c * mid[:, 0] - s * mid[:, 1], s * mid[:, 0] + c * mid[:, 1]])
        assert np.allclose(lay[:, :2], rot, atol=1e-9)
        assert np.allclose(lay[:, 2], z)
    assert info["layer_m"] == pytest.approx(min(g.face_width for g in helical.gears) / n_layers)


def test_sector_keeps_the_full_gear_inertia(helical, coarse_meshes):
    """Sector model: lumped polar inertia of the kept elements + the reference's added inertia = full gear's."""
    from gearrom.fe.explicit.driver import prepare

    setup = GearPairSetup()
    full, _ = helical_pair_model(helical, coarse_meshes, setup, 2)
    sec, info = helical_pair_model(helical, coarse_meshes, setup, 2, run_angle=0.5)
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
