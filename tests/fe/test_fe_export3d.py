"""Abaqus/CalculiX deck of the 3D helical model (gearrom.fe.export3d), run with ccx when installed.

References: the deck is checked by independent geometry (corner volumes, mid-side nodes at the
edge midpoints of the C3D10 node order of the CalculiX manual, section "Ten-node tetrahedral
element"; face labels S1..S4 of its *SURFACE card), and the contact point of pair 0 at z = 0
(input roll L1_SAP + r_b1 theta on the line of action, Niemann/Winter) must lie on both contact
surfaces. The ccx run is an independent FE code (CalculiX 2.x, penalty face-to-face contact on
quadratic tetrahedra) whose static TE must agree with the 3D LTCA on the same mesh within 5 %.
"""
from __future__ import annotations

import math
import shutil
import subprocess
import warnings

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.errors import ModelError
from gearrom.fe.export import export_inp
from gearrom.fe.mesh2d import MeshSettings
from gearrom.fe.mesh3d import Mesh3DSettings, sector_mesh

DECK_MESH = Mesh3DSettings().scaled(1.5)  # the coarsest level gmsh meshes cleanly (2.0 gives slivers)
# the ccx deck of the command line is on the LTCA's default mesh, which does not resolve the Hertz zone the LTCA
# adds analytically (benchmarks/bench_inp_helical_ccx.py and bench_inp_cli_ccx.py: figures and diagnosis)
TORQUE = 120.0


@pytest.fixture(scope="module")
def pair():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config("thesis-helical").pair


def _read_deck(path):
    """Nodes {id: xyz}, C3D10 rows per ELSET, element-face surfaces, CLOAD lines and the keyword lines."""
    nodes, elems, surf, cload, keys = {}, {}, {}, [], []
    block = None
    for line in path.read_text().splitlines():
        if line.startswith("*"):
            keys.append(line)
            up = line.upper().replace(" ", "")
            block = None
            if up == "*NODE":
                block = ("node",)
            elif up.startswith("*ELEMENT,") and "TYPE=C3D10" in up:
                block = ("elem", up.split("ELSET=")[1].split(",")[0])
                elems[block[1]] = []
            elif up.startswith("*SURFACE,") and "TYPE=ELEMENT" in up:
                block = ("surf", up.split("NAME=")[1].split(",")[0])
                surf[block[1]] = []
            elif up == "*CLOAD":
                block = ("cload",)
            continue
        if block is None:
            continue
        parts = line.split(",")
        if block[0] == "node":
            nodes[int(parts[0])] = np.array([float(x) for x in parts[1:4]])
        elif block[0] == "elem":
            elems[block[1]].append([int(x) for x in parts])
        elif block[0] == "surf":
            surf[block[1]].append((int(parts[0]), parts[1].strip()))
        else:
            cload.append(parts)
    return nodes, {k: np.array(v) for k, v in elems.items()}, surf, cload, keys


