"""A 3D (Hex8) helical gear pair for the explicit solver, and its transmission error.

Mesh: the transverse-section Q4 mesh of each gear (:func:`gearrom.fe.explicit.gearmesh.gear_quad_mesh`,
the rack-generated transverse profile of the helical gear) is extruded over the common face width
``b = min(b1, b2)`` in ``n_layers`` equal layers, the section at axial position ``z`` (``z = 0`` at
mid-face, ``-b/2 .. b/2``) turned about the gear axis by the helix twist
:func:`gearrom.geometry.profile.twist` (counter-clockwise for a right hand). Between two layers the
flank is the bilinear (ruled) facet through the twisted nodes: its sag from the helicoid, normal to
the flank, is about ``r (dtwist)^2 / 8 sin(alpha_r)`` (reported as ``twist_sag_m``). The contact restores
that sag and the transverse chords' (:func:`gearrom.fe.explicit.contact.facet_sags`), so that it meets
the flank between the nodes, not the facets' chords.

Set-up: the mid-face section (``z = 0``) is placed exactly as the spur pair of
:mod:`gearrom.fe.explicit.gearpair` (same code: input tooth 0 on +x, output turned until its flank
touches, minus the clearance), so the start position, the drive-flank selection, the rigid bore
references (rotation about z only, translations and tilting fixed) and the TE definition are the
spur ones. The twist turns every section of the input by ``tw1(z)`` and of the output by
``tw2(z) = -tw1(z) z1 / z2``: a meshing-consistent rotation, so every section is the spur start
position at another mesh phase. The output is then turned so that the tightest section keeps the
clearance (no initial overclosure anywhere across the face).

Transmission error on the transverse line of action, positive when the output lags:
``TE = rb1 theta1 - rb2 theta2`` (transverse base radii), zero at rigid first contact.

Contact sets: the drive flanks between the root form circle and the radius that meets the mate's root
form circle on the line of action (the LTCA's active flank). The seed's pair is 0.2 um tighter than
zero backlash, has a negative tip-root clearance (ra1 + rf2 and ra2 + rf1 exceed aw by 25 um) and a
tip-fillet interference below the root form circles (config warning); outside these sets the bodies
may overlap without contact, as the LTCA ignores them.

Start gap: the sections are placed by the rigid outline touch (bisection per layer), then the output is
turned until the 3D contact's own smallest gap (:func:`contact_min_gap`, normal gap / cos(beta_b) on the
line of action) equals the set-up clearance: the outline touch may come from points outside the contact
sets (the mate's tip passing the root), which left the coarse pair ~8 um wider than intended.

Contact energy (solved problem, kept for the record): until the open-edge rule of
:func:`gearrom.fe.explicit.contact.contact_forces_3d` the 3D runs created energy in bursts that grew into an
instability (hundreds of J against ~1 J of external work). Cause: the contact sets end inside the meshing
zone (cut flank ends, the end faces), and a slave node beyond such an edge, whose closest master feature is
the edge, was taken as penetrating as soon as it crossed the facet plane, with its whole distance to the
edge (48 um in the traced event) as the penetration. Slave sets are also cut to the radii whose conjugate
points lie on the mate's facets, so that every loaded slave has a master facet.
"""
from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np

from gearrom.errors import ConfigError, MeshError
from gearrom.fe.explicit.flankmods import apply_flank_modifications, micro_enabled, usable_tip_radius
from gearrom.fe.explicit.driver import solve
from gearrom.fe.explicit.gearpair import (GearPairSetup, first_touch, gear_pair_model, outline_order,
                                          polar_inertias, transmission_error)
from gearrom.fe.explicit.model import ExplicitModel, Material, boundary_segments
from gearrom.fe.explicit.result import ExplicitResult

log = logging.getLogger(__name__)

__all__ = ["helical_pair_model", "helical_meshes", "run_helical_pair"]

#: centre-distance widening of the 2D spur placement, m (undone before the drive-flank touch search)
_AW_SLACK = 0.2e-3
#: tolerance below the root form radius still in the contact sets, m
_ROOT_BAND = 1e-6


