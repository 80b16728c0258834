"""Plane (transverse) triangle meshes with gmsh: a whole gear with graded flanks, and a test disk.

The outline of a gear is built from :func:`gearrom.geometry.profile.tooth_profile`, one spline per
profile segment (root arc, fillet, involute, tip edge rounding, tip), so the mesh density is independent of the number
of profile points and the nodes lie on the generated curves. The loaded ("right", x > 0 in the frame
of each tooth) flank of the refined teeth gets elements of ``flank_size``; the size grows to
``tooth_size`` inside those teeth and to ``body_size`` elsewhere.

Tooth numbering: tooth ``j`` is tooth 0 (centred on +y) rotated by ``+j * 2 pi / z``
(counter-clockwise). The rigid bore circle is returned as ``bore_nodes``.
"""
from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
from dataclasses import dataclass, field

import numpy as np

from gearrom.errors import MeshError

log = logging.getLogger(__name__)

SEGMENT_NAMES = ("root", "fillet", "involute", "tip", "edge")
"""Curve names by profile segment label; ``"edge"`` (4) is the tip edge rounding (see :func:`gear_mesh`)."""


@dataclass(frozen=True)
class MeshSettings:
    """Mesh density of a gear (lengths in m).

    Parameters
    ----------
    flank_size : float
        Element size on the loaded flank (and its tip edge rounding) of the refined teeth [m]. It
        must resolve the Hertz half-width (~0.1 mm at nominal load): the refinement study picks the
        default (benchmarks/bench_stiffness_refinement.py, spur pair at 120 N m, all sizes scaled
        from 0.05 to 0.0125 mm: with 0.025 mm the mean stiffness is 0.4 % above its Richardson
        value and the STE peak-to-peak 0.3 % below the finest mesh's).
    tooth_size : float
        Element size inside the refined teeth and on their fillets [m].
    body_size : float
        Element size in the rim, the hub and the other teeth [m].
    refined_teeth : int
        Teeth ``-n..n`` get the fine flank. The influence coefficients load tooth 0 only, so 0
        suffices for them; the full-contact cross-check needs 1 (every pair in contact refined).
    near_teeth : int
        Teeth ``-n..n`` get ``tooth_size`` (elastic neighbours of the loaded teeth).
    grading : float
        Distance over which the flank size grows to the tooth size [m].
    """

    flank_size: float = 0.025e-3
    tooth_size: float = 0.35e-3
    body_size: float = 2.5e-3
    refined_teeth: int = 0
    near_teeth: int = 3
    grading: float = 0.8e-3

    def __post_init__(self) -> None:
        for name in ("flank_size", "tooth_size", "body_size", "grading"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise MeshError(f"fe.mesh.{name} must be a positive length, got {v!r}")
        if not self.flank_size <= self.tooth_size <= self.body_size:
            raise MeshError(
                f"fe.mesh sizes must satisfy flank_size <= tooth_size <= body_size, got "
                f"{self.flank_size:.3g} / {self.tooth_size:.3g} / {self.body_size:.3g} m"
            )
        if self.refined_teeth < 0 or self.near_teeth < max(self.refined_teeth, 2):
            raise MeshError(
                f"fe.mesh needs 0 <= refined_teeth <= near_teeth and near_teeth >= 2, got {self.refined_teeth}, {self.near_teeth}"
            )

    def scaled(self, factor: float) -> "MeshSettings":
        """All sizes multiplied by ``factor`` (refinement studies)."""
        return MeshSettings(self.flank_size * factor, self.tooth_size * factor, self.body_size * factor,
                            self.refined_teeth, self.near_teeth, self.grading)


@dataclass(frozen=True, eq=False)
class Mesh2D:
    """Linear triangle mesh plus named boundary curves.

    Attributes
    ----------
    points : ndarray (n, 2)
        Node coordinates [m].
    triangles : ndarray (m, 3)
        Node indices, counter-clockwise.
    curves : dict[str, ndarray (k, 2)]
        Boundary edges (node index pairs) of named curves, e.g. ``"involute_r_0"`` (right flank of tooth 0).
    bore_nodes : ndarray of int
        Nodes on the bore (tied to the rigid reference node).
    """

    points: np.ndarray
    triangles: np.ndarray
    curves: dict[str, np.ndarray] = field(default_factory=dict)
    bore_nodes: np.ndarray = field(default_factory=lambda: np.zeros(0, int))

    def quality(self) -> np.ndarray:
        """Per-triangle quality 4 sqrt(3) A / sum(l^2) (1 equilateral, 0 degenerate)."""
        p = self.points[self.triangles]
        e = np.roll(p, -1, axis=1) - p
        area = 0.5 * (e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0])
        return 4 * math.sqrt(3) * area / np.sum(e**2, axis=(1, 2))

    def check(self, min_quality: float = 0.05) -> None:
        """Raise :class:`MeshError` on inverted or degenerate triangles."""
        q = self.quality()
        bad = np.flatnonzero(q < min_quality)
        if bad.size:
            k = int(bad[np.argmin(q[bad])])
            c = self.points[self.triangles[k]].mean(axis=0) * 1e3
            raise MeshError(
                f"{bad.size} degenerate or inverted triangles (quality < {min_quality}); worst {q[k]:.3g} "
                f"at ({c[0]:.3f}, {c[1]:.3f}) mm"
            )


