"""Integer speed ratios (15/30: input order 1 = output order 2), [signal] settings in the diagnosis, and a
sampled A/B run-up of the bundled ``stage-15-30`` config through ``gearrom diagnose``.

References: analytic line amplitudes of synthetic angle records, and for the end-to-end cases the
effect injected into the emulated recording (:mod:`stage_quad`: torsional rig model, DAQ emulation at
50 kHz, 1000-line encoders, start-up / steady / stop).
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from gearrom.testing import Injected
from gearrom.calibrate.residual import coinciding_lines, fit_lines, load_run
from gearrom.errors import MeasurementError
from gearrom.signal import GearMeshInfo, TESettings

sys.path.insert(0, str(Path(__file__).parent))
from stage_quad import CONFIG, write_stage_run  # noqa: E402

UM = 1e-6


def _angles(ratio: float, revs_in: float = 4.0, te_um: float = 0.5, n: int = 20000):
    th1 = np.linspace(0.0, 2 * math.pi * revs_in, n)
    th2 = ratio * th1 - te_um * UM / 0.03 * np.cos(15 * th1)  # a TE-sized wobble makes the columns not identical
    return th1, th2


def test_coinciding_lines_fitted_as_one():
    """15/30: lines [1, 0] and [0, 2] are one line; the fit gives its analytic amplitude to both names
    instead of two huge cancelling ones; a 32/41 pair's order 1 of each shaft stays two lines."""
    th1, th2 = _angles(0.5)
    y = 3 * UM * np.cos(th1 + 0.4) + 1 * UM * np.cos(0.5 * th1 - 0.2)
    keep, inv = coinciding_lines(th1, th2, [[1, 0], [0, 2], [0, 1]])
    assert keep.tolist() == [0, 2] and inv.tolist() == [0, 0, 1]
    c = fit_lines(y, th1, th2, np.array([[1.0, 0.0], [0.0, 2.0], [0.0, 1.0]]))
    assert abs(c[0]) == pytest.approx(3 * UM, rel=1e-3) and c[1] == c[0]
    assert abs(c[2]) == pytest.approx(1 * UM, rel=1e-3)
    th1, th2 = _angles(32 / 41)
    keep, _ = coinciding_lines(th1, th2, [[1, 0], [0, 1], [0, 2]])
    assert keep.tolist() == [0, 1, 2]


@pytest.fixture(scope="module")
def stage_runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("stage")
    return {"ecc": write_stage_run(d / "ecc.json", Injected(eccentricity={"input_gear": (10.0, 40.0)}), seed=2),
            "clean": write_stage_run(d / "clean.json", seed=1), "dir": d}


def test_diagnose_passes_signal_settings(stage_runs, tmp_path, monkeypatch):
    """The config's [signal] section reaches the run reader (reference: the values written into the TOML)."""
    import importlib

    dg = importlib.import_module("gearrom.calibrate.diagnose")
    from gearrom.config import load_config

    src = Path(load_config(CONFIG, check=False).source).read_text()
    cfg = tmp_path / "stage.toml"
    cfg.write_text(src + '\n[signal]\nestimate_scale = "output"\nratio_tolerance = 0.02\nmin_speed_fraction = 0.1\n')
    seen = {}

    class Stop(Exception):
        pass

    def fake(path, mesh, torque, read_settings, te_settings):
        seen.update(read=read_settings, te=te_settings)
        raise Stop

    monkeypatch.setattr(dg, "load_run", fake)
    with pytest.raises(Stop):
        dg.diagnose(cfg, [stage_runs["clean"]])
    assert seen["te"].estimate_scale == "output" and seen["te"].ratio_tolerance == 0.02
    assert seen["read"].min_speed_fraction == 0.1


def test_load_run_estimates_encoder_scale(tmp_path):
    """An output encoder that counts 1 % more than its nominal lines: refused by the ratio check, read with
    ``estimate_scale="output"`` (reference: the emulated sensor ratio 1.01)."""
    from gearrom.signal.daq import DAQSettings

    p = write_stage_run(tmp_path / "scaled.json", daq=DAQSettings(sample_rate_hz=50e3), out_ratio=1.01)
    mesh = GearMeshInfo.from_config(CONFIG)
    with pytest.raises(MeasurementError, match="speed ratio"):
        load_run(p, mesh)
    run = load_run(p, mesh, te_settings=TESettings(estimate_scale="output"))
    assert run.revs_out > 1 and run.info["steady_window_s"][1] > run.info["steady_window_s"][0]
    assert float(np.sqrt(np.mean(run.y[0] ** 2))) < 3 * UM  # no 1 % ratio ramp left in the TE


def test_stage_runup_diagnose_cli(stage_runs, tmp_path, capsys):
    """Acceptance: ``gearrom diagnose stage-15-30 FILE`` on a sampled A/B run-up with 10 um runout of the
    input gear (order 1 in = order 2 out): one effect, 10 um within 1 um, the line reported under both names."""
    from gearrom.cli import main

    out = tmp_path / "d.json"
    assert main(["diagnose", CONFIG, str(stage_runs["ecc"]), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    d = json.loads(out.read_text())
    assert [(e["effect"], e["target"]) for e in d["effects"]] == [("eccentricity", "input_gear")]
    assert d["effects"][0]["parameters"]["amplitude_um"] == pytest.approx(10.0, abs=1.0)
    assert "order 2 of the output shaft, the same line" in d["effects"][0]["evidence"]
    rows = d["runs"][0]["orders"]
    row = next(r for r in rows if "1x f_in" in r["names"])
    assert row["names"] == ["1x f_in", "2x f_out"] and row["before_um"] == pytest.approx(10.0, abs=1.0)
    assert sum("2x f_out" in r["names"] for r in rows) == 1
    assert d["runs"][0]["steady_window_s"] and "steady part" in text


@pytest.mark.slow
def test_stage_runup_clean_no_effect(stage_runs, tmp_path):
    """A clean recording (the nominal model only) gets no effect; what stays is the encoders' line order
    (x4 decoding of A/B with a 0.1 rad phase error: input order 1000 = output order 2000)."""
    from gearrom.cli import main

    out = tmp_path / "d.json"
    assert main(["diagnose", CONFIG, str(stage_runs["clean"]), "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["effects"] == []
    for u in d["unexplained"]:
        assert u["order_at_this_run"] > 900, u
