"""Fixtures of the diagnosis tests: synthetic measurements with undeclared effects, generated at test time.

Each data set is simulated by the torsional rig model with effects injected from their physical
definitions (:mod:`gearrom.testing.synthetic`), emulated as encoder edges (40000 edges/rev,
80 MHz counter, 2 ns jitter, 0.2 urad line errors) and written as ``gearrom.measurement/1`` files.
Data sets and diagnoses are cached per session, so several tests can look at one diagnosis. The
acceptance data of the closed loop are made by the exudyn ROM with its own effect models (``rom_*`` fixtures).
"""
from __future__ import annotations

import pytest

from gearrom.calibrate import FitSettings, TorsionalRig, diagnose
from gearrom.testing import Injected, make_run


@pytest.fixture(scope="session")
def rigs():
    return {}


@pytest.fixture(scope="session")
def dataset(tmp_path_factory, rigs):
    """``dataset(key, injected, speeds=(1250, 2500), config="thesis-helical", revs_out=2, **emulation)``."""
    cache = {}

    def make(key, injected=None, speeds=(1250.0, 2500.0), config="thesis-helical", revs_out=2.0, **kw):
        if key not in cache:
            if config not in rigs:
                rigs[config] = TorsionalRig.from_config(config)
            d = tmp_path_factory.mktemp(key)
            cache[key] = [make_run(d / f"run_{int(rpm)}.json", config, rpm, simulator=rigs[config],
                                   injected=injected or Injected(), revs_out=revs_out, seed=int(rpm), **kw)
                          for rpm in speeds]
        return cache[key]

    return make


#: Data made by the diagnosis' own model (only the injected effect differs): no model error, so the
#: model-uncertainty floor of real or independent data (FitSettings.model_floor_um) is off and effects
#: down to the noise are attributable.
SELF_MADE = FitSettings(model_floor_um=0.0)


@pytest.fixture(scope="session")
def diagnosed(dataset, rigs):
    """``diagnosed(key, injected, ...)``: the diagnosis of a data set (cached)."""
    cache = {}

    def run(key, injected=None, config="thesis-helical", settings: FitSettings | None = None, **kw):
        if key not in cache:
            paths = dataset(key, injected, config=config, **kw)
            cache[key] = diagnose(config, paths, simulator=rigs[config], settings=settings or SELF_MADE)
        return cache[key]

    return run


# ------------------------------------------------------------------ data made by the exudyn ROM
ROM_CONFIG = "thesis-rig"


@pytest.fixture(scope="session")
def rom_sims():
    """One diagnosis model per config (the configs' nominal ROM, caches shared by all tests)."""
    pytest.importorskip("exudyn")
    from gearrom.calibrate import RomSimulator

    cache = {}

    def get(config=ROM_CONFIG):
        if config not in cache:
            cache[config] = RomSimulator(config)
        return cache[config]

    return get


@pytest.fixture(scope="session")
def rom_dataset(tmp_path_factory):
    """``rom_dataset(key, injected, speeds=(1250,), config="thesis-rig", **kw)`` -> [(path, info), ...]:
    runs simulated by the exudyn ROM with its own effect models, emulated as encoder edges (40000 and
    36000 edges/rev, 80 MHz counter, 2 ns jitter, 0.2 urad line errors, random start and disc angles,
    2.3 output revolutions) and written as ``gearrom.measurement/1`` files. Cached per session."""
    pytest.importorskip("exudyn")
    from gearrom.testing.synthetic import make_rom_run, rom_model

    cache = {}

    def make(key, injected, speeds=(1250.0,), config=ROM_CONFIG, torque_out_Nm=120.0, **kw):
        if key not in cache:
            d = tmp_path_factory.mktemp(f"rom_{key}")
            model = rom_model(config, torque_out_Nm, injected)
            cache[key] = [make_rom_run(d / f"run_{int(rpm)}.json", config, rpm, injected, model=model,
                                       torque_out_Nm=torque_out_Nm, seed=int(rpm) + 7, **kw) for rpm in speeds]
        return cache[key]

    return make


@pytest.fixture(scope="session")
def rom_diagnosed(rom_dataset, rom_sims):
    """``rom_diagnosed(key, injected, ...)`` -> (DiagnosisResult, infos): the diagnosis (nominal model of the
    config, not told about the effects) of a ROM data set (cached)."""
    cache = {}

    def run(key, injected, config=ROM_CONFIG, settings: FitSettings | None = None, **kw):
        if key not in cache:
            runs = rom_dataset(key, injected, config=config, **kw)
            res = diagnose(config, [p for p, _ in runs], simulator=rom_sims(config), settings=settings or SELF_MADE)
            cache[key] = (res, [i for _, i in runs])
        return cache[key]

    return run
