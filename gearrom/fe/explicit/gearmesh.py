"""All-quadrilateral (Q4) mesh of a whole spur gear for the explicit solver (gmsh, full-quad blossom).

The outline is the rack-generated tooth profile of :mod:`gearrom.geometry.profile` with the tip edges
rounded as in the quasi-static FE (:func:`gearrom.fe.tipedge.tip_edge_radius`), cleaned as in
:mod:`gearrom.fe.mesh2d`, repeated for all teeth and resampled at the boundary element size, with
the bore circle. Meshing puts nodes on the chords of that polyline (gmsh also splits every boundary
segment at its midpoint); with ``project`` every outline node is then moved onto the generated
profile itself (its nearest point on a profile sampled 10 times more densely), so that the rigid
flanks carry no facet error: the facets' kinematic TE would otherwise be of the order of the elastic
mesh-frequency TE. The size is ``outline_size`` on the outline and grows to ``body_size`` at
``grading`` (m) from it. Frame: gear centre at the origin, tooth 0 on +y.
"""
from __future__ import annotations

import math

import numpy as np

from gearrom.errors import MeshError


def closed_outline(pair, i: int, density: int = 1) -> np.ndarray:
    """Closed outline of all teeth; ``density`` multiplies the points per profile section."""
    from gearrom.fe.mesh2d import clean_profile   # same cleaning as the quasi-static meshes
    from gearrom.fe.tipedge import tip_edge_radius
    from gearrom.geometry.profile import rotate, tooth_profile

    # the same rounded tip edges as the quasi-static FE (config tip_edge_radius or its default)
    rho = tip_edge_radius(pair, i)[0]
    prof = clean_profile(tooth_profile(pair, i, n_involute=80 * density, n_fillet=40 * density, n_tip=8 * density,
                                       n_root=8 * density, tip_edge_radius=rho))
    z = pair.gears[i].z
    parts = [rotate(prof.points, -k * 2 * math.pi / z)[:-1] for k in range(z)]
    return np.vstack(parts)