class _TransverseSection:
    """The helical pair seen by the 2D spur set-up: its transverse section (attributes delegated), with
    the centre distance widened by ``slack`` so that the spur placement never sees an overlap (the
    seed's helical pair is nominally backlash-free, 0.2 um tighter than zero backlash). The true
    centre distance is restored and the contact re-found on the drive flanks only afterwards."""

    is_helical = False

    def __init__(self, pair, slack: float):
        self._pair = pair
        self.aw = pair.aw + slack

    def __getattr__(self, name):
        return getattr(self._pair, name)


def _rot(p: np.ndarray, c, angle: float) -> np.ndarray:
    cs, sn = math.cos(angle), math.sin(angle)
    q = p - c
    return c + np.column_stack([cs * q[:, 0] - sn * q[:, 1], sn * q[:, 0] + cs * q[:, 1]])


def helical_meshes(pair, outline_size: float, body_size: float | None = None, grading: float = 2e-3,
                   project: bool = True, sag: float | None = None, periodic: bool = False):
    """Transverse Q4 meshes (nodes, quads, bore) of both gears (:func:`gear_quad_mesh`).

    ``gear_quad_mesh`` resamples the outline at twice the outline size and halves the segments, so
    every second outline node is a chord midpoint (chords ``2 outline_size`` long: about 14 um of sag
    near the base circle of the input at 0.4 mm). With ``project`` every outline node is moved onto
    the generated profile (nearest point of the dense rack-generated outline,
    :func:`_project_outline`), so the flank becomes chords of ``outline_size`` with all vertices on the
    true profile. Where those moves would invert an element (fine outlines at the root), the nodes
    are first placed by ``gear_quad_mesh``'s own projection, which retries another quad algorithm
    until every element stays valid, and then moved the last sub-um onto the dense outline.
    ``sag`` (m): refine the flank outline until its chords stay within ``sag`` of the profile
    (``gear_quad_mesh``'s option; the projection then always takes the second way).
    ``periodic``: every tooth gets the same section (``gear_quad_mesh``'s option: one tooth sector
    meshed and copied), and the dense outline the nodes are projected on is sampled alike on every
    tooth, so the projected sections stay copies of one another. A whole-gear mesh gives each tooth its
    own compliance, which a dynamic record carries as shaft-order content and drift.
    """
    from gearrom.fe.explicit.gearmesh import gear_quad_mesh

    out = []
    for i in (0, 1):
        nodes, quads, bore = gear_quad_mesh(pair, i, outline_size, body_size, grading, project=False, sag=sag,
                                            periodic=periodic)
        if project:
            moved = _project_outline(pair, i, nodes, quads, bore, periodic=periodic)
            if sag is not None or _inverted(moved, quads):
                nodes, quads, bore = gear_quad_mesh(pair, i, outline_size, body_size, grading, project=True, sag=sag,
                                                    periodic=periodic)
                moved = _project_outline(pair, i, nodes, quads, bore, periodic=periodic)
                if _inverted(moved, quads):
                    raise MeshError(f"gear {i}: projecting the outline onto the profile inverts an element at "
                                    f"outline size {outline_size * 1e3:g} mm; try another outline or body size")
            nodes = moved
        out.append((nodes, quads, bore))
    return out


def _inverted(nodes: np.ndarray, quads: np.ndarray) -> bool:
    """Whether any quad has a non-positive corner (counter-clockwise order expected)."""
    p = nodes[quads]                                     # (m, 4, 2)
    a = np.roll(p, -1, axis=1) - p
    b = np.roll(p, 1, axis=1) - p
    return bool(np.any(a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0] <= 0))