@contextlib.contextmanager
def gmsh_session(name: str):
    """Initialise gmsh if needed, yield, and clean up (finalise only what we initialised)."""
    import gmsh

    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(interruptible=False)
    verbose = bool(os.environ.get("GEARROM_GMSH_VERBOSE"))  # debugging aid: gmsh's own log on stdout
    gmsh.option.setNumber("General.Terminal", 1 if verbose else 0)
    gmsh.option.setNumber("General.Verbosity", 5 if verbose else 1)
    gmsh.model.add(name)
    try:
        yield gmsh
    finally:
        gmsh.model.remove()
        if own:
            gmsh.finalize()


def add_bore_surface(geo, outer: int, bore_radius: float) -> list[int]:
    """Add the plane surface between the curve loop ``outer`` and a bore circle of ``bore_radius`` [m] (four
    arcs about the origin) to the gmsh ``geo`` kernel and synchronize; returns the arcs' tags."""
    c0 = geo.addPoint(0, 0, 0)
    q = [geo.addPoint(bore_radius * math.cos(a), bore_radius * math.sin(a), 0) for a in np.arange(4) * math.pi / 2]
    arcs = [geo.addCircleArc(q[n], c0, q[(n + 1) % 4]) for n in range(4)]
    geo.addPlaneSurface([outer, geo.addCurveLoop(arcs)])
    geo.synchronize()
    return arcs