def resample_closed(poly: np.ndarray, h: float, sag: float | None = None, h_min: float | None = None,
                     r_refine: float = 0.0, multiple: int = 1) -> np.ndarray:
    """Points along the closed polyline ``poly`` at spacing ``h``, or finer where it curves.

    With ``sag`` (m) the spacing is ``min(h, 2 sqrt(8 sag / kappa))`` (not below ``h_min``): after the
    later halving of every segment, the chords of an arc of curvature kappa deviate from it by at most
    ``sag``. The curvature comes from the turning angle at each polyline vertex, and the spacing is
    the smallest over +-h along the outline, so that the refinement starts ahead of a rounded corner.
    Only vertices at radius >= ``r_refine`` (m, from the origin) are refined. The point count is a
    multiple of ``multiple``: the points of a polyline made of ``multiple`` rotated copies of one part are
    then rotated copies of one part's points too.
    """
    closed = np.vstack([poly, poly[:1]])
    seg = np.hypot(*np.diff(closed, axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    if sag is None:
        n = max(8, multiple * int(round(arc[-1] / h / multiple)))
        t = np.linspace(0.0, arc[-1], n, endpoint=False)
    else:
        d = np.diff(closed, axis=0)
        ang = np.arctan2(d[:, 1], d[:, 0])
        turn = np.abs(np.angle(np.exp(1j * (ang - np.roll(ang, 1)))))          # at vertex k (start of segment k)
        kappa = turn / np.maximum(0.5 * (seg + np.roll(seg, 1)), 1e-300)
        spacing = np.clip(2.0 * np.sqrt(8.0 * sag / np.maximum(kappa, 1e-300)), h_min or 0.25 * h, h)
        spacing[np.hypot(*poly.T) < r_refine] = h
        # smallest spacing within +-h of arc length (periodic)
        s0 = arc[:-1]
        total = arc[-1]
        ext_s = np.concatenate([s0 - total, s0, s0 + total])
        ext_sp = np.tile(spacing, 3)
        lo = np.searchsorted(ext_s, s0 + total - h)
        hi = np.searchsorted(ext_s, s0 + total + h)
        csp = np.array([ext_sp[a:b].min() for a, b in zip(lo, hi)])
        dens = np.concatenate([[0.0], np.cumsum(seg / csp)])                    # nodes per arc length
        n = max(8, multiple * int(round(dens[-1] / multiple)))
        t = np.interp(np.arange(n) * dens[-1] / n, dens, arc)
    return np.column_stack([np.interp(t, arc, closed[:, 0]), np.interp(t, arc, closed[:, 1])])


_ATTEMPTS = ((8, 1, 10), (8, 1, 0), (6, 1, 10), (5, 1, 10), (8, 0, 10))   # (algorithm, blossom, smoothing)


def project_onto(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Nearest points on the closed polyline ``poly`` (m, 2) of ``points`` (k, 2)."""
    from scipy.spatial import cKDTree

    near = cKDTree(poly).query(points)[1]
    best = np.full(points.shape, np.nan)
    dist = np.full(points.shape[0], np.inf)
    m = poly.shape[0]
    for shift in (-1, 0):                      # the two segments that meet at the nearest vertex
        a = poly[(near + shift) % m]
        b = poly[(near + shift + 1) % m]
        ab = b - a
        t = np.clip(np.einsum("ij,ij->i", points - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
        q = a + t[:, None] * ab
        dq = np.hypot(*(points - q).T)
        better = dq < dist
        best[better], dist[better] = q[better], dq[better]
    return best


def gear_quad_mesh(pair, i: int, outline_size: float, body_size: float | None = None,
                   grading: float = 2e-3, project: bool = True, sag: float | None = None, periodic: bool = False):
    """Q4 mesh of gear ``i`` of ``pair``; ``project`` puts the outline nodes on the generated profile.

    ``periodic``: mesh the sector of one tooth (between the middles of its two root spaces, from the
    outline to the bore) with its two radial cuts meshed alike, and copy it around the gear, so that
    every tooth has the same mesh. A whole-gear mesh gives each tooth its own mesh, hence a slightly
    different compliance per tooth: content at the shaft orders that a tooth-identical model lacks.

    ``sag`` (m): refine the outline above the base circle where it curves (flanks, tip-edge roundings) so
    that its chords stay within ``sag`` of the profile (:func:`resample_closed`; at most 4 times finer
    than ``outline_size``); the fillets below the base circle, which never touch, keep ``outline_size``.
    The smaller elements there lower the stable step unless mass scaling lifts it
    (:class:`gearrom.fe.explicit.model.ExplicitModel`).

    Returns
    -------
    nodes : ndarray (n, 2), m
    quads : ndarray (m, 4), counter-clockwise
    bore : ndarray of int, nodes on the bore circle
    """
    from gearrom.fe.explicit.geometry import element_geometry

    body_size = body_size or outline_size
    if not 0 < outline_size <= body_size:
        raise MeshError(f"gear_quad_mesh needs 0 < outline_size <= body_size, got {outline_size}, {body_size}")
    z = pair.gears[i].z if periodic else 1
    if sag is None:
        outline = resample_closed(closed_outline(pair, i), 2 * outline_size, multiple=z)   # halved below
    else:
        outline = resample_closed(closed_outline(pair, i, density=10), 2 * outline_size, sag,
                                   r_refine=pair.rb[i], multiple=z)
    last = None
    for algo, blossom, smooth in _ATTEMPTS:   # gmsh quads are occasionally degenerate at the root
        if periodic:
            mesh = _periodic_mesh(pair, i, outline, outline_size, body_size, grading, algo, blossom, smooth)
        else:
            mesh = _mesh(pair, i, outline, outline_size, body_size, grading, algo, blossom, smooth)
        if project:
            mesh = _projected(mesh, closed_outline(pair, i, density=10))
        try:
            element_geometry(mesh[0], mesh[1])
            return mesh
        except MeshError as exc:
            last = exc
    raise MeshError(f"gear {i}: no valid quad mesh at outline_size {outline_size * 1e3:.3f} mm ({last})")


def _projected(mesh, exact: np.ndarray):
    """The mesh with its outer boundary nodes (all boundary nodes but the bore's) on ``exact``."""
    from gearrom.fe.explicit.model import boundary_segments

    xy, quads, bore = mesh
    edge = np.setdiff1d(np.unique(boundary_segments(quads)), bore)
    xy = xy.copy()
    xy[edge] = project_onto(xy[edge], exact)
    return xy, quads, bore


def _quad_options(gmsh, lines, outline_size, body_size, grading, algo, blossom, smooth) -> None:
    """Size field and quad options of the gear meshes (sizes doubled: the quad subdivision halves them)."""
    from gearrom.fe.mesh2d import threshold_field

    thr = threshold_field(gmsh, lines, 2 * outline_size, 2 * body_size, 0.5 * outline_size, grading, sampling=4)
    gmsh.model.mesh.field.setAsBackgroundMesh(thr)
    for opt, val in (("Mesh.MeshSizeExtendFromBoundary", 0), ("Mesh.MeshSizeFromPoints", 0),
                     ("Mesh.MeshSizeFromCurvature", 0), ("Mesh.Algorithm", algo),
                     ("Mesh.RecombineAll", 1), ("Mesh.RecombinationAlgorithm", blossom),
                     ("Mesh.SubdivisionAlgorithm", 1), ("Mesh.Smoothing", smooth)):
        gmsh.option.setNumber(opt, val)
    for ln in lines:   # keep the outline resolution: one element per resampled segment (halved)
        gmsh.model.mesh.setTransfiniteCurve(ln, 2)


def _periodic_mesh(pair, i, outline, outline_size, body_size, grading, algo, blossom, smooth):
    """One tooth's sector meshed with alike radial cuts (gmsh periodic curves), copied to every tooth and
    merged at the cuts. ``outline`` holds ``z`` rotated copies of the first tooth's points."""
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree
    from scipy.sparse import coo_matrix

    from gearrom.fe.mesh2d import gmsh_session
    from gearrom.geometry.profile import rotate

    z = pair.gears[i].z
    pitch = 2 * math.pi / z
    n = outline.shape[0] // z
    tooth = np.vstack([outline[:n], rotate(outline[:1], -pitch)])   # root middle to root middle
    rb = 0.5 * pair.gears[i].bore_diameter
    with gmsh_session(f"quadsector{i}") as gmsh:
        geo = gmsh.model.geo
        pts = [geo.addPoint(x, y, 0.0) for x, y in tooth]
        lines = [geo.addLine(pts[k], pts[k + 1]) for k in range(len(pts) - 1)]
        c0 = geo.addPoint(0.0, 0.0, 0.0)
        b0, b1 = (geo.addPoint(*(rb * p / np.hypot(*p)), 0.0) for p in (tooth[0], tooth[-1]))
        cut0, cut1 = geo.addLine(b0, pts[0]), geo.addLine(b1, pts[-1])      # both from the bore outwards
        arc = geo.addCircleArc(b1, c0, b0)
        geo.addPlaneSurface([geo.addCurveLoop(lines + [-cut1, arc, cut0])])
        geo.synchronize()
        c, s = math.cos(-pitch), math.sin(-pitch)
        gmsh.model.mesh.setPeriodic(1, [cut1], [cut0], [c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])
        _quad_options(gmsh, lines, outline_size, body_size, grading, algo, blossom, smooth)
        xy, quads, index = _generate(gmsh, f"the tooth sector of gear {i}")
        bore = np.unique(np.concatenate([index[nodes.astype(np.int64)]
                                         for _, _, nodes in zip(*gmsh.model.mesh.getElements(1, arc))]))
    xy, quads, bore = _compact(xy, quads, bore)
    m = xy.shape[0]
    allxy = np.vstack([rotate(xy, -k * pitch) for k in range(z)])
    allq = np.vstack([quads + k * m for k in range(z)])
    allbore = np.concatenate([bore + k * m for k in range(z)])
    # merge the coincident nodes of neighbouring sectors' cuts
    pairs = cKDTree(allxy).query_pairs(1e-9 * rb, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(allxy),) * 2)
    _, label = connected_components(graph, directed=False)
    first = np.full(label.max() + 1, -1, np.int64)
    for k in range(len(label) - 1, -1, -1):
        first[label[k]] = k
    keep = np.unique(first)
    new = np.full(len(allxy), -1, np.int64)
    new[keep] = np.arange(keep.size)
    idx = new[first[label]]
    return allxy[keep], _counter_clockwise(allxy[keep], idx[allq]), np.unique(idx[allbore])


def _generate(gmsh, what: str):
    """Mesh the open gmsh model in 2D: nodes, quads and the node tag -> row index."""
    from gearrom.fe.mesh2d import surface_elements

    try:
        gmsh.model.mesh.generate(2)
    except Exception as exc:  # gmsh raises plain Exception
        raise MeshError(f"gmsh failed to mesh {what}: {exc}") from None
    return surface_elements(gmsh, 3, f" for {what}")


def _compact(xy, quads, bore):
    """Drop the nodes no quad uses (gmsh keeps geometry points such as the arc centre)."""
    used = np.unique(quads)
    remap = np.full(xy.shape[0], -1, np.int64)
    remap[used] = np.arange(used.size)
    bore = remap[bore]
    return xy[used], remap[quads], bore[bore >= 0]


def _counter_clockwise(xy, quads):
    """``quads`` all counter-clockwise (gmsh orients all elements alike: flip all, never one by one)."""
    p = xy[quads]
    area = 0.5 * np.sum(p[:, :, 0] * np.roll(p[:, :, 1], -1, axis=1) - np.roll(p[:, :, 0], -1, axis=1) * p[:, :, 1], axis=1)
    return quads[:, ::-1] if np.median(area) < 0 else quads


def _mesh(pair, i, outline, outline_size, body_size, grading, algo, blossom, smooth):
    from gearrom.fe.mesh2d import add_bore_surface, gmsh_session

    rb = 0.5 * pair.gears[i].bore_diameter
    with gmsh_session(f"quadgear{i}") as gmsh:
        geo = gmsh.model.geo
        pts = [geo.addPoint(x, y, 0.0) for x, y in outline]
        lines = [geo.addLine(pts[k], pts[(k + 1) % len(pts)]) for k in range(len(pts))]
        outer = geo.addCurveLoop(lines)
        arcs = add_bore_surface(geo, outer, rb)
        _quad_options(gmsh, lines, outline_size, body_size, grading, algo, blossom, smooth)
        xy, quads, index = _generate(gmsh, f"gear {i}")
        bore = []
        for c in arcs:
            for _, _, nodes in zip(*gmsh.model.mesh.getElements(1, c)):
                bore.append(index[nodes.astype(np.int64)])
        bore = np.unique(np.concatenate(bore))
    xy, quads, bore = _compact(xy, quads, bore)
    return xy, _counter_clockwise(xy, quads), bore