def _project_outline(pair, i: int, nodes: np.ndarray, quads: np.ndarray, bore: np.ndarray,
                     spacing: float = 1e-6, max_move: float = 30e-6, periodic: bool = False) -> np.ndarray:
    """Outline (non-bore boundary) nodes moved to the nearest point of the dense generated outline
    (``periodic``: sampled alike on every tooth)."""
    from scipy.spatial import cKDTree

    from gearrom.fe.explicit.gearmesh import closed_outline, project_onto, resample_closed

    dense = resample_closed(closed_outline(pair, i), spacing, multiple=pair.gears[i].z if periodic else 1)
    b = set(int(k) for k in bore)
    ids = np.array(sorted(set(np.unique(boundary_segments(quads)).tolist()) - b))
    dist, j = cKDTree(dense).query(nodes[ids])
    target = dense[j]
    if periodic:   # nearest point on the dense polyline: continuous in the node, so alike on every tooth
        target = project_onto(nodes[ids], dense)
        dist = np.hypot(*(target - nodes[ids]).T)
    move = dist < max_move          # chord midpoints across the sharp tip corners stay where they are
    out = np.array(nodes, float)
    out[ids[move]] = target[move]
    log.info("gear %d: %d outline nodes moved onto the profile (max %.2f um), %d corner nodes kept", i,
             int(move.sum()), float(dist[move].max()) * 1e6, int((~move).sum()))
    return out


def _drive_touch(n1, loop1, drive1, n2, loop2, drive2, c2, span: float, r_root: tuple[float, float],
                 zone: float = 7e-3) -> float:
    """Counter-clockwise turn of gear 2 (about ``c2``) from -span..span at which the drive flanks of the two
    outlines first overlap (vertex in polygon both ways, as the node-to-segment contact), by bisection.
    Vertices inside the opposite gear's root band (radius < ``r_root`` of that gear) are ignored, as the
    contact ignores them."""
    from matplotlib.path import Path

    poly1 = Path(n1[loop1])
    near1 = n1[drive1[(np.abs(n1[drive1, 1]) < zone) & (np.hypot(*(n1[drive1] - c2).T) > r_root[1])]]
    sel2 = drive2[np.abs(n2[drive2, 1]) < zone + 2e-3]

    def overlap(angle):
        q2 = _rot(n2, c2, angle)
        p2 = q2[sel2]
        p2 = p2[np.hypot(*p2.T) > r_root[0]]
        return bool(poly1.contains_points(p2).any() or Path(q2[loop2]).contains_points(near1).any())

    lo, hi = -span, span
    if overlap(lo) or not overlap(hi):
        raise MeshError(f"helical pair: drive flanks not bracketed within +-{span:.4g} rad of the start position")
    return first_touch(overlap, lo, hi)


def _outer_loop_segments(elements2d: np.ndarray, bore: set) -> np.ndarray:
    segs = boundary_segments(elements2d)
    keep = np.array([not (int(a) in bore and int(b) in bore) for a, b in segs])
    return segs[keep]


def _flank_contact_sets(pair, m2d, n1_2d, n2_2d, c2, off: int) -> tuple[dict, dict]:
    """Master facets and slave nodes on the involute flanks of the transverse section: facets with a node
    below the root form circle or above the radius that meets the mate's root form circle are left
    out, and a slave node is kept only where its conjugate point lies on the mate's facets."""
    n2d = n1_2d.shape[0] + n2_2d.shape[0]
    rad = np.hypot(*np.vstack([n1_2d, n2_2d - c2]).T)
    rf = np.where(np.arange(n2d) < off, 0.5 * pair.dff[0], 0.5 * pair.dff[1])
    loa = pair.aw * math.sin(pair.alpha_wt)
    roll_ff = [math.sqrt(max((0.5 * pair.dff[g]) ** 2 - pair.rb[g] ** 2, 0.0)) for g in (0, 1)]
    # no contact above the mate's root form circle's conjugate nor above the usable tip d_Na
    r_top = [min(math.hypot(pair.rb[g], loa - roll_ff[1 - g]), usable_tip_radius(pair, g)) for g in (0, 1)]
    rt = np.where(np.arange(n2d) < off, r_top[0], r_top[1])
    on_root = (rad < rf - _ROOT_BAND) | (rad > rt + _ROOT_BAND)
    surfs = {k: np.asarray(v)[~on_root[np.asarray(v)].any(axis=1)] for k, v in m2d.surfaces.items()}
    # The master facets end at the last outline nodes inside [rf, rt], short of those radii by up to one
    # facet. A slave node is kept only where its conjugate point on the transverse line of action lies on
    # the mate's facets: otherwise it meets the mate beyond the facet set's edge, where the penalty contact
    # has no surface (a first touch there was invisible to the contact: the pair closed ~10 um before
    # the flanks took load on the coarse mesh).
    cov = [rad[np.unique(surfs[k])] for k in ("outline_1", "outline_2")]

    def conjugate(g: int, r_mate: float) -> float:
        return math.hypot(pair.rb[g], loa - math.sqrt(max(r_mate ** 2 - pair.rb[1 - g] ** 2, 0.0)))

    r_lo = [max(0.5 * pair.dff[g], conjugate(g, cov[1 - g].max())) for g in (0, 1)]
    r_hi = [min(r_top[g], conjugate(g, cov[1 - g].min())) for g in (0, 1)]
    is1 = np.arange(n2d) < off
    off_slave = (rad < np.where(is1, r_lo[0], r_lo[1]) - _ROOT_BAND) | (rad > np.where(is1, r_hi[0], r_hi[1]) + _ROOT_BAND)
    slaves = {k: np.asarray(m2d.node_sets[k])[~off_slave[np.asarray(m2d.node_sets[k])]] for k in ("flank_1", "flank_2")}
    return surfs, slaves


