"""Exports: VTU of the loaded state and the Abaqus/CalculiX deck (run with ccx when installed).

References: the VTU displacements must reproduce the LTCA approach (the influence-coefficient
solution itself: delta = sum of the surface normal displacements at a loaded point); the ccx run
is an independent FE code (CalculiX 2.x, penalty surface-to-surface contact on quadratic wedges)
whose static TE must agree with the LTCA within 5 %; it runs the deck exactly as the command line
writes it.
"""
from __future__ import annotations

import math
import shutil
import subprocess

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.errors import SolverError
from gearrom.fe.ccx import read_ccx_rotation, read_readout, read_static_te
from gearrom.fe.export import export_inp, export_vtu
from gearrom.fe.mesh2d import MeshSettings
from gearrom.fe.sweep import build_ltca

CCX_MESH = MeshSettings(flank_size=0.06e-3, tooth_size=0.6e-3, body_size=4e-3, refined_teeth=1)


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    pair = load_config("thesis-spur").pair
    return pair, build_ltca(pair, CCX_MESH, cache_dir=tmp_path_factory.mktemp("c"))


def test_vtu_reproduces_ltca_approach(model, tmp_path):
    import meshio

    pair, ltca = model
    theta = 0.5 * ltca.period
    res = ltca.solve(theta, 120.0)
    m = meshio.read(export_vtu(ltca, theta, 120.0, tmp_path / "p.vtu", CCX_MESH))
    pd = m.point_data
    assert {"displacement", "contact_pressure", "von_mises", "gear"} <= set(pd)
    g = pd["gear"]
    # nodal values interpolated from the patch pressures: at most the patch peak, not far below it
    assert 0.7 * res.max_pressure < pd["contact_pressure"].max() <= 1.001 * res.max_pressure
    # at the most loaded point of gear 1 and the nearest point of gear 2
    k1 = np.flatnonzero(g == 0)[np.argmax(pd["contact_pressure"][g == 0])]
    idx2 = np.flatnonzero(g == 1)
    k2 = idx2[np.argmin(np.linalg.norm(m.points[idx2] - m.points[k1], axis=1))]
    u = np.array([math.cos(pair.alpha_wt), math.sin(pair.alpha_wt), 0.0])  # gear 1 outward normal on the LOA
    approach = -(pd["displacement"][k1] - pd["displacement"][k2]) @ u
    # a nodal value against a patch average: a few per cent
    assert approach == pytest.approx(res.ste, rel=0.06)


def test_inp_deck_has_the_model(model, tmp_path):
    pair, _ = model
    info = export_inp(pair, 0.1, 120.0, tmp_path / "a.inp", CCX_MESH)
    text = info.path.read_text()
    for key in ("*NODE", "TYPE=C3D15", "*MATERIAL", "*RIGID BODY", "*CONTACT PAIR", "*SURFACE BEHAVIOR", "*STATIC", "*CLOAD"):
        assert key in text
    assert info.moment_Nmm == pytest.approx(-120e3 * 32 / 41)


def test_deck_steps_close_contact_then_load(model, tmp_path):
    """The written deck: a contact-closure step with a prescribed rotation of the input's ROT node of
    the moment's sign and below the static TE estimate, then OP=NEW (supports restated) and the moment."""
    pair, _ = model
    info = export_inp(pair, 0.1, 120.0, tmp_path / "a.inp", CCX_MESH, ltca_ste=10e-6)
    text = info.path.read_text()
    steps = text.split("*STEP")[1:]
    assert len(steps) == 2
    assert "*CLOAD" not in steps[0] and f"{info.rot_node},3,3," in steps[0]
    closure = float(steps[0].split(f"{info.rot_node},3,3,")[1].split()[0])
    # ISO 6336 static TE estimate (F_bt / c_gamma b) on the input base circle: 5-40 % of it, clockwise
    from gearrom.fe.iso6336 import mesh_stiffness

    ste_iso = 120.0 / pair.rb[1] / (mesh_stiffness(pair) * pair.face_width)
    assert -0.4 * ste_iso / pair.rb[0] < closure < -0.05 * ste_iso / pair.rb[0]
    assert "*BOUNDARY, OP=NEW" in steps[1] and f"{info.rot_node},3,{info.moment_Nmm:.9g}" in steps[1]
    for support in (f"{info.rot_node},1,2", "BORE2,1,3", "NPLANE,3,3"):
        assert support in steps[0] and support in steps[1]
    r = read_readout(info.path)
    assert (r.node, r.steps, r.ltca_ste_um) == (info.rot_node, 2, pytest.approx(10.0))
    assert r.te_um_per_rad == pytest.approx(-pair.rb[0] * 1e6)


def test_readout_rejects_an_unconverged_last_step(tmp_path):
    """A .dat whose last block is step 1 (step 2 did not converge) must not be read as the result."""
    dat = tmp_path / "d.dat"
    dat.write_text(" displacements (vx,vy,vz) for set NROT and time  0.1000000E+01\n\n    7  0.0  0.0 -2.0E-04\n")
    assert read_ccx_rotation(dat, 7) == (-2e-4, pytest.approx(float("nan"), nan_ok=True))
    with pytest.raises(SolverError, match="step time 1"):
        read_ccx_rotation(dat, 7, end_time=2.0)
    with pytest.raises(SolverError, match="no result for node 8"):
        read_ccx_rotation(dat, 8)


def test_ccx_te_errors(tmp_path):
    """ccx-te on a file that is not a gearrom deck, or without a result: exit 2, one line."""
    from gearrom.cli import main

    bad = tmp_path / "x.inp"
    bad.write_text("*HEADING\n")
    assert main(["ccx-te", str(bad)]) == 2
    assert main(["ccx-te", str(tmp_path / "missing.inp")]) == 2


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx, Debian package calculix-ccx) is not installed")
def test_cli_deck_solves_with_calculix_within_5_percent(tmp_path, monkeypatch):
    """The deck of ``gearrom stiffness thesis-spur --inp``, coarsened twofold (``--mesh-factor 2``), solved by
    ``ccx -i`` as written.

    Reference: the LTCA's static TE at the deck's position (theta = 0) and torque (120 N m) at the default
    resolution (``gearrom stiffness thesis-spur --json``); CalculiX is an independent FE code (penalty
    face-to-face contact on quadratic wedges) whose result moves little with the deck's mesh, while the LTCA
    on a coarse mesh is softer. Tolerance 5 % (issue acceptance; the meshes differ near the Hertz zone).
    The deck at full resolution is solved by benchmarks/bench_inp_cli_ccx.py.
    """
    import json

    from gearrom.cli import main

    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    deck = tmp_path / "d.inp"
    assert main(["stiffness", "thesis-spur", "--positions", "4", "--mesh-factor", "2", "--inp", str(deck)]) == 0
    run = subprocess.run(["ccx", "-i", "d"], cwd=tmp_path, capture_output=True, text=True, timeout=1800)
    assert run.returncode == 0 and "Job finished" in run.stdout, run.stdout[-2000:]
    res = read_static_te(deck)
    assert res["torque_out_Nm"] == pytest.approx(120.0, rel=1e-6)
    assert main(["stiffness", "thesis-spur", "--positions", "4", "--json", str(tmp_path / "s.json")]) == 0
    fine = json.loads((tmp_path / "s.json").read_text())
    assert fine["mesh_angle_deg"][0] == 0.0 and fine["torque_Nm"] == 120.0
    assert res["ste_um"] == pytest.approx(fine["ste_um"][0], rel=0.05)
    assert main(["ccx-te", str(deck)]) == 0
