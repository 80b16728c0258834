"""FE tables as the ROM's excitation (``[rom] excitation = "fe"``): content-keyed cache, torque map,
the ROM's quasi-static deflection against the LTCA, and the sweep's record of its excitation.

Reference: the LTCA solved directly at each torque over a mesh period (the quasi-static FE, not the
table); the ROM's mesh deflection at a crawl speed must equal the static TE within 2 % (mean), also at
a torque between the table's torque-map points.
"""
from __future__ import annotations

import json
import logging

import numpy as np
import pytest

from gearrom.config import load_config
from gearrom.excitation.fe import fe_excitation, torque_map



@pytest.fixture(scope="module")
def rig_config(spur_fe_rig_config):
    return spur_fe_rig_config


@pytest.fixture(scope="module")
def MESH(spur_fe_mesh):  # noqa: N802 (the mesh constant of the FE tests)
    return spur_fe_mesh


def test_torque_map_brackets_the_operating_torque():
    tq = torque_map(120.0)
    assert tq[0] == pytest.approx(30.0) and tq[-1] == pytest.approx(240.0) and 120.0 in tq


def test_table_is_cached_by_content(tmp_path, monkeypatch, MESH):
    pair = load_config("thesis-spur").pair
    first = fe_excitation(pair, [60.0, 120.0], 8, MESH, cache_dir=tmp_path)
    assert first.metadata["source"] == "fe" and len(list((tmp_path / "tables").glob("table-*.nc"))) == 1
    import gearrom.fe.sweep as fesweep

    def no_fe(*a, **k):
        raise AssertionError("the cached table must be used, not a new FE solve")

    monkeypatch.setattr(fesweep, "build_ltca", no_fe)
    again = fe_excitation(pair, [120.0, 60.0], 8, MESH, cache_dir=tmp_path)
    np.testing.assert_array_equal(again.e, first.e)
    assert again.metadata["cache_key"] == first.metadata["cache_key"]
    with pytest.raises(AssertionError, match="cached table"):  # another torque map is another entry
        fe_excitation(pair, [60.0, 120.0, 240.0], 8, MESH, cache_dir=tmp_path)


def test_damaged_table_is_recomputed(tmp_path, caplog, MESH):
    pair = load_config("thesis-spur").pair
    first = fe_excitation(pair, [120.0], 8, MESH, cache_dir=tmp_path)
    (entry,) = (tmp_path / "tables").glob("table-*.nc")
    entry.write_bytes(entry.read_bytes()[:100])
    with caplog.at_level(logging.WARNING, logger="gearrom.fe.cache"):
        again = fe_excitation(pair, [120.0], 8, MESH, cache_dir=tmp_path)
    assert sum("damaged" in r.getMessage() and str(entry) in r.getMessage() for r in caplog.records) == 1
    np.testing.assert_allclose(again.e, first.e, rtol=1e-12)


def test_rom_crawl_deflection_matches_the_ltca_static_te(rig_config, MESH):
    """0.5x, 1x, 2x the operating torque and 100 N m (between map points 90 and 120)."""
    from gearrom.fe.sweep import build_ltca
    from gearrom.rom.rig import build_rig
    from gearrom.rom.simulate import simulate_run

    model = build_rig(rig_config)
    assert model.excitation.metadata["source"] == "fe"
    ltca = build_ltca(model.pair, MESH)
    z1 = model.pair.z[0]
    thetas = (np.arange(16) + 0.5) * ltca.period / 16
    for torque in (60.0, 100.0, 120.0, 240.0):
        ref = np.mean([ltca.solve(th, torque).ste for th in thetas])
        t_mesh = 60.0 / 10.0 / z1
        run = simulate_run(model, 10.0, torque, duration_s=t_mesh, settle_s=0.2 * t_mesh)
        assert run.delta.mean() == pytest.approx(ref, rel=0.02), torque


def test_sweep_records_its_excitation(rig_config, tmp_path):
    from gearrom.cli import main

    out = tmp_path / "sw"
    assert main(["sweep", str(rig_config), "--rpm", "1500", "--revs", "0.5", "--out", str(out), "--no-progress",
                 "--no-linear", "--processes", "1"]) == 0
    exc = json.loads((out / "summary.json").read_text())["excitation"]
    assert exc["source"] == "fe" and len(exc["cache_key"]) == 24 and exc["torques_Nm"][0] == pytest.approx(30.0)
    from gearrom.rom.sweep import SweepResult

    assert SweepResult.load(out / "sweep.nc").metadata["excitation"] == exc