def _extrude(pair, X2, q2, off: int, c2, zs, stagger: bool, slaves: dict, node_sets: dict, surfs: dict):
    """Extrude the transverse Q4 section into twisted Hex8 layers, gear by gear (node order: gear 1 layer by
    layer, then gear 2), with the node sets and contact surfaces lifted to every layer.

    Returns ``nodes``, ``hexes``, ``base`` (per gear: first and end 2D node, first 3D node, layer count),
    the layer planes per gear, the node sets and the surfaces.
    """
    from gearrom.geometry.profile import twist

    n1_2d, n2_2d = X2[:off], X2[off:]
    n2d = X2.shape[0]
    z_gear = [zs, zs]
    if stagger:   # output planes half a layer off the input's (end layers half thick)
        z_gear[1] = np.concatenate([[zs[0]], 0.5 * (zs[:-1] + zs[1:]), [zs[-1]]])
    parts = [(n1_2d, np.zeros(2), 0, off, 0), (n2_2d, c2, off, n2d, 1)]
    blocks, hexes, base = [], [], []
    start = 0
    for pts, cen, lo, hi, g in parts:
        nl, zg = len(z_gear[g]), z_gear[g]
        tw = np.asarray(twist(pair, g, zg), float)
        for k in range(nl):
            blocks.append(np.column_stack([_rot(pts, cen, tw[k]), np.full(len(pts), zg[k])]))
        q = q2[(q2 >= lo).all(axis=1) & (q2 < hi).all(axis=1)] - lo
        hexes += [np.hstack([q + start + k * (hi - lo), q + start + (k + 1) * (hi - lo)]) for k in range(nl - 1)]
        base.append((lo, hi, start, nl))
        start += nl * (hi - lo)
    nodes = np.vstack(blocks)
    hexes = np.vstack(hexes)

    def gear_of(ids):
        return 0 if np.all(np.asarray(ids) < off) else 1

    def layers(ids):
        ids = np.asarray(ids, np.int64)
        lo, hi, st, nl = base[gear_of(ids)]
        return np.concatenate([ids - lo + st + k * (hi - lo) for k in range(nl)])

    def faces(segs):
        segs = np.asarray(segs, np.int64)
        lo, hi, st, nl = base[gear_of(segs)]
        sg = segs - lo + st
        m = hi - lo
        return np.vstack([np.column_stack([sg[:, 0] + k * m, sg[:, 1] + k * m, sg[:, 1] + (k + 1) * m,
                                           sg[:, 0] + (k + 1) * m]) for k in range(nl - 1)])

    sets = {k: layers(slaves.get(k, v)) for k, v in node_sets.items()}
    surfaces = {k: faces(v) for k, v in surfs.items()}
    return nodes, hexes, base, z_gear, sets, surfaces


