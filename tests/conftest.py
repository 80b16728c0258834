"""Shared fixtures."""
from __future__ import annotations

import warnings

import pytest

from gearrom.config import load_config


def pytest_configure(config):
    """One BLAS thread per test process: the suite runs one xdist worker per core, and a second BLAS
    thread per worker only waits for a core the other worker holds."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")


@pytest.fixture(scope="session")
def spur():
    return load_config("thesis-spur")


@pytest.fixture(scope="session")
def helical():
    # the nominal drawing data is marginal (tip chamfer not modelled): it warns, see docs/config.md
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config("thesis-helical")


#: coarse 2D mesh of the spur rig with FE excitation (~0.5 s per gear): the ``[fe]`` section of
#: :func:`spur_fe_rig_config` gives the same settings
SPUR_FE_MESH_MM = {"flank_size_mm": 0.12, "tooth_size_mm": 1.35, "body_size_mm": 9.0}


@pytest.fixture(scope="session")
def spur_fe_rig_config(tmp_path_factory):
    """A TOML path: thesis-spur on the default rig with ``[rom] excitation = "fe"`` on a coarse mesh
    (32 positions per mesh period)."""
    path = tmp_path_factory.mktemp("spur_fe_rig") / "spur-rig-fe.toml"
    fe = "\n".join(f"{k} = {v}" for k, v in SPUR_FE_MESH_MM.items())
    path.write_text(f'extends = "thesis-spur"\nname = "spur-rig-fe"\n[rom]\nexcitation = "fe"\n[fe]\n{fe}\npositions = 32\n')
    return path


@pytest.fixture(scope="session")
def spur_fe_mesh():
    """The :class:`~gearrom.fe.mesh2d.MeshSettings` of :func:`spur_fe_rig_config`."""
    from gearrom.fe.mesh2d import MeshSettings

    return MeshSettings(**{k[:-3]: v * 1e-3 for k, v in SPUR_FE_MESH_MM.items()})
