"""Exports of the loaded FE state: VTU (meshio, for ParaView) and an Abaqus/CalculiX input deck.

* :func:`export_vtu` re-solves both gear bodies under the LTCA contact forces of one position and
  writes the two deformed-ready meshes in the global frame (gear 1 centre at the origin, gear 2 at
  (0, a_w)) with point data ``displacement`` [m], ``contact_pressure`` [Pa], ``von_mises`` [Pa], ``gear``
  (helical pairs: the 3D model's tetrahedral gears, :mod:`gearrom.fe.loaded3d`).
* :func:`export_inp` writes the model of one mesh position as an Abaqus input deck in mm, N, MPa
  (helical pairs: the 3D sector model, :mod:`gearrom.fe.export3d`); spur pairs:
  both gears as a plane-strain slab of thickness b (one layer of 15-node wedges C3D15 extruded
  from the quadratic triangles, u_z = 0), the input bore on a rigid body (REF/ROT node) loaded by
  the driving moment, the output bore clamped, a surface-to-surface contact pair on the flanks of
  the teeth -1..1 (penalty, linear pressure-overclosure), a contact-closure step and the load step
  (:mod:`gearrom.fe.ccx`). CalculiX (``ccx``) runs it as written; ``gearrom ccx-te`` reads the TE.
"""
from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gearrom.fe.ccx import closure_rotation, deck_steps, readout_line, write_deck
from gearrom.fe.compliance import patch_operator
from gearrom.fe.elastic import ElasticBody2D, FacetIndex
from gearrom.fe.fullcontact import frames_at
from gearrom.fe.mesh2d import MeshSettings, gear_mesh

if TYPE_CHECKING:
    from gearrom.fe.export3d import Inp3DInfo

log = logging.getLogger(__name__)

#: mesh of the spur deck: coarser than the LTCA's (a 3D slab of quadratic wedges is ~100 times the
#: 2D problem), fine enough on the flanks of the teeth -1..1 for a static TE cross-check
DECK_MESH_2D = MeshSettings(flank_size=0.06e-3, tooth_size=0.6e-3, body_size=4e-3, refined_teeth=1)