def helical_pair_model(pair, meshes, setup: GearPairSetup, n_layers: int, material: Material | None = None,
                       run_angle: float | None = None, margin_teeth: int = 2,
                       stagger: bool = False) -> tuple[ExplicitModel, dict]:
    """Build the Hex8 explicit model of a helical pair from the two transverse Q4 meshes.

    Parameters
    ----------
    pair : GearPair
        A helical pair (``pair.is_helical``).
    meshes : sequence of two (nodes, quads, bore) tuples
        Transverse-section meshes in the gear frames (tooth 0 on +y), e.g. :func:`helical_meshes`.
    setup : GearPairSetup
        Operating point (the spur dataclass; ``flanks``, ``clearance`` etc. mean the same here).
    n_layers : int
        Element layers over the face width.
    run_angle : float, optional
        Input rotation (rad) the run will cover. If given, each gear is cut to the sector that meets
        the mate during that rotation (the contact zone including the helix twist, plus
        ``margin_teeth`` pitches on both sides); the inertia of the removed part is added to the
        reference node (``RigidReference.inertia``), so the rigid-body dynamics are the full gear's.
    stagger : bool
        Put the output's layer planes half a layer off the input's, so that no slave node sits on a
        master facet crease between layers (with matching planes every contact node is on one).

    Returns
    -------
    model : ExplicitModel (3D)
    info : dict with ``rb`` (transverse base radii, m), ``clearance_angle`` (rad), ``omega_in``,
        ``omega_out`` (rad/s), ``n_layers``, ``layer_m`` (axial element size), ``flank_spacing_m``
        (median transverse flank edge), ``twist_per_layer_rad`` (input), ``twist_sag_m``.
    """
    if not pair.is_helical:
        raise ConfigError("helical_pair_model needs a helical pair; use gear_pair_model for spur pairs")
    if int(n_layers) != n_layers or n_layers < 1:
        raise ConfigError(f"n_layers must be a positive integer, got {n_layers}")
    n_layers = int(n_layers)
    m2d, info2 = gear_pair_model(_TransverseSection(pair, _AW_SLACK), meshes, setup, material)
    X2 = np.array(m2d.nodes)
    q2 = np.asarray(m2d.elements)
    n2d = X2.shape[0]
    off = info2["n_gear1"]
    c2 = np.array([pair.aw, 0.0])
    width = min(g.face_width for g in pair.gears)
    zs = np.linspace(-0.5 * width, 0.5 * width, n_layers + 1)
    from gearrom.geometry.profile import twist

    tw1 = np.asarray(twist(pair, 0, zs), float)
    tw2 = np.asarray(twist(pair, 1, zs), float)
    if not np.allclose(tw2, -tw1 * pair.z[0] / pair.z[1], rtol=1e-6, atol=1e-12):
        raise ConfigError("helical pair: the twists of the two gears are not meshing-consistent "
                          "(hands must be opposite for an external pair)")
    # -- the true centre distance, then the tightest section keeps the clearance on the drive flanks
    X2[off:, 0] -= _AW_SLACK
    refs = tuple(replace(r, center=(float(c2[0]), 0.0)) if r.nodes == "bore_2" else r for r in m2d.references)
    n1_2d, n2_2d = X2[:off], X2[off:]
    # contact on the involute flanks only (radius >= root form radius, as the quasi-static LTCA): the seed's
    # pair has a negative tip-root clearance (ra + rf of the mate > aw by 25 um) and a tip-fillet
    # interference below the root form circles (config warning), where the mate's tip corner sweeps up to
    # ~50 um into the fillet. Slave nodes and master facets with any node below the root form circle are
    # left out, so that a tip corner crossing the fillet never meets a facet (no overclosure at the start,
    # no deep capture when it reaches the flank).
    # The top of each flank is cut at the radius that meets the mate's root form circle on the line of
    # action (beyond it the mate has no involute: the LTCA's active flank ends there too), so that the tip
    # corners that sweep through the mate's fillet are in no contact set either.
    surfs, slaves = _flank_contact_sets(pair, m2d, n1_2d, n2_2d, c2, off)
    drive1 = slaves["flank_1"]
    drive2 = slaves["flank_2"] - off
    poly_loop1 = outline_order(_outer_loop_segments(q2[(q2 < off).all(axis=1)], set(m2d.node_sets["bore_1"].tolist())))
    poly_loop2 = outline_order(_outer_loop_segments(q2[(q2 >= off).all(axis=1)] - off,
                                                    set((m2d.node_sets["bore_2"] - off).tolist())))
    rb1, rb2 = pair.rb
    slack = []
    for k in range(n_layers + 1):
        a1 = _rot(n1_2d, np.zeros(2), tw1[k])
        a2 = _rot(n2_2d, c2, tw2[k])
        slack.append(_drive_touch(a1, poly_loop1, drive1, a2, poly_loop2, drive2, c2, 0.006,
                                   (0.5 * pair.dff[0] - _ROOT_BAND, 0.5 * pair.dff[1] - _ROOT_BAND)))
    corr = min(slack) - setup.clearance / rb2
    log.info("helical: per-layer rigid slack %s um on the LoA; output turned by %.3f um",
             np.round(np.array(slack) * rb2 * 1e6, 3).tolist(), corr * rb2 * 1e6)
    n2_2d = _rot(n2_2d, c2, corr)
    X2 = np.vstack([n1_2d, n2_2d])
    removed_j = [0.0, 0.0]
    if run_angle is not None:
        X2, q2, off, slaves, surfs, node_sets, removed_j = _cut_sectors(
            pair, X2, q2, off, slaves, surfs, dict(m2d.node_sets), m2d.material.rho, width,
            run_angle, float(np.max(np.abs(tw1))), margin_teeth)
        refs = tuple(replace(r, inertia=r.inertia + removed_j[0 if r.nodes == "bore_1" else 1]) for r in refs)
    else:
        node_sets = dict(m2d.node_sets)
    n1_2d, n2_2d = X2[:off], X2[off:]
    n2d = X2.shape[0]
    nodes, hexes, base, z_gear, sets, surfaces = _extrude(pair, X2, q2, off, c2, zs, stagger, slaves, node_sets,
                                                         surfs)
    # -- start gap as the 3D contact sees it: the rigid section touch above may come from outline points
    # outside the contact sets (the mate's tip passing the root: negative tip-root clearance), so the
    # output is turned until the contact's own smallest gap is the clearance on the line of action
    g1 = np.arange(nodes.shape[0]) < base[1][2]
    cos_bb = math.cos(pair.beta_b)
    gap_start = []
    for _ in range(3):
        probe = ExplicitModel(nodes, hexes, m2d.material, node_sets=sets, surfaces=surfaces, references=refs,
                              contacts=m2d.contacts)
        g_loa = contact_min_gap(probe) / cos_bb
        gap_start.append(g_loa)
        turn = (g_loa - setup.clearance) / rb2
        if abs(turn * rb2) < 1e-9:
            break
        rot = _rot(nodes[~g1, :2], c2, turn)      # counter-clockwise closes the drive flanks
        nodes[~g1, :2] = rot
    log.info("helical: contact gap on the line of action at the start %s um (target %.3f um)",
             np.round(np.array(gap_start) * 1e6, 3).tolist(), setup.clearance * 1e6)
    if micro_enabled(pair):   # drawing micro-geometry, on the pair placed by its perfect flanks
        loops = [outline_order(_outer_loop_segments(q2[(q2 < off).all(axis=1)], set(node_sets["bore_1"].tolist()))),
                 outline_order(_outer_loop_segments(q2[(q2 >= off).all(axis=1)] - off,
                                                    set((np.asarray(node_sets["bore_2"]) - off).tolist())))]
        flanks = [np.union1d(slaves["flank_1"], np.unique(surfs["outline_1"])),
                  np.union1d(slaves["flank_2"], np.unique(surfs["outline_2"])) - off]
        nodes = apply_flank_modifications(pair, nodes, base, z_gear, loops, flanks, (np.zeros(2), c2))
    omega1, omega2 = info2["omega_in"], info2["omega_out"]
    v0 = None
    if m2d.initial_velocity is not None:
        v0 = np.zeros_like(nodes)
        g1 = np.arange(nodes.shape[0]) < base[1][2]
        v0[g1, :2] = omega1 * np.column_stack([-nodes[g1, 1], nodes[g1, 0]])
        r = nodes[~g1, :2] - c2
        v0[~g1, :2] = omega2 * np.column_stack([-r[:, 1], r[:, 0]])
    model = ExplicitModel(
        nodes, hexes, m2d.material, node_sets=sets, surfaces=surfaces,
        references=refs, contacts=m2d.contacts, initial_velocity=v0, mass_damping=setup.mass_damping,
        relative_damping=setup.relative_damping, integration=setup.integration,
        hourglass_stiffness=setup.hourglass_stiffness,
        hourglass_viscosity=setup.hourglass_viscosity,
        mass_scaling_dt=setup.mass_scaling_dt)
    dtw = abs(tw1[1] - tw1[0])
    r_mid = 0.5 * pair.d[0]
    sag = r_mid * dtw ** 2 / 8 * math.sin(pair.alpha_t)
    info = dict(info2, n_layers=n_layers, layer_m=width / n_layers, width_m=width, twist_per_layer_rad=dtw,
                twist_sag_m=sag, layer_slack_m=[s * rb2 for s in slack], n_gear1_2d=off, n_nodes_2d=n2d,
                z_layers=(z_gear[0].tolist(), z_gear[1].tolist()), n_nodes_gear1=int(base[1][2]),
                removed_inertia_kgm2=removed_j, sector=run_angle is not None, start_gap_loa_m=gap_start)
    return model, info


