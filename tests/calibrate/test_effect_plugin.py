"""A new diagnosis effect is one module and one registry line: a toy effect defined here, end to end.

The toy is ``encoder_ovality``: an oval encoder disc, a twice-per-revolution angle error of one encoder
(measurement only). Everything it needs is in this file: its spec, its candidate fit (order 2 of the
shaft in the TE and the encoder's own channel), its config mapping, and the shaft-order plugin hooks
(evidence, the residual line it explains); ``register`` adds it to the library. The data: the torsional rig model simulated clean, the input encoder's angle
given a twice-per-rev error of known size and phase before the encoder emulation (as
:func:`gearrom.testing.synthetic.make_run` does for once-per-rev encoder errors). The reference is
the injected error itself.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearrom.calibrate import (LIBRARY, PLUGINS, EffectSpec, FitSettings, RunConditions, TorsionalRig,
                               diagnose, register, unregister)
from gearrom.calibrate.evidence import ShaftOrderPlugin
from gearrom.calibrate.fit import ShaftOrder
from gearrom.calibrate.registry import ENCODERS
from gearrom.calibrate.writeconfig import diagnosed_config
from gearrom.signal import emulate_edges, write_measurement

CONFIG = "thesis-helical"
AMP_UM, PHASE_DEG = 3.0, 40.0  # injected twice-per-rev error of the input encoder (TE equivalent)


# ---------------------------------------------------------------- the toy effect module
SPEC = EffectSpec("encoder_ovality", ENCODERS, "measurement", {e: 5.0 for e in ENCODERS}, {e: 50.0 for e in ENCODERS},
                  "twice per revolution of one channel only, independent of speed and load",
                  size_key="amplitude_um")


class Ovality(ShaftOrder):
    order = 2
    measurement_only = True


class OvalityPlugin(ShaftOrderPlugin):
    spec = SPEC
    candidate = Ovality

    def write_config(self, draft, target, params):
        draft.notes.append(f"{target}: ovality {params['amplitude_um']:.3g} um is a measurement error; not written")


# ---------------------------------------------------------------- data and diagnoses
@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    rig = TorsionalRig.from_config(CONFIG)
    rb1 = rig.pair.rb[0]
    out = []
    for rpm in (1250.0, 2500.0):
        dur = 2.0 / (rpm / 60 * rig.pair.z[0] / rig.pair.z[1]) + 4e-3
        h = rig.simulate(RunConditions(rpm, 120.0, dur))
        th1 = h.theta_in_rad + AMP_UM * 1e-6 / rb1 * np.cos(2 * h.theta_in_rad + math.radians(PHASE_DEG))
        rec = emulate_edges(h.t_s, th1, h.theta_out_rad, edges_per_rev=40000, clock_hz=80e6, jitter_s=2e-9,
                            line_error_rad=2e-7, rng=int(rpm))
        path = tmp_path_factory.mktemp("ovality") / f"run_{int(rpm)}.json"
        out.append(write_measurement(path, rec, rpm_in=rpm, torque_out_Nm=120.0, config=CONFIG))
    return rig, out


SETTINGS = FitSettings(model_floor_um=0.0, candidates=("eccentricity", "encoder_eccentricity", "pitch_error"))


@pytest.fixture(scope="module")
def with_toy(runs):
    rig, paths = runs
    register(OvalityPlugin())
    try:
        settings = FitSettings(model_floor_um=0.0, candidates=(*SETTINGS.candidates, "encoder_ovality"))
        yield diagnose(CONFIG, paths, simulator=rig, settings=settings)
    finally:
        unregister("encoder_ovality")


def test_registry_adds_and_removes_the_toy():
    assert "encoder_ovality" not in PLUGINS
    register(OvalityPlugin())
    try:
        assert LIBRARY["encoder_ovality"] is SPEC
    finally:
        unregister("encoder_ovality")
    assert "encoder_ovality" not in LIBRARY


def test_registered_toy_effect_is_found_sized_and_removed(with_toy):
    s = with_toy.summary
    first = s["effects"][0]
    assert (first["effect"], first["target"]) == ("encoder_ovality", "input_encoder")
    assert first["parameters"]["amplitude_um"] == pytest.approx(AMP_UM, rel=0.1)
    assert first["within_tolerance"] and first["drawing_tolerance_um"] == 5.0
    assert "order 2 of the input shaft, in one channel only" in first["evidence"]
    assert s["error_after_rms_um"] <= 0.5 * s["error_before_rms_um"]
    assert not any(u.get("integer_order") == "input order 2" and "at_lines_of" not in u for u in s["unexplained"])
    doc, notes = diagnosed_config(s, CONFIG)
    assert any("ovality" in n for n in notes)


def test_without_the_toy_the_line_stays_unexplained(runs):
    rig, paths = runs
    s = diagnose(CONFIG, paths, simulator=rig, settings=SETTINGS).summary
    assert not any(e["effect"] == "encoder_ovality" for e in s["effects"])
    assert any("input order 2" in (u.get("integer_order") or "") for u in s["unexplained"])