def export_vtu(ltca, theta: float, torque: float, path: str | Path, settings: MeshSettings | None = None) -> Path:
    """Solve both gears under the LTCA contact forces at ``theta`` [rad], ``torque`` [N m]; write VTU.

    ``settings`` must be the mesh settings the LTCA compliances were computed with (default mesh
    if omitted); the bodies are re-meshed and factorised here.
    """
    import meshio

    pair = ltca.pair
    if pair.is_helical:
        from gearrom.errors import ModelError
        from gearrom.fe.ltca_helical import Helical3DLTCA

        if not isinstance(ltca, Helical3DLTCA):
            raise ModelError("export_vtu: the helical slice model has no single mesh; use the 3D model "
                             "(build_ltca(..., helical_model='3d'))")
        from gearrom.fe.loaded3d import LoadedPair3D
        from gearrom.fe.mesh3d import Mesh3DSettings

        return LoadedPair3D(ltca, settings if isinstance(settings, Mesh3DSettings) else None).write_vtu(theta, torque, path)
    res = ltca.solve(theta, torque)
    cands = ltca.candidates(theta)
    pts_all, cells, disp, pres, vm, gear_id = [], [], [], [], [], []
    offset = 0
    frames = frames_at(pair, theta)
    for i in range(2):
        g = pair.gears[i]
        body = ElasticBody2D(gear_mesh(pair, i, settings), g.material.youngs_modulus, g.material.poisson_ratio, g.face_width)
        c = ltca.c[i]
        rb = c.rb
        radius = np.hypot(body.mesh.points[:, 0], body.mesh.points[:, 1])
        F = np.zeros(body.ndof)
        pressure = np.zeros(body.mesh.points.shape[0])
        k0 = 0
        for p, a, fa, w, *_ in cands:
            f = res.force_c[k0:k0 + a.size]
            k0 += a.size
            tooth = -p if i == 0 else p
            edges = body.mesh.curves.get(f"involute_r_{tooth}")
            if edges is None or not np.any(f > 0):
                continue
            sig = c.sigma[a] if i == 0 else c.sigma[0] + (fa + w) * c.spacing
            r_e = radius[np.unique(edges)]
            L = np.sqrt(np.maximum(r_e**2 - rb**2, 0.0))
            P = patch_operator(body, edges, radius, lambda s: np.sqrt(rb**2 + 2 * rb * s), sig, c.spacing,
                               L.min() ** 2 / (2 * rb), L.max() ** 2 / (2 * rb), 6, f"gear {i} tooth {tooth}")
            F += P @ f
            nodes = np.unique(edges)
            s_nodes = (radius[nodes] ** 2 - rb**2) / (2 * rb)
            order = np.argsort(sig)
            pressure[nodes] = np.interp(s_nodes, sig[order], (f / (c.spacing * c.face_width))[order], left=0, right=0)
        U = body.solve(F)[:, 0]
        R, O = frames[i]
        pts_all.append(body.mesh.points @ R.T + O)
        cells.append(body.mesh.triangles + offset)
        disp.append(body.vertex_displacement(U) @ R.T)
        pres.append(pressure)
        vm.append(body.stress_vm_vertices(U))
        gear_id.append(np.full(body.mesh.points.shape[0], i))
        offset += body.mesh.points.shape[0]
    pts = np.vstack(pts_all)
    d = np.vstack(disp)
    mesh = meshio.Mesh(
        np.column_stack([pts, np.zeros(len(pts))]), [("triangle", np.vstack(cells))],
        point_data={"displacement": np.column_stack([d, np.zeros(len(d))]), "contact_pressure": np.concatenate(pres),
                    "von_mises": np.concatenate(vm), "gear": np.concatenate(gear_id).astype(float)},
    )
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    meshio.write(path, mesh)
    return path


@dataclass(frozen=True)
class InpInfo:
    """What a runner needs to read the deck's result: the ROT node id and r_b1 [mm] (the deck's
    readout line holds the same, :func:`gearrom.fe.ccx.read_static_te`)."""

    path: Path
    rot_node: int
    rb1_mm: float
    moment_Nmm: float
    nodes: int
    elements: int