def contact_min_gap(model: ExplicitModel) -> float:
    """Smallest signed gap (m) between the slave nodes and master facets of a 3D model, as the contact sees it
    (nodes deeper than the capture depth are not in contact and are left out).

    Raises MeshError when no slave node has a master facet within reach.
    """
    from gearrom.fe.explicit.contact import contact_search, signed_gaps_3d
    from gearrom.fe.explicit.driver import prepare

    d = prepare(model, 0.9, 32)
    x = np.asarray(model.nodes, float)
    contact_search(x, d["slaves"], d["s_pair"], d["segs"], d["g_pair"], d["g_rad"], d["margin"] + d["p_depth"].max(),
                   d["head"], d["nxt"], d["cand"], d["ncand"], d["cell_h"])
    g = signed_gaps_3d(x, d["slaves"], d["segs"], d["g_rad"], d["cand"], d["ncand"], d["seg_open"], d["seg_sag"])
    g = g[g > -d["p_depth"][d["s_pair"]]]      # deeper than the capture depth: not a contact (other side)
    if g.size == 0:
        raise MeshError("helical pair: no contact node has a master facet within reach at the start position")
    return float(g.min())


def _cut_sectors(pair, X2, q2, off, slaves, surfs, node_sets, rho, width, run_angle, twist_max, margin_teeth):
    """Keep the elements of each gear whose centroid lies in the sector that meshes during ``run_angle``.

    Teeth enter the mesh from y < 0 for both gears (input counter-clockwise about the origin, mesh on
    +x; output clockwise about (aw, 0), mesh on -x). Returns the renumbered arrays and the polar
    inertia of the removed elements of each gear (centroid rule, kg m^2).
    """
    c = [np.zeros(2), np.array([pair.aw, 0.0])]
    toward = [0.0, math.pi]                    # direction of the mesh zone from each centre
    turn = [run_angle, run_angle * pair.z[0] / pair.z[1]]
    cen = X2[q2].mean(axis=1)
    gear = (q2 >= off).all(axis=1).astype(int)
    area = 0.5 * np.abs(np.sum(X2[q2][:, :, 0] * np.roll(X2[q2][:, :, 1], -1, axis=1)
                               - np.roll(X2[q2][:, :, 0], -1, axis=1) * X2[q2][:, :, 1], axis=1))
    keep = np.zeros(len(q2), bool)
    removed_j = [0.0, 0.0]
    for g in (0, 1):
        ra = 0.5 * pair.da[g]
        half = (0.5 * pair.eps_alpha * pair.pb_t) / ra + twist_max * (1 if g == 0 else pair.z[0] / pair.z[1]) \
            + margin_teeth * 2 * math.pi / pair.z[g]
        d = cen[gear == g] - c[g]
        ang = np.arctan2(d[:, 1], d[:, 0]) - toward[g]
        ang = (ang + math.pi) % (2 * math.pi) - math.pi
        lo = -(turn[g] + half) if g == 0 else -half          # angles measured counter-clockwise
        hi = half if g == 0 else turn[g] + half
        k = (ang >= lo) & (ang <= hi)                         # output: teeth come from y < 0, i.e. ang > 0
        if hi - lo >= 2 * math.pi:
            k[:] = True
        idx = np.nonzero(gear == g)[0]
        keep[idx[k]] = True
        gone = idx[~k]
        removed_j[g] = float(rho * width * np.sum(area[gone] * np.sum((cen[gone] - c[g]) ** 2, axis=1)))
    q2 = q2[keep]
    used = np.unique(q2)
    new = np.full(X2.shape[0], -1, np.int64)
    new[used] = np.arange(used.size)
    edges = set(map(tuple, np.sort(np.concatenate([q2[:, [0, 1]], q2[:, [1, 2]], q2[:, [2, 3]], q2[:, [3, 0]]]), axis=1)))

    def ids(a):
        a = np.asarray(a, np.int64)
        return new[a[new[a] >= 0]]

    surfs = {k: new[np.array([sg for sg in v if tuple(sorted(sg)) in edges], np.int64).reshape(-1, 2)]
             for k, v in surfs.items()}
    slaves = {k: ids(v) for k, v in slaves.items()}
    node_sets = {k: ids(v) for k, v in node_sets.items()}
    off_new = int(np.sum(used < off))
    return X2[used], new[q2], off_new, slaves, surfs, node_sets, removed_j