def test_deck_has_the_3d_model(pair, tmp_path):
    theta = 0.3 * 2 * math.pi / pair.z[0]
    info = export_inp(pair, theta, TORQUE, tmp_path / "h.inp", DECK_MESH)
    nodes, elems, surf, cload, keys = _read_deck(info.path)
    text = "\n".join(keys).upper()
    for key in ("*MATERIAL", "*ELASTIC", "*SOLID SECTION", "*RIGID BODY", "*CONTACT PAIR", "*SURFACE INTERACTION",
                "*SURFACE BEHAVIOR", "*STEP", "*STATIC", "*CLOAD", "*NODE PRINT", "*END STEP"):
        assert key in text
    assert text.count("*RIGID BODY") == 2 and "NLGEOM" not in text
    # counts: every tetrahedron of both sector meshes, its vertices and one node per edge, + 4 reference nodes
    meshes = [sector_mesh(pair, g, DECK_MESH) for g in range(2)]
    n_edges = [len({tuple(sorted(e)) for t in m.tets for e in ((t[0], t[1]), (t[0], t[2]), (t[0], t[3]),
                                                              (t[1], t[2]), (t[1], t[3]), (t[2], t[3]))}) for m in meshes]
    assert len(nodes) == info.nodes == sum(m.points.shape[0] for m in meshes) + sum(n_edges) + 4
    assert [elems[f"EG{g + 1}"].shape[0] for g in range(2)] == [m.tets.shape[0] for m in meshes]
    assert info.elements == sum(m.tets.shape[0] for m in meshes)
    # C3D10 connectivity: positive corner volume, mid-side nodes 5..10 on the edges 1-2, 2-3, 3-1, 1-4, 2-4, 3-4
    ids = np.array(sorted(nodes))
    xyz = np.array([nodes[k] for k in ids])
    conn = np.searchsorted(ids, np.vstack(list(elems.values()))[:, 1:])
    X = xyz[conn]
    vol = np.einsum("ij,ij->i", np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), X[:, 3] - X[:, 0]) / 6
    assert vol.min() > 0
    ends = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]])
    A, B = X[:, ends[:, 0]], X[:, ends[:, 1]]
    off = np.linalg.norm(X[:, 4:] - 0.5 * (A + B), axis=2)
    length = np.linalg.norm(B - A, axis=2)
    t = np.einsum("ijk,ijk->ij", X[:, 4:] - A, B - A) / length**2
    assert np.all(np.abs(t - 0.5) < 0.05)  # halfway along its own edge (the curved ones bulge mostly sideways)
    # curved flank edges: the chord sag h^2 / (8 rho) of the involute, rho >= 4.5 mm (SAP), h <= 2 mm here
    assert np.all(off <= 0.06 * length)
    assert np.mean(off < 1e-9) > 0.97  # all other edges straight
    # surfaces: element faces S1..S4 of the contact teeth, both gears, in a contact pair
    assert set(surf) == {"SLAVE1", "MASTER2"} and all(len(v) > 0 for v in surf.values())
    assert "SLAVE1,MASTER2" in info.path.read_text()
    n1 = elems["EG1"].shape[0]
    faces = {"S1": [0, 1, 2], "S2": [0, 3, 1], "S3": [1, 3, 2], "S4": [2, 3, 0]}
    assert all(e <= n1 for e, _ in surf["SLAVE1"]) and all(e > n1 for e, _ in surf["MASTER2"])
    assert 0 in info.pairs and len(info.pairs) >= 3  # eps_gamma ~ 3.5
    # the contact point of pair 0 at z = 0 lies on both surfaces (within the flank mesh's chord sag)
    a = pair.alpha_wt
    L1 = pair.roll_start_active[0] + pair.rb[0] * theta
    P = (pair.rb[0] * np.array([-math.sin(a), math.cos(a)]) + L1 * np.array([math.cos(a), math.sin(a)])) * 1e3
    P = np.append(P, 0.0)
    allconn = np.vstack(list(elems.values()))
    edge_of = {frozenset(e): 4 + k for k, e in enumerate(ends.tolist())}
    u, v = np.meshgrid(np.linspace(0, 1, 401), np.linspace(0, 1, 401))
    u, v = u[u + v <= 1], v[u + v <= 1]
    w = 1 - u - v
    shape = np.column_stack([w * (2 * w - 1), u * (2 * u - 1), v * (2 * v - 1), 4 * w * u, 4 * u * v, 4 * v * w])
    for name in ("SLAVE1", "MASTER2"):
        row = np.array([[*faces[s], edge_of[frozenset(faces[s][:2])], edge_of[frozenset(faces[s][1:])],
                         edge_of[frozenset([faces[s][2], faces[s][0]])]] for _, s in surf[name]])
        el = np.array([e for e, _ in surf[name]]) - 1
        q6 = xyz[np.searchsorted(ids, allconn[el[:, None], 1 + row])]  # (nf, 6, 3): the quadratic faces
        near = np.flatnonzero(np.linalg.norm(q6[:, :3].mean(axis=1) - P, axis=1) < 2 * DECK_MESH.tooth_size * 1e3)
        assert near.size > 0
        S = np.einsum("sk,fkd->fsd", shape, q6[near]).reshape(-1, 3)
        k = np.argmin(np.linalg.norm(S - P, axis=1))
        f = near[k // shape.shape[0]]
        n = np.cross(q6[f, 1] - q6[f, 0], q6[f, 2] - q6[f, 0])
        n /= np.linalg.norm(n)
        assert np.linalg.norm(S[k] - P) < 0.02  # mm: the sampled surface reaches the point
        # P on the curved P2 face (the P2 interpolation of the involute: ~1 um at h = 2 mm near the SAP;
        # the flat corner facets miss it by up to 16 um)
        assert abs((P - S[k]) @ n) < 3e-3
        assert abs(n @ [math.cos(a), math.sin(a), 0.0]) > 0.8  # a flank facing along the line of action
    # the load: a clockwise moment of the output torque on the output rotation node
    (node, dof, value), = cload
    assert (int(node), int(dof)) == (info.rot_node, 3)
    assert float(value) == pytest.approx(-TORQUE * 1e3) == info.moment_Nmm
    assert info.rb_mm == pytest.approx(pair.rb[1] * 1e3)
    assert f"{pair.gears[0].material.youngs_modulus * 1e-6:.9g}," in info.path.read_text()


def test_deck_errors(pair, tmp_path):
    with pytest.raises(ModelError, match="no single mesh"):
        export_inp(pair, 0.0, TORQUE, tmp_path / "s.inp", helical_model="slices")
    # 2D settings (the CLI's) are ignored as by export_vtu: the default 3D mesh, scaled
    info = export_inp(pair, 0.0, TORQUE, tmp_path / "s.inp", MeshSettings(), mesh_factor=1.5)
    # 2D settings ignored: the LTCA's mesh x 1.5, with the flanks of every tooth that can touch refined
    reach = max(abs(p) for p in info.pairs)
    assert info.settings == Mesh3DSettings(refined_teeth=reach).scaled(1.5) and reach >= 1
    with pytest.raises(ModelError, match="elastic sector"):
        export_inp(pair, 0.0, TORQUE, tmp_path / "s.inp", Mesh3DSettings(teeth=2), mesh_factor=1.5)


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx, Debian package calculix-ccx) is not installed")
def test_cli_deck_solves_with_calculix_within_5_percent(tmp_path, monkeypatch):
    """Exactly the deck of ``gearrom stiffness thesis-helical --inp`` (theta = 0, 120 N m, the 3D LTCA's
    mesh), solved by ``ccx -i`` as written (contact closure, then the moment); reference: the 3D
    LTCA's static TE at that position and torque recorded in the deck; tolerance 5 % (issue acceptance)."""
    from gearrom.cli import main
    from gearrom.fe.ccx import read_static_te

    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    deck = tmp_path / "h.inp"
    assert main(["stiffness", "thesis-helical", "--positions", "4", "--inp", str(deck)]) == 0
    run = subprocess.run(["ccx", "-i", "h"], cwd=tmp_path, capture_output=True, text=True, timeout=7200)
    assert run.returncode == 0 and "Job finished" in run.stdout, run.stdout[-2000:]
    res = read_static_te(deck)
    assert res["torque_out_Nm"] == pytest.approx(TORQUE, rel=1e-6)
    assert res["ste_um"] == pytest.approx(res["ltca_ste_um"], rel=0.05)
