"""Reliability of the measurement pipeline and its CLI: results independent of the working directory,
options checked before any computation and named in errors, data files confined to the measurement
folder, outputs written into missing folders, float64 time-stamp resolution reported."""
from __future__ import annotations

import json
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from gearrom.cli import main
from gearrom.errors import ConfigError, MeasurementError
from gearrom.signal import ReadSettings, load_angles, settings_from_section


def _copy_run(base_run: Path, folder: Path, **changes) -> Path:
    """The base run's JSON (with ``changes``) and its data file copied into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(base_run.with_suffix(".csv"), folder / "run.csv")
    doc = json.loads(base_run.read_text())
    doc.update(changes)
    (folder / "run.json").write_text(json.dumps(doc))
    return folder / "run.json"


def _one_line_error(err: str, option: str) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and option in lines[0] and "Traceback" not in err, err


def test_config_key_resolved_next_to_the_json(base_run, tmp_path, monkeypatch, capsys):
    """A path in the JSON's 'config' key is relative to the JSON (like 'data'), so the TE does not depend on
    the working directory; the config's [signal] low-pass makes a wrong config visible in the result."""
    meas = tmp_path / "meas"
    path = _copy_run(base_run, meas, config="pair.toml")
    (meas / "pair.toml").write_text('extends = "thesis-helical"\nname = "local"\n[signal]\nlowpass_hz = 1000.0\n')
    results = []
    for cwd in (meas, tmp_path, tmp_path / "elsewhere"):
        cwd.mkdir(exist_ok=True)
        monkeypatch.chdir(cwd)
        rel = Path(__import__("os").path.relpath(path, cwd))
        assert main(["te", str(rel), "--json", "-"]) == 0, capsys.readouterr().err
        d = json.loads(capsys.readouterr().out)
        assert d["filters"]["lowpass_hz"] == 1000.0
        results.append(d["gmf_amplitude_um"])
    assert results[0] == results[1] == results[2]


def test_bundled_config_name_stays_a_name(base_run, tmp_path):
    from gearrom.signal import read_meta

    path = _copy_run(base_run, tmp_path, config="thesis-helical")
    assert read_meta(path).config == "thesis-helical"
    path = _copy_run(base_run, tmp_path, config="sub/pair.toml")
    assert read_meta(path).config == str((tmp_path / "sub" / "pair.toml").resolve())


@pytest.mark.parametrize("argv, option", [
    (["--plot", "x.xyz"], "--plot"),
    (["--fs-hz", "1e10"], "--fs-hz"),
    (["--fs-hz", "nan"], "--fs-hz"),
    (["--rpm-tolerance", "-1"], "--rpm-tolerance"),
    (["--lowpass-order", "40"], "--lowpass-order"),
    (["--lowpass-hz", "50000"], "--lowpass-hz"),  # above the Nyquist frequency of the 83.3 kHz grid
])
def test_te_bad_option_is_one_line_before_reading(base_run, tmp_path, monkeypatch, capsys, argv, option):
    """Each bad option is refused before the data are read (load_angles is never reached)."""
    import gearrom.signal

    def never(*a, **k):
        raise AssertionError("the data were read before the option was checked")

    monkeypatch.setattr(gearrom.signal, "load_angles", never)
    assert main(["te", str(base_run), *argv]) == 2
    _one_line_error(capsys.readouterr().err, option)


def test_plot_extension_lists_the_supported_ones(base_run, capsys):
    assert main(["te", str(base_run), "--plot", "x.xyz"]) == 2
    err = capsys.readouterr().err
    assert ".xyz" in err and ".png" in err and ".pdf" in err


def test_campbell_negative_fmax(capsys):
    assert main(["campbell", "thesis-rig", "--fmax", "-5"]) == 2
    _one_line_error(capsys.readouterr().err, "--fmax")


def test_override_error_names_the_option_not_the_section():
    with pytest.raises(ConfigError) as exc:
        settings_from_section({"lowpass_hz": 1000.0}, "pair.toml", {"lowpass_order": 20},
                              {"lowpass_order": "--lowpass-order"})
    assert "--lowpass-order" in str(exc.value) and "[signal]" not in str(exc.value)
    with pytest.raises(ConfigError) as exc:  # a bad section value is still blamed on the section
        settings_from_section({"lowpass_order": 20}, "pair.toml", {"lowpass_hz": 1000.0},
                              {"lowpass_hz": "--lowpass-hz"})
    assert "pair.toml" in str(exc.value) and "--lowpass-hz" not in str(exc.value)


def test_te_outputs_into_missing_folders(base_run, tmp_path):
    out = tmp_path / "a" / "b"
    assert main(["te", str(base_run), "--json", str(out / "te.json"), "--save", str(out / "c" / "te.npz"),
                 "--plot", str(out / "d" / "te.png")]) == 0
    assert (out / "te.json").is_file() and (out / "c" / "te.npz").is_file() and (out / "d" / "te.png").is_file()