def run_helical_pair(pair, meshes, setup: GearPairSetup, t_end: float, sample_period: float, n_layers: int,
                     max_candidates: int = 32, sector: bool = True, stagger: bool = False, **solve_kw) -> tuple[ExplicitResult, np.ndarray, dict]:
    """Build and run the helical pair; return (result, TE history in m, info).

    ``max_candidates``: candidate master facets kept per slave node. The facets are long axially and
    twisted, so the facet that holds a node's projection is often not among the few with the nearest
    centroids (the solver default of 8 then misses contacts until they are deep). ``sector``: cut
    both gears to the sectors that mesh until ``t_end`` (see :func:`helical_pair_model`).

    ``setup.start == "loaded"``: the run starts from the loaded static state at the start position, found by
    a direct static solve of the same model with its contact geometry updated to the deformed positions
    (:meth:`gearrom.fe.explicit.static3d.StaticPair3D.loaded_state`: the explicit model's own
    equilibrium), each gear at its rigid-body speed and the full torque at t = 0. With a checkpoint
    (``solve_kw``) that state is stored next to it (``<checkpoint>.loaded.npz``) and reused.
    """
    from gearrom.fe.explicit.driver import prepare

    run_angle = setup.rpm_in * 2 * math.pi / 60 * t_end if sector else None
    model, info = helical_pair_model(pair, meshes, setup, n_layers, run_angle=run_angle, stagger=stagger)
    if setup.start == "loaded":
        from gearrom.fe.explicit.gearpair import loaded_model, start_state_key, stored_start_state
        from gearrom.fe.explicit.static3d import StaticPair3D

        state = stored_start_state(solve_kw.get("checkpoint"), ".loaded.npz", "te", model.nodes.shape, setup.torque_out,
                                   lambda: StaticPair3D(model, info, pair).loaded_state(setup.torque_out),
                                   key=start_state_key(model))
        log.info("loaded start: static TE %.3f um (direct static solve)", state[2] * 1e6)
        model = loaded_model(model, info, setup, (state[0], state[1], 0.0))
        info = dict(info, loaded_te_m=state[2])
    d = prepare(model, solve_kw.pop("safety", 0.9), max_candidates)
    res = solve(model, t_end, sample_period, prepared=d, **solve_kw)
    te = transmission_error(res, info["rb"], info["clearance_angle"])
    j1, j2 = polar_inertias(model, d["mass"], info["n_nodes_gear1"])
    res.meta.update(rpm_in=setup.rpm_in, torque_out_Nm=setup.torque_out, mu=setup.mu, start=setup.start,
                    flank_spacing_m=info["flank_spacing_m"], penalty_scale=setup.penalty_scale,
                    n_layers=n_layers, layer_m=info["layer_m"], max_candidates=max_candidates,
                    removed_inertia_kgm2=info["removed_inertia_kgm2"], inertia_in_kgm2=j1, inertia_out_kgm2=j2)
    return res, te, info
