"""The analytical thin-slice model (:class:`gearrom.excitation.slices.SliceMicroModel`) takes the flank
modifications along the transverse line of action, as ISO 1328-1 measures profile and helix deviations
and as the FE models do (:mod:`gearrom.fe.flankgaps`).

References (closed forms, helical pair of the rig, beta_b = 30.4 deg, eps_alpha = 2.05): the unloaded TE
of a helix slope is the least removal over the slices in contact; under a load that keeps every slice
in contact the slices are parallel linear springs, so the TE change is the stiffness-weighted mean of the
removal. Taking the values along the flank normal (transverse = normal / cos(beta_b)) would scale every
change by 1 / cos(beta_b) = 1.16, far outside the tolerances.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.excitation.slices import MicroMods, SliceMicroModel

UM = 1e-6


@pytest.fixture(scope="module")
def pair():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config("thesis-helical").pair


@pytest.mark.parametrize("f_h", [20 * UM, -20 * UM])
def test_helix_slope_unloaded_shift_is_half_the_transverse_slope(pair, f_h):
    """Unloaded TE shift of a helix slope = -|f_Hbeta| / 2 (1 - 1/n), on the transverse line of action.

    Reference (closed form): the removal ``f_Hbeta (y/b - 1/2)`` is linear over the face. With
    eps_alpha > 1 every face section has a pair in contact at every angle, so the unloaded pair turns
    until the section of least removal touches; the model samples the face at the slice centres
    ``y_k = (k + 1/2) b / n``, the outermost ``b / (2 n)`` inside the face end, hence
    ``-|f_Hbeta| / 2 (1 - 1/n)`` at every angle. The load (1e-6 N m) deflects the touching slice by
    picometres (tolerance 0.1 nm).
    """
    model = SliceMicroModel(n_theta=16, n_slices=32)
    n = model.n_slices
    ref = -0.5 * abs(f_h) * (1 - 1 / n)
    e0 = model.excitation(pair, [1e-6], MicroMods()).e[0]
    e = model.excitation(pair, [1e-6], MicroMods(helix_slope=f_h)).e[0]
    np.testing.assert_allclose(e - e0, ref, atol=1e-10)
    assert abs(ref / math.cos(pair.beta_b) - ref) > 1 * UM  # the normal reading is far outside the tolerance


def _tip_relief_removal(pair, model, theta, c_a, d_ca):
    """Removal [m] of a linear tip relief ``c_a`` of the input gear starting at diameter ``d_ca``, on the
    slice grid of ``model`` (shape (n_theta, n_pairs, n_slices)): ``c_a`` times the fraction of the roll
    length from d_Ca to the tip, zero below d_Ca (the drawing's definition, linear in roll length)."""
    n_pairs = int(math.ceil(pair.eps_alpha + pair.eps_beta)) + 1
    y = (np.arange(model.n_slices) + 0.5) * pair.face_width / model.n_slices
    s = pair.rb[0] * theta[:, None, None] + pair.pb_t * np.arange(n_pairs)[None, :, None] - y * math.tan(pair.beta_b)
    roll = pair.roll_start_active[0] + s  # input-gear roll length of each slice's contact point
    roll_ca = math.sqrt((d_ca / 2) ** 2 - pair.rb[0] ** 2)
    return c_a * np.clip((roll - roll_ca) / (pair.roll_tip[0] - roll_ca), 0.0, None)


@pytest.mark.parametrize("what", ["lead_crowning", "helix_slope", "tip_relief"])
def test_loaded_shift_is_the_stiffness_weighted_transverse_removal(pair, what):
    """Under a load that keeps every slice in contact the TE change is sum(k h) / sum(k), h transverse.

    Reference (statics of parallel linear springs): with every slice of every pair in contact,
    ``sum_i k_i (delta - h_i) = F`` gives ``delta = (F + sum k_i h_i) / sum k_i``, so the TE change from
    the perfect pair at the same angle is ``sum k_i h_i / sum k_i``, with the slice stiffnesses of the
    perfect pair (the modifications change only the gaps) and the removals ``h`` written here from the
    drawing definitions, as transverse values: lead crowning C_b (2 y/b - 1)^2 of the pair, helix slope
    f_Hbeta (y/b - 1/2), linear tip relief of the input gear (drawing C_a = 8 um from d_Ca = 59.37 mm).
    120 N m keeps every slice loaded (checked). Agreement to rounding (rel 1e-9).

    For the crowning, the mean over a mesh period is also the mean removal over the slice centres,
    C_b (1 - 1/n^2) / 3 (every slice passes through the same mesh phases, and the total stiffness of a
    helical pair with eps_beta near 2 hardly varies over the period, which enters the mean only at second
    order: rel 1e-3), the closed form the FE slice LTCA is checked against in tests/fe/test_fe_helical.py.
    """
    model = SliceMicroModel(n_theta=32, n_slices=32)
    n, b = model.n_slices, pair.face_width
    y = (np.arange(n) + 0.5) * b / n
    theta, k, _ = model.slices(pair, MicroMods())
    if what == "lead_crowning":
        mods, h = MicroMods(lead_crowning=8 * UM), np.broadcast_to(8 * UM * (2 * y / b - 1) ** 2, k.shape)
    elif what == "helix_slope":
        mods, h = MicroMods(helix_slope=11 * UM), np.broadcast_to(11 * UM * (y / b - 0.5), k.shape)
    else:
        mods = MicroMods(tip_relief=(8 * UM, 0.0), tip_relief_start_diameter=(59.37e-3, None))
        h = _tip_relief_removal(pair, model, theta, 8 * UM, 59.37e-3)
    e0 = model.excitation(pair, [120.0], MicroMods()).e[0]
    e = model.excitation(pair, [120.0], mods).e[0]
    on = k > 0
    for i in range(theta.size):  # every slice in contact: the deflection exceeds every gap
        assert np.all(e[i] > h[i][on[i]])
    ref = (k * h).sum(axis=(1, 2)) / k.sum(axis=(1, 2))
    np.testing.assert_allclose(e - e0, ref, rtol=1e-9, atol=1e-15)
    if what == "lead_crowning":
        assert np.mean(e - e0) == pytest.approx(8 * UM * (1 - 1 / n**2) / 3, rel=1e-3)
