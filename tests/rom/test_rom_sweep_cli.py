"""Sweep and Campbell: CLI outputs, summary format, resume, modal checks."""
import json
import math

import numpy as np
import pytest

from gearrom.cli import main
from gearrom.errors import ConfigError
from gearrom.rom.modal import campbell, modal_analysis
from gearrom.rom.rig import build_rig
from gearrom.rom.sweep import SweepResult, parse_rpm


def test_parse_rpm():
    np.testing.assert_allclose(parse_rpm("250:5000:25")[[0, -1]], [250, 5000])
    assert parse_rpm("250:5000:25").size == 191
    np.testing.assert_allclose(parse_rpm("100,200"), [100, 200])
    with pytest.raises(ConfigError, match="rpm specification"):
        parse_rpm("a:b")
    with pytest.raises(ConfigError, match=r"speeds in \(0, "):
        parse_rpm("-5")
    with pytest.raises(ConfigError, match="more than 100000 speeds"):  # bounded before the grid is expanded
        parse_rpm("1:1e12:1")


def test_sweep_cli_outputs_and_resume(tmp_path, capsys):
    out = tmp_path / "sw"
    args = ["sweep", "thesis-rig", "--rpm", "1000,3000", "--out", str(out), "--revs", "0.5", "--no-progress",
            "--processes", "2"]
    assert main(args) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["config"] == "thesis-rig" and len(s["speeds"]) == 2
    sp = s["speeds"][0]
    for key in ("rpm_in", "dte_ptp_um", "dte_rms_um", "gmf_amplitude_um", "contact_loss", "dynamic_factor"):
        assert key in sp
    assert len(sp["gmf_amplitude_um"]) == 3 and isinstance(sp["contact_loss"], bool)
    for f in ("sweep.nc", "waterfall.png", "gmf_vs_speed.png"):
        assert (out / f).stat().st_size > 0
    res = SweepResult.load(out / "sweep.nc")
    assert res.data["dte_sensor"].shape[0] == 2
    files = sorted((out / "speeds").glob("*.nc"))
    mtimes = [f.stat().st_mtime_ns for f in files]
    # resume: a rerun with one more speed computes only that one
    assert main(args[:3] + ["1000,2000,3000"] + args[4:]) == 0
    assert [f.stat().st_mtime_ns for f in files] == mtimes
    assert len(list((out / "speeds").glob("*.nc"))) == 3
    assert "3 speeds" in capsys.readouterr().out


def test_sweep_cli_bad_config_key(tmp_path, capsys):
    p = tmp_path / "c.toml"
    p.write_text('extends = "thesis-rig"\n[sweep]\nrevs = 2\n')
    assert main(["sweep", str(p), "--out", str(tmp_path / "o")]) == 2
    assert "sweep.revs" in capsys.readouterr().err


def test_modal_mesh_share_and_campbell_crossing():
    model = build_rig("thesis-rig")
    m = modal_analysis(model, 1000.0, fmax=10e3)
    assert np.all((m.mesh_share >= 0) & (m.mesh_share <= 1))
    assert m.mesh_share.max() > 0.2  # a mesh-dominated mode exists below 10 kHz
    # energy check: shares are <= 1 and the mesh-dominated mode lies between the
    # uncoupled gear-on-bearing modes and the rigid-gear mesh mode sqrt(k/m_eq)
    f_rigid = math.sqrt(model.excitation.mean_stiffness(120.0) / model.mesh_mass()) / (2 * math.pi)
    f_mesh = m.freqs[np.argmax(m.mesh_share)]
    assert f_mesh < f_rigid
    c = campbell(model, np.linspace(250, 5000, 6))
    # a crossing of order o with a (speed-independent torsional) mode f lies at rpm = 60 f / o
    for x in c.crossings:
        assert x["frequency_Hz"] == pytest.approx(c.orders[x["order"]] * x["rpm_in"] / 60, rel=1e-6)


def test_campbell_cli(tmp_path, capsys):
    assert main(["campbell", "thesis-rig", "--rpm", "250:5000:1187.5", "--json", str(tmp_path / "c.json"),
                 "--plot", str(tmp_path / "c.png")]) == 0
    d = json.loads((tmp_path / "c.json").read_text())
    assert d["modes"][0]["frequency_Hz"] > 50 and "crossings" in d
    assert (tmp_path / "c.png").stat().st_size > 0
    assert "mesh E" in capsys.readouterr().out


def test_modal_result_round_trip(tmp_path):
    from gearrom.rom.modal import ModalResult

    m = modal_analysis(build_rig("thesis-rig"), 500.0, fmax=5e3)
    back = ModalResult.load(m.save(tmp_path / "modes.json"))
    np.testing.assert_allclose(back.freqs, m.freqs)
    np.testing.assert_allclose(back.shapes, m.shapes)
    assert m.plot().axes


def test_sweep_options_checked_before_any_run(tmp_path, capsys):
    """Revolutions below one mesh period (0 samples: an FFT traceback), a torque beyond 100x the
    operating torque and an --out blocked by a file: exit 2, one line naming the option, nothing run."""
    from gearrom.cli import main

    blocker = tmp_path / "file"
    blocker.write_text("x")
    for extra, opt in ((["--revs", "0.01"], "--revs"), (["--torque", "1e13"], "--torque"),
                       (["--out", str(blocker)], "--out")):
        argv = ["sweep", "thesis-rig", "--rpm", "1000", "--out", str(tmp_path / "o"), "--no-progress", *extra]
        assert main(argv) == 2
        err = [ln for ln in capsys.readouterr().err.splitlines() if "error:" in ln]
        assert len(err) == 1 and opt in err[0]
    assert not (tmp_path / "o" / "speeds").exists() or not any((tmp_path / "o" / "speeds").iterdir())