def test_drawing_tip_relief_reaches_the_sweep_through_the_table(spur_fe_rig_config, tmp_path):
    """A tip relief in the config changes the FE table, and the sweep's mesh deflection at a low speed
    (quasi-static: the deflection follows the static TE) shows the table's GMF amplitudes.

    Reference: the FE table's own STE harmonics at the operating torque (the quasi-static FE); the
    sweep at 30 rpm (GMF 16 Hz, below every mode of the rig; at 250 rpm the second GMF order already
    meets the rig's lowest torsional modes) must reproduce GMF orders 1 and 2 within 3 % of the
    table's amplitude, with and without the relief, and the relief must change GMF1.
    """
    from gearrom.rom.rig import build_rig
    from gearrom.rom.sweep import run_sweep

    relieved = tmp_path / "relief.toml"
    relief = "enabled = true\ntip_relief_um = 12.0\ntip_relief_start_diameter_mm = 49.8\n"
    relieved.write_text(f'extends = "{spur_fe_rig_config}"\nname = "spur-rig-fe-relief"\n'
                        f"[input_gear.microgeometry]\n{relief}[output_gear.microgeometry]\n"
                        f"enabled = true\ntip_relief_um = 12.0\ntip_relief_start_diameter_mm = 63.3\n")
    gmf = {}
    for name, cfg in (("nominal", spur_fe_rig_config), ("relief", relieved)):
        table = build_rig(cfg).excitation.harmonics(120.0, 2).ste
        res = run_sweep(str(cfg), [30.0], tmp_path / name, processes=1, n_output_revs=10 / 41, samples_per_mesh=32,
                        progress=False, linear=False)
        orders, amp = res.spectrum("delta")
        z1 = res.z[0]
        sim = [amp[0, np.argmin(abs(orders - m * z1))] for m in (1, 2)]
        for m in (1, 2):
            assert sim[m - 1] == pytest.approx(abs(table[m]), rel=0.03), (name, m)
        gmf[name] = abs(table[1])
    assert abs(gmf["relief"] / gmf["nominal"] - 1) > 0.2


def test_helical_strip_count_is_part_of_the_table_key():
    """A helical table on another strip count is another table; the default strip count keeps the key
    that tables without the setting have (cached tables stay valid), and a spur table has no strips."""
    from gearrom.excitation.fe import DEFAULT_SLICES, table_key

    helical = load_config("thesis-helical").pair
    spur = load_config("thesis-spur").pair
    base = table_key(helical, [120.0], 64)
    assert table_key(helical, [120.0], 64, n_slices=DEFAULT_SLICES) == base
    assert table_key(helical, [120.0], 64, n_slices=96) != base
    assert table_key(spur, [120.0], 64, n_slices=96) == table_key(spur, [120.0], 64)


@pytest.mark.parametrize("config,helical_model,changes_with", [
    ("thesis-spur", "3d", "gearrom.fe.compliance"),              # spur: plane-strain compliances
    ("thesis-helical", "3d", "gearrom.fe.compliance3d"),         # helical 3D LTCA: 3D sector compliances
    ("thesis-helical", "slices", "gearrom.fe.compliance"),       # helical slice LTCA: plane-strain sections
])
def test_table_key_follows_the_revision_of_its_compliances(monkeypatch, config, helical_model, changes_with):
    """The compliances are cached under keys of their own: a table's key (and the key of the diagnosis'
    FE micro-geometry tables) changes with the code revision of the compliances its LTCA is built on,
    and not with the other kind's."""
    import importlib

    from gearrom.calibrate import MicroMods
    from gearrom.calibrate.microfe import FEMicroModel
    from gearrom.excitation.fe import table_key

    pair = load_config(config).pair
    micro = FEMicroModel(helical_model=helical_model)
    before = (table_key(pair, [120.0], 64, helical_model=helical_model), micro.table_key(pair, [120.0], MicroMods()))
    for module in ("gearrom.fe.compliance", "gearrom.fe.compliance3d"):
        with monkeypatch.context() as m:
            m.setattr(importlib.import_module(module), "CODE_VERSION", "changed")
            after = (table_key(pair, [120.0], 64, helical_model=helical_model),
                     micro.table_key(pair, [120.0], MicroMods()))
            assert [a != b for a, b in zip(after, before)] == [module == changes_with] * 2, module
