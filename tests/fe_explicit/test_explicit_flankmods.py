"""Drawing micro-geometry on the flanks of the explicit helical model (gearrom.fe.explicit.flankmods).

References:
* the drawing's modifications as ISO 21771 defines them, written out here on their own: linear tip
  relief C_a from the roll length at d_Ca to the tip, parabolic profile crowning C_H (zero in the middle
  of the active profile, C_H at both of its ends), parabolic lead crowning C_b (zero in the middle of the
  face width, C_b at both ends); values from the seed drawing (thesis-helical-drawing, annex 11.1 / 11.2);
* every loaded-flank node of the input gear (whose placement the modifications do not touch) moves by
  exactly that removal, into the material, along the transverse outline normal (perpendicular to the
  section's outline within the angle its facets turn by);
* every other node is where the perfect model has it, bit for bit.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from gearrom.fe.explicit.flankmods import flank_normals
from gearrom.fe.explicit.gearpair import GearPairSetup
from gearrom.fe.explicit.helicalpair import helical_meshes, helical_pair_model


def _pair(name):
    from gearrom.config import load_config

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config(name).pair


@pytest.fixture(scope="module")
def models():
    perfect, drawing = _pair("thesis-helical"), _pair("thesis-helical-drawing")
    meshes = helical_meshes(perfect, 0.5e-3, 3e-3, 1e-3, periodic=True)
    out = {}
    for name, pair in (("perfect", perfect), ("drawing", drawing)):
        out[name] = helical_pair_model(pair, meshes, GearPairSetup(), 4)
    return drawing, out


def _drawing_removal(pair, i, roll, z):
    """C_a, C_H and C_b of the drawing at roll length ``roll`` and axial position ``z`` (ISO 21771)."""
    m = pair.gears[i].micro
    rb = pair.rb[i]
    l_tip = math.sqrt((0.5 * pair.da[i]) ** 2 - rb ** 2)
    l_ca = math.sqrt((0.5 * m.tip_relief_start_diameter) ** 2 - rb ** 2)
    l_sap, l_eap = pair.roll_start_active[i], pair.roll_tip[i]
    tip = m.tip_relief * np.clip((roll - l_ca) / (l_tip - l_ca), 0.0, None)
    crown = m.profile_crowning * ((roll - 0.5 * (l_sap + l_eap)) / (0.5 * (l_eap - l_sap))) ** 2
    lead = m.lead_crowning * (2 * z / pair.face_width) ** 2
    return tip + crown + lead


def test_outward_normals_of_a_polygon_circle():
    a = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    xy = np.column_stack([np.cos(a), np.sin(a)]) * 0.03
    n = flank_normals(xy, np.arange(400))
    assert np.allclose(n, xy / 0.03, atol=1e-12)


def test_flank_nodes_move_by_the_drawing_removal(models):
    drawing, out = models
    (mp, ip), (md, idd) = out["perfect"], out["drawing"]
    n1 = ip["n_nodes_gear1"]
    xp, xd = np.asarray(mp.nodes)[:n1], np.asarray(md.nodes)[:n1]
    move = xd - xp
    moved = np.hypot(*move[:, :2].T) > 0
    assert moved.sum() > 100
    assert np.all(move[:, 2] == 0)
    assert np.array_equal(xd[~moved], xp[~moved])
    flank = np.asarray(md.node_sets["flank_1"])
    flank = flank[flank < n1]
    assert set(np.flatnonzero(moved)) >= set(flank[moved[flank]].tolist())
    r = np.hypot(*xp[moved, :2].T)
    roll = np.sqrt(r ** 2 - drawing.rb[0] ** 2)
    expected = _drawing_removal(drawing, 0, roll, xp[moved, 2])
    size = np.hypot(*move[moved, :2].T)
    assert np.allclose(size, expected, rtol=1e-9, atol=1e-12)
    assert expected.max() > 8e-6                         # the tip relief region is in the flank sets
    # into the material: the moved nodes come closer to the axis (the flank normal points outwards)
    assert np.all(np.hypot(*xd[moved, :2].T) < r)
    # nothing above the usable tip d_Na carries contact
    r_sets = np.hypot(*np.asarray(md.nodes)[flank, :2].T)
    assert r_sets.max() <= 0.5 * drawing.effective_tip_diameter[0] + 1e-6
