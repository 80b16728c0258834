"""3D meshes of helical gears with an elastic tooth sector: a graded transverse mesh extruded with the helix twist.

The whole transverse section (profile from the rack envelope,
:func:`gearrom.geometry.profile.tooth_profile`, bore circle) is meshed with gmsh (3-node
triangles): ``flank_size`` on the loaded (right) flank of tooth 0, ``tooth_size`` in the sector
teeth ``-n..n``, ``body_size`` in the rim and the other teeth (coarse, 1-2 elements across). The
full ring is kept on purpose: a sector cut free at two radial faces and tied to the bore only
along its own arc is 2-3 times too compliant in the body (measured against the plane-strain full
gear of :mod:`gearrom.fe.compliance`: the tooth-to-neighbour coupling was 6.5e-9 against
2-3e-9 m/N per N), because the rim carries the torque around to the whole bore.
The triangle mesh is then extruded layer by layer over the face width: layer ``k`` at axial
position ``zeta_k`` is the section rotated by the helix twist
:func:`gearrom.geometry.profile.twist` (so the flanks are involute helicoids up to the chord
error of the layers), and every prism between two layers is split into three tetrahedra with the
diagonal rule "from the upper node of the lower-index vertex", which keeps the faces conforming.
The FE model uses quadratic tetrahedra on this mesh (:mod:`gearrom.fe.elastic3d`).

Frames: gear centre at the origin, axis +z, face width centred on z = 0; tooth ``j`` is tooth 0
(centred on +y at z = 0) rotated by ``+j 2 pi / z`` (counter-clockwise), as in :mod:`~gearrom.fe.mesh2d`.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from gearrom.errors import MeshError
from gearrom.fe.mesh2d import SEGMENT_NAMES, Mesh2D, clean_profile, extract_mesh, finish_mesh, threshold_field, gmsh_session

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Mesh3DSettings:
    """Density of a 3D helical sector mesh (lengths in m).

    The default is the coarsest level of the refinement study
    (``benchmarks/bench_stiffness_helical3d_refinement.py``, thesis-helical at 120 N m): its mean
    stiffness, mean STE and STE peak-to-peak are within 0.7 %, 0.7 % and 0.004 um of a 1.6 times
    finer mesh (232k / 345k dofs). The near field is analytical, so the flank mesh does not have to
    resolve the Hertz zone.

    Parameters
    ----------
    flank_size : float
        Element size on the loaded flank of tooth 0 (the loaded tooth of the influence coefficients).
        The Hertz zone is NOT resolved: the near field is analytical (:mod:`gearrom.fe.compliance3d`).
    tooth_size, body_size : float
        Element size in the teeth of the sector and in the rim.
    layer : float
        Target layer thickness of the extrusion over the face width.
    teeth : int
        Teeth ``-teeth..teeth`` in the sector (2 teeth: 5-tooth sector, 3: 7-tooth sector).
    grading : float
        Distance over which the flank size grows to the tooth size.
    refined_teeth : int
        The loaded flanks of teeth ``-n..n`` get ``flank_size`` (0: tooth 0 only, the loaded tooth of
        the influence coefficients; a CalculiX deck, which resolves every contact in its own mesh,
        refines every tooth that can touch).
    """

    flank_size: float = 0.72e-3
    tooth_size: float = 1.28e-3
    body_size: float = 4.8e-3
    layer: float = 1.44e-3
    teeth: int = 3
    grading: float = 1.2e-3
    refined_teeth: int = 0

    def __post_init__(self) -> None:
        for name in ("flank_size", "tooth_size", "body_size", "layer", "grading"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and v > 0 and math.isfinite(v)):
                raise MeshError(f"fe.mesh3d.{name} must be a positive length, got {v!r}")
        if not self.flank_size <= self.tooth_size <= self.body_size:
            raise MeshError(f"fe.mesh3d sizes must satisfy flank_size <= tooth_size <= body_size, got "
                            f"{self.flank_size:.3g} / {self.tooth_size:.3g} / {self.body_size:.3g} m")
        if not isinstance(self.teeth, int) or not 2 <= self.teeth <= 4:
            raise MeshError(f"fe.mesh3d.teeth must be 2, 3 or 4 (a 5- to 9-tooth sector), got {self.teeth!r}")
        if not isinstance(self.refined_teeth, int) or not 0 <= self.refined_teeth <= self.teeth:
            raise MeshError(f"fe.mesh3d.refined_teeth must be in 0..teeth = {self.teeth}, got {self.refined_teeth!r}")

    def scaled(self, factor: float) -> "Mesh3DSettings":
        """All lengths times ``factor`` (refinement studies)."""
        return Mesh3DSettings(self.flank_size * factor, self.tooth_size * factor, self.body_size * factor,
                              self.layer * factor, self.teeth, self.grading, self.refined_teeth)


@dataclass(frozen=True, eq=False)
class Mesh3D:
    """Linear tetrahedral mesh of a helical gear (elastic sector teeth ``-n..n``).

    Attributes
    ----------
    points : ndarray (n, 3)
        Node coordinates [m].
    tets : ndarray (m, 4)
        Node indices (positive volume).
    section : Mesh2D
        The transverse (z = 0 section) triangle mesh that was extruded.
    zeta : ndarray (nl + 1,)
        Axial positions of the layers [m].
    bore_nodes : ndarray of int
        Nodes on the bore surface (tied to the rigid reference node).
    flank_nodes : dict[str, ndarray]
        Nodes of named section curves over all layers (e.g. ``"involute_r_0"``).
    """

    points: np.ndarray
    tets: np.ndarray
    section: Mesh2D
    zeta: np.ndarray
    bore_nodes: np.ndarray
    flank_nodes: dict = field(default_factory=dict)

    def volumes(self) -> np.ndarray:
        p = self.points[self.tets]
        return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6.0

    def check(self) -> None:
        """Raise :class:`MeshError` on inverted or degenerate tetrahedra."""
        v = self.volumes()
        p = self.points[self.tets]
        edges = np.stack([p[:, a] - p[:, b] for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))], 1)
        lmax = np.linalg.norm(edges, axis=2).max(axis=1)
        q = 6 * math.sqrt(2) * v / lmax**3  # 1 for the regular tetrahedron
        bad = np.flatnonzero(q < 1e-3)
        if bad.size:
            c = p[bad[0]].mean(axis=0) * 1e3
            raise MeshError(f"{bad.size} degenerate or inverted tetrahedra; first at ({c[0]:.3f}, {c[1]:.3f}, {c[2]:.3f}) mm")


def section_mesh(pair, i: int, s: Mesh3DSettings) -> Mesh2D:
    """Transverse mesh of gear ``i``: sector teeth ``-s.teeth..s.teeth`` at tooth size (named curves), the rest coarse."""
    from gearrom.geometry.profile import rotate, tooth_profile

    g = pair.gears[i]
    z = g.z
    n = s.teeth
    if 2 * n + 1 > z // 2:
        raise MeshError(f"gear {i}: a {2 * n + 1}-tooth elastic sector needs z >= {2 * (2 * n + 1)}, got {z}")
    prof = clean_profile(tooth_profile(pair, i, n_involute=60, n_fillet=30, n_tip=6, n_root=6))
    keys = list(zip(prof.segment, prof.side))
    runs, start = [], 0
    for k in range(1, len(keys)):
        if keys[k] != keys[start]:
            runs.append((start, k, keys[start]))
            start = k
    runs.append((start, len(keys) - 1, keys[start]))
    with gmsh_session(f"sector{i}") as gmsh:
        geo = gmsh.model.geo
        named: dict[str, list[int]] = {}
        loop: list[int] = []
        prev = first = None
        for j in range(n, -n - 1, -1):  # clockwise over the sector teeth
            pts = rotate(prof.points, j * 2 * math.pi / z)
            tags = [prev if (m == 0 and prev is not None) else geo.addPoint(p[0], p[1], 0.0) for m, p in enumerate(pts)]
            first = first or tags[0]
            prev = tags[-1]
            for a, b, (seg, side) in runs:
                ids = tags[a:b + 1]
                if len(ids) < 2:
                    continue
                c = geo.addSpline(ids) if len(ids) > 2 else geo.addLine(*ids)
                loop.append(c)
                named.setdefault(f"{SEGMENT_NAMES[seg]}_{'r' if side > 0 else 'l'}_{j}", []).append(c)
        # the rest of the ring: the root circle through the outer space middles (no teeth)
        c0 = geo.addPoint(0, 0, 0)
        p_end = rotate(prof.points[-1:], -n * 2 * math.pi / z)[0]
        r_root = float(np.hypot(*p_end))
        a_end = math.atan2(p_end[1], p_end[0])
        span = 2 * math.pi - (2 * n + 1) * 2 * math.pi / z
        mids = [geo.addPoint(r_root * math.cos(a_end - f * span), r_root * math.sin(a_end - f * span), 0)
                for f in (1 / 3, 2 / 3)]
        chain = [prev, *mids, first]
        loop += [geo.addCircleArc(chain[m], c0, chain[m + 1]) for m in range(3)]
        rbore = 0.5 * g.bore_diameter
        q = [geo.addPoint(rbore * math.cos(a), rbore * math.sin(a), 0) for a in np.arange(4) * math.pi / 2]
        bore = [geo.addCircleArc(q[m], c0, q[(m + 1) % 4]) for m in range(4)]
        geo.addPlaneSurface([geo.addCurveLoop(loop), geo.addCurveLoop(bore)])
        geo.synchronize()
        fine = [c for j in range(-s.refined_teeth, s.refined_teeth + 1) for c in named.get(f"involute_r_{j}", [])]
        fillet0 = [c for key in ("fillet_r_0", "root_r_0", "fillet_l_0", "root_l_0") for c in named.get(key, [])]
        teeth = [c for cs in named.values() for c in cs]
        fields = [
            threshold_field(gmsh, fine, s.flank_size, s.tooth_size, 1.5 * s.flank_size, s.grading),
            threshold_field(gmsh, fillet0, s.tooth_size, s.body_size, 0.3e-3, 2e-3),
            threshold_field(gmsh, teeth, s.tooth_size, s.body_size, 0.1 * pair.mn, 1.5 * pair.mn),
        ]
        for f in fields[:2]:  # the fine fields stop at their DistMax (else their SizeMax caps the body)
            gmsh.model.mesh.field.setNumber(f, "StopAtDistMax", 1)
        gmsh.option.setNumber("Mesh.MeshSizeMax", s.body_size)
        finish_mesh(gmsh, fields)
        mesh = extract_mesh(gmsh, named, bore)
    return mesh


def extrude(section: Mesh2D, pair, i: int, layer: float) -> Mesh3D:
    """Extrude a transverse mesh over gear ``i``'s face width with the helix twist (see module doc)."""
    from gearrom.geometry.profile import twist

    b = pair.gears[i].face_width
    nl = max(2, int(math.ceil(b / layer - 1e-9)))
    zeta = np.linspace(-0.5 * b, 0.5 * b, nl + 1)
    p2 = section.points
    nv = p2.shape[0]
    pts = np.empty(((nl + 1) * nv, 3))
    for k, zk in enumerate(zeta):
        a = float(twist(pair, i, zk))
        c, sn = math.cos(a), math.sin(a)
        pts[k * nv:(k + 1) * nv] = np.column_stack([c * p2[:, 0] - sn * p2[:, 1], sn * p2[:, 0] + c * p2[:, 1],
                                                     np.full(nv, zk)])
    tri = np.sort(section.triangles, axis=1)  # a < b < c: conforming prism split
    a, b_, c = tri.T
    tets = []
    for k in range(nl):
        lo, up = k * nv, (k + 1) * nv
        tets += [np.column_stack([a + lo, b_ + lo, c + lo, a + up]),
                 np.column_stack([b_ + lo, c + lo, a + up, b_ + up]),
                 np.column_stack([c + lo, a + up, b_ + up, c + up])]
    tets = np.vstack(tets)
    p = pts[tets]
    vol = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    neg = vol < 0
    tets[neg] = tets[neg][:, [1, 0, 2, 3]]
    layers = np.arange(nl + 1)[:, None] * nv
    bore = (section.bore_nodes[None, :] + layers).ravel()
    flank = {name: (np.unique(e)[None, :] + layers).ravel() for name, e in section.curves.items()}
    mesh = Mesh3D(points=pts, tets=tets, section=section, zeta=zeta, bore_nodes=bore, flank_nodes=flank)
    mesh.check()
    return mesh


def sector_mesh(pair, i: int, settings: Mesh3DSettings | None = None) -> Mesh3D:
    """Mesh the helical sector of gear ``i`` (see module doc)."""
    s = settings or Mesh3DSettings()
    section = section_mesh(pair, i, s)
    mesh = extrude(section, pair, i, s.layer)
    log.info("gear %d 3D sector: %d nodes, %d tets (%d layers)", i, mesh.points.shape[0], mesh.tets.shape[0],
             mesh.zeta.size - 1)
    return mesh
