"""``gearrom stiffness`` end to end on a coarse mesh, and its input errors.

Reference for the numbers: ISO 6336-1 c_gamma_alpha (about +-20 %), see test_fe_spur.py.
"""
from __future__ import annotations

import json

import pytest

from gearrom.cli import main

KEYS = {"definition", "torque_Nm", "mean_stiffness_N_per_um", "stiffness_ptp_N_per_um", "ste_mean_um", "ste_ptp_um",
        "max_contact_pressure_MPa", "mesh_angle_deg", "stiffness_N_per_um", "ste_um", "load_share"}


def test_cli_stiffness_json_plot_table(tmp_path, capsys):
    out = tmp_path / "s.json"
    rc = main(["stiffness", "thesis-spur", "--torque-Nm", "120", "--positions", "16", "--mesh-factor", "1.6",
               "--json", str(out), "--plot", str(tmp_path / "s.png"), "--save", str(tmp_path / "s.nc"),
               "--cache-dir", str(tmp_path / "cache"), "--vtu", str(tmp_path / "s.vtu"), "--inp", str(tmp_path / "s.inp")])
    assert rc == 0
    d = json.loads(out.read_text())
    assert KEYS <= set(d)
    assert len(d["ste_um"]) == 16 and d["torque_Nm"] == 120.0
    assert 0.8 < d["ratio_to_iso6336"] < 1.2
    assert (tmp_path / "s.png").stat().st_size > 0
    from gearrom.excitation.table import MeshExcitation

    assert MeshExcitation.load(tmp_path / "s.nc").n_theta == 16
    assert "mean k" in capsys.readouterr().out
    assert (tmp_path / "s.vtu").stat().st_size > 0 and "*CONTACT PAIR" in (tmp_path / "s.inp").read_text()


@pytest.mark.parametrize("argv, msg", [
    (["--torque-Nm", "-5"], "--torque-Nm"),
    (["--positions", "2"], "--positions"),
    (["--pattern", "p.png"], "helical pairs only"),
])
def test_cli_stiffness_bad_input(argv, msg, capsys):
    assert main(["stiffness", "thesis-spur", "--no-cache", *argv]) == 2
    assert msg in capsys.readouterr().err


def test_cli_stiffness_unknown_fe_key(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text('extends = "thesis-spur"\n[fe]\nflank_sise_mm = 0.02\n')
    assert main(["stiffness", str(cfg), "--no-cache"]) == 2
    assert "fe.flank_sise_mm" in capsys.readouterr().err
