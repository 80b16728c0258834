"""Fixtures of the diagnosis tests: synthetic measurements with undeclared effects, generated at test time.

Each data set is simulated by the torsional rig model with effects injected from their physical
definitions (:mod:`gearrom.calibrate.synthetic`), emulated as encoder edges (40000 edges/rev,
80 MHz counter, 2 ns jitter, 0.2 urad line errors) and written as ``gearrom.measurement/1`` files.
Data sets and diagnoses are cached per session, so several tests can look at one diagnosis.
"""
from __future__ import annotations

import pytest

from gearrom.calibrate import FitSettings, Injected, TorsionalRig, diagnose, make_run


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


@pytest.fixture(scope="session")
def diagnosed(dataset, rigs):
    """``diagnosed(key, injected, ...)``: the diagnosis of a data set (cached)."""
    cache = {}

    def run(key, injected=None, config="thesis-helical", settings: FitSettings | None = None, **kw):
        if key not in cache:
            paths = dataset(key, injected, config=config, **kw)
            cache[key] = diagnose(config, paths, simulator=rigs[config], settings=settings)
        return cache[key]

    return run
