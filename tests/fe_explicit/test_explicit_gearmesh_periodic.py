"""Tooth-periodic Q4 gear mesh (``gear_quad_mesh(..., periodic=True)``).

References (geometry, no solver):
* rotational symmetry: a gear of z identical teeth meshed tooth by tooth is mapped onto itself by a
  rotation of one pitch 2 pi / z, nodes and elements alike (to round-off);
* one body: the sector copies share the nodes of their cuts, so the mesh is one connected part whose
  boundary is the outline and the bore only (no free edge along a cut);
* the same domain as the whole-gear mesh: equal areas within 0.5 %, the chord error of two coarse
  outline polygons (0.3 mm chords across tip roundings of a few tenths of a mm) placed differently; a
  sector missing or copied twice would change the area by 1 / z (2.4-3.1 %).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from gearrom.config import load_config
from gearrom.fe.explicit.gearmesh import closed_outline, gear_quad_mesh, project_onto
from gearrom.fe.explicit.model import boundary_segments
from gearrom.geometry.profile import rotate


def _area(xy, quads):
    p = xy[quads]
    return float(np.sum(0.5 * np.sum(p[:, :, 0] * np.roll(p[:, :, 1], -1, axis=1)
                                     - np.roll(p[:, :, 0], -1, axis=1) * p[:, :, 1], axis=1)))


@pytest.fixture(scope="module", params=[0, 1], ids=["pinion", "wheel"])
def meshes(request):
    pair = load_config("thesis-spur").pair
    i = request.param
    return pair, i, gear_quad_mesh(pair, i, 0.3e-3, 2e-3, periodic=True), gear_quad_mesh(pair, i, 0.3e-3, 2e-3)


def test_one_pitch_rotation_maps_the_mesh_onto_itself(meshes):
    pair, i, (xy, quads, bore), _ = meshes
    z = pair.gears[i].z
    d, image = cKDTree(xy).query(rotate(xy, -2 * math.pi / z))
    assert d.max() < 1e-12
    assert np.unique(image).size == xy.shape[0]
    assert set(map(tuple, np.sort(image[quads], axis=1))) == set(map(tuple, np.sort(quads, axis=1)))
    assert set(image[bore]) == set(bore)


def test_sector_copies_form_one_body_bounded_by_outline_and_bore(meshes):
    pair, i, (xy, quads, bore), _ = meshes
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    a = quads.ravel()
    b = np.roll(quads, -1, axis=1).ravel()
    n_parts, _ = connected_components(coo_matrix((np.ones(a.size), (a, b)), shape=(len(xy),) * 2), directed=False)
    assert n_parts == 1
    edge = np.unique(boundary_segments(quads))
    rb = 0.5 * pair.gears[i].bore_diameter
    on_bore = np.abs(np.hypot(*xy[edge].T) - rb) < 1e-9
    outline = closed_outline(pair, i, density=10)
    gap = np.hypot(*(project_onto(xy[edge[~on_bore]], outline) - xy[edge[~on_bore]]).T)
    assert gap.max() < 1e-9                                  # outline nodes on the profile, none on a cut
    assert set(edge[on_bore]) == set(bore)


def test_same_domain_as_the_whole_gear_mesh(meshes):
    _, _, (xy, quads, _), (xy2, quads2, _) = meshes
    assert _area(xy, quads) > 0
    assert _area(xy, quads) == pytest.approx(_area(xy2, quads2), rel=5e-3)
