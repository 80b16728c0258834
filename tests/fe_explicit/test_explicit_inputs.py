"""Input validation (clear errors naming the field), result save/load round trip and plot.

References: the error contract of gearrom.errors (messages name the field that is wrong); the
analytic stable step of a 1D bar element with lumped mass, dt = h / c (Courant), which the element
eigenvalue bound must reproduce for nu = 0 (no Poisson coupling) within 1 %.
"""
from __future__ import annotations

import numpy as np
import pytest

from gearrom.errors import ConfigError, MeshError
from gearrom.fe.explicit import (ContactPair, ExplicitModel, ExplicitResult, Material, RigidReference,
                                 solve, stable_dt)
from gearrom.fe.explicit.meshes import rectangle_q4


def _plate():
    return rectangle_q4(0.1, 0.01, 10, 2)


def test_bad_material_and_shapes():
    with pytest.raises(ConfigError, match="nu"):
        Material(nu=0.5)
    nodes, elements = _plate()
    with pytest.raises(MeshError, match="elements"):
        ExplicitModel(nodes, elements[:, :3])
    with pytest.raises(MeshError, match="outside"):
        ExplicitModel(nodes, elements + 1000)
    with pytest.raises(ConfigError, match="unknown node set 'bore'"):
        ExplicitModel(nodes, elements, references=(RigidReference("bore"),))
    with pytest.raises(ConfigError, match="unknown surface"):
        ExplicitModel(nodes, elements, node_sets={"s": [0]}, contacts=(ContactPair("s", "m"),))
    with pytest.raises(ConfigError, match="initial_velocity"):
        ExplicitModel(nodes, elements, initial_velocity=np.zeros((3, 2)))


def test_inverted_element_is_named():
    nodes, elements = _plate()
    bad = elements.copy()
    bad[3] = bad[3, ::-1]
    model = ExplicitModel(nodes, bad)
    with pytest.raises(MeshError, match="element 3"):
        stable_dt(model)


def test_dt_above_stable_step_rejected():
    nodes, elements = _plate()
    model = ExplicitModel(nodes, elements)
    with pytest.raises(ConfigError, match="stable step"):
        solve(model, 1e-5, dt=10 * stable_dt(model, safety=1.0))


def test_stable_step_matches_bar_courant_limit():
    mat = Material(nu=0.0)
    h = 0.01
    nodes, elements = rectangle_q4(1.0, h, 100, 1)
    model = ExplicitModel(nodes, elements, mat, hourglass_stiffness=0.0)
    # a 1-element-high strip: the axial (h/c) limit; transverse modes of a unit-aspect cell give the same
    assert abs(stable_dt(model, safety=1.0) / (h / np.sqrt(mat.E / mat.rho)) - 1) < 0.01


def test_result_roundtrip_and_plot(tmp_path):
    nodes, elements = _plate()
    v0 = np.zeros_like(nodes)
    v0[:, 1] = nodes[:, 0]
    model = ExplicitModel(nodes, elements, Material(), thickness=0.01, initial_velocity=v0,
                          node_sets={"left": np.nonzero(nodes[:, 0] == 0)[0]},
                          references=(RigidReference("left", torque=1.0),))
    res = solve(model, 2e-5, sample_period=1e-6, probes=[5])
    path = res.save(tmp_path / "run")
    back = ExplicitResult.load(path)
    np.testing.assert_array_equal(back.energies, res.energies)
    np.testing.assert_array_equal(back.probe_u, res.probe_u)
    assert back.meta["n_elements"] == elements.shape[0]
    fig = res.plot(tmp_path / "run.png")
    assert (tmp_path / "run.png").stat().st_size > 0
    assert len(fig.axes) == 2
    with pytest.raises(ConfigError, match="not found"):
        ExplicitResult.load(tmp_path / "missing")
