"""Exports: VTU of the loaded state and the Abaqus/CalculiX deck (run with ccx when installed).

References: the VTU displacements must reproduce the LTCA approach (the influence-coefficient
solution itself: delta = sum of the surface normal displacements at a loaded point); the ccx run
is an independent FE code (CalculiX 2.x, penalty surface-to-surface contact on quadratic wedges)
whose static TE must agree with the LTCA within 5 % (issue acceptance).
"""
from __future__ import annotations

import math
import os
import shutil
import subprocess

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.fe.export import export_inp, export_vtu, read_ccx_rotation
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


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx, Debian package calculix-ccx) is not installed")
def test_calculix_static_te_within_5_percent(model, tmp_path):
    pair, ltca = model
    theta = 0.5 * ltca.period
    guess = ltca.solve(theta, 120.0)
    info = export_inp(pair, theta, 120.0, tmp_path / "spur.inp", CCX_MESH, rotation=-guess.ste / pair.rb[0])
    run = subprocess.run(["ccx", "-i", "spur"], cwd=tmp_path, capture_output=True, text=True, timeout=900,
                         env={**os.environ, "OMP_NUM_THREADS": "2"})
    assert run.returncode == 0, run.stdout[-2000:]
    rot, moment = read_ccx_rotation(tmp_path / "spur.dat", info.rot_node)
    torque_out = abs(moment) * 1e-3 * pair.z[1] / pair.z[0]
    ste_ccx = -rot * pair.rb[0]
    ste_ltca = ltca.solve(theta, torque_out).ste
    print(f"ccx: {torque_out:.2f} N m, STE {ste_ccx * 1e6:.4f} um; LTCA {ste_ltca * 1e6:.4f} um")
    assert ste_ccx == pytest.approx(ste_ltca, rel=0.05)
