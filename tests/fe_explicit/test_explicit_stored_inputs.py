"""Inputs of long, checkpointed explicit runs that must survive a move to another machine.

References (no solver figures):
* rotational symmetry of the tooth-periodic helical sections: each gear's transverse section, its outline
  projected onto the generated profile, is mapped onto itself by one pitch 2 pi / z (to round-off), as
  the spur sections are (``test_explicit_gearmesh_periodic.py``); the whole-gear section is not (control);
* stored meshes are read back bit for bit, and a store made from other settings is rebuilt, not used;
* a refused checkpoint names the model field that differs (here the relative damping), so that a user
  can tell a changed set-up from a changed model build.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from gearrom.config import load_config
from gearrom.errors import ConfigError
from gearrom.fe.explicit import ExplicitModel, Material, RigidReference, solve
from gearrom.fe.explicit.gearpair import stored_meshes
from gearrom.fe.explicit.helicalpair import helical_meshes
from gearrom.fe.explicit.meshes import annulus_q4
from gearrom.geometry.profile import rotate


@pytest.fixture(scope="module")
def helical():
    return load_config("thesis-helical").pair


def _pitch_mismatch(xy: np.ndarray, z: int) -> float:
    return float(cKDTree(xy).query(rotate(xy, -2 * math.pi / z))[0].max())


def test_periodic_helical_sections_repeat_every_tooth(helical):
    periodic = helical_meshes(helical, 0.5e-3, 3e-3, 1e-3, periodic=True)
    whole = helical_meshes(helical, 0.5e-3, 3e-3, 1e-3)
    for i, ((xy, quads, bore), (xw, _, _)) in enumerate(zip(periodic, whole)):
        z = helical.gears[i].z
        assert _pitch_mismatch(xy, z) < 1e-12
        assert _pitch_mismatch(xw, z) > 1e-7          # control: the whole-gear section differs per tooth
        image = cKDTree(xy).query(rotate(xy, -2 * math.pi / z))[1]
        assert set(map(tuple, np.sort(image[quads], axis=1))) == set(map(tuple, np.sort(quads, axis=1)))


def test_stored_meshes_are_read_back_and_rebuilt_for_other_settings(tmp_path):
    calls = []
    rng = np.random.default_rng(1)

    def build():
        calls.append(1)
        return [(rng.random((5, 2)), rng.integers(0, 5, (3, 4)), np.array([0, 1])) for _ in range(2)]

    path = tmp_path / "meshes.npz"
    first = stored_meshes(path, "a", build)
    again = stored_meshes(path, "a", build)
    assert len(calls) == 1
    for m0, m1 in zip(first, again):
        for x0, x1 in zip(m0, m1):
            assert x0.dtype == x1.dtype and np.array_equal(x0, x1)
    other = stored_meshes(path, "b", build)
    assert len(calls) == 2 and not np.array_equal(other[0][0], first[0][0])


def _ring(alpha: float) -> ExplicitModel:
    nodes, elements, inner, _ = annulus_q4(0.02, 0.04, 2, 24)
    return ExplicitModel(nodes, elements, Material(), thickness=0.01, node_sets={"bore": inner},
                         references=(RigidReference("bore", spring_k=1e3, omega0=5.0),), relative_damping=alpha)


def test_refused_checkpoint_names_the_differing_field(tmp_path):
    ck = tmp_path / "run.ckpt.npz"
    solve(_ring(10.0), 2e-4, sample_period=2e-5, chunks=4, checkpoint=ck)
    with pytest.raises(ConfigError, match=r"mismatch in: relative_damping\)"):
        solve(_ring(20.0), 2e-4, sample_period=2e-5, chunks=4, checkpoint=ck)
