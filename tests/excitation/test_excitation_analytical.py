"""Analytical ISO 6336-1 shaped excitation against the ISO numbers of shared/notes/reference-values.md."""
import warnings

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.errors import ModelError
from gearrom.excitation.analytical import analytical_excitation, iso_mesh_stiffness, iso_single_stiffness


@pytest.fixture(scope="module")
def spur():
    return load_config("thesis-spur").pair


@pytest.fixture(scope="module")
def helical():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config("thesis-helical").pair


def test_iso_single_and_mesh_stiffness_spur(spur):
    # reference-values.md (ISO 6336-1 method B worked by hand): c' ~ 12.6, c_gamma ~ 20.6 N/(mm um)
    assert iso_single_stiffness(spur) / 1e9 == pytest.approx(12.6, abs=0.05)
    assert iso_mesh_stiffness(spur) / 1e9 == pytest.approx(20.6, abs=0.05)


def test_spur_table_mean_and_peak_match_iso(spur):
    ex = analytical_excitation(spur, [120.0], n_theta=512)
    b = spur.face_width
    # mean over the mesh cycle = c_gamma b (~370 N/um for b = 18 mm, reference-values.md)
    assert ex.mean_stiffness(120.0) / 1e6 == pytest.approx(370, rel=0.01)
    # single-pair zone mid-path reaches c' b (ISO's definition of c')
    assert ex.k.min() == pytest.approx(12.56e9 * b, rel=0.01)
    # STE = F/k with F = T/rb2 (statics)
    ft = 120.0 / spur.rb[1]
    np.testing.assert_allclose(ex.e[0] * ex.k[0], ft, rtol=1e-12)
    # load shares sum to one and stay within [0, 1]
    np.testing.assert_allclose(ex.load_share.sum(axis=2), 1.0, rtol=1e-12)
    assert ex.load_share.min() >= 0 and ex.load_share.max() <= 1


def test_spur_single_double_contact_durations(spur):
    # the fraction of the mesh period with 2 pairs in contact is eps_alpha - 1 (kinematics)
    ex = analytical_excitation(spur, [120.0], n_theta=2000)
    two = np.mean((ex.load_share[0] > 0).sum(axis=1) == 2)
    assert two == pytest.approx(spur.eps_alpha - 1.0, abs=2e-3)


def test_helical_nearly_constant_stiffness(helical):
    # eps_beta = 2.02 ~ integer: the contact-line length and so the stiffness are nearly constant
    ex = analytical_excitation(helical, [120.0])
    k = ex.k[0]
    assert np.ptp(k) / k.mean() < 0.02
    cg = iso_mesh_stiffness(helical) * helical.face_width
    assert k.mean() == pytest.approx(cg, rel=0.005)


def test_bad_inputs_raise(spur):
    with pytest.raises(ModelError, match="torques_Nm"):
        analytical_excitation(spur, [120.0, 60.0])
    with pytest.raises(ModelError, match="n_theta"):
        analytical_excitation(spur, [120.0], n_theta=4)