def export_inp(pair, theta: float, torque: float, path: str | Path, settings=None,
               penalty_MPa_per_mm: float = 1e7, rotation: float | None = None, *, helical_model: str = "3d",
               mesh_factor: float = 1.0, contact: str = "surface",
               ltca_ste: float | None = None) -> InpInfo | Inp3DInfo:
    """Write the Abaqus/CalculiX deck of the pair at ``theta`` [rad] and output ``torque`` [N m].

    The deck solves as written: a contact-closure step with a prescribed rotation, then the moment
    (:mod:`gearrom.fe.ccx`); its comment lines say where the static TE is read. ``ltca_ste`` [m],
    the LTCA's static TE at this position and torque, is recorded in the readout line so that
    ``gearrom ccx-te`` reports the ratio.

    Spur pairs: the plane-strain slab (module doc), ``settings`` a :class:`MeshSettings` (default
    :data:`DECK_MESH_2D` x ``mesh_factor``); returns :class:`InpInfo`. With ``rotation`` [rad] the
    deck has one step in which the input reference node is turned by that (clockwise negative)
    angle instead of loaded by the moment (displacement control); the printed RF of the ROT node is
    then the transmitted moment.

    Helical pairs: the 3D sector model (:func:`gearrom.fe.export3d.export_inp_3d`; ``settings`` a
    :class:`~gearrom.fe.mesh3d.Mesh3DSettings`, 2D settings are ignored as by :func:`export_vtu`,
    ``mesh_factor`` scales it, ``contact`` "surface" or "node"); the output gear carries the moment
    (or the prescribed ``rotation`` [rad], negative = lagging) and the input is held; returns
    :class:`gearrom.fe.export3d.Inp3DInfo`. The helical slice model (``helical_model="slices"``) is a
    stack of unrelated plane-strain sections with no single mesh and cannot be written
    (:class:`~gearrom.errors.ModelError`).
    """
    if pair.is_helical:
        from gearrom.errors import ModelError
        from gearrom.fe.export3d import export_inp_3d
        from gearrom.fe.mesh3d import Mesh3DSettings

        if helical_model != "3d":
            raise ModelError(f"export_inp: helical_model={helical_model!r} has no single mesh to write (the slice "
                             "model is a stack of plane-strain sections); use helical_model='3d'")
        if settings is not None and not isinstance(settings, Mesh3DSettings):
            log.warning("export_inp: %s ignored, a helical pair is written as the 3D model "
                        "(default Mesh3DSettings x mesh_factor)", type(settings).__name__)
            settings = None
        return export_inp_3d(pair, theta, torque, path, settings, penalty_MPa_per_mm=penalty_MPa_per_mm,
                             rotation=rotation, mesh_factor=mesh_factor, contact=contact, ltca_ste=ltca_ste)
    s = settings or (DECK_MESH_2D.scaled(mesh_factor) if mesh_factor != 1.0 else DECK_MESH_2D)
    if s.refined_teeth < 1:
        s = dataclasses.replace(s, refined_teeth=1)
    frames = frames_at(pair, theta)
    lines = ["*HEADING", f"gearrom spur pair, theta = {theta:.9g} rad, output torque = {torque:.9g} N m (mm, N, MPa)"]
    node_lines, elem_lines, sets = [], [], {}
    nid, eid = 0, 0
    bore_sets, surf = [], {}
    for i in range(2):
        g = pair.gears[i]
        mesh = gear_mesh(pair, i, s)
        body = FacetIndex(mesh)  # only the facet numbering is needed, no assembly
        f = body.skmesh.facets
        nv = mesh.points.shape[0]
        R, O = frames[i]
        P = (mesh.points @ R.T + O) * 1e3
        M = 0.5 * (P[f[0]] + P[f[1]])
        nf = f.shape[1]
        b = g.face_width * 1e3
        base = nid
        n2 = nv + nf
        # ids: bottom vertices, bottom midsides, top vertices, top midsides, middle vertices
        bot_v = base + 1 + np.arange(nv)
        bot_m = base + 1 + nv + np.arange(nf)
        top_v = base + 1 + n2 + np.arange(nv)
        top_m = base + 1 + n2 + nv + np.arange(nf)
        mid_v = base + 1 + 2 * n2 + np.arange(nv)
        for ids, xy, z in ((bot_v, P, 0.0), (bot_m, M, 0.0), (top_v, P, b), (top_m, M, b), (mid_v, P, 0.5 * b)):
            node_lines += [f"{k},{x:.12g},{y:.12g},{z:.12g}" for k, (x, y) in zip(ids, xy)]
        nid = base + 2 * n2 + nv
        t = mesh.triangles
        fe = [body.facet_index(np.column_stack([t[:, a], t[:, (a + 1) % 3]])) for a in range(3)]
        first_e = eid + 1
        for k in range(t.shape[0]):
            v = t[k]
            eid += 1
            conn = [bot_v[v[0]], bot_v[v[1]], bot_v[v[2]], top_v[v[0]], top_v[v[1]], top_v[v[2]],
                    bot_m[fe[0][k]], bot_m[fe[1][k]], bot_m[fe[2][k]], top_m[fe[0][k]], top_m[fe[1][k]], top_m[fe[2][k]],
                    mid_v[v[0]], mid_v[v[1]], mid_v[v[2]]]
            elem_lines.append(f"{eid}," + ",".join(str(c) for c in conn))
        sets[f"EG{i + 1}"] = (first_e, eid)
        # bore nodes (all layers)
        bore_v = mesh.bore_nodes
        on_bore = np.zeros(nv, bool)
        on_bore[bore_v] = True
        bf = np.flatnonzero(on_bore[f[0]] & on_bore[f[1]] & (body.skmesh.f2t[1] < 0))
        bore_sets.append(np.concatenate([bot_v[bore_v], top_v[bore_v], mid_v[bore_v], bot_m[bf], top_m[bf]]))
        # flank faces of teeth -1..1 -> wedge faces S3 (v0-v1), S4 (v1-v2), S5 (v2-v0)
        faces = []
        tri_of_edge = {}
        for a in range(3):
            for k, fk in enumerate(fe[a]):
                tri_of_edge[int(fk)] = (k, a)
        for j in range(-1, 2):
            for e in mesh.curves[f"involute_r_{j}"]:
                k, a = tri_of_edge[int(body.facet_index(e[None])[0])]
                faces.append(f"{first_e + k},S{3 + a}")
        surf[i] = faces
    ref, rot = nid + 1, nid + 2
    node_lines += [f"{ref},0,0,{0.5 * pair.gears[0].face_width * 1e3:.12g}", f"{rot},0,0,0"]
    T1 = torque * pair.z[0] / pair.z[1] * 1e3  # N mm on the input gear
    E = [g.material for g in pair.gears]
    lines += ["*NODE", *node_lines, "*ELEMENT, TYPE=C3D15, ELSET=EALL", *elem_lines]
    for name, (a, b_) in sets.items():
        lines += [f"*ELSET, ELSET={name}, GENERATE", f"{a},{b_},1"]
    for i, nodes in enumerate(bore_sets):
        lines += [f"*NSET, NSET=BORE{i + 1}"] + [",".join(str(x) for x in nodes[k:k + 12]) for k in range(0, nodes.size, 12)]
    lines += ["*NSET, NSET=NROT", str(rot)]
    for i in range(2):
        lines += [f"*MATERIAL, NAME=STEEL{i + 1}", "*ELASTIC", f"{E[i].youngs_modulus * 1e-6:.9g},{E[i].poisson_ratio:.9g}",
                  f"*SOLID SECTION, ELSET=EG{i + 1}, MATERIAL=STEEL{i + 1}"]
    lines += ["*SURFACE, NAME=SLAVE1, TYPE=ELEMENT", *surf[0], "*SURFACE, NAME=MASTER2, TYPE=ELEMENT", *surf[1]]
    lines += ["*RIGID BODY, NSET=BORE1, REF NODE=%d, ROT NODE=%d" % (ref, rot)]
    # plane strain: u_z = 0 everywhere except on the rigid input bore (constrained through the rigid body)
    keep = np.setdiff1d(np.arange(1, nid + 1), bore_sets[0])
    lines += ["*NSET, NSET=NPLANE"] + [",".join(str(x) for x in keep[k:k + 16]) for k in range(0, keep.size, 16)]
    # supports: input centre held in x, y, z and its tilts; output bore clamped; the slab's u_z
    supports = [f"{ref},1,3", f"{rot},1,2", "BORE2,1,3", "NPLANE,3,3"]
    lines += readout_line(rot, 1 if rotation is not None else 2, pair.rb[0] * 1e3, 1e-3 * pair.z[1] / pair.z[0],
                          ltca_ste)
    lines += deck_steps(f"{penalty_MPa_per_mm:.6g},0.25", "SURFACE TO SURFACE", rot, -T1, supports,
                        closure_rotation(pair, torque, pair.rb[0]), rotation)
    path = write_deck(path, lines)
    return InpInfo(path=path, rot_node=rot, rb1_mm=pair.rb[0] * 1e3, moment_Nmm=-T1, nodes=nid + 2, elements=eid)
