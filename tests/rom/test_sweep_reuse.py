"""Sweep reuse: stored per-speed results are keyed by everything they depend on and written atomically."""
import math
import threading
import warnings
from pathlib import Path

import numpy as np
import pytest

import gearrom
import gearrom.rom.simulate as simulate_mod
from gearrom.cli import main
from gearrom.config import load_config
from gearrom.errors import ConfigError
from gearrom.excitation.analytical import analytical_excitation
from gearrom.excitation.table import MeshExcitation
from gearrom.rom.sweep import SweepResult, run_sweep

FAST = {"processes": 1, "n_output_revs": 0.25, "samples_per_mesh": 8, "progress": False, "linear": False}


@pytest.fixture
def count_runs(monkeypatch):
    """Count the simulations run in this process (the sweep runs in-process with ``processes=1``)."""
    calls = []
    real = simulate_mod.simulate_run

    def counted(model, rpm, *args, **kwargs):
        calls.append(rpm)
        return real(model, rpm, *args, **kwargs)

    monkeypatch.setattr(simulate_mod, "simulate_run", counted)
    return calls


def _table_config(tmp_path: Path, scale_e: float = 1.0, scale_k: float = 1.0) -> Path:
    """A thesis-rig config whose ``[rom] excitation`` is a NetCDF table next to it (rewritten in place)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg = load_config("thesis-rig")
    ex = analytical_excitation(cfg.pair, [60.0, 120.0, 240.0], n_theta=64)
    MeshExcitation(ex.z1, ex.theta, ex.torque, ex.k * scale_k, ex.e * scale_e, ex.load_share, ex.definition,
                   metadata=ex.metadata, pairs=ex.pairs).save(tmp_path / "table.nc")
    p = tmp_path / "rig.toml"
    p.write_text('extends = "thesis-rig"\n[rom]\nexcitation = "table.nc"\n')
    return p


def test_rewritten_excitation_table_is_not_reused(tmp_path, count_runs):
    cfg = _table_config(tmp_path)
    out = tmp_path / "out"
    first = run_sweep(cfg, [1000.0], out, **FAST)
    assert len(count_runs) == 1
    _table_config(tmp_path, scale_e=3.0, scale_k=0.5)
    second = run_sweep(cfg, [1000.0], out, **FAST)
    assert len(count_runs) == 2
    # the static TE the run replays is the table's e: three times larger in the rewritten table
    ste1, ste2 = np.ptp(first.data["ste"]), np.ptp(second.data["ste"])
    assert ste2 == pytest.approx(3 * ste1, rel=0.05)
    # the same table again: both stored results are kept apart and the first one is reused
    _table_config(tmp_path)
    third = run_sweep(cfg, [1000.0], out, **FAST)
    assert len(count_runs) == 2
    np.testing.assert_array_equal(third.data["dte_sensor"], first.data["dte_sensor"])


def test_table_rewritten_during_the_run_is_not_stored(tmp_path, monkeypatch):
    from gearrom.errors import ModelError

    cfg = _table_config(tmp_path)
    real = simulate_mod.simulate_run

    def rewrite_then_run(*args, **kwargs):
        _table_config(tmp_path, scale_e=3.0)
        return real(*args, **kwargs)

    monkeypatch.setattr(simulate_mod, "simulate_run", rewrite_then_run)
    with pytest.raises(ModelError, match="changed during the sweep"):
        run_sweep(cfg, [1000.0], tmp_path / "out", **FAST)
    assert list((tmp_path / "out" / "speeds").iterdir()) == []


def test_package_version_is_part_of_the_key(tmp_path, count_runs, monkeypatch):
    # the excitation is a stored table: another package version then changes the stored speeds' key only
    # (the FE tables of the config's default excitation carry the version in their own key, and would be
    # recomputed from the 3D FE)
    cfg = _table_config(tmp_path)
    out = tmp_path / "out"
    run_sweep(cfg, [1000.0], out, **FAST)
    run_sweep(cfg, [1000.0], out, **FAST)
    assert len(count_runs) == 1
    monkeypatch.setattr(gearrom, "__version__", gearrom.__version__ + ".post999")
    run_sweep(cfg, [1000.0], out, **FAST)
    assert len(count_runs) == 2


@pytest.mark.parametrize("module,name,still_reused", [
    ("gearrom.excitation.slices", "MODEL_REVISION", False),  # the ROM follows the pitch deviations with it
    ("gearrom.calibrate.microfe", "CODE_VERSION", True),  # a model a sweep does not run on
])
def test_speeds_of_another_model_revision_are_not_reused(tmp_path, count_runs, monkeypatch, module, name,
                                                         still_reused):
    """A rerun into the same folder reuses a stored speed only while the revisions of the models it was
    computed with are unchanged.

    Reference: the simulations run. A sweep of a config with pitch deviations on the input gear (the ROM
    follows them with the thin-slice model, :func:`gearrom.excitation.slices.pitch_te`) over a stored
    excitation table is run and rerun (reused), then the revision constant of one model is changed (as
    a code change of that model does) and the sweep rerun: the speed is simulated again when the run
    uses that model, and reused when it does not (the FE micro-geometry model of the diagnosis).
    """
    import importlib

    cfg = _table_config(tmp_path)
    z1 = load_config("thesis-rig").pair.z[0]
    pitch = ", ".join(f"{2.0 * math.sin(2 * math.pi * j / z1):.3f}" for j in range(z1))
    cfg.write_text(cfg.read_text() + f"[input_gear.microgeometry]\nenabled = true\npitch_deviations_um = [{pitch}]\n")
    out = tmp_path / "out"
    run_sweep(cfg, [1000.0], out, **FAST)
    run_sweep(cfg, [1000.0], out, **FAST)
    assert len(count_runs) == 1
    monkeypatch.setattr(importlib.import_module(module), name, "changed")
    run_sweep(cfg, [1000.0], out, **FAST)
    assert len(count_runs) == (1 if still_reused else 2)


@pytest.mark.parametrize("module,name,changes", [
    ("gearrom.excitation.slices", "MODEL_REVISION", True),
    ("gearrom.excitation.fe", "TABLE_REVISION", True),  # the nominal FE table of thesis-rig
    ("gearrom.fe.compliance3d", "CODE_VERSION", True),  # the 3D compliances behind that table
    ("gearrom.fe.compliance", "CODE_VERSION", False),  # plane-strain compliances: not the helical table's model
    ("gearrom.excitation.fe", "SLICES_REVISION", False),  # the helical slice LTCA: not the table's model
    ("gearrom.calibrate.microfe", "CODE_VERSION", False),
])
def test_fe_excitation_revisions_are_part_of_the_key(monkeypatch, module, name, changes):
    """The reuse key of a sweep on the ``"fe"`` excitation (thesis-rig's) changes with the revision of every
    model its speeds are built from, and only with those (no table is computed for the key)."""
    import importlib

    from gearrom.rom.sweep import reuse_key

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cfg = load_config("thesis-rig")
    before = reuse_key(cfg, 120.0, 1.0, 64, False)
    monkeypatch.setattr(importlib.import_module(module), name, "changed")
    assert (reuse_key(cfg, 120.0, 1.0, 64, False) != before) is changes


def test_torques_do_not_overwrite_each_other(tmp_path, count_runs):
    # a stored table holding both torques: the FE excitation of the config would compute a second FE table
    # for the other torque's map, which is not what this test is about
    cfg = _table_config(tmp_path)
    out = tmp_path / "out"
    a = run_sweep(cfg, [1000.0], out, torque_out=120.0, **FAST)
    b = run_sweep(cfg, [1000.0], out, torque_out=60.0, **FAST)
    assert len(list((out / "speeds").glob("*.nc"))) == 2
    again = run_sweep(cfg, [1000.0], out, torque_out=120.0, **FAST)
    assert len(count_runs) == 2
    np.testing.assert_array_equal(again.data["force"], a.data["force"])
    assert b.metadata["torque_out_Nm"] == 60.0 and again.metadata["torque_out_Nm"] == 120.0


def test_close_speeds_have_their_own_files(tmp_path, count_runs):
    out = tmp_path / "out"
    res = run_sweep("thesis-rig", [1000.0, 1000.001], out, **FAST)
    assert len(list((out / "speeds").glob("*.nc"))) == 2
    assert [s["rpm_in"] for s in res.summary] == [1000.0, 1000.001]
    run_sweep("thesis-rig", [1000.001], out, **FAST)
    assert count_runs == [1000.0, 1000.001]


def test_repeated_speed_is_rejected(tmp_path, count_runs):
    with pytest.raises(ConfigError, match="1000"):
        run_sweep("thesis-rig", [1000.0, 2000.0, 1000.0], tmp_path / "out", **FAST)
    assert count_runs == []


def test_cli_repeated_speed_names_rpm(tmp_path, capsys, count_runs):
    assert main(["sweep", "thesis-rig", "--rpm", "1000,1000", "--out", str(tmp_path / "o"), "--revs", "0.25",
                 "--no-progress", "--processes", "1", "--no-linear"]) == 2
    err = capsys.readouterr().err
    assert "--rpm" in err and "1000" in err
    assert count_runs == []


@pytest.mark.parametrize("value", ["-120", "0", "nan", "inf"])
def test_cli_bad_torque_names_option(tmp_path, capsys, value):
    assert main(["sweep", "thesis-rig", "--rpm", "1000", "--torque", value, "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--torque" in err and "N m" in err and value in err
    assert "analytical_excitation" not in err


def test_api_bad_torque_is_config_error(tmp_path):
    with pytest.raises(ConfigError, match="torque_out"):
        run_sweep("thesis-rig", [1000.0], tmp_path / "out", torque_out=-120.0, **FAST)


@pytest.mark.parametrize("damage", ["empty", "truncated"])
def test_damaged_stored_speed_is_recomputed_with_one_warning(tmp_path, count_runs, damage):
    out = tmp_path / "out"
    first = run_sweep("thesis-rig", [1000.0], out, **FAST)
    (f,) = (out / "speeds").glob("*.nc")
    raw = f.read_bytes()
    f.write_bytes(b"" if damage == "empty" else raw[: len(raw) // 2])
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        again = run_sweep("thesis-rig", [1000.0], out, **FAST)
    msgs = [str(w.message) for w in rec if f.name in str(w.message)]
    assert len(msgs) == 1 and "\n" not in msgs[0] and "recomput" in msgs[0]
    assert len(count_runs) == 2
    np.testing.assert_allclose(again.data["dte_sensor"], first.data["dte_sensor"])


def test_interrupted_write_keeps_the_previous_file(tmp_path, monkeypatch):
    import xarray as xr

    out = tmp_path / "out"
    res = run_sweep("thesis-rig", [1000.0], out, **FAST)
    target = res.save(out / "sweep.nc")
    before = target.read_bytes()

    def broken(self, path=None, *args, **kwargs):
        Path(path).write_bytes(b"half a file")
        raise KeyboardInterrupt

    monkeypatch.setattr(xr.Dataset, "to_netcdf", broken)
    with pytest.raises(KeyboardInterrupt):
        res.save(target)
    monkeypatch.undo()
    assert target.read_bytes() == before
    assert sorted(p.name for p in out.iterdir()) == ["speeds", "sweep.nc"]
    assert SweepResult.load(target).rpm.tolist() == [1000.0]


def test_cli_interrupted_outputs_keep_the_previous_files(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    out = tmp_path / "o"
    args = ["sweep", "thesis-rig", "--rpm", "1000", "--out", str(out), "--revs", "0.25", "--no-progress",
            "--processes", "1", "--no-linear"]
    assert main(args) == 0
    before = {f: (out / f).read_bytes() for f in ("summary.json", "waterfall.png", "gmf_vs_speed.png")}

    def broken(self, fname, *a, **kw):
        if isinstance(fname, (str, Path)):
            Path(fname).write_bytes(b"half a picture")
        else:
            fname.write(b"half a picture")
        raise KeyboardInterrupt

    monkeypatch.setattr(Figure, "savefig", broken)
    assert main(args) == 130
    assert {f: (out / f).read_bytes() for f in before} == before
    assert not [p.name for p in out.iterdir() if p.name.startswith(".")]  # no temporary file left


def test_concurrent_writers_of_one_file_do_not_collide(tmp_path):
    from gearrom.rom.sweep import write_netcdf_atomic

    res_ds = SweepResult("c", np.array([1.0]), {"dte_sensor": np.zeros((1, 64))}, 8, (1, 1),
                         [{"gmf_amplitude_um": [0.0], "dynamic_factor": 1.0, "contact_loss": False}]).to_dataset()
    target = tmp_path / "shared.nc"
    errors = []

    def write():
        try:
            for _ in range(5):
                write_netcdf_atomic(res_ds, target)
        except Exception as exc:  # noqa: BLE001 (collected for the assertion)
            errors.append(exc)

    threads = [threading.Thread(target=write) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert [p.name for p in tmp_path.iterdir()] == ["shared.nc"]
    assert SweepResult.load(target).rpm.tolist() == [1.0]