class _FakeDiagnosis:
    def to_json(self) -> str:
        return '{"diagnosis": 1}\n'

    def text(self) -> str:
        return "diagnosis\n"

    def save(self, path):
        Path(path).write_bytes(b"npz")

    def write_report(self, directory):
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        (d / "diagnosis.json").write_text(self.to_json())
        raise RuntimeError("a figure failed")  # the JSON written before must survive this


def test_diagnose_json_into_missing_folder_is_written(base_run, tmp_path, monkeypatch):
    """The diagnosis JSON goes into a folder that does not exist yet, before anything else can fail."""
    import gearrom.calibrate
    import gearrom.calibrate.simulator

    monkeypatch.setattr(gearrom.calibrate.simulator, "default_simulator", lambda *a, **k: object())
    monkeypatch.setattr(gearrom.calibrate, "diagnose", lambda *a, **k: _FakeDiagnosis())
    out = tmp_path / "new" / "deeper" / "d.json"
    with pytest.raises(RuntimeError):
        main(["diagnose", "thesis-helical", str(base_run), "--torque-out-Nm", "100", "--json", str(out),
              "--save", str(tmp_path / "n2" / "d.npz"), "--report", str(tmp_path / "rep")])
    assert out.read_text() == '{"diagnosis": 1}\n' and (tmp_path / "n2" / "d.npz").is_file()


def test_diagnose_bad_output_refused_before_the_diagnosis(base_run, tmp_path, monkeypatch, capsys):
    import gearrom.calibrate.simulator

    def never(*a, **k):
        raise AssertionError("the model was built before the outputs were checked")

    monkeypatch.setattr(gearrom.calibrate.simulator, "default_simulator", never)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["diagnose", "thesis-helical", str(base_run), "--json", str(blocker / "d.json")]) == 2
    _one_line_error(capsys.readouterr().err, "--json")


@pytest.fixture
def outside_run(base_run, tmp_path) -> Path:
    """A measurement whose 'data' climbs out of its folder to a file holding a secret."""
    secret = tmp_path / "secret"
    secret.mkdir()
    (secret / "x.csv").write_text("password=hunter2\ninput,0.0\n")
    return _copy_run(base_run, tmp_path / "meas", data="../secret/x.csv")


def test_data_outside_the_folder_is_refused(outside_run, capsys):
    with pytest.raises(MeasurementError, match="outside") as exc:
        load_angles(outside_run)
    assert "hunter2" not in str(exc.value)
    assert main(["te", str(outside_run)]) == 2
    err = capsys.readouterr().err
    assert "outside" in err and "--allow-outside-data" in err and "hunter2" not in err


def test_allowed_outside_data_is_not_quoted(outside_run, capsys):
    with pytest.raises(MeasurementError, match="header") as exc:
        load_angles(outside_run, ReadSettings(allow_outside_data=True))
    assert "hunter2" not in str(exc.value)
    assert main(["te", str(outside_run), "--allow-outside-data"]) == 2
    assert "hunter2" not in capsys.readouterr().err


def test_inside_data_is_still_quoted(base_run, tmp_path):
    path = _copy_run(base_run, tmp_path)
    (tmp_path / "run.csv").write_text("channel,t_s\ninput,0.0\nwheel,1.0\n")
    with pytest.raises(MeasurementError, match="wheel"):
        load_angles(path)


def test_epoch_timestamps_warn_with_the_resolution_lost(base_run, tmp_path):
    """Unix-time stamps (1.7e9 s) keep a float64 spacing of 2.4e-7 s: reported against the edge interval."""
    import pandas as pd

    path = _copy_run(base_run, tmp_path)
    df = pd.read_csv(tmp_path / "run.csv")
    df["t_s"] = df["t_s"] + 1.7e9
    df.to_csv(tmp_path / "run.csv", index=False, float_format="%.9f")
    with pytest.warns(UserWarning, match=r"resolution of 2\.38e-07 s") as rec:
        try:
            load_angles(path)
        except MeasurementError:
            pass  # the quantised stamps may not be readable; the warning comes first
    assert "interval" in str(rec[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_angles(base_run)  # time from zero: no warning


def test_grid_size_is_bounded(base_run):
    with pytest.raises(MeasurementError, match="max_grid_samples"):
        load_angles(base_run, ReadSettings(fs_hz=1e6, max_grid_samples=100_000))


@pytest.mark.parametrize("kw", [{"rpm_tolerance": -1.0}, {"rpm_tolerance": float("nan")}, {"fs_hz": float("inf")},
                                {"max_grid_samples": 3}])
def test_read_settings_checked(kw):
    with pytest.raises(ConfigError, match=next(iter(kw))):
        ReadSettings(**kw)


def test_angle_grid_is_bounded(tmp_path):
    from gearrom.signal import AngleRecord, write_measurement

    t = np.arange(1000) / 1000.0
    rec = AngleRecord(t, 2 * np.pi * 10 * t, 2 * np.pi * 5 * t)
    path = write_measurement(tmp_path / "a.json", rec, rpm_in=600.0)
    with pytest.raises(MeasurementError, match="max_grid_samples"):
        load_angles(path, ReadSettings(fs_hz=1e9, max_grid_samples=10_000))
