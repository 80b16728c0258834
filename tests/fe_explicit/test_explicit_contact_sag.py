"""3D contact on a faceted curved surface: the facets' sag restored from their neighbours.

Reference: the exact cylinder. A cylinder of radius R cut into N flat facets around its axis has its facet
corners on the cylinder and the facet centres R (1 - cos(pi / N)) inside it (the mid-chord sag); a slave
node at radius r has the true gap r - R. Flat facets see the node up to that sag farther out than it is;
with the sag restored the gap is the cylinder's to second order in the facet angle, and a node sliding around at a constant radius
keeps a constant penalty energy (potential theory: the contact force, the energy's gradient, has no
tangential part on the true surface).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearrom.fe.explicit.contact import contact_forces_3d, facet_sags, signed_gaps_3d
from gearrom.fe.explicit.driver import _open_edges

R = 10e-3         # cylinder radius, m
N = 48            # facets around (7.5 degrees apart, below the crease angle)
H = 2e-3          # axial length of a facet, m
K = 1e9           # penalty, N/m
DEPTH = 0.2e-3


def _cylinder(n_axial: int = 3):
    """Facets of a closed cylinder, outward normals, corners on the cylinder."""
    phi = 2 * math.pi * np.arange(N) / N
    zs = H * np.arange(n_axial + 1)
    nodes = np.array([[R * math.cos(p), R * math.sin(p), z] for z in zs for p in phi])
    segs = []
    for k in range(n_axial):
        for j in range(N):
            a, b = k * N + j, k * N + (j + 1) % N
            segs.append([a, b, b + N, a + N])      # xi around (counter-clockwise), eta along z: normal outward
    return nodes, np.array(segs, np.int64)


def _gap_and_force(nodes, segs, sag, p):
    x = np.vstack([nodes, p])
    n = len(nodes)
    g_rad = np.array([np.linalg.norm(x[s] - x[s].mean(axis=0), axis=1).max() for s in segs])
    seg_open = _open_edges(segs, np.zeros(len(segs), np.int64))
    cand = np.array([list(range(len(segs)))])
    f = np.zeros_like(x)
    gap = np.zeros(1)
    e, _ = contact_forces_3d(x, np.zeros_like(x), np.array([n]), np.array([0]), segs, np.full(len(segs), K), g_rad,
                             cand, np.array([len(segs)]), np.array([0.0]), np.array([1e-3]), np.array([DEPTH]), f,
                             gap, seg_open, sag)
    g = signed_gaps_3d(x, np.array([n]), segs, g_rad, cand, np.array([len(segs)]), seg_open, sag)[0]
    return g, f[n].copy(), e


def test_sag_of_a_faceted_cylinder():
    """Around: the chord sag of the circle, R (1 - cos(pi / N)), within its second-order error; along the
    straight generatrix: none."""
    nodes, segs = _cylinder()
    sag = facet_sags(nodes, segs, np.zeros(len(segs), np.int64))
    exact = R * (1 - math.cos(math.pi / N))
    np.testing.assert_allclose(sag[:, 0], exact, rtol=0.02)
    np.testing.assert_allclose(sag[:, 1], 0.0, atol=1e-6 * exact)


def test_sag_stops_at_a_crease():
    """Two flat plates meeting at 30 degrees: a crease, not a curved surface: no sag on either."""
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    nodes = np.array([[-H, 0, 0], [0, 0, 0], [0, H, 0], [-H, H, 0], [H * c, 0, -H * s], [H * c, H, -H * s]])
    segs = np.array([[0, 1, 2, 3], [1, 4, 5, 2]])
    np.testing.assert_array_equal(facet_sags(nodes, segs, np.zeros(2, np.int64)), 0.0)


@pytest.mark.parametrize("frac", [0.0, 0.3, 0.5, 0.8])
def test_gap_is_the_true_cylinder_gap(frac):
    """A node 2 um inside the cylinder, anywhere across a facet: the gap is -2 um to within 3 % of the sag
    (flat facets: off by up to the full sag R (1 - cos(pi / N)), 21 um here)."""
    nodes, segs = _cylinder()
    sag = facet_sags(nodes, segs, np.zeros(len(segs), np.int64))
    exact = R * (1 - math.cos(math.pi / N))
    phi = 2 * math.pi / N * (0.5 + 0.5 * frac)        # from the facet middle towards its corner
    p = np.array([(R - 2e-6) * math.cos(phi), (R - 2e-6) * math.sin(phi), 1.5 * H])
    g, f, e = _gap_and_force(nodes, segs, sag, p)
    assert g == pytest.approx(-2e-6, abs=0.03 * exact)
    g_flat, _, _ = _gap_and_force(nodes, segs, np.zeros_like(sag), p)
    assert g_flat - (-2e-6) > 0.3 * exact or frac > 0.7        # flat facets: the node looks farther out
    # the force on the slave points out along the cylinder's radius (the true surface normal)
    radial = np.array([math.cos(phi), math.sin(phi), 0.0])
    assert np.linalg.norm(f - (f @ radial) * radial) < 0.03 * np.linalg.norm(f)
    assert f @ radial > 0


def test_sliding_at_constant_radius_keeps_the_energy():
    """A node 3 um inside the cylinder slid over two facets at constant radius: the penalty energy stays
    within 3 % of K g^2 / 2 and the work of the contact force is minus its change (conservative); flat
    facets lose the node over most of each facet (their sag is seven times its depth here)."""
    nodes, segs = _cylinder()
    sag = facet_sags(nodes, segs, np.zeros(len(segs), np.int64))
    g0 = -3e-6
    phis = np.linspace(0.1, 2.1, 801) * 2 * math.pi / N
    pts = np.column_stack([(R + g0) * np.cos(phis), (R + g0) * np.sin(phis), np.full_like(phis, 1.5 * H)])
    res = [_gap_and_force(nodes, segs, sag, p) for p in pts]
    energy = np.array([r[2] for r in res])
    ref = 0.5 * K * g0 ** 2
    assert np.all(np.abs(energy / ref - 1) < 0.03)
    mid = 0.5 * (pts[1:] + pts[:-1])
    work = sum(float(_gap_and_force(nodes, segs, sag, m)[1] @ dp) for m, dp in zip(mid, np.diff(pts, axis=0)))
    assert work == pytest.approx(-(energy[-1] - energy[0]), abs=1e-3 * ref)


@pytest.mark.parametrize("dz_um", [-1.0, 0.3, 1.0, 2.0, 3.0])
def test_gap_across_a_shared_edge_near_the_facet_corner(dz_um):
    """A node 2 um inside the cylinder near a facet's corner line (0.9 of the way from the facet middle, where
    the bilinear facet lies 4 um inside the cylinder: the node is above the facet but inside the surface),
    just before and after the shared edge between two axial rows of facets: the gap stays the cylinder's and
    the force stays radial. The neighbour behind the edge sees the node in its border zone at a distance
    (dz^2 + 2 um^2)^0.5 less its sag: a smaller magnitude than the true gap for dz up to 3.5 um, which taken
    as the gap would point the force along the axis."""
    nodes, segs = _cylinder()
    sag = facet_sags(nodes, segs, np.zeros(len(segs), np.int64))
    exact = R * (1 - math.cos(math.pi / N))
    phi = 2 * math.pi / N * (0.5 + 0.5 * 0.9)
    p = np.array([(R - 2e-6) * math.cos(phi), (R - 2e-6) * math.sin(phi), H + dz_um * 1e-6])
    g, f, e = _gap_and_force(nodes, segs, sag, p)
    assert g == pytest.approx(-2e-6, abs=0.03 * exact)
    radial = np.array([math.cos(phi), math.sin(phi), 0.0])
    assert np.linalg.norm(f - (f @ radial) * radial) < 0.03 * np.linalg.norm(f)
