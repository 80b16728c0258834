"""Abaqus/CalculiX input deck of the 3D helical model at one mesh position (mm, N, MPa).

The deck holds the two sector meshes of :func:`gearrom.fe.mesh3d.sector_mesh` (the meshes of the
3D LTCA's compliances, :class:`gearrom.fe.ltca_helical.Helical3DLTCA`) placed in the global frame of
:func:`gearrom.fe.export._frames` (gear 1 centre at the origin, gear 2 centre at (0, a_w, 0), both
axes +z, face widths centred on z = 0: the frame of :class:`gearrom.fe.loaded3d.LoadedPair3D`):

* the P2 tetrahedra as ``C3D10`` (corners 1-4, then the mid-side nodes of the edges 1-2, 2-3, 3-1,
  1-4, 2-4, 3-4); the flank vertices and the mid-side nodes of the flank faces lie on the exact
  involute helicoid (straight edges would miss it by tens of um on the 1-2 mm flank elements of
  the teeth other than tooth 0, more than the STE), all other mid-side nodes at the edge midpoints;
* each bore (vertex and mid-side nodes, as the FE bodies clamp it) on a ``*RIGID BODY`` with a
  reference node at the gear centre and a rotation node; the input gear's reference is held fixed,
  the output's translations and tilts are held and its rotation about +z is loaded by the output
  torque (``*CLOAD``, a clockwise moment resisting the driven gear) or, with ``rotation``,
  prescribed (displacement control: no rigid-body mode before contact closes);
* element-face surfaces (``*SURFACE, TYPE=ELEMENT``) on the right flanks (involute part, whole
  face width) of the teeth that can touch at that position (pair ``p``: tooth ``-p`` of gear 1,
  tooth ``p`` of gear 2, :class:`~gearrom.fe.ltca_helical.Helical3DLTCA`), a ``*CONTACT PAIR``
  (face-to-face penalty by default, CalculiX's advice for quadratic elements; node-to-surface on
  request) with a linear pressure-overclosure ``*SURFACE BEHAVIOR``;
* linear-geometry ``*STATIC`` steps (contact closure by a prescribed rotation, then the moment,
  :mod:`gearrom.fe.ccx`) and ``*NODE PRINT`` of both rotation nodes (U, RF).

The static TE is read back as in the spur deck: ``STE = -phi_2 r_b2`` on the transverse line of
action (``phi_2`` the output rotation about +z, negative when the output lags; the input is held),
the transmitted output torque is the output rotation node's moment (:meth:`Inp3DInfo.static_te`).
The flanks are nominal: micro-geometry and pitch errors of the pair are not in the deck.

Accuracy (``benchmarks/bench_inp_helical_ccx.py``, thesis-helical, 120 N m, 0.3 period): on the
LTCA's default mesh ccx's STE is 4.99 % below the LTCA's (5.6 % at 1.25 times the mesh lengths).
The meshes do not resolve the Hertz zone (~0.1 mm; 1.3 mm flank elements on the loaded teeth but
tooth 0), which the LTCA adds analytically: its near field spread over 0.4 mm patches gives ccx's
STE within 0.4 %, and refining only the flank of tooth 0 (0.9 -> 0.3 mm, level 1.25 with 0.72 mm
layers, at 0.9 period where pair 0 carries 45 % of the load) takes ccx from 5.6 % to 3.3 % below
(halving the layers alone changes nothing; the benchmark's ``--refinement`` cases, ~20 min of
ccx each). The penalty's own compliance is ~1.5 % of the STE
(1e8 MPa/mm: 7.1 % below at level 1.25); node-to-surface contact gives 14 % above (CalculiX
advises face-to-face contact for quadratic elements).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gearrom.errors import ModelError
from gearrom.fe.mesh3d import Mesh3D, Mesh3DSettings, sector_mesh

log = logging.getLogger(__name__)

#: C3D10 mid-side nodes 5..10: the corner pairs (0-based) of their edges
C3D10_EDGES = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]])
#: tetrahedron faces S1..S4 (0-based corners; Abaqus/CalculiX numbering)
TET_FACES = np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]])


@dataclass(frozen=True)
class Inp3DInfo:
    """What a runner needs to read the helical deck's result.

    Attributes
    ----------
    path : Path
    rot_node : int
        Rotation node of the output gear (its U3 is the rotation about +z [rad], RF3 the moment [N mm]).
    rb_mm : float
        Base radius of the output gear [mm] (STE = -U3 r_b2).
    moment_Nmm : float
        Moment applied to ``rot_node`` about +z [N mm] (negative: clockwise, resisting); 0 under
        displacement control.
    nodes, elements : int
        Counts in the deck (nodes include the four reference / rotation nodes).
    pairs : tuple of int
        Tooth pairs with contact surfaces (gear 1 tooth ``-p``, gear 2 tooth ``p``).
    settings : Mesh3DSettings
        Mesh density of both gears.
    """

    path: Path
    rot_node: int
    rb_mm: float
    moment_Nmm: float
    nodes: int
    elements: int
    pairs: tuple
    settings: Mesh3DSettings

    def static_te(self, dat_path: str | Path) -> tuple[float, float]:
        """(static TE [m] on the transverse line of action, positive when the output lags; transmitted
        output torque [N m]) from the ccx ``.dat`` of this deck."""
        from gearrom.fe.ccx import read_ccx_rotation

        rot, moment = read_ccx_rotation(dat_path, self.rot_node)
        return -rot * self.rb_mm * 1e-3, abs(moment) * 1e-3


def contact_pairs(pair, theta: float, margin: float = 0.1e-3) -> list[int]:
    """Tooth pairs whose contact line lies on the active flanks somewhere over the face width at ``theta``.

    Pair ``p`` touches the z-section at input roll ``L1 = L1_SAP + r_b1 (theta + contact_shift(z)) + p p_bt``
    (:func:`gearrom.geometry.profile.contact_shift`, as :class:`~gearrom.fe.ltca_helical.Helical3DLTCA`);
    it is kept if that range over the common face width meets the active roll range of gear 1 widened
    by ``margin`` [m].
    """
    from gearrom.geometry.profile import contact_shift

    b = pair.face_width
    z = np.linspace(-0.5 * b, 0.5 * b, 65)
    L = pair.roll_start_active[0] + pair.rb[0] * (theta + np.asarray(contact_shift(pair, z), float))
    lo, hi = pair.roll_start_active[0] - margin, pair.roll_tip[0] + margin
    p_lo = math.floor((lo - L.max()) / pair.pb_t) - 1
    p_hi = math.ceil((hi - L.min()) / pair.pb_t) + 1
    return [p for p in range(p_lo, p_hi + 1) if (L.min() + p * pair.pb_t <= hi) and (L.max() + p * pair.pb_t >= lo)]


def _flank_faces(mesh: Mesh3D, tooth: int) -> tuple[np.ndarray, np.ndarray]:
    """(element, face 0..3) of the boundary faces on the right involute flank of ``tooth``."""
    key = f"involute_r_{tooth}"
    if key not in mesh.flank_nodes:
        raise ModelError(f"tooth {tooth} has no named flank in the 3D sector mesh (teeth outside the elastic sector)")
    on = np.zeros(mesh.points.shape[0], bool)
    on[mesh.flank_nodes[key]] = True
    f = mesh.tets[:, TET_FACES]  # (m, 4, 3)
    cand = on[f].all(axis=2)
    nv = mesh.section.points.shape[0]
    layer = f // nv
    cand &= layer.min(axis=2) != layer.max(axis=2)  # on the flank, not an end-plane triangle of the section
    el, fa = np.nonzero(cand)
    # boundary only: a face shared by two tetrahedra is interior
    keys = np.sort(mesh.tets[:, TET_FACES].reshape(-1, 3), axis=1)
    _, inv, cnt = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    bnd = cnt[inv.ravel()].reshape(-1, 4) == 1
    keep = bnd[el, fa]
    return el[keep], fa[keep]


def _snap_to_flank(pair, gear: int, X: np.ndarray, tooth: int) -> np.ndarray:
    """Points of the exact right flank of ``tooth`` at the radius and axial position of ``X`` (gear frame) [m]."""
    from gearrom.fe.compliance3d import flank_geometry

    rb = pair.rb[gear]
    r = np.hypot(X[:, 0], X[:, 1])
    sig = (np.maximum(r, rb) ** 2 - rb**2) / (2 * rb)
    return flank_geometry(pair, gear, sig, X[:, 2], tooth)[0]


def _gear_block(pair, gear: int, mesh: Mesh3D, frame, teeth, first_node: int, first_elem: int) -> dict:
    """Nodes [mm], C3D10 connectivity, bore node ids and flank faces of one placed gear."""
    nv = mesh.points.shape[0]
    edges, e_of = np.unique(np.sort(mesh.tets[:, C3D10_EDGES].reshape(-1, 2), axis=1), axis=0, return_inverse=True)
    e_of = e_of.reshape(-1, 6)  # unique edges; the edge of each C3D10 mid-side node
    loc = np.array([[0, 1], [1, 2], [2, 0]])
    pts = mesh.points.copy()
    faces = [(j, *_flank_faces(mesh, j)) for j in teeth]
    for j, el, fa in faces:  # flank vertices onto the exact helicoid (gmsh spline: sub-um moves)
        fv = np.unique(mesh.tets[el[:, None], TET_FACES[fa]])
        pts[fv] = _snap_to_flank(pair, gear, pts[fv], j)
    mid = 0.5 * (pts[edges[:, 0]] + pts[edges[:, 1]])
    snapped = 0
    for j, el, fa in faces:  # and the mid-side nodes of the flank faces (curved P2 faces)
        fe = np.sort(mesh.tets[el[:, None, None], TET_FACES[fa][:, loc]], axis=2).reshape(-1, 2)
        ei = np.unique(np.searchsorted(edges[:, 0] * nv + edges[:, 1], fe[:, 0] * nv + fe[:, 1]))
        new = _snap_to_flank(pair, gear, mid[ei], j)
        moved = np.linalg.norm(new - mid[ei], axis=1)
        length = np.linalg.norm(pts[edges[ei, 0]] - pts[edges[ei, 1]], axis=1)
        if np.any(moved > 0.1 * length + 1e-6):
            raise ModelError(f"gear {gear + 1} tooth {j}: flank mid-side nodes {moved.max() * 1e6:.1f} um off the "
                             "exact flank (mesh and flank geometry disagree)")
        mid[ei] = new
        snapped += ei.size
    R, O = frame
    xyz = np.vstack([pts, mid]) @ R.T * 1e3 + O * 1e3
    ids = first_node + 1 + np.arange(xyz.shape[0])
    conn = np.column_stack([ids[mesh.tets], ids[nv + e_of]])
    on = np.zeros(nv, bool)
    on[mesh.bore_nodes] = True
    bore_e = np.flatnonzero(on[edges[:, 0]] & on[edges[:, 1]])
    log.info("gear %d deck block: %d nodes, %d C3D10, %d flank faces, %d flank mid-side nodes on the helicoid",
             gear + 1, xyz.shape[0], conn.shape[0], sum(el.size for _, el, _ in faces), snapped)
    return {"ids": ids, "xyz": xyz, "conn": conn, "elem0": first_elem,
            "bore": np.concatenate([ids[mesh.bore_nodes], ids[nv + bore_e]]),
            "faces": [(first_elem + 1 + el, fa + 1) for _, el, fa in faces]}


def export_inp_3d(pair, theta: float, torque: float, path: str | Path, settings: Mesh3DSettings | None = None,
                  penalty_MPa_per_mm: float = 1e7, rotation: float | None = None, mesh_factor: float = 1.0,
                  contact: str = "surface", margin: float = 0.1e-3, ltca_ste: float | None = None) -> Inp3DInfo:
    """Write the CalculiX/Abaqus deck of the 3D helical model at ``theta`` [rad] (see module doc).

    Parameters
    ----------
    pair : GearPair
        A helical pair.
    theta : float
        Input angle in the mesh period [rad] (the LTCA's: pair 0 touches the z = 0 section at
        input roll ``L1_SAP + r_b1 theta``).
    torque : float
        Output torque [N m]: the moment on the output rotation node (ignored under ``rotation``).
    path : str or Path
        The ``.inp`` file (ccx runs it as ``ccx -i <stem>``).
    settings : Mesh3DSettings, optional
        Mesh density of both gears (default: the LTCA's default :class:`Mesh3DSettings` with the
        loaded flanks of every tooth that can touch at ``theta`` refined, ``refined_teeth``: the deck
        resolves each contact in its own mesh, the LTCA only tooth 0's).
    penalty_MPa_per_mm : float
        Slope of the linear pressure-overclosure law [MPa/mm].
    rotation : float, optional
        Displacement control: one step with this rotation of the output gear about +z [rad]
        (negative: lagging) prescribed instead of the contact-closure and moment steps; the printed
        RF of the rotation node is then the transmitted moment.
    mesh_factor : float
        Every mesh length times this (``settings.scaled``; thesis-helical meshes cleanly up to 1.5).
    contact : {"surface", "node"}
        Face-to-face (``SURFACE TO SURFACE``) or node-to-face (``NODE TO SURFACE``) penalty contact.
    margin : float
        Roll length [m] beyond the active flanks within which a pair still gets contact surfaces.
    ltca_ste : float, optional
        The LTCA's static TE at this position and torque [m], recorded in the readout line.
    """
    if not pair.is_helical:
        raise ModelError("export_inp_3d: the 3D deck is for helical pairs (spur pairs: gearrom.fe.export.export_inp)")
    if contact not in ("surface", "node"):
        raise ModelError(f"contact must be 'surface' or 'node', got {contact!r}")
    if not (math.isfinite(mesh_factor) and mesh_factor > 0):
        raise ModelError(f"mesh_factor must be a positive number, got {mesh_factor!r}")
    pairs = contact_pairs(pair, theta, margin)
    if settings is None:  # the LTCA's mesh with the flanks of every tooth that can touch refined
        reach = max((abs(p) for p in pairs), default=0)
        settings = Mesh3DSettings(refined_teeth=min(reach, Mesh3DSettings().teeth))
    s = settings.scaled(mesh_factor) if mesh_factor != 1.0 else settings
    if not pairs or max(abs(p) for p in pairs) > s.teeth:
        raise ModelError(f"pairs {pairs} can touch at theta = {theta:.6g} rad but the elastic sector has teeth "
                         f"-{s.teeth}..{s.teeth}: use Mesh3DSettings(teeth=...) >= {max(map(abs, pairs), default=0)}")
    # the spur deck's and LoadedPair3D's placement (lifted to 3D) and the deck lines both decks share
    from gearrom.fe.ccx import closure_rotation, deck_steps, readout_line, write_deck
    from gearrom.fe.fullcontact import frames_at

    frames = [(np.block([[R2, np.zeros((2, 1))], [np.zeros((1, 2)), np.ones((1, 1))]]), np.append(O2, 0.0))
              for R2, O2 in frames_at(pair, theta)]
    blocks, nid, eid = [], 0, 0
    for g in range(2):
        teeth = [-p if g == 0 else p for p in pairs]
        blk = _gear_block(pair, g, sector_mesh(pair, g, s), frames[g], teeth, nid, eid)
        blocks.append(blk)
        nid, eid = int(blk["ids"][-1]), eid + blk["conn"].shape[0]
    ref1, rot1, ref2, rot2 = nid + 1, nid + 2, nid + 3, nid + 4
    aw = pair.aw * 1e3
    M2 = -torque * 1e3  # N mm, clockwise on the driven gear
    mat = [g.material for g in pair.gears]
    L = ["*HEADING", f"gearrom helical pair (3D sector model), theta = {theta:.9g} rad, output torque = "
         f"{torque:.9g} N m, pairs {pairs} (mm, N, MPa)", "*NODE"]
    for blk in blocks:
        L += [f"{k},{x:.12g},{y:.12g},{z:.12g}" for k, (x, y, z) in zip(blk["ids"], blk["xyz"])]
    L += [f"{ref1},0,0,0", f"{rot1},0,0,0", f"{ref2},0,{aw:.12g},0", f"{rot2},0,{aw:.12g},0"]
    for g, blk in enumerate(blocks):
        L.append(f"*ELEMENT, TYPE=C3D10, ELSET=EG{g + 1}")
        e0 = blk["elem0"]
        L += [f"{e0 + 1 + k}," + ",".join(str(int(c)) for c in row) for k, row in enumerate(blk["conn"])]
    for g, blk in enumerate(blocks):
        b = blk["bore"]
        L += [f"*NSET, NSET=BORE{g + 1}"] + [",".join(map(str, b[k:k + 16])) for k in range(0, b.size, 16)]
    L += ["*NSET, NSET=NROT", f"{rot1},{rot2}"]
    for g in range(2):
        L += [f"*MATERIAL, NAME=STEEL{g + 1}", "*ELASTIC", f"{mat[g].youngs_modulus * 1e-6:.9g},{mat[g].poisson_ratio:.9g}",
              f"*SOLID SECTION, ELSET=EG{g + 1}, MATERIAL=STEEL{g + 1}"]
    for g, name in enumerate(("SLAVE1", "MASTER2")):
        L.append(f"*SURFACE, NAME={name}, TYPE=ELEMENT")
        for el, fa in blocks[g]["faces"]:
            L += [f"{e},S{f}" for e, f in zip(el, fa)]
    L += [f"*RIGID BODY, NSET=BORE1, REF NODE={ref1}, ROT NODE={rot1}",
          f"*RIGID BODY, NSET=BORE2, REF NODE={ref2}, ROT NODE={rot2}"]
    # supports: input gear held; output centre held in x, y, z and its tilts (its rotation is loaded)
    supports = [f"{ref1},1,3", f"{rot1},1,3", f"{ref2},1,3", f"{rot2},1,2"]
    behaviour = f"{penalty_MPa_per_mm:.6g}" if contact == "surface" else f"{penalty_MPa_per_mm:.6g},0.25"
    L += readout_line(rot2, 1 if rotation is not None else 2, pair.rb[1] * 1e3, 1e-3, ltca_ste)
    L += deck_steps(behaviour, "SURFACE TO SURFACE" if contact == "surface" else "NODE TO SURFACE", rot2, M2,
                    supports, closure_rotation(pair, torque, pair.rb[1]), rotation)
    path = write_deck(path, L)
    log.info("wrote %s: %d nodes, %d C3D10, pairs %s", path, nid + 4, eid, pairs)
    return Inp3DInfo(path=path, rot_node=rot2, rb_mm=pair.rb[1] * 1e3, moment_Nmm=M2 if rotation is None else 0.0,
                     nodes=nid + 4, elements=eid, pairs=tuple(pairs), settings=s)


def calculix_crosscheck(pair, workdir: str | Path, settings: Mesh3DSettings | None = None, theta_frac: float = 0.3,
                        torque: float = 120.0, threads: int = 2, cache_dir: str | Path | None = None, **deck) -> dict:
    """Static TE of the deck run by CalculiX against the 3D LTCA on the same mesh (one position).

    The LTCA (:func:`~gearrom.fe.ltca_helical.build_helical3d`, compliances cached in ``cache_dir``,
    default ``workdir/cache``) gives the STE at ``torque`` [N m] and ``theta_frac`` of the mesh
    period; the deck prescribes that output rotation (displacement control), ``ccx`` runs it in
    ``workdir`` on ``threads`` threads, and the LTCA is solved again at the torque ccx transmitted.
    ``deck``: options of :func:`export_inp_3d`. Returns both STEs [um], the torque [N m], their
    ratio, node / element counts and times [s].
    """
    import os
    import shutil
    import subprocess
    import time

    from gearrom.errors import SolverError
    from gearrom.fe.ltca_helical import build_helical3d

    if shutil.which("ccx") is None:
        raise SolverError("CalculiX (ccx, Debian package calculix-ccx) is not installed")
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    s = settings or Mesh3DSettings()
    t0 = time.perf_counter()
    ltca = build_helical3d(pair, s, cache_dir=cache_dir or workdir / "cache")
    theta = theta_frac * ltca.period
    guess = ltca.solve(theta, torque)
    info = export_inp_3d(pair, theta, torque, workdir / "helical.inp", s, rotation=-guess.ste / pair.rb[1], **deck)
    t1 = time.perf_counter()
    run = subprocess.run(["ccx", "-i", "helical"], cwd=workdir, capture_output=True, text=True, timeout=3600,
                         env={**os.environ, "OMP_NUM_THREADS": str(threads)})
    t2 = time.perf_counter()
    if run.returncode != 0:
        raise SolverError(f"ccx failed ({run.returncode}): {run.stdout[-1500:]}")
    ste, torque_out = info.static_te(workdir / "helical.dat")
    res = ltca.solve(theta, torque_out)
    ref = res.ste
    log.info("ccx %.2f N m, STE %.4f um; LTCA %.4f um (%d nodes, ccx %.0f s)", torque_out, ste * 1e6, ref * 1e6,
             info.nodes, t2 - t1)
    return {"theta_over_period": theta_frac, "nodes": info.nodes, "elements": info.elements, "pairs": list(info.pairs),
            "ltca_loaded_pairs": sorted({int(p) for p in res.pair[res.force_c > 0]}),
            "mesh_mm": {k: getattr(info.settings, k) * 1e3 for k in ("flank_size", "tooth_size", "body_size", "layer")},
            "torque_out_Nm": torque_out, "ste_ccx_um": ste * 1e6, "ste_ltca_um": ref * 1e6, "ratio": ste / ref,
            "ltca_and_deck_s": t1 - t0, "ccx_s": t2 - t1}
