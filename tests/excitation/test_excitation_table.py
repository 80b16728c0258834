"""MeshExcitation: interpolation, harmonics, round trip, validation."""
import math

import numpy as np
import pytest

from gearrom.errors import ModelError
from gearrom.excitation.table import MeshExcitation


def _table(n=64, z1=20):
    theta = np.arange(n) * 2 * math.pi / z1 / n
    ph = z1 * theta
    torque = np.array([50.0, 150.0])
    k = np.array([1e8 * (1 + 0.1 * np.cos(ph)), 2e8 * (1 + 0.1 * np.cos(ph))])
    e = np.array([1e-6 * np.sin(2 * ph), 3e-6 * np.sin(2 * ph)])
    share = np.ones((2, n, 1))
    return MeshExcitation(z1=z1, theta=theta, torque=torque, k=k, e=e, load_share=share,
                          definition="secant test", metadata={"source": "test"})


def test_fourier_interpolation_exact_for_band_limited_data():
    # trigonometric interpolation reproduces a band-limited periodic function exactly (sampling theorem)
    ex = _table()
    th = np.linspace(-1.0, 3.0, 101)
    np.testing.assert_allclose(ex.stiffness(th, 50.0), 1e8 * (1 + 0.1 * np.cos(20 * th)), rtol=1e-12)
    # linear in torque: halfway between 50 and 150 N m
    np.testing.assert_allclose(ex.ste(th, 100.0), 2e-6 * np.sin(40 * th), atol=1e-18)
    h = ex.harmonics(150.0, 3)
    np.testing.assert_allclose(abs(h.stiffness), [2e8, 2e7, 0, 0], atol=1e-3)
    np.testing.assert_allclose(abs(h.ste), [0, 0, 3e-6, 0], atol=1e-18)


def test_round_trip(tmp_path):
    ex = _table()
    p = ex.save(tmp_path / "ex.nc")
    ex2 = MeshExcitation.load(p)
    np.testing.assert_array_equal(ex2.k, ex.k)
    np.testing.assert_array_equal(ex2.e, ex.e)
    assert ex2.definition == ex.definition and ex2.metadata == ex.metadata and ex2.z1 == ex.z1


def test_outside_torque_range_warns_and_clamps():
    ex = _table()
    with pytest.warns(UserWarning, match="outside the excitation table"):
        v = ex.stiffness(0.0, 500.0)
    assert v == pytest.approx(2e8 * 1.1)


def test_validation_names_field():
    ex = _table()
    with pytest.raises(ModelError, match="theta"):
        MeshExcitation(z1=20, theta=ex.theta * 1.1, torque=ex.torque, k=ex.k, e=ex.e, load_share=ex.load_share,
                       definition="x")
    with pytest.raises(ModelError, match="k has shape"):
        MeshExcitation(z1=20, theta=ex.theta, torque=ex.torque, k=ex.k[:1], e=ex.e, load_share=ex.load_share,
                       definition="x")
    with pytest.raises(ModelError, match="definition"):
        MeshExcitation(z1=20, theta=ex.theta, torque=ex.torque, k=ex.k, e=ex.e, load_share=ex.load_share,
                       definition="")


def test_load_rejects_foreign_file(tmp_path):
    import xarray as xr

    from gearrom.excitation.table import netcdf_engine

    p = tmp_path / "other.nc"
    xr.Dataset({"a": ("x", [1.0])}).to_netcdf(p, engine=netcdf_engine())
    with pytest.raises(ModelError, match="not a gearrom MeshExcitation"):
        MeshExcitation.load(p)
