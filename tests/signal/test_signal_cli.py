"""``gearrom te``: outputs, gear data from --config / the JSON's config key, one-line errors (exit 2)."""
from __future__ import annotations

import json

import pytest

from gearrom.cli import main


def test_te_cli_outputs(base_run, tmp_path, capsys):
    out, png, npz = tmp_path / "te.json", tmp_path / "te.png", tmp_path / "te.npz"
    rc = main(["te", str(base_run), "--json", str(out), "--plot", str(png), "--save", str(npz)])
    assert rc == 0
    d = json.loads(out.read_text())
    for key in ("rpm_in", "te_rms_um", "te_ptp_um", "gmf_hz", "gmf_amplitude_um", "repairs"):
        assert key in d
    assert len(d["gmf_amplitude_um"]) == 3 and d["repairs"] == []
    # known components (conftest): 5, 2, 1 um; default gear data = thesis-helical config
    assert d["gmf_amplitude_um"] == pytest.approx([5.0, 2.0, 1.0], rel=0.01)
    assert d["gear"]["z1"] == 32 and png.stat().st_size > 10_000 and npz.stat().st_size > 0
    assert "rpm" in capsys.readouterr().out


def test_te_cli_pitch_and_config_key(base_run, tmp_path, capsys):
    doc = json.loads(base_run.read_text())
    doc["config"] = "thesis-helical"
    doc["data"] = str(base_run.parent / "run.csv")
    (tmp_path / "m.json").write_text(json.dumps(doc))
    assert main(["te", str(tmp_path / "m.json"), "--te-on", "pitch", "--json", "-", "--allow-outside-data"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["te_on"] == "pitch" and d["gear"]["name"] == "thesis-helical"
    # pitch TE = line TE / cos(alpha_t), alpha_t = 19.825 deg (reference-values.md)
    assert d["gmf_amplitude_um"][0] == pytest.approx(5.0 / 0.940732, rel=0.01)


def test_te_cli_errors_are_one_line(base_run, tmp_path, capsys):
    (tmp_path / "bad.json").write_text('{"format": "gearrom.measurement/1"}')
    assert main(["te", str(tmp_path / "bad.json")]) == 2
    err = capsys.readouterr().err
    assert "bad.json" in err and "missing key" in err and len(err.strip().splitlines()) == 1
    assert main(["te", str(base_run), "--lowpass-hz", "-5"]) == 2
    assert "lowpass_hz" in capsys.readouterr().err


def test_te_cli_signal_section_and_override(base_run, tmp_path, capsys):
    """[signal] of the config sets the low-pass; a CLI option overrides it. The zero-phase Bessel low-pass at
    1000 Hz scales the 666.7 Hz GMF line by |H|^2 of the analog Bessel filter (scipy.signal.freqs)."""
    import math

    from scipy import signal

    cfg = tmp_path / "pair.toml"
    cfg.write_text('extends = "thesis-helical"\nname = "with-signal"\n[signal]\nlowpass_hz = 1000.0\nte_on = "line"\n')
    assert main(["te", str(base_run), "--config", str(cfg), "--json", "-"]) == 0
    d = json.loads(capsys.readouterr().out)
    b, a = signal.bessel(4, 2 * math.pi * 1000.0, analog=True, norm="mag")
    h = abs(signal.freqs(b, a, worN=[2 * math.pi * 32 * 1250 / 60])[1][0]) ** 2
    assert d["filters"]["lowpass_hz"] == 1000.0 and d["gmf_amplitude_um"][0] == pytest.approx(5 * h, rel=0.01)
    assert main(["te", str(base_run), "--config", str(cfg), "--lowpass-hz", "20000", "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["filters"]["lowpass_hz"] == 20000.0
    cfg.write_text('extends = "thesis-helical"\n[signal]\nlowpass_herz = 1000.0\n')
    assert main(["te", str(base_run), "--config", str(cfg)]) == 2
    assert "lowpass_herz" in capsys.readouterr().err