def surface_elements(gmsh, etype: int, what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nodes (x, y) and 2D elements of the open gmsh model: ``(points, connectivity, tag -> row index)``.

    ``etype``: the gmsh element type every 2D element must have (2: 3-node triangle, 3: 4-node quad);
    ``what`` names the mesh in the error.

    Raises
    ------
    MeshError
        gmsh produced another element type.
    """
    tags, coords, _ = gmsh.model.mesh.getNodes()
    pts = coords.reshape(-1, 3)[:, :2]
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(tags.size)
    n_nodes = {2: 3, 3: 4}[etype]
    conn = []
    for et, _, nodes in zip(*gmsh.model.mesh.getElements(2)):
        if et != etype:
            raise MeshError(f"gmsh produced element type {et}{what}; expected {n_nodes}-node "
                            f"{'triangles' if etype == 2 else 'quads'}")
        conn.append(index[nodes.astype(np.int64)].reshape(-1, n_nodes))
    return pts, np.vstack(conn), index


def extract_mesh(gmsh, named: dict[str, list[int]], bore_curves: list[int]) -> Mesh2D:
    """The generated 2D triangle mesh of the open gmsh model as a checked :class:`Mesh2D`: unused nodes
    dropped, triangles counter-clockwise, boundary edges of each named curve group and the bore nodes."""
    pts, tri, index = surface_elements(gmsh, 2, "")
    used = np.unique(tri)
    remap = np.full(pts.shape[0], -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    pts, tri = pts[used], remap[tri]
    p = pts[tri]
    area = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
    tri[area < 0] = tri[area < 0][:, ::-1]

    def edges_of(curve_tags: list[int]) -> np.ndarray:
        out = []
        for c in curve_tags:
            for etype, _, nodes in zip(*gmsh.model.mesh.getElements(1, c)):
                out.append(remap[index[nodes.astype(np.int64)]].reshape(-1, 2))
        return np.vstack(out) if out else np.zeros((0, 2), int)

    curves = {name: edges_of(c) for name, c in named.items()}
    bore = np.unique(edges_of(bore_curves))
    mesh = Mesh2D(points=pts, triangles=tri, curves=curves, bore_nodes=bore)
    mesh.check()
    return mesh


def threshold_field(gmsh, curve_tags: list[int], size_min: float, size_max: float, d_min: float, d_max: float,
                    sampling: int = 400) -> int:
    """A gmsh size field [m]: ``size_min`` within ``d_min`` of the curves, growing to ``size_max`` at ``d_max``
    (distances from ``sampling`` points per curve); returns the field tag."""
    f = gmsh.model.mesh.field
    dist = f.add("Distance")
    f.setNumbers(dist, "CurvesList", curve_tags)
    f.setNumber(dist, "Sampling", sampling)
    th = f.add("Threshold")
    f.setNumber(th, "InField", dist)
    f.setNumber(th, "SizeMin", size_min)
    f.setNumber(th, "SizeMax", size_max)
    f.setNumber(th, "DistMin", d_min)
    f.setNumber(th, "DistMax", d_max)
    return th


def finish_mesh(gmsh, fields: list[int], algorithm: int = 6) -> None:
    """Mesh the open gmsh model in 2D with the minimum of the size ``fields`` as the only size source."""
    f = gmsh.model.mesh.field
    mn = f.add("Min")
    f.setNumbers(mn, "FieldsList", fields)
    f.setAsBackgroundMesh(mn)
    for opt, val in (("Mesh.MeshSizeExtendFromBoundary", 0), ("Mesh.MeshSizeFromPoints", 0),
                     ("Mesh.MeshSizeFromCurvature", 0), ("Mesh.Algorithm", algorithm)):
        gmsh.option.setNumber(opt, val)
    try:
        gmsh.model.mesh.generate(2)
    except Exception as exc:  # gmsh raises plain Exception
        raise MeshError(f"gmsh failed to mesh: {exc}") from None


def clean_profile(prof):
    """Adapter: order the root + fillet points of the left half by polar angle (descending).

    ``tooth_profile`` sorts the fillet by radius, which scrambles the points that lie on the
    root circle (equal radii) into a self-intersecting outline. Sorting the left half's root
    and fillet points by polar angle (from the space middle towards the flank) and dropping
    near-duplicates gives a simple polygon; the right half is the mirror image.
    """
    from gearrom.geometry.profile import ToothProfile

    left = prof.side < 0
    pts, seg, roll = prof.points[left], prof.segment[left], prof.roll[left]
    low = seg <= 1
    ang = np.arctan2(pts[low, 1], pts[low, 0])
    order = np.argsort(-ang, kind="stable")
    lp, ls, lr = pts[low][order], seg[low][order], roll[low][order]
    keep = np.concatenate([[True], np.hypot(*np.diff(lp, axis=0).T) > 1e-7])
    lp = lp[keep]
    hp = pts[~low]
    if np.hypot(*(lp[-1] - hp[0])) < 1e-7:
        lp = lp[:-1]
    # resample root + fillet uniformly in arc length; the root arc is where r stays at r_root
    chain = np.vstack([lp, hp[:1]])
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(chain, axis=0).T))])
    t = np.linspace(0.0, arc[-1], 49)[:-1]
    lp = np.column_stack([np.interp(t, arc, chain[:, 0]), np.interp(t, arc, chain[:, 1])])
    r = np.hypot(lp[:, 0], lp[:, 1])
    on_root = r < r.min() + 1e-3 * (r.max() - r.min() + 1e-12)
    last_root = int(np.flatnonzero(on_root).max()) if on_root.any() else 0
    ls = np.where(np.arange(lp.shape[0]) <= max(last_root, 1), 0, 1)
    lr = np.full(lp.shape[0], np.nan)
    L_pts = np.vstack([lp, hp])
    L_seg = np.concatenate([ls, seg[~low]])
    L_roll = np.concatenate([lr, roll[~low]])
    R_pts = L_pts[::-1][1:] * np.array([-1.0, 1.0])
    return ToothProfile(
        points=np.vstack([L_pts, R_pts]), segment=np.concatenate([L_seg, L_seg[::-1][1:]]),
        roll=np.concatenate([L_roll, L_roll[::-1][1:]]),
        side=np.concatenate([np.full(len(L_pts), -1), np.full(len(R_pts), 1)]), form_radius=prof.form_radius,
    )


clean_profile = clean_profile  # old private name (kept for gearrom.fe.explicit.gearmesh)


def gear_mesh(pair, i: int, settings: MeshSettings | None = None, tip_edge_radius: float | None = None) -> Mesh2D:
    """Mesh the whole transverse section of gear ``i`` of ``pair`` (bore to tip).

    The tip edges are rounded (:mod:`gearrom.fe.tipedge`); the rounding of the loaded flank of the
    refined teeth is meshed as finely as the flank (curves ``"edge_r_{j}"``).

    Parameters
    ----------
    pair : GearPair
        Gear pair (helical pairs: the transverse section).
    i : int
        0 input gear, 1 output gear.
    settings : MeshSettings
        Mesh density.
    tip_edge_radius : float, optional
        Tip edge rounding radius [m]; default :func:`gearrom.fe.tipedge.tip_edge_radius` (the
        config's value, else 0.1 m_n). 0 gives sharp tip corners.

    Returns
    -------
    Mesh2D
        Curves ``"{segment}_{l|r}_{j}"`` for the teeth ``|j| <= near_teeth`` (segments
        :data:`SEGMENT_NAMES`).
    """
    from gearrom.fe.tipedge import tip_edge_radius as edge_radius
    from gearrom.geometry.profile import rotate, tooth_profile

    s = settings or MeshSettings()
    g = pair.gears[i]
    z = g.z
    rho = edge_radius(pair, i)[0] if tip_edge_radius is None else tip_edge_radius
    prof = clean_profile(tooth_profile(pair, i, n_involute=80, n_fillet=40, n_tip=12, n_root=8, tip_edge_radius=rho))
    # label the tip edge rounding (tip segment below the tip circle) as its own segment
    ra = 0.5 * pair.da[i]
    on_edge = (prof.segment == 3) & (np.hypot(prof.points[:, 0], prof.points[:, 1]) < ra * (1 - 1e-9))
    prof = dataclasses.replace(prof, segment=np.where(on_edge, 4, prof.segment))
    with gmsh_session(f"gear{i}") as gmsh:
        geo = gmsh.model.geo
        # split each tooth outline into runs of equal (segment, side)
        keys = list(zip(prof.segment, prof.side))
        runs, start = [], 0
        for k in range(1, len(keys)):
            if keys[k] != keys[start]:
                runs.append((start, k, keys[start]))
                start = k
        runs.append((start, len(keys) - 1, keys[start]))
        named: dict[str, list[int]] = {}
        curve_loop: list[int] = []
        first_point = None
        prev_point = None
        for k in range(z):  # clockwise: tooth index j = -k (mod z)
            j = -k if k <= z // 2 else z - k
            pts = rotate(prof.points, -k * 2 * math.pi / z)
            tags = []
            for n, p in enumerate(pts):
                if n == 0 and prev_point is not None:
                    tags.append(prev_point)
                elif k == z - 1 and n == len(pts) - 1:
                    tags.append(first_point)
                else:
                    tags.append(geo.addPoint(p[0], p[1], 0.0))
            if first_point is None:
                first_point = tags[0]
            prev_point = tags[-1]
            for a, b, (seg, side) in runs:
                ids = tags[a:b + 1]
                if len(ids) < 2:
                    continue
                c = geo.addSpline(ids) if len(ids) > 2 else geo.addLine(*ids)
                curve_loop.append(c)
                if abs(j) <= s.near_teeth:
                    named.setdefault(f"{SEGMENT_NAMES[seg]}_{'r' if side > 0 else 'l'}_{j}", []).append(c)
        outer = geo.addCurveLoop(curve_loop)
        arcs = add_bore_surface(geo, outer, 0.5 * g.bore_diameter)
        fine = [c for j in range(-s.refined_teeth, s.refined_teeth + 1) for n in ("involute_r", "edge_r")
                for c in named.get(f"{n}_{j}", [])]
        fillets = [c for j in range(-s.refined_teeth, s.refined_teeth + 1)
                   for n in ("fillet_r", "fillet_l", "root_r", "root_l") for c in named.get(f"{n}_{j}", [])]
        near = [c for key, cs in named.items() for c in cs]
        fields = [
            threshold_field(gmsh, fine, s.flank_size, s.tooth_size, 2 * s.flank_size, s.grading),
            threshold_field(gmsh, fillets, 0.5 * s.tooth_size, s.body_size, 0.3e-3, 3e-3),
            threshold_field(gmsh, near, s.tooth_size, s.body_size, 0.2 * pair.mn, 3 * pair.mn),
        ]
        finish_mesh(gmsh, fields)
        mesh = extract_mesh(gmsh, named, arcs)
    log.info("gear %d mesh: %d nodes, %d triangles", i, mesh.points.shape[0], mesh.triangles.shape[0])
    return mesh


def disk_mesh(radius: float, bore: float, fine_size: float, coarse_size: float, fine_zone: float) -> Mesh2D:
    """A disk (annulus) with a fine mesh around its top point (0, radius): the Hertz test body.

    The curve ``"contact"`` is the arc within ``fine_zone`` (arc length) of the top point.
    """
    with gmsh_session("disk") as gmsh:
        geo = gmsh.model.geo
        c0 = geo.addPoint(0, 0, 0)
        half = fine_zone / radius
        angles = [math.pi / 2 - half, math.pi / 2 + half, 3 * math.pi / 2]
        po = [geo.addPoint(radius * math.cos(a), radius * math.sin(a), 0) for a in angles]
        contact = geo.addCircleArc(po[0], c0, po[1])
        rest = [geo.addCircleArc(po[1], c0, po[2]), geo.addCircleArc(po[2], c0, po[0])]
        outer = geo.addCurveLoop([contact, *rest])
        pi_ = [geo.addPoint(bore * math.cos(a), bore * math.sin(a), 0) for a in np.arange(4) * math.pi / 2]
        arcs = [geo.addCircleArc(pi_[n], c0, pi_[(n + 1) % 4]) for n in range(4)]
        geo.addPlaneSurface([outer, geo.addCurveLoop(arcs)])
        geo.synchronize()
        fields = [threshold_field(gmsh, [contact], fine_size, coarse_size, fine_zone, 0.5 * radius)]
        finish_mesh(gmsh, fields)
        return extract_mesh(gmsh, {"contact": [contact]}, arcs)


FE_SECTION_KEYS = {
    "flank_size_mm": "element size on the loaded flank [mm]",
    "tooth_size_mm": "element size in the refined teeth [mm]",
    "body_size_mm": "element size in the body [mm]",
    "refined_teeth": "teeth -n..n with the fine flank [-]",
    "near_teeth": "teeth -n..n with the tooth size [-]",
    "positions": "mesh positions per mesh cycle [-]",
    "torques_Nm": "output torques of the torque map [N m]",
}


def settings_from_section(section: dict, source: str = "config") -> tuple[MeshSettings, dict]:
    """Mesh settings from a config's ``[fe]`` section; returns (settings, other keys).

    Raises
    ------
    ConfigError
        Unknown key or a value of the wrong type.
    """
    from gearrom.errors import ConfigError

    d = MeshSettings()
    kw = {}
    for key, value in section.items():
        if key not in FE_SECTION_KEYS:
            raise ConfigError(f"{source}: unknown key 'fe.{key}' (known: {', '.join(FE_SECTION_KEYS)})")
        if key.endswith("_mm"):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ConfigError(f"{source}: fe.{key} must be a number, got {value!r}")
            kw[key[:-3]] = float(value) * 1e-3
        elif key in ("refined_teeth", "near_teeth"):
            if not isinstance(value, int) or isinstance(value, bool):
                raise ConfigError(f"{source}: fe.{key} must be an integer, got {value!r}")
            kw[key] = value
    base = {k: getattr(d, k) for k in ("flank_size", "tooth_size", "body_size", "refined_teeth", "near_teeth", "grading")}
    base.update(kw)
    try:
        settings = MeshSettings(**base)
    except MeshError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    rest = {k: v for k, v in section.items() if k in ("positions", "torques_Nm")}
    return settings, rest
