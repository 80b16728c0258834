"""Which stored explicit FE record belongs to which pair (gearrom.validation.records).

Reference: the configs themselves. A pair with the drawing micro-geometry switched on is another pair
than the perfect one (its static TE differs by micrometres), so its records carry their own name and the
key of the pair they were run on, and a record of another pair is refused rather than compared.
"""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from gearrom.errors import ConfigError, MeasurementError
from gearrom.validation.records import pair_key, record_prefix
from gearrom.validation.report import validate


def _cfg(name):
    from gearrom.config import load_config

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_config(name)


def test_record_names_follow_the_pair():
    for name, prefix in (("thesis-spur", "spur"), ("thesis-helical", "helical"), ("thesis-rig", "helical"),
                         ("thesis-helical-drawing", "helical-thesis-helical-drawing")):
        c = _cfg(name)
        assert record_prefix(c.pair, c.name) == prefix
    assert pair_key(_cfg("thesis-rig").pair) == pair_key(_cfg("thesis-helical").pair)
    assert pair_key(_cfg("thesis-helical-drawing").pair) != pair_key(_cfg("thesis-helical").pair)


def _write_record(stem, key):
    t = np.linspace(0, 1e-3, 65)
    np.savez(stem.with_suffix(".npz"), t_s=t, te_m=np.zeros_like(t), theta_rad=np.zeros((t.size, 2)))
    stem.with_suffix(".json").write_text(json.dumps({"t_steady_from_s": 0.0, "torque_out_Nm": 120.0,
                                                     "start": "loaded", "config": "thesis-helical",
                                                     "pair_key": key}))


def test_a_record_of_another_pair_is_refused(tmp_path):
    _write_record(tmp_path / "helical-thesis-helical-drawing_2000rpm_loaded", pair_key(_cfg("thesis-helical").pair))
    with pytest.raises(ConfigError, match="another pair"):
        validate("thesis-helical-drawing", [2000.0], fe_dir=tmp_path, fe_integration="loaded")


def test_a_missing_record_names_the_command(tmp_path):
    with pytest.raises(MeasurementError, match="run_explicit_helical.py 2000 .*--config thesis-helical-drawing"):
        validate("thesis-helical-drawing", [2000.0], fe_dir=tmp_path, fe_integration="loaded")
    # without a kind given, a pair of its own names its loaded-start reference (the only kind made for it)
    with pytest.raises(MeasurementError, match=r"helical-thesis-helical-drawing_2000rpm_loaded\.npz is missing .*"
                                               r"run_explicit_helical.py 2000 --start loaded"):
        validate("thesis-helical-drawing", [2000.0], fe_dir=tmp_path)
